"""The three QThread workers: perception, kinematics/control (50 Hz) and the motor bridge.

Each is a thin loop around Qt-free core objects from a ``DeskSession``. Workers talk to the GUI
only through signals carrying frozen core messages; between workers they pass only the latest
value through a ``Latest`` slot (no unbounded queues). Every worker stops and joins on ``stop()``.

Signals (all emitted from the worker's own thread, received queued in the GUI thread):
- PerceptionWorker.sigResult(PerceptionResult) — one per camera frame
- PerceptionWorker.sigError(str) — camera stopped delivering frames ("" once frames are back)
- PerceptionWorker.sigHealth(HealthStatus) — the calibration health changed (drifted or back to
  fine; while drifted at most once a second with the new numbers)
- PerceptionWorker.sigControls(list[CameraControl]) — the camera's image controls with their
  ranges and values, after the first frame, after a replug and on request
- PerceptionWorker.sigControlApplied(CameraControl) — a requested control as the device took it
  (clamped); sigControlError(str) when it refused
- PerceptionWorker.sigCalibrationApplied(StereoCalibration) — a new calibration is in use
- PerceptionWorker.sigDetectorsApplied(list[tuple[str, params]]) — the marker-less object
  detectors now in use (their frozen settings), by the name they were requested with (after a request, or after one
  failed and was turned off); an empty list: object perception is off
- PerceptionWorker.sigDetectorError(str) — a detector could not be built or raised while
  detecting (it is left out; the others keep running)
- ControlWorker.sigCommand(JointCommand, Goal) — one per control tick that produced a command
- BridgeWorker.sigState(JointState) — after each write (and at 10 Hz while idle)
- BridgeWorker.sigStatus(BridgeStatus) — connection state, about 2 Hz
"""
from __future__ import annotations

import threading
import time
from dataclasses import replace
from typing import Generic, Optional, TypeVar

from PySide6 import QtCore

from core.detect.registry import make_detector
from core.detect.stereo import StereoObjectPerception
from core.devices.bridge import BridgeError
from core.devices.reconnect import Reconnector
from core.messages import TargetMode
from core.motion.schedule import rate_cap_interval
from core.session import DeskSession, object_perception_options
from core.settings import SgbmParams, StereoMatchParams
from core.vision.calibration_health import CalibrationHealth
from core.vision.cameras import CameraError
from core.vision.disparity import DisparityComputer
from core.vision.perception import StereoMarkerPerception

HEALTH_REPEAT_S = 1.0  # while drifted, the banner's numbers are refreshed at most this often

DetectorSpec = tuple  # (registry name, {settings field: value}) as the detector panel asks for one


class GuardedDetector:
    """A detector whose ``detect`` never raises: a failure is kept in ``error`` and yields no
    detections, so one bad detector (a broken ONNX model, an out-of-memory) costs only itself —
    the perception worker reports it and turns that detector off instead of dying."""

    def __init__(self, detector, spec_name: str):
        self.inner = detector
        self.spec_name = spec_name  # the name it was requested with ("hsv", "onnx:/path/model.onnx")
        self.name = getattr(detector, "name", spec_name)
        self.error: Optional[str] = None

    @property
    def params(self):
        return self.inner.params

    @property
    def heavy(self) -> bool:
        return bool(getattr(self.inner, "heavy", False))

    def with_params(self, **changes) -> "GuardedDetector":
        return GuardedDetector(self.inner.with_params(**changes), self.spec_name)

    def detect(self, image_bgr, roi=None):
        if self.error is not None:
            return []
        try:
            return self.inner.detect(image_bgr, roi)
        except Exception as exc:  # noqa: BLE001 - any failure of a user's model must not kill the worker
            self.error = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
            return []


def new_object_perception(session: DeskSession, calibration, base_T_camera, detectors) -> StereoObjectPerception:
    """An object perception as the session builds one: with the options its command line chose
    (tracker, ROI search, skew compensation: ``object_perception_options``) and these detectors."""
    return StereoObjectPerception(calibration, base_T_camera, detectors, **object_perception_options(session.options))


