"""The main window: camera views, arm twin, target / camera / stereo / joint panels, status bar.

The GUI thread only stores the newest worker results in slots and redraws from them at display
rate (a single-shot timer), so slow frames never pile up. Only what changed is redrawn: a slot
marks the window dirty only when its message shows something new (a held command with a new
seq, a repeated camera frame or a reused perception answer does not), and arms the timer; an
idle window then sleeps until something moves. The views and twins skip what they already
show. The status bar's fps and latency are refreshed twice a second by their own timer.

The Camera tab opens the calibration wizard (its own worker, fed with the live frames); a saved
calibration is handed to the perception worker, which switches perception, disparity and the
calibration health monitor to it without a restart. The Stereo tab's presets are read and
written here (widgets never touch files), per camera pair.

Marker-less objects (issue 11): the Objects tab's detector panel asks the perception worker for
detectors (built and re-tuned there, between frames); their objects are drawn in both camera
views; the Target tab's Object mode follows one, chosen in its list or by a tap on its box; and
"Pick colour" turns the next tap on a camera view into a named HSV colour.
"""
from __future__ import annotations

import math
import time
import weakref
from dataclasses import replace
from typing import Optional

import numpy as np
import shiboken6
from PySide6 import QtCore, QtGui, QtWidgets

from app.calibration_worker import CalibrationController
from app.estop_switches import EStopSwitches
from app.hand_eye import HandEyeController
from app.preferences import WindowPreferences
from app.startup import GuiThreadGarbage, finish_splash, make_app
from app.workers import WorkerSet
from core.detect.colour import DEFAULT_COLOURS, colour_from_pixel
from core.messages import TargetMode
from core.motion.jog import JogSpace, Jogger, JogTeleopSource, joint_display
from core.motion.teleop import COMMON_TARGET_BOX, Box, TeleopController, make_hand_source, reachable_target_box
from core.motion.pick_place import PickPlaceSequence
from core.vision.markers import default_markers
from core.session import DeskSession, SessionOptions, freeze_startup_objects
from core.vision.disparity import (
    PresetError,
    delete_preset,
    disparity_legend,
    list_presets,
    load_preset,
    save_preset,
)
from widgets._style import TOUCH_PX, touch_button, touch_scroll_area, touch_slider, touch_tabs
from widgets.arm_twin import ArmTwin, profile_joint_levels, same_points
from widgets.arm_twin_3d import available_3d, make_twin_3d
from widgets.bridge_picker import BridgePicker
from widgets.camera_controls import CameraSettingsPanel
from widgets.camera_view import CameraView, MarkerOverlay, ObjectOverlay
from widgets.detector_panel import DetectorPanel
from widgets.device_controls import DeviceControlsPanel
from widgets.estop import EStopButton, RearmButton, StopGuard
from widgets.help_dialog import HelpDialog
from widgets.jog_panel import JogPanel, is_text_field, jog_key_action
from widgets.joint_readout import JointReadout
from widgets.markers_table import MarkersTable
from widgets.recordings_dialog import RecordingsDialog
from widgets.pose_panel import PosePanel, pose_panel_applies, pose_target_from_matrix
from widgets.status import Banner, StatusBarItems
from widgets.stereo_panel import StereoPanel
from widgets.target_panel import TargetPanel
from widgets.teleop_panel import KEYBOARD_SOURCE, target_box_problem, teleop_banner_text

REDRAW_INTERVAL_MS = 33  # ~30 Hz display rate: draws start at least this far apart
MIN_REDRAW_GAP_MS = 5  # and leave the event loop at least this long between them (slow draws)
STATUS_INTERVAL_MS = 500  # fps / latency / bridge in the status bar: readable at 2 Hz, not at 30
NOTE_SHOW_MS = 15_000  # how long a one-off note (e.g. "new calibration in use") stays in the banner
LEGEND_TICKS = 5
TWIN_MIN_HEIGHT_PX = 120
MODAL_PAUSE = "a dialog is open"  # ArmController.pause reason while a modal dialog without STOP is up
FIT_DELAY_MS = 150  # after a show/move/resize: the window manager has framed the window by then
COMPACT_VIEW_PX = 420  # narrower camera views label markers by id and objects by id and name only
PICK_TOLERANCE_HUE = 10  # "Pick colour": hue ± this (OpenCV's 0…179) around the tapped pixels
NO_DETECTOR_HINT = "no object detector is on — switch one on in the Objects tab (e.g. hsv)"
JOG_TICK_MS = 20  # a held jog key or button moves the target at 50 Hz (the control rate)
STOP_STRIP_HEIGHT_PX = TOUCH_PX + 8  # the strip STOP sits in: its height never changes
STOP_WIDTH_PX = 150  # STOP's fixed width ("STOPPED" fits; wider than a fingertip by three)


class JogKeyFilter(QtCore.QObject):
    """The application-wide event filter behind the jog keys: a small object of its own (not the
    window), holding the window weakly and passing on only key and deactivation events. The
    window itself as the filter made every event of the application a Python call on it, and one
    arriving while the window was being destroyed ("pure virtual method called") aborted Python."""

    _KINDS = (QtCore.QEvent.Type.KeyPress, QtCore.QEvent.Type.KeyRelease, QtCore.QEvent.Type.WindowDeactivate)

    def __init__(self, window: "MainWindow"):
        super().__init__()
        self._window = weakref.ref(window)

    def eventFilter(self, obj, event) -> bool:  # noqa: N802 (Qt override)
        kind = event.type()
        if kind not in self._KINDS:
            return False
        window = self._window()
        if window is None or not shiboken6.isValid(window) or not shiboken6.isValid(obj):
            return False
        return window.jog_event(obj, event, kind)


