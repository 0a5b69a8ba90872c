"""Labelled images of the simulated desk, for training and scoring the desk detector.

Each dataset *seed* is one random scene, rendered as two images, from one of two kinds of camera:

* the stereo rig (``render_scene``): both views of a desk with balls, upside-down cups, yellow
  banana-like plushes, discs and cylinders in many hues, a lift panel of 9 buttons, a door handle,
  ArUco cards, sometimes the arm or a hovering hand in the way;
* the assistive arm's hand camera (``render_hand_scene``): a lift panel somewhere within the arm's
  reach, sometimes the door handle, a few other objects or a hand beside it, seen from two poses
  the arm takes (``hand_camera_pose``): the ready view of the whole panel and views along the
  approach to a button (or the handle), 8–32 cm away, the camera's axis tilted ~30° back towards
  the base as the arm holds it — close, steep views the rig never has.

Both under random camera settings (exposure, gain, brightness, contrast) on one of a few desks
(desk texture, blur, noise and a slightly bumped rig). The labels are ``SimDesk.image_boxes`` (the
rig) or ``SimDesk.render_camera(boxes=True)`` (the hand camera): tight boxes of what is visible of
each object, so they are exact by construction. Training mixes the two (``view="both"``: a share
``HAND_SHARE`` of the seeds are hand-camera scenes, ``is_hand_scene``); scoring takes either alone.

Seeds below ``TEST_SEED_BASE`` are for training; seeds from it on are held out (their scenes,
and three of their four desks, are never used in training). Everything is deterministic given
the seed.

``render_samples(seeds, view=...)`` yields full-size ``Sample``s (what the app's cameras would see);
``training_arrays`` letterboxes them to a network input and caches them as .npz chunks;
``score_detector`` runs any detector over held-out samples and returns per-class AP and mAP@0.5.
"""
from __future__ import annotations

import functools
import math
import time
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterable, Iterator, Optional, Sequence

import numpy as np

from core.detect.learned.evaluation import DetectionScores, ScoredBox, TruthBox, evaluate_detections
from core.settings import CameraSettings
from core.sim.desk import SIDES, SimDesk
from core.sim.rig import SimRig, SimRigConfig
from core.sim.scenarios import (
    THING_ID_BASE,
    Card,
    DoorHandle,
    Hand,
    Panel,
    Scenario,
    SceneState,
    Thing,
)

__all__ = ["CLASSES", "TEST_SEED_BASE", "DATASET_VERSION", "HAND_SHARE", "VIEWS", "LabelledBox", "Sample",
           "random_scene", "random_hand_scene", "is_hand_scene", "hand_camera_pose", "desk_for", "render_scene",
           "render_hand_scene", "render_views", "render_samples", "training_arrays", "score_detector",
           "training_seeds", "held_out_seeds", "renderer_fingerprint"]

CLASSES = ("ball", "cup", "plush", "button", "disc", "handle")  # class index = position
TEST_SEED_BASE = 1_000_000  # seeds ≥ this are the held-out test scenes
DATASET_VERSION = 2  # bump when a change alters the renders or labels (invalidates caches); 2: hand-camera views
DIFFICULT_VISIBLE_FRACTION = 0.5  # a box showing less of its object than this is "difficult"
DIFFICULT_MIN_PX = 24  # ... and so is one with fewer visible pixels than this
CHUNK_SCENES = 250  # training_arrays caches this many scenes per .npz file
MARKER_IDS = (23, 50, 7, 99)  # the desk's ArUco cards (distractors, never labelled)

# desks: (desk seed, blur σ px, noise σ, rig mount offset dx dy dz m, roll pitch yaw rad)
_TRAIN_DESKS = 12
_TEST_DESKS = (0, 1000, 1001, 1002)  # the app's default desk, and three that training never sees
_DEFAULT_DESK = 0

VIEWS = ("stereo", "hand", "both")  # which camera renders a seed: the rig, the hand camera, or the training mix
# a third of the training images from the hand camera: enough that the close, steep views of the panel
# are learnt (the stereo-only model found no button there), while the rig's views keep ~2/3 of the images
HAND_SHARE = 0.35
HAND_AXIS_TILT_RAD = math.radians(30.0)  # the assistive arm holds its camera axis tilted so (app.cli_assist)
HAND_DEPTH_M = (0.08, 0.32)  # target depths of the approach views (the ready view is ~0.25 m, ACT starts at 0.15)


class _FixedScene(Scenario):
    """A scenario that is one SceneState at every t (the generator's own scene)."""

    name = "dataset"

    def __init__(self, marker_ids: Sequence[int], state: SceneState):
        super().__init__(marker_ids, 0)
        self._state = state

    def state(self, t: float) -> SceneState:
        return self._state