def build_detector(spec_name: str, options: dict, current=None):
    """The detector ``spec_name`` with the settings ``options`` (fields of its params that it
    lacks are ignored): ``current`` changed by ``with_params`` when given (an ONNX model keeps
    its loaded network when only thresholds change), else a new one from the registry."""
    detector = current if current is not None else make_detector(spec_name)
    params = detector.params
    changes = {k: v for k, v in options.items() if hasattr(params, k) and getattr(params, k) != v}
    return detector.with_params(**changes) if changes else detector

T = TypeVar("T")


class Latest(Generic[T]):
    """A one-value mailbox: ``put`` replaces, ``take`` returns the newest (waits until one arrives)."""

    def __init__(self) -> None:
        self._value: Optional[T] = None
        self._version = 0
        self._cond = threading.Condition()

    def put(self, value: T) -> None:
        with self._cond:
            self._value = value
            self._version += 1
            self._cond.notify_all()

    def peek(self) -> Optional[T]:
        with self._cond:
            return self._value

    def wait_newer(self, version: int, timeout: float) -> tuple[Optional[T], int]:
        """The value once its version exceeds ``version`` (or the current one after ``timeout``)."""
        with self._cond:
            self._cond.wait_for(lambda: self._version > version, timeout=timeout)
            return self._value, self._version

    def wake(self) -> None:
        """Wake a waiter without a new value (it then re-checks its stop flag)."""
        with self._cond:
            self._cond.notify_all()


class _LoopThread(QtCore.QThread):
    """A QThread running ``loop_once`` until ``stop()``."""

    def __init__(self, name: str, parent=None):
        super().__init__(parent)
        self.setObjectName(name)
        self._running = threading.Event()

    def start(self, *args) -> None:  # noqa: D102
        self._running.set()
        super().start(*args)

    @property
    def running(self) -> bool:
        return self._running.is_set()

    def stop(self) -> None:
        """Ask the loop to end, wake it, and join the thread."""
        self._running.clear()
        self.wake()
        if not self.wait(5000):
            # never leave a running QThread behind (it aborts the interpreter at exit)
            self.terminate()
            self.wait()

    def wake(self) -> None:
        """Interrupt a blocking wait in the loop."""

    def run(self) -> None:  # noqa: D102 (QThread override)
        while self._running.is_set():
            self.loop_once()

    def loop_once(self) -> None:
        raise NotImplementedError