class MainWindow(QtWidgets.QMainWindow):
    """deskarm's window for one DeskSession; owns the workers and stops them on close."""

    def __init__(self, session: DeskSession):
        super().__init__()
        self.session = session
        self.setWindowTitle("deskarm")
        self._result = None
        self._command = None
        self._goal = None
        self._state = None
        # what the last draw showed: a new message is compared with these, not with the
        # previous message, so slow drifts below the tolerances still get drawn
        self._drawn_result = None
        self._drawn_command = None
        self._drawn_goal = None
        self._drawn_state = None
        self._only_changes = True  # see redraw_only_changes
        self._running = False
        self._draw_started = 0.0  # time.perf_counter() when the last draw began
        self._bridge_status = None
        self._frame_times: list[float] = []
        self._latency_ms = 0.0
        self._latency_source_t: Optional[float] = None  # frame time behind the latency shown
        self._camera_error: Optional[str] = None
        self._health_message = ""
        self._note = ""
        self._probe: Optional[tuple[float, float]] = None  # tapped pixel of the disparity map
        self._tap_used = False  # the current tap on a camera view picked a colour or an object
        self._detectors_running: list[str] = []  # what the perception worker runs (names)
        self.depth_sample = None  # DepthSample at the probe, for tests and the readout
        self._dirty = False
        self.calibration_controller: Optional[CalibrationController] = None
        self.help_dialog: Optional[HelpDialog] = None
        self.recordings_dialog: Optional[RecordingsDialog] = None
        self.hand_eye: Optional[HandEyeController] = None
        self.pick_place: Optional[PickPlaceSequence] = None  # a marker's pick_place action, running
        self.recorder = None  # core.record.Recorder while the Record button is on
        self.record_path: Optional[str] = None  # where the next recording goes (None: a new dated folder)
        self._estop_dialogs: list = []  # open dialogs that show the e-stop state (set_estop)
        self._note_timer = QtCore.QTimer(self)
        self._note_timer.setSingleShot(True)
        self._note_timer.timeout.connect(self._clear_note)
        self._fit_timer = QtCore.QTimer(self)  # after show, moves and resizes: stay on the screen
        self._fit_timer.setSingleShot(True)
        self._fit_timer.setInterval(FIT_DELAY_MS)
        self._fit_timer.timeout.connect(self.fit_to_screen)
        self._build()
        # the physical STOP / RE-ARM (--estop-switch / --rearm-switch): a missing device is shown
        self.estop_switches = EStopSwitches.for_window(self)
        if self.estop_switches.enabled:
            self.statusBar().insertPermanentWidget(0, self.estop_switches.make_status_label())
        self.workers = WorkerSet(session, self)
        p = self.workers.perception
        p.sigResult.connect(self.on_result)
        p.sigError.connect(self.on_camera_error)
        p.sigHealth.connect(self.on_health)
        p.sigControls.connect(self.on_controls)
        p.sigControlApplied.connect(self.on_control_applied)
        p.sigControlError.connect(self.on_control_error)
        p.sigCalibrationApplied.connect(self.on_calibration_applied)
        p.sigDetectorsApplied.connect(self.on_detectors_applied)
        p.sigDetectorError.connect(self.on_detector_error)
        running = [(d.spec_name, d.params) for d in p.object_detectors()]  # --detector
        self._detectors_running = [name for name, _ in running]
        self.detector_panel.set_detectors(running)
        self._update_object_hint()
        self._load_initial_preset()
        self._update_legend()
        self._update_calibration_label()
        self.workers.control.sigCommand.connect(self.on_command)
        self.workers.bridge.sigState.connect(self.on_state)
        self.workers.bridge.sigStatus.connect(self.on_bridge_status)
        self._redraw_timer = QtCore.QTimer(self)
        self._redraw_timer.setSingleShot(True)
        self._redraw_timer.timeout.connect(self.redraw)
        self._status_timer = QtCore.QTimer(self)
        self._status_timer.setInterval(STATUS_INTERVAL_MS)
        self._status_timer.timeout.connect(self._refresh_status)
        self.splitter.splitterMoved.connect(self._mark_dirty)  # view width: compact marker labels
        # settings remembered between runs (mode, Lissajous, camera controls, bridge port, 3D,
        # geometry); restored as user actions would set them, the bridge is never connected
        self.preferences = WindowPreferences(self)
        self.preferences.sigMessage.connect(self._show_note)
        self.preferences.restore()
        if self.preferences.messages:
            self._show_note(" · ".join(self.preferences.messages))
        self._teleop_start_mode()  # --teleop / the teleop scenario: over a remembered mode

    @property
    def redraw_only_changes(self) -> bool:
        """True (the default): redraw only what changed.

        False is the window as it was before: every worker message marks it dirty, the redraw
        timer re-arms after each draw, every draw sets every image, overlay and plot item
        (``redraw_unchanged`` on the views and twins) and the status bar each frame. It is
        kept as the baseline of ``bench/bench_window.py``.
        """
        return self._only_changes

    @redraw_only_changes.setter
    def redraw_only_changes(self, on: bool) -> None:
        self._only_changes = bool(on)
        for widget in (self.view_left, self.view_right, *self._twins()):
            widget.redraw_unchanged = not self._only_changes
        self._mark_dirty()

    # --- layout -----------------------------------------------------------------------------
    def _build(self) -> None:
        s = self.session
        central = QtWidgets.QWidget()
        outer = QtWidgets.QVBoxLayout(central)
        outer.setContentsMargins(4, 4, 4, 4)
        outer.setSpacing(4)
        # The STOP strip: a fixed height, STOP at its right end with a fixed size, so STOP keeps
        # one place and size in every state (stopped, recording, replay, any banner); messages
        # go in the row below it, where they may grow. RE-ARM appears only while stopped, at the
        # other end of the strip: a finger that presses STOP again ("make sure") lands on STOP.
        self.stop_strip = QtWidgets.QWidget()
        self.stop_strip.setObjectName("stop_strip")
        self.stop_strip.setFixedHeight(STOP_STRIP_HEIGHT_PX)
        top = QtWidgets.QHBoxLayout(self.stop_strip)
        top.setContentsMargins(0, 0, 0, 0)
        top.setSpacing(4)
        self.menu_button = self._build_menu_button()
        top.addWidget(self.menu_button)
        self.record_button = touch_button("● REC", checkable=True)  # record the session (rosbag2/MCAP)
        self.record_button.setToolTip("Record cameras, markers, goals and joints as a rosbag2 folder (MCAP) "
                                      "in the recordings folder; tap again to stop")
        self.record_button.setMinimumHeight(TOUCH_PX + 8)
        self.record_button.toggled.connect(self.on_record_toggled)
        top.addWidget(self.record_button)
        self.rearm_button = RearmButton()  # only while stopped; acts after a 1 s hold
        self.rearm_button.sigHeld.connect(self.on_rearm_requested)
        self.rearm_button.hide()
        top.addWidget(self.rearm_button)
        # between them, messages: the banner (camera, e-stop, notes) while it fits on one line —
        # a longer one moves to the row below the strip (_place_banner) — and the target state
        # ("on target", "out of reach by 81 mm") whatever tab is open; never taller than the strip
        self.strip_messages = QtWidgets.QWidget()
        self.strip_messages.setSizePolicy(QtWidgets.QSizePolicy.Policy.Ignored,
                                          QtWidgets.QSizePolicy.Policy.Ignored)
        messages = QtWidgets.QVBoxLayout(self.strip_messages)
        messages.setContentsMargins(0, 0, 0, 0)
        messages.setSpacing(2)
        self.banner = Banner()
        self.banner.sigChanged.connect(self._place_banner)
        messages.addWidget(self.banner)
        self.target_panel = TargetPanel()
        self.target_status = self.target_panel.detach_reach_label()
        self.target_status.setSizePolicy(QtWidgets.QSizePolicy.Policy.Ignored,
                                         QtWidgets.QSizePolicy.Policy.Preferred)
        messages.addWidget(self.target_status)
        messages.addStretch(1)
        top.addWidget(self.strip_messages, 1)
        self.estop_button = EStopButton()
        self.estop_button.setFixedSize(self.estop_button.sizeHint().expandedTo(
            QtCore.QSize(STOP_WIDTH_PX, STOP_STRIP_HEIGHT_PX)))
        self.stop_strip.setFixedHeight(self.estop_button.height())  # STOP's style may ask for more
        self.estop_button.sigStopRequested.connect(self.on_stop_requested)
        top.addWidget(self.estop_button)
        outer.addWidget(self.stop_strip)
        # a banner longer than one line in the strip: here, full width, wrapped (STOP stays put)
        self.banner_row = QtWidgets.QVBoxLayout()
        self.banner_row.setContentsMargins(0, 0, 0, 0)
        outer.addLayout(self.banner_row)
        # a press on STOP's area stops over every popup, list, tooltip and dialog; Esc stops in
        # every window; nothing covers STOP; the keys come back after a dialog with no window manager
        self.stop_guard = StopGuard(self.estop_button, self)
        self.stop_guard.sigStopRequested.connect(self.on_stop_requested)
        self._add_shortcuts()
        self._restore_banner()

        self.splitter = QtWidgets.QSplitter(QtCore.Qt.Orientation.Horizontal)
        self.splitter.setHandleWidth(10)  # wide enough to drag with a finger
        left = QtWidgets.QWidget()
        left_layout = QtWidgets.QVBoxLayout(left)
        left_layout.setContentsMargins(0, 0, 0, 0)
        cams = QtWidgets.QHBoxLayout()
        self.view_left = CameraView("Left")
        self.view_right = CameraView("Right")
        for v in (self.view_left, self.view_right):
            cams.addWidget(v)
            v.sigDisplayModeChanged.connect(self.on_display_mode)
            v.sigMarkerClicked.connect(self.on_view_marker_tapped)
            v.sigObjectClicked.connect(self.on_object_tapped)
            v.sigClicked.connect(self.on_view_clicked)
        left_layout.addLayout(cams, 3)
        self.replay_bar = self._build_replay_bar()  # only for --camera replay:PATH
        if self.replay_bar is not None:
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
        self.view_3d_button = touch_button("3D twin", checkable=True)  # in the Robot tab
        ok3d, self._why_no_3d = available_3d()
        self.view_3d_button.setEnabled(ok3d)
        if not ok3d:
            self.view_3d_button.setText("3D twin (no OpenGL here)")
        self.view_3d_button.toggled.connect(self.on_view_3d)
        self.splitter.addWidget(left)

        self.tabs = QtWidgets.QTabWidget()
        self.tabs.setDocumentMode(True)
        self.tabs.tabBar().setExpanding(True)
        touch_tabs(self.tabs)
        self.camera_page = self._build_camera_page()
        self.stereo_panel = StereoPanel()
        self.sgbm_panel = self.stereo_panel.sgbm  # the block-matching trackbars
        self.joints = JointReadout()
        self.joints.set_joints(s.profile.joint_names, *joint_display_limits(s.profile),
                               None if s.profile.has_servos else [j.display_unit for j in s.profile.joints])
        self.pose_panel = None
        if pose_panel_applies(s.profile):  # 6-DOF arms: X/Y/Z, yaw/pitch/roll, grip
            self.pose_panel = PosePanel()
            self.pose_panel.configure_for(s.profile, s.kinematics)
            home = pose_target_from_matrix(s.kinematics.fk_pose(s.profile.q_home))
            # one target state: the Pose tab starts at the targeter's manual target, with the
            # home orientation, and the Target tab's X/Y/Z sliders get the same ranges
            self.pose_panel.set_pose(replace(home, base_p=tuple(s.targeter.manual_target)))
            lo_hi = [self.pose_panel.spins[k] for k in "xyz"]
            self.target_panel.set_manual_ranges(*(v / 100.0 for sp in lo_hi for v in (sp.minimum(), sp.maximum())))
            self.pose_panel.sigPoseChanged.connect(self.on_pose_target)
        self.bridge_picker = BridgePicker(list_port_choices)
        self.bridge_picker.sigConnectRequested.connect(self.on_bridge_requested)
        robot_page = QtWidgets.QWidget()
        robot_layout = QtWidgets.QVBoxLayout(robot_page)
        robot_layout.setContentsMargins(0, 0, 0, 0)
        robot_layout.addWidget(self.joints)
        self.hand_eye_button = touch_button("Camera → arm calibration…")
        self.hand_eye_button.setToolTip("Where the cameras are in the robot's frame: the arm carries its tool "
                                        "marker through a sweep (or touch markers on the desk)")
        self.hand_eye_button.clicked.connect(self.on_open_hand_eye)
        robot_layout.addWidget(self.hand_eye_button)
        robot_layout.addWidget(self.view_3d_button)
        robot_layout.addWidget(self.bridge_picker)
        robot_layout.addStretch(1)
        pages = [(self.target_panel, "Target")]
        if self.pose_panel is not None:
            pages.append((self.pose_panel, "Pose"))
        self.markers_table = MarkersTable()
        self.markers_table.set_config(s.markers or default_markers())
        self.markers_table.sigMarkerChosen.connect(self.on_marker_chosen)
        self.detector_panel = DetectorPanel()  # marker-less objects: detectors and their settings
        self.detector_panel.sigDetectorsChanged.connect(self.on_detectors_changed)
        self.detector_panel.sigPickToggled.connect(self.on_pick_toggled)
        self._build_jog()
        if self.pose_panel is not None:  # 6-DOF arms: jogging below the pose (eight tabs do not fit 800 px)
            pages[-1] = (self._jog_with_pose(), "Pose")
        else:
            pages.append((self.jog_panel, "Jog"))
        pages += [(self.markers_table, "Markers"), (self.detector_panel, "Objects"),
                  (self.camera_page, "Camera"), (self.stereo_panel, "Stereo"), (robot_page, "Robot")]
        for widget, title in pages:
            # vertical-only and never narrower than its page, so the splitter leaves the panel
            # room for it (no sideways scrolling, no clipped buttons at 800x480)
            area = touch_scroll_area(widget)
            self.tabs.addTab(area, title)
        self.tabs.currentChanged.connect(self._on_tab_changed)  # the Markers table fills when shown
        self.splitter.addWidget(self.tabs)
        self.splitter.setStretchFactor(0, 3)
        self.splitter.setStretchFactor(1, 2)
        self.splitter.setCollapsible(0, False)
        self.splitter.setCollapsible(1, False)
        outer.addWidget(self.splitter, 1)
        self.setCentralWidget(central)

        self.status_items = StatusBarItems()
        self.status_items.add_to(self.statusBar())

        # panel -> core (setters are thread-safe; workers read them on their next tick)
        tp = self.target_panel
        tp.set_marker_ids(s.options.marker_ids)
        tp.set_lissajous(s.targeter.lissajous)
        tp.set_manual_target(s.targeter.manual_target)
        tp.sigModeChanged.connect(self.on_mode_changed)
        tp.sigManualTargetChanged.connect(self.on_manual_target)
        tp.sigFollowIdChanged.connect(self.on_follow_id)
        tp.sigFollowObjectChanged.connect(self.on_follow_object)
        tp.sigLissajousChanged.connect(self.on_lissajous)
        tp.sigLissajousRunning.connect(self.on_lissajous_running)
        tp.set_mode(s.targeter.mode.value)
        self._build_teleop()
        sp = self.stereo_panel
        sp.sigParamsChanged.connect(self.on_sgbm_params)
        sp.sigMatchParamsChanged.connect(self.on_match_params)
        sp.sigPresetSaveRequested.connect(self.on_preset_save)
        sp.sigPresetLoadRequested.connect(self.on_preset_load)
        sp.sigPresetDeleteRequested.connect(self.on_preset_delete)
        self._update_preview()

    def _build_replay_bar(self) -> Optional[QtWidgets.QWidget]:
        """A replay's progress and a seek slider (None for live cameras)."""
        if getattr(self.session.camera, "kind", "") != "replay":
            return None
        bar = QtWidgets.QWidget()
        row = QtWidgets.QHBoxLayout(bar)
        row.setContentsMargins(0, 0, 0, 0)
        self.replay_label = QtWidgets.QLabel("replay 0:00")
        row.addWidget(self.replay_label)
        self.replay_slider = touch_slider(QtWidgets.QSlider(QtCore.Qt.Orientation.Horizontal))
        self.replay_slider.setRange(0, 1000)
        self.replay_slider.sliderReleased.connect(self.on_replay_seek)
        row.addWidget(self.replay_slider, 1)
        return bar

    @QtCore.Slot()
    def on_replay_seek(self) -> None:
        """The seek slider was let go: the replay continues from there."""
        camera = self.session.camera
        camera.seek(self.replay_slider.value() / 1000.0 * camera.duration_s)

    def _refresh_replay_bar(self) -> None:
        camera = self.session.camera
        if self.replay_bar is None or self.replay_slider.isSliderDown():
            return
        blocked = self.replay_slider.blockSignals(True)
        self.replay_slider.setValue(round(camera.progress * 1000))
        self.replay_slider.blockSignals(blocked)
        done = camera.progress * camera.duration_s
        text = f"replay {int(done) // 60}:{int(done) % 60:02d} / {int(camera.duration_s) // 60}:" \
               f"{int(camera.duration_s) % 60:02d}"
        if self.replay_label.text() != text:
            self.replay_label.setText(text)

    def _build_menu_button(self) -> QtWidgets.QToolButton:
        """☰: full screen, help, quit — the way out and in on a kiosk with no window manager."""
        button = QtWidgets.QToolButton()
        button.setText("☰")
        button.setToolTip("Menu: full screen, help, quit")
        button.setMinimumSize(TOUCH_PX + 8, TOUCH_PX + 8)
        button.setStyleSheet("QToolButton { font-size: 20pt; } QToolButton::menu-indicator { image: none; }")
        button.setPopupMode(QtWidgets.QToolButton.ToolButtonPopupMode.InstantPopup)
        menu = QtWidgets.QMenu(button)
        menu.setStyleSheet(f"QMenu::item {{ min-height: {TOUCH_PX}px; padding: 0 28px 0 16px; }}")
        self.fullscreen_action = menu.addAction("Full screen", self.toggle_fullscreen)
        self.fullscreen_action.setShortcut(QtGui.QKeySequence("F11"))
        self.fullscreen_action.setCheckable(True)
        self.recordings_action = menu.addAction("Recordings…", self.show_recordings)
        self.help_action = menu.addAction("Help && about", self.show_help)
        self.help_action.setShortcut(QtGui.QKeySequence("F1"))
        menu.addSeparator()
        self.quit_action = menu.addAction("Quit", self.close)
        self.quit_action.setShortcut(QtGui.QKeySequence("Ctrl+Q"))
        button.setMenu(menu)
        return button

    def _add_shortcuts(self) -> None:
        """Esc stops from anywhere in the application; F11, F1 and Ctrl+Q act even when the
        menu is closed (its actions' shortcuts alone would need the menu in a widget tree)."""
        # Esc is taken by the StopGuard before any widget, popup or dialog sees it
        for action in (self.fullscreen_action, self.help_action, self.quit_action):
            action.setShortcutContext(QtCore.Qt.ShortcutContext.WindowShortcut)
            self.addAction(action)

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
        if self.help_dialog is None:
            self.help_dialog = HelpDialog(deskarm_version(), self._settings_file(), parent=self)
            self.help_dialog.sigStopRequested.connect(self.on_stop_requested)
            self.help_dialog.sigResetRequested.connect(self.on_reset_settings)
            self._estop_dialogs.append(self.help_dialog)
        self.help_dialog.set_estop(not self.session.controller.armed)
        self.help_dialog.show()
        self.help_dialog.raise_()
        return self.help_dialog

    @QtCore.Slot()
    def show_recordings(self) -> RecordingsDialog:
        """☰ → Recordings…: what was recorded, and the command that replays it."""
        from core.record.recorder import list_recordings, recordings_dir

        dialog = self.recordings_dialog
        if dialog is None:
            dialog = self.recordings_dialog = RecordingsDialog(str(recordings_dir()), parent=self)
            dialog.sigStopRequested.connect(self.on_stop_requested)
            self._estop_dialogs.append(dialog)
        dialog.set_recordings(list_recordings())
        dialog.set_estop(not self.session.controller.armed)
        dialog.resize(min(760, self.width()), min(440, self.height()))
        dialog.show()
        dialog.raise_()
        return dialog

    def _settings_file(self) -> str:
        return str(self.preferences.path)

    @QtCore.Slot()
    def on_reset_settings(self) -> None:
        """Help → Reset settings (held): defaults in every control, the old file kept as .bak."""
        if self.preferences.reset():
            text = "settings reset to defaults (the old file is kept as preferences.toml.bak)"
            self._show_note(text)
            if self.help_dialog is not None:
                self.help_dialog.set_reset_message(text)

    def _build_camera_page(self) -> QtWidgets.QWidget:
        """Calibrate button and state, then the image controls: the simulated camera's four
        settings, or a real camera's device controls as it reports them."""
        page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(page)
        layout.setContentsMargins(0, 0, 0, 0)
        self.calibrate_button = touch_button("Calibrate cameras…")
        self.calibrate_button.setMinimumHeight(TOUCH_PX + 12)
        font = self.calibrate_button.font()
        font.setBold(True)
        self.calibrate_button.setFont(font)
        self.calibrate_button.setToolTip("Stereo calibration with a printed chessboard or ChArUco board")
        self.calibrate_button.clicked.connect(self.on_open_calibration)
        layout.addWidget(self.calibrate_button)
        self.calibration_label = QtWidgets.QLabel()
        self.calibration_label.setWordWrap(True)
        layout.addWidget(self.calibration_label)
        self.camera_panel: Optional[CameraSettingsPanel] = None
        self.device_panel: Optional[DeviceControlsPanel] = None
        if self.session.is_simulated_camera or self.session.camera.kind == "remote":
            # the simulated desk's four controls (sent to the serving machine's cameras when remote)
            self.camera_panel = CameraSettingsPanel()
            self.camera_panel.sigSettingsChanged.connect(self.on_camera_settings)
            layout.addWidget(self.camera_panel)
        else:
            self.device_panel = DeviceControlsPanel()
            self.device_panel.sigControlRequested.connect(self.on_control_requested)
            self.device_panel.sigAutoRequested.connect(self.on_auto_requested)
            self.device_panel.sigRefreshRequested.connect(self.on_controls_refresh)
            layout.addWidget(self.device_panel)
        layout.addStretch(1)
        return page

    # --- lifecycle --------------------------------------------------------------------------
    def start(self) -> None:
        self._running = True
        self.workers.start()
        self._redraw_timer.start(REDRAW_INTERVAL_MS)
        self._status_timer.start()
        app = QtWidgets.QApplication.instance()
        if app is not None:  # a modal dialog takes the focus when it opens
            app.focusWindowChanged.connect(self.check_modal_dialog)
            app.installEventFilter(self._jog_key_filter)  # jog keys, wherever the focus is in this window
        self.estop_switches.start()  # installed last, so its filter sees the switch keys first

    def stop(self) -> None:
        app = QtWidgets.QApplication.instance()
        if self._running and app is not None:
            try:
                app.focusWindowChanged.disconnect(self.check_modal_dialog)
            except (RuntimeError, TypeError):
                pass
            app.removeEventFilter(self._jog_key_filter)
        self._jog_stop()
        self.stop_guard.remove()
        self._running = False
        self._redraw_timer.stop()
        self._status_timer.stop()
        if self.calibration_controller is not None:
            self.calibration_controller.close()  # stops and joins the wizard's worker
        if self.hand_eye is not None:
            self.hand_eye.close()
        self._stop_recording()
        self.estop_switches.stop()  # its key filter goes, its device threads are joined
        self.workers.stop()

    def closeEvent(self, event: QtGui.QCloseEvent) -> None:  # noqa: N802 (Qt override)
        self.preferences.save()
        self.stop()
        super().closeEvent(event)

    def resizeEvent(self, event: QtGui.QResizeEvent) -> None:  # noqa: N802 (Qt override)
        super().resizeEvent(event)
        self.centralWidget().layout().activate()  # the strip's new width, for the banner's place
        self._place_banner()
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
    def _mark_dirty(self) -> None:
        """Draw at the next redraw, arming the redraw timer unless it already runs.

        The timer fires REDRAW_INTERVAL_MS after the last draw began (but never sooner than
        MIN_REDRAW_GAP_MS from now), so a camera frame arriving at 30 fps is drawn as it comes
        instead of waiting a whole interval from its arrival.
        """
        self._dirty = True
        if self._running and not self._redraw_timer.isActive():
            since_ms = (time.perf_counter() - self._draw_started) * 1e3
            self._redraw_timer.start(int(max(MIN_REDRAW_GAP_MS, REDRAW_INTERVAL_MS - since_ms)))

    # --- worker slots (GUI thread; they only store, redraw draws) ----------------------------
    @QtCore.Slot(object)
    def on_result(self, result) -> None:
        self._result = result
        if self.calibration_controller is not None:
            self.calibration_controller.feed(result.frame)  # newest only; ignored while closed
        if self.hand_eye is not None:
            self.hand_eye.on_result(result)  # the camera→arm sweep steps with each frame
        if self.pick_place is not None:
            self._step_pick_place()
        if self.recorder is not None:  # queue puts: the recorder's own thread encodes and writes
            if result.frame is not None:
                self.recorder.frame(result.frame)
            self.recorder.result(result)
        now = time.monotonic()
        self._frame_times.append(now)
        while self._frame_times and now - self._frame_times[0] > 2.0:
            self._frame_times.pop(0)
        if not self._only_changes or (not self._dirty and result_changed(self._drawn_result, result)):
            self._mark_dirty()

    @QtCore.Slot(str)
    def on_camera_error(self, message: str) -> None:
        """A camera problem (banner, retrying), the end of a replay (banner, ▶ Play again; the
        views keep the last frame) or, with "", the camera is back."""
        ended = replay_end_text(self.session.camera) if message else ""
        self._camera_error = None if ended else (message or None)
        for view in (self.view_left, self.view_right):  # the next frame clears it
            view.set_placeholder(f"no frames — {message}" if message and not ended else "")
        if self.replay_bar is not None:
            show_play_again(self.replay_bar, self.session.camera, bool(ended))
        if self.calibration_controller is not None:
            self.calibration_controller.camera_problem(ended or message)
        if self.device_panel is not None:
            if message and not ended:
                self.device_panel.set_message("camera not delivering frames — the controls come back with it",
                                              warn=True)
            else:
                self.device_panel.set_message("")
        self._restore_banner()

    @QtCore.Slot(object)
    def on_health(self, status) -> None:
        """Calibration health (HealthStatus): the drift message goes to the banner."""
        self._health_message = (f"{status.message} (or Camera tab → Calibrate cameras…)"
                                if status.drifted and status.message else "")
        self._restore_banner()

    @QtCore.Slot(object)
    def on_controls(self, controls) -> None:
        """The camera's image controls (list of CameraControl) from the perception worker."""
        if self.device_panel is not None:
            self.device_panel.set_controls(controls)

    @QtCore.Slot(object)
    def on_control_applied(self, control) -> None:
        if self.device_panel is not None:
            self.device_panel.show_applied(control)

    @QtCore.Slot(str)
    def on_control_error(self, message: str) -> None:
        if self.device_panel is not None:
            self.device_panel.set_message(message, warn=True)

    @QtCore.Slot(str, float)
    def on_control_requested(self, name: str, value: float) -> None:
        self.workers.perception.request_control(name, value)

    @QtCore.Slot(str, bool)
    def on_auto_requested(self, name: str, on: bool) -> None:
        self.workers.perception.request_auto(name, on)

    @QtCore.Slot()
    def on_controls_refresh(self) -> None:
        self.workers.perception.request_controls()

    @QtCore.Slot(object, object)
    def on_command(self, command, goal) -> None:
        """A control tick's command: up to 50 Hz, also while the arm holds still (the held
        command again with a new seq), which marks nothing dirty."""
        self._command, self._goal = command, goal
        if self.recorder is not None:
            self.recorder.command(command, goal)
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
        if self.recorder is not None:
            self.recorder.state(state)
        if not self._only_changes or (not self._dirty and state_changed(self._drawn_state, state)):
            self._mark_dirty()

    @QtCore.Slot(object)
    def on_bridge_status(self, status) -> None:
        self._bridge_status = status

    # --- panel slots --------------------------------------------------------------------------
    @QtCore.Slot(str)
    def on_mode_changed(self, mode: str) -> None:
        self.session.targeter.set_mode(TargetMode(mode))
        self._update_preview()
        if TargetMode(mode) is TargetMode.CUPS:
            hint = cups_hint(self.session)
            self.target_panel.set_cups_hint(hint)
            if hint:
                self._show_note(hint)
        if TargetMode(mode) is TargetMode.OBJECT:
            chosen = self.target_panel.follow_object
            if chosen is not None:
                self.session.targeter.set_follow_object(*chosen)
            if not self._detectors_running:
                self._show_note(NO_DETECTOR_HINT)
        if TargetMode(mode) is TargetMode.TELEOP:
            self._teleop_ensure_controller()
            hint = teleop_hint(self.session, self.teleop_panel.source)
            if hint:
                self._show_note(hint)

    @QtCore.Slot(object)
    def on_manual_target(self, p) -> None:
        try:
            self.session.targeter.set_manual_target(p)  # keeps a manual orientation (Pose tab)
        except ValueError as exc:  # a non-finite target is refused where it enters: say so
            self._show_note(str(exc))
            return
        if self.pose_panel is not None:  # the Pose tab shows the same target
            self.pose_panel.set_pose(replace(self.pose_panel.pose(), base_p=tuple(float(v) for v in p)))

    @QtCore.Slot(int)
    def on_follow_id(self, marker_id: int) -> None:
        self.session.targeter.set_follow_id(marker_id)

    @QtCore.Slot(str, object)
    def on_follow_object(self, label: str, object_id) -> None:
        """The Target tab's object list: follow that track (or any object of that label)."""
        self.session.targeter.set_follow_object(label, object_id)

    # --- marker-less objects: detectors, colour picking, taps on objects ----------------------
    @QtCore.Slot(object)
    def on_detectors_changed(self, specs) -> None:
        """The Objects tab wants these detectors (list of (name, options)): the perception
        worker builds or re-tunes them before its next frame."""
        if self.detector_panel.message() and not self.detector_panel.picking:
            self.detector_panel.set_message("")  # an old problem: the new request answers anew
        self.workers.perception.request_detectors(specs)

    @QtCore.Slot(object)
    def on_detectors_applied(self, running) -> None:
        """The perception worker now runs these detectors ((name, settings) list)."""
        self._detectors_running = [name for name, _ in running]
        self.detector_panel.set_running(self._detectors_running)
        self._update_object_hint()
        self._mark_dirty()

    @QtCore.Slot(str)
    def on_detector_error(self, message: str) -> None:
        """A detector could not be built or failed while detecting (it is off now): say so in
        the Objects tab and the banner; everything else keeps running."""
        self.detector_panel.set_message(message, error=True)
        self._show_note(message)

    def _update_object_hint(self) -> None:
        self.target_panel.set_object_hint("" if self._detectors_running else NO_DETECTOR_HINT)

    @QtCore.Slot(bool)
    def on_pick_toggled(self, on: bool) -> None:
        if on:
            self._show_note(f"Pick colour: tap the object in a camera view — it sets the colour "
                            f"“{self.detector_panel.pick_name()}”")

    def pick_colour_at(self, view: CameraView, x_px: float, y_px: float) -> bool:
        """"Pick colour": the colour around pixel (x, y) of ``view``'s image becomes the named
        colour of the HSV detector (added or updated, the detector switched on). False (and a
        note) when there is no image there."""
        r = self._result
        if view.display_mode != "image":
            self._show_note("Pick colour: switch the view back to the camera image, then tap the object")
            return False
        if r is None or r.frame is None:
            self._show_note("Pick colour: no camera image yet")
            return False
        image = r.frame.left if view is self.view_left else r.frame.right
        name = self.detector_panel.pick_name()
        try:
            colour = colour_from_pixel(image, x_px, y_px, tolerance=PICK_TOLERANCE_HUE, name=name)
        except ValueError as exc:
            self._show_note(f"Pick colour: {exc}")
            return False
        self.detector_panel.add_picked_colour(colour)
        self._show_note(f"colour “{name}” picked at ({x_px:.0f}, {y_px:.0f}) px: hue {colour.h_lo}…{colour.h_hi}, "
                        f"saturation ≥ {colour.s_lo}, value ≥ {colour.v_lo}")
        return True

    @QtCore.Slot(int)
    def on_object_tapped(self, object_id: int) -> None:
        """A tap on an object's box: in Object mode the arm follows that object."""
        if self._tap_used:  # the tap picked a colour
            return
        obs = None if self._result is None else self._result.object_observation(object_id)
        label = obs.label if obs is not None else ""
        name = f"{label or 'object'} #{object_id}"
        self._tap_used = True  # not also a marker tap
        if self.session.targeter.mode is not TargetMode.OBJECT:
            self._show_note(f"{name}: choose the Target tab's Object mode to follow it")
            return
        self.target_panel.set_follow_object(label, object_id)  # the list shows it
        self.session.targeter.set_follow_object(label, object_id)
        self._show_note(f"following {name}")

    @QtCore.Slot(int)
    def on_view_marker_tapped(self, marker_id: int) -> None:
        """A tap on a marker in a camera view (not when the same tap picked a colour or an object)."""
        if not self._tap_used:
            self.on_marker_clicked(marker_id)

    @QtCore.Slot(object)
    def on_lissajous(self, params) -> None:
        self.session.targeter.set_lissajous(params)
        self._update_preview()

    @QtCore.Slot(bool)
    def on_lissajous_running(self, running: bool) -> None:
        self.session.targeter.set_lissajous_running(running)

    @QtCore.Slot(object)
    def on_camera_settings(self, settings) -> None:
        self.workers.perception.set_camera_settings(settings)

    @QtCore.Slot(object)
    def on_sgbm_params(self, params) -> None:
        self.workers.perception.set_sgbm_params(params)
        self._update_legend()

    @QtCore.Slot(object)
    def on_match_params(self, match) -> None:
        self.workers.perception.set_match_params(match)

    # --- stereo presets (per camera pair, in the user's config folder) -------------------------
    def _load_initial_preset(self) -> None:
        """The pair's active preset, if it has one, into the panel and the worker."""
        pair = self.session.camera.pair_id
        try:
            names = list_presets(pair)
            loaded = load_preset(pair)
        except PresetError as exc:
            self.stereo_panel.set_presets([])
            self.stereo_panel.set_preset_status(str(exc), ok=False)
            return
        current = None
        if loaded is not None:
            self.stereo_panel.set_all(*loaded)
            self.workers.perception.set_stereo_params(*loaded)
            current = next((n for n in names if load_preset(pair, n) == loaded), None)
        self.stereo_panel.set_presets(names, current)

    @QtCore.Slot(str)
    def on_preset_save(self, name: str) -> None:
        pair, sp = self.session.camera.pair_id, self.stereo_panel
        try:
            path = save_preset(pair, sp.params(), sp.match_params(), name)
            sp.set_presets(list_presets(pair), name)
        except (PresetError, OSError) as exc:
            sp.set_preset_status(str(exc), ok=False)
            return
        sp.set_preset_status(f"saved “{name}” for {pair} ({path.name})")

    @QtCore.Slot(str)
    def on_preset_load(self, name: str) -> None:
        pair, sp = self.session.camera.pair_id, self.stereo_panel
        try:
            loaded = load_preset(pair, name)
        except (PresetError, OSError) as exc:
            sp.set_preset_status(str(exc), ok=False)
            return
        if loaded is None:
            sp.set_preset_status(f"no preset “{name}” for {pair}", ok=False)
            return
        sp.set_all(*loaded)
        self.workers.perception.set_stereo_params(*loaded)
        self._update_legend()
        sp.set_preset_status(f"loaded “{name}”")

    @QtCore.Slot(str)
    def on_preset_delete(self, name: str) -> None:
        pair, sp = self.session.camera.pair_id, self.stereo_panel
        try:
            existed = delete_preset(pair, name)
            sp.set_presets(list_presets(pair))
        except (PresetError, OSError) as exc:
            sp.set_preset_status(str(exc), ok=False)
            return
        sp.set_preset_status(f"deleted “{name}”" if existed else f"no preset “{name}” to delete", ok=existed)

    # --- calibration ------------------------------------------------------------------------
    @QtCore.Slot()
    def on_open_calibration(self) -> None:
        """Open the calibration wizard (fed with the live frames while it is open)."""
        if self.calibration_controller is None:
            ctl = self.calibration_controller = CalibrationController(self)
            ctl.sigCalibrationInstalled.connect(self.on_calibration_installed)
            ctl.sigStopRequested.connect(self.on_stop_requested)  # the wizard's own STOP and Esc
            ctl.sigBoardShown.connect(self.on_board_shown)
        self.calibration_controller.set_estop(not self.session.controller.armed)
        self.calibration_controller.open(self)

    # --- recording ------------------------------------------------------------------------------
    @QtCore.Slot(bool)
    def on_record_toggled(self, on: bool) -> None:
        """● REC: record this session as a rosbag2 folder (MCAP) in the recordings folder."""
        if not on:
            path = self._stop_recording()
            if path:
                self._show_note(f"recording saved: {path} — replay it with `deskarm --camera replay:{path}`")
            return
        from core.record.recorder import Recorder

        s = self.session
        path, self.record_path = self.record_path, None  # --record PATH: the first recording goes there
        try:
            self.recorder = Recorder.for_session(s, path or None).start(
                calibration=s.calibration, base_T_camera=s.perception.base_T_camera,
                estopped=not s.controller.armed)
        except (OSError, ValueError) as exc:
            self.recorder = None
            self._show_note(f"cannot record: {exc}")
            blocked = self.record_button.blockSignals(True)
            self.record_button.setChecked(False)
            self.record_button.blockSignals(blocked)
        self._refresh_record_button()

    def _stop_recording(self) -> str:
        """Close the recorder (joins its thread); the folder's path, "" when none was recording."""
        recorder, self.recorder = self.recorder, None
        if recorder is None:
            return ""
        recorder.close()
        if recorder.error:
            self._show_note(f"recording stopped: {recorder.error}")
        self._refresh_record_button()
        return str(recorder.path)

    def _refresh_record_button(self) -> None:
        r = self.recorder
        if r is None:
            text = "● REC"
        elif r.error:  # disk full: the recording ends, the loop goes on
            self._show_note(f"recording stopped: {r.error}")
            self.record_button.setChecked(False)
            return
        else:
            m, sec = divmod(int(r.elapsed_s), 60)
            text = f"■ {m}:{sec:02d}\n{r.file_bytes / 1e6:.0f} MB"  # on disk, not before compression
            if r.frames_dropped:
                text += f" · {r.frames_dropped} lost"
        if self.record_button.text() != text:
            self.record_button.setText(text)

    @QtCore.Slot(int)
    def _on_tab_changed(self, _index: int) -> None:
        self._mark_dirty()  # a table that only updates while shown shows the present at once

    @QtCore.Slot()
    def on_open_hand_eye(self):
        """Robot tab → Calibrate camera→arm…: the hand-eye wizard (its own STOP)."""
        if self.hand_eye is None:
            self.hand_eye = HandEyeController(self)
            self.hand_eye.sigStopRequested.connect(self.on_stop_requested)
            self.hand_eye.sigCalibrationInUse.connect(self.on_hand_eye_in_use)
        self.hand_eye.set_estop(not self.session.controller.armed)
        return self.hand_eye.open()

    @QtCore.Slot(object, str)
    def on_hand_eye_in_use(self, result, path: str) -> None:
        self._show_note(f"camera→arm calibration in use ({result.rms_mm:.1f} mm RMS) — saved to {path}")
        self._refresh_status()
        self._mark_dirty()

    @QtCore.Slot(int)
    def on_marker_chosen(self, marker_id: int) -> None:
        """A row of the Markers table: do what the markers file says for that id (follow it, or
        point at it)."""
        spec = self.markers_table.config.marker(marker_id)
        action = spec.action if spec is not None else "follow"
        self.pick_place = None
        if action == "pick_place":
            self.start_pick_place(marker_id)
        elif action == "follow":
            self.target_panel.set_mode(TargetMode.FOLLOW.value)
            self.on_mode_changed(TargetMode.FOLLOW.value)
        elif self.session.targeter.mode is TargetMode.FOLLOW:
            self.target_panel.set_mode(TargetMode.MANUAL.value)
            self.on_mode_changed(TargetMode.MANUAL.value)
        self.on_marker_clicked(marker_id)
        self.markers_table.set_chosen(marker_id)

    def start_pick_place(self, marker_id: int) -> Optional[PickPlaceSequence]:
        """Pick the marked object up and put it at the place the markers file names for it."""
        config = self.markers_table.config
        obs = self._result.marker(marker_id) if self._result is not None else None
        place = config.place_of(marker_id)
        if obs is None or not obs.found or obs.base_p_centre is None or place is None:
            self._show_note(f"pick and place {config.name_of(marker_id)}: it must be seen by both cameras"
                            if place is not None else f"{config.name_of(marker_id)} has no place in the markers file")
            return None
        self.target_panel.set_mode(TargetMode.MANUAL.value)
        self.on_mode_changed(TargetMode.MANUAL.value)
        self.pick_place = PickPlaceSequence(obs.base_p_centre, place, label=config.name_of(marker_id))
        self._step_pick_place()
        return self.pick_place

    def _step_pick_place(self) -> None:
        """Advance a running pick and place with the measured tool (each perception result)."""
        seq = self.pick_place
        if seq is None or self.session.targeter.mode is not TargetMode.MANUAL:
            self.pick_place = None  # the user chose another mode: the sequence ends
            return
        s = self.session
        tool = None if self._state is None else np.asarray(s.kinematics.fk(self._state.q), float)[:3]
        before = seq.message
        step = seq.step(s.clock.now(), tool)
        if step.target is not None:
            grip = None
            if s.profile.gripper is not None:
                grip = s.profile.gripper.min_m if step.grip_closed else s.profile.gripper.max_m
            try:
                s.targeter.set_manual_pose(step.target, s.targeter.manual_rpy, grip)
            except ValueError as exc:
                self._show_note(str(exc))
            self.target_panel.show_manual_target(step.target)
        if step.message != before or step.done:
            self._show_note(step.message)
        if step.done:
            self.pick_place = None

    @QtCore.Slot(object)
    def on_board_shown(self, board) -> None:
        """The wizard is capturing ``board`` (None: closed): the simulated desk holds one up."""
        show = getattr(self.session.camera, "show_board", None)
        if show is None:
            return
        try:
            show(board)
        except (RuntimeError, ValueError) as exc:
            self._show_note(f"the simulated desk cannot show this board: {exc}")

    @QtCore.Slot(object, object)
    def on_calibration_installed(self, path, calibration) -> None:
        """The wizard saved a calibration: use it now (the worker switches before its next frame)."""
        s = self.session
        s.banners = [b for b in s.banners if not b.startswith("UNCALIBRATED") and "rescaled" not in b]
        self.workers.perception.set_calibration(calibration)
        self._show_note(f"new calibration in use (stereo RMS {calibration.rms_stereo:.2f} px, epipolar "
                        f"{calibration.epipolar_error_px:.2f} px) — saved to {path}")

    @QtCore.Slot(object)
    def on_calibration_applied(self, calibration) -> None:
        """The perception worker now uses ``calibration``."""
        self._update_legend()
        self._update_calibration_label()
        self._mark_dirty()

    def _update_calibration_label(self) -> None:
        c = self.session.calibration
        if any(b.startswith("UNCALIBRATED") for b in self.session.banners):
            text = "Not calibrated: nominal parameters, 3D positions approximate."
        elif self.session.is_simulated_camera and c.source.endswith("sim_rig_calibration.yaml"):
            text = "Calibration: the simulated rig's exact one."
        else:
            text = (f"Calibration: {c.source or 'from the wizard'} · stereo RMS {c.rms_stereo:.2f} px · "
                    f"epipolar {c.epipolar_error_px:.2f} px · baseline {c.baseline_m * 1e3:.1f} mm")
        self.calibration_label.setText(text)

    def _show_note(self, text: str) -> None:
        self._note = text
        self._note_timer.start(NOTE_SHOW_MS)
        self._restore_banner()

    @QtCore.Slot()
    def _clear_note(self) -> None:
        self._note = ""
        self._restore_banner()

    # --- disparity view: legend and depth probe ---------------------------------------------
    def _update_legend(self) -> None:
        """Depth marks on the disparity colour bars for the current parameters and calibration."""
        p = self.stereo_panel.params()
        lo, hi = max(0.0, float(p.min_disparity)), float(p.min_disparity + p.num_disparities)
        ticks = [(t.disparity_px, f"{t.disparity_px:.0f} px\n{format_depth(t.depth_m)}")
                 for t in disparity_legend(self.session.calibration, lo, hi, LEGEND_TICKS)]
        for view in (self.view_left, self.view_right):
            view.set_depth_legend(ticks)

    @QtCore.Slot(float, float)
    def on_view_clicked(self, x_px: float, y_px: float) -> None:
        """A tap on a view: with "Pick colour" on, a colour sample; in disparity mode it
        measures the depth there (kept live until the next tap). Comes before the view's
        object and marker taps, which it may consume."""
        view = self.sender()
        self._tap_used = False
        if not isinstance(view, CameraView):
            return
        if self.detector_panel.picking:
            self._tap_used = True
            self.pick_colour_at(view, x_px, y_px)
            return
        if view.display_mode != "disparity":
            return
        self._probe = (x_px, y_px)
        self._update_probe()

    def _update_probe(self) -> None:
        r = self._result
        if self._probe is None or r is None or r.disparity is None:
            return
        x, y = self._probe
        sample = self.workers.perception.disparity.depth_at(
            r.disparity, x, y, base_T_camera=self.session.perception.base_T_camera)
        text, readout = depth_texts(x, y, sample)
        for view in (self.view_left, self.view_right):
            view.set_probe(x, y, text)
        self.stereo_panel.set_depth_readout(readout)
        self.depth_sample = sample

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
            self._show_note(blocked)  # "STOP switch gpio:17 is down — release it to re-arm"
            return
        if not self.session.controller.armed:
            self.on_estop(False)

    def on_estop(self, engaged: bool) -> None:
        """E-stop: the control worker refuses commands and the bridge stops the arm; every
        view of the state (STOP, RE-ARM, banner, status bar, open dialogs) follows."""
        if engaged:
            self.session.controller.estop()
            self._jog_stop()  # nothing jogs on after a STOP (nor when re-armed)
        else:
            self.session.controller.rearm()
        self.estop_button.set_engaged(engaged)
        self.rearm_button.setVisible(engaged)
        if self.recorder is not None:
            self.recorder.estop(engaged)
        if self.calibration_controller is not None:
            self.calibration_controller.set_estop(engaged)
        if self.hand_eye is not None:
            self.hand_eye.set_estop(engaged)
        for dialog in self._estop_dialogs:
            dialog.set_estop(engaged)
        self._restore_banner()
        self._refresh_status()  # "E-STOP" in the status bar now, not at the next refresh
        self.workers.bridge.request_estop(engaged)
        self._mark_dirty()  # the target strip says stopped / back on target

    @QtCore.Slot()
    def check_modal_dialog(self, *_args) -> None:
        """Pause the arm while a modal dialog without its own STOP is open (a file dialog, a
        message box): it may cover STOP on a small screen. Dialogs that carry STOP and show
        the e-stop state (``set_estop``: the calibration wizard, help) do not pause it."""
        modal = QtWidgets.QApplication.activeModalWidget()
        blocking = modal is not None and modal is not self and not hasattr(modal, "set_estop")
        controller = self.session.controller
        if blocking == (MODAL_PAUSE in controller.paused_by):
            return
        if blocking:
            controller.pause(MODAL_PAUSE)
        else:
            controller.resume(MODAL_PAUSE)
        self._restore_banner()
        self._mark_dirty()

    def _restore_banner(self) -> None:
        """The most important message: camera lost, e-stop, calibration drift, a note, session notes."""
        s = self.session
        if self._camera_error:
            retry = "" if "retrying" in self._camera_error else " — retrying"
            self.banner.show_message(f"camera lost — {self._camera_error}{retry}", "error")
        elif not s.controller.armed:
            self.banner.show_message("E-STOP — the arm is stopped. To resume, hold RE-ARM (top left) for 1 s.", "error")
        elif s.controller.paused:
            self.banner.show_message(f"arm paused while {', '.join(sorted(s.controller.paused_by))} — "
                                     "it holds still until that closes", "warn")
        elif replay_end_text(s.camera):  # the recording played to its end: no fault
            self.banner.show_message(replay_end_text(s.camera), "info")
        elif self._health_message:
            self.banner.show_message(self._health_message, "warn")
        elif self._note:
            self.banner.show_message(self._note, "info")
        elif s.banners:
            self.banner.show_message(" · ".join(s.banners), "warn" if "UNCALIBRATED" in " ".join(s.banners) else "info")
        else:
            self.banner.clear()

    def _place_banner(self) -> None:
        """The banner in the STOP strip while its text fits there on one line, else in the row
        below the strip (wrapped, full width): short messages cost no height, long ones are read
        whole, and STOP — alone at the strip's right end, at a fixed height — never moves."""
        banner = self.banner
        room = self.strip_messages.width()
        padding = 2 * 10 + 8  # the banner's horizontal padding and a margin
        fits = banner.fontMetrics().horizontalAdvance(banner.text()) + padding <= room
        in_strip = banner.parentWidget() is self.strip_messages
        if fits == in_strip or not banner.text():
            return
        if fits:
            self.banner_row.removeWidget(banner)
            self.strip_messages.layout().insertWidget(0, banner)
        else:
            self.strip_messages.layout().removeWidget(banner)
            self.banner_row.addWidget(banner)

    @QtCore.Slot(str)
    def on_bridge_requested(self, url: str) -> None:
        self.bridge_picker.set_status(f"connecting to {url} …", None)  # neutral until it answers
        self.workers.bridge.request_bridge(url)

    @QtCore.Slot(str)
    def on_display_mode(self, _mode: str) -> None:
        wanted = "disparity" in (self.view_left.display_mode, self.view_right.display_mode)
        self.workers.perception.set_disparity_enabled(wanted)

    @QtCore.Slot(int)
    def on_marker_clicked(self, marker_id: int) -> None:
        """Tapping a marker: in Follow mode the arm follows that marker; in any other mode it
        becomes the manual target (pointing position above it)."""
        if self.session.targeter.mode is TargetMode.FOLLOW:
            self.target_panel.set_follow_id(marker_id)  # the Marker id box shows it
            self.session.targeter.set_follow_id(marker_id)
            self._show_note(f"following marker {marker_id}")
            return
        if self._result is None:
            return
        obs = self._result.marker(marker_id)
        if obs is None or obs.base_p_centre is None:
            return
        if not all(math.isfinite(v) for v in obs.base_p_centre):
            self._show_note(f"marker {marker_id} has no 3D position yet — it must be seen by both cameras")
            return
        self.target_panel.set_mode(TargetMode.MANUAL.value)  # does not emit: tell the targeter
        self.on_mode_changed(TargetMode.MANUAL.value)
        self.target_panel.set_manual_target(self.session.targeter.pointing.apply(obs.base_p_centre))

    @QtCore.Slot(bool)
    def on_view_3d(self, on: bool) -> None:
        """Show the 3D twin (OpenGL) instead of the top and side views, or back."""
        if on and self.twin3d is None:
            self.twin3d = make_twin_3d()
            if self.twin3d is None:
                self.view_3d_button.setChecked(False)
                self.banner.show_message(f"3D view unavailable: {available_3d()[1]}", "warn")
                return
            self.twin3d.configure_for(self.session.profile, self.session.kinematics)
            self.twin3d.redraw_unchanged = not self._only_changes
            self.twin_stack.addWidget(self.twin3d)
        self.twin_stack.setCurrentWidget(self.twin3d if on else self.twin)
        self._update_preview()
        self._mark_dirty()

    @QtCore.Slot(object)
    def on_pose_target(self, pose) -> None:
        """A pose typed in the Pose tab becomes the manual target, orientation included; the
        Target tab's X/Y/Z show it too (one target state)."""
        self.target_panel.set_mode(TargetMode.MANUAL.value)
        self.on_mode_changed(TargetMode.MANUAL.value)
        try:
            self.session.targeter.set_manual_pose(pose.base_p, pose.rpy, pose.grip_m)
        except ValueError as exc:
            self._show_note(str(exc))
            return
        self.target_panel.show_manual_target(pose.base_p)

    # --- jogging (issue 13): the Jog tab's ± buttons and the keys --------------------------------
    def _build_jog(self) -> None:
        s = self.session
        self.jogger = Jogger(s.profile, s.kinematics, desk_margin_m=s.controller.workspace.desk_margin_m)
        self._jog_key_filter = JogKeyFilter(self)
        self.jog_panel = JogPanel()
        self.jog_panel.set_joints(s.profile.joint_names)
        prm = self.jogger.params
        self.jog_panel.set_step_labels([f"{v * 1e3:g} mm" for v in prm.cartesian_steps_m],
                                       [f"{v:g}°" for v in prm.joint_steps_deg])
        self.jog_panel.set_step_index(self.jogger.step_index)
        self.jog_panel.sigPressed.connect(self.jog_press)
        self.jog_panel.sigReleased.connect(self.jog_release)
        self.jog_panel.sigSpaceChanged.connect(self.set_jog_space)
        self.jog_panel.sigStepChanged.connect(self.set_jog_step)
        self._jog_timer = QtCore.QTimer(self)
        self._jog_timer.setInterval(JOG_TICK_MS)
        self._jog_timer.timeout.connect(self._jog_tick)
        self._jog_keys: dict[int, int] = {}  # a held jog key → its channel (released by the same key)
        self._jog_note = ""
        self._jog_tab_index = 1  # the tab after Target: Jog, or Pose (with the jog below it)
        self._jog_show()

    def _jog_with_pose(self) -> QtWidgets.QWidget:
        """The Pose tab's page for 6-DOF arms: the pose controls, then jogging."""
        page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(page)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.pose_panel)
        title = QtWidgets.QLabel("<b>Jog</b>")
        layout.addWidget(title)
        layout.addWidget(self.jog_panel)
        return page

    @QtCore.Slot(str)
    def set_jog_space(self, space: str) -> None:
        """Cartesian or joint jogging (J, or the tab's switch). Back in x/y/z after a joint jog the
        Cartesian target continues from where the joints put the tool."""
        c = self.session.controller
        self.jogger.set_space(space)
        self._jog_keys.clear()
        self._jog_timer.stop()
        self.jog_panel.set_space(self.jogger.space.value)
        if self.jogger.space is JogSpace.CARTESIAN and c.joint_jog is not None:
            q = c.joint_jog
            c.set_joint_jog(None)
            if self.pose_panel is not None:  # 6-DOF: keep the orientation the joints gave the tool too
                pose = pose_target_from_matrix(self.session.kinematics.fk_pose(q))
                pose = replace(pose, grip_m=self.session.targeter.manual_grip_m)
                self.pose_panel.set_pose(pose)
                self.on_pose_target(pose)
                self.jogger.start_cartesian(pose.base_p)
            else:
                self._jog_apply_cartesian(self.jogger.start_cartesian(self.session.kinematics.fk(q)))
        self._jog_show()

    @QtCore.Slot(int)
    def set_jog_step(self, index: int) -> None:
        self.jogger.set_step_index(index)
        self.jog_panel.set_step_index(self.jogger.step_index)
        self._jog_show()

    @QtCore.Slot(int, int)
    def jog_press(self, channel: int, direction: int) -> None:
        """A ± button or a jog key went down: one step now, more while it is held (not while stopped)."""
        if not self.session.controller.armed:
            self._jog_note = "stopped — hold RE-ARM before jogging"
            self._jog_show()
            return
        if self._teleop_keys_drive():  # the keyboard is TELEOP's hand source: the keys move its target
            self._teleop_keyboard.press(channel, direction, self.session.clock.now())
            return
        if not self.jogger.holding:
            self._jog_begin()
        try:
            target = self.jogger.press(channel, direction, time.monotonic())
        except ValueError as exc:
            self._show_note(str(exc))
            return
        self._jog_apply(target)
        self._jog_timer.start()

    @QtCore.Slot(int)
    def jog_release(self, channel: int) -> None:
        """The button or key came up: the target stops where it is."""
        if self._teleop_keyboard is not None:
            self._teleop_keyboard.release(channel, self.session.clock.now())
        if self.jogger.holding and self.session.controller.armed:
            self._jog_apply(self.jogger.release(channel, time.monotonic()))
        if not self.jogger.holding:
            self._jog_timer.stop()

    def _jog_begin(self) -> None:
        """Where a jog starts: the MANUAL target or the joint jog's target when one is on, else
        where the arm is commanded (so jogging out of Follow starts at the tool, not at an old target)."""
        s, c = self.session, self.session.controller
        manual = s.targeter.mode is TargetMode.MANUAL
        q_arm = c.last.q if c.last is not None else c.start_pose(self._state)
        if self.jogger.space is JogSpace.CARTESIAN:
            if manual and c.joint_jog is None:
                self.jogger.start_cartesian(s.targeter.manual_target)
            else:
                self.jogger.start_cartesian(s.kinematics.fk(c.joint_jog if manual and c.joint_jog else q_arm))
        else:
            self.jogger.start_joints(c.joint_jog if manual and c.joint_jog is not None else q_arm)

    def _jog_apply(self, target) -> None:
        """The jog's new target to the arm: the MANUAL target (Cartesian) or a joint goal."""
        s = self.session
        if self.jogger.space is JogSpace.CARTESIAN:
            self._jog_apply_cartesian(target)
        else:
            # the manual target follows the joints' tool point (the twin and the Target tab show it)
            base_p = tuple(float(v) for v in s.kinematics.fk(target))
            if s.targeter.mode is not TargetMode.MANUAL:  # Manual at that point first: no jump
                self._jog_apply_cartesian(base_p)
                s.controller.set_joint_jog(target, base_p)
                self.workers.control.user_input()  # step at once, not at the next tick
            else:
                s.controller.set_joint_jog(target, base_p)  # before the target: see set_joint_jog
                self.on_manual_target(base_p)  # the targeter's listener steps the control at once
                self.target_panel.show_manual_target(base_p)
        self._jog_note = self.jogger.note
        self._jog_show()
        self._mark_dirty()

    def _jog_apply_cartesian(self, base_p) -> None:
        s = self.session
        s.controller.set_joint_jog(None)
        self.on_manual_target(base_p)  # the target first, then the mode: no step towards an old target
        self.target_panel.show_manual_target(base_p)
        if s.targeter.mode is not TargetMode.MANUAL:
            self.target_panel.set_mode(TargetMode.MANUAL.value)
            self.on_mode_changed(TargetMode.MANUAL.value)

    def _jog_tick(self) -> None:
        """50 Hz while something is held: the continuous part of the jog."""
        if not self.session.controller.armed:
            self._jog_stop()
            return
        target = self.jogger.update(time.monotonic())
        if target is not None:
            self._jog_apply(target)
        if not self.jogger.holding:
            self._jog_timer.stop()

    def _jog_stop(self) -> None:
        """Let go of every jog key and button (STOP, focus lost, closing): targets stay put."""
        if getattr(self, "jogger", None) is None:
            return
        self.jogger.release_all()
        if getattr(self, "_teleop_keyboard", None) is not None:
            self._teleop_keyboard.release_all()
        self._jog_keys.clear()
        self._jog_timer.stop()

    def _jog_show(self) -> None:
        s, c = self.session, self.session.controller
        joint_space = self.jogger.space is JogSpace.JOINT
        q = c.joint_jog if joint_space and c.joint_jog is not None else (
            c.last.q if c.last is not None else s.profile.q_home)
        p = s.kinematics.fk(q) if joint_space else s.targeter.manual_target
        self.jog_panel.show_state(p, joint_display(s.profile, q), self._jog_note)

    def jog_event(self, obj, event, kind) -> bool:
        """A key or deactivation event seen by the application-wide ``JogKeyFilter``: jog keys
        anywhere in this window unless the focus is in a text field (a focused slider or tab bar
        would otherwise eat the arrows). True when the event is used up."""
        if kind in (QtCore.QEvent.Type.KeyPress, QtCore.QEvent.Type.KeyRelease):
            return (isinstance(obj, QtWidgets.QWidget) and obj.window() is self
                    and self._jog_key(event, kind == QtCore.QEvent.Type.KeyPress))
        if obj is self:  # WindowDeactivate: a key released in another window never comes here
            self._jog_stop()
        return False

    def _jog_key(self, event: QtGui.QKeyEvent, pressed: bool) -> bool:
        """Handle one key event as a jog key; True when it was one (and is used up)."""
        mods = QtCore.Qt.KeyboardModifier
        if event.modifiers() & (mods.ControlModifier | mods.AltModifier | mods.MetaModifier):
            return False
        if is_text_field(QtWidgets.QApplication.focusWidget()):
            return False
        key = int(event.key())
        if not pressed:
            if key in self._jog_keys:
                if not event.isAutoRepeat():
                    self.jog_release(self._jog_keys.pop(key))
                return True
            return False
        action = jog_key_action(key, self.jogger.space.value, self.jog_panel.selected_joint, self.jogger.joint_count)
        if action is None:
            return False
        if event.isAutoRepeat():
            return True  # held: the timer moves it
        if action.kind == "jog":
            self._jog_keys[key] = action.channel
            self.jog_press(action.channel, action.direction)
        elif action.kind == "step":
            self.set_jog_step(self.jogger.step_index + action.direction)
        elif action.kind == "space":
            self.set_jog_space((JogSpace.JOINT if self.jogger.space is JogSpace.CARTESIAN else JogSpace.CARTESIAN).value)
        elif action.kind == "joint":
            self.jog_panel.set_selected_joint(action.channel)
        return True

    # --- teleoperation (issue 13): the Target tab's Teleop page, its banner line, the twin's boxes -------
    # (one block: the source choice builds a TeleopController — or the keyboard's JogTeleopSource —
    # for the targeter's TELEOP mode; the target box is checked against the arm's reach here)
    def _build_teleop(self) -> None:
        s = self.session
        self.teleop_panel = self.target_panel.teleop
        # TeleopParams for the controllers this window builds (None: the defaults); tests shorten the gestures
        self.teleop_params = None
        # spec → HandSource ("marker:23", "hsv:green", "pose:PATH"); a test may put a scripted source here
        self.teleop_source_factory = self._make_hand_source
        self._teleop_keyboard: Optional[JogTeleopSource] = None  # while the keyboard is TELEOP's source
        self._teleop_margin = float(s.controller.workspace.desk_margin_m)
        current = s.targeter.teleop  # the session's (--teleop, the teleop scenario), or None
        box = getattr(current, "target_box", None)
        presets: list[tuple[str, Box]] = []
        try:
            common = reachable_target_box(s.kinematics, self._teleop_margin, box=Box(*COMMON_TARGET_BOX))
            presets = [("Every arm reaches", common), ("Half size", common.shrunk(0.5))]
            own = reachable_target_box(s.kinematics, self._teleop_margin)  # the delta has its own
            if own != common:
                presets.insert(0, ("This arm's", own))
            larger = reachable_target_box(s.kinematics, self._teleop_margin, box=common.shrunk(1.5), tries=4)
            if larger != common:
                presets.append(("Larger (this arm)", larger))
        except ValueError as exc:  # an arm that reaches no box around the common one: say so on the page
            self.teleop_panel.refuse_target_box(str(exc))
        box = box or (presets[0][1] if presets else None)
        self.teleop_panel.set_presets(presets)
        if box is not None:
            self.teleop_panel.show_target_box(box)
        ids = tuple(getattr(s.perception, "marker_ids", s.options.marker_ids))
        self.teleop_panel.set_sources(ids, [c.name for c in DEFAULT_COLOURS])
        if current is not None:
            self.teleop_panel.set_source(getattr(current, "source", current).name)
        self.teleop_panel.sigSourceChanged.connect(self.on_teleop_source)
        self.teleop_panel.sigRestart.connect(self.on_teleop_restart)
        self.teleop_panel.sigTargetBoxChanged.connect(self.on_teleop_target_box)

    def _teleop_start_mode(self) -> None:
        """``--teleop`` or ``--scenario teleop``: start in TELEOP mode (the session set it; a
        remembered mode from the last run does not win over it)."""
        s = self.session
        if s.targeter.teleop is None or not (s.options.teleop_source or s.options.scenario == "teleop"):
            return
        if s.targeter.mode is not TargetMode.TELEOP or self.target_panel.mode != TargetMode.TELEOP.value:
            self.target_panel.set_mode(TargetMode.TELEOP.value)
            self.on_mode_changed(TargetMode.TELEOP.value)
            if self._note == NO_DETECTOR_HINT:  # the remembered Object mode's hint: no longer the mode
                self._clear_note()

    def _make_hand_source(self, spec: str):
        s = self.session
        return make_hand_source(spec, s.calibration, s.perception.base_T_camera)

    def _teleop_controller_for(self, spec: str):
        """A new teleop controller for ``spec`` (ValueError, OSError, or the pose model's error)."""
        s = self.session
        if spec == KEYBOARD_SOURCE:
            jogger = Jogger(s.profile, s.kinematics, desk_margin_m=self._teleop_margin)
            q = self._command.q if self._command is not None else s.profile.q_home
            return JogTeleopSource(jogger, s.kinematics.fk(q))  # from where the arm is
        box = self.teleop_panel.accepted_box or reachable_target_box(s.kinematics, self._teleop_margin)
        return TeleopController(self.teleop_source_factory(spec), box, self.teleop_params)

    @QtCore.Slot(str)
    def on_teleop_source(self, spec: str) -> None:
        """A hand source was chosen: TELEOP mode with a new controller (it calibrates afresh)."""
        s = self.session
        previous = s.targeter.teleop
        try:
            controller = self._teleop_controller_for(spec)
        except Exception as exc:  # noqa: BLE001 — a bad spec, a missing file, a model cv2.dnn cannot read
            self._show_note(f"teleop source {spec}: {exc}")
            if previous is not None:
                self.teleop_panel.set_source(getattr(previous, "source", previous).name)
            return
        self._teleop_keyboard = controller if isinstance(controller, JogTeleopSource) else None
        s.targeter.set_teleop(controller)
        if spec.startswith("hsv:") and not self._detectors_running:
            self._show_note(f"teleop source {spec}: the glove is seen by the hsv detector — "
                            "turn it on in the Objects tab")
        if s.targeter.mode is not TargetMode.TELEOP:  # choosing a hand means driving by hand
            self.target_panel.set_mode(TargetMode.TELEOP.value)
            self.on_mode_changed(TargetMode.TELEOP.value)
        self._mark_dirty()

    def _teleop_ensure_controller(self) -> None:
        """Into TELEOP mode without a hand source: the panel's choice (else the first marker)."""
        if self.session.targeter.teleop is not None:
            return
        spec = self.teleop_panel.source or f"marker:{self.session.options.marker_ids[0]}"
        self.teleop_panel.set_source(spec)
        self.on_teleop_source(spec)

    @QtCore.Slot()
    def on_teleop_restart(self) -> None:
        """Restart: calibrate again (the keyboard source goes back to where it started)."""
        if self.session.targeter.teleop is None:
            self._teleop_ensure_controller()
            return
        if self._teleop_keyboard is not None:
            self._teleop_keyboard.restart()
        else:
            self.session.targeter.restart_teleop()
        self._mark_dirty()

    @QtCore.Slot(object, object)
    def on_teleop_target_box(self, lo, hi) -> None:
        """The target box was edited (or a preset chosen): taken when the arm reaches all of it,
        else refused with the reason (the controls go back to the box in use)."""
        if not all(a < b for a, b in zip(lo, hi)):
            axes = ", ".join(axis for axis, a, b in zip("xyz", lo, hi) if not a < b)
            self.teleop_panel.refuse_target_box(f"target box: min must be below max along {axes}")
            return
        box = Box(tuple(lo), tuple(hi))
        problem = target_box_problem(self.session.kinematics, box, self._teleop_margin)
        if problem:
            self.teleop_panel.refuse_target_box(problem)
            return
        self.teleop_panel.show_target_box(box)
        controller = self.session.targeter.teleop
        if hasattr(controller, "set_target_box"):
            # the control worker calls the controller under the targeter's lock: change it under it too
            with self.session.targeter._lock:
                controller.set_target_box(box)
        self._mark_dirty()

    def _teleop_keys_drive(self) -> bool:
        """The jog keys move TELEOP's keyboard source (Cartesian jogging only: it gives a point)."""
        return (self._teleop_keyboard is not None and self.session.targeter.teleop is self._teleop_keyboard
                and self.session.targeter.mode is TargetMode.TELEOP and self.jogger.space is JogSpace.CARTESIAN)

    def _draw_teleop(self, twin):
        """The teleop state on the Teleop page and in the twin (hand volume, target box, hand,
        mapped point); the TeleopStatus in TELEOP mode, else None (and the twin's items cleared)."""
        s = self.session
        status = s.targeter.teleop_status() if s.targeter.mode is TargetMode.TELEOP else None
        set_teleop = getattr(twin, "set_teleop", None)  # the 2D twin; the 3D one does not draw it
        if status is None:
            if set_teleop is not None:
                set_teleop()
            if s.targeter.mode is TargetMode.TELEOP:
                self.teleop_panel.set_status(None)
            return None
        self.teleop_panel.set_status(status)
        if set_teleop is not None:
            keyboard = status.source == KEYBOARD_SOURCE  # its "target box" is only the reach sphere's
            set_teleop(status.hand_box, None if keyboard else status.target_box,
                       None if keyboard else status.base_p_hand, status.base_p_mapped)
        return status

    def _twins(self):
        return [t for t in (self.twin, self.twin3d) if t is not None]

    def _update_preview(self) -> None:
        """Lissajous preview in the twin, with out-of-reach points moved to the nearest reachable."""
        t = self.session.targeter
        if t.mode is not TargetMode.LISSAJOUS:
            for twin in self._twins():
                twin.set_preview(None)
            self._preview_note = ""
            self._mark_dirty()
            return
        points, outside = lissajous_preview(t.lissajous, self.session.kinematics)
        for twin in self._twins():
            twin.set_preview(points)
        self._preview_note = (
            f"{outside:.0%} of the curve is out of reach (drawn at the nearest reachable point)" if outside else ""
        )
        self._mark_dirty()  # the reach status shows the note, even while the goal holds still

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
                self._draw_started = time.perf_counter()
                self._draw()
        finally:
            if not self._only_changes and self._running:
                self._redraw_timer.start(REDRAW_INTERVAL_MS)

    def _fps(self) -> float:
        t = self._frame_times
        return (len(t) - 1) / (t[-1] - t[0]) if len(t) > 2 else 0.0

    def _draw(self) -> None:
        s = self.session
        r = self._result
        self._drawn_result, self._drawn_state = r, self._state
        self._drawn_command, self._drawn_goal = self._command, self._goal
        followed = None
        if r is not None:
            self.target_panel.set_objects_seen([(o.label, o.object_id) for o in r.objects])
            if r.objects and s.targeter.mode is TargetMode.OBJECT:
                obs = r.object_observation(s.targeter.follow_object_id, s.targeter.follow_object_label)
                followed = None if obs is None else obs.object_id
        if r is not None and r.frame is not None:
            params = self.stereo_panel.params()
            max_disparity = float(params.num_disparities + params.min_disparity)
            if r.disparity is not None:
                self._update_probe()
                ms = r.timings_ms.get("disparity")
                if ms is not None:
                    self.stereo_panel.set_timing(f"disparity {ms:.0f} ms per frame")
            for view, img, side in ((self.view_left, r.frame.left, "left"), (self.view_right, r.frame.right, "right")):
                if view.display_mode == "disparity" and r.disparity is not None:
                    view.show_disparity(r.disparity, max_disparity)
                else:
                    view.show_image(img)
                compact = view.width() < COMPACT_VIEW_PX  # small views: ids only, positions are in the twin
                overlays = [o for o in (MarkerOverlay.from_observation(m, side, "" if compact else None)
                                        for m in r.markers) if o is not None]
                view.set_markers(overlays)
                # objects: id, name and score; position and speed too in a wide view, or for the
                # object being followed
                view.set_objects([o for o in (ObjectOverlay.from_observation(obs, side, not compact or
                                                                             obs.object_id == followed)
                                              for obs in r.objects) if o is not None])
        if r is not None and self.tabs.currentWidget().widget() is self.markers_table:
            tool = (None if self._state is None
                    else tuple(float(v) for v in np.asarray(s.kinematics.fk(self._state.q), float)[:3]))
            self.markers_table.update(r.markers, tool)
        twin = self.twin_stack.currentWidget()  # only the visible twin is redrawn
        if r is not None and r.frame is not None:
            twin.set_markers({m.marker_id: np.asarray(m.base_p_centre) for m in r.markers if m.found and m.base_p_centre is not None})
        q_cmd = self._command.q if self._command is not None else None
        q_meas = self._state.q if self._state is not None else None
        recorded = getattr(s.camera, "recorded_state_at", None)
        if recorded is not None and r is not None and r.frame is not None:
            # a replay: the recorded arm beside the command re-computed from the recorded frames
            state = recorded(r.frame.t)
            if state is not None:
                q_meas = state.q
        twin.set_arm(None if q_cmd is None else np.asarray(s.kinematics.chain_points(q_cmd)),
                     None if q_meas is None else np.asarray(s.kinematics.chain_points(q_meas)))
        if hasattr(s.kinematics, "arm_segments"):  # the delta's three arms
            twin.set_extra_segments(None if q_meas is None else list(s.kinematics.arm_segments(q_meas)))
        twin.set_joint_levels(None if q_meas is None else profile_joint_levels(s.profile, q_meas))
        if recorded is not None:
            twin.set_measured_label("recorded arm")
        elif self._state is not None:
            twin.set_measured_label("measured" if self._state.measured else "commanded (no feedback)")
        goal, cmd = self._goal, self._command
        teleop = self._draw_teleop(twin)  # TeleopStatus in TELEOP mode, else None
        teleop_line = None if teleop is None else teleop_banner_text(teleop)
        if goal is not None:
            twin.set_target(goal.base_p_target if goal.valid else None, bool(cmd.reachable) if cmd else True)
            twin.set_aimed_point(cmd.base_p_target if cmd is not None and not cmd.reachable else None)
            if not s.controller.armed:  # the last "on target" is stale: nothing is commanded
                self.target_panel.set_reach_status("arm stopped (e-stop) — nothing is commanded", False)
            elif s.controller.paused:
                self.target_panel.set_reach_status(f"arm holding still — {s.controller.note or 'paused'}", False)
            elif teleop_line is not None and not goal.valid:  # calibrating, hand lost, ended
                self.target_panel.set_reach_status(*teleop_line)
            elif not goal.valid:
                self.target_panel.set_reach_status(goal.note or "target lost — holding", False)
            elif s.controller.workspace_note:  # below the desk, in a keep-out box: say which
                self.target_panel.set_reach_status(s.controller.workspace_note, False)
            elif cmd is not None and not cmd.reachable:
                self.target_panel.set_reach_status(
                    f"out of reach by {cmd.reach_error_m * 1e3:.0f} mm — going to the nearest point", False)
            elif goal.mode is TargetMode.LISSAJOUS and getattr(self, "_preview_note", ""):
                self.target_panel.set_reach_status(self._preview_note, False)
            elif goal.mode is TargetMode.OBJECT:  # "following red ball #3"
                self.target_panel.set_reach_status(following_text(goal), True)
            elif teleop_line is not None and goal.mode is TargetMode.TELEOP:  # "teleop: following"
                self.target_panel.set_reach_status(*teleop_line)
            else:
                self.target_panel.set_reach_status(f"on target{' · ' + goal.note if goal.note else ''}", True)
        elif teleop_line is not None:  # no command yet (calibrating from the start): the strip says why
            self.target_panel.set_reach_status(*teleop_line)
        cmd_deg = joint_display_values(s.profile, cmd.q) if cmd is not None else None
        meas_deg = joint_display_values(s.profile, self._state.q) if self._state is not None else None
        self.joints.set_values(cmd_deg, meas_deg)
        if self.tabs.currentIndex() == self._jog_tab_index:
            self._jog_show()
        if not self._only_changes:
            self._refresh_status()  # redraw-all: every frame, as before

    @QtCore.Slot()
    def _refresh_status(self) -> None:
        """fps on the views; camera, bridge, fps and latency in the status bar (2 Hz timer)."""
        s = self.session
        self.check_modal_dialog()
        self._refresh_record_button()
        self._refresh_replay_bar()
        fps = self._fps()
        r = self._result
        if r is not None and r.frame is not None:
            for view in (self.view_left, self.view_right):
                view.set_fps(fps)
        b = self._bridge_status
        bridge_text = "—" if b is None else (f"{b.url} ✓ {b.commands_sent} cmds" if b.connected else f"{b.url} ✗ {b.message}")
        if not s.controller.armed:
            bridge_text = f"E-STOP · {bridge_text}"
        if b is not None:
            # green only for a working connection: a failed switch keeps the old bridge
            # connected but says "could not switch to … — still on …": warning colour
            self.bridge_picker.show_bridge_status(b)
        self.status_items.update(s.camera.name, bridge_text, fps, self._latency_ms, s.camera_to_robot_state())


