"""The assistive arm's per-frame loop, without Qt: hand-camera image → boxes → choice → FSM → joints.

``AssistLoop`` owns the joint values ``q`` and the loop's clock ``t`` (simulated: ``step`` advances
it by ``frame_dt_s``; the caller decides whether that runs as fast as the CPU allows or paced
by a wall clock). One frame of ``step``:

1. the approach FSM (``core.motion.assist.ApproachFsm``) takes the latest observation and answers
   with the next joint values (IBVS in ALIGN/APPROACH, the blind press in ACT);
2. the clock moves on one frame;
3. in ALIGN/APPROACH the hand camera renders (or grabs) a new image and the chosen box is
   followed in it (``_Follower``: the detector on a window around where the box should be every
   ``detect_every`` frames, a KCF tracker — or, with ``tracker=False``, the Kalman prediction —
   in between); its depth comes from the button's known size or the range sensor.

The detector is either a circle detector (``radius_px`` from the fitted circle; depth from the
button face's or ring's known radius, told apart by the grey level inside) or a box detector
made to speak the same language by ``SizedBoxDetector`` (the learned desk model: a radius from
each box, and the one physical radius that radius measures).

Before a choice, ``boxes(image)`` lists the selectable boxes (detections, the small ones — the
plate's screws — left out) in reading order; ``offer(image)`` keeps that list as the one the
user's choice refers to, and ``select(index)`` starts the FSM on it. ``stop()`` ends any
approach (the arm holds). ``go_to(q)`` moves the arm back to a pose (the ready pose) at a
bounded joint speed, over the following steps.

Used by ``deskarm assist-trials`` (app/cli_assist.py), which adds the simulated user and the
truth checks, and by the assistive window (app/assist_window.py), which adds the real user.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

FRAME_DT_S = 1.0 / 30.0
DETECT_EVERY = 3  # the detector runs on every 3rd frame (10 Hz); the tracker (or the Kalman) in between
# the circle detector fits either the dark face's edge (most of the time) or the chrome ring's outer
# edge: its semi-major axis is one of these physical radii (measured on hand-camera images at
# 0.12–0.26 m, r_px·Z/f: 8.5–8.9 mm and 10.7–11.1 mm; the face is 0.78 of the 11 mm button)
DETECTED_RADII_M = (0.0086, 0.011)
DARK_FACE_LEVEL = 120  # grey level between the dark face (~40) and the chrome ring (~220)
MIN_RADIUS_OF_MEDIAN = 0.6  # circles smaller than this fraction of the median radius are not offered
RETURN_SPEED_RAD_S = 0.8  # go_to: the fastest joint's speed on the way back to a pose
BUTTON_RING_RADIUS_M = 0.011  # a lift-panel button's outer (chrome ring) radius (core.sim.scenarios.Panel)
# where a target's depth comes from: the button's known size; the range sensor (None on a dropout);
# "auto": the range sensor when it has a reading, else the known size (a real board whose HC-SR04
# is absent, unplugged or out of range falls back frame by frame)
DEPTH_SOURCES = ("size", "range", "auto")


class SizedBoxDetector:
    """A box detector (the learned desk model) as the assist loop needs it: only one class of
    object, each detection with a radius — half its box's larger side — and the physical radius
    (``known_radius_m``) that this radius measures, for the depth from the object's known size.

    A round button seen obliquely is an ellipse whose major axis is its true diameter; the box's
    larger side spans it (the camera's x axis stays horizontal, the tilt shortens the other side).
    ``known_radius_m`` is what the detector's boxes really measure on average: the ring's radius
    times the mean ratio of the detected box to the true one (see app.cli_assist).
    ``centre_shift_of_width``: where the point to servo on lies in the box — this fraction of the
    box's width below the box's centre (image y). A button's box holds its whole silhouette, the
    top face and the part of its side the tilted camera sees above it; the face's centre, where
    the press must land, is lower than the box's centre (0 keeps the box's centre).

    ``detect(image, roi)`` runs the network on the WHOLE image and keeps the detections whose
    centre lies in ``roi``: the network's input size is fixed, so a crop would be enlarged to it
    and show the button at a scale it was not trained on (and costs the same). Detections of the
    whole image are cached per image (the loop asks twice for the same frame at most)."""

    def __init__(self, detector, label: str, known_radius_m: float, centre_shift_of_width: float = 0.0):
        if not 0.0 < known_radius_m < 1.0:
            raise ValueError(f"known_radius_m = {known_radius_m} m: need 0 < r < 1 m (the object's physical radius)")
        names = getattr(detector, "names", None)
        if not -0.5 <= centre_shift_of_width <= 0.5:
            raise ValueError(f"centre_shift_of_width = {centre_shift_of_width}: need −0.5…0.5 (a point inside the box)")
        if names is not None and label not in names:
            raise ValueError(f"the detector has no class {label!r} (its classes: {', '.join(names)}); choose one of "
                             f"those")
        self.detector = detector
        self.label = str(label)
        self.known_radius_m = float(known_radius_m)
        self.centre_shift_of_width = float(centre_shift_of_width)
        self.name = f"{getattr(detector, 'name', 'boxes')}:{label}"
        self._cache: tuple = (None, [])

    @property
    def params(self):
        return getattr(self.detector, "params", None)

    def _all(self, image) -> list:
        from dataclasses import replace

        if self._cache[0] is image:
            return self._cache[1]
        k = self.centre_shift_of_width
        found = [replace(d, radius_px=0.5 * max(d.box[2], d.box[3]),
                         centre_px=(d.centre_px[0], d.centre_px[1] + k * d.box[2]))
                 for d in self.detector.detect(image) if d.label == self.label]
        self._cache = (image, found)
        return found

    def detect(self, image, roi=None) -> list:
        """This class's detections in ``image`` (centre inside ``roi`` = (x, y, w, h) when given), with radius_px."""
        found = self._all(image)
        if roi is None:
            return list(found)
        x, y, w, h = (float(v) for v in roi)
        return [d for d in found if x <= d.centre_px[0] <= x + w and y <= d.centre_px[1] <= y + h]


