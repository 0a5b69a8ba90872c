"""The assistive view: choose a button on the hand camera's image by touch, two switches or one switch.

``AssistWindow`` fills its screen (full screen on an 800×480 panel, with or without a window
manager: ``show_filling_screen``): the hand camera's image with the selectable boxes drawn big and
numbered (``widgets.assist_view.AssistView``; a box's outline and its number badge are one target),
a big state line ("choose a button", "aligning with 7", "approaching 7", "pressing 7", "done: 7
pressed", "stopped"), STOP always in the top right corner (``widgets.estop``: STOP only stops;
RE-ARM needs a 1 s hold), the input mode (touch / 2 switches / 1 switch timed), the scan period T
and a "Switches…" dialog that maps keys and mouse buttons to the roles "next", "confirm" and
"single switch". Quitting is for the carer, out of a switch user's reach: Ctrl+Q, or the ☰ button
in the top left corner (its menu holds "Quit"); the scanning never lands on it, and in the switch
modes a mouse button that is a switch, pressed over it, is that switch and never opens it.

Input modes (``core.motion.scanning`` holds their state machines):

- touch: a tap (click) on a box selects it; a tap outside every box shows "not a button" briefly
  and nothing moves;
- two switches: "next" (default Space, right mouse button) moves the highlight on, "confirm"
  (default Enter, left mouse button) starts the arm on the highlighted box; both act on release;
- one switch, timed: the highlight moves on by itself every T s (0.5–5 s), a press confirms the
  box highlighted when it went down.

In both switch modes, holding a switch for ``long_press_s`` (1.5 s) stops the arm and cancels (the
e-stop, as STOP); while stopped, holding it again for as long re-arms (the RE-ARM button's hold) —
so a one-switch user reaches every action. Esc is STOP in every mode. A held key counts as held:
the auto-repeat's release/press pairs are ignored — also the ones X11 delivers unflagged (the
release is kept ``KEY_REPEAT_GRACE_S`` for a press with its timestamp; see ``keyReleaseEvent``).

The settings (mode, T, long press, mapping, sound cue) are kept in ``assist.toml`` in the user's
config folder (core.paths; ``DESKARM_HOME`` in tests) — a file of its own so the main window's
``preferences.toml`` is untouched.

``AssistWorker`` (a QThread) runs ``core.motion.assist_loop.AssistLoop`` on the simulated desk
(the still lift panel of ``deskarm assist-trials``, the ``assistive_5dof`` arm) or on a webcam as
the hand camera: on a simulated clock (frames as fast as the CPU goes: tests) or paced by the wall
clock (30 frames/s). With an arm (``guarded_arm_factory``: the simulated servo arm by default, a
v1/v2 board or a Phidget board with ``--bridge``) every joint value goes through the safety chain
of ``core.devices.guarded_arm.GuardedArm`` to it.
"""
from __future__ import annotations

import queue
import sys
import threading
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Callable, Optional

from PySide6 import QtCore, QtGui, QtWidgets

from core.devices.bridge import parse_bridge_url
from core.motion.scanning import MAX_PERIOD_S, MIN_PERIOD_S, OneSwitchScanner, TouchSelector, TwoSwitchScanner
from widgets._style import BUTTON_STYLE, SPIN_STYLE, TOUCH_PX
from widgets.assist_view import MOUSE_NAMES, AssistView, SwitchSafeButton
from widgets.estop import EStopButton, RearmButton, StopDialog, StopGuard

ASSIST_SETTINGS_FILE = "assist.toml"
MODES = ("touch", "scan2", "scan1")
MODE_NAMES = {"touch": "Touch", "scan2": "2 switches", "scan1": "1 switch"}
SCAN_TICK_MS = 40  # how often the timed scan and the long-press hold are checked
# the live view while nothing moves (choosing, stopped): 10 frames/s is enough to see the scene
# change and costs a third of 30 (make bench: "assist window CPU choosing")
PREVIEW_PERIOD_S = 0.1
BOX_GROWTH_MAX = 1.6  # boxes are drawn (and hit-tested) up to this much larger than the detected circle …
BOX_GAP_FRACTION = 0.9  # … but no larger than this fraction of the distance to the nearest neighbour
# a key switch's release waits this long for the press of an auto-repeat pair (the X server sends
# both at once with one timestamp; measured under Xvfb: the press arrives 1–2 ms after the release)
KEY_REPEAT_GRACE_S = 0.1
MENU_BUTTON_PX = 52  # the ☰ button: a fingertip target (≥ TOUCH_PX) beside the state line
SCREENSHOT_WAIT_S = 30.0  # --screenshot: the longest wait for the boxes after --after


# -----------------------------------------------------------------------------------------------
# settings


@dataclass(frozen=True)
class AssistSettings:
    """The assistive view's own settings (``assist.toml``)."""

    mode: str = "touch"
    scan_period_s: float = 1.5
    long_press_s: float = 1.5
    sound: bool = False
    next_switch: tuple[str, ...] = ("key:Space", "mouse:right")
    confirm_switch: tuple[str, ...] = ("key:Return", "key:Enter", "mouse:left")
    single_switch: tuple[str, ...] = ("key:Space", "key:Return", "key:Enter", "mouse:left")
    # the real arm's ready pose (degrees, one per joint) where its camera sees the panel; () = the
    # pose aimed at the simulated desk's panel place (``app.cli_assist.nominal_ready_pose``)
    ready_deg: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"assist mode {self.mode!r}: use one of {', '.join(MODES)}")
        if not MIN_PERIOD_S <= self.scan_period_s <= MAX_PERIOD_S:
            raise ValueError(f"scan period {self.scan_period_s} s is outside {MIN_PERIOD_S:g}…{MAX_PERIOD_S:g} s")
        if not 0.5 <= self.long_press_s <= 5.0:
            raise ValueError(f"long press {self.long_press_s} s is outside 0.5…5 s")
        for role in ("next_switch", "confirm_switch", "single_switch"):
            names = getattr(self, role)
            bad = [n for n in names if not is_switch_name(n)]
            if bad or not names:
                raise ValueError(f"{role} = {list(names)}: each switch is 'key:NAME' (a Qt key name such as "
                                 f"key:Space, key:Return, key:F1), one of mouse:left, mouse:right, mouse:middle, "
                                 f"gamepad:BTN_… (an evdev button, e.g. gamepad:BTN_SOUTH) or gpio:PIN (a "
                                 f"Raspberry Pi BCM pin, e.g. gpio:17)")
        if set(self.next_switch) & set(self.confirm_switch):
            raise ValueError(f"{sorted(set(self.next_switch) & set(self.confirm_switch))} is both 'next' and "
                             f"'confirm': give the two switches different keys or buttons")