# --- what a new worker message changes on screen (pure: tested without a window) -------------
def _same_markers(a, b) -> bool:
    """Two tuples of MarkerObservation draw the same (id, found, corners, position)."""
    return len(a) == len(b) and all(
        x is y or (x.marker_id == y.marker_id and x.found == y.found
                   and same_points(x.left_corners, y.left_corners)
                   and same_points(x.right_corners, y.right_corners)
                   and same_points(x.base_p_centre, y.base_p_centre))
        for x, y in zip(a, b))


def _same_detection(a, b) -> bool:
    return a is b or (a is not None and b is not None and a.label == b.label and a.box == b.box)


def _same_objects(a, b) -> bool:
    """Two tuples of ObjectObservation draw the same (id, label, boxes in both views, position)."""
    return len(a) == len(b) and all(
        x is y or (x.object_id == y.object_id and x.label == y.label and x.triangulated == y.triangulated
                   and _same_detection(x.left, y.left) and _same_detection(x.right, y.right)
                   and same_points(x.base_p, y.base_p))
        for x, y in zip(a, b))


def result_changed(drawn, result) -> bool:
    """True when a PerceptionResult shows something the drawn one did not: other images (not
    the very same arrays, unless the frame is flagged ``repeated``), another disparity map or
    other markers or objects (unless perception ``reused`` its answer). Pixels are never compared."""
    if drawn is None or result is None:
        return drawn is not result
    f0, f1 = drawn.frame, result.frame
    if (f0 is None) != (f1 is None):
        return True
    if f1 is not None and not (f1.repeated or (f1.left is f0.left and f1.right is f0.right)):
        return True
    if result.disparity is not drawn.disparity:
        return True
    return not (result.reused or (_same_markers(result.markers, drawn.markers)
                                  and _same_objects(result.objects, drawn.objects)))