@dataclass
class _Box:
    box: tuple  # (x, y, w, h) at the tracker's scale
    index: int  # which detection


class _Follower:
    """The chosen button from frame to frame: the detector on a window around it every
    ``detect_every`` frames; in between a KCF tracker (at half resolution: the button is large up
    close, and KCF's cost grows with it) or, with no tracker, nothing (the Kalman bridges)."""

    SCALE = 0.5  # the tracker's image scale
    WINDOW = 3.0  # the detector's window: this many radii around the last centre, each way

    def __init__(self, loop: "AssistLoop", image, chosen, t: float):
        from core.detect.tracking import ObjectTracker

        self.loop = loop
        self.centre = np.array(chosen.centre_px, dtype=float)
        self.radius = float(chosen.radius_px)
        self.point_base: Optional[np.ndarray] = None  # the button in robot_base, once a depth is known
        self.tracker = ObjectTracker("KCF") if loop.use_tracker else None
        if self.tracker is not None:
            self.tracker.start(self._small(image), self._scaled(chosen.box), t)

    def _small(self, image):
        import cv2

        return cv2.resize(image, None, fx=self.SCALE, fy=self.SCALE, interpolation=cv2.INTER_AREA)

    def _scaled(self, box) -> tuple:
        return tuple(float(v) * self.SCALE for v in box)

    def remember(self, centre, depth_m: Optional[float], base_T_camera: np.ndarray) -> None:
        """Keep where the button is in robot_base (its centre's ray at depth_m from the camera pose the
        arm's joints give): later frames predict its pixel from the camera's own motion."""
        if depth_m is None or not depth_m > 0:
            return
        K_inv = np.linalg.inv(self.loop.camera.K)
        camera_p = K_inv @ np.array([centre[0], centre[1], 1.0]) * depth_m
        self.point_base = (base_T_camera @ np.append(camera_p, 1.0))[:3]

    def predicted_centre(self, base_T_camera: np.ndarray) -> np.ndarray:
        """Where the button should be in this image: the remembered point seen from the camera's
        pose now (ego-motion), else the last centre."""
        if self.point_base is None:
            return self.centre
        uv, z = self.loop.camera.project(base_T_camera, self.point_base[None, :])
        return uv[0] if z[0] > 0 else self.centre

    def follow(self, image, t: float, detect: bool,
               base_T_camera: Optional[np.ndarray] = None) -> tuple[Optional[np.ndarray], Optional[float]]:
        """(centre px, detected radius px or None) of the chosen button in ``image``, or (None, None).
        ``base_T_camera``: the camera's pose from the joints (no shake), for the ego-motion prediction."""
        detections = None
        expected = self.centre if base_T_camera is None else self.predicted_centre(base_T_camera)
        if detect:
            half = max(60.0, self.WINDOW * self.radius)
            h, w = image.shape[:2]
            x0, y0 = max(0.0, expected[0] - half), max(0.0, expected[1] - half)
            x1, y1 = min(w - 1.0, expected[0] + half), min(h - 1.0, expected[1] + half)
            detections = self.loop.detect(image, (x0, y0, x1 - x0, y1 - y0)) if x1 > x0 + 8 and y1 > y0 + 8 else []
        centre, radius = None, None
        if self.tracker is not None:
            small_dets = None if detections is None else [_Box(self._scaled(d.box), i) for i, d in enumerate(detections)]
            state = self.tracker.update(self._small(image), t, small_dets)
            if state.ok and not state.lost:
                centre = np.array(state.centre_px) / self.SCALE + (0.5 / self.SCALE - 0.5)  # pixel-centre convention
                match = self.tracker.match(small_dets, t) if small_dets else None
                if match is not None:
                    d = detections[match.index]
                    centre, radius = np.array(d.centre_px, dtype=float), float(d.radius_px)
        elif detections:
            # the nearest button-sized circle to where the button should be (screws are circles too)
            sized = [d for d in detections if 0.6 <= d.radius_px / self.radius <= 1.6]
            dist = [float(np.hypot(*(np.array(d.centre_px) - expected))) for d in sized]
            i = int(np.argmin(dist)) if dist else -1
            detections = sized
            if i >= 0 and dist[i] <= max(30.0, 1.5 * self.radius):
                centre, radius = np.array(detections[i].centre_px, dtype=float), float(detections[i].radius_px)
        if centre is not None:
            self.centre = centre
        if radius is not None:
            self.radius = radius
        return centre, radius


