"""``deskarm assist-trials``: the assistive arm's whole loop on the simulated desk, many times.

    deskarm assist-trials [--n 50] [--mode touch|scan2|scan1] [--vibration] [--no-tracker] [--realistic]
                          [--detector circles|desk] [--seed S] [--scan-period S] [--depth size|range] [--json]

Each trial: a lift panel (the ``panel`` scene's, moved by up to ±1 cm and turned by up to ±0.1 rad,
no passing hand) and a random button 1…9 the simulated user wants; the arm at its ready pose (the
park pose with the hand tilted 30° back, camera on the panel's usual place: see ``_ready_pose``); the
hand camera's image → the button detector (``--detector``, see ``make_assist_detector``: ``circles``,
the default, the buttons' round faces; or ``desk``, the shipped learned model — trained on the stereo
rig's views and on hand-camera views of the panel — its "button" boxes, ~3× less accurate in size,
so circles stays the default: see resources/models/README.md) → the boxes offered to the user in
reading order → the user's input, simulated (touch: a tap near the button, taps outside every box are ignored and
repeated; scan2: "next" presses at ~0.5 s and "confirm"; scan1: timed scanning, one press ~0.4 s
after the highlight reaches the box) → the approach FSM (IBVS, Kalman, detector every 3rd frame
with a KCF tracker in between — with ``--no-tracker`` the Kalman prediction bridges those frames;
the detector looks in a window around where the button should be, predicted from the camera's own
motion) → the press. Depth: from the button's known size (its detected ellipse's semi-major axis,
the fitted edge told apart by the grey level just inside it), or with ``--depth range`` the
simulated ultrasonic sensor; with ``desk``, half the box's larger side is the button's ring radius
(scaled by what the model's boxes measure on average, ``DESK_BUTTON_RADIUS_M``), and the point
aimed at is the top face's centre, a little below the box's (``DESK_BUTTON_CENTRE_SHIFT``). Circles
much smaller than the rest (the plate's screws) are not offered.

Success: the intended button was pressed — the tool tip's path crossed the button's top face
within ``SUCCESS_RADIUS_M`` (3 mm) of its centre and went on down by at least half the button's
travel. final_distance_mm: the horizontal distance from that crossing point to the button's
centre. time_to_target_s: from the confirmed choice to that crossing (the arm's time);
selection_s: the user's input time before it. depth_error_pct: the estimated depth of the followed
button against the truth, on the frames the detector measured it in ALIGN/APPROACH. Simulated clock at 30 frames/s, run as fast
as the CPU allows; the wall-clock cost is reported too (loop_ms_per_frame: one step of the loop in
ALIGN/APPROACH, render included; detect_ms_per_call: the detector alone).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

PROG = "deskarm assist-trials"
from core.motion.assist_loop import (  # noqa: E402,F401 (re-exported: the loop's constants)
    DARK_FACE_LEVEL, DETECT_EVERY, DETECTED_RADII_M, FRAME_DT_S, MIN_RADIUS_OF_MEDIAN)

SUCCESS_RADIUS_M = 0.003
AXIS_TILT_RAD = math.radians(30.0)  # the hand presses tilted back towards the base (see core.motion.servoing)
TRIAL_TIMEOUT_S = 25.0
# a press goes 6 mm past the estimated surface along the tool axis (5.2 mm down at 30°): the 3 mm travel
# plus a margin for the depth-from-size error (~2 %, 3 mm at 0.15 m); the button bottoms out and the
# rest is taken up by the arm's compliance (reported as overtravel_mm)
PRESS_DEPTH_M = 0.006
# servo gain (1/s), the camera's top speed and the approach speed: tried 2/0.08/0.06, 3/0.12/0.08 and
# 4/0.15/0.10 on 12 trials with and without vibration — all 100 %; the middle one is used
SERVO_GAIN, MAX_LINEAR_SPEED_M_S, APPROACH_SPEED_M_S = 3.0, 0.12, 0.08
ASSIST_DETECTORS = ("circles", "desk")  # make_assist_detector's names
# the desk model's button boxes: half the larger side measures this physical radius on average (the
# 11 mm ring, times the mean ratio of detected to true box size on hand-camera renders: see the report
# in resources/models/README.md); the depth from size divides by it
DESK_BUTTON_RADIUS_M = 0.01125
# ... and the button's top face (where the press lands) is centred this fraction of the box's width below
# the box's centre: the box also holds the part of the button's side the tilted camera sees above the face
# (measured on the same frames: 0.063 ± 0.011; uncorrected it put the press ~1.5 mm off the centre)
DESK_BUTTON_CENTRE_SHIFT = 0.063


def display_problem(environ, platform: str = sys.platform) -> str:
    """Why a window cannot open here ("" when it can): on Linux Qt needs a display — X11's
    DISPLAY, Wayland's WAYLAND_DISPLAY — or a platform named in QT_QPA_PLATFORM (eglfs or linuxfb
    draw on a screen without a desktop). Without one Qt aborts the process (exit 134) after a
    screenful of plugin messages; this is checked first and said in one line instead."""
    if not platform.startswith("linux"):
        return ""
    qpa = environ.get("QT_QPA_PLATFORM", "").split(":", 1)[0].strip()
    has_x, has_wayland = bool(environ.get("DISPLAY")), bool(environ.get("WAYLAND_DISPLAY"))
    if qpa == "xcb" and not has_x:
        where = "QT_QPA_PLATFORM=xcb but DISPLAY is not set"
    elif qpa.startswith("wayland") and not has_wayland:
        where = f"QT_QPA_PLATFORM={qpa} but WAYLAND_DISPLAY is not set"
    elif not qpa and not (has_x or has_wayland):
        where = "DISPLAY and WAYLAND_DISPLAY are not set"
    else:
        return ""
    return (f"no display to open the window on ({where}) — run it on the desktop, set QT_QPA_PLATFORM=eglfs "
            f"(or linuxfb) for a screen without a desktop, or add --screenshot out.png to render it offscreen")


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:
        self.exit(2, f"{self.prog}: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, description="Run the assistive arm's approach on the simulated desk: choose a panel "
                                       "button with a simulated input, servo the eye-in-hand camera onto it, press.")
    p.add_argument("--n", type=int, default=50, help="number of trials (default 50)")
    p.add_argument("--mode", choices=("touch", "scan2", "scan1"), default="touch", help="input mode (default touch)")
    p.add_argument("--vibration", action="store_true", help="shake the hand (0.5 mm, 0.25°, 4–11 Hz)")
    p.add_argument("--no-tracker", action="store_true", help="no KCF tracker between detector frames")
    p.add_argument("--realistic", action="store_true",
                   help="the hand camera's images as a cheap webcam's (core.sim.realism's webcam preset: blur, "
                        "rolling shutter, flicker, noise, vignetting, distortion, JPEG)")
    p.add_argument("--detector", choices=ASSIST_DETECTORS, default="circles",
                   help="the hand camera's button detector: circles (default: the buttons' round faces) or desk "
                        "(the shipped learned model's button boxes)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--scan-period", type=float, default=1.0, help="scan1: highlight period, 0.5…5 s (default 1)")
    p.add_argument("--depth", choices=("size", "range"), default="size",
                   help="the target's depth: from the button's known size (default) or the simulated ultrasonic "
                        "range sensor along the camera axis")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    return p


# -----------------------------------------------------------------------------------------------
# the detector


def make_assist_detector(name: str = "circles"):
    """The hand camera's button detector by name, set up as the trials use it (for the assistive
    window too): "circles" — the buttons' round faces, ≥ 12 px in radius (the digits' loops and the
    plate's screws are smaller); "desk" — the shipped learned model (``make_detector("desk")``)
    restricted to its "button" class, each box with a radius and the physical radius it measures
    (``core.motion.assist_loop.SizedBoxDetector``). ValueError naming the valid names; the desk
    model's own FileNotFoundError when its file is missing."""
    from core.detect.registry import make_detector
    from core.motion.assist_loop import SizedBoxDetector

    if name == "circles":
        # faces are ≥ 20 px in radius from the ready pose on; the digits' loops and the screws are < 10 px
        return make_detector("circles", max_objects=16, min_radius_px=12)
    if name == "desk":
        return SizedBoxDetector(make_detector("desk"), "button", DESK_BUTTON_RADIUS_M, DESK_BUTTON_CENTRE_SHIFT)
    raise ValueError(f"unknown assist detector {name!r}; valid: {', '.join(ASSIST_DETECTORS)}")