def command_changed(drawn_command, drawn_goal, command, goal) -> bool:
    """True when a (JointCommand, Goal) shows something the drawn pair did not: joints, target,
    aimed point, reachability, reach error (to the mm shown), mode or note. The held command
    repeated with a new seq and time does not."""
    if drawn_command is None or (drawn_goal is None) != (goal is None):
        return True
    if not (same_points(command.q, drawn_command.q) and command.reachable == drawn_command.reachable
            and round(command.reach_error_m * 1e3) == round(drawn_command.reach_error_m * 1e3)
            and same_points(command.base_p_target, drawn_command.base_p_target)):
        return True
    if goal is None:
        return False
    return not (goal.valid == drawn_goal.valid and goal.mode is drawn_goal.mode and goal.note == drawn_goal.note
                and same_points(goal.base_p_target, drawn_goal.base_p_target))


def state_changed(drawn, state) -> bool:
    """True when a JointState shows something the drawn one did not (joints, feedback or not)."""
    return drawn is None or state.measured != drawn.measured or not same_points(state.q, drawn.q)


def following_text(goal) -> str:
    """"following red ball #3" for a valid Object-mode goal (its note names the object)."""
    note = goal.note or "object"
    return note if note.startswith("following") else f"following {note}"


def format_depth(depth_m: float) -> str:
    """"41 cm" below a metre, "1.25 m" above, "∞" at zero disparity."""
    if not math.isfinite(depth_m):
        return "∞"
    return f"{depth_m * 100:.0f} cm" if depth_m < 1.0 else f"{depth_m:.2f} m"