@dataclass(frozen=True)
class LoopStatus:
    """What the loop is doing, for a display: the FSM's state, what it aims at and why it stopped."""

    state: str  # "IDLE", "ALIGN", "APPROACH", "ACT" (the FSM's) or "RETURN" (go_to under way)
    t: float  # the loop's clock (s)
    target_index: Optional[int]  # the chosen box (0-based, in the offered order), None before a choice
    centre_px: Optional[tuple[float, float]]  # where the chosen box is followed in the latest image
    outcome: Optional[str]  # the reason of the last return to IDLE ("pressed and back …", "stopped by the user", …)
    error_px: Optional[tuple[float, float]] = None
    radius_px: Optional[float] = None  # the followed box's radius in the latest image


MOVING_STATES = ("ALIGN", "APPROACH", "ACT")  # the arm is on its way to (or pressing) the chosen box
_VERBS = {"ALIGN": "aligning with", "APPROACH": "approaching", "ACT": "pressing"}


def state_line(status: LoopStatus, previous: Optional[LoopStatus], stopped: bool, current: str) -> str:
    """The assistive view's state line after ``status`` ("aligning with 7", "done: 7 pressed",
    "could not reach 7: lost", "going back", "stopped", …); ``previous``: the status before (None
    at first), ``stopped``: the user's STOP is engaged, ``current``: the line shown now (kept when
    nothing new is to be said, and a "stopped: …" reason is kept while stopped)."""
    n = None if status.target_index is None else status.target_index + 1
    if stopped:  # a state change queued before the stop reached the loop: the stop wins
        return current if current.startswith("stopped") else "stopped"
    if status.state in MOVING_STATES:
        return f"{_VERBS[status.state]} {n}"
    if status.state in ("IDLE", "RETURN") and previous is not None and previous.state in MOVING_STATES:
        outcome = status.outcome or ""
        if outcome.startswith(("pressed", "touched")):
            return f"done: {n} pressed"
        return f"could not reach {n}: {outcome.split(':')[0]}"
    if status.state == "RETURN" and not current.startswith(("done", "could not")):
        return "going back"
    return current


