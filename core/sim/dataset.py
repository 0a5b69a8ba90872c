"""Labelled images of the simulated desk, for training and scoring the desk detector.

Each dataset *seed* is one random scene, rendered into both cameras (two images): balls, upside-
down cups, yellow banana-like plushes, discs and cylinders in many hues, a lift panel of 9
buttons, a door handle, ArUco cards, sometimes the arm or a hovering hand in the way, under
random camera settings (exposure, gain, brightness, contrast) on one of a few desks (desk
texture, blur, noise and a slightly bumped rig). The labels are ``SimDesk.image_boxes``: tight
boxes of what is visible of each object, so they are exact by construction.

Seeds below ``TEST_SEED_BASE`` are for training; seeds from it on are held out (their scenes,
and three of their four desks, are never used in training). Everything is deterministic given
the seed.

``render_samples(seeds)`` yields full-size ``Sample``s (what the app's cameras would see);
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

__all__ = ["CLASSES", "TEST_SEED_BASE", "DATASET_VERSION", "LabelledBox", "Sample", "random_scene", "desk_for",
           "render_scene", "render_samples", "training_arrays", "score_detector", "training_seeds",
           "held_out_seeds", "renderer_fingerprint"]

CLASSES = ("ball", "cup", "plush", "button", "disc", "handle")  # class index = position
TEST_SEED_BASE = 1_000_000  # seeds ≥ this are the held-out test scenes
DATASET_VERSION = 1  # bump when a change alters the renders or labels (invalidates caches)
DIFFICULT_VISIBLE_FRACTION = 0.5  # a box showing less of its object than this is "difficult"
DIFFICULT_MIN_PX = 24  # ... and so is one with fewer visible pixels than this
CHUNK_SCENES = 250  # training_arrays caches this many scenes per .npz file
MARKER_IDS = (23, 50, 7, 99)  # the desk's ArUco cards (distractors, never labelled)

# desks: (desk seed, blur σ px, noise σ, rig mount offset dx dy dz m, roll pitch yaw rad)
_TRAIN_DESKS = 12
_TEST_DESKS = (0, 1000, 1001, 1002)  # the app's default desk, and three that training never sees
_DEFAULT_DESK = 0


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
    side: str  # "left" or "right"
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
    settings = CameraSettings(exposure=float(np.clip(rng.normal(0.0, 0.3), -0.8, 0.8)),
                              gain=float(rng.choice((0.0, rng.uniform(0.0, 12.0)))),
                              brightness=float(rng.uniform(-15, 15)), contrast=float(rng.uniform(0.8, 1.2)))
    if seed >= TEST_SEED_BASE:
        desk = _TEST_DESKS[int(rng.integers(len(_TEST_DESKS)))]
    else:
        desk = int(rng.integers(_TRAIN_DESKS))
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


def render_samples(seeds: Iterable[int], classes: Sequence[str] = CLASSES) -> Iterator[Sample]:
    """Both views of each scene seed, in order (left, right, left, right, …)."""
    for seed in seeds:
        yield from render_scene(int(seed), classes)


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

    from core.sim import desk, rig, scenarios

    crc = 0
    for module in (desk, rig, scenarios, sys.modules[__name__]):
        crc = zlib.crc32(Path(module.__file__).read_bytes(), crc)
    return f"{crc:08x}"


def _chunk_path(cache_dir: Path, start: int, count: int, input_wh: tuple[int, int], classes: Sequence[str]) -> Path:
    tag = "-".join(classes)
    return cache_dir / (f"desk-v{DATASET_VERSION}-{renderer_fingerprint()}-{input_wh[0]}x{input_wh[1]}-{tag}-"
                        f"{start:07d}-{count}.npz")


def _build_chunk(path: Path, start: int, count: int, input_wh: tuple[int, int], classes: Sequence[str]) -> None:
    images, boxes, labels, difficult, counts = [], [], [], [], []
    for sample in render_samples(range(start, start + count), classes):
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
                    first_seed: int = 0, progress: Optional[Callable[[str], None]] = None):
    """``n_images`` training images (both views of scenes ``first_seed`` …), letterboxed to
    ``input_wh`` as OnnxYoloDetector feeds its network: (images (N, H, W, 3) BGR uint8,
    boxes [(K, 4) input px], labels [(K,)], difficult [(K,)]). Rendered once, then read from
    .npz chunks of up to CHUNK_SCENES scenes in ``cache_dir`` (named after ``renderer_fingerprint``)."""
    say = progress or (lambda text: None)
    if first_seed % CHUNK_SCENES:
        raise ValueError(f"first_seed {first_seed} must be a multiple of {CHUNK_SCENES}")
    n_scenes = -(-int(n_images) // 2)
    training_seeds(n_scenes, first_seed)  # checks the range
    cache_dir = Path(cache_dir)
    images, boxes, labels, difficult = [], [], [], []
    need = 2 * n_scenes
    for start in range(first_seed, first_seed + n_scenes, CHUNK_SCENES):
        count = min(CHUNK_SCENES, first_seed + n_scenes - start)
        path = _chunk_path(cache_dir, start, count, input_wh, classes)
        if not path.exists():
            t0 = time.perf_counter()
            _build_chunk(path, start, count, input_wh, classes)
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
                   iou_threshold: float = 0.5, score_threshold: float = 0.25) -> tuple[DetectionScores, dict]:
    """AP per class and mAP@``iou_threshold`` of ``detector`` (anything with ``detect(image)`` →
    detections with ``label``, ``score``, ``box`` (x, y, w, h px)) on ``n_images`` held-out renders
    (both views of scenes ``first_seed`` …). Returns (scores, timing: render and detect ms per image)."""
    n_scenes = -(-int(n_images) // 2)
    truths, found = [], []
    render_s = detect_s = 0.0
    seeds = iter(held_out_seeds(n_scenes, first_seed))
    while len(truths) < n_images:
        t0 = time.perf_counter()
        pair = render_scene(next(seeds), classes)
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