def depth_texts(x_px: float, y_px: float, sample) -> tuple[str, str]:
    """(label on the view, line in the Stereo tab) for a DepthSample (None: nothing matched)."""
    if sample is None:
        return "no depth here\n(no stereo match)", f"({x_px:.0f}, {y_px:.0f}): no depth — no stereo match there"
    text = f"{sample.depth_mm:.0f} mm"
    where = ""
    if sample.base_p is not None:
        x_cm, y_cm, z_cm = (round(100.0 * v, 1) + 0.0 for v in sample.base_p)  # + 0.0: no "-0.0"
        where = f"x {x_cm:.1f} y {y_cm:.1f} z {z_cm:.1f} cm"
        text += "\n" + where
    readout = (f"Depth at ({x_px:.0f}, {y_px:.0f}): {sample.depth_mm:.0f} mm (disparity "
               f"{sample.disparity_px:.1f} px)" + (f" · robot base {where}" if where else ""))
    return text, readout


def joint_display_limits(profile) -> tuple[list[float], list[float]]:
    """Joint limits as people read them: servo degrees for servo arms, else deg or mm."""
    if getattr(profile, "has_servos", True):
        return [j.servo_min_deg for j in profile.joints], [j.servo_max_deg for j in profile.joints]
    return [j.to_display(j.q_min) for j in profile.joints], [j.to_display(j.q_max) for j in profile.joints]


