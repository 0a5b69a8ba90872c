"""The main window: the frame (camera views, arm twin, tabs, STOP strip, menu) composed of features.

``MainWindow`` builds the frame, composes one controller per capability from ``app/features/``
(target, jog, teleop, objects, markers, recording, calibration, stereo, e-stop, status) and runs
the redraw. Each feature owns its page widget's signals and talks to the session; features never
import each other — what one needs from another, the window passes as a callable or a signal.

The GUI thread only stores the newest worker results in slots and redraws from them at display
rate (a single-shot timer), so slow frames never pile up. Only what changed is redrawn: a slot
marks the window dirty only when its message shows something new (a held command with a new
seq, a repeated camera frame or a reused perception answer does not), and arms the timer; an
idle window then sleeps until something moves. The views and twins skip what they already
show. The status bar's fps and latency are refreshed twice a second by their own timer.
"""
from __future__ import annotations

import time
from types import SimpleNamespace
from typing import TYPE_CHECKING, Optional

from PySide6 import QtCore, QtGui, QtWidgets

from app.estop_switches import EStopSwitches
from app.features.calibration import CalibrationFeature
from app.features.estop import EStopFeature
from app.features.help import HelpFeature
from app.features.jog import JogFeature, JogKeyFilter  # noqa: F401 (JogKeyFilter: re-exported)
from app.features.markers import MarkersFeature
from app.features.objects import NO_DETECTOR_HINT, ObjectsFeature
from app.features.robot import RobotFeature
from app.features.recording import RecordingFeature, show_play_again  # noqa: F401 (re-exported)
from app.features.rtx import RtxFeature
from app.features.teach import TeachFeature
from app.features.status import StatusFeature
from app.features.stereo import StereoFeature
from app.features.target import TargetFeature
from app.features.teleop import TeleopFeature
from app.preferences import WindowPreferences
from app.startup import GuiThreadGarbage, finish_splash, make_app, run_until_quit
from app.window_draw import (  # noqa: F401 (the change tests import these from here)
    RedrawPacer,
    frame_rate,
    note_frame,
    command_changed,
    draw_twin,
    draw_views,
    reach_status,
    result_changed,
    state_changed,
)
from app.window_frame import (  # noqa: F401 (re-exported: tests and app.cli import them from here)
    FRAME_GUESS_PX,
    after_first_frame,
    fit_to_screen,
    menu_button,
    pause_scene,
    stop_strip,
    show_tab_of,
    timer,
    touch_tab_widget,
    two_panes,
    fit_window_size,
    fitted_geometry,
    start_scene_now,
)
from app.window_texts import (  # noqa: F401 (re-exported)
    cups_hint,
    depth_texts,
    following_text,
    format_depth,
    joint_display_limits,
    joint_display_values,
    list_port_choices,
    lissajous_preview,
    replay_end_text,
    teleop_hint,
)
from app.workers import WorkerSet
from core.messages import TargetMode
from core.motion.teleop_choice import starts_in_teleop
from core.session import DeskSession, SessionOptions, freeze_startup_objects
from widgets.arm_twin import ArmTwin
from widgets.camera_view import CameraView
from widgets.teleop_panel import teleop_banner_text

if TYPE_CHECKING:  # made on first use: not imported at start-up
    from widgets.help_dialog import HelpDialog

REDRAW_INTERVAL_MS = 33  # ~30 Hz display rate: draws start at least this far apart
MIN_REDRAW_GAP_MS = 5  # and leave the event loop at least this long between them (slow draws)
STATUS_INTERVAL_MS = 500  # fps / latency / bridge in the status bar: readable at 2 Hz, not at 30
TWIN_MIN_HEIGHT_PX = 120
FIT_DELAY_MS = 150  # after a show/move/resize: the window manager has framed the window by then


class _Feature:
    """A window attribute that is a feature's (read and written there): ``window.recorder`` is
    ``window.recording.recorder``; kept so callers and tests need not know which feature holds it."""

    def __init__(self, feature: str, name: str):
        self.feature, self.name = feature, name

    def __get__(self, window, owner=None):
        return self if window is None else getattr(getattr(window, self.feature), self.name)

    def __set__(self, window, value) -> None:
        setattr(getattr(window, self.feature), self.name, value)