@dataclass(frozen=True)
class LabelledBox:
    """One object in one image: class, box (x0, y0, x1, y1 px: pixel edges, slice style), whether
    it is difficult (mostly hidden or cut off), and the simulator's truth about it."""

    label: str  # one of CLASSES
    box: tuple[float, float, float, float]
    difficult: bool
    truth_id: int
    visible_fraction: float
    name: str  # the simulator's label, e.g. "red ball", "button 5"

    @property
    def class_index(self) -> int:
        return CLASSES.index(self.label)


@dataclass(frozen=True)
class Sample:
    """A rendered image (BGR uint8, full camera size) and its labelled boxes."""

    seed: int
    side: str  # "left" or "right" (the stereo rig), "hand" (the assistive arm's hand camera)
    image: np.ndarray
    boxes: tuple[LabelledBox, ...]


def training_seeds(count: int, first: int = 0) -> range:
    """``count`` training scene seeds from ``first``; ValueError if they reach the held-out range."""
    if first < 0 or first + count > TEST_SEED_BASE:
        raise ValueError(f"training seeds {first}…{first + count - 1} must stay below {TEST_SEED_BASE} "
                         f"(the held-out scenes start there)")
    return range(first, first + count)


def held_out_seeds(count: int, first: int = TEST_SEED_BASE) -> range:
    """``count`` held-out scene seeds from ``first`` (≥ TEST_SEED_BASE)."""
    if first < TEST_SEED_BASE:
        raise ValueError(f"held-out seeds start at {TEST_SEED_BASE}, not {first} (lower seeds are training scenes)")
    return range(first, first + count)


# ------------------------------------------------------------------------------------ random scenes
def _rng(seed: int, salt: int) -> np.random.Generator:
    return np.random.default_rng([int(seed) & 0x7FFFFFFFFFFF, salt, 20261124])


def _hsv_colour(rng: np.random.Generator, hue=None, sat=(0.45, 1.0), val=(0.45, 1.0)) -> tuple[int, int, int]:
    """A BGR colour from a random (or given, 0…1) hue, saturation and value."""
    h = rng.random() if hue is None else hue
    s, v = rng.uniform(*sat), rng.uniform(*val)
    i = int(h * 6) % 6
    f = h * 6 - math.floor(h * 6)
    p, q, t = v * (1 - s), v * (1 - f * s), v * (1 - (1 - f) * s)
    r, g, b = ((v, t, p), (q, v, p), (p, v, t), (p, q, v), (t, p, v), (v, p, q))[i]
    return (int(b * 255), int(g * 255), int(r * 255))


def _object_colour(rng: np.random.Generator) -> tuple[int, int, int]:
    """Mostly saturated hues, sometimes white, grey or near black (cups come in those too)."""
    u = rng.random()
    if u < 0.12:
        level = int(rng.uniform(190, 240))
        return (level, level + int(rng.integers(-6, 7)), level + int(rng.integers(-6, 7)))
    if u < 0.18:
        level = int(rng.uniform(40, 140))
        return (level, level, level)
    return _hsv_colour(rng)


def _half_width_m(y: float) -> float:
    """Roughly half the width of the desk the default rig sees at depth y (robot_base)."""
    return 0.29 + 0.43 * (0.37 - y)


class _Placer:
    """Picks footprints (centre, radius) on the visible desk that overlap earlier ones little."""

    def __init__(self, rng: np.random.Generator):
        self.rng = rng
        self.taken: list[tuple[float, float, float]] = []

    def place(self, radius: float, y_range=(-0.10, 0.36), overlap: float = 0.15) -> Optional[tuple[float, float]]:
        for _ in range(30):
            y = float(self.rng.uniform(*y_range))
            # most objects where the arm works (y 0…0.32), the rest further away
            if self.rng.random() < 0.7:
                y = float(self.rng.uniform(max(y_range[0], -0.02), y_range[1]))
            half = _half_width_m(y) * 1.04
            x = float(self.rng.uniform(-half, half))
            if all(math.hypot(x - tx, y - ty) > (1 - overlap) * (radius + tr) for tx, ty, tr in self.taken):
                self.taken.append((x, y, radius))
                return x, y
        return None


def _settings_and_desk(rng: np.random.Generator, seed: int) -> tuple[CameraSettings, int]:
    """Random camera settings and a desk index: a training desk, or for held-out seeds a test desk."""
    settings = CameraSettings(exposure=float(np.clip(rng.normal(0.0, 0.3), -0.8, 0.8)),
                              gain=float(rng.choice((0.0, rng.uniform(0.0, 12.0)))),
                              brightness=float(rng.uniform(-15, 15)), contrast=float(rng.uniform(0.8, 1.2)))
    if seed >= TEST_SEED_BASE:
        desk = _TEST_DESKS[int(rng.integers(len(_TEST_DESKS)))]
    else:
        desk = int(rng.integers(_TRAIN_DESKS))
    return settings, desk


