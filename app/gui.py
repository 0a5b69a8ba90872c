"""The main window: camera views, arm twin, target / camera / stereo / joint panels, status bar.

The GUI thread only stores the newest worker results in slots and redraws from them at display
rate (a single-shot timer re-armed after each draw), so slow frames never pile up.
"""
from __future__ import annotations

import math
import sys
import time
from typing import Optional

import numpy as np
from PySide6 import QtCore, QtGui, QtWidgets

from app.workers import WorkerSet
from core.messages import TargetMode
from core.session import DeskSession, SessionOptions
from widgets.arm_twin import ArmTwin
from widgets.camera_controls import CameraSettingsPanel, SgbmPanel
from widgets.bridge_picker import BridgePicker
from widgets.camera_view import CameraView, MarkerOverlay
from widgets.estop import EStopButton
from widgets.joint_readout import JointReadout
from widgets.status import Banner, StatusBarItems
from widgets.target_panel import TargetPanel

REDRAW_INTERVAL_MS = 33  # ~30 Hz display rate


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
        self._bridge_status = None
        self._frame_times: list[float] = []
        self._latency_ms = 0.0
        self._camera_error: Optional[str] = None
        self._dirty = False
        self._build()
        self.workers = WorkerSet(session, self)
        self.workers.perception.sigResult.connect(self.on_result)
        self.workers.perception.sigError.connect(self.on_camera_error)
        self.workers.control.sigCommand.connect(self.on_command)
        self.workers.bridge.sigState.connect(self.on_state)
        self.workers.bridge.sigStatus.connect(self.on_bridge_status)
        self._redraw_timer = QtCore.QTimer(self)
        self._redraw_timer.setSingleShot(True)
        self._redraw_timer.timeout.connect(self.redraw)

    # --- layout -----------------------------------------------------------------------------
    def _build(self) -> None:
        s = self.session
        central = QtWidgets.QWidget()
        outer = QtWidgets.QVBoxLayout(central)
        outer.setContentsMargins(4, 4, 4, 4)
        outer.setSpacing(4)
        top = QtWidgets.QHBoxLayout()
        self.banner = Banner()
        top.addWidget(self.banner, 1)
        self.estop_button = EStopButton()
        self.estop_button.sigEstopChanged.connect(self.on_estop)
        top.addWidget(self.estop_button)
        outer.addLayout(top)
        stop_shortcut = QtGui.QShortcut(QtGui.QKeySequence(QtCore.Qt.Key.Key_Escape), self)
        stop_shortcut.setContext(QtCore.Qt.ShortcutContext.ApplicationShortcut)
        stop_shortcut.activated.connect(self.estop_button.engage)
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
            v.sigMarkerClicked.connect(self.on_marker_clicked)
        left_layout.addLayout(cams, 3)
        self.twin = ArmTwin()
        reach = s.kinematics.workspace_radius_range() if hasattr(s.kinematics, "workspace_radius_range") else (0.0, 0.25)
        self.twin.set_view_range(max(0.25, reach[1] + 0.04), 0.32)
        self._set_workspace_outline()
        left_layout.addWidget(self.twin, 2)
        self.splitter.addWidget(left)

        self.tabs = QtWidgets.QTabWidget()
        self.tabs.setDocumentMode(True)
        self.tabs.tabBar().setExpanding(True)
        self.tabs.setStyleSheet("QTabBar::tab { min-height: 40px; min-width: 60px; padding: 0 8px; }")
        self.target_panel = TargetPanel()
        self.camera_panel = CameraSettingsPanel()
        self.sgbm_panel = SgbmPanel()
        self.joints = JointReadout()
        self.joints.set_joints(s.profile.joint_names, *joint_display_limits(s.profile))
        self.bridge_picker = BridgePicker(list_port_choices)
        self.bridge_picker.sigConnectRequested.connect(self.on_bridge_requested)
        robot_page = QtWidgets.QWidget()
        robot_layout = QtWidgets.QVBoxLayout(robot_page)
        robot_layout.setContentsMargins(0, 0, 0, 0)
        robot_layout.addWidget(self.joints)
        robot_layout.addWidget(self.bridge_picker)
        robot_layout.addStretch(1)
        for widget, title in ((self.target_panel, "Target"), (self.camera_panel, "Camera"),
                              (self.sgbm_panel, "Stereo"), (robot_page, "Robot")):
            area = QtWidgets.QScrollArea()
            area.setWidgetResizable(True)
            area.setFrameShape(QtWidgets.QFrame.Shape.NoFrame)
            area.setWidget(widget)
            # flick-scroll with a finger on touch screens
            QtWidgets.QScroller.grabGesture(area.viewport(), QtWidgets.QScroller.ScrollerGestureType.TouchGesture)
            self.tabs.addTab(area, title)
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
        tp.sigLissajousChanged.connect(self.on_lissajous)
        tp.sigLissajousRunning.connect(self.on_lissajous_running)
        tp.set_mode(s.targeter.mode.value)
        self.camera_panel.sigSettingsChanged.connect(self.on_camera_settings)
        self.sgbm_panel.sigParamsChanged.connect(self.on_sgbm_params)
        self._update_preview()

    def _set_workspace_outline(self) -> None:
        kin = self.session.kinematics
        side = np.asarray(kin.workspace_outline_side()) if hasattr(kin, "workspace_outline_side") else None
        top = None
        if hasattr(kin, "workspace_radius_range"):
            r_min, r_max = kin.workspace_radius_range()
            a = np.linspace(0, 2 * math.pi, 121)
            top = np.c_[r_max * np.cos(a), r_max * np.sin(a)]
        self.twin.set_workspace(top, side)

    def resizeEvent(self, event: QtGui.QResizeEvent) -> None:  # noqa: N802 (Qt override)
        """Give the panels the width they need (~370 px) and the views the rest."""
        super().resizeEvent(event)
        width = self.splitter.width() or event.size().width()
        needed = max(w.minimumSizeHint().width() for w in (self.target_panel, self.camera_panel, self.sgbm_panel, self.joints, self.bridge_picker))
        panel = max(needed + 40, int(0.30 * width))  # + the scroll bar and frame
        panel = min(panel, max(300, width - 400), 560)
        self.splitter.setSizes([width - panel, panel])

    # --- lifecycle --------------------------------------------------------------------------
    def start(self) -> None:
        self.workers.start()
        self._redraw_timer.start(REDRAW_INTERVAL_MS)

    def stop(self) -> None:
        self._redraw_timer.stop()
        self.workers.stop()

    def closeEvent(self, event: QtGui.QCloseEvent) -> None:  # noqa: N802 (Qt override)
        self.stop()
        super().closeEvent(event)

    # --- worker slots (GUI thread; they only store, redraw draws) ----------------------------
    @QtCore.Slot(object)
    def on_result(self, result) -> None:
        self._result = result
        now = time.monotonic()
        self._frame_times.append(now)
        while self._frame_times and now - self._frame_times[0] > 2.0:
            self._frame_times.pop(0)
        self._dirty = True

    @QtCore.Slot(str)
    def on_camera_error(self, message: str) -> None:
        """A camera problem (banner, retrying) or, with "", the camera is back."""
        self._camera_error = message or None
        if message:
            self.banner.show_message(f"camera lost — {message} — retrying", "error")
        else:
            self._restore_banner()

    @QtCore.Slot(object, object)
    def on_command(self, command, goal) -> None:
        self._command, self._goal = command, goal
        if command.source_t is not None:
            self._latency_ms = (self.session.clock.now() - command.source_t) * 1e3
        self._dirty = True

    @QtCore.Slot(object)
    def on_state(self, state) -> None:
        self._state = state
        self._dirty = True

    @QtCore.Slot(object)
    def on_bridge_status(self, status) -> None:
        self._bridge_status = status

    # --- panel slots --------------------------------------------------------------------------
    @QtCore.Slot(str)
    def on_mode_changed(self, mode: str) -> None:
        self.session.targeter.set_mode(TargetMode(mode))
        self._update_preview()

    @QtCore.Slot(object)
    def on_manual_target(self, p) -> None:
        self.session.targeter.set_manual_target(p)

    @QtCore.Slot(int)
    def on_follow_id(self, marker_id: int) -> None:
        self.session.targeter.set_follow_id(marker_id)

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

    @QtCore.Slot(bool)
    def on_estop(self, engaged: bool) -> None:
        """E-stop: the control worker refuses commands and the bridge stops the arm."""
        if engaged:
            self.session.controller.estop()
            self.banner.show_message("E-STOP — the arm is stopped. Tap RE-ARM to resume.", "error")
        else:
            self.session.controller.rearm()
            self._restore_banner()
        self.workers.bridge.request_estop(engaged)

    def _restore_banner(self) -> None:
        s = self.session
        if s.banners:
            self.banner.show_message(" · ".join(s.banners), "warn" if "UNCALIBRATED" in " ".join(s.banners) else "info")
        else:
            self.banner.clear()

    @QtCore.Slot(str)
    def on_bridge_requested(self, url: str) -> None:
        self.bridge_picker.set_status(f"connecting to {url} …", True)
        self.workers.bridge.request_bridge(url)

    @QtCore.Slot(str)
    def on_display_mode(self, _mode: str) -> None:
        wanted = "disparity" in (self.view_left.display_mode, self.view_right.display_mode)
        self.workers.perception.set_disparity_enabled(wanted)

    @QtCore.Slot(int)
    def on_marker_clicked(self, marker_id: int) -> None:
        """Tapping a marker makes it the manual target (pointing position above it)."""
        if self._result is None:
            return
        obs = self._result.marker(marker_id)
        if obs is None or obs.base_p_centre is None:
            return
        self.target_panel.set_mode(TargetMode.MANUAL.value)  # does not emit: tell the targeter
        self.on_mode_changed(TargetMode.MANUAL.value)
        self.target_panel.set_manual_target(self.session.targeter.pointing.apply(obs.base_p_centre))

    def _update_preview(self) -> None:
        """Lissajous preview in the twin, with out-of-reach points moved to the nearest reachable."""
        t = self.session.targeter
        if t.mode is not TargetMode.LISSAJOUS:
            self.twin.set_preview(None)
            self._preview_note = ""
            return
        points, outside = lissajous_preview(t.lissajous, self.session.kinematics)
        self.twin.set_preview(points)
        self._preview_note = (
            f"{outside:.0%} of the curve is out of reach (drawn at the nearest reachable point)" if outside else ""
        )

    # --- drawing ------------------------------------------------------------------------------
    def redraw(self) -> None:
        try:
            if self._dirty:
                self._dirty = False
                self._draw()
        finally:
            self._redraw_timer.start(REDRAW_INTERVAL_MS)

    def _draw(self) -> None:
        s = self.session
        r = self._result
        fps = (len(self._frame_times) - 1) / (self._frame_times[-1] - self._frame_times[0]) if len(self._frame_times) > 2 else 0.0
        if r is not None and r.frame is not None:
            for view, img, side in ((self.view_left, r.frame.left, "left"), (self.view_right, r.frame.right, "right")):
                if view.display_mode == "disparity" and r.disparity is not None:
                    view.show_disparity(r.disparity, float(self.sgbm_panel.params().num_disparities + self.sgbm_panel.params().min_disparity))
                else:
                    view.show_image(img)
                compact = view.width() < 420  # small views: ids only, positions are in the twin
                overlays = [o for o in (MarkerOverlay.from_observation(m, side, "" if compact else None)
                                        for m in r.markers) if o is not None]
                view.set_markers(overlays)
                view.set_fps(fps)
            self.twin.set_markers({m.marker_id: np.asarray(m.base_p_centre) for m in r.markers if m.found and m.base_p_centre is not None})
        commanded = s.kinematics.chain_points(self._command.q) if self._command is not None else None
        measured = s.kinematics.chain_points(self._state.q) if self._state is not None else None
        self.twin.set_arm(None if commanded is None else np.asarray(commanded), None if measured is None else np.asarray(measured))
        if self._state is not None:
            self.twin.set_measured_label("measured" if self._state.measured else "commanded (no feedback)")
        goal, cmd = self._goal, self._command
        if goal is not None:
            self.twin.set_target(goal.base_p_target if goal.valid else None, bool(cmd.reachable) if cmd else True)
            self.twin.set_aimed_point(cmd.base_p_target if cmd is not None and not cmd.reachable else None)
            if not goal.valid:
                self.target_panel.set_reach_status(goal.note or "target lost — holding", False)
            elif cmd is not None and not cmd.reachable:
                self.target_panel.set_reach_status(
                    f"out of reach by {cmd.reach_error_m * 1e3:.0f} mm — going to the nearest point", False)
            elif goal.mode is TargetMode.LISSAJOUS and getattr(self, "_preview_note", ""):
                self.target_panel.set_reach_status(self._preview_note, False)
            else:
                self.target_panel.set_reach_status(f"on target{' · ' + goal.note if goal.note else ''}", True)
        cmd_deg = joint_display_values(s.profile, cmd.q) if cmd is not None else None
        meas_deg = joint_display_values(s.profile, self._state.q) if self._state is not None else None
        self.joints.set_values(cmd_deg, meas_deg)
        b = self._bridge_status
        bridge_text = "—" if b is None else (f"{b.url} ✓ {b.commands_sent} cmds" if b.connected else f"{b.url} ✗ {b.message}")
        if not s.controller.armed:
            bridge_text = f"E-STOP · {bridge_text}"
        if b is not None:
            self.bridge_picker.set_status(f"{b.url}: {'connected' if b.connected else 'not connected'}"
                                          f"{' — ' + b.message if b.message else ''}", b.connected)
        self.status_items.update(s.camera.name, bridge_text, fps, self._latency_ms)


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