def is_switch_name(name: str) -> bool:
    """'key:<Qt key name>', 'mouse:left|right|middle', 'gamepad:BTN_…' or 'gpio:PIN' (core.devices.switches)."""
    from core.devices.switches import is_device_switch_name

    if name in ("mouse:left", "mouse:right", "mouse:middle") or is_device_switch_name(name):
        return True
    if not name.startswith("key:") or len(name) <= 4:
        return False
    return QtGui.QKeySequence.fromString(name[4:])[0].key() != QtCore.Qt.Key.Key_unknown


def key_switch_name(event: QtGui.QKeyEvent) -> str:
    """The switch name of a key event: 'key:Space', 'key:Return', 'key:A', …"""
    return "key:" + QtGui.QKeySequence(event.key()).toString()


def switch_words(names) -> str:
    """Switch names in plain words: ("key:Space", "mouse:right") → "Space key or right mouse button".

    Enter and Return (one key on most keyboards, two Qt names) read as one "Enter key"."""
    words: list[str] = []
    for name in names:
        kind, _, what = name.partition(":")
        if kind == "key":
            text = "Enter key" if what in ("Return", "Enter") else f"{what} key"
        elif kind == "mouse":
            text = f"{what} mouse button"
        elif kind == "gamepad":
            text = f"gamepad {what}"
        elif kind == "gpio":
            text = f"switch on pin {what}"
        else:
            text = name
        if text not in words:
            words.append(text)
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " or " + words[-1]


def with_switches(settings: AssistSettings, specs) -> AssistSettings:
    """The settings with each ``SwitchSpec`` (``--switch NAME=ROLE``) added to its role's switches
    (and taken out of the other 2-switch role, so next and confirm never share a switch)."""
    roles = {"next": "next_switch", "confirm": "confirm_switch", "single": "single_switch"}
    changes = {field: tuple(getattr(settings, field)) for field in roles.values()}
    for spec in specs:
        field = roles[spec.role]
        if spec.name not in changes[field]:
            changes[field] = changes[field] + (spec.name,)
        other = {"next_switch": "confirm_switch", "confirm_switch": "next_switch"}.get(field)
        if other:
            changes[other] = tuple(n for n in changes[other] if n != spec.name)
    return replace(settings, **changes)


def device_switch_names(settings: AssistSettings) -> list[str]:
    """The switches in the settings that need a source of their own (gamepad buttons, GPIO pins)."""
    from core.devices.switches import is_device_switch_name

    names = [n for role in ("next_switch", "confirm_switch", "single_switch") for n in getattr(settings, role)]
    return sorted({n for n in names if is_device_switch_name(n)})


def settings_path() -> Path:
    from core.paths import user_dir

    return user_dir("config") / ASSIST_SETTINGS_FILE


_ASSIST_FIX = "using the defaults; fix or delete the file"


def _assist_value(key: str, value):
    """``value`` from assist.toml as the type of setting ``key`` wants, or ValueError saying what is expected."""
    import math

    default = AssistSettings.__dataclass_fields__[key].default

    def number(v) -> bool:
        return isinstance(v, (int, float)) and not isinstance(v, bool)

    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ValueError("expected true or false")
        return value
    if isinstance(default, float):
        if not number(value):
            raise ValueError("expected a number")
        return float(value)
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ValueError("expected a string")
        return value
    if key == "ready_deg":
        if not (isinstance(value, list) and all(number(v) and math.isfinite(v) for v in value)):
            raise ValueError("expected a list of finite numbers (degrees, one per joint)")
        return tuple(float(v) for v in value)
    if not (isinstance(value, list) and all(isinstance(v, str) for v in value)):  # the *_switch lists
        raise ValueError("expected a list of switch names such as [\"key:Space\", \"mouse:right\"]")
    return tuple(value)


def _short_value(value) -> str:
    """``repr(value)`` cut to a line: a value nested hundreds of levels deep stays readable."""
    import reprlib

    short = reprlib.Repr()
    short.maxlevel, short.maxlist, short.maxdict, short.maxstring, short.maxother = 2, 4, 4, 40, 40
    return short.repr(value)


def load_assist_settings(path: Optional[Path] = None) -> tuple[AssistSettings, list[str]]:
    """The saved settings (defaults when there is no file) and warnings for what was not usable.

    A file that cannot be read at all (not TOML, not UTF-8, nested too deeply) gives the defaults
    and one warning naming the file; a bad value gives the default for that setting only."""
    from core.paths import UserFileError, read_user_toml

    path = Path(path) if path else settings_path()
    try:
        data = read_user_toml(path, "the assistive view's settings", _ASSIST_FIX)
    except FileNotFoundError:
        return AssistSettings(), []
    except UserFileError as exc:
        return AssistSettings(), [str(exc)]
    settings, warnings = AssistSettings(), []
    for key, value in data.items():
        if key not in AssistSettings.__dataclass_fields__:
            warnings.append(f"{path}: unknown setting {key!r} ignored")
            continue
        try:
            settings = replace(settings, **{key: _assist_value(key, value)})
        except (TypeError, ValueError) as exc:
            warnings.append(f"{path}: {key} = {_short_value(value)}: {exc} — the default is used")
    return settings, warnings


def save_assist_settings(settings: AssistSettings, path: Optional[Path] = None) -> Path:
    import tomli_w

    from core.paths import write_file_atomically

    data = {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(settings).items()}
    text = "# deskarm: the assistive view's settings (written by the window)\n" + tomli_w.dumps(data)
    return write_file_atomically(Path(path) if path else settings_path(), text.encode())


# -----------------------------------------------------------------------------------------------
# the simulated desk's loop


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


# -----------------------------------------------------------------------------------------------
# the settings dialog