class _TimedDetector:
    """A detector that counts its calls and their wall time (the trials report ms per call)."""

    def __init__(self, detector):
        self.detector = detector
        self.calls = 0
        self.seconds = 0.0

    def __getattr__(self, name):  # known_radius_m, name, params, …: the wrapped detector's
        return getattr(self.detector, name)

    def detect(self, image, roi=None):
        t0 = time.perf_counter()
        try:
            return self.detector.detect(image, roi)
        finally:
            self.calls += 1
            self.seconds += time.perf_counter() - t0


# -----------------------------------------------------------------------------------------------
# the scene


def nominal_ready_pose(kin, K) -> tuple:
    """The assistive arm's ready pose for a panel where the ``panel`` scene has it (the hand
    tilted 30° back from the park pose, the camera centred on the panel's top): the trials', the
    simulated window's, and the real arm's default (``assist.toml`` ``ready_deg`` overrides it)."""
    from core.motion.servoing import aimed_pose
    from core.sim.scenarios import Panel, PanelScenario

    nominal = Panel(*PanelScenario.PANEL_XY, yaw=PanelScenario.PANEL_YAW)
    return aimed_pose(kin, K, (nominal.x, nominal.y, nominal.top_z), kin.q_home, AXIS_TILT_RAD, FRAME_DT_S)


