"""The assistive view's arm chain: the loop on its thread, the driven arm, what the window sees of them.

``AssistWorker`` (a QThread) runs ``core.motion.assist_loop.AssistLoop`` on the simulated desk
(the still lift panel of ``deskarm assist-trials``, the ``assistive_5dof`` arm: ``build_sim_loop``)
or on a webcam as the hand camera (``build_webcam_loop``): on a simulated clock (frames as fast as
the CPU goes: tests) or paced by the wall clock (30 frames/s). With an arm
(``guarded_arm_factory``: the simulated servo arm by default, a v1/v2 board or a Phidget board
with ``--bridge``) every joint value goes through the safety chain of
``core.devices.guarded_arm.GuardedArm`` to it.

``ArmChain`` is the window's side of it: it owns the worker and the side column's arm line, shows
each new image in the view (and the followed box while the arm moves), and passes the boxes, the
loop's status, a stop the worker made by itself and a failure on as its own signals (received in
the GUI thread).
"""
from __future__ import annotations

import queue
import sys
import threading
import time
from typing import Callable, Optional

from PySide6 import QtCore, QtWidgets

from core.devices.bridge import parse_bridge_url

# the live view while nothing moves (choosing, stopped): 10 frames/s is enough to see the scene
# change and costs a third of 30 (make bench: "assist window CPU choosing")
PREVIEW_PERIOD_S = 0.1


def build_sim_loop(seed: int = 0, vibration: bool = False, passing_hand: bool = False, detector: str = "circles"):
    """(AssistLoop, ready pose) on the simulated desk: the lift panel of ``deskarm assist-trials``
    (its first trial's place) as a panel that answers — a pushed button goes down and its ring
    lights (``core.sim.assist_scene``) — the ``assistive_5dof`` arm at its ready pose. With
    ``passing_hand`` the ``panel`` scenario's hand reaches in now and then. ``detector``: the button
    detector (``app.cli_assist.make_assist_detector``: "circles" or "desk")."""
    import numpy as np

    from app.cli_assist import AssistTrials, trial_scene
    from core.sim.assist_scene import AssistPanelScene, PressFeedbackCamera

    trials = AssistTrials("touch", vibration=vibration, seed=seed, detector=detector)
    placed = trial_scene(np.random.default_rng([int(seed), 0, 12]))
    scene = AssistPanelScene(placed.panel(), placed.handle, passing_hand=passing_hand)
    trials.desk.set_scenario(scene)
    loop = trials.loop
    loop.camera = PressFeedbackCamera(loop.camera, scene)
    loop.render_always = True
    loop.reset(trials.ready_q, 0.0)
    return loop, trials.ready_q