class SwitchSettingsDialog(StopDialog):
    """Which key or mouse button is "next", "confirm" and the single switch; the long press; sound."""

    def __init__(self, settings: AssistSettings, parent=None):
        super().__init__(parent)
        self.setWindowTitle("Switches")
        self.setModal(False)  # the window's STOP stays live beside it
        self.settings = settings
        form = QtWidgets.QFormLayout(self)
        self.stop_button = EStopButton()  # its own STOP, as every dialog of deskarm; Esc is STOP too
        self.stop_button.sigStopRequested.connect(self.request_stop)
        form.addRow("Esc or STOP stops the arm", self.stop_button)
        self.edits = {}
        for role, label in (("next_switch", "2 switches: next"), ("confirm_switch", "2 switches: confirm"),
                            ("single_switch", "1 switch")):
            edit = QtWidgets.QLineEdit(", ".join(getattr(settings, role)))
            edit.setMinimumHeight(TOUCH_PX)
            edit.setToolTip("Comma-separated: key:Space, key:Return, key:F1 … or mouse:left, mouse:right, "
                            "mouse:middle. Switch interfaces usually send Space or Enter.")
            self.edits[role] = edit
            form.addRow(label, edit)
        self.long_press = QtWidgets.QDoubleSpinBox()
        self.long_press.setRange(0.5, 5.0)
        self.long_press.setSingleStep(0.5)
        self.long_press.setSuffix(" s")
        self.long_press.setValue(settings.long_press_s)
        self.long_press.setStyleSheet(SPIN_STYLE)
        form.addRow("Hold to stop / re-arm", self.long_press)
        self.sound = QtWidgets.QCheckBox("Sound when the highlight moves")
        self.sound.setChecked(settings.sound)
        form.addRow(self.sound)
        self.error = QtWidgets.QLabel("")
        self.error.setWordWrap(True)
        self.error.setStyleSheet("color: #d32f2f;")
        form.addRow(self.error)
        buttons = QtWidgets.QDialogButtonBox(QtWidgets.QDialogButtonBox.StandardButton.Ok
                                             | QtWidgets.QDialogButtonBox.StandardButton.Cancel)
        buttons.setStyleSheet(BUTTON_STYLE)
        buttons.accepted.connect(self._accept)
        buttons.rejected.connect(self.reject)
        form.addRow(buttons)

    def result_settings(self) -> AssistSettings:
        """The settings as edited (ValueError naming the problem when they are not valid)."""
        switches = {role: tuple(n.strip() for n in edit.text().split(",") if n.strip())
                    for role, edit in self.edits.items()}
        return replace(self.settings, long_press_s=float(self.long_press.value()), sound=self.sound.isChecked(),
                       **switches)

    def _accept(self) -> None:
        try:
            self.settings = self.result_settings()
        except ValueError as exc:
            self.error.setText(str(exc))
            return
        self.accept()


# -----------------------------------------------------------------------------------------------
# the window


def grown_boxes(boxes: list) -> list:
    """The boxes drawn larger about their centres (up to BOX_GROWTH_MAX), never into a neighbour:
    bigger targets for a shaky finger, the same centres."""
    if not boxes:
        return []
    centres = [(x + w / 2, y + h / 2) for x, y, w, h in boxes]
    out = []
    for i, (x, y, w, h) in enumerate(boxes):
        cx, cy = centres[i]
        gaps = [max(abs(cx - ox), abs(cy - oy)) for j, (ox, oy) in enumerate(centres) if j != i]
        size = max(w, h)
        growth = BOX_GROWTH_MAX if not gaps else min(BOX_GROWTH_MAX, max(1.0, BOX_GAP_FRACTION * min(gaps) / size))
        out.append((cx - w * growth / 2, cy - h * growth / 2, w * growth, h * growth))
    return out