class MainWindow(QtWidgets.QMainWindow):
    """deskarm's window for one DeskSession; owns the workers and stops them on close."""

    def __init__(self, session: DeskSession):
        super().__init__()
        self.session = session
        self.setWindowTitle("deskarm")
        self._result = self._command = self._goal = self._state = None
        # what the last draw showed: a new message is compared with these, not with the
        # previous message, so slow drifts below the tolerances still get drawn
        self._drawn_result = self._drawn_command = self._drawn_goal = self._drawn_state = None
        self._only_changes = True  # see redraw_only_changes
        self._running = False
        self.pacer = RedrawPacer(REDRAW_INTERVAL_MS, getattr(getattr(session, "options", None), "fps", 30.0))
        self._bridge_status = None
        self._frame_times: list[float] = []
        self._latency_ms = 0.0
        self._latency_source_t: Optional[float] = None  # frame time behind the latency shown
        self._tap_used = False  # the current tap on a camera view picked a colour or an object
        self._dirty = False
        self._fit_timer = timer(self, self.fit_to_screen, FIT_DELAY_MS)  # after show, moves, resizes: stay on screen
        self._redraw_timer = timer(self, self.redraw)
        self._status_timer = timer(self, self._refresh_status, STATUS_INTERVAL_MS, single_shot=False)
        self.workers = WorkerSet(session, self)
        self._build()
        # the physical STOP / RE-ARM (--estop-switch / --rearm-switch): a missing device is shown
        self.estop_switches = EStopSwitches.for_window(self)
        if self.estop_switches.enabled:
            self.statusBar().insertPermanentWidget(0, self.estop_switches.make_status_label())
        w = self.workers
        for signal, slot in ((w.perception.sigResult, self.on_result), (w.perception.sigError, self.on_camera_error),
                             (w.perception.sigHealth, self.status.set_health), (w.control.sigCommand, self.on_command),
                             (w.bridge.sigState, self.on_state), (w.bridge.sigStatus, self.on_bridge_status)):
            signal.connect(slot)
        self.stereo.show_initial_preset()
        self.splitter.splitterMoved.connect(self._mark_dirty)  # view width: compact marker labels
        # settings remembered between runs, restored as user actions would set them (no bridge connects)
        self.preferences = WindowPreferences(self)
        self.help = HelpFeature(session, self.preferences, self)
        self.help.sigNote.connect(self.status.show_note)
        self.help.sigDialogMade.connect(self.estop.add_dialog)
        self.preferences.sigMessage.connect(self.status.show_note)
        self.preferences.restore()
        if self.preferences.messages:
            self.status.show_note(" · ".join(self.preferences.messages))
        self._teleop_start_mode()  # --teleop / the teleop scenario: over a remembered mode

    @property
    def redraw_only_changes(self) -> bool:
        """True (the default): redraw only what changed. False: every message redraws every image,
        overlay, plot item and the status bar (the baseline of ``bench/bench_window.py``)."""
        return self._only_changes

    @redraw_only_changes.setter
    def redraw_only_changes(self, on: bool) -> None:
        self._only_changes = bool(on)
        for widget in (self.view_left, self.view_right, *self._twins()):
            widget.redraw_unchanged = not self._only_changes
        self._mark_dirty()

    # --- layout: the STOP strip, the views and twin, the tabs; the features ---------------------
    def _build(self) -> None:
        s = self.session
        self.view_left, self.view_right = CameraView("Left"), CameraView("Right")
        self._make_features()
        central = QtWidgets.QWidget()
        outer = QtWidgets.QVBoxLayout(central)
        outer.setContentsMargins(4, 4, 4, 4)
        outer.setSpacing(4)
        # The STOP strip: STOP at its right end at a fixed size and height; messages go in the row
        # below it, where they may grow. RE-ARM appears only while stopped, at the other end of the
        # strip: a finger that presses STOP again ("make sure") lands on STOP.
        self.menu_button, (self.fullscreen_action, self.recordings_action, self.help_action, self.quit_action) = \
            menu_button(self, [("Full screen", self.toggle_fullscreen, "F11", True),
                               ("Recordings…", self.recording.show_recordings, "", False),
                               ("Help && about", self.show_help, "F1", False), None, ("Quit", self.close, "Ctrl+Q", False)])
        # between them, messages: the banner (camera, e-stop, notes) while it fits on one line —
        # a longer one moves to the row below the strip — and the target state ("on target",
        # "out of reach by 81 mm") whatever tab is open
        self.target_status = self.target_panel.detach_reach_label()
        self.strip_messages = self.status.build_strip(self.target_status)
        self.stop_strip = stop_strip([self.menu_button, self.record_button, self.rearm_button], self.strip_messages,
                                     self.estop_button)
        outer.addWidget(self.stop_strip)
        self.banner_row = self.status.banner_row  # a longer banner: below the strip, wrapped
        outer.addLayout(self.banner_row)
        self.status.restore()

        left = QtWidgets.QWidget()
        left_layout = QtWidgets.QVBoxLayout(left)
        left_layout.setContentsMargins(0, 0, 0, 0)
        cams = QtWidgets.QHBoxLayout()
        for v in (self.view_left, self.view_right):
            cams.addWidget(v)
            v.sigMarkerClicked.connect(self.on_view_marker_tapped)
            v.sigObjectClicked.connect(self.on_object_tapped)
            v.sigClicked.connect(self.on_view_clicked)
        left_layout.addLayout(cams, 3)
        if self.replay_bar is not None:  # only for --camera replay:PATH
            left_layout.addWidget(self.replay_bar)
        self.twin = ArmTwin()
        self.twin.configure_for(s.profile, s.kinematics)
        self.twin3d = None  # created on first use: the first GL widget re-composites the window
        self.twin_stack = QtWidgets.QStackedWidget()
        # the 3D twin's GL view asks for ~500 px: never let it grow the window off an 800x480 screen
        self.twin_stack.setSizePolicy(QtWidgets.QSizePolicy.Policy.Preferred, QtWidgets.QSizePolicy.Policy.Ignored)
        self.twin_stack.setMinimumHeight(TWIN_MIN_HEIGHT_PX)
        self.twin_stack.addWidget(self.twin)
        left_layout.addWidget(self.twin_stack, 2)
        pages = [(self.target_panel, "Target")]
        self._jog_tab_index = 1  # the tab after Target: Jog, or Pose (with the jog below it)
        if self.pose_panel is not None:  # 6-DOF arms: jogging below the pose (eight tabs do not fit 800 px)
            pages.append((self.jog.page_with_pose(), "Pose"))
        else:
            pages.append((self.jog_panel, "Jog"))
        pages += [(self.markers_table, "Markers"), (self.objects.page_with(self.teach.page), "Objects"),
                  (self.camera_page, "Camera"), (self.stereo_panel, "Stereo"), (self.robot.page, "Robot")]
        self.tabs = touch_tab_widget(pages, self)  # the hidden pages join when opened or after the 1st frame
        self.tabs.currentChanged.connect(self._mark_dirty)  # a table that only updates while shown: at once
        if self.rtx.needs_init:  # the arm moves only after its initialisation: show where to start it
            show_tab_of(self.tabs, self.robot.page)
        self.splitter = two_panes(left, self.tabs)
        outer.addWidget(self.splitter, 1)
        self.setCentralWidget(central)
        self.status_items.add_to(self.statusBar())
        self.target.connect_panels(self.on_mode_changed, self.on_pose_target)
        self.target.update_preview()

    def _make_features(self) -> None:
        """One controller per capability; the window keeps references to their widgets under
        the names it always had (``window.jog_panel``, ``window.markers_table``, …)."""
        s, w = self.session, self.workers
        self.status = StatusFeature(s, self)
        self.estop = EStopFeature(s, w.bridge, self)
        self.estop.sigStopRequested.connect(self.on_stop_requested)
        self.estop.sigRearmRequested.connect(self.on_rearm_requested)
        self.recording = RecordingFeature(s, self)
        self.target = TargetFeature(s, self._twins, self)
        self.objects = ObjectsFeature(s, w.perception, self.target_panel, lambda: self._result, self)
        self.objects.attach_views((self.view_left, self.view_right))  # unsure objects drawn grey
        self.markers = MarkersFeature(s, self.target_panel, self._set_mode, lambda: self._result,
                                      lambda: self._state, self)
        self.teleop = TeleopFeature(s, self.target_panel.teleop, self._set_mode, lambda: self._command,
                                    lambda: self.objects.running, self)
        target = SimpleNamespace(set_mode=self._set_mode, set_manual_target=self.target.on_manual_target,
                                 show_manual_target=self.target_panel.show_manual_target, set_pose=self.on_pose_target)
        self.jog = JogFeature(s, target, w.control.user_input, lambda: self._state, lambda: self.teleop.keyboard,
                              self.pose_panel, self)
        self.calibration = CalibrationFeature(s, w.perception, self)
        self.stereo = StereoFeature(s, w.perception, (self.view_left, self.view_right), self)
        self.robot = RobotFeature(s, w.bridge, self)
        self.robot.hand_eye_button.clicked.connect(self.calibration.open_hand_eye)
        self.robot.view_3d_button.toggled.connect(self.on_view_3d)
        self.rtx = RtxFeature(s, self)  # a UMI-RTX's encoder initialisation (no page for other arms)
        self.teach = TeachFeature(s, parent=self)  # a new object for the desk model, in the Objects tab
        self.teach.sigModelChanged.connect(self.objects.reload_learned)
        self.robot.add_panel(self.rtx.page)
        self.sgbm_panel = self.stereo.stereo_panel.sgbm  # the block-matching trackbars
        for feature in (self.recording, self.target, self.objects, self.markers, self.teleop, self.jog,
                        self.calibration, self.teach):
            feature.sigNote.connect(self.status.show_note)
        for feature in (self.target, self.objects, self.teleop, self.jog):
            feature.sigChanged.connect(self._mark_dirty)
        for feature in (self.recording, self.calibration):
            feature.sigDialogMade.connect(self.estop.add_dialog)
        self.calibration.sigCalibrationChanged.connect(self.on_calibration_changed)

    @QtCore.Slot()
    def toggle_fullscreen(self) -> None:
        """F11: full screen (a kiosk) or back to the fitted window."""
        if self.isFullScreen():
            self.showNormal()
            fit_to_screen(self)
        else:
            self.showFullScreen()
        self.fullscreen_action.setChecked(self.isFullScreen())

    @QtCore.Slot()
    def show_help(self) -> HelpDialog:
        """F1: version, shortcuts, reset settings — with its own STOP."""
        return self.help.show_help()

    # --- lifecycle --------------------------------------------------------------------------
    def start(self) -> None:
        self._running = True
        self.workers.start()
        self._redraw_timer.start(REDRAW_INTERVAL_MS)
        self._status_timer.start()
        app = QtWidgets.QApplication.instance()
        if app is not None:  # a modal dialog takes the focus when it opens
            app.focusWindowChanged.connect(self.check_modal_dialog)
            self.jog.install()  # jog keys, wherever the focus is in this window
        self.estop_switches.start()  # installed last, so its filter sees the switch keys first

    def stop(self) -> None:
        app = QtWidgets.QApplication.instance()
        if self._running and app is not None:
            try:
                app.focusWindowChanged.disconnect(self.check_modal_dialog)
            except (RuntimeError, TypeError):
                pass
            self.jog.uninstall()
        self.jog.stop()
        self.estop.remove()
        self._running = False
        self._redraw_timer.stop()
        self._status_timer.stop()
        self.calibration.close()  # stops and joins the wizards' workers
        self.recording.stop()
        self.rtx.stop()  # cancels and joins an RTX initialisation
        self.teach.stop()  # cancels and joins a training under way
        self.estop_switches.stop()  # its key filter goes, its device threads are joined
        self.workers.stop()

    def closeEvent(self, event: QtGui.QCloseEvent) -> None:  # noqa: N802 (Qt override)
        self.preferences.save()
        self.stop()
        super().closeEvent(event)

    def resizeEvent(self, event: QtGui.QResizeEvent) -> None:  # noqa: N802 (Qt override)
        super().resizeEvent(event)
        self.centralWidget().layout().activate()  # the strip's new width, for the banner's place
        self.status.place_banner()
        self._mark_dirty()  # narrow views show compact marker labels
        self._fit_timer.start()

    def showEvent(self, event: QtGui.QShowEvent) -> None:  # noqa: N802 (Qt override)
        super().showEvent(event)
        self._fit_timer.start()
        self.stop_guard.reclaim_focus_soon()  # Esc, F1, Ctrl+Q before the first tap (no window manager)

    def moveEvent(self, event: QtGui.QMoveEvent) -> None:  # noqa: N802 (Qt override)
        super().moveEvent(event)  # a window manager reparenting the window moves it: its frame is known now
        self._fit_timer.start()

    @QtCore.Slot()
    def fit_to_screen(self) -> bool:
        """Keep all of the window (title bar and status bar included) on the screen's free area."""
        return fit_to_screen(self)

    @property
    def dirty(self) -> bool:
        """Something visible changed since the last draw (the next redraw draws)."""
        return self._dirty

    @QtCore.Slot()
    def _mark_dirty(self, *_args) -> None:
        """Draw at the next redraw, arming the redraw timer unless it already runs.

        The timer fires the pacer's interval (REDRAW_INTERVAL_MS; longer while the CPU is short)
        after the last draw began (never sooner than MIN_REDRAW_GAP_MS from now), so a camera frame
        arriving at 30 fps is drawn as it comes instead of waiting a whole interval from its arrival.
        """
        self._dirty = True
        if self._running and not self._redraw_timer.isActive():
            self._redraw_timer.start(self.pacer.next_draw_in_ms(MIN_REDRAW_GAP_MS))

    # --- worker slots (GUI thread; they only store, redraw draws) ----------------------------
    @QtCore.Slot(object)
    def on_result(self, result) -> None:
        self._result = result
        self.calibration.result(result)
        if self.markers.pick_place is not None:
            self.markers.step_pick_place()
        self.recording.result(result)  # queue puts: the recorder's own thread encodes and writes
        note_frame(self._frame_times, time.monotonic())
        self.teach.on_frame(None if result.frame is None else result.frame.left)  # while the Teach tab takes frames
        if not self._only_changes or (not self._dirty and result_changed(self._drawn_result, result)):
            self._mark_dirty()

    @QtCore.Slot(str)
    def on_camera_error(self, message: str) -> None:
        """A camera problem (banner, retrying), the end of a replay (banner, ▶ Play again; the
        views keep the last frame) or, with "", the camera is back."""
        ended = self.recording.camera_problem(message)
        for view in (self.view_left, self.view_right):  # the next frame clears it
            view.set_placeholder(f"no frames — {message}" if message and not ended else "")
        self.calibration.camera_problem(message, ended)
        self.status.set_camera_error(None if ended else message)

    @QtCore.Slot(object, object)
    def on_command(self, command, goal) -> None:
        """A control tick's command: up to 50 Hz, also while the arm holds still (the held
        command again with a new seq), which marks nothing dirty."""
        self._command, self._goal = command, goal
        self.recording.command(command, goal)
        if command.source_t is not None and command.source_t != self._latency_source_t:
            # the first command carrying a new frame: frame -> command (as shown here); the
            # ticks after it carry the same frame time, their age is not a latency
            self._latency_source_t = command.source_t
            self._latency_ms = (self.session.clock.now() - command.source_t) * 1e3
        if not self._only_changes or (not self._dirty and command_changed(
                self._drawn_command, self._drawn_goal, command, goal)):
            self._mark_dirty()

    @QtCore.Slot(object)
    def on_state(self, state) -> None:
        """The bridge's joint state: after each write and at 10 Hz while idle."""
        self._state = state
        self.recording.state(state)
        if not self._only_changes or (not self._dirty and state_changed(self._drawn_state, state)):
            self._mark_dirty()

    @QtCore.Slot(object)
    def on_bridge_status(self, status) -> None:
        self._bridge_status = status

    # --- what one feature's action means for others ---------------------------------------------
    def _set_mode(self, mode: str) -> None:
        """Switch the target mode as a tap on its button would (the panel's set_mode does not emit)."""
        self.target_panel.set_mode(mode)
        self.on_mode_changed(mode)

    @QtCore.Slot(str)
    def on_mode_changed(self, mode: str) -> None:
        self.target.set_mode(mode)
        if TargetMode(mode) is TargetMode.OBJECT:
            self.objects.mode_entered()
        if TargetMode(mode) is TargetMode.TELEOP:
            self.teleop.ensure_controller()
            hint = teleop_hint(self.session, self.teleop_panel.source)
            if hint:
                self.status.show_note(hint)

    @QtCore.Slot(object)
    def on_pose_target(self, pose) -> None:
        """A pose typed in the Pose tab becomes the manual target, orientation included; the
        Target tab's X/Y/Z show it too (one target state)."""
        self._set_mode(TargetMode.MANUAL.value)
        self.target.set_pose(pose)

    def _teleop_start_mode(self) -> None:
        """``--teleop`` or ``--scenario teleop``: start in TELEOP mode (the session set it; a
        remembered mode from the last run does not win over it)."""
        s = self.session
        if not starts_in_teleop(s.options, s.targeter.teleop):
            return
        if s.targeter.mode is not TargetMode.TELEOP or self.target_panel.mode != TargetMode.TELEOP.value:
            self._set_mode(TargetMode.TELEOP.value)
            if self.status.note == NO_DETECTOR_HINT:  # the remembered Object mode's hint: no longer the mode
                self.status.clear_note()

    @QtCore.Slot()
    def on_calibration_changed(self) -> None:
        """A new stereo or camera → arm calibration is in use: legends, status bar, views."""
        self.stereo.update_legend()
        self._refresh_status()
        self._mark_dirty()

    @QtCore.Slot(float, float)
    def on_view_clicked(self, x_px: float, y_px: float) -> None:
        """A tap on a view: with "Pick colour" on, a colour sample; in disparity mode it
        measures the depth there (kept live until the next tap). Comes before the view's
        object and marker taps, which it may consume."""
        view = self.sender()
        self._tap_used = False
        if not isinstance(view, CameraView):
            return
        if self.objects.picking:
            self._tap_used = True
            self.objects.pick_colour_at(view, "left" if view is self.view_left else "right", x_px, y_px)
            return
        self.stereo.probe_at(view, x_px, y_px, self._result)

    @QtCore.Slot(int)
    def on_object_tapped(self, object_id: int) -> None:
        """A tap on an object's box: in Object mode the arm follows that object."""
        if self._tap_used:  # the tap picked a colour
            return
        self._tap_used = True  # not also a marker tap
        self.objects.follow_tapped(object_id)

    @QtCore.Slot(int)
    def on_view_marker_tapped(self, marker_id: int) -> None:
        """A tap on a marker in a camera view (not when the same tap picked a colour or an object)."""
        if not self._tap_used:
            self.markers.on_marker_clicked(marker_id)

    # --- e-stop: one place that every view of the state follows ---------------------------------
    @QtCore.Slot()
    def on_stop_requested(self) -> None:
        """STOP (button, Esc, a dialog's STOP, a STOP switch): stop, as many times as it is asked."""
        self.estop_switches.note_stop()  # a RE-ARM switch hold under way ends
        self.on_estop(True)

    @QtCore.Slot()
    def on_rearm_requested(self) -> None:
        """RE-ARM held long enough: resume (only reachable while stopped, and never while a
        STOP switch is held down)."""
        blocked = self.estop_switches.rearm_blocked()
        if blocked:
            self.status.show_note(blocked)  # "STOP switch gpio:17 is down — release it to re-arm"
            return
        if not self.session.controller.armed:
            self.on_estop(False)

    def on_estop(self, engaged: bool) -> None:
        """E-stop: the control worker refuses commands and the bridge stops the arm; every
        view of the state (STOP, RE-ARM, banner, status bar, open dialogs) follows."""
        if engaged:
            self.jog.stop()  # nothing jogs on after a STOP (nor when re-armed)
            self.rtx.estop()  # an RTX initialisation under way ends (every motor stopped)
        self.estop.set_engaged(engaged)
        self.recording.estop(engaged)
        self.status.restore()
        self._refresh_status()  # "E-STOP" in the status bar now, not at the next refresh
        self._mark_dirty()  # the target strip says stopped / back on target

    @QtCore.Slot()
    def check_modal_dialog(self, *_args) -> None:
        """Pause the arm while a modal dialog without its own STOP is open (see EStopFeature)."""
        if self.estop.check_modal_dialog():
            self.status.restore()
            self._mark_dirty()

    @QtCore.Slot(bool)
    def on_view_3d(self, on: bool) -> None:
        """Show the 3D twin (OpenGL) instead of the top and side views, or back."""
        if on and self.twin3d is None:
            from widgets.arm_twin_3d import available_3d, make_twin_3d  # OpenGL: when first asked for
            self.twin3d = make_twin_3d()
            if self.twin3d is None:
                self.view_3d_button.setChecked(False)
                self.banner.show_message(f"3D view unavailable: {available_3d()[1]}", "warn")
                return
            self.twin3d.configure_for(self.session.profile, self.session.kinematics)
            self.twin3d.redraw_unchanged = not self._only_changes
            self.twin_stack.addWidget(self.twin3d)
        self.twin_stack.setCurrentWidget(self.twin3d if on else self.twin)
        self.target.update_preview()
        self._mark_dirty()

    def _twins(self):
        return [t for t in (getattr(self, "twin", None), getattr(self, "twin3d", None)) if t is not None]

    # --- drawing ------------------------------------------------------------------------------
    def redraw(self) -> None:
        """Draw if something changed since the last draw (the redraw timer's slot).

        The single-shot timer is armed by the slot that marks the window dirty (see
        ``_mark_dirty``), so an idle window does not wake at display rate; in redraw-all mode it
        re-arms REDRAW_INTERVAL_MS after every draw, as it always did. Either way only one draw
        is ever pending and slow draws never pile up.
        """
        if self._only_changes:
            self._redraw_timer.stop()  # called directly: the pending draw would have nothing new
        try:
            if self._dirty:
                self._dirty = False
                with self.pacer.drawing(self._frame_times):
                    self._draw()
        finally:
            if not self._only_changes and self._running:
                self._redraw_timer.start(int(self.pacer.interval_ms))

    def _draw(self) -> None:
        s, r = self.session, self._result
        self._drawn_result, self._drawn_state = r, self._state
        self._drawn_command, self._drawn_goal = self._command, self._goal
        followed = None
        if r is not None:
            self.target_panel.set_objects_seen([(o.label, o.object_id) for o in r.objects])
            if r.objects and s.targeter.mode is TargetMode.OBJECT:
                obs = r.object_observation(s.targeter.follow_object_id, s.targeter.follow_object_label)
                followed = None if obs is None else obs.object_id
        if r is not None and r.frame is not None:
            self.stereo.draw(r)
            draw_views((self.view_left, self.view_right), r, self.stereo.max_disparity(), followed)
        if r is not None and self.tabs.currentWidget().widget() is self.markers_table:
            self.markers.draw(r, self._state)
        twin = self.twin_stack.currentWidget()  # only the visible twin is redrawn
        draw_twin(twin, s, r, self._command, self._state)
        goal, cmd = self._goal, self._command
        teleop = self.teleop.draw(twin)  # TeleopStatus in TELEOP mode, else None
        teleop_line = None if teleop is None else teleop_banner_text(teleop)
        if goal is not None:
            twin.set_target(goal.base_p_target if goal.valid else None, bool(cmd.reachable) if cmd else True)
            twin.set_aimed_point(cmd.base_p_target if cmd is not None and not cmd.reachable else None)
        line = reach_status(s.controller, goal, cmd, teleop_line, self.target.preview_note)
        if line is not None:
            self.target_panel.set_reach_status(*line)
        self.robot.draw(cmd, self._state)
        if self.tabs.currentIndex() == self._jog_tab_index:
            self.jog.show()
        if not self._only_changes:
            self._refresh_status()  # redraw-all: every frame, as before

    @QtCore.Slot()
    def _refresh_status(self) -> None:
        """fps on the views; camera, bridge, fps and latency in the status bar (2 Hz timer)."""
        self.check_modal_dialog()
        self.recording.refresh()
        fps = frame_rate(self._frame_times)  # the frames of the last 2 s
        r = self._result
        if r is not None and r.frame is not None:
            for view in (self.view_left, self.view_right):
                view.set_fps(fps)
        self.robot.show_bridge_status(self._bridge_status)
        self.rtx.poll()
        self.status.refresh(fps, self._latency_ms, self._bridge_status)