def joint_display_values(profile, q) -> list[float]:
    """Joint values as people read them (see joint_display_limits)."""
    if getattr(profile, "has_servos", True):
        return list(profile.to_servo_deg(q))
    return list(profile.to_display(q))


def cups_hint(session) -> str:
    """What the cups game needs and this desk lacks ("" when the scene can play it)."""
    if session.is_simulated_camera and session.options.scenario != "cups":
        return ("cups game: this simulated scene has no ball or cups — restart with "
                "`deskarm --scenario cups` to play it")
    if not session.is_simulated_camera:
        return ("cups game: put a red ball on the desk in view of both cameras and cover it "
                "with one of the marked cups; the arm points at the cup hiding it")
    return ""


def teleop_hint(session, source: Optional[str]) -> str:
    """Why Teleop will wait for ever here, in plain words ("" when a hand can be seen): the
    simulated desk shows a hand only in its teleop scenario; the keyboard needs none."""
    if source == KEYBOARD_SOURCE or not session.is_simulated_camera or session.options.scenario == "teleop":
        return ""
    return ("teleop: this simulated scene has no hand in view, so calibrating waits — restart with "
            "`deskarm --scenario teleop`, or choose Keyboard (jog keys) as the hand")


def list_port_choices() -> list[tuple[str, str]]:
    """(label, path) for each serial port, stable names first (empty if listing fails)."""
    try:
        from core.devices.ports import list_ports, preferred_name
    except ImportError:
        return []
    out = []
    for info in list_ports():
        path = preferred_name(info)
        out.append((f"{path} — {info.description}" if info.description else path, path))
    return out