class AssistLoop:
    """The per-frame loop of the assistive arm on one hand camera (see the module docstring).

    ``camera``: renders/grabs with ``render(q, t)`` → an object with ``image`` (BGR) and
    ``base_T_camera``; has ``K`` and ``project(base_T_camera, points)`` (``core.sim.hand_camera.
    SimHandCamera``). ``kinematics``: ``camera_pose(q)`` (the camera's pose from the joints, no shake).
    ``detector``: a ``core.detect`` detector whose detections carry ``radius_px`` (circles), or a
    ``SizedBoxDetector`` (boxes; its ``known_radius_m`` gives the depth from size).
    ``servo``: the ``IbvsController``; ``assist_config``: the FSM's ``AssistConfig``.
    ``range_sensor`` (``measure(pose, t)`` → m or None) is needed with ``depth_source`` "range" or "auto"
    (the range when it has a reading, else the known size; ``last_depth_source`` tells which).
    ``render_always``: render an image in every state (a display wants one; trials skip the
    frames nobody looks at).
    """

    def __init__(self, kinematics, camera, detector, servo, assist_config, q0: Sequence[float], *,
                 tracker: bool = True, depth_source: str = "size", range_sensor=None,
                 frame_dt_s: float = FRAME_DT_S, detect_every: int = DETECT_EVERY, render_always: bool = False):
        from core.motion.assist import ApproachFsm

        if depth_source not in DEPTH_SOURCES:
            raise ValueError(f"depth source {depth_source!r}: use 'size' (the button's known size), 'range' "
                             f"(the ultrasonic sensor along the camera axis) or 'auto' (the range when the "
                             f"sensor has a reading, else the size)")
        if depth_source in ("range", "auto") and range_sensor is None:
            raise ValueError(f"depth source {depth_source!r} needs a range sensor: pass range_sensor=…, "
                             f"or use depth 'size'")
        if not 0 < frame_dt_s <= 1.0:
            raise ValueError(f"frame_dt_s = {frame_dt_s} s: need 0 < dt ≤ 1 s")
        self.kin = kinematics
        self.camera = camera
        self.detector = detector
        self.servo = servo
        self.assist_config = assist_config
        self.use_tracker = bool(tracker)
        self.depth_source = depth_source
        self.range_sensor = range_sensor
        self.frame_dt_s = float(frame_dt_s)
        self.detect_every = int(detect_every)
        self.render_always = bool(render_always)
        self.fsm = ApproachFsm(servo, assist_config)
        self.q: tuple = tuple(float(v) for v in q0)
        self.t = 0.0
        self.offered: list = []  # the boxes the user chooses from (detections, reading order)
        self.target_index: Optional[int] = None
        self.last_frame = None  # the latest rendered frame
        self.last_centre: Optional[np.ndarray] = None
        self.last_status = None  # the FSM's latest AssistStatus
        self._offered_frame = None
        self._obs = None
        self._follower: Optional[_Follower] = None
        self._frame_no = 0
        self._seq = 0
        self._return_to: Optional[np.ndarray] = None
        self.last_depth_source: Optional[str] = None  # "range" or "size": what gave the latest depth
        self.last_depth_m: Optional[float] = None  # the latest frame's own depth estimate (before the FSM's median)

    # -- before a choice ---------------------------------------------------------------------

    def reset(self, q: Sequence[float], t: float = 0.0) -> None:
        """Start over at joints q and time t (s): no choice, nothing offered, the FSM idle."""
        from core.motion.assist import ApproachFsm

        self.fsm = ApproachFsm(self.servo, self.assist_config)
        self.q = tuple(float(v) for v in q)
        self.t = float(t)
        self.offered, self.target_index, self._offered_frame = [], None, None
        self._obs, self._follower, self._frame_no, self._return_to = None, None, 0, None
        self.last_frame, self.last_centre, self.last_status, self.last_depth_m = None, None, None, None

    def render(self):
        """A new frame at the current joints and time (kept as ``last_frame``)."""
        self.last_frame = self.camera.render(self.q, self.t)
        return self.last_frame

    def detect(self, image, roi=None) -> list:
        """The detector's detections that carry a radius (buttons' faces)."""
        return [d for d in self.detector.detect(image, roi) if d.radius_px is not None]

    def boxes(self, image) -> list:
        """The selectable detections in ``image``, in reading order (row by row, left to right):
        circles much smaller than the rest (the plate's screws) are left out."""
        from core.motion.scanning import reading_order

        dets = self.detect(image)
        if dets:
            median_r = float(np.median([d.radius_px for d in dets]))
            dets = [d for d in dets if d.radius_px >= MIN_RADIUS_OF_MEDIAN * median_r]
        order = reading_order([d.box for d in dets])
        return [dets[i] for i in order]

    def offer(self, frame=None) -> list:
        """Detect the boxes in ``frame`` (default: a new render) and keep them as the choices
        ``select`` refers to; returns them."""
        frame = self.render() if frame is None else frame
        self.offered = self.boxes(frame.image)
        self._offered_frame = frame
        return self.offered

    # -- the choice and the approach ------------------------------------------------------------

    @property
    def state(self) -> str:
        """"IDLE", "ALIGN", "APPROACH", "ACT", or "RETURN" while ``go_to`` moves the arm."""
        if self._return_to is not None and self.fsm.state.value == "IDLE":
            return "RETURN"
        return self.fsm.state.value

    @property
    def busy(self) -> bool:
        return self.state != "IDLE"

    def select(self, index: int, t: Optional[float] = None) -> None:
        """The user chose offered box ``index`` (0-based) at time t (default: the loop's clock;
        the clock jumps there): the FSM starts aligning on it."""
        from core.motion.assist import TargetObservation

        if not 0 <= index < len(self.offered):
            raise ValueError(f"box {index + 1} is not among the {len(self.offered)} offered: call offer() first "
                             f"and choose one of those")
        if self.busy:
            raise ValueError(f"the arm is busy ({self.state}): stop it before choosing another box")
        if t is not None:
            self.t = float(t)
        t = self.t
        chosen = self.offered[index]
        frame = self._offered_frame
        self.target_index = int(index)
        self.fsm.start(t, f"box {index + 1}")
        self._follower = _Follower(self, frame.image, chosen, t)
        depth = self._target_depth(frame, chosen.centre_px, chosen.radius_px, self.kin.camera_pose(self.q), t)
        self._obs = TargetObservation(tuple(chosen.centre_px), depth)
        self._follower.remember(chosen.centre_px, depth, self.kin.camera_pose(self.q))
        self.last_centre = np.array(chosen.centre_px, dtype=float)
        self._frame_no = 0

    def stop(self, reason: str = "stopped by the user") -> None:
        """End any approach or return: the FSM goes IDLE and the arm holds where it is."""
        self._return_to = None
        self.fsm.stop(self.t, reason)
        self._obs = None

    def go_to(self, q: Sequence[float]) -> None:
        """Move the arm to joints q over the following steps (at most ``RETURN_SPEED_RAD_S`` per joint)."""
        if self.fsm.state.value != "IDLE":
            raise ValueError(f"the arm is busy ({self.state}): stop it first")
        self._return_to = np.array(q, dtype=float)

    # -- one frame --------------------------------------------------------------------------------

    def step(self):
        """One frame: (frame or None, JointCommand, LoopStatus). The frame is None when nothing
        was rendered (ACT and IDLE, unless ``render_always``)."""
        from core.messages import JointCommand
        from core.motion.assist import AssistState, TargetObservation

        dt = self.frame_dt_s
        if self._return_to is not None and self.fsm.state == AssistState.IDLE:
            delta = self._return_to - np.array(self.q)
            biggest = float(np.max(np.abs(delta))) if delta.size else 0.0
            limit = RETURN_SPEED_RAD_S * dt
            if biggest <= limit:
                self.q, self._return_to = tuple(float(v) for v in self._return_to), None
            else:
                self.q = tuple(float(v) for v in np.array(self.q) + delta * (limit / biggest))
            self.t += dt
            return self._finish(None, JointCommand)
        status = self.fsm.step(self.t, self.q, self._obs, dt)
        self.last_status = status
        self.q = status.q
        self.t += dt
        self._frame_no += 1
        if self.fsm.state in (AssistState.IDLE, AssistState.ACT) or self._follower is None:
            self._obs = None
            return self._finish(self.render() if self.render_always else None, JointCommand)
        frame = self.render()
        base_T_camera = self.kin.camera_pose(self.q)  # what the joints say (a shake is unknown to the arm)
        centre, size = self._follower.follow(frame.image, self.t, self._frame_no % self.detect_every == 0,
                                             base_T_camera)
        self.last_depth_m = None
        if centre is None:
            self._obs = None
            return self._finish(frame, JointCommand)
        depth = self._target_depth(frame, centre, size, base_T_camera, self.t)
        self.last_depth_m = depth
        self._obs = TargetObservation(tuple(centre), depth)
        self.last_centre = centre
        if size is not None:
            self._follower.remember(centre, depth, base_T_camera)
        return self._finish(frame, JointCommand)

    def _finish(self, frame, JointCommand):
        self._seq += 1
        command = JointCommand(seq=self._seq, t=self.t, q=self.q)
        status = self.last_status
        err = getattr(status, "error_px", None) if self.fsm.state.value in ("ALIGN", "APPROACH") else None
        centre = None if self.last_centre is None or not self.busy else tuple(float(v) for v in self.last_centre)
        radius = None if centre is None or self._follower is None else float(self._follower.radius)
        return frame, command, LoopStatus(self.state, self.t, self.target_index, centre, self.fsm.outcome,
                                          None if err is None else (float(err[0]), float(err[1])), radius)

    # -- depth --------------------------------------------------------------------------------

    def _target_depth(self, frame, centre_px, radius_px: Optional[float], base_T_camera: np.ndarray,
                      t: float) -> Optional[float]:
        """The followed button's depth by ``depth_source`` (``last_depth_source`` says which one
        gave it: "range", "size" or None)."""
        depth = None
        self.last_depth_source = None
        if self.depth_source in ("range", "auto"):
            depth = self._range_depth(centre_px, frame.base_T_camera, base_T_camera, t)
            if depth is not None:
                self.last_depth_source = "range"
                return depth
            if self.depth_source == "range":
                return None
        if radius_px is not None:
            depth = self._depth(frame.image, centre_px, radius_px)
            self.last_depth_source = None if depth is None else "size"
        return depth

    def _depth(self, image, centre_px, radius_px: float) -> Optional[float]:
        """The button's depth from its known size. A ``SizedBoxDetector`` says what its radius
        measures (``known_radius_m``). The circle detector fits either the dark face's
        edge or the chrome ring's outer edge; which one shows in the image just inside the fitted
        circle (at 0.85 of its radius): dark face inside → the face (8.6 mm), bright ring → the ring."""
        from core.motion.servoing import depth_from_size

        known = getattr(self.detector, "known_radius_m", None)
        if known is not None:
            return depth_from_size(radius_px, float(known), self.camera.K[0, 0])

        a = np.linspace(0.0, 2 * np.pi, 24, endpoint=False)
        xs = np.clip(np.round(centre_px[0] + 0.85 * radius_px * np.cos(a)).astype(int), 0, image.shape[1] - 1)
        ys = np.clip(np.round(centre_px[1] + 0.85 * radius_px * np.sin(a)).astype(int), 0, image.shape[0] - 1)
        samples = image[ys, xs]
        inside = float(np.median(samples if samples.ndim == 1 else samples.mean(axis=1)))
        fitted = DETECTED_RADII_M[0] if inside < DARK_FACE_LEVEL else DETECTED_RADII_M[1]
        return depth_from_size(radius_px, fitted, self.camera.K[0, 0])

    def _range_depth(self, centre_px, sensor_pose: np.ndarray, base_T_camera: np.ndarray, t: float) -> Optional[float]:
        """The button's depth from the ultrasonic range: the echo comes from the surface the camera
        axis points at (≈ 5 cm beside the button, the plate or the desk), taken as a horizontal plane
        at that height; the button's depth is where its pixel's ray meets that plane (camera pose
        from the joints, ``base_T_camera``; the sensor itself reads from where it really is, ``sensor_pose``,
        shake included). None on a dropout."""
        reading = self.range_sensor.measure(sensor_pose, t)
        if reading is None:
            return None
        R, c = base_T_camera[:3, :3], base_T_camera[:3, 3]
        plane_z = c[2] + reading * R[2, 2]
        ray = R @ (np.linalg.inv(self.camera.K) @ np.array([centre_px[0], centre_px[1], 1.0]))  # camera z = 1
        if ray[2] > -1e-6:
            return None
        depth = (plane_z - c[2]) / ray[2]
        return float(depth) if depth > 0 else None