def random_scene(seed: int) -> tuple[SceneState, CameraSettings, Optional[np.ndarray], int]:
    """Scene ``seed``: (state, camera settings, arm chain points or None, desk index for ``desk_for``)."""
    rng = _rng(seed, 1)
    placer = _Placer(rng)
    things: list[Thing] = []
    index = 0

    def add(kind: str, name: str, radius_m: float, height_m: float, colour, footprint: float, yaw: float = 0.0):
        nonlocal index
        spot = placer.place(footprint)
        if spot is None:
            return
        things.append(Thing(kind=kind, label=f"{name} {kind}", truth_id=THING_ID_BASE - index, x=spot[0], y=spot[1],
                            radius_m=radius_m, height_m=height_m, colour=colour, yaw=yaw))
        index += 1

    panels: tuple[Panel, ...] = ()
    handles: tuple[DoorHandle, ...] = ()
    if rng.random() < 0.55:  # a lift panel first: it needs the most room
        spot = placer.place(0.10, y_range=(0.0, 0.30), overlap=0.0)
        if spot is not None:
            lit = tuple(int(n) for n in rng.choice(9, size=int(rng.integers(0, 3)), replace=False) + 1)
            pressed = tuple(int(n) for n in rng.choice(9, size=int(rng.integers(0, 2)), replace=False) + 1)
            panels = (Panel(spot[0], spot[1], yaw=float(rng.uniform(-math.pi, math.pi)), lit=lit, pressed=pressed),)
    if rng.random() < 0.45:
        length = float(rng.uniform(0.10, 0.14))
        spot = placer.place(0.5 * length + 0.02)
        if spot is not None:
            yaw = float(rng.uniform(-math.pi, math.pi))
            # the footprint was reserved around the lever's middle: put the pivot half a lever back
            px, py = spot[0] - 0.5 * length * math.cos(yaw), spot[1] - 0.5 * length * math.sin(yaw)
            handles = (DoorHandle(px, py, yaw=yaw, length_m=length),)
    for _ in range(int(rng.integers(0, 5))):
        r = float(rng.uniform(0.014, 0.032))
        add("ball", "random", r, 2 * r, _object_colour(rng), r)
    for _ in range(int(rng.integers(0, 4))):
        rim = float(rng.uniform(0.034, 0.046))
        add("cup", "random", rim, float(rng.uniform(0.065, 0.10)), _object_colour(rng), rim)
    for _ in range(int(rng.choice(3, p=(0.35, 0.45, 0.2)))):  # yellow, banana-like
        half = float(rng.uniform(0.05, 0.08))
        colour = _hsv_colour(rng, hue=float(rng.uniform(0.12, 0.17)), sat=(0.65, 0.95), val=(0.8, 0.98))
        add("plush", "yellow", half, float(rng.uniform(0.03, 0.048)), colour, half,
            yaw=float(rng.uniform(-math.pi, math.pi)))
    for _ in range(int(rng.integers(0, 4))):
        # flat discs, or cylinders clearly slimmer and lower than a cup
        if rng.random() < 0.6:
            r, height = float(rng.uniform(0.015, 0.034)), float(rng.uniform(0.004, 0.014))
        else:
            r, height = float(rng.uniform(0.014, 0.025)), float(rng.uniform(0.02, 0.05))
        add("disc", "random", r, height, _object_colour(rng), r)
    cards = []
    for marker_id in MARKER_IDS[:int(rng.integers(0, 4))]:
        spot = placer.place(0.03, overlap=0.3)
        if spot is not None:
            cards.append(Card(marker_id, spot[0], spot[1], yaw=float(rng.uniform(-math.pi, math.pi))))
    hands = ()
    if rng.random() < 0.25:
        y = float(rng.uniform(-0.05, 0.32))
        hands = (Hand(float(rng.uniform(-0.8, 0.8) * _half_width_m(y)), y, float(rng.uniform(0.07, 0.2)),
                      yaw=float(rng.uniform(-math.pi, math.pi))),)
    arm = None
    if rng.random() < 0.3:  # the arm, reaching somewhere (an occluder and a distractor)
        yaw = float(rng.uniform(-1.3, 1.3)) + math.pi / 2
        shoulder = np.array([0.0, 0.0, 0.07])
        up = float(rng.uniform(0.2, 1.3))
        elbow = shoulder + 0.10 * np.array([math.cos(yaw) * math.cos(up), math.sin(yaw) * math.cos(up), math.sin(up)])
        down = float(rng.uniform(-1.0, 0.3))
        tool = elbow + 0.12 * np.array([math.cos(yaw) * math.cos(down), math.sin(yaw) * math.cos(down),
                                        math.sin(down)])
        tool[2] = max(tool[2], 0.02)
        arm = np.array([[0.0, 0.0, 0.0], shoulder, elbow, tool])
    settings, desk = _settings_and_desk(rng, seed)
    state = SceneState(cards=tuple(cards), hands=hands, things=tuple(things), panels=panels, handles=handles)
    return state, settings, arm, desk