def lissajous_preview(params, kinematics, n: int = 400):
    """Curve points (n,3) with unreachable ones replaced by the nearest reachable, and the
    fraction that was out of reach."""
    ts = np.linspace(0.0, params.period_s(), n)
    points = np.empty((n, 3))
    outside = 0
    q = None
    for k, t in enumerate(ts):
        ik = kinematics.ik(params.point(t), q)
        q = ik.q
        points[k] = ik.base_p_reached
        outside += int(not ik.reachable)
    return points, outside / n


# a title bar and borders a window manager adds around the window (a guess until the window
# manager reports its frame; fit_to_screen corrects it once the window is shown)
FRAME_GUESS_PX = (16, 48)


def fit_window_size(requested: tuple[int, int], available: tuple[int, int],
                    frame: tuple[int, int] = FRAME_GUESS_PX) -> tuple[tuple[int, int], bool]:
    """(size, maximise) for a window asked to be ``requested`` on a screen whose free area is
    ``available``, with a window-manager frame of ``frame`` (w, h) around it: never larger than
    the screen (STOP and the status bar must stay on it), and maximised when window plus frame
    do not fit — a 1280x800 default on a 1280x800 screen (title bar) or an 800x480 touch display."""
    (rw, rh), (aw, ah), (fw, fh) = requested, available, frame
    if aw <= 0 or ah <= 0:  # no screen geometry known
        return (rw, rh), False
    fits = rw + fw <= aw and rh + fh <= ah
    return (min(rw, aw - fw), min(rh, ah - fh)) if fits else (min(rw, aw), min(rh, ah)), not fits


