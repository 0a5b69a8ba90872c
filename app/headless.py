"""The headless runner: the window's pipeline without a window, with metrics.

It drives the same core objects the workers drive (``DeskSession``): camera frames at the
camera rate, perception on each frame, targeting, and the control step that writes to the
motor bridge when the session's ``ControlSchedule`` says so (at once for each new goal, else
on the 50 Hz tick). With ``fast`` it runs on a simulated clock as fast as the machine
allows. No Qt is imported here.

A serial board that goes away does not end the run: the bridge is reconnected with the same
backoff as the window's bridge worker (``core.devices.reconnect.Reconnector``), and the summary
counts the losses (``bridge_disconnects``) and the time without a link (``disconnected_s``).
Per-frame samples are kept in bounded reservoirs, so a soak of any length has a flat memory.

On the simulated desk the run is scored against the ground truth by ``core.sim.scoring`` (markers,
following a marker, the cups game) and ``core.sim.object_scoring`` (marker-less objects), fed this
run's events (frames with their truth, perception results and goals; commands; joint states): the
same scores a recording or a remote run gets without this runner. Teleoperation and the settled
reach error are still scored here (they read the targeter's and the bridge's state).

With ``--record [PATH]`` the run is recorded (``core.record.Recorder``: a rosbag2 folder, MCAP):
every frame, perception result, command, joint state, e-stop change and camera→arm change is
handed to the recorder's thread without waiting; a failing disk stops the recording, not the run.
"""
from __future__ import annotations

import json
import math
import random
import sys
import time
from collections import deque
from dataclasses import dataclass, field, replace
from typing import Callable, Iterable, Optional

import numpy as np

from app.rtx_init import attach_status
from core.devices.bridge import BridgeError
from core.devices.reconnect import Reconnector
from core.messages import TargetMode
from core.session import DeskSession, SessionOptions, freeze_startup_objects
from core.sim.object_scoring import (  # noqa: F401 (label_matches, label_specificity: re-exported for the tests)
    ObjectFollowScore,
    detector_labels,
    label_matches,
    label_specificity,
    note_objects,
    object_follow_summary,
    objects_summary,
)
from core.sim.scoring import CommandEvent, FrameEvent, MarkerScore, TruthScore, percentile, rounded

MAX_SAMPLES = 20_000  # samples kept per metric: a p95 from this many is within ~0.3 percentile points
RECENT_PERCEPTION = 60  # frames behind the status line's perception figure (2 s at 30 fps)
RECENT_ERROR_3D = 120  # marker observations behind the status line's 3D error figure
TELEOP_SETTLE_S = 0.5  # teleop tracking is scored from this long after (re)entering FOLLOWING (the sprint there)
TELEOP_GESTURES = ("corner", "calibrate", "rejected", "end")  # the gesture events the JSON lists


def check_duration(duration_s) -> float:
    """``duration_s`` as a float, or ValueError naming ``--duration`` and the valid range."""
    try:
        value = float(duration_s)
    except (TypeError, ValueError):
        value = float("nan")
    if not math.isfinite(value) or value <= 0:
        raise ValueError(f"--duration {duration_s!r} is outside the valid range: a finite number of "
                         "seconds > 0 (e.g. --duration 10)")
    return value


class Reservoir(list):
    """At most ``capacity`` samples: every one until full, then a uniform random sample of all
    appended so far (reservoir sampling, algorithm R, with a fixed seed: runs are repeatable).

    A list, so whatever reads the samples (numpy, json, the bench) works unchanged, but bounded:
    percentiles stay accurate on a run of any length while memory stays flat. ``seen`` counts
    every sample appended; the order is not the order of arrival once full.
    """

    def __init__(self, capacity: int = MAX_SAMPLES, seed: int = 0):
        super().__init__()
        if capacity < 1:
            raise ValueError(f"capacity = {capacity}: expected ≥ 1")
        self.capacity = int(capacity)
        self.seen = 0
        self._rng = random.Random(seed)

    def append(self, value) -> None:
        self.seen += 1
        if len(self) < self.capacity:
            super().append(value)
            return
        j = self._rng.randrange(self.seen)
        if j < self.capacity:
            self[j] = value

    def extend(self, values: Iterable) -> None:
        for v in values:
            self.append(v)

    def __iadd__(self, values: Iterable) -> "Reservoir":
        self.extend(values)
        return self