def build_webcam_loop(device, bridge=None, depth: str = "auto", calibration=None, capture_factory=None,
                      ready_q=None, detector: str = "circles"):
    """(AssistLoop, ready pose) on a real hand camera: webcam ``device`` on the ``assistive_5dof``
    arm (``core.devices.hand_camera.WebcamHandCamera``), the circle detector and the servo of the
    trials. Depth: "size" (the button's known size), "range" (the v2 board's HC-SR04 through
    ``bridge.range_m``) or "auto" (the range when the board has a reading, else the size; with no
    board or a board without ``range_m``, the size). The webcam may be missing: the loop runs on
    black frames and the camera's ``status_message`` says why. ``ready_q``: the ready pose
    (default: ``nominal_ready_pose``, the camera on a panel where the simulated desk has it).
    ``detector``: "circles" (default) or "desk" (``app.cli_assist.make_assist_detector``)."""
    from app.cli_assist import (APPROACH_SPEED_M_S, AXIS_TILT_RAD, DETECT_EVERY, FRAME_DT_S, MAX_LINEAR_SPEED_M_S,
                                PRESS_DEPTH_M, SERVO_GAIN, make_assist_detector, nominal_ready_pose)
    from core.devices.hand_camera import BridgeRangeSensor, WebcamHandCamera
    from core.kinematics.clik import ClikKinematics
    from core.kinematics.profile import load_profile
    from core.motion.assist import AssistConfig
    from core.motion.assist_loop import DEPTH_SOURCES, AssistLoop
    from core.motion.servoing import IbvsConfig, IbvsController

    if depth not in DEPTH_SOURCES:
        raise ValueError(f"depth {depth!r}: use one of {', '.join(DEPTH_SOURCES)}")
    has_range = bridge is not None and callable(getattr(bridge, "range_m", None))
    if depth == "range" and not has_range:
        raise ValueError("depth 'range' needs a v2 board with a range sensor (--bridge serial2://…); "
                         "use depth 'size' or 'auto'")
    if depth == "auto" and not has_range:
        depth = "size"
    kin = ClikKinematics(load_profile("assistive_5dof"))
    camera = WebcamHandCamera(device, kin, calibration=calibration, capture_factory=capture_factory)
    camera.connect(keep_trying=True)
    servo = IbvsController(kin, camera.K, IbvsConfig(axis_tilt_rad=AXIS_TILT_RAD, gain=SERVO_GAIN,
                                                      max_linear_speed_m_s=MAX_LINEAR_SPEED_M_S))
    detector = make_assist_detector(detector)
    config = AssistConfig(press_depth_m=PRESS_DEPTH_M, approach_speed_m_s=APPROACH_SPEED_M_S)
    ready_q = nominal_ready_pose(kin, camera.K) if ready_q is None else tuple(float(v) for v in ready_q)
    loop = AssistLoop(kin, camera, detector, servo, config, ready_q, depth_source=depth,
                      range_sensor=BridgeRangeSensor(bridge) if depth != "size" else None,
                      frame_dt_s=FRAME_DT_S, detect_every=DETECT_EVERY, render_always=True)
    return loop, ready_q


def guarded_arm_factory(bridge) -> Callable[[object], object]:
    """An ``AssistWorker`` arm factory: the loop → a ``GuardedArm`` sending its joints to ``bridge``
    (a ``core.devices`` bridge, not yet connected; the worker connects it in its thread)."""
    def make(loop):
        from core.devices.guarded_arm import GuardedArm

        return GuardedArm(bridge, loop.kin, loop.frame_dt_s)

    return make


def ready_pose_problem(ready_deg, profile) -> str:
    """Why ``assist.toml``'s ``ready_deg`` cannot be the ready pose ("" when it can)."""
    import math

    n = len(profile.joints)
    if len(ready_deg) != n or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in ready_deg):
        return f"ready_deg = {list(ready_deg)}: give {n} finite joint angles in degrees ({', '.join(j.name for j in profile.joints)})"
    outside = [f"{j.name} {v:g}° (limits {math.degrees(j.q_min):.0f}…{math.degrees(j.q_max):.0f}°)"
               for j, v in zip(profile.joints, ready_deg) if not j.q_min <= math.radians(v) <= j.q_max]
    if outside:
        return f"ready_deg is outside the joint limits: {', '.join(outside)} — fix it in assist.toml or delete the line"
    return ""