class AssistWindow(QtWidgets.QMainWindow):
    """The assistive view (see the module docstring). ``clock``: the time the scanning runs on
    (time.monotonic; a test passes its own). ``loop_factory``/``worker_clock``: the AssistWorker's."""

    sigStateText = QtCore.Signal(str)  # the state line changed (for tests and a log)
    sigDeviceSwitch = QtCore.Signal(str, bool)  # a gamepad / GPIO switch (name, pressed), from its thread

    def __init__(self, loop_factory: Callable[[], tuple] = build_sim_loop, worker_clock: str = "wall",
                 clock: Callable[[], float] = time.monotonic, settings_file: Optional[Path] = None,
                 parent=None, arm_factory: Optional[Callable[[object], object]] = None):
        super().__init__(parent)
        self.setWindowTitle("deskarm — assist")
        self._clock = clock
        self._settings_file = settings_file
        self.settings, self.settings_warnings = load_assist_settings(settings_file)
        self.boxes: list = []  # as offered (image px), numbered 1…
        self.hit_boxes: list = []  # as drawn and hit-tested (grown)
        self.status = None
        self.engaged = False
        self.ignored_taps = 0
        self.state_text = ""
        self._target: Optional[int] = None
        self._scanner = None
        self._down: Optional[dict] = None  # the switch held now: {name, role, t, fired, engaged_at_press}
        # a key switch's release that may be half of an auto-repeat pair: {name, t, stamp} (keyReleaseEvent)
        self._pending_release: Optional[dict] = None
        self.switch_sources: dict = {}  # device switch name → core.devices.switches.SwitchSource (running)
        self.switch_messages: list[str] = []  # what the device switches say is wrong (shown in the hint)
        self.settings_dialog: Optional[SwitchSettingsDialog] = None  # "Switches…" while open
        self._cue = None  # the sound cue, made when the first one is wanted
        self.sigDeviceSwitch.connect(self._on_device_switch, QtCore.Qt.ConnectionType.QueuedConnection)
        self._build()
        self.set_mode(self.settings.mode, save=False)
        self.worker = AssistWorker(loop_factory, worker_clock, self, arm_factory=arm_factory)
        self.worker.sigArm.connect(self._on_arm)
        self.worker.sigStopped.connect(self._on_worker_stopped)
        self.worker.sigBoxes.connect(self._on_boxes)
        self.worker.sigStatus.connect(self._on_status)
        self.worker.sigFrame.connect(self._on_frame)
        self.worker.sigError.connect(self._on_error)
        self._scan_timer = QtCore.QTimer(self)
        self._scan_timer.setInterval(SCAN_TICK_MS)
        self._scan_timer.timeout.connect(self.scan_tick)
        self._release_timer = QtCore.QTimer(self)  # ends a pending key release's wait (wall time)
        self._release_timer.setSingleShot(True)
        self._release_timer.setInterval(int(KEY_REPEAT_GRACE_S * 1000))
        self._release_timer.timeout.connect(lambda: self._resolve_pending_release(None))
        self.quit_action = QtGui.QAction("Quit", self)  # Ctrl+Q: a carer's key, not a switch's
        self.quit_action.setShortcut(QtGui.QKeySequence("Ctrl+Q"))
        self.quit_action.triggered.connect(self.quit)
        self.addAction(self.quit_action)
        self._set_state_text("starting the arm…")

    # -- layout -----------------------------------------------------------------------------------

    def _build(self) -> None:
        central = QtWidgets.QWidget()
        self.setCentralWidget(central)
        outer = QtWidgets.QVBoxLayout(central)
        outer.setContentsMargins(6, 4, 6, 6)
        outer.setSpacing(4)
        top = QtWidgets.QHBoxLayout()
        # ☰ in the top left corner, as far from STOP (top right) as the window allows; its menu is a
        # panel in the window, not a popup: nothing grabs the mouse or the keys while it is open, so
        # STOP and Esc stop as ever
        self.menu_button = SwitchSafeButton("☰", self._is_mouse_switch)
        self.menu_button.setObjectName("assistMenuButton")
        self.menu_button.setFixedSize(MENU_BUTTON_PX, MENU_BUTTON_PX)
        menu_font = QtGui.QFont(self.font())
        menu_font.setPixelSize(28)
        self.menu_button.setFont(menu_font)
        self.menu_button.setToolTip("Menu: Quit (also Ctrl+Q). In the switch modes the mouse buttons are "
                                    "switches here too: choose Touch first, or press Ctrl+Q.")
        self.menu_button.clicked.connect(self.toggle_menu)
        self.menu_button.sigSwitchPressed.connect(self.switch_down)
        self.menu_button.sigSwitchReleased.connect(self.switch_up)
        top.addWidget(self.menu_button)
        # RE-ARM (only while stopped) at the left, next to ☰, never where STOP is: pressing STOP
        # again "to make sure" lands on STOP
        self.rearm_button = RearmButton()
        self.rearm_button.hide()
        self.rearm_button.sigHeld.connect(self.rearm)
        top.addWidget(self.rearm_button)
        self.state_label = QtWidgets.QLabel("")
        font = self.state_label.font()
        font.setPointSize(22)
        font.setBold(True)
        self.state_label.setFont(font)
        self.state_label.setStyleSheet("color: white; background: #202020; border-radius: 6px; padding: 2px 10px;")
        self.state_label.setMinimumWidth(200)
        self.state_label.setSizePolicy(QtWidgets.QSizePolicy.Policy.Ignored, QtWidgets.QSizePolicy.Policy.Preferred)
        top.addWidget(self.state_label, 1)
        self.stop_button = EStopButton()
        self.stop_button.setFixedSize(self.stop_button.sizeHint().expandedTo(QtCore.QSize(150, TOUCH_PX + 8)))
        self.stop_button.sigStopRequested.connect(self.emergency_stop)
        top.addWidget(self.stop_button)
        outer.addLayout(top)
        # a press on STOP's area stops over any dialog or popup, Esc stops in every window (and
        # closes the menu), dialogs are kept off STOP, the keys come back after a dialog
        self.stop_guard = StopGuard(self.stop_button, self)
        self.stop_guard.sigStopRequested.connect(self.stop_from_anywhere)
        middle = QtWidgets.QHBoxLayout()
        self.view = AssistView()
        self.view.sigPressed.connect(self._on_view_pressed)
        self.view.sigReleased.connect(self._on_view_released)
        middle.addWidget(self.view, 1)
        side = QtWidgets.QVBoxLayout()
        side.setSpacing(6)
        self.mode_buttons = {}
        group = QtWidgets.QButtonGroup(self)
        group.setExclusive(True)
        mode_font = QtGui.QFont(self.font())
        mode_font.setPointSize(13)
        for mode in MODES:
            b = QtWidgets.QPushButton(MODE_NAMES[mode])
            b.setCheckable(True)
            b.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)
            b.setStyleSheet(BUTTON_STYLE)
            b.setFont(mode_font)
            b.clicked.connect(lambda _=False, m=mode: self.set_mode(m))
            group.addButton(b)
            self.mode_buttons[mode] = b
            side.addWidget(b)
        self.period_spin = QtWidgets.QDoubleSpinBox()
        self.period_spin.setRange(MIN_PERIOD_S, MAX_PERIOD_S)
        self.period_spin.setSingleStep(0.5)
        self.period_spin.setDecimals(1)
        self.period_spin.setPrefix("every ")  # the 1-switch scan period (no label: room for the hint)
        self.period_spin.setSuffix(" s")
        self.period_spin.setValue(self.settings.scan_period_s)
        self.period_spin.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)
        self.period_spin.setStyleSheet(SPIN_STYLE)
        self.period_spin.setFont(mode_font)
        self.period_spin.valueChanged.connect(self.set_scan_period)
        side.addWidget(self.period_spin)
        self.settings_button = QtWidgets.QPushButton("Switches…")
        self.settings_button.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)
        self.settings_button.setStyleSheet(BUTTON_STYLE)
        self.settings_button.setFont(mode_font)
        self.settings_button.clicked.connect(self.open_settings)
        side.addWidget(self.settings_button)
        self.arm_label = QtWidgets.QLabel("")  # the driven arm's link (hidden on the simulated desk)
        self.arm_label.setWordWrap(False)  # one line: "arm: connected", "arm: NOT CONNECTED"
        self.arm_label.hide()
        side.addWidget(self.arm_label)
        self.hint_label = QtWidgets.QLabel("")
        self.hint_label.setWordWrap(True)
        hint_font = QtGui.QFont(self.font())
        hint_font.setPointSize(11)
        self.hint_label.setFont(hint_font)
        self.arm_label.setFont(hint_font)
        self.hint_label.setAlignment(QtCore.Qt.AlignmentFlag.AlignTop)
        side.addWidget(self.hint_label, 1)
        side.setContentsMargins(4, 0, 0, 0)  # the column's width and height go to the hint's lines
        side_widget = QtWidgets.QWidget()
        side_widget.setLayout(side)
        side_widget.setFixedWidth(190)
        middle.addWidget(side_widget)
        outer.addLayout(middle, 1)
        self.setFocusPolicy(QtCore.Qt.FocusPolicy.StrongFocus)
        self._build_menu(central)

    def _build_menu(self, central: QtWidgets.QWidget) -> None:
        """The ☰ menu: a panel over the camera view under the ☰ button, hidden until asked for."""
        self.menu_panel = QtWidgets.QFrame(central)
        self.menu_panel.setObjectName("assistMenu")
        self.menu_panel.setStyleSheet("#assistMenu { background: #303030; border: 2px solid #9e9e9e; "
                                      "border-radius: 8px; }")
        box = QtWidgets.QVBoxLayout(self.menu_panel)
        box.setContentsMargins(8, 8, 8, 8)
        box.setSpacing(8)
        font = QtGui.QFont(self.font())
        font.setPointSize(14)
        self.quit_button = SwitchSafeButton("Quit  (Ctrl+Q)", self._is_mouse_switch)
        self.close_menu_button = SwitchSafeButton("Close menu", self._is_mouse_switch)
        for button in (self.quit_button, self.close_menu_button):
            button.setStyleSheet(BUTTON_STYLE)
            button.setFont(font)
            button.setMinimumWidth(200)
            button.sigSwitchPressed.connect(self.switch_down)
            button.sigSwitchReleased.connect(self.switch_up)
            box.addWidget(button)
        self.quit_button.clicked.connect(self.quit)
        self.close_menu_button.clicked.connect(self.close_menu)
        self.menu_panel.hide()

    def _is_mouse_switch(self, name: str) -> bool:
        """True when mouse button ``name`` is a switch in the current mode (never in touch mode)."""
        return self._role(name) is not None

    def toggle_menu(self) -> None:
        """Open the ☰ menu (or close it when open)."""
        if self.menu_panel.isVisible():
            self.close_menu()
            return
        self.menu_panel.adjustSize()
        corner = self.menu_button.mapTo(self.centralWidget(), QtCore.QPoint(0, self.menu_button.height() + 4))
        self.menu_panel.move(corner)
        self.menu_panel.raise_()
        self.menu_panel.show()

    def close_menu(self) -> None:
        self.menu_panel.hide()

    def quit(self) -> None:
        """Quit (Ctrl+Q, the ☰ menu): the arm holds where it is, the worker ends, the window closes."""
        self.close_menu()
        if self.worker.isRunning():
            self.worker.emergency_stop()  # handled before the worker's quit: the arm is e-stopped, then let go
        self.close()

    # -- life cycle -------------------------------------------------------------------------------

    def start(self) -> None:
        self.worker.start()
        self._scan_timer.start()
        self._start_switch_sources()

    def stop(self) -> None:
        """Stop the scan timer, the switch sources and the worker (all joined)."""
        self._scan_timer.stop()
        self.stop_guard.remove()
        self._stop_switch_sources()
        if self._cue is not None:
            self._cue.close()
        if self.worker.isRunning():
            self.worker.stop()

    # -- gamepad and GPIO switches ------------------------------------------------------------------

    def _start_switch_sources(self) -> None:
        """One source per gamepad / GPIO switch in the settings (others stopped); each press and
        release reaches ``switch_down`` / ``switch_up`` in the GUI thread, as a key's would."""
        from core.devices.switches import make_switch_source

        wanted = set(device_switch_names(self.settings))
        for name in [n for n in self.switch_sources if n not in wanted]:
            self.switch_sources.pop(name).stop()
        for name in sorted(wanted - set(self.switch_sources)):
            source = make_switch_source(name, self.sigDeviceSwitch.emit)
            self.switch_sources[name] = source
            source.start()

    def _stop_switch_sources(self) -> None:
        for source in self.switch_sources.values():
            source.stop()
        self.switch_sources = {}

    def _on_device_switch(self, name: str, pressed: bool) -> None:
        if pressed:
            self.switch_down(name)
        else:
            self.switch_up(name)

    def check_switch_sources(self) -> None:
        """Show what the gamepad / GPIO switches report (missing library, no device, …) in the hint."""
        messages = [s.status_message for s in self.switch_sources.values() if s.status_message]
        camera_message = getattr(getattr(self.worker.loop, "camera", None), "status_message", "")
        if camera_message:  # a real hand camera unplugged (never a crash: the loop runs on black frames)
            messages.insert(0, camera_message)
        if messages != self.switch_messages:
            self.switch_messages = messages
            self._update_hint()

    def closeEvent(self, event: QtGui.QCloseEvent) -> None:  # noqa: N802 (Qt override)
        self.stop()
        super().closeEvent(event)

    # -- settings ---------------------------------------------------------------------------------

    def _save(self) -> None:
        try:
            save_assist_settings(self.settings, self._settings_file)
        except OSError as exc:
            self.hint_label.setText(str(exc))

    def set_mode(self, mode: str, save: bool = True) -> None:
        """Switch the input mode (touch, scan2, scan1); any scan starts over."""
        if mode not in MODES:
            raise ValueError(f"assist mode {mode!r}: use one of {', '.join(MODES)}")
        self.settings = replace(self.settings, mode=mode)
        self.mode_buttons[mode].setChecked(True)
        self.period_spin.setEnabled(mode == "scan1")
        self._down = None
        self._pending_release = None
        self._restart_scan()
        self._update_hint()
        if save:
            self._save()

    def set_scan_period(self, period_s: float) -> None:
        period_s = min(MAX_PERIOD_S, max(MIN_PERIOD_S, float(period_s)))
        self.settings = replace(self.settings, scan_period_s=period_s)
        if abs(self.period_spin.value() - period_s) > 1e-9:
            self.period_spin.setValue(period_s)
        self._restart_scan()
        self._save()

    def set_settings(self, settings: AssistSettings) -> None:
        self.settings = settings
        self.set_mode(settings.mode)
        if self.worker.isRunning():
            self._start_switch_sources()

    def open_settings(self) -> "SwitchSettingsDialog":
        """"Switches…": not modal (the window's STOP stays live beside it, kept uncovered), with
        its own STOP; Esc is STOP; OK applies the settings."""
        dialog = self.settings_dialog
        if dialog is not None and dialog.isVisible():
            dialog.raise_()
            return dialog
        dialog = self.settings_dialog = SwitchSettingsDialog(self.settings, self)
        dialog.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
        dialog.sigStopRequested.connect(self.emergency_stop)
        dialog.accepted.connect(lambda: self.set_settings(dialog.settings))
        dialog.show()
        dialog.raise_()
        dialog.activateWindow()
        return dialog

    def stop_from_anywhere(self) -> None:
        """STOP's area pressed or Esc typed, whatever is open: the menu closes and the arm stops."""
        self.close_menu()
        self.emergency_stop()

    def add_warning(self, text: str) -> None:
        """A settings problem the user should see (shown under the hint)."""
        self.settings_warnings.append(text)
        self._update_hint()

    def _update_hint(self) -> None:
        s = self.settings
        hold = f"Hold {s.long_press_s:g} s: stop (again: re-arm)."
        text = {"touch": "Tap a numbered box.",
                "scan2": f"Next: {switch_words(s.next_switch)}.\nGo: {switch_words(s.confirm_switch)}.\n{hold}",
                "scan1": f"Press the {switch_words(s.single_switch)} when your box is yellow.\n{hold}"}[s.mode]
        if self.switch_messages or self.settings_warnings:
            text += "\n\n" + "\n".join(self.switch_messages + self.settings_warnings)
        self.hint_label.setText(text)

    # -- what the worker says ---------------------------------------------------------------------

    @property
    def choosing(self) -> bool:
        """True when a choice may be made: boxes offered, the arm idle, not stopped."""
        return bool(self.boxes) and not self.engaged and (self.status is None or self.status.state == "IDLE") \
            and self._target is None

    def _on_boxes(self, boxes: list) -> None:
        self.boxes = list(boxes)
        self.hit_boxes = grown_boxes(self.boxes)
        self.view.set_boxes(self.hit_boxes)
        self.view.set_chosen(None)
        self._target = None
        self._restart_scan()
        if not self.engaged:
            self._set_state_text("choose a button" if self.boxes else "no buttons in view")

    def _on_frame(self) -> None:
        image, status = self.worker.take_frame()
        if image is not None:
            self.view.set_image(image)
        if status is not None and status.state in ("ALIGN", "APPROACH", "ACT") and not self.engaged:
            self.view.set_follow(status.centre_px, status.radius_px)

    def _on_arm(self, state: str, text: str) -> None:
        """One short line in the side column (the narrow 800x480 layout); the bridge's whole
        message goes to the tooltip and, when something is wrong, to the log."""
        self.arm_label.setText(f"arm: {state}")
        self.arm_label.setToolTip(text)
        self.arm_label.setVisible(bool(state))
        bad = state in ("E-STOP", "not connected")
        self.arm_label.setStyleSheet("color: white; background: #b00020; padding: 2px;" if bad else "color: #1b5e20;")
        if bad:
            print(f"deskarm --assist: arm {text}", file=sys.stderr)

    def _on_worker_stopped(self, reason: str) -> None:
        """The worker stopped the arm (its board went away): the window's STOP, with the reason."""
        self.emergency_stop()
        self._set_state_text("stopped: arm not connected")
        self.hint_label.setText("Board unplugged: plug it back in, then hold RE-ARM.")
        print(f"deskarm --assist: {reason}", file=sys.stderr)

    def _on_error(self, message: str) -> None:
        self._set_state_text("error")
        self.hint_label.setText(message)

    def _on_status(self, status) -> None:
        previous = self.status
        self.status = status
        n = None if status.target_index is None else status.target_index + 1
        if self.engaged:  # a state change queued before the stop reached the worker: the stop wins
            if not self.state_text.startswith("stopped"):  # (keeps "stopped: arm not connected")
                self._set_state_text("stopped")
        elif status.state in ("ALIGN", "APPROACH", "ACT"):
            self._target = status.target_index
            self.view.set_chosen(status.target_index, status.centre_px)
            self.view.set_highlight(None)
            verb = {"ALIGN": "aligning with", "APPROACH": "approaching", "ACT": "pressing"}[status.state]
            self._set_state_text(f"{verb} {n}")
        elif status.state in ("IDLE", "RETURN") and previous is not None and previous.state in ("ALIGN", "APPROACH", "ACT"):
            outcome = status.outcome or ""
            if outcome.startswith(("pressed", "touched")):
                self._set_state_text(f"done: {n} pressed")
            else:
                self._set_state_text(f"could not reach {n}: {outcome.split(':')[0]}")
            self.view.set_chosen(None)
            self.boxes, self.hit_boxes = [], []  # the camera has moved: offered again from the ready pose
            self.view.set_boxes([])
        elif status.state == "RETURN" and not self.state_text.startswith(("done", "could not")):
            self._set_state_text("going back")

    def _set_state_text(self, text: str) -> None:
        if text == self.state_text:
            return
        self.state_text = text
        self.state_label.setText(text)
        self.sigStateText.emit(text)

    # -- stop and re-arm --------------------------------------------------------------------------

    def emergency_stop(self) -> None:
        """STOP: the arm holds, any choice is cancelled; RE-ARM (a hold) resumes."""
        self.engaged = True
        self.worker.emergency_stop()
        self.stop_button.set_engaged(True)
        self.rearm_button.show()
        self._target = None
        self._scanner = None
        self.boxes, self.hit_boxes = [], []  # stale once the arm has moved: offered again after the re-arm
        self.view.set_boxes([])
        self.view.set_highlight(None)
        self.view.set_chosen(None)
        self._set_state_text("stopped")

    def rearm(self) -> None:
        if not self.engaged:
            return
        self.engaged = False
        self.boxes = []
        self.worker.rearm()
        self.stop_button.set_engaged(False)
        self.rearm_button.hide()
        self._set_state_text("going back")

    # -- choosing ---------------------------------------------------------------------------------

    def _restart_scan(self) -> None:
        self._scanner = None
        self.view.set_highlight(None)
        if not self.choosing or self.settings.mode == "touch":
            return
        if self.settings.mode == "scan2":
            self._scanner = TwoSwitchScanner(len(self.boxes))
            self.view.set_highlight(0)
        else:
            self._scanner = OneSwitchScanner(len(self.boxes), self.settings.scan_period_s, self.settings.long_press_s)
            self.view.set_highlight(self._scanner.start(self._clock()).index)

    def _choose(self, index: int) -> None:
        if not self.choosing:
            return
        self._target = index
        self._scanner = None
        self.view.set_highlight(None)
        self.view.set_chosen(index)
        self._set_state_text(f"aligning with {index + 1}")
        self.worker.select(index)

    def _moved_highlight(self, index: int) -> None:
        self.view.set_highlight(index)
        if self.settings.sound:
            self.sound_cue().play()

    def sound_cue(self):
        """The highlight's sound cue (``app.sound_cue.SoundCue``), made on first use."""
        if self._cue is None:
            from app.sound_cue import SoundCue

            self._cue = SoundCue(QtWidgets.QApplication.beep)
        return self._cue

    def tap(self, image_point: Optional[tuple[float, float]], box: Optional[int] = None) -> None:
        """Touch mode: a tap at an image point (None: beside the image); ``box``: the box the view
        found under the tap (its outline or its number badge — one target), which is then chosen."""
        if not self.choosing:
            if image_point is not None:
                self.view.acknowledge(image_point)
            return
        if box is not None and 0 <= box < len(self.hit_boxes):
            self._choose(box)
            return
        if image_point is None:
            self.ignored_taps += 1
            return
        event = TouchSelector(self.hit_boxes).tap(image_point[0], image_point[1], self._clock())
        if event.kind == "select":
            self._choose(event.index)
        else:
            self.ignored_taps += 1
            self.view.acknowledge(image_point)

    def _role(self, name: str) -> Optional[str]:
        s = self.settings
        if s.mode == "scan1":
            return "single" if name in s.single_switch else None
        if s.mode == "scan2":
            if name in s.next_switch:
                return "next"
            if name in s.confirm_switch:
                return "confirm"
        return None

    def switch_down(self, name: str) -> bool:
        """A switch went down (key or mouse button by name); True when it is mapped."""
        role = self._role(name)
        if role is None or self._down is not None:
            return role is not None
        now = self._clock()
        self._down = {"name": name, "role": role, "t": now, "fired": False, "engaged_at_press": self.engaged}
        if role == "single" and isinstance(self._scanner, OneSwitchScanner):
            self._scan_events(self._scanner.press(now))
        return True

    def switch_up(self, name: str, now: Optional[float] = None) -> bool:
        """The switch came up (``now``: when, on the window's clock; default now): a short press
        acts (next, confirm, select), a long one already did."""
        down = self._down
        if down is None or down["name"] != name:
            return self._role(name) is not None
        now = self._clock() if now is None else now
        self._check_hold(now)
        self._down = None
        if isinstance(self._scanner, OneSwitchScanner) and down["role"] == "single":
            events = self._scanner.release(now)
            if not down["fired"]:
                self._scan_events(events)
            return True
        if down["fired"] or not self.choosing or not isinstance(self._scanner, TwoSwitchScanner):
            return True
        if down["role"] == "next":
            self._moved_highlight(self._scanner.next(now).index)
        elif down["role"] == "confirm":
            self._choose(self._scanner.confirm(now).index)
        return True

    def _check_hold(self, now: float) -> None:
        """A switch held for long_press_s: stop (or, when the press began stopped, re-arm)."""
        down = self._down
        pending = self._pending_release
        if pending is not None and down is not None and pending["name"] == down["name"]:
            now = pending["t"]  # released then, unless a press of the same instant shows an auto-repeat
        if down is None or down["fired"] or now - down["t"] < self.settings.long_press_s:
            return
        down["fired"] = True
        if down["engaged_at_press"]:
            self.rearm()
        else:
            self.emergency_stop()

    def _scan_events(self, events) -> None:
        for event in events:
            if event.kind == "highlight":
                self._moved_highlight(event.index)
            elif event.kind == "select":
                self._choose(event.index)
            # "stop": handled by _check_hold, the same for every switch mode

    def scan_tick(self) -> None:
        """The timed scan and the long-press hold, at the window's clock (SCAN_TICK_MS)."""
        now = self._clock()
        self._resolve_pending_release(now)
        self._check_hold(now)
        self.check_switch_sources()
        if isinstance(self._scanner, OneSwitchScanner) and self.choosing:
            self._scan_events(self._scanner.tick(now))

    # -- events -----------------------------------------------------------------------------------

    def _on_view_pressed(self, name: str, point, box=None) -> None:
        if self.settings.mode == "touch":
            if name == "mouse:left":
                self.tap(point, box)
            return
        self.switch_down(name)

    def _on_view_released(self, name: str) -> None:
        if self.settings.mode != "touch":
            self.switch_up(name)

    def mousePressEvent(self, event: QtGui.QMouseEvent) -> None:  # noqa: N802 (Qt override)
        """A mouse switch pressed beside the view (the state line, the margins) is the switch too."""
        name = MOUSE_NAMES.get(event.button())
        if name is not None and self._is_mouse_switch(name):
            event.accept()
            self.switch_down(name)
            return
        super().mousePressEvent(event)

    def mouseReleaseEvent(self, event: QtGui.QMouseEvent) -> None:  # noqa: N802 (Qt override)
        name = MOUSE_NAMES.get(event.button())
        if name is not None and self._is_mouse_switch(name):
            event.accept()
            self.switch_up(name)
            return
        super().mouseReleaseEvent(event)

    def keyPressEvent(self, event: QtGui.QKeyEvent) -> None:  # noqa: N802 (Qt override)
        if event.key() == QtCore.Qt.Key.Key_Escape:
            event.accept()
            self.close_menu()
            self.emergency_stop()
            return
        name = key_switch_name(event)
        if event.isAutoRepeat():
            event.accept() if self._role(name) else super().keyPressEvent(event)
            return
        pending = self._pending_release
        if pending is not None:
            if pending["name"] == name and is_auto_repeat_pair(pending["stamp"], event.timestamp()):
                # the X server's auto-repeat, delivered unflagged: the key never came up
                self._pending_release = None
                self._release_timer.stop()
                event.accept()
                return
            self._resolve_pending_release(None)  # it was a real release: it acts before this press
        if self.switch_down(name):
            event.accept()
            return
        super().keyPressEvent(event)

    def keyReleaseEvent(self, event: QtGui.QKeyEvent) -> None:  # noqa: N802 (Qt override)
        """A key switch's release acts at once — unless it may be half of an auto-repeat pair.

        With X11 auto-repeat a held key arrives as release/press pairs carrying one timestamp;
        Qt flags them ``isAutoRepeat()`` only when the press is already queued when it reads the
        release (measured under Xvfb with the window running: every pair came unflagged). So a
        release with a timestamp is kept for ``KEY_REPEAT_GRACE_S``: a press of the same key with
        the same timestamp cancels it (the hold goes on: no "next", no new press), anything else —
        the grace passing, another key — lets it act. A release without a timestamp (0: a
        synthetic event) cannot be told apart and acts at once."""
        if event.isAutoRepeat():
            event.accept()
            return
        name = key_switch_name(event)
        if self._pending_release is not None:
            self._resolve_pending_release(None)
        down = self._down
        if event.timestamp() and down is not None and down["name"] == name:
            self._pending_release = {"name": name, "t": self._clock(), "stamp": event.timestamp()}
            self._release_timer.start()
            event.accept()
            return
        if self.switch_up(name):
            event.accept()
            return
        super().keyReleaseEvent(event)

    def _resolve_pending_release(self, now: Optional[float]) -> None:
        """A pending key release acts (``now`` None: at once; else once the grace has passed on
        the window's clock)."""
        pending = self._pending_release
        if pending is None or (now is not None and now - pending["t"] < KEY_REPEAT_GRACE_S):
            return
        self._pending_release = None
        self._release_timer.stop()
        self.switch_up(pending["name"], pending["t"])  # as long as the key was really held, not the wait