# What the features hold, under the names the window always had (``window.jog_panel`` is
# ``window.jog.jog_panel``): callers — app/preferences.py, app/hand_eye.py, tests — keep working
# without knowing which feature holds what. Read and written through to the feature.
for _name, _feature, _attr in (
        ("_note", "status", "note"), ("banner", "status", "banner"), ("status_items", "status", "status_items"),
        ("estop_button", "estop", "estop_button"), ("rearm_button", "estop", "rearm_button"),
        ("stop_guard", "estop", "stop_guard"),
        ("recorder", "recording", "recorder"), ("record_path", "recording", "record_path"),
        ("record_button", "recording", "record_button"), ("replay_bar", "recording", "replay_bar"),
        ("replay_label", "recording", "replay_label"), ("replay_slider", "recording", "replay_slider"),
        ("recordings_dialog", "recording", "recordings_dialog"), ("show_recordings", "recording", "show_recordings"),
        ("on_replay_seek", "recording", "on_replay_seek"), ("_refresh_replay_bar", "recording", "refresh_replay_bar"),
        ("_camera_error", "status", "camera_error"), ("on_marker_clicked", "markers", "on_marker_clicked"),
        ("target_panel", "target", "target_panel"), ("pose_panel", "target", "pose_panel"),
        ("on_manual_target", "target", "on_manual_target"), ("on_follow_id", "target", "on_follow_id"),
        ("on_lissajous", "target", "on_lissajous"),
        ("detector_panel", "objects", "detector_panel"), ("_detectors_running", "objects", "running"),
        ("markers_table", "markers", "markers_table"), ("pick_place", "markers", "pick_place"),
        ("teleop_panel", "teleop", "teleop_panel"), ("teleop_params", "teleop", "params"),
        ("teleop_source_factory", "teleop", "source_factory"),
        ("jogger", "jog", "jogger"), ("jog_panel", "jog", "jog_panel"), ("_jog_timer", "jog", "timer"),
        ("_jog_tick", "jog", "tick"),
        ("camera_page", "calibration", "page"), ("calibrate_button", "calibration", "calibrate_button"),
        ("calibration_label", "calibration", "calibration_label"), ("camera_panel", "calibration", "camera_panel"),
        ("device_panel", "calibration", "device_panel"), ("calibration_controller", "calibration", "calibration_controller"),
        ("hand_eye", "calibration", "hand_eye"), ("on_camera_settings", "calibration", "on_camera_settings"),
        ("on_controls_refresh", "calibration", "on_controls_refresh"),
        ("on_calibration_installed", "calibration", "on_calibration_installed"),
        ("on_open_calibration", "calibration", "open_calibration"), ("on_open_hand_eye", "calibration", "open_hand_eye"),
        ("stereo_panel", "stereo", "stereo_panel"), ("depth_sample", "stereo", "depth_sample"),
        ("joints", "robot", "joints"), ("bridge_picker", "robot", "bridge_picker"),
        ("hand_eye_button", "robot", "hand_eye_button"), ("view_3d_button", "robot", "view_3d_button"),
        ("on_bridge_requested", "robot", "on_bridge_requested"), ("help_dialog", "help", "help_dialog")):
    setattr(MainWindow, _name, _Feature(_feature, _attr))