@dataclass
class RunMetrics:
    """What the headless runner measures; ``summary()`` is the JSON object it prints."""

    scenario: str
    frames: int = 0
    # per-frame samples, bounded (MAX_SAMPLES each, read at creation); one seed per metric
    perception_ms: Reservoir = field(default_factory=lambda: Reservoir(MAX_SAMPLES, 1))  # computed frames (ms)
    latency_ms: Reservoir = field(default_factory=lambda: Reservoir(MAX_SAMPLES, 2))  # frame -> bytes (ms)
    # markers vs ground truth (core.sim.scoring): error_3d_mm (mm), visible_pairs, seen_pairs
    markers: MarkerScore = field(default_factory=lambda: MarkerScore(Reservoir(MAX_SAMPLES, 3)))
    reach_error_mm: Reservoir = field(default_factory=lambda: Reservoir(MAX_SAMPLES, 4))  # tip vs aim (mm)
    # tip vs where it should point by the ground truth (simulated desk): unlike the aim, this sees a
    # wrong camera→arm transform (the aim is computed through it)
    reach_error_true_mm: Reservoir = field(default_factory=lambda: Reservoir(MAX_SAMPLES, 5))
    recent_perception_ms: deque = field(default_factory=lambda: deque(maxlen=RECENT_PERCEPTION), repr=False)
    recent_error_3d_mm: deque = field(default_factory=lambda: deque(maxlen=RECENT_ERROR_3D), repr=False)
    commands_sent: int = 0
    limit_violations: int = 0
    unreachable_commands: int = 0
    wall_s: float = 0.0
    sim_s: float = 0.0
    full_searches: int = 0
    frames_reused: int = 0  # frames the source repeated, whose perception answer was reused
    event_steps: int = 0  # control steps run at once for a new goal
    tick_steps: int = 0  # control steps run on the 50 Hz tick
    bridge_disconnects: int = 0  # times the bridge's device went away during the run
    disconnected_s: float = 0.0  # total time without a bridge link (s)
    # marker-less objects (only with --detector: ``objects`` is True then)
    objects: bool = False
    object_perception_ms: Reservoir = field(default_factory=lambda: Reservoir(MAX_SAMPLES, 6))
    object_visible_pairs: int = 0  # (frame, truth object) pairs visible in both views by ground truth
    object_seen_pairs: int = 0  # of those, with an observation of its label within OBJECT_SEEN_M
    object_error_mm: dict = field(default_factory=dict)  # kind -> Reservoir (mm)
    object_id_switches: int = 0
    object_velocity_error_mm_s: Reservoir = field(default_factory=lambda: Reservoir(MAX_SAMPLES, 7))
    # truth objects moving at ≥ FAST_OBJECT_M_S: their 3D error alone (the skew compensation's case);
    # these object fields are those of core.sim.object_scoring.ObjectCounts, which counts into them
    object_error_fast_mm: Reservoir = field(default_factory=lambda: Reservoir(MAX_SAMPLES, 8))
    # following a marker-less object (--follow-object; ``following`` is True then)
    following: bool = False
    object_follow_error_mm: Reservoir = field(default_factory=lambda: Reservoir(MAX_SAMPLES, 9))
    object_stops: int = 0  # stopped events of the followed object
    object_approaches: int = 0  # cubic approaches planned (stops and re-plans)
    arrival_speed_mm_s: list = field(default_factory=list)  # tool speed at the end of each approach
    time_to_reach_stopped_s: list = field(default_factory=list)  # stopped event -> tool within REACHED_M
    # teleoperation (TargetMode.TELEOP with a teleop controller; ``teleop`` is True then), see teleop_summary
    teleop: bool = False
    teleop_tracking_mm: Reservoir = field(default_factory=lambda: Reservoir(MAX_SAMPLES, 10))
    teleop_target_error_mm: Reservoir = field(default_factory=lambda: Reservoir(MAX_SAMPLES, 11))
    teleop_speed_limited_samples: int = 0  # tracking samples skipped: the true mapped target outran the limit
    teleop_hold_command_mm_max: float = 0.0  # commands while holding: max tool displacement they ask for
    teleop_hold_tool_mm_max: float = 0.0  # the tool's drift while holding (finishing its last step included)
    teleop_hold_commands: int = 0
    teleop_valid_goals_after_end: int = 0
    teleop_corner_error_mm: list = field(default_factory=list)  # calibrated hand box corners vs the true ones
    gesture_events: list = field(default_factory=list)  # {event, t_detected, t_true}
    teleop_state_s: dict = field(default_factory=dict)
    # scorers against the simulated desk's truth (core.sim.scoring), only when frames carried truth
    truth_scores: list = field(default_factory=list)

    def object_error(self, kind: str) -> Reservoir:
        """The error reservoir of one kind of object (created on first use, its own seed)."""
        if kind not in self.object_error_mm:
            self.object_error_mm[kind] = Reservoir(MAX_SAMPLES, 100 + len(self.object_error_mm))
        return self.object_error_mm[kind]

    @property
    def error_3d_mm(self) -> Reservoir:
        """The markers' 3D errors vs the ground truth (mm)."""
        return self.markers.errors_mm

    @property
    def visible_pairs(self) -> int:
        """(frame, marker) pairs visible in both views by the ground truth."""
        return self.markers.visible_pairs

    @property
    def seen_pairs(self) -> int:
        """Of those, how many perception found."""
        return self.markers.seen_pairs

    def object_summary(self) -> dict:
        """The marker-less objects' part of the JSON (empty without --detector)."""
        if not self.objects:
            return {}
        return {"object_perception_ms_p50": rounded(percentile(self.object_perception_ms, 50)),
                **objects_summary(self), **self.follow_summary()}

    def follow_summary(self) -> dict:
        """The object-following part of the JSON (empty unless --follow-object)."""
        return object_follow_summary(self) if self.following else {}

    def summary(self) -> dict:
        return {
            "scenario": self.scenario,
            "frames": self.frames,
            "fps": rounded(self.frames / self.wall_s if self.wall_s > 0 else 0.0, 2),
            "perception_ms_p50": rounded(percentile(self.perception_ms, 50)),
            "perception_ms_p95": rounded(percentile(self.perception_ms, 95)),
            "latency_ms_p50": rounded(percentile(self.latency_ms, 50)),
            "latency_ms_p95": rounded(percentile(self.latency_ms, 95)),
            **self.markers.summary(),  # error_3d_mm_p50/p95, markers_seen_ratio
            "commands_sent": self.commands_sent,
            "limit_violations": self.limit_violations,
            "reach_error_mm_p50": rounded(percentile(self.reach_error_mm, 50)),
            "reach_error_true_mm_p50": rounded(percentile(self.reach_error_true_mm, 50)),
            "unreachable_commands": self.unreachable_commands,
            "full_frame_searches": self.full_searches,
            "frames_reused": self.frames_reused,
            "control_steps_event": self.event_steps,
            "control_steps_tick": self.tick_steps,
            "duration_s": rounded(self.sim_s, 2),
            "bridge_disconnects": self.bridge_disconnects,
            "disconnected_s": rounded(self.disconnected_s),
            **self.object_summary(),
            **self.teleop_summary(),
            **{k: v for score in self.truth_scores for k, v in score.summary().items()},
        }

    def teleop_summary(self) -> dict:
        """The teleoperation part of the JSON (empty unless TELEOP mode drives the arm).

        ``teleop_tracking_mm_p50/p95``: the tool (FK of the measured joints, at each control step)
        against the mapped TRUE hand target — the true wristband position (the frame's truth carried
        to the step's time with its true velocity) through the calibrated mapping (without its dead
        zone, smoothing and speed limit) — while FOLLOWING, TELEOP_SETTLE_S after entering it, with
        the band visible in both views; samples whose true mapped target moved faster than the
        mapping's speed limit are left out (``teleop_speed_limited_samples``: by design the arm lags
        there). ``teleop_target_error_mm_p50``: the goal handed to the control step vs the mapped
        true hand at the frame's time (perception + filtering alone). ``teleop_hold_*``: while
        HOLDING or ENDED, how far the commands ask the tool to move from where it was commanded when
        the hold began (0: no command moves it), and how far the tool drifts.
        """
        if not self.teleop:
            return {}

        return {
            "teleop_tracking_mm_p50": rounded(percentile(self.teleop_tracking_mm, 50)),
            "teleop_tracking_mm_p95": rounded(percentile(self.teleop_tracking_mm, 95)),
            "teleop_tracking_samples": self.teleop_tracking_mm.seen,
            "teleop_speed_limited_samples": self.teleop_speed_limited_samples,
            "teleop_target_error_mm_p50": rounded(percentile(self.teleop_target_error_mm, 50)),
            "teleop_target_error_mm_p95": rounded(percentile(self.teleop_target_error_mm, 95)),
            "teleop_corner_error_mm": [rounded(v) for v in self.teleop_corner_error_mm],
            "teleop_hold_commands": self.teleop_hold_commands,
            "teleop_hold_command_mm_max": rounded(self.teleop_hold_command_mm_max),
            "teleop_hold_tool_mm_max": rounded(self.teleop_hold_tool_mm_max),
            "teleop_valid_goals_after_end": self.teleop_valid_goals_after_end,
            "gesture_events": list(self.gesture_events),
            "teleop_state_s": {k: rounded(v, 2) for k, v in self.teleop_state_s.items()},
        }