def is_auto_repeat_pair(release_stamp: int, press_stamp: int) -> bool:
    """True when a key press is the second half of an auto-repeat pair with a release: the X
    server stamps both with the same time (ms); a person cannot release and press again within
    the same millisecond. Unknown (0) timestamps never pair."""
    return bool(release_stamp) and release_stamp == press_stamp


def build_assist_window(seed: int = 0, vibration: bool = False, hand_camera=None, switches=(), depth: str = "auto",
                        bridge_url: str = "sim://", passing_hand: bool = False, detector: str = "circles",
                        worker_clock: str = "wall") -> AssistWindow:
    """The assistive view as ``deskarm --assist`` runs it (not shown, not started): on the simulated
    desk, or with ``hand_camera`` (a webcam device: ``core.devices.hand_camera.parse_hand_camera_spec``)
    on a real one; the loop's joints go through the safety chain to ``bridge_url`` (``sim://``: the
    simulated servo arm). ``switches``: ``SwitchSpec``s added to the saved settings (gamepad / GPIO /
    keys). ``passing_hand``: on the simulated desk, a hand reaches in over the panel now and then."""
    import math

    from core.devices import open_bridge
    from core.kinematics.profile import load_profile

    profile = load_profile("assistive_5dof")
    bridge = open_bridge(bridge_url, profile)  # not connected yet: the worker connects it
    ready: dict = {}  # the settings' ready pose, read once the window has loaded them (before start)
    if hand_camera is None:
        factory = lambda: build_sim_loop(seed, vibration, passing_hand, detector)  # noqa: E731
    else:
        factory = lambda: build_webcam_loop(hand_camera, bridge=bridge, depth=depth,  # noqa: E731
                                            ready_q=ready.get("q"), detector=detector)
    window = AssistWindow(factory, worker_clock=worker_clock, arm_factory=guarded_arm_factory(bridge))
    ready_deg = window.settings.ready_deg
    if ready_deg:
        problem = ready_pose_problem(ready_deg, profile)
        if problem:
            window.add_warning(f"{problem}; the default ready pose is used")
        else:
            ready["q"] = tuple(math.radians(v) for v in ready_deg)
    if switches:
        window.set_settings(with_switches(window.settings, switches))
    return window