class PerceptionWorker(_LoopThread):
    """Camera -> perception (-> disparity while shown, -> ball finder in the cups game).

    Settings from the GUI (camera settings and controls, stereo parameters, a new calibration)
    are left as pending requests under one lock and applied here between frames: a device may
    block for a frame while it takes a control, and the calibration swap must not race a compute.
    """

    sigResult = QtCore.Signal(object)
    sigError = QtCore.Signal(str)
    sigHealth = QtCore.Signal(object)
    sigControls = QtCore.Signal(object)
    sigControlApplied = QtCore.Signal(object)
    sigControlError = QtCore.Signal(str)
    sigCalibrationApplied = QtCore.Signal(object)
    sigDetectorsApplied = QtCore.Signal(object)
    sigDetectorError = QtCore.Signal(str)

    def __init__(self, session: DeskSession, results: Latest, parent=None):
        super().__init__("perception", parent)
        self.session = session
        self.results = results
        self.disparity = DisparityComputer(session.calibration)
        self.health = CalibrationHealth()
        self._want_disparity = threading.Event()
        self._settings_lock = threading.Lock()
        self._pending_settings = None
        self._pending_controls: dict[str, tuple[str, float]] = {}  # name -> ("value" | "auto", value)
        self._pending_stereo: Optional[tuple[Optional[SgbmParams], Optional[StereoMatchParams]]] = None
        self._pending_calibration = None
        self._pending_detectors: Optional[list[DetectorSpec]] = None  # None: no request
        self._want_controls = True  # read them once frames arrive
        self._error_reported = ""  # the camera problem last reported ("" = none)
        self._health_drifted = False
        self._health_sent_t = 0.0
        self.on_result = None  # called (in this thread) after each result is published
        if session.object_perception is not None:  # --detector: guard what the session built
            op = session.object_perception
            op.detectors = [d if isinstance(d, GuardedDetector) else GuardedDetector(d, name)
                            for d, name in zip(op.detectors, session.options.detectors)]

    def set_disparity_enabled(self, enabled: bool) -> None:
        if enabled:
            self._want_disparity.set()
        else:
            self._want_disparity.clear()

    def set_sgbm_params(self, params: SgbmParams) -> None:
        """New block-matching parameters (applied before the next frame)."""
        self.set_stereo_params(params, None)

    def set_match_params(self, match: StereoMatchParams) -> None:
        """New matcher / WLS / resolution choice (applied before the next frame)."""
        self.set_stereo_params(None, match)

    def set_stereo_params(self, params: Optional[SgbmParams], match: Optional[StereoMatchParams]) -> None:
        """Either or both stereo parameter sets (None keeps that set)."""
        with self._settings_lock:
            old_p, old_m = self._pending_stereo or (None, None)
            self._pending_stereo = (params or old_p, match or old_m)

    def set_camera_settings(self, settings) -> None:
        with self._settings_lock:
            self._pending_settings = settings

    def request_control(self, name: str, value: float) -> None:
        """Set a device control on both cameras (the newest value per control wins)."""
        with self._settings_lock:
            self._pending_controls[name] = ("value", float(value))

    def request_auto(self, name: str, on: bool) -> None:
        """Switch a control's automatic mode on both cameras."""
        with self._settings_lock:
            self._pending_controls[name + ":auto"] = ("auto", 1.0 if on else 0.0)

    def request_controls(self) -> None:
        """Read the controls again and emit sigControls."""
        with self._settings_lock:
            self._want_controls = True

    def set_calibration(self, calibration) -> None:
        """Use this StereoCalibration from the next frame on (perception, disparity, health)."""
        with self._settings_lock:
            self._pending_calibration = calibration

    def request_detectors(self, specs) -> None:
        """Run these marker-less object detectors from the next frame on (any thread).

        ``specs`` is a list of (registry name, {settings field: value}): "hsv", "circles",
        "aruco", "onnx:PATH", …; a detector already running is changed with ``with_params``,
        a new one is built from the registry (an error is reported on sigDetectorError and that
        detector left out). An empty list turns object perception off.
        """
        with self._settings_lock:
            self._pending_detectors = [(str(name), dict(options)) for name, options in specs]

    def object_detectors(self) -> list:
        """The (guarded) detectors object perception runs now ([] when it is off); read them
        in tests and the window, never change them from another thread."""
        op = self.session.object_perception
        return [] if op is None else list(op.detectors)

    def wake(self) -> None:
        self.session.camera.interrupt()

    def _apply_requests(self) -> None:
        s = self.session
        with self._settings_lock:
            settings, self._pending_settings = self._pending_settings, None
            controls, self._pending_controls = self._pending_controls, {}
            stereo, self._pending_stereo = self._pending_stereo, None
            calibration, self._pending_calibration = self._pending_calibration, None
            detectors, self._pending_detectors = self._pending_detectors, None
        if settings is not None:
            s.camera.set_settings(settings)
        for key, (kind, value) in sorted(controls.items(), key=lambda kv: kv[1][0] != "auto"):
            name = key.split(":")[0]
            try:
                applied = (s.camera.set_auto(name, bool(value)) if kind == "auto"
                           else s.camera.set_control(name, value))
            except (KeyError, CameraError, ValueError) as exc:
                self.sigControlError.emit(str(exc).strip("'\""))
            else:
                self.sigControlApplied.emit(applied)
        if stereo is not None:
            params, match = stereo
            self.disparity.set_all(params or self.disparity.params, match or self.disparity.match)
        if calibration is not None:
            self._use_calibration(calibration)
        if detectors is not None:
            self._use_detectors(detectors)

    def _use_detectors(self, specs: list[DetectorSpec]) -> None:
        """Build (or re-tune) the requested detectors and hand them to the object perception."""
        s = self.session
        op = s.object_perception
        current = {} if op is None else {d.spec_name: d for d in op.detectors if isinstance(d, GuardedDetector)}
        built, problems = [], []
        for name, options in specs:
            old = current.get(name)
            try:
                new = build_detector(name, options, None if old is None else old.inner)
            except Exception as exc:  # noqa: BLE001 - a bad file or setting: say so, keep the others
                problems.append(f"detector {name}: {exc}")
                continue
            built.append(old if old is not None and new is old.inner else GuardedDetector(new, name))
        if not built:
            s.object_perception = None
        elif op is None:
            s.object_perception = new_object_perception(s, s.calibration, s.perception.base_T_camera, built)
        else:
            other_set = [d.spec_name for d in op.detectors] != [d.spec_name for d in built]
            op.detectors = built
            if other_set:  # a detector on or off: start the ids again. A re-tuned one (a slider)
                op.reset()  # keeps the tracks, so the object being followed keeps its id
        self._emit_detectors()  # first what runs (a failed detector is off), then why
        for message in problems:
            self.sigDetectorError.emit(message)

    def _emit_detectors(self) -> None:
        self.sigDetectorsApplied.emit([(d.spec_name, d.params) for d in self.object_detectors()])

    def _check_detector_errors(self) -> None:
        """Turn off a detector that raised while detecting, and say which and why."""
        op = self.session.object_perception
        failed = [d for d in op.detectors if d.error is not None]
        if not failed:
            return
        op.detectors = [d for d in op.detectors if d.error is None]
        for d in failed:
            self.sigDetectorError.emit(f"detector {d.spec_name} failed and was turned off: {d.error}")
        if not op.detectors:
            self.session.object_perception = None
        self._emit_detectors()

    def _use_calibration(self, calib) -> None:
        s = self.session
        old = s.perception
        new = StereoMarkerPerception(calib, old.base_T_camera, marker_ids=old.marker_ids,
                                     full_search_every=old.full_search_every, search_margin=old.search_margin)
        # keep the detectors (their dictionary and tuning) and the robust-search rhythm
        new.detector, new.robust_detector, new.robust_every = old.detector, old.robust_detector, old.robust_every
        s.calibration = calib
        s.perception = new
        if s.object_perception is not None:  # the objects are triangulated with it too
            s.object_perception = new_object_perception(s, calib, new.base_T_camera, s.object_perception.detectors)
        self.disparity = DisparityComputer(calib, self.disparity.params, self.disparity.match)
        self.health.reset()
        if self._health_drifted:
            self._health_drifted = False
            self.sigHealth.emit(self.health.status())
        self.sigCalibrationApplied.emit(calib)

    def _emit_controls(self) -> None:
        with self._settings_lock:
            want, self._want_controls = self._want_controls, False
        if not want:
            return
        try:
            controls = self.session.camera.controls("left")
        except (CameraError, KeyError, ValueError):
            controls = []
        self.sigControls.emit(list(controls))

    def _feed_health(self, result) -> None:
        self.health.feed(result)
        drifted = self.health.drifted
        now = time.monotonic()
        if drifted != self._health_drifted or (drifted and now - self._health_sent_t >= HEALTH_REPEAT_S):
            self._health_drifted = drifted
            self._health_sent_t = now
            self.sigHealth.emit(self.health.status())

    def loop_once(self) -> None:
        s = self.session
        self._apply_requests()
        frame = s.camera.read()
        if frame is None:
            if not s.camera.is_connected and self.running:
                message = s.camera.status_message or f"{s.camera.name}: no frames"
                if message != self._error_reported:  # report each new state once
                    self._error_reported = message
                    self.sigError.emit(message)
            return
        if self._error_reported:
            self._error_reported = ""
            self.sigError.emit("")  # frames again: the camera is back
            self.request_controls()  # a replugged device may have other ranges
        self._emit_controls()
        result = s.perception.process(frame)
        extra = {}
        if self._want_disparity.is_set():  # a repeated frame gets the computer's last map back
            t0 = time.perf_counter()
            extra["disparity"] = self.disparity.compute(frame.left, frame.right)
            if not result.reused:
                extra["timings_ms"] = dict(result.timings_ms, disparity=(time.perf_counter() - t0) * 1e3)
        if s.targeter.mode is TargetMode.CUPS:  # likewise the ball finder's last answer
            extra["ball_left_px"] = s.ball_finder.find(frame.left)
        op = s.object_perception
        if op is not None:  # marker-less objects: detect in both views, match, triangulate, track
            t0 = time.perf_counter()
            extra["objects"] = tuple(op.process(frame))
            if not result.reused:
                timings = extra.get("timings_ms", result.timings_ms)
                extra["timings_ms"] = dict(timings, objects=(time.perf_counter() - t0) * 1e3)
            self._check_detector_errors()
        if extra:
            result = replace(result, **extra)
        if not result.reused:
            self._feed_health(result)
        self.results.put(result)
        if self.on_result is not None:
            self.on_result()
        self.sigResult.emit(result)