def _trial_scenario(rng):
    from core.sim.scenarios import DoorHandle, Panel, PanelScenario, Scenario, SceneState

    class TrialScene(Scenario):
        """A still panel (moved a little per trial) and the handle; ``pressed`` is set by the press."""

        name = "assist-trial"

        def __init__(self):
            super().__init__((23,), 0)
            dx, dy = rng.uniform(-0.01, 0.01, size=2)
            self.panel_kw = dict(x=PanelScenario.PANEL_XY[0] + dx, y=PanelScenario.PANEL_XY[1] + dy,
                                 yaw=PanelScenario.PANEL_YAW + rng.uniform(-0.1, 0.1))
            self.pressed: tuple = ()
            self.handle = DoorHandle(*PanelScenario.HANDLE_PIVOT, yaw=PanelScenario.HANDLE_YAW)

        def panel(self) -> Panel:
            return Panel(**self.panel_kw, pressed=self.pressed)

        def state(self, t: float) -> SceneState:
            return SceneState(panels=(self.panel(),), handles=(self.handle,))

    return TrialScene()


trial_scene = _trial_scenario  # public: the assistive window shows the same still panel


# -----------------------------------------------------------------------------------------------
# the simulated user


def _contains(box, pt) -> bool:
    x, y, w, h = box
    return x <= pt[0] <= x + w and y <= pt[1] <= y + h


def simulate_choice(mode: str, boxes: list, target_px, rng, scan_period_s: float = 1.0) -> dict:
    """The simulated user's input: {index (chosen box or None), seconds, presses, ignored}.

    ``boxes`` in scanning order; ``target_px`` where the wanted button is in the image."""
    from core.motion.scanning import OneSwitchScanner, TouchSelector, TwoSwitchScanner

    want = next((i for i, b in enumerate(boxes) if _contains(b, target_px)), None)
    if want is None:
        return {"index": None, "seconds": 0.0, "presses": 0, "ignored": 0}
    if mode == "touch":
        sel = TouchSelector(boxes)
        t, ignored = 0.0, 0
        for _ in range(10):
            t += max(0.5, rng.normal(1.0, 0.2))  # find the button on the screen, reach, tap
            tap = np.asarray(target_px) + rng.normal(0.0, 6.0, size=2)  # ~6 px scatter (a finger on a 7" screen)
            ev = sel.tap(tap[0], tap[1], t)
            if ev.kind == "select":
                return {"index": ev.index, "seconds": t, "presses": ignored + 1, "ignored": ignored}
            ignored += 1
        return {"index": None, "seconds": t, "presses": ignored, "ignored": ignored}
    if mode == "scan2":
        sc = TwoSwitchScanner(len(boxes))
        t = max(0.3, rng.normal(0.6, 0.1))
        while sc.highlight != want:
            sc.next(t)
            t += float(np.clip(rng.normal(0.5, 0.1), 0.25, 1.0))
        ev = sc.confirm(t)
        return {"index": ev.index, "seconds": t, "presses": sc.presses, "ignored": 0}
    sc = OneSwitchScanner(len(boxes), period_s=scan_period_s)
    sc.start(0.0)
    reaction = float(np.clip(rng.normal(0.4, 0.08), 0.2, 0.7))
    t_arrive = want * scan_period_s  # the highlight reaches the wanted box
    t_press = t_arrive + reaction
    sc.tick(t_press)
    sc.press(t_press)
    events = sc.release(t_press + 0.15)
    sel = [e for e in events if e.kind == "select"]
    return {"index": sel[0].index if sel else None, "seconds": t_press + 0.15, "presses": sc.presses, "ignored": 0}