class AssistWorker(QtCore.QThread):
    """Runs an AssistLoop: commands in (select, e-stop, re-arm), frames and state changes out.

    Signals (emitted from the worker's thread, received queued in the GUI thread):
    - sigBoxes(list[(x, y, w, h)]): the boxes offered to choose from (after start, after a return)
    - sigStatus(LoopStatus): the loop's state changed (or its outcome)
    - sigFrame(): a new image is waiting in ``take_frame()`` (sent again only after a take)
    - sigError(str): the loop could not be built or failed; the worker has ended
    - sigArm(str, str): the driven arm's state changed: ("connected" | "simulated" | "E-STOP" |
      "not connected", ``arm_text``), or ("", "") without an arm
    - sigStopped(str): the worker stopped the arm by itself (its board went away) — the window
      shows it as a STOP with that reason; RE-ARM reconnects and goes back to the ready pose

    With ``arm_factory`` (the loop → a ``core.devices.guarded_arm.GuardedArm``; ``guarded_arm_factory``) every joint value of the loop
    goes through deskarm's safety chain to that arm's bridge, and the loop continues from what was
    sent; at start (and after a re-arm) the arm moves from where it is to the ready pose before the
    boxes are offered. Without one the loop's joints are the simulated arm itself.
    """

    sigBoxes = QtCore.Signal(object)
    sigStatus = QtCore.Signal(object)
    sigFrame = QtCore.Signal()
    sigError = QtCore.Signal(str)
    sigArm = QtCore.Signal(str, str)
    sigStopped = QtCore.Signal(str)

    def __init__(self, loop_factory: Callable[[], tuple], clock: str = "sim", parent=None,
                 arm_factory: Optional[Callable[[object], object]] = None):
        super().__init__(parent)
        if clock not in ("sim", "wall"):
            raise ValueError(f"worker clock {clock!r}: use 'sim' (as fast as possible) or 'wall' (real time)")
        self.setObjectName("AssistWorker")
        self._factory = loop_factory
        self.clock = clock
        self._commands: "queue.SimpleQueue[tuple]" = queue.SimpleQueue()
        self._wake = threading.Event()
        self._running = threading.Event()
        self._frame_lock = threading.Lock()
        self._frame = None
        self._frame_pending = False
        self.loop = None
        self.ready_q = None
        self.engaged = False
        self.last_command = None  # the latest JointCommand (what was sent to the arm, with one)
        self._arm_factory = arm_factory
        self.arm = None  # the GuardedArm, built in the thread
        self.arm_text = ""
        self._arm_waiting = False  # the arm's board is not connected yet: nothing moves, nothing offered
        self._last_state = None  # (state, outcome) of the latest sigStatus
        self.selections: list[int] = []  # every index the loop was asked to go to

    # -- from the GUI thread ---------------------------------------------------------------------

    def start(self, *args) -> None:  # noqa: D102
        self._running.set()
        super().start(*args)

    def _send(self, command: tuple) -> None:
        self._commands.put(command)
        self._wake.set()

    def select(self, index: int) -> None:
        """Go to offered box ``index`` (0-based)."""
        self._send(("select", int(index)))

    def emergency_stop(self) -> None:
        """The arm holds; the choice is cancelled; nothing moves until ``rearm``."""
        self._send(("estop",))

    def rearm(self) -> None:
        """Resume after an e-stop: the arm goes back to its ready pose, then a new choice."""
        self._send(("rearm",))

    def take_frame(self):
        """(the newest image (BGR), its LoopStatus) or (None, None); allows the next sigFrame."""
        with self._frame_lock:
            frame, self._frame, self._frame_pending = self._frame, None, False
            return frame if frame is not None else (None, None)

    def stop(self) -> None:
        """End the loop and join the thread."""
        self._running.clear()
        self._send(("quit",))
        if not self.wait(10000):
            self.terminate()
            self.wait()

    # -- the thread ------------------------------------------------------------------------------

    def _publish(self, frame, status=None) -> None:
        if frame is None:
            return
        with self._frame_lock:
            self._frame = (frame.image, status)
            if self._frame_pending:
                return
            self._frame_pending = True
        self.sigFrame.emit()

    def _offer(self) -> None:
        boxes = self.loop.offer()
        self._publish(self.loop.last_frame)
        self.sigBoxes.emit([tuple(float(v) for v in d.box) for d in boxes])

    def _handle(self, command: tuple) -> None:
        kind = command[0]
        loop = self.loop
        if kind == "select":
            if self.engaged or loop.busy:
                return  # the GUI never offers a choice then; a late command is dropped
            self.selections.append(command[1])
            loop.select(command[1])
        elif kind == "estop":
            self.engaged = True
            loop.stop("stopped by the user")
            if self.arm is not None:
                self.arm.estop()
                self._arm_state()
        elif kind == "rearm" and self.engaged:
            self.engaged = False
            if self.arm is not None:
                self.arm.rearm()
                self._arm_begin()  # from where the arm is now (it may have sagged while off)
            else:
                loop.go_to(self.ready_q)

    # -- the driven arm ----------------------------------------------------------------------------

    def _arm_state(self) -> None:
        """``arm_text``: "<url>: connected", "<url>: E-STOP" or "<url>: NOT CONNECTED — <the bridge's words>"."""
        arm = self.arm
        if arm is None:
            state, text = "", ""
        elif arm.connected:
            state = "E-STOP" if arm.bridge.is_estopped else "connected"
            text = f"{arm.bridge.url}: {state}"
            if state == "connected" and parse_bridge_url(arm.bridge.url) == "sim":
                state = "simulated"
        else:
            state, text = "not connected", f"{arm.bridge.url}: NOT CONNECTED — {arm.message or 'no answer'}"
        if text != self.arm_text:
            self.arm_text = text
            self.sigArm.emit(state, text)

    def _arm_begin(self) -> None:
        """Connect the arm (or keep waiting for it), then move from where it is to the ready pose."""
        connected = self.arm.connect()
        self._arm_state()
        self._arm_waiting = not connected
        if connected:
            self.loop.q = self.arm.start_pose()  # the loop is idle here (at start, or stopped)
            self.loop.go_to(self.ready_q)

    def _arm_lost(self, reason: str) -> None:
        """The arm's board is gone: the loop stops (it must not servo a camera whose arm does not
        move) and the window shows a STOP with the reason."""
        self.engaged = True
        self.loop.stop(reason)
        self._arm_state()
        self.sigStopped.emit(reason)

    def _arm_send(self) -> bool:
        """The loop's new joint values to the arm; False (and the loop stopped) when none reached it."""
        loop = self.loop
        command = self.arm.send(loop.q, loop.t)
        if command is None:
            self._arm_lost(self.arm.lost or "the arm did not take the command")
            return False
        loop.q = tuple(command.q)
        self.last_command = command
        return True

    def run(self) -> None:  # noqa: D102 (QThread override)
        try:
            self.loop, self.ready_q = self._factory()
            if self._arm_factory is not None:
                self.arm = self._arm_factory(self.loop)
                self._arm_begin()
            else:
                self._offer()
            self._emit_status()
            next_tick = last_preview = time.monotonic()
            preview = self.clock == "wall"  # a live image while nothing moves (not in as-fast-as-possible tests)
            while self._running.is_set():
                loop = self.loop
                idle = self.engaged or not loop.busy
                wait_s = PREVIEW_PERIOD_S if preview else 0.2
                try:  # commands: waited for when there is nothing to do, else only taken
                    command = self._commands.get(timeout=wait_s) if idle else self._commands.get_nowait()
                except queue.Empty:
                    command = None
                if command is not None:
                    if command[0] == "quit":
                        break
                    was = loop.state
                    self._handle(command)
                    if command[0] == "estop" or loop.state != was:
                        self._emit_status()
                    continue
                if self._arm_waiting and not self.engaged:
                    self._arm_begin()  # tried again on the connect backoff
                    if not self._arm_waiting:
                        self._emit_status()
                    continue
                if idle:
                    if self.arm is not None and not self.engaged and not self.arm.connected:
                        self._arm_lost(f"the arm's board went away: {self.arm.message or 'no answer'}")
                        self._emit_status()
                    now_s = time.monotonic()
                    if preview and not loop.busy and now_s - last_preview >= PREVIEW_PERIOD_S:
                        # the camera keeps showing what it sees while the user chooses (or while
                        # stopped); the boxes stay as offered — the arm holds still at its pose
                        loop.t += min(now_s - last_preview, 1.0)
                        last_preview = now_s
                        self._publish(loop.render())
                    continue
                was = loop.state
                frame, command, status = loop.step()
                if self.arm is None:
                    self.last_command = command
                elif not self._arm_send():
                    self._publish(frame, status)
                    self._emit_status()
                    continue
                self._publish(frame, status)
                now = (loop.state, loop.fsm.outcome)
                if now != self._last_state:
                    self.sigStatus.emit(status)
                    self._last_state = now
                if was != "IDLE" and loop.state == "IDLE":
                    if was == "RETURN":
                        self._offer()  # back at the ready pose: a fresh choice
                    else:
                        loop.go_to(self.ready_q)  # pressed, lost or timed out: back to the ready pose
                if self.clock == "wall":
                    next_tick += loop.frame_dt_s
                    delay = next_tick - time.monotonic()
                    if delay > 0:
                        self._wake.wait(delay)  # a paced wait that a command (or quit) cuts short
                        self._wake.clear()
                    else:
                        next_tick = time.monotonic()
        except Exception as exc:  # noqa: BLE001 — reported to the window instead of killing the thread silently
            self.sigError.emit(f"the assistive loop stopped: {type(exc).__name__}: {exc}")
        finally:
            if self.arm is not None:
                self.arm.disconnect()  # a v2 board's watchdog then holds the arm where it is

    def _emit_status(self) -> None:
        from core.motion.assist_loop import LoopStatus

        loop = self.loop
        self._last_state = (loop.state, loop.fsm.outcome)
        self.sigStatus.emit(LoopStatus(loop.state, loop.t, loop.target_index, None, loop.fsm.outcome))