def fitted_geometry(frame: QtCore.QRect, inner: QtCore.QRect, available: QtCore.QRect) -> Optional[QtCore.QRect]:
    """Where a window must go (its inner geometry) so that its frame — title bar included —
    lies inside ``available``; None when it already does. Pure: tested without a screen."""
    if available.isEmpty() or available.contains(frame):
        return None
    left, top = inner.x() - frame.x(), inner.y() - frame.y()
    right, bottom = frame.right() - inner.right(), frame.bottom() - inner.bottom()
    w = min(inner.width(), available.width() - left - right)
    h = min(inner.height(), available.height() - top - bottom)
    x = min(max(frame.x(), available.x()), available.right() + 1 - (w + left + right))
    y = min(max(frame.y(), available.y()), available.bottom() + 1 - (h + top + bottom))
    return QtCore.QRect(x + left, y + top, max(1, w), max(1, h))


def fit_to_screen(window: QtWidgets.QWidget) -> bool:
    """Move/shrink a shown, normal (not maximised or full-screen) window so all of it, frame
    included, is on its screen's available area. True when it had to change."""
    screen = window.screen()
    if screen is None or window.isFullScreen() or window.isMaximized() or not window.isVisible():
        return False
    target = fitted_geometry(window.frameGeometry(), window.geometry(), screen.availableGeometry())
    if target is None:
        return False
    window.setGeometry(target)
    return True


def deskarm_version() -> str:
    try:
        from importlib.metadata import version

        return version("deskarm")
    except Exception:  # noqa: BLE001 - a source checkout without metadata
        return "(source checkout)"


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
    window = MainWindow(session)
    screen = app.primaryScreen()
    free = screen.availableGeometry() if screen is not None else QtCore.QRect()
    fitted, maximise = fit_window_size(size, (free.width(), free.height()))
    app.aboutToQuit.connect(window.stop)
    freeze_startup_objects()  # short young-generation collections while the loop runs
    garbage = GuiThreadGarbage(app)  # … and only in the GUI thread
    app.aboutToQuit.connect(garbage.stop)
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
    if record is not None:  # --record [PATH]: recording from the start (● REC stops it)
        window.record_path = record or None
        window.record_button.setChecked(True)
    return app.exec()


def replay_end_text(camera) -> str:
    """"replay finished (0:12) — …" when ``camera`` is a replay that played to its end, else ""."""
    if getattr(camera, "kind", "") != "replay" or not getattr(camera, "finished", False):
        return ""
    whole_s = int(camera.duration_s)  # as the replay bar counts: "replay 0:12 / 0:12"
    return f"replay finished ({whole_s // 60}:{whole_s % 60:02d}) — tap ▶ Play again or drag the seek bar"


def show_play_again(replay_bar: QtWidgets.QWidget, camera, shown: bool) -> Optional[QtWidgets.QPushButton]:
    """Show (``shown``) or hide the replay bar's ▶ Play again button, made on first use: a tap
    plays ``camera`` (a replay) from its start. Returns the button (None before it was needed)."""
    button = replay_bar.findChild(QtWidgets.QPushButton, "play_again")
    if button is None:
        if not shown:
            return None
        button = touch_button("▶ Play again")
        button.setObjectName("play_again")
        button.setToolTip("Play the recording again from its start")
        # the camera, not the window, in the slot: a window held by its own button's slot is a cycle
        button.clicked.connect(lambda *_: camera.seek(0.0))
        replay_bar.layout().addWidget(button)
    button.setVisible(shown)
    return button


def start_scene_now(session: DeskSession) -> None:
    """Start the simulated desk's scenario (or the replayed recording) over, now that the window
    is up: it began when the session opened the camera, and building the window takes a while —
    on a slow machine the teleop scenario's first calibration corner (held from 1.5 s to 3.5 s)
    was over before the first frame was looked at, and teleop waited for a corner that never came.
    Call it before the workers start (nothing else reads the camera then)."""
    if getattr(session.camera, "kind", "") in ("sim", "replay"):
        session.camera.connect()  # both restart their timeline at the clock's now


def take_screenshot(options: SessionOptions, path: str, after_s: float, size: tuple[int, int]) -> int:
    """Run the window offscreen for ``after_s`` seconds of the scenario and save a PNG of exactly
    ``size`` (width, height) pixels, whatever window geometry the preferences hold (maximised,
    another size) and whatever the offscreen screen's size; exit. The preferences are read (the
    mode, the camera settings) but not written. 1 (and one line) when the PNG cannot be written."""
    app = make_app()
    session = DeskSession.create(options)
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
    app.exec()
    if not (saved and saved[0]):
        import sys

        print(f"deskarm: could not write the screenshot to {path} — check that its folder exists and is "
              "writable", file=sys.stderr)
        return 1
    print(f"deskarm: screenshot saved to {path} ({size[0]}x{size[1]}, after {after_s:g} s)")
    return 0