# -----------------------------------------------------------------------------------------------
# one trial


@dataclass
class TrialResult:
    button: int
    selected_ok: bool
    success: bool = False
    pressed_button: Optional[int] = None
    final_distance_mm: Optional[float] = None
    press_depth_mm: Optional[float] = None  # how far the button went down (≤ its travel)
    overtravel_mm: Optional[float] = None  # how much further the tool tip was driven (the arm's compliance)
    selection_s: float = 0.0
    time_to_target_s: Optional[float] = None
    depth_errors: list = field(default_factory=list)  # (estimated − true) / true depth, per followed frame
    presses: int = 0
    outcome: str = ""
    events: list = field(default_factory=list)


class AssistTrials:
    """Builds the arm, desk, camera and detector once; ``run_trial(i)`` runs one trial."""

    def __init__(self, mode: str = "touch", vibration: bool = False, tracker: bool = True, seed: int = 0,
                 scan_period_s: float = 1.0, depth_source: str = "size", detector: str = "circles",
                 realistic: bool = False):
        from core.motion.assist import AssistConfig
        from core.motion.assist_loop import AssistLoop
        from core.kinematics.clik import ClikKinematics
        from core.kinematics.profile import load_profile
        from core.motion.servoing import IbvsConfig, IbvsController
        from core.sim.desk import SimDesk
        from core.sim.hand_camera import HandCameraConfig, SimHandCamera
        from core.sim.range_sensor import SimRangeSensor
        from core.sim.rig import SimRig

        self.mode, self.vibration, self.use_tracker, self.seed = mode, vibration, tracker, int(seed)
        self.scan_period_s = float(scan_period_s)
        if depth_source not in ("size", "range"):
            raise ValueError(f"depth source {depth_source!r}: use 'size' (the button's known size) or 'range' "
                             f"(the ultrasonic sensor along the camera axis)")
        self.depth_source = depth_source
        self.kin = ClikKinematics(load_profile("assistive_5dof"))
        self.desk = SimDesk(SimRig(), "static", seed=self.seed)
        self.camera = SimHandCamera(self.desk, self.kin, HandCameraConfig(vibration=vibration), seed=self.seed)
        self.realistic = bool(realistic)
        if self.realistic:
            self.camera = _RealisticHandCamera(self.camera, self.seed)
        self.servo = IbvsController(self.kin, self.camera.K, IbvsConfig(axis_tilt_rad=AXIS_TILT_RAD, gain=SERVO_GAIN,
                                                                         max_linear_speed_m_s=MAX_LINEAR_SPEED_M_S))
        self.detector = _TimedDetector(make_assist_detector(detector))
        self.detector_name = detector
        self.step_seconds = 0.0  # wall time of the loop's steps that rendered and followed (ALIGN/APPROACH)
        self.step_frames = 0
        self.range_sensor = SimRangeSensor(self.desk, seed=self.seed)
        self.ready_q = self._ready_pose()
        self.assist_config = AssistConfig(press_depth_m=PRESS_DEPTH_M, approach_speed_m_s=APPROACH_SPEED_M_S)
        self.trace: Optional[list] = None  # debugging: per frame (t, state, depth, true depth, centre error, IBVS error)
        self.loop = AssistLoop(self.kin, self.camera, self.detector, self.servo, self.assist_config, self.ready_q,
                               tracker=tracker, depth_source=depth_source, range_sensor=self.range_sensor,
                               frame_dt_s=FRAME_DT_S, detect_every=DETECT_EVERY)

    def _ready_pose(self) -> tuple:
        """The arm's ready pose for this desk: the hand tilted as the servo holds it, the camera
        centred on where the panel usually is (a taught pose: computed once from the panel
        scene's nominal place, not from a trial's panel). The approach then starts without a
        swing of the whole image, and the user chooses from this view."""
        return nominal_ready_pose(self.kin, self.camera.K)

    def run_trial(self, index: int) -> TrialResult:
        """One trial: the scene, the simulated user's choice, then ``AssistLoop`` frames until the
        FSM is back in IDLE (or TRIAL_TIMEOUT_S), with the truth checks of the press."""
        from core.motion.assist import AssistState

        rng = np.random.default_rng([self.seed, index, 12])
        scene = _trial_scenario(rng)
        self.desk.set_scenario(scene)
        button = int(rng.integers(1, 10))
        panel = scene.panel()
        P = np.array(panel.button_centre(button))
        top_z = P[2]
        travel = panel.press_depth_m
        loop = self.loop
        loop.reset(self.ready_q, 0.0)
        frame = loop.render()
        dets = loop.offer(frame)
        target_px = self.camera.project(frame.base_T_camera, P[None, :])[0][0]
        choice = simulate_choice(self.mode, [d.box for d in dets], target_px, rng, self.scan_period_s)
        res = TrialResult(button=button, selected_ok=False, selection_s=choice["seconds"], presses=choice["presses"])
        if choice["index"] is None:
            res.outcome = "the wanted button was not among the offered boxes"
            return res
        chosen = dets[choice["index"]]
        res.selected_ok = _contains(chosen.box, target_px)
        t_start = choice["seconds"]
        loop.select(choice["index"], t_start)
        fsm = loop.fsm
        prev_tool = self.camera.base_T_tool(loop.q, loop.t)[:3, 3]
        contact, deepest, t_contact = None, -np.inf, None
        while fsm.state != AssistState.IDLE and loop.t - t_start < TRIAL_TIMEOUT_S:
            t0 = time.perf_counter()
            frame, _command, _status = loop.step()
            if frame is not None:
                self.step_seconds += time.perf_counter() - t0
                self.step_frames += 1
            q, t = loop.q, loop.t
            # the press: where the tool tip's path crosses the button tops' plane, and how deep it goes
            tool = self.camera.base_T_tool(q, t)[:3, 3]
            if contact is None and prev_tool[2] > top_z >= tool[2]:
                s = (prev_tool[2] - top_z) / (prev_tool[2] - tool[2])
                contact = prev_tool + s * (tool - prev_tool)
                t_contact = t - FRAME_DT_S + s * FRAME_DT_S
            if contact is not None:
                deepest = max(deepest, top_z - tool[2])
                if deepest >= travel / 2 and not scene.pressed:
                    hit = [n for n in panel.BUTTONS if np.hypot(*(np.array(panel.button_centre(n)[:2]) - contact[:2]))
                           <= panel.button_radius_m]
                    if hit:
                        scene.pressed = (hit[0],)
                        res.pressed_button = hit[0]
            prev_tool = tool
            depth = loop.last_depth_m if frame is not None else None
            if depth is not None:
                true_z = float(self.camera.project(frame.base_T_camera, P[None, :])[1][0])
                res.depth_errors.append((depth - true_z) / true_z)
            if self.trace is not None and frame is not None and loop.last_status is not None:
                true_uv, true_z = self.camera.project(frame.base_T_camera, P[None, :])
                err = loop.last_status.error_px
                depth = loop.last_status.depth_m
                self.trace.append((round(t, 2), fsm.state.value, depth and round(depth, 4), round(float(true_z[0]), 4),
                                   tuple(np.round(loop.last_centre - true_uv[0], 1)),
                                   np.round(err, 1) if err is not None else None))
        res.outcome = fsm.outcome or "trial timeout"
        res.events = fsm.event_log()
        if contact is not None:
            res.final_distance_mm = float(np.hypot(*(contact[:2] - P[:2])) * 1000)
            res.press_depth_mm = float(min(deepest, travel) * 1000)
            res.overtravel_mm = float(max(0.0, deepest - travel) * 1000)
            res.time_to_target_s = float(t_contact - t_start)
            res.success = bool(res.final_distance_mm <= SUCCESS_RADIUS_M * 1000 and deepest >= travel / 2
                               and res.pressed_button == button)
        return res