del _name, _feature, _attr


def collect_in_the_gui_thread(app: QtWidgets.QApplication) -> None:
    """After the first frame: collect what start-up made once and freeze it (the running loop's
    young-generation collections then stay short; a full collection is ~0.1 s of a Pi 4 core),
    then collect only from the GUI thread's timer (app.startup.GuiThreadGarbage, which keeps the
    automatic collector off; app.cli.start_up has kept it off since the start)."""
    freeze_startup_objects()
    app.aboutToQuit.connect(GuiThreadGarbage(app).stop)


def run_window(options: SessionOptions, size: tuple[int, int],
               splash: Optional[QtWidgets.QWidget] = None, record: Optional[str] = None) -> int:
    """Open the window and run until it is closed (fitted to the screen it opens on); the
    start-up ``splash`` (app.startup.show_splash) stays up until the window shows."""
    app = make_app()
    try:
        session = DeskSession.create(options)
    except (OSError, RuntimeError, ValueError) as exc:
        finish_splash(splash)
        QtWidgets.QMessageBox.critical(None, "deskarm could not start", str(exc))
        return 1
    pause_scene(session)  # until the window is up: start_scene_now
    window = MainWindow(session)
    screen = app.primaryScreen()
    free = screen.availableGeometry() if screen is not None else QtCore.QRect()
    fitted, maximise = fit_window_size(size, (free.width(), free.height()))
    app.aboutToQuit.connect(window.stop)
    if window.preferences.geometry_restored:  # where the user left it (it fits this screen)
        window.show()
    elif maximise:
        window.resize(*fitted)
        window.move(free.topLeft())  # where no window manager maximises (a bare X server)
        window.showMaximized()
    else:
        window.resize(*fitted)
        window.move(free.topLeft())
        window.show()
    finish_splash(splash)
    start_scene_now(session)
    window.start()
    after_first_frame(window, lambda: collect_in_the_gui_thread(app))
    if record is not None:  # --record [PATH]: recording from the start (● REC stops it)
        window.record_path = record or None
        window.record_button.setChecked(True)
    return run_until_quit(app, window)