class ControlWorker(_LoopThread):
    """Targeting + IK + safety, when the session's ControlSchedule says: at once for a new
    perception result or user input, else on the 50 Hz tick; hands commands to the bridge worker."""

    sigCommand = QtCore.Signal(object, object)  # (JointCommand, the Goal the controller used: controller.last_goal)

    def __init__(self, session: DeskSession, results: Latest, states: Latest, commands: Latest, parent=None):
        super().__init__("control", parent)
        self.session = session
        self.results, self.states, self.commands = results, states, commands
        self.schedule = session.control_schedule()
        self._bell = threading.Event()  # rung by a new perception result, a user input, stop()
        self._result_version = 0
        self._input = threading.Event()
        session.targeter.listeners.append(self.user_input)

    def user_input(self) -> None:
        """The user changed the goal (any thread): step at once."""
        self._input.set()
        self._bell.set()

    def new_result(self) -> None:
        """Perception published a result (any thread): step at once."""
        self._bell.set()

    def wake(self) -> None:
        self._bell.set()
        self.session.clock.interrupt()

    def loop_once(self) -> None:
        s = self.session
        sched = self.schedule
        sched.min_interval_s = rate_cap_interval(s.bridge, sched.period_s)  # the bridge may be switched
        now = s.clock.now()
        _, version = self.results.wait_newer(self._result_version, 0.0)
        if version != self._result_version:
            self._result_version = version
            sched.goal_arrived(now)
        if self._input.is_set():
            self._input.clear()
            sched.goal_arrived(now)
        due = sched.next_due(now, getattr(s.camera, "next_frame_t", None))
        if due > now:
            if s.clock.simulated:
                s.clock.wait_until(due)
            else:
                self._bell.wait(due - now)
                self._bell.clear()
            return  # look again: a new goal may have come
        if not self.running:
            return
        sched.ran(now)
        result = self.results.peek()
        state = self.states.peek()
        q_now = s.controller.start_pose(state)
        if s.targeter.mode is TargetMode.OBJECT:  # the intercept and the approach start from the tool
            s.targeter.set_tool_position(s.kinematics.fk(q_now))
        goal = s.targeter.update(result)
        cmd = s.controller.step(goal, q_now, now)
        if cmd is not None:
            self.commands.put(cmd)
            # the goal the controller used: a joint jog turns a MANUAL goal into a joint goal
            self.sigCommand.emit(cmd, s.controller.last_goal or goal)