def list_port_choices() -> list[tuple[str, str]]:
    """(label, path) for each serial port, stable names first (empty if listing fails)."""
    try:
        from core.serial_ports import list_ports, preferred_name
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


def _make_app() -> QtWidgets.QApplication:
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication(sys.argv[:1])
    app.setApplicationName("deskarm")
    from pathlib import Path

    icon = Path(__file__).resolve().parents[1] / "resources" / "deskarm.svg"
    if icon.is_file():
        app.setWindowIcon(QtGui.QIcon(str(icon)))
    return app


def run_window(options: SessionOptions, size: tuple[int, int]) -> int:
    """Open the window and run until it is closed."""
    app = _make_app()
    try:
        session = DeskSession.create(options)
    except (OSError, RuntimeError, ValueError) as exc:
        QtWidgets.QMessageBox.critical(None, "deskarm could not start", str(exc))
        return 1
    window = MainWindow(session)
    window.resize(*size)
    app.aboutToQuit.connect(window.stop)
    window.show()
    window.start()
    return app.exec()


def take_screenshot(options: SessionOptions, path: str, after_s: float, size: tuple[int, int]) -> int:
    """Run the window offscreen for ``after_s`` seconds of the scenario, save a PNG, exit."""
    app = _make_app()
    session = DeskSession.create(options)
    window = MainWindow(session)
    window.resize(*size)
    window.show()
    window.start()

    def grab() -> None:
        window.redraw()
        window.grab().save(path)
        window.stop()
        app.quit()

    QtCore.QTimer.singleShot(int(after_s * 1000), grab)
    app.exec()
    print(f"deskarm: screenshot saved to {path} ({size[0]}x{size[1]}, after {after_s:g} s)")
    return 0