@functools.lru_cache(maxsize=24)
def desk_for(index: int) -> SimDesk:
    """Desk ``index``: 0 is the app's default (default rig, desk seed 0); others a desk texture,
    blur, noise and a rig bumped by ≤ 2 cm / 2° of their own."""
    if index == _DEFAULT_DESK:
        return SimDesk(SimRig(), scenario="static", marker_ids=MARKER_IDS, seed=0)
    rng = _rng(index, 2)
    offset = tuple(float(v) for v in np.concatenate([rng.uniform(-0.02, 0.02, 3), np.radians(rng.uniform(-2, 2, 3))]))
    rig = SimRig(SimRigConfig(mount_offset=offset))
    return SimDesk(rig, scenario="static", marker_ids=MARKER_IDS, seed=int(index),
                   blur_sigma_px=float(rng.uniform(0.4, 1.0)), noise_sigma=float(rng.uniform(1.2, 3.5)))


def _labelled(boxes: dict, classes: Sequence[str]) -> tuple[LabelledBox, ...]:
    out = []
    for truth_id, b in sorted(boxes.items(), key=lambda kv: -kv[0]):
        if b.kind not in classes:
            continue
        hard = b.visible_fraction < DIFFICULT_VISIBLE_FRACTION or b.visible_px < DIFFICULT_MIN_PX
        out.append(LabelledBox(label=b.kind, box=(float(b.x0), float(b.y0), float(b.x1), float(b.y1)), difficult=hard,
                               truth_id=int(truth_id), visible_fraction=float(b.visible_fraction), name=b.label))
    return tuple(out)


def render_scene(seed: int, classes: Sequence[str] = CLASSES) -> tuple[Sample, Sample]:
    """Scene ``seed`` seen by the left and the right camera."""
    state, settings, arm, desk_index = random_scene(seed)
    desk = desk_for(desk_index)
    desk.set_scenario(_FixedScene(desk.marker_ids, state))
    desk.set_camera_settings(settings)
    t = float(seed % 100_000)  # only the sensor noise depends on t here
    left, right, _ = desk.render(t, arm)
    boxes = desk.image_boxes(t, arm)
    images = {"left": left, "right": right}
    return tuple(Sample(seed=seed, side=side, image=images[side], boxes=_labelled(boxes[side], classes))
                 for side in SIDES)


# ------------------------------------------------------------------------------------ hand-camera scenes
def is_hand_scene(seed: int) -> bool:
    """Whether training seed ``seed`` is a hand-camera scene in the training mix (``view="both"``):
    a share HAND_SHARE of the seeds, chosen by the seed alone."""
    return bool(_rng(seed, 3).random() < HAND_SHARE)


@functools.lru_cache(maxsize=1)
def _hand_camera() -> tuple[np.ndarray, tuple[int, int], np.ndarray]:
    """(K, (w, h), the tool tip in the camera frame (m)) of the assistive arm's hand camera: the
    default ``HandCameraConfig`` and the ``assistive_5dof`` profile's camera-to-tool offset."""
    from core.kinematics.clik import ClikKinematics
    from core.kinematics.profile import load_profile
    from core.sim.hand_camera import HandCameraConfig

    config = HandCameraConfig()
    kin = ClikKinematics(load_profile("assistive_5dof"))
    q0 = kin.q_home
    camera_p_tool = (np.linalg.inv(kin.camera_pose(q0)) @ kin.fk_pose(q0))[:3, 3]
    return config.K, config.size, camera_p_tool