def servo_deg_outside_limits(servo_deg, profile) -> bool:
    """An independent check of what was written (never trusts the clamp it checks)."""
    for d, j in zip(servo_deg, profile.joints):
        if not (0 <= d <= 180) or d < math.floor(j.servo_min_deg + 1e-9) or d > math.ceil(j.servo_max_deg - 1e-9):
            return True
    return False


def command_outside_limits(sent, cmd, bridge, profile) -> bool:
    """Did what the bridge sent leave a joint's limits? Servo arms: the servo degrees written;
    other arms: the joint values the bridge commanded."""
    if getattr(profile, "has_servos", True):
        return servo_deg_outside_limits(sent, profile)
    from core.motion.safety import is_within_limits

    q_sent = getattr(bridge, "last_sent_q", None) or cmd.q
    return not is_within_limits(q_sent, profile)


class HeadlessRunner:
    """Runs a DeskSession for ``duration`` seconds and collects RunMetrics."""

    def __init__(self, session: DeskSession, duration_s: float, status: Callable[[str], None] | None = None,
                 recorder=None):
        self.s = session
        self.recorder = recorder  # a started core.record.Recorder, or None
        self.duration_s = check_duration(duration_s)
        self.status = status or (lambda line: None)
        self.metrics = RunMetrics(scenario=session.options.scenario)
        self._goal = None
        self._cmd_source_wall: dict[int, float] = {}
        self._last_target = None
        self._target_since = 0.0
        self._last_truth = None  # ground truth of the latest frame (simulated sources)
        self.schedule = None
        # the window's backoff (0.5 s … 5 s), on the session's clock (simulated with --fast)
        self.reconnector = Reconnector(now=session.clock.now)
        self._recorded_base_T_camera = session.perception.base_T_camera
        self.metrics.objects = session.object_perception is not None
        self.metrics.following = session.targeter.mode is TargetMode.OBJECT
        self._object_labels = detector_labels(session.object_perception)
        self._object_ids: dict[tuple, int] = {}  # (truth id, label) -> object_id of its last matched observation
        self._object_truth_prev: dict[int, tuple[float, np.ndarray]] = {}  # truth id -> (t, position)
        aim = lambda p: session.targeter.pointing.apply(p)  # noqa: E731 (the targeter's rule at the time)
        self.object_follow = ObjectFollowScore(session.kinematics, aim, self.metrics) if self.metrics.following else None
        self._last_result = None
        # teleoperation: the hand's truth, the state at the last step, where the hold began
        self.metrics.teleop = session.targeter.mode is TargetMode.TELEOP and session.targeter.teleop is not None
        self._teleop_truth: Optional[tuple] = None  # (t, band position, velocity, visible in both views)
        self._teleop_state = ""
        self._teleop_following_since: Optional[float] = None
        self._teleop_hold_ref: Optional[tuple] = None  # (commanded tool point, measured tool point) at hold start
        self._teleop_last_cmd_p: Optional[np.ndarray] = None
        self._teleop_events_seen = 0
        # why the camera gave nothing, read before the session closes it (its status, else "")
        self.camera_status = ""
        self.camera_connected = False
        # scored against the truth (core.sim.scoring) from this run's events: the markers, following
        # a marker, the cups game's choice — the same scores a recording of the run gets
        self.truth = TruthScore.for_targeter(session.kinematics, session.targeter, markers=self.metrics.markers,
                                             follow_samples=Reservoir(MAX_SAMPLES, 12))

    def run(self) -> RunMetrics:
        s, m = self.s, self.metrics
        clock = s.clock
        attach_status(s.bridge, self.status)  # an RTX says its initialisation (?init=auto) on stderr
        s.bridge.connect()  # a board missing at the start is an error (one line), not a wait
        self.reconnector.ensure(s.bridge)
        schedule = self.schedule = s.control_schedule()
        state = s.bridge.joint_state()
        if state is not None and hasattr(s.camera, "set_arm_points"):
            s.camera.set_arm_points(s.kinematics.chain_points(state.q))
        t0 = clock.now()
        wall0 = time.perf_counter()
        next_status = t0 + 1.0
        pending_latency: list[tuple[float, float]] = []  # (frame t, processing wall s)
        try:
            while clock.now() - t0 < self.duration_s:
                # control steps that fall before the next camera frame run first (time order)
                next_frame = getattr(s.camera, "next_frame_t", None)
                due = schedule.next_due(clock.now(), next_frame)
                if next_frame is not None and due < next_frame:
                    clock.wait_until(due)
                    self._control_step(pending_latency)
                    continue
                frame = s.camera.read()
                if frame is None:
                    if getattr(s.camera, "finished", False):
                        break  # a replay ends with its recording, not with --duration
                    continue
                w0 = time.perf_counter()
                result = s.perception.process(frame)
                if s.targeter.mode is TargetMode.CUPS:
                    result = replace(result, ball_left_px=s.ball_finder.find(frame.left))
                objects = None
                if s.object_perception is not None:  # marker-less objects, before targeting sees the result
                    w1 = time.perf_counter()
                    objects = s.object_perception.process(frame)
                    m.object_perception_ms.append((time.perf_counter() - w1) * 1e3)
                    result = replace(result, objects=tuple(objects))
                if self.recorder is not None:
                    self._record_frame(frame, result)
                self._last_result = result
                self._goal = s.targeter.update(result)
                processing = time.perf_counter() - w0
                pending_latency.append((frame.t, processing if clock.simulated else 0.0))
                self._score_frame(frame, result)
                m.recent_error_3d_mm.extend(self.truth.note(FrameEvent.of(frame, result, self._goal)))
                if objects is not None:
                    self._score_objects(frame, objects)
                if m.following:
                    self._note_followed(frame)
                if m.teleop:
                    self._note_teleop(frame)
                schedule.goal_arrived(clock.now())  # a new perception result: step at once
                # event-driven: this frame's step now; tick-driven (or real cameras): any ticks due
                while schedule.due(clock.now()):
                    self._control_step(pending_latency)
                if clock.now() >= next_status:
                    next_status += 1.0
                    self.status(self._status_line(clock.now() - t0))
        finally:
            m.wall_s = time.perf_counter() - wall0
            m.sim_s = clock.now() - t0
            m.event_steps, m.tick_steps = schedule.event_steps, schedule.tick_steps
            m.bridge_disconnects = self.reconnector.disconnects
            m.disconnected_s = self.reconnector.disconnected_s()
            m.truth_scores = self.truth.scores()
            self.camera_status = str(getattr(s.camera, "status_message", "") or "")
            self.camera_connected = bool(getattr(s.camera, "is_connected", False))
            s.close()
        return m

    def _control_step(self, pending_latency) -> None:
        s, m = self.s, self.metrics
        now = s.clock.now()
        self.schedule.ran(now)
        try:
            state = s.bridge.joint_state() if self.reconnector.ensure(s.bridge) else None
        except BridgeError as exc:
            self.reconnector.lost(s.bridge, exc)  # leaves it disconnected
            state = None
        if not s.bridge.is_connected:
            pending_latency.clear()  # frames while the board is away lead to no bytes
            return
        # no joint state yet (v1 has none before its first command): start from the last
        # command, else from home, as the window's control worker does
        q_now = s.controller.start_pose(state)
        if s.targeter.mode is TargetMode.OBJECT:
            # the follower's lead time and approaches start from the tool; like the window's control
            # worker, each step asks for a fresh goal (an approach is a trajectory in time)
            s.targeter.set_tool_position(s.kinematics.fk(q_now))
            if self._last_result is not None:
                self._goal = s.targeter.update(self._last_result)
        w0 = time.perf_counter()
        cmd = s.controller.step(self._goal, q_now, now)
        if cmd is None:
            # nothing to write (no goal yet, e-stopped): these frames led to no bytes, they have
            # no frame -> bytes latency (counted before, they showed the wait for the first goal)
            pending_latency.clear()
            return
        try:
            sent = s.bridge.send(cmd)
        except BridgeError as exc:  # the board went away: reconnect on a later step
            self.reconnector.lost(s.bridge, exc)
            pending_latency.clear()
            return
        ctrl_wall = time.perf_counter() - w0
        if self.recorder is not None:
            self.recorder.command(cmd, self._goal)
        m.commands_sent += 1
        self.truth.note(CommandEvent(now, tuple(cmd.q), tuple(q_now)))
        if command_outside_limits(sent, cmd, s.bridge, s.profile):
            m.limit_violations += 1
        if not cmd.reachable:
            m.unreachable_commands += 1
        if pending_latency:
            # the first command after a frame carries that frame's goal
            for frame_t, processing in pending_latency:
                m.latency_ms.append((s.clock.now() - frame_t + processing + (ctrl_wall if s.clock.simulated else 0.0)) * 1e3)
            pending_latency.clear()
        try:
            state = s.bridge.joint_state()
        except BridgeError as exc:
            self.reconnector.lost(s.bridge, exc)
            return
        if hasattr(s.camera, "set_arm_points") and state is not None:
            s.camera.set_arm_points(s.kinematics.chain_points(state.q))
        if self.recorder is not None:
            self.recorder.state(state)
        self._score_reach(cmd, state)
        if m.teleop:
            self._score_teleop(cmd, state, s.clock.now())
        if m.following and state is not None:
            self.object_follow.note_step(s.clock.now(), state.q, s.targeter.object_follow_status())

    def _record_frame(self, frame, result) -> None:
        """Hand this frame's messages to the recorder (queue puts: nothing waits for the disk)."""
        rec, s = self.recorder, self.s
        rec.frame(frame)
        rec.result(result)
        rec.estop(s.bridge.is_estopped)
        base_T_camera = s.perception.base_T_camera
        if base_T_camera is not self._recorded_base_T_camera:  # replaced (hand-eye): a new /tf_static
            if not np.array_equal(base_T_camera, self._recorded_base_T_camera):
                rec.calibration(base_T_camera=base_T_camera)
            self._recorded_base_T_camera = base_T_camera

    def _score_frame(self, frame, result) -> None:
        m = self.metrics
        m.frames += 1
        if result.reused:  # a repeated frame: nothing was computed, nothing to time
            m.frames_reused += 1
        else:
            m.perception_ms.append(result.timings_ms["total"])
            m.recent_perception_ms.append(result.timings_ms["total"])
        m.full_searches += int(result.full_frame_search)
        self._last_truth = frame.truth  # the markers are scored against it by self.truth

    def _score_objects(self, frame, observations) -> None:
        """Score the marker-less objects of one frame against its ground truth (simulated desk):
        ``core.sim.object_scoring.note_objects`` with this run's detector labels and state."""
        note_objects(self.metrics, frame.t, frame.truth, observations, self._object_labels, self._object_ids,
                     self._object_truth_prev)

    def _note_followed(self, frame) -> None:
        """The followed object's truth and the follower's status, for the follow error at the steps."""
        if frame.truth is not None:
            self.object_follow.note_frame(frame.t, frame.truth, self.s.targeter.object_follow_status())

    def _teleop_scene(self):
        """(scenario, scenario time offset) of a simulated teleop desk, or (None, 0)."""
        desk = getattr(self.s.camera, "desk", None)
        scenario = getattr(desk, "scenario_object", None)
        if scenario is None or not hasattr(scenario, "gesture_times"):
            return None, 0.0
        return scenario, float(getattr(self.s.camera, "_t0", 0.0))

    def _note_teleop(self, frame) -> None:
        """Per frame: the hand's truth (for the step's tracking error), the goal vs the mapped truth,
        new gesture events (with their true times), goals after the end."""
        s, m = self.s, self.metrics
        teleop = s.targeter.teleop
        status = s.targeter.teleop_status()
        m.teleop_state_s = dict(status.state_s)
        marker_id = getattr(getattr(teleop, "source", None), "marker_id", None)
        truth = frame.truth
        obj = None if truth is None or marker_id is None else truth.by_id().get(marker_id)
        if obj is not None:
            t = float(frame.t)
            p = np.asarray(obj.base_p_centre, float)
            prev = self._teleop_truth
            v = np.zeros(3) if prev is None or t - prev[0] <= 1e-6 else (p - prev[1]) / (t - prev[0])
            self._teleop_truth = (t, p, v, bool(obj.visible_left and obj.visible_right))
        goal = self._goal
        if status.state == "ended" and goal is not None and goal.valid:
            m.teleop_valid_goals_after_end += 1
        mapping = getattr(teleop, "mapping", None)  # a keyboard source has none
        if (goal is not None and goal.valid and mapping is not None and self._teleop_truth is not None
                and self._teleop_truth[3]):
            true_target = mapping.map(self._teleop_truth[1])
            m.teleop_target_error_mm.append(float(np.linalg.norm(np.asarray(goal.base_p_target) - true_target)) * 1e3)
        scenario, t0 = self._teleop_scene()
        true_times = scenario.gesture_times() if scenario is not None else {}
        for ev in status.events[self._teleop_events_seen:]:
            if ev.event not in TELEOP_GESTURES:
                continue
            t_true = true_times.get(ev.event)
            m.gesture_events.append({"event": ev.event, "t_detected": round(ev.t - t0, 3),
                                     "t_true": None if t_true is None else round(t_true, 3),
                                     "message": ev.message})
            if ev.event == "calibrate" and scenario is not None and status.hand_box is not None:
                a, b = (np.asarray(c) for c in scenario.corners())
                true_box = np.array([np.minimum(a, b), np.maximum(a, b)])
                got = np.array([status.hand_box.lo, status.hand_box.hi])
                m.teleop_corner_error_mm = [float(np.linalg.norm(got[i] - true_box[i])) * 1e3 for i in range(2)]
        self._teleop_events_seen = len(status.events)

    def _score_teleop(self, cmd, state, now: float) -> None:
        """Per control step: tracking error while following, and that holding commands keep still."""
        s, m = self.s, self.metrics
        teleop = s.targeter.teleop
        status = teleop.status()
        m.teleop_state_s = dict(status.state_s)
        cmd_p = np.asarray(s.kinematics.fk(cmd.q), float)
        tool = None if state is None else np.asarray(s.kinematics.fk(state.q), float)
        if status.state != self._teleop_state:
            if status.state == "following":
                self._teleop_following_since = now
            if status.state in ("holding", "ended") and self._teleop_state not in ("holding", "ended"):
                ref_cmd = self._teleop_last_cmd_p if self._teleop_last_cmd_p is not None else cmd_p
                self._teleop_hold_ref = (ref_cmd, tool)
            self._teleop_state = status.state
        if status.state in ("holding", "ended") and self._teleop_hold_ref is not None:
            ref_cmd, ref_tool = self._teleop_hold_ref
            m.teleop_hold_commands += 1
            m.teleop_hold_command_mm_max = max(m.teleop_hold_command_mm_max,
                                               float(np.linalg.norm(cmd_p - ref_cmd)) * 1e3)
            if tool is not None and ref_tool is not None:
                m.teleop_hold_tool_mm_max = max(m.teleop_hold_tool_mm_max,
                                                float(np.linalg.norm(tool - ref_tool)) * 1e3)
        self._teleop_last_cmd_p = cmd_p
        truth, mapping = self._teleop_truth, getattr(teleop, "mapping", None)
        if (status.state != "following" or mapping is None or truth is None or not truth[3] or tool is None
                or self._teleop_following_since is None or now - self._teleop_following_since < TELEOP_SETTLE_S):
            return
        t_truth, p_truth, v_truth, _ = truth
        true_target = mapping.map(p_truth + v_truth * (now - t_truth))
        # how fast the mapped true target moves: the hand's velocity through the map's per-axis scale
        scale = mapping.target_box.extent / np.where(mapping.hand_box.extent > 0, mapping.hand_box.extent, 1.0)
        if float(np.linalg.norm(v_truth * scale)) > mapping.params.max_speed_m_s:
            m.teleop_speed_limited_samples += 1
            return
        m.teleop_tracking_mm.append(float(np.linalg.norm(tool - true_target)) * 1e3)

    def _score_reach(self, cmd, state) -> None:
        """Tool tip vs aimed point, once the arm has settled on a goal that stopped moving."""
        s, m = self.s, self.metrics
        goal = self._goal
        if goal is None or not goal.valid or goal.mode not in (TargetMode.FOLLOW, TargetMode.CUPS):
            return
        if not cmd.reachable or state is None or not state.measured:
            return
        target = np.asarray(goal.base_p_target)
        now = s.clock.now()
        if self._last_target is None or np.linalg.norm(target - self._last_target) > 0.002:
            self._last_target, self._target_since = target, now
            return
        settled = getattr(s.bridge, "is_settled", lambda: False)()
        if settled and now - self._target_since > 0.5:
            tip = np.asarray(s.kinematics.fk(state.q))
            m.reach_error_mm.append(float(np.linalg.norm(tip - np.asarray(cmd.base_p_target))) * 1e3)
            true_aim = self._true_aim(goal)
            if true_aim is not None:
                m.reach_error_true_mm.append(float(np.linalg.norm(tip - true_aim)) * 1e3)

    def _true_aim(self, goal) -> Optional[np.ndarray]:
        """Where the tool should be by the ground truth: the pointing position of the marker the goal
        follows, at its true place (None without truth or for an out-of-reach aim)."""
        truth, targeter = self._last_truth, self.s.targeter
        marker_id = targeter.follow_id if goal.mode is TargetMode.FOLLOW else targeter.ball_cup_id
        if truth is None or marker_id is None:
            return None
        obj = next((o for o in truth.objects if o.marker_id == marker_id), None)
        if obj is None:
            return None
        aim = np.asarray(targeter.pointing.apply(obj.base_p_centre))
        ik = self.s.kinematics.ik(tuple(aim))
        return aim if ik.reachable else None

    def _status_line(self, elapsed: float) -> str:
        m = self.metrics
        p = percentile(m.recent_perception_ms, 50)
        e = percentile(m.recent_error_3d_mm, 50)
        seen = m.seen_pairs / m.visible_pairs if m.visible_pairs else 0.0
        goal = self._goal
        note = f" goal: {goal.note}" if goal is not None and goal.note else ""
        if self.reconnector.disconnects:
            note += f" bridge-disconnects={self.reconnector.disconnects}"
        if not self.s.bridge.is_connected:
            note += f" bridge: {self.s.bridge.message or 'not connected'}"
        return (
            f"t={elapsed:5.1f}s frames={m.frames} perception={p or 0:.2f}ms "
            f"3d-error={e or 0:.2f}mm seen={seen:.0%} commands={m.commands_sent} "
            f"limit-violations={m.limit_violations}{note}"
        )