def take_screenshot(options: SessionOptions, path: str, after_s: float, size: tuple[int, int]) -> int:
    """Run the window offscreen for ``after_s`` seconds of the scenario and save a PNG of exactly
    ``size`` (width, height) pixels, whatever window geometry the preferences hold (maximised,
    another size) and whatever the offscreen screen's size; exit. The preferences are read (the
    mode, the camera settings) but not written. 1 (and one line) when the PNG cannot be written."""
    app = make_app()
    session = DeskSession.create(options)
    pause_scene(session)  # until the window is up: start_scene_now
    window = MainWindow(session)
    window.preferences.read_only = True  # a screenshot's size is no window geometry to remember
    window.setWindowState(QtCore.Qt.WindowState.WindowNoState)  # not maximised / full screen as saved
    window.setFixedSize(*size)  # neither the screen (offscreen: 800x800) nor fit_to_screen resizes it
    window.show()
    start_scene_now(session)
    window.start()
    saved = []

    def grab() -> None:
        window.redraw()
        saved.append(window.grab().save(path, "PNG"))
        window.stop()
        app.quit()

    QtCore.QTimer.singleShot(int(after_s * 1000), grab)
    run_until_quit(app, window)
    if not (saved and saved[0]):
        import sys

        print(f"deskarm: could not write the screenshot to {path} — check that its folder exists and is "
              "writable", file=sys.stderr)
        return 1
    print(f"deskarm: screenshot saved to {path} ({size[0]}x{size[1]}, after {after_s:g} s)")
    return 0