def _turn(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix of ``angle`` rad about the unit vector ``axis`` (Rodrigues)."""
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * Kx + (1 - math.cos(angle)) * Kx @ Kx


def hand_camera_pose(point_base, depth_m: float, pixel, K: np.ndarray, tilt_rad: float = HAND_AXIS_TILT_RAD,
                     roll_rad: float = 0.0, axis_jitter_rad: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
    """base_T_camera (4x4, OpenCV optical frame) of a hand camera that sees ``point_base`` (robot_base,
    m) at ``pixel`` (u, v) and depth ``depth_m``, held as the assistive arm holds it: the optical axis
    tilted ``tilt_rad`` from straight down towards the base in the arm's vertical plane, the image's
    x axis horizontal (``IbvsController`` in translate mode; a 5-DOF arm's hand cannot spin freely),
    then turned by ``roll_rad`` about the axis and tipped by ``axis_jitter_rad`` (about the camera's
    x and y: a hand that is not quite where the servo wants it, or shakes)."""
    P = np.asarray(point_base, dtype=float).reshape(3)
    camera_p = depth_m * (np.linalg.inv(K) @ np.array([pixel[0], pixel[1], 1.0]))
    outward = P[:2] / max(float(np.linalg.norm(P[:2])), 1e-6)  # the arm's vertical plane, first guess
    for _ in range(4):  # the plane goes through the camera, which moves with it: a few fixed-point steps
        axis = math.cos(tilt_rad) * np.array([0.0, 0.0, -1.0]) - math.sin(tilt_rad) * np.array([*outward, 0.0])
        x = np.cross([0.0, 0.0, 1.0], axis)
        x /= np.linalg.norm(x)
        R = np.column_stack([x, np.cross(axis, x), axis]) @ _turn(np.array([0.0, 0.0, 1.0]), roll_rad)
        R = R @ _turn(np.array([1.0, 0.0, 0.0]), axis_jitter_rad[0]) @ _turn(np.array([0.0, 1.0, 0.0]),
                                                                             axis_jitter_rad[1])
        centre = P - R @ camera_p
        if np.linalg.norm(centre[:2]) > 1e-6:
            outward = centre[:2] / np.linalg.norm(centre[:2])
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, centre
    return T


def random_hand_scene(seed: int) -> tuple[SceneState, CameraSettings, int, tuple[np.ndarray, np.ndarray]]:
    """Hand-camera scene ``seed``: (state, camera settings, desk index, two base_T_camera poses).

    A lift panel (half the time near the ``panel`` scene's place and turn, else anywhere the arm
    reaches, any yaw; random lit and pressed buttons), the door handle beside it (55 %), 0–3 balls,
    cups, plushes or discs around it, a hovering hand (10 %). Each pose is either the ready view
    (the panel's middle near the image centre, 19–32 cm away) or a view along an approach (a random
    button, or the handle, 8–32 cm away, where the servo puts it — on the tool's axis — or anywhere
    in the image while it aligns), tilt 30° ± 4°, a little roll and jitter."""
    from core.sim.scenarios import PanelScenario

    rng = _rng(seed, 4)
    if rng.random() < 0.5:
        x, y = (np.array(PanelScenario.PANEL_XY) + rng.uniform(-0.04, 0.04, 2)).tolist()
        yaw = PanelScenario.PANEL_YAW + float(rng.uniform(-0.35, 0.35))
    else:
        x, y, yaw = float(rng.uniform(-0.16, 0.16)), float(rng.uniform(0.06, 0.24)), float(rng.uniform(-math.pi, math.pi))
    lit = tuple(int(n) for n in rng.choice(9, size=int(rng.integers(0, 3)), replace=False) + 1)
    pressed = tuple(int(n) for n in rng.choice(9, size=int(rng.integers(0, 2)), replace=False) + 1)
    panel = Panel(float(x), float(y), yaw=float(yaw), lit=lit, pressed=pressed)
    taken = [(panel.x, panel.y, 0.10)]  # footprints (x, y, radius) already used

    def free_spot(radius: float, near: float, far: float) -> Optional[tuple[float, float]]:
        for _ in range(20):
            a, r = float(rng.uniform(-math.pi, math.pi)), float(rng.uniform(near, far))
            px, py = panel.x + r * math.cos(a), panel.y + r * math.sin(a)
            if all(math.hypot(px - tx, py - ty) > radius + tr for tx, ty, tr in taken):
                taken.append((px, py, radius))
                return px, py
        return None

    handles: tuple[DoorHandle, ...] = ()
    if rng.random() < 0.55:
        length = float(rng.uniform(0.10, 0.14))
        spot = free_spot(0.5 * length + 0.015, 0.13, 0.20)
        if spot is not None:
            hyaw = float(rng.uniform(-math.pi, math.pi))
            px, py = spot[0] - 0.5 * length * math.cos(hyaw), spot[1] - 0.5 * length * math.sin(hyaw)
            handles = (DoorHandle(px, py, yaw=hyaw, length_m=length),)
    things: list[Thing] = []
    for index in range(int(rng.choice(4, p=(0.45, 0.25, 0.2, 0.1)))):
        kind = str(rng.choice(("ball", "cup", "plush", "disc")))
        if kind == "ball":
            r = float(rng.uniform(0.014, 0.032))
            size, height, colour, tyaw = r, 2 * r, _object_colour(rng), 0.0
        elif kind == "cup":
            size = float(rng.uniform(0.034, 0.046))
            height, colour, tyaw = float(rng.uniform(0.065, 0.10)), _object_colour(rng), 0.0
        elif kind == "plush":
            size, height = float(rng.uniform(0.05, 0.08)), float(rng.uniform(0.03, 0.048))
            colour = _hsv_colour(rng, hue=float(rng.uniform(0.12, 0.17)), sat=(0.65, 0.95), val=(0.8, 0.98))
            tyaw = float(rng.uniform(-math.pi, math.pi))
        else:
            size, height = float(rng.uniform(0.015, 0.034)), float(rng.uniform(0.004, 0.03))
            colour, tyaw = _object_colour(rng), 0.0
        spot = free_spot(size, 0.11, 0.24)
        if spot is not None:
            things.append(Thing(kind=kind, label=f"random {kind}", truth_id=THING_ID_BASE - index, x=spot[0],
                                y=spot[1], radius_m=size, height_m=height, colour=colour, yaw=tyaw))
    hands = ()
    if rng.random() < 0.10:  # a user's hand beside the panel, low (the camera comes down to ~9 cm)
        spot = free_spot(0.06, 0.10, 0.22)
        if spot is not None:
            hands = (Hand(spot[0], spot[1], float(rng.uniform(0.04, 0.07)), yaw=float(rng.uniform(-math.pi, math.pi))),)
    K, (w, h), camera_p_tool = _hand_camera()
    corners = np.array([panel.to_base(su * panel.width_m / 2, sv * panel.length_m / 2, z)
                        for su in (-1, 1) for sv in (-1, 1) for z in (0.0, panel.top_z)])

    def sees_the_whole_panel_from_in_front(T: np.ndarray) -> bool:
        # no near-plane clipping in the renderer: a plate corner behind the camera would paint it all over
        camera_z = (np.linalg.inv(T) @ np.column_stack([corners, np.ones(len(corners))]).T)[2]
        return bool(camera_z.min() > 0.03)

    poses = []
    while len(poses) < 2:
        if rng.random() < 0.35:  # the ready view: the whole panel, its middle near the image centre
            target = np.array(panel.to_base(*rng.uniform(-0.02, 0.02, 2), panel.top_z))
            depth = float(rng.uniform(0.19, HAND_DEPTH_M[1]))
            pixel = (0.5 * (w - 1) + rng.normal(0, 30), 0.5 * (h - 1) + rng.normal(0, 30))
        else:  # on the way to a button (or the handle)
            if handles and rng.random() < 0.15:
                target = np.array(handles[0].centre)
            else:
                target = np.array(panel.button_centre(int(rng.integers(1, 10))))
            depth = float(rng.uniform(*HAND_DEPTH_M))
            if rng.random() < 0.5:  # where the servo brings it: the tool's axis at that depth
                s = (depth - camera_p_tool[2])
                on_axis = K @ (camera_p_tool + np.array([0.0, 0.0, s]))
                pixel = (on_axis[0] / on_axis[2] + rng.normal(0, 15),
                         min(on_axis[1] / on_axis[2], h - 40.0) + rng.normal(0, 15))
            else:  # still aligning: anywhere in the image
                pixel = (rng.uniform(50, w - 50), rng.uniform(50, h - 50))
        tilt = float(np.clip(rng.normal(HAND_AXIS_TILT_RAD, math.radians(4)), math.radians(18), math.radians(42)))
        pose = hand_camera_pose(target, depth, pixel, K, tilt, float(rng.normal(0, math.radians(4))),
                                tuple(rng.normal(0, math.radians(1.0), 2)))
        if sees_the_whole_panel_from_in_front(pose):  # else draw another (the arm would not be there either)
            poses.append(pose)
    settings, desk = _settings_and_desk(rng, seed)

    def in_front(points, margin: float) -> bool:
        # the renderer does not clip at a near plane (the rig never sees anything behind it): an object
        # behind or at a hand camera would be painted over the whole image, so it is left out
        pts = np.column_stack([np.atleast_2d(points), np.ones(len(np.atleast_2d(points)))])
        return all(float((np.linalg.inv(T) @ pts.T)[2].min()) > margin for T in poses)

    things = [th for th in things if in_front([th.x, th.y, th.height_m], 0.06 + th.radius_m)]
    hands = tuple(hd for hd in hands if in_front([hd.x, hd.y, hd.z], 0.15))
    handles = tuple(hd for hd in handles if in_front([hd.along(0.0), hd.along(hd.length_m)], 0.05))
    state = SceneState(hands=hands, things=tuple(things), panels=(panel,), handles=handles)
    return state, settings, desk, (poses[0], poses[1])


def render_hand_scene(seed: int, classes: Sequence[str] = CLASSES) -> tuple[Sample, Sample]:
    """Hand-camera scene ``seed`` seen from its two poses (side "hand")."""
    state, settings, desk_index, poses = random_hand_scene(seed)
    desk = desk_for(desk_index)
    desk.set_scenario(_FixedScene(desk.marker_ids, state))
    desk.set_camera_settings(settings)
    K, size, _ = _hand_camera()
    t = float(seed % 100_000)
    out = []
    for i, pose in enumerate(poses):
        # the hand camera's own supersampling cap (HandCameraConfig.max_supersample): what the app renders
        image, boxes = desk.render_camera(pose, K, size, t, boxes=True, noise_index=2 + i, max_supersample=2)
        out.append(Sample(seed=seed, side="hand", image=image, boxes=_labelled(boxes, classes)))
    return out[0], out[1]


def _check_view(view: str) -> str:
    if view not in VIEWS:
        raise ValueError(f"view {view!r}: use one of {', '.join(VIEWS)} (the stereo rig, the hand camera, or "
                         f"the training mix of both)")
    return view


def render_views(seed: int, classes: Sequence[str] = CLASSES, view: str = "stereo") -> tuple[Sample, Sample]:
    """The two images of seed ``seed`` for ``view``: "stereo" (``render_scene``), "hand"
    (``render_hand_scene``) or "both" (the training mix: hand when ``is_hand_scene(seed)``)."""
    _check_view(view)
    if view == "hand" or (view == "both" and is_hand_scene(seed)):
        return render_hand_scene(seed, classes)
    return render_scene(seed, classes)


def render_samples(seeds: Iterable[int], classes: Sequence[str] = CLASSES, view: str = "stereo") -> Iterator[Sample]:
    """The two images of each scene seed, in order (left, right, … or hand, hand, …; see render_views)."""
    for seed in seeds:
        yield from render_views(int(seed), classes, view)


# ------------------------------------------------------------------------------------ training arrays
def _letterbox_sample(sample: Sample, input_wh: tuple[int, int], classes: Sequence[str]):
    from core.detect.onnx_yolo import letterbox

    boxed, scale, (left, top) = letterbox(sample.image, input_wh)
    boxes = np.array([[b.box[0] * scale + left, b.box[1] * scale + top, b.box[2] * scale + left,
                       b.box[3] * scale + top] for b in sample.boxes], np.float32).reshape(-1, 4)
    labels = np.array([classes.index(b.label) for b in sample.boxes], np.int64)
    difficult = np.array([b.difficult for b in sample.boxes], bool)
    return boxed, boxes, labels, difficult


@functools.lru_cache(maxsize=1)
def renderer_fingerprint() -> str:
    """8 hex digits of a CRC of the simulator's and this generator's source: cached renders are
    keyed by it, so a change to how the desk is drawn never trains on stale images."""
    import sys

    from core.sim import desk, hand_camera, rig, scenarios

    crc = 0
    for module in (desk, rig, scenarios, hand_camera, sys.modules[__name__]):
        crc = zlib.crc32(Path(module.__file__).read_bytes(), crc)
    return f"{crc:08x}"


def _chunk_path(cache_dir: Path, start: int, count: int, input_wh: tuple[int, int], classes: Sequence[str],
                view: str) -> Path:
    tag = "-".join(classes)
    return cache_dir / (f"desk-v{DATASET_VERSION}-{renderer_fingerprint()}-{view}-{input_wh[0]}x{input_wh[1]}-{tag}-"
                        f"{start:07d}-{count}.npz")


def _build_chunk(path: Path, start: int, count: int, input_wh: tuple[int, int], classes: Sequence[str],
                 view: str) -> None:
    images, boxes, labels, difficult, counts = [], [], [], [], []
    for sample in render_samples(range(start, start + count), classes, view):
        img, b, lab, d = _letterbox_sample(sample, input_wh, classes)
        images.append(img)
        boxes.append(b)
        labels.append(lab)
        difficult.append(d)
        counts.append(len(b))
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    np.savez_compressed(tmp, images=np.stack(images), boxes=np.concatenate(boxes), labels=np.concatenate(labels),
                        difficult=np.concatenate(difficult), counts=np.array(counts, np.int64))
    tmp.replace(path)


def training_arrays(n_images: int, input_wh: tuple[int, int], cache_dir: Path, classes: Sequence[str] = CLASSES,
                    first_seed: int = 0, progress: Optional[Callable[[str], None]] = None, view: str = "both"):
    """``n_images`` training images (the two images of scenes ``first_seed`` …, from the cameras
    ``view`` says: default the mix of stereo-rig and hand-camera scenes), letterboxed to
    ``input_wh`` as OnnxYoloDetector feeds its network: (images (N, H, W, 3) BGR uint8,
    boxes [(K, 4) input px], labels [(K,)], difficult [(K,)]). Rendered once, then read from
    .npz chunks of up to CHUNK_SCENES scenes in ``cache_dir`` (named after ``renderer_fingerprint``)."""
    say = progress or (lambda text: None)
    _check_view(view)
    if first_seed % CHUNK_SCENES:
        raise ValueError(f"first_seed {first_seed} must be a multiple of {CHUNK_SCENES}")
    n_scenes = -(-int(n_images) // 2)
    training_seeds(n_scenes, first_seed)  # checks the range
    cache_dir = Path(cache_dir)
    images, boxes, labels, difficult = [], [], [], []
    need = 2 * n_scenes
    for start in range(first_seed, first_seed + n_scenes, CHUNK_SCENES):
        count = min(CHUNK_SCENES, first_seed + n_scenes - start)
        path = _chunk_path(cache_dir, start, count, input_wh, classes, view)
        if not path.exists():
            t0 = time.perf_counter()
            _build_chunk(path, start, count, input_wh, classes, view)
            say(f"rendered scenes {start}…{start + count - 1} in {time.perf_counter() - t0:.1f} s → {path}")
        with np.load(path) as z:
            imgs, b, lab, d, counts = z["images"], z["boxes"], z["labels"], z["difficult"], z["counts"]
        ends = np.cumsum(counts)
        starts = ends - counts
        take = min(len(imgs), need - len(images))
        for i in range(take):
            images.append(imgs[i])
            boxes.append(b[starts[i]:ends[i]])
            labels.append(lab[starts[i]:ends[i]])
            difficult.append(d[starts[i]:ends[i]])
    images, boxes, labels, difficult = images[:n_images], boxes[:n_images], labels[:n_images], difficult[:n_images]
    return np.stack(images), boxes, labels, difficult


# ------------------------------------------------------------------------------------ scoring
def score_detector(detector, n_images: int, first_seed: int = TEST_SEED_BASE, classes: Sequence[str] = CLASSES,
                   iou_threshold: float = 0.5, score_threshold: float = 0.25,
                   view: str = "stereo") -> tuple[DetectionScores, dict]:
    """AP per class and mAP@``iou_threshold`` of ``detector`` (anything with ``detect(image)`` →
    detections with ``label``, ``score``, ``box`` (x, y, w, h px)) on ``n_images`` held-out renders
    (the two images of scenes ``first_seed`` … seen by ``view``: "stereo" the rig's two views,
    "hand" two hand-camera poses, "both" the training mix). Returns (scores, timing: render and
    detect ms per image)."""
    _check_view(view)
    n_scenes = -(-int(n_images) // 2)
    truths, found = [], []
    render_s = detect_s = 0.0
    seeds = iter(held_out_seeds(n_scenes, first_seed))
    while len(truths) < n_images:
        t0 = time.perf_counter()
        pair = render_views(next(seeds), classes, view)
        render_s += time.perf_counter() - t0
        for sample in pair[:n_images - len(truths)]:
            t0 = time.perf_counter()
            detections = detector.detect(sample.image)
            detect_s += time.perf_counter() - t0
            truths.append([TruthBox(b.label, b.box, b.difficult) for b in sample.boxes])
            found.append([ScoredBox(d.label, (d.box[0], d.box[1], d.box[0] + d.box[2], d.box[1] + d.box[3]), d.score)
                          for d in detections])
    scores = evaluate_detections(truths, found, classes, iou_threshold, score_threshold)
    n = max(len(truths), 1)
    return scores, {"render_ms_per_image": 1000 * render_s / n, "detect_ms_per_image": 1000 * detect_s / n}


def desk_negatives(count: int, input_wh: tuple[int, int], first_seed: int = 0) -> list[np.ndarray]:
    """``count`` renders of the simulated desk holding only what the model already knows (its
    classes' objects, lift panels, door handles, the arm; the cards and hands taken out),
    letterboxed to ``input_wh``: negatives that teach a new class it is none of the old ones
    (``core.detect.learned.teach.teach(scene_negatives=desk_negatives)``)."""
    from dataclasses import replace

    from core.detect.onnx_yolo import letterbox

    desks, out = {}, []
    for seed in training_seeds(count, first_seed):
        state, settings, arm, index = random_scene(seed)
        if index not in desks:
            desks[index] = desk_for(index)
        desk = desks[index]
        desk.set_scenario(_FixedScene(desk.marker_ids, replace(state, cards=(), hands=())))
        desk.set_camera_settings(settings)
        left, right, _ = desk.render(float(seed), arm)
        out.append(letterbox(left if seed % 2 == 0 else right, input_wh)[0])
    return out