def show_filling_screen(window: QtWidgets.QWidget, size: tuple[int, int] = (800, 480)) -> None:
    """Show ``window`` over all of its screen's available geometry, with or without a window manager.

    Full screen (no title bar) on a screen no bigger than ``size`` (the 7" 800×480 panel),
    maximised on a bigger one. The geometry is set first: with no window manager nothing acts on
    the full-screen or maximised state, and the window came up at its size hint (526×392 on an
    800×480 screen: 30 px boxes, the hint cut off)."""
    screen = window.screen() or QtGui.QGuiApplication.primaryScreen()
    free = screen.availableGeometry() if screen is not None else QtCore.QRect(0, 0, *size)
    window.setGeometry(free)
    if free.width() <= size[0] and free.height() <= size[1]:
        window.showFullScreen()
    else:
        window.showMaximized()
    if window.geometry() != free:  # a platform that ignored the state (offscreen, X11 without a manager)
        window.setGeometry(free)
    if QtGui.QGuiApplication.platformName() != "offscreen":  # (offscreen has no raise: it would only warn)
        window.raise_()
        window.activateWindow()  # the keys (Esc, Ctrl+Q, key switches) go to the window from the start


def run_assist_window(size: tuple[int, int] = (800, 480), seed: int = 0, vibration: bool = False,
                      hand_camera=None, switches=(), depth: str = "auto", bridge_url: str = "sim://",
                      passing_hand: bool = False, detector: str = "circles") -> int:
    """Open the assistive view (wall clock), filling its screen, and run until it is closed: on the
    simulated desk, or with ``hand_camera`` on a real one (``build_assist_window``). ``bridge_url``:
    the arm the loop's joints go to through the safety chain (``sim://``: the simulated servo arm; a
    v1/v2 serial port or phidget://: a real one — the caller refuses a real arm on the simulated desk
    unless asked for on purpose). ``size``: the largest screen shown full screen (a bigger one gets
    a maximised window)."""
    from app.startup import GuiThreadGarbage, make_app

    app = make_app()
    window = build_assist_window(seed, vibration, hand_camera, switches, depth, bridge_url, passing_hand, detector)
    app.aboutToQuit.connect(window.stop)
    garbage = GuiThreadGarbage(app)  # collections only in the GUI thread (see app/startup.py)
    app.aboutToQuit.connect(garbage.stop)
    show_filling_screen(window, size)
    window.start()
    return app.exec()