class _RealisticHandCamera:
    """A hand camera whose images pass through the webcam realism preset (``--realistic``): the
    same poses and truth, each frame's blur, shutter, flicker, noise and JPEG drawn from (seed, t)."""

    def __init__(self, camera, seed: int):
        from core.sim.realism import WEBCAM

        self._camera, self._seed, self.preset = camera, int(seed) & 0x7FFFFFFF, WEBCAM

    def __getattr__(self, name):  # K, config, project, base_T_camera, …: the wrapped camera's
        return getattr(self._camera, name)

    def render(self, q, t: float, boxes: bool = False):
        from dataclasses import replace

        from core.sim.realism import apply_realism

        frame = self._camera.render(q, t, boxes=boxes)
        rng = np.random.default_rng([self._seed, int(round(float(t) * 1e6)) & 0x7FFFFFFF, 27])
        return replace(frame, image=apply_realism(frame.image, rng, float(t), self.preset))


def summarise(results: list, mode: str, vibration: bool, tracker: bool, detector: str, wall_s: float,
              timing: Optional[dict] = None) -> dict:
    dist = [r.final_distance_mm for r in results if r.final_distance_mm is not None]
    ttt = [r.time_to_target_s for r in results if r.time_to_target_s is not None]
    total = [r.selection_s + r.time_to_target_s for r in results if r.time_to_target_s is not None]
    pct = (lambda xs, p: float(np.percentile(xs, p)) if xs else None)
    mean = (lambda xs: float(np.mean(xs)) if xs else None)
    depth_pct = [100 * abs(e) for r in results for e in r.depth_errors]
    depth_bias = [100 * e for r in results for e in r.depth_errors]
    outcomes: dict = {}
    for r in results:
        key = r.outcome.split(":")[0]
        outcomes[key] = outcomes.get(key, 0) + 1
    return {
        "mode": mode, "vibration": vibration, "tracker": tracker, "detector": detector, "trials": len(results),
        "success_rate": sum(r.success for r in results) / max(1, len(results)),
        "final_distance_mm_mean": mean(dist), "final_distance_mm_p95": pct(dist, 95),
        "time_to_target_s_mean": mean(ttt), "time_to_target_s_p95": pct(ttt, 95),
        "selection_s_mean": mean([r.selection_s for r in results]),
        "choice_to_press_total_s_mean": mean(total),
        "presses_mean": mean([r.presses for r in results]),
        "selections_wrong": sum(not r.selected_ok for r in results),
        "overtravel_mm_mean": mean([r.overtravel_mm for r in results if r.overtravel_mm is not None]),
        "wrong_button_pressed": sum(r.pressed_button is not None and r.pressed_button != r.button for r in results),
        "depth_error_pct_median": pct(depth_pct, 50), "depth_error_pct_p95": pct(depth_pct, 95),
        "depth_bias_pct_mean": mean(depth_bias),
        "outcomes": outcomes, "wall_s": round(wall_s, 2), **(timing or {}),
    }


