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

``AssistWorker`` (a QThread, ``app.assist.arm_chain``) runs ``core.motion.assist_loop.AssistLoop``
on the simulated desk (the still lift panel of ``deskarm assist-trials``, the ``assistive_5dof``
arm) or on a webcam as the hand camera: on a simulated clock (frames as fast as the CPU goes:
tests) or paced by the wall clock (30 frames/s). With an arm (``guarded_arm_factory``: the
simulated servo arm by default, a v1/v2 board or a Phidget board with ``--bridge``) every joint
value goes through the safety chain of ``core.devices.guarded_arm.GuardedArm`` to it.

The window is a composition: it builds the frame (the view, the state line, the STOP/RE-ARM strip,
the side column) and holds what is chosen and whether STOP is engaged; each capability is a
feature of ``app.assist`` (see its ``__init__``): the arm chain, the input modes, the switches,
"Switches…", the sound cue, the ☰ menu and the screen. The names other modules import from here
(settings, loops, dialogs, …) are re-exported.
"""
from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Callable, Optional

from PySide6 import QtCore, QtGui, QtWidgets

from app.assist.arm_chain import ArmChain, build_sim_loop
from app.assist.menu import AssistMenu
from app.assist.modes import ChoiceModes
from app.assist.screens import screenshot_when_ready, show_filling_screen
from app.assist.settings import (MODE_NAMES, MODES, AssistSettings, hint_text, load_assist_settings,
                                 save_assist_settings, switch_role)
from app.assist.settings_dialog import SwitchSettingsDialog, SwitchSettingsEditor
from app.assist.sound import HighlightSound
from app.assist.switches import SwitchInput
from core.motion.assist_loop import MOVING_STATES, state_line
from core.motion.scanning import MAX_PERIOD_S, MIN_PERIOD_S, grown_boxes
from widgets._style import TOUCH_PX
from widgets.assist_view import MOUSE_NAMES, AssistView
from widgets.estop import EStopButton, RearmButton, StopGuard

# build_assist_window's loops and arm, and the names other modules and tests import from here (moved)
from app.assist.arm_chain import (PREVIEW_PERIOD_S, AssistWorker, build_webcam_loop,  # noqa: E402,F401,I001
                                  guarded_arm_factory, ready_pose_problem)
from app.assist.menu import MENU_BUTTON_PX  # noqa: E402,F401
from app.assist.screens import SCREENSHOT_WAIT_S  # noqa: E402,F401
from app.assist.settings import (ASSIST_SETTINGS_FILE, device_switch_names, is_switch_name,  # noqa: E402,F401
                                 key_switch_name, settings_path, switch_words, with_switches)
from core.motion.scanning import BOX_GAP_FRACTION, BOX_GROWTH_MAX  # noqa: E402,F401
from core.motion.switch_presses import KEY_REPEAT_GRACE_S, is_auto_repeat_pair  # noqa: E402,F401

SCAN_TICK_MS = 40  # how often the timed scan and the long-press hold are checked


class AssistWindow(QtWidgets.QMainWindow):
    """The assistive view (see the module docstring). ``clock``: the time the scanning runs on
    (time.monotonic; a test passes its own). ``loop_factory``/``worker_clock``: the AssistWorker's."""

    sigStateText = QtCore.Signal(str)  # the state line changed (for tests and a log)

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
        self.state_text = ""
        self._target: Optional[int] = None
        self.switch_messages: list[str] = []  # what the device switches and the camera say is wrong (in the hint)
        side_font = QtGui.QFont(self.font())
        side_font.setPointSize(13)
        self.view = AssistView()
        self.sound = HighlightSound(lambda: self.settings.sound)
        self.modes = ChoiceModes(self.view, lambda: self.choosing, self._choose, self.sound.moved, clock, side_font,
                                 self.settings.scan_period_s, self)
        self.switches = SwitchInput(self._role, lambda: self.settings.long_press_s, lambda: self.engaged, clock,
                                    self.modes.press, self.modes.release, self._held, self)
        self.arm_chain = ArmChain(loop_factory, worker_clock, self.view, lambda: self.engaged, self,
                                  arm_factory=arm_factory)
        self.worker = self.arm_chain.worker
        self.switch_editor = SwitchSettingsEditor(lambda: self.settings, self, side_font)
        self._build(side_font)
        self.modes.sigModeChosen.connect(self.set_mode)
        self.modes.sigPeriodChanged.connect(self.set_scan_period)
        self.switch_editor.sigApplied.connect(self.set_settings)
        self.switch_editor.sigStopRequested.connect(self.emergency_stop)
        self.menu.sigQuit.connect(self.quit)
        self.set_mode(self.settings.mode, save=False)
        self.arm_chain.sigStopped.connect(self._on_worker_stopped)
        self.arm_chain.sigBoxes.connect(self._on_boxes)
        self.arm_chain.sigStatus.connect(self._on_status)
        self.arm_chain.sigError.connect(self._on_error)
        self._scan_timer = QtCore.QTimer(self)
        self._scan_timer.setInterval(SCAN_TICK_MS)
        self._scan_timer.timeout.connect(self.scan_tick)
        self._set_state_text("starting the arm…")

    # -- layout -----------------------------------------------------------------------------------

    def _build(self, side_font: QtGui.QFont) -> None:
        central = QtWidgets.QWidget()
        self.setCentralWidget(central)
        outer = QtWidgets.QVBoxLayout(central)
        outer.setContentsMargins(6, 4, 6, 6)
        outer.setSpacing(4)
        top = QtWidgets.QHBoxLayout()
        self.menu = AssistMenu(self, central, self._is_mouse_switch, self.switch_down, self.switch_up)
        self.menu_button, self.menu_panel, self.quit_button = self.menu.button, self.menu.panel, self.menu.quit_button
        self.close_menu_button, self.quit_action = self.menu.close_button, self.menu.quit_action
        top.addWidget(self.menu_button)  # ☰ in the top left corner, as far from STOP as the window allows
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
        self.view.sigPressed.connect(self._on_view_pressed)
        self.view.sigReleased.connect(self._on_view_released)
        middle.addWidget(self.view, 1)
        side = QtWidgets.QVBoxLayout()
        side.setSpacing(6)
        self.mode_buttons, self.period_spin = self.modes.buttons, self.modes.period_spin
        self.settings_button, self.arm_label = self.switch_editor.button, self.arm_chain.label
        for widget in (*self.modes.widgets(), self.settings_button, self.arm_label):
            side.addWidget(widget)
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

    def _is_mouse_switch(self, name: str) -> bool:
        """True when mouse button ``name`` is a switch in the current mode (never in touch mode)."""
        return self._role(name) is not None

    def _role(self, name: str) -> Optional[str]:
        return switch_role(self.settings, name)

    def toggle_menu(self) -> None:
        """Open the ☰ menu (or close it when open)."""
        self.menu.toggle()

    def close_menu(self) -> None:
        self.menu.close()

    def quit(self) -> None:
        """Quit (Ctrl+Q, the ☰ menu): the arm holds where it is, the worker ends, the window closes."""
        self.close_menu()
        if self.worker.isRunning():
            self.worker.emergency_stop()  # handled before the worker's quit: the arm is e-stopped, then let go
        self.close()

    # -- life cycle -------------------------------------------------------------------------------

    def start(self) -> None:
        self.arm_chain.start()
        self._scan_timer.start()
        self.switches.start_sources(self.settings)

    def stop(self) -> None:
        """Stop the scan timer, the switch sources and the worker (all joined)."""
        self._scan_timer.stop()
        self.stop_guard.remove()
        self.switches.stop_sources()
        self.sound.close()
        self.arm_chain.stop()

    @property
    def switch_sources(self) -> dict:
        """Device switch name → its running ``core.devices.switches.SwitchSource``."""
        return self.switches.sources

    def check_switch_sources(self) -> None:
        """Show what the gamepad / GPIO switches report (missing library, no device, …) in the hint."""
        messages = self.switches.source_messages()
        camera_message = self.arm_chain.camera_message()
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
        self.modes.show_mode(mode)
        self.switches.reset()
        self._restart_scan()
        self._update_hint()
        if save:
            self._save()

    def set_scan_period(self, period_s: float) -> None:
        period_s = min(MAX_PERIOD_S, max(MIN_PERIOD_S, float(period_s)))
        self.settings = replace(self.settings, scan_period_s=period_s)
        self.modes.show_period(period_s)
        self._restart_scan()
        self._save()

    def set_settings(self, settings: AssistSettings) -> None:
        self.settings = settings
        self.set_mode(settings.mode)
        if self.worker.isRunning():
            self.switches.start_sources(self.settings)

    def open_settings(self) -> SwitchSettingsDialog:
        """"Switches…": not modal (the window's STOP stays live beside it, kept uncovered), with
        its own STOP; Esc is STOP; OK applies the settings."""
        return self.switch_editor.open()

    @property
    def settings_dialog(self) -> Optional[SwitchSettingsDialog]:
        """"Switches…" while open (the latest one opened)."""
        return self.switch_editor.dialog

    def stop_from_anywhere(self) -> None:
        """STOP's area pressed or Esc typed, whatever is open: the menu closes and the arm stops."""
        self.close_menu()
        self.emergency_stop()

    def add_warning(self, text: str) -> None:
        """A settings problem the user should see (shown under the hint)."""
        self.settings_warnings.append(text)
        self._update_hint()

    def _update_hint(self) -> None:
        self.hint_label.setText(hint_text(self.settings, self.switch_messages + self.settings_warnings))

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
        text = state_line(status, previous, self.engaged, self.state_text)
        # while stopped, a state change queued before the stop reached the worker changes nothing
        if not self.engaged and status.state in MOVING_STATES:
            self._target = status.target_index
            self.view.set_chosen(status.target_index, status.centre_px)
            self.view.set_highlight(None)
        elif not self.engaged and status.state in ("IDLE", "RETURN") and previous is not None \
                and previous.state in MOVING_STATES:
            self.view.set_chosen(None)
            self.boxes, self.hit_boxes = [], []  # the camera has moved: offered again from the ready pose
            self.view.set_boxes([])
        self._set_state_text(text)

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
        self.modes.cancel()
        self.boxes, self.hit_boxes = [], []  # stale once the arm has moved: offered again after the re-arm
        self.view.set_boxes([])
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

    def _held(self, action: str) -> None:
        """A switch held for the long press: "stop", or "rearm" when the press began stopped."""
        if action == "rearm":
            self.rearm()
        else:
            self.emergency_stop()

    # -- choosing ---------------------------------------------------------------------------------

    def _restart_scan(self) -> None:
        self.modes.restart(self.settings, len(self.boxes))

    def _choose(self, index: int) -> None:
        if not self.choosing:
            return
        self._target = index
        self.modes.cancel()
        self.view.set_chosen(index)
        self._set_state_text(f"aligning with {index + 1}")
        self.worker.select(index)

    @property
    def ignored_taps(self) -> int:
        """Taps beside every box (touch mode): acknowledged, nothing moved."""
        return self.modes.ignored_taps

    def tap(self, image_point: Optional[tuple[float, float]], box: Optional[int] = None) -> None:
        """Touch mode: a tap at an image point (None: beside the image); ``box``: the box the view
        found under the tap (its outline or its number badge — one target), which is then chosen."""
        self.modes.tap(image_point, box, self.hit_boxes)

    def switch_down(self, name: str) -> bool:
        """A switch went down (key or mouse button by name); True when it is mapped."""
        return self.switches.down(name)

    def switch_up(self, name: str, now: Optional[float] = None) -> bool:
        """The switch came up (``now``: when, on the window's clock; default now): a short press
        acts (next, confirm, select), a long one already did."""
        return self.switches.up(name, now)

    def scan_tick(self) -> None:
        """The timed scan and the long-press hold, at the window's clock (SCAN_TICK_MS)."""
        now = self._clock()
        self.switches.tick(now)
        self.check_switch_sources()
        self.modes.tick(now)

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
        if self.switches.key_press(event):
            event.accept()
            return
        super().keyPressEvent(event)

    def keyReleaseEvent(self, event: QtGui.QKeyEvent) -> None:  # noqa: N802 (Qt override)
        """A key switch's release acts at once — unless it may be half of an X11 auto-repeat pair
        (``SwitchInput.key_release``)."""
        if self.switches.key_release(event):
            event.accept()
            return
        super().keyReleaseEvent(event)


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