def take_assist_screenshot(path: str, size: tuple[int, int] = (800, 480), after_s: float = 2.0, seed: int = 0,
                           hand_camera=None, switches=(), passing_hand: bool = False,
                           detector: str = "circles") -> int:
    """``deskarm --assist --screenshot PATH``: the assistive view offscreen at exactly ``size``, in the
    saved input mode, once the boxes are offered (at least ``after_s`` s after the start, at most
    SCREENSHOT_WAIT_S more), saved as a PNG of exactly WxH pixels. The arm is always the simulated
    servo arm: a screenshot never moves a real one. Returns the exit code (1: not written)."""
    from app.startup import make_app

    app = make_app()
    window = build_assist_window(seed, False, hand_camera, switches, "auto", "sim://", passing_hand, detector,
                                 worker_clock="sim")
    window.setFixedSize(*size)  # exactly what was asked for, even below the layout's minimum
    window.show()
    window.start()
    started = time.monotonic()
    result: dict = {}

    def poll() -> None:
        elapsed = time.monotonic() - started
        ready = window.choosing or window.state_text == "error"
        if elapsed < after_s or (not ready and elapsed < after_s + SCREENSHOT_WAIT_S):
            return
        timer.stop()
        image = window.grab().toImage()
        if (image.width(), image.height()) != size:  # a device pixel ratio other than 1
            image = image.scaled(*size, QtCore.Qt.AspectRatioMode.IgnoreAspectRatio,
                                 QtCore.Qt.TransformationMode.SmoothTransformation)
        result.update(saved=image.save(path, "PNG"), state=window.state_text, after_s=elapsed)
        window.stop()
        window.close()
        app.quit()

    timer = QtCore.QTimer()
    timer.setInterval(50)
    timer.timeout.connect(poll)
    timer.start()
    app.exec()
    if not result.get("saved"):
        print(f"deskarm: could not write the screenshot to {path}: check the folder exists and is writable",
              file=sys.stderr)
        return 1
    mode = MODE_NAMES[window.settings.mode]
    print(f"deskarm: screenshot saved to {path} ({size[0]}x{size[1]}, assistive view, {mode}: "
          f"{result['state']}, after {result['after_s']:.1f} s)")
    return 0