def run_trials(n: int, mode: str = "touch", vibration: bool = False, tracker: bool = True, seed: int = 0,
               scan_period_s: float = 1.0, depth_source: str = "size", detector: str = "circles",
               realistic: bool = False) -> tuple[dict, list]:
    t0 = time.perf_counter()
    runner = AssistTrials(mode, vibration, tracker, seed, scan_period_s, depth_source, detector, realistic)
    results = [runner.run_trial(i) for i in range(n)]
    timed = runner.detector
    timing = {"detect_ms_per_call": round(1000 * timed.seconds / timed.calls, 2) if timed.calls else None,
              "loop_ms_per_frame": (round(1000 * runner.step_seconds / runner.step_frames, 2)
                                    if runner.step_frames else None)}
    summary = summarise(results, mode, vibration, tracker, runner.detector_name, time.perf_counter() - t0, timing)
    summary["depth"] = depth_source
    summary["realistic"] = bool(realistic)
    return summary, results


def run(command: str, argv: list[str]) -> int:
    """Entry point of ``deskarm assist-trials``."""
    args = build_parser().parse_args(argv)
    if not 1 <= args.n <= 10000:
        print(f"{PROG}: --n {args.n}: need 1…10000 trials", file=sys.stderr)
        return 2
    if not 0.5 <= args.scan_period <= 5.0:
        print(f"{PROG}: --scan-period {args.scan_period}: need 0.5…5 s", file=sys.stderr)
        return 2
    try:
        summary, results = run_trials(args.n, args.mode, args.vibration, not args.no_tracker, args.seed,
                                      args.scan_period, args.depth, args.detector, args.realistic)
    except FileNotFoundError as exc:  # the desk model's file is missing: its message names the fix
        print(f"{PROG}: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(summary))
    else:
        for key, value in summary.items():
            print(f"{key}: {round(value, 3) if isinstance(value, float) else value}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(run("assist-trials", sys.argv[1:]))