def run_headless(options: SessionOptions, duration_s: float, as_json: bool, out=None, record=None, err=None) -> int:
    """Entry point of ``deskarm --headless``; returns the process exit code.

    The result alone goes to ``out`` (default stdout): the JSON object with ``as_json`` (so
    ``deskarm --headless --json | python -m json.tool`` works), else the one ``done:`` line
    (and ``recorded:``). Everything else — banners, the once-a-second status, the recording's
    problems, why a run failed — goes to ``err``: stderr by default, or ``out`` when only ``out``
    is given (one stream holding everything in order, for a caller that reads it all).

    Exit code 1 when the run saw nothing (no camera frame at all: a camera that never opened, a
    remote desk that never answered), after one line on ``err`` saying why; the JSON is still
    printed. ``record``: None (no recording), True or "" (a new folder under the recordings folder)
    or a path (a new rosbag2 folder there). Following an object (``options.follow_object``),
    intercept and skew compensation are session options."""
    if err is None:
        err = out if out is not None else sys.stderr
    out = out or sys.stdout
    duration_s = check_duration(duration_s)  # before any device is opened
    session = DeskSession.create(options)
    recorder = None
    if record is not None and record is not False:
        from core.record.recorder import Recorder

        try:
            recorder = Recorder.for_session(session, None if record in (True, "") else record)
            recorder.start(session.calibration, session.perception.base_T_camera, session.bridge.is_estopped)
        except (OSError, ValueError):
            session.close()
            raise
        print(f"deskarm: recording to {recorder.path}", file=err)
    for banner in session.banners:
        print(f"deskarm: {banner}", file=err)
    mode = "as fast as possible (simulated clock)" if options.simulated_clock else f"paced at {options.fps:g} fps"
    print(
        f"deskarm headless: camera {session.camera.name}, bridge {session.bridge.url}, "
        f"robot {session.profile.name}, scenario {options.scenario}, {duration_s:g} s {mode}",
        file=err, flush=True,
    )
    runner = HeadlessRunner(session, duration_s, status=lambda line: print(line, file=err, flush=True),
                            recorder=recorder)
    freeze_startup_objects()
    try:
        metrics = runner.run()
    finally:
        if recorder is not None:
            recorder.close()
    summary = metrics.summary()
    if recorder is not None:
        summary.update(record_summary(recorder))
        if recorder.error:
            print(f"deskarm: {recorder.error}", file=err, flush=True)
    if as_json:
        print(json.dumps(summary), file=out, flush=True)
    else:
        print(
            f"done: {summary['frames']} frames, {summary['fps']} fps, perception p50 "
            f"{summary['perception_ms_p50']} ms, 3D error p50 {summary['error_3d_mm_p50']} mm, "
            f"limit violations {summary['limit_violations']}",
            file=out,
        )
        if recorder is not None:
            print(f"recorded: {summary['record_path']}, {summary['frames_recorded']} frames "
                  f"({summary['frames_dropped']} dropped), {summary['record_mb']} MB", file=out)
    if metrics.frames == 0:
        print(f"deskarm: {saw_nothing(session.camera.name, metrics.sim_s, runner.camera_status, runner.camera_connected, duration_s)}",
              file=err, flush=True)
        return 1
    return 0


def saw_nothing(camera_name: str, seconds: float, status: str = "", connected: bool = False,
                duration_s: Optional[float] = None) -> str:
    """The line a run that received no camera frame ends with: which camera, for how long, why
    (the camera's status; an open camera with nothing to say: a run shorter than its first frame)."""
    head = f"the run saw nothing: {camera_name} gave no frame in {seconds:.1f} s"
    if connected and not status and duration_s is not None:
        return f"{head} (it was open: --duration {duration_s:g} s may be shorter than its first frame)"
    return f"{head} ({status or 'it delivered nothing'}) — check the camera (--camera) and try again"


def record_summary(recorder) -> dict:
    """The recording's part of the headless JSON (after ``recorder.close()``)."""
    from core.record.recorder import folder_size

    return {
        "record_path": str(recorder.path),
        "frames_recorded": recorder.frames_written,
        "frames_dropped": recorder.frames_dropped,
        "record_mb": round(folder_size(recorder.path) / 1e6, 3),
        "record_error": recorder.error or None,
    }