class ArmChain(QtCore.QObject):
    """The worker and the arm line, for the window (see the module docstring).

    Signals (GUI thread):
    - sigBoxes(list[(x, y, w, h)]): the boxes offered to choose from (image px)
    - sigStatus(LoopStatus): the loop's state changed (or its outcome)
    - sigStopped(str): the worker stopped the arm by itself (its board went away): the reason
    - sigError(str): the loop could not be built or failed; the worker has ended

    ``view``: where the images go (``widgets.assist_view.AssistView``); ``stopped``: True while the
    user's STOP is engaged (the followed box is not drawn then)."""

    sigBoxes = QtCore.Signal(object)
    sigStatus = QtCore.Signal(object)
    sigStopped = QtCore.Signal(str)
    sigError = QtCore.Signal(str)

    def __init__(self, loop_factory: Callable[[], tuple], worker_clock: str, view, stopped: Callable[[], bool],
                 parent: QtCore.QObject, arm_factory: Optional[Callable[[object], object]] = None):
        super().__init__(parent)
        self.view = view
        self._stopped = stopped
        self.worker = AssistWorker(loop_factory, worker_clock, parent, arm_factory=arm_factory)
        self.label = QtWidgets.QLabel("")  # the driven arm's link (hidden on the simulated desk)
        self.label.setWordWrap(False)  # one line: "arm: connected", "arm: NOT CONNECTED"
        self.label.hide()
        # slots of this QObject (GUI thread): the worker's signals arrive queued
        self.worker.sigArm.connect(self._on_arm)
        self.worker.sigStopped.connect(self._on_stopped)
        self.worker.sigBoxes.connect(self._on_boxes)
        self.worker.sigStatus.connect(self._on_status)
        self.worker.sigFrame.connect(self._on_frame)
        self.worker.sigError.connect(self._on_error)

    def start(self) -> None:
        self.worker.start()

    def stop(self) -> None:
        """End the loop and join the worker (nothing when it is not running)."""
        if self.worker.isRunning():
            self.worker.stop()

    def camera_message(self) -> str:
        """What a real hand camera says is wrong ("" when nothing: never a crash, the loop runs on black frames)."""
        return getattr(getattr(self.worker.loop, "camera", None), "status_message", "")

    def _on_boxes(self, boxes: list) -> None:
        self.sigBoxes.emit(boxes)

    def _on_status(self, status) -> None:
        self.sigStatus.emit(status)

    def _on_stopped(self, reason: str) -> None:
        self.sigStopped.emit(reason)

    def _on_error(self, message: str) -> None:
        self.sigError.emit(message)

    def _on_frame(self) -> None:
        image, status = self.worker.take_frame()
        if image is not None:
            self.view.set_image(image)
        if status is not None and status.state in ("ALIGN", "APPROACH", "ACT") and not self._stopped():
            self.view.set_follow(status.centre_px, status.radius_px)

    def _on_arm(self, state: str, text: str) -> None:
        """One short line in the side column (the narrow 800x480 layout); the bridge's whole
        message goes to the tooltip and, when something is wrong, to the log."""
        self.label.setText(f"arm: {state}")
        self.label.setToolTip(text)
        self.label.setVisible(bool(state))
        bad = state in ("E-STOP", "not connected")
        self.label.setStyleSheet("color: white; background: #b00020; padding: 2px;" if bad else "color: #1b5e20;")
        if bad:
            print(f"deskarm --assist: arm {text}", file=sys.stderr)