def run_assist_window(size: tuple[int, int] = (800, 480), seed: int = 0, vibration: bool = False,
                      hand_camera=None, switches=(), depth: str = "auto", bridge_url: str = "sim://",
                      passing_hand: bool = False, detector: str = "circles") -> int:
    """Open the assistive view (wall clock), filling its screen, and run until it is closed: on the
    simulated desk, or with ``hand_camera`` on a real one (``build_assist_window``). ``bridge_url``:
    the arm the loop's joints go to through the safety chain (``sim://``: the simulated servo arm; a
    v1/v2 serial port or phidget://: a real one — the caller refuses a real arm on the simulated desk
    unless asked for on purpose). ``size``: the largest screen shown full screen (a bigger one gets
    a maximised window)."""
    from app.startup import GuiThreadGarbage, make_app, run_until_quit
    from core.cpu_budget import fit_opencv_threads

    app = make_app()
    fit_opencv_threads()  # as DeskSession.create: no spinning pool under a CPU quota
    window = build_assist_window(seed, vibration, hand_camera, switches, depth, bridge_url, passing_hand, detector)
    app.aboutToQuit.connect(window.stop)
    garbage = GuiThreadGarbage(app)  # collections only in the GUI thread (see app/startup.py)
    app.aboutToQuit.connect(garbage.stop)
    show_filling_screen(window, size)
    window.start()
    return run_until_quit(app, window)


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
    result = screenshot_when_ready(app, window, path, size, after_s)
    if not result.get("saved"):
        print(f"deskarm: could not write the screenshot to {path}: check the folder exists and is writable",
              file=sys.stderr)
        return 1
    mode = MODE_NAMES[window.settings.mode]
    print(f"deskarm: screenshot saved to {path} ({size[0]}x{size[1]}, assistive view, {mode}: "
          f"{result['state']}, after {result['after_s']:.1f} s)")
    return 0