class BridgeWorker(_LoopThread):
    """Writes the newest command to the motor bridge and reports the joint state.

    Reconnects with a growing delay when the device disappears; the state is a visible status.
    """

    sigState = QtCore.Signal(object)
    sigStatus = QtCore.Signal(object)

    def __init__(self, session: DeskSession, commands: Latest, states: Latest, parent=None):
        super().__init__("bridge", parent)
        self.session = session
        self.commands, self.states = commands, states
        self._version = 0
        self._last_status_t = 0.0
        self.reconnector = Reconnector()  # backoff 0.5 s … 5 s, shared with the headless runner
        self._requests_lock = threading.Lock()
        self._estop_request: Optional[bool] = None
        self._bridge_request: Optional[str] = None

    def wake(self) -> None:
        self.commands.wake()

    def request_estop(self, engaged: bool) -> None:
        """Stop (True) or re-arm (False) the arm; carried out in this worker's thread."""
        with self._requests_lock:
            self._estop_request = bool(engaged)
        self.commands.wake()

    def request_bridge(self, url: str) -> None:
        """Switch to another bridge (URL as for --bridge); carried out in this worker's thread."""
        with self._requests_lock:
            self._bridge_request = url
        self.commands.wake()

    def _handle_requests(self) -> None:
        with self._requests_lock:
            estop, self._estop_request = self._estop_request, None
            url, self._bridge_request = self._bridge_request, None
        s = self.session
        refusal = s.real_arm_refusal(url) if url is not None else ""
        if refusal:  # a real arm never follows the simulated desk standing in for missing cameras
            s.bridge.message = refusal
            s.bridge.request_failed = True
            url = None
        if url is not None:
            from core.devices import open_bridge

            try:
                new = open_bridge(url, s.profile, clock=s.clock)
            except (ValueError, BridgeError) as exc:  # unknown URL or unfit profile: keep the bridge that works
                s.bridge.message = str(exc)
                s.bridge.request_failed = True
            else:
                old = s.bridge
                old.disconnect()
                try:
                    new.connect()
                except BridgeError as exc:
                    # keep what was working: reconnect the previous bridge and say why
                    try:
                        old.connect()
                    except BridgeError:
                        pass
                    old.message = f"could not switch to {url}: {exc} — still on {old.url}"
                    old.request_failed = True
                else:
                    s.bridge = new
                    self.reconnector.reset()
        if estop is not None:
            method = getattr(s.bridge, "estop" if estop else "rearm", None)
            if method is not None:  # bridges keep an e-stop made while disconnected
                try:
                    method()
                except BridgeError as exc:
                    s.bridge.message = str(exc)
                    s.bridge.request_failed = True

    def _ensure_connected(self) -> bool:
        """Connect if needed, retrying with a growing delay (0.5 s … 5 s) after failures."""
        return self.reconnector.ensure(self.session.bridge)

    def loop_once(self) -> None:
        s = self.session
        cmd, self._version = self.commands.wait_newer(self._version, timeout=0.1)
        if not self.running:
            return
        self._handle_requests()
        if not s.controller.armed:
            cmd = None  # e-stop: nothing is written until the user re-arms
        if self._ensure_connected():
            if cmd is not None:
                try:
                    s.bridge.send(cmd)
                except BridgeError as exc:  # the device went away: reconnect from the next loop
                    self.reconnector.lost(s.bridge, exc)
            try:
                state = s.bridge.joint_state()
            except BridgeError as exc:
                self.reconnector.lost(s.bridge, exc)
                state = None
            if state is not None:
                self.states.put(state)
                if hasattr(s.camera, "set_arm_points"):
                    s.camera.set_arm_points(s.kinematics.chain_points(state.q))
                self.sigState.emit(state)
        now = time.monotonic()
        if now - self._last_status_t > 0.5:
            self._last_status_t = now
            self.sigStatus.emit(s.bridge.status())


class WorkerSet:
    """The three workers of a session, started and stopped together."""

    def __init__(self, session: DeskSession, parent=None):
        self.session = session
        self.results: Latest = Latest()
        self.states: Latest = Latest()
        self.commands: Latest = Latest()
        self.perception = PerceptionWorker(session, self.results, parent)
        self.control = ControlWorker(session, self.results, self.states, self.commands, parent)
        self.perception.on_result = self.control.new_result  # a new result wakes the control step
        self.bridge = BridgeWorker(session, self.commands, self.states, parent)
        self.started = False

    def start(self) -> None:
        try:
            self.session.bridge.connect()
        except BridgeError as exc:
            self.session.bridge.message = str(exc)  # the bridge worker retries; the GUI shows it
        for w in (self.bridge, self.control, self.perception):
            w.start()
        self.started = True

    def stop(self) -> None:
        """Stop in data-flow order and join every thread; safe to call twice."""
        if not self.started:
            return
        self.started = False
        for w in (self.perception, self.control, self.bridge):
            w.stop()
        self.session.close()
