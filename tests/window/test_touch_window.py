"""The window on a 7" 800x480 touch screen (issue: a window a touch-screen user can trust).

One test per item that can be checked offscreen: STOP stays stopped, re-arming is a separate
hold, dialogs carry STOP, everything fits at 800x480 (3D twin on too), finger-sized tabs and
drop-down rows, no wheel surprises, tap-to-follow, one target state, kiosk shortcuts.
"""
import random

import numpy as np
import pytest
from PySide6 import QtCore, QtGui, QtWidgets

from app.gui import MainWindow, cups_hint, fitted_geometry
from core.messages import Goal, TargetMode
from core.session import DeskSession, SessionOptions
from widgets.estop import EStopButton, RearmButton
from widgets._style import TOUCH_PX

SMALL = (800, 480)


def make_window(qtbot, robot="desk_rrr", scenario="static", size=SMALL, **options):
    """The main window on the simulated desk (more SessionOptions in ``options``), shown, not started."""
    session = DeskSession.create(SessionOptions(camera="sim", scenario=scenario, robot=robot, **options))
    w = MainWindow(session)
    qtbot.addWidget(w)
    w.resize(*size)
    w.show()
    qtbot.waitExposed(w)
    return w


@pytest.fixture
def small(qtbot):
    w = make_window(qtbot)
    yield w
    w.stop()


# --- 1. STOP is idempotent; re-arming is a separate, held control --------------------------
def test_stop_and_rearm_on_random_taps_never_rearm_without_a_full_hold(qtbot):
    """Random sequences of STOP taps, RE-ARM taps, short presses and full holds: the arm is
    armed only right after a full hold of RE-ARM, and every STOP leaves it stopped."""
    stop, rearm = EStopButton(), RearmButton(hold_ms=60)
    for b in (stop, rearm):
        qtbot.addWidget(b)
        b.show()
    armed = [True]
    stop.sigStopRequested.connect(lambda: armed.__setitem__(0, False))
    rearm.sigHeld.connect(lambda: armed.__setitem__(0, True))
    rng = random.Random(7)
    left = QtCore.Qt.MouseButton.LeftButton
    for _ in range(60):
        action = rng.choice(["stop", "stop", "double_stop", "tap_rearm", "short_hold", "hold"])
        if action in ("stop", "double_stop"):
            for _ in range(1 + (action == "double_stop")):
                qtbot.mouseClick(stop, left)
            assert armed[0] is False
        elif action == "tap_rearm":
            before = armed[0]
            qtbot.mouseClick(rearm, left)
            assert armed[0] is before and not rearm.holding
        elif action == "short_hold":
            before = armed[0]
            qtbot.mousePress(rearm, left)
            assert rearm.holding
            qtbot.mouseRelease(rearm, left)
            assert armed[0] is before and not rearm.holding
        else:
            with qtbot.waitSignal(rearm.sigHeld, timeout=3000):
                qtbot.mousePress(rearm, left)
            qtbot.mouseRelease(rearm, left)
            assert armed[0] is True


def test_stop_is_a_tap_target_and_rearm_only_shows_while_stopped(small):
    assert small.estop_button.height() >= TOUCH_PX and small.estop_button.isVisible()
    assert not small.rearm_button.isVisible()
    small.on_stop_requested()
    assert small.rearm_button.isVisible() and small.rearm_button.height() >= TOUCH_PX
    assert "hold RE-ARM" in small.banner.text()
    small._goal = Goal(seq=1, t=0.0, base_p_target=(0.0, 0.15, 0.1), mode=TargetMode.MANUAL)
    small._dirty = True
    small.redraw()
    assert "stopped" in small.target_status.text()  # not a stale "on target"


# --- 2. dialogs carry STOP and show the e-stop state ----------------------------------------
def test_help_dialog_has_stop_and_shows_the_state(qtbot, small):
    dialog = small.show_help()
    qtbot.waitExposed(dialog)
    assert "keeps moving" in dialog.estop_strip.state_label.text()
    qtbot.mouseClick(dialog.estop_strip.stop_button, QtCore.Qt.MouseButton.LeftButton)
    assert not small.session.controller.armed
    assert "STOPPED" in dialog.estop_strip.state_label.text()
    qtbot.keyClick(dialog, QtCore.Qt.Key.Key_Escape)  # Esc stops again, the dialog stays
    assert dialog.isVisible() and not small.session.controller.armed
    small.on_rearm_requested()  # the window re-arms (held RE-ARM): the dialog follows
    assert "keeps moving" in dialog.estop_strip.state_label.text()


# --- 3. fit at 800x480 -----------------------------------------------------------------------
def test_the_window_needs_no_more_than_800x480_even_with_a_tall_twin(qtbot, small):
    """The 3D twin's GL view asks for ~500 px; whatever the twin stack holds, the window's
    minimum stays within 800x480 and the shown window is not grown past it."""
    tall = QtWidgets.QWidget()
    tall.setMinimumSize(300, 520)  # a stand-in for the GL view (no OpenGL offscreen)
    small.twin_stack.addWidget(tall)
    small.twin_stack.setCurrentWidget(tall)
    qtbot.waitUntil(lambda: small.twin_stack.currentWidget() is tall)
    QtWidgets.QApplication.processEvents()
    hint = small.minimumSizeHint()
    assert hint.width() <= SMALL[0] and hint.height() <= SMALL[1], hint
    assert small.height() <= SMALL[1] and small.width() <= SMALL[0]
    small.twin_stack.setCurrentWidget(small.twin)
    assert small.height() <= SMALL[1]


def test_every_tab_fits_800x480_without_sideways_scrolling(qtbot, small):
    for i in range(small.tabs.count()):
        small.tabs.setCurrentIndex(i)
        QtWidgets.QApplication.processEvents()
        area = small.tabs.widget(i)
        assert area.horizontalScrollBar().maximum() == 0, small.tabs.tabText(i)
    assert small.statusBar().geometry().bottom() < small.height()
    # the target state is outside the tabs: visible whatever tab is open
    assert small.target_status.isVisibleTo(small) and not small.tabs.isAncestorOf(small.target_status)


@pytest.mark.parametrize("frame, inner, available, expected", [
    # a 1280x800 window with a 19 px title bar on a 1280x800 screen: shrunk to fit, title bar on screen
    ((0, 0, 1280, 819), (0, 19, 1280, 800), (0, 0, 1280, 800), (0, 19, 1280, 781)),
    # already inside: nothing to do
    ((10, 10, 800, 480), (12, 30, 796, 458), (0, 0, 1920, 1080), None),
    # pushed off the right edge: moved back
    ((1500, 0, 600, 400), (1500, 20, 600, 380), (0, 0, 1920, 1080), (1320, 20, 600, 380)),
])
def test_fitted_geometry_keeps_the_frame_on_the_free_area(frame, inner, available, expected):
    got = fitted_geometry(QtCore.QRect(*frame), QtCore.QRect(*inner), QtCore.QRect(*available))
    assert (None if got is None else got.getRect()) == expected


def test_lissajous_run_is_at_the_top_of_its_page(qtbot, small):
    small.target_panel.mode_buttons["lissajous"].click()
    QtWidgets.QApplication.processEvents()
    run = small.target_panel.run_button
    area = small.target_panel.stack.currentWidget()  # the page's scroll area
    top_left = run.mapTo(area.viewport(), QtCore.QPoint(0, 0))
    assert run.isVisible() and 0 <= top_left.y() and top_left.y() + run.height() <= area.viewport().height()


# --- 6. touch targets -------------------------------------------------------------------------
def test_tabs_and_drop_down_rows_are_finger_sized(qtbot, small):
    bar = small.tabs.tabBar()
    assert all(bar.tabRect(i).height() >= TOUCH_PX for i in range(bar.count()))
    combos = small.findChildren(QtWidgets.QComboBox)
    assert combos
    for combo in combos:
        if combo.count() == 0:
            combo.addItem("probe")
        combo.showPopup()
        QtWidgets.QApplication.processEvents()
        assert combo.view().visualRect(combo.model().index(0, 0)).height() >= TOUCH_PX, combo.objectName()
        combo.hidePopup()


# --- 7. the wheel over an unfocused slider scrolls the page, not the value ------------------
def test_wheel_over_an_unfocused_slider_keeps_its_value(qtbot, small):
    small.tabs.deferred.insert_all()  # the pages of the tabs not opened yet too (they join when opened)
    sliders = [s for s in small.findChildren(QtWidgets.QAbstractSlider)
               if not isinstance(s, QtWidgets.QScrollBar)]
    assert len(sliders) > 5
    for slider in sliders:
        before = slider.value()
        centre = QtCore.QPointF(slider.width() / 2, slider.height() / 2)
        event = QtGui.QWheelEvent(centre, slider.mapToGlobal(centre), QtCore.QPoint(0, 0),
                                  QtCore.QPoint(0, -120), QtCore.Qt.MouseButton.NoButton,
                                  QtCore.Qt.KeyboardModifier.NoModifier, QtCore.Qt.ScrollPhase.NoScrollPhase, False)
        QtWidgets.QApplication.sendEvent(slider, event)
        assert slider.value() == before, slider.parent()
    # once chosen (focused), the wheel does move it
    slider = small.target_panel.axes["x"].slider
    small.tabs.setCurrentIndex(0)
    small.activateWindow()
    slider.setFocus()
    qtbot.waitUntil(slider.hasFocus)
    before = slider.value()
    centre = QtCore.QPointF(slider.width() / 2, slider.height() / 2)
    event = QtGui.QWheelEvent(centre, slider.mapToGlobal(centre), QtCore.QPoint(0, 0), QtCore.QPoint(0, 120),
                              QtCore.Qt.MouseButton.NoButton, QtCore.Qt.KeyboardModifier.NoModifier,
                              QtCore.Qt.ScrollPhase.NoScrollPhase, False)
    QtWidgets.QApplication.sendEvent(slider, event)
    assert slider.value() != before


# --- 8. tap a marker in Follow mode: follow it ------------------------------------------------
def test_tapping_a_marker_in_follow_mode_follows_it(qtbot, small):
    small.start()
    try:
        qtbot.waitUntil(lambda: small._result is not None and sum(m.found for m in small._result.markers) == 2,
                        timeout=5000)
        small.target_panel.mode_buttons["follow"].click()
        small.target_panel.set_follow_id(23)
        small.on_marker_clicked(50)
        assert small.session.targeter.mode is TargetMode.FOLLOW
        assert small.session.targeter.follow_id == 50 and small.target_panel.follow_id == 50
        small.target_panel.mode_buttons["manual"].click()  # outside Follow: a fixed manual point
        small.on_marker_clicked(23)
        assert small.session.targeter.mode is TargetMode.MANUAL
    finally:
        small.stop()


# --- 9. one target state for the Pose and Target tabs ---------------------------------------
def test_pose_and_target_tabs_show_one_target(qtbot):
    w = make_window(qtbot, robot="umi_rtx")
    try:
        pose = w.pose_panel.pose()
        assert np.allclose(pose.base_p, w.target_panel.manual_target(), atol=1e-3)  # from the start
        moved = type(pose)((pose.base_p[0] + 0.05, pose.base_p[1], pose.base_p[2] - 0.02), pose.rpy, pose.grip_m)
        w.on_pose_target(moved)
        assert np.allclose(w.target_panel.manual_target(), moved.base_p, atol=1e-3)
        assert np.allclose(w.session.targeter.manual_target, moved.base_p)
        w.target_panel.set_manual_target((0.1, 0.2, 0.15))  # Target tab edit -> Pose tab
        assert np.allclose(w.pose_panel.pose().base_p, (0.1, 0.2, 0.15), atol=1e-3)
        assert np.allclose(w.pose_panel.pose().rpy, moved.rpy, atol=1e-3)  # orientation kept
        assert w.target_status.isVisibleTo(w)  # reach feedback is outside both tabs
    finally:
        w.stop()


# --- 10. a failed bridge switch is not shown in success green ------------------------------
def test_a_failed_bridge_switch_is_not_green(qtbot, small):
    small.start()
    try:
        small.on_bridge_requested("v2:/dev/deskarm-no-such-port")
        qtbot.waitUntil(lambda: small._bridge_status is not None and "could not" in small._bridge_status.message,
                        timeout=5000)
        small._refresh_status()
        assert small._bridge_status.request_failed and small._bridge_status.connected  # still on sim://
        assert "#2e9d44" not in small.bridge_picker.status_label.text()  # not success green
        small.on_bridge_requested("sim://")  # a switch that works is green again
        qtbot.waitUntil(lambda: not small._bridge_status.request_failed, timeout=5000)
        small._refresh_status()
        assert "#2e9d44" in small.bridge_picker.status_label.text()
    finally:
        small.stop()


# --- 11. cups without a ball -------------------------------------------------------------------
def test_cups_game_in_a_scene_without_a_ball_says_how(qtbot, small):
    small.target_panel.mode_buttons["cups"].click()
    assert "--scenario cups" in small.target_panel.cups_hint.text()
    assert "--scenario cups" in small.banner.text()
    assert cups_hint(DeskSession.create(SessionOptions(camera="sim", scenario="cups"))) == ""


# --- 14. kiosk: quit, full screen and help from the keyboard and the menu --------------------
def test_kiosk_shortcuts_and_menu(qtbot, small):
    actions = {a.text(): a for a in small.menu_button.menu().actions() if a.text()}
    assert {"Full screen", "Help && about", "Quit"} <= set(actions)
    assert small.fullscreen_action.shortcut() == QtGui.QKeySequence("F11")
    assert small.quit_action.shortcut() == QtGui.QKeySequence("Ctrl+Q")
    assert small.menu_button.height() >= TOUCH_PX
    small.toggle_fullscreen()
    qtbot.waitUntil(small.isFullScreen)
    small.toggle_fullscreen()
    qtbot.waitUntil(lambda: not small.isFullScreen())
    dialog = small.show_help()
    assert "Ctrl+Q" in "".join(label.text() for label in dialog.findChildren(QtWidgets.QLabel))
    small.start()
    small.quit_action.trigger()  # Ctrl+Q: closes the window, which stops its workers
    qtbot.waitUntil(lambda: not small.isVisible())
    assert not small.workers.control.isRunning()


def test_a_modal_dialog_without_stop_pauses_the_arm_and_says_so(qtbot, small):
    small.start()
    try:
        box = QtWidgets.QMessageBox(QtWidgets.QMessageBox.Icon.Question, "Save?", "a file dialog stand-in",
                                    parent=small)
        box.open()  # window-modal, like a file dialog
        qtbot.waitUntil(lambda: QtWidgets.QApplication.activeModalWidget() is box)
        small.check_modal_dialog()  # also run by focus changes and the 2 Hz status refresh
        assert small.session.controller.paused and "paused" in small.banner.text()
        box.done(0)
        qtbot.waitUntil(lambda: QtWidgets.QApplication.activeModalWidget() is None)
        small.check_modal_dialog()
        assert not small.session.controller.paused and "paused" not in small.banner.text()
        # a dialog with its own STOP (help, the calibration wizard) does not pause the arm
        dialog = small.show_help()
        dialog.setModal(True)
        small.check_modal_dialog()
        assert not small.session.controller.paused
    finally:
        small.stop()


def test_the_calibration_wizard_carries_stop_and_the_simulated_desk_shows_it_a_board(qtbot, small):
    small.start()
    try:
        small.on_open_calibration()
        ctl = small.calibration_controller
        wizard = ctl.wizard
        qtbot.waitExposed(wizard)
        qtbot.mouseClick(wizard.stop_button, QtCore.Qt.MouseButton.LeftButton)
        assert not small.session.controller.armed and small.estop_button.engaged
        assert wizard.estop_engaged and wizard.isVisible()
        small.on_rearm_requested()
        assert not wizard.estop_engaged
        # starting a capture session holds a board up in front of the simulated cameras
        ctl.on_start_requested(ctl.board or wizard_board(wizard))
        qtbot.waitUntil(lambda: small.session.camera.shown_board is not None, timeout=3000)
        ctl.close()
        qtbot.waitUntil(lambda: small.session.camera.shown_board is None, timeout=3000)
    finally:
        small.stop()


def wizard_board(wizard):
    from core.vision.stereo_calibration import ChessboardSpec

    return ChessboardSpec(9, 6, 0.025)


def test_the_wizard_dictionary_list_has_finger_sized_rows(qtbot):
    from widgets.calibration_wizard import CalibrationWizard

    wizard = CalibrationWizard()
    qtbot.addWidget(wizard)
    combo = wizard.fields["dictionary"]
    assert combo.view().sizeHintForRow(0) >= TOUCH_PX


def test_record_button_records_the_session_and_a_replay_reads_it(qtbot, small, tmp_path, monkeypatch):
    from core.record.reader import open_recording

    monkeypatch.setenv("DESKARM_HOME", str(tmp_path))
    small.start()
    try:
        qtbot.waitUntil(lambda: small._result is not None, timeout=5000)
        small.record_button.click()
        assert small.recorder is not None and small.record_button.height() >= TOUCH_PX
        qtbot.waitUntil(lambda: small.recorder.frames_written >= 10, timeout=10000)
        small._refresh_status()
        assert small.record_button.text().startswith("■")
        path = small.recorder.path
        small.record_button.click()  # stop: the recorder's thread is joined, the note names the folder
        assert small.recorder is None and str(path) in small._note
    finally:
        small.stop()
    recording = open_recording(path)
    assert recording.topics["/deskarm/camera/left/image/compressed"] >= 10 and recording.session.robot == "desk_rrr"


def test_a_replay_has_a_seek_bar_shows_the_recorded_arm_and_is_listed(qtbot, tmp_path, monkeypatch):
    import subprocess
    import sys

    monkeypatch.setenv("DESKARM_HOME", str(tmp_path))
    from core.record.recorder import default_recording_path

    path = default_recording_path()
    done = subprocess.run([sys.executable, "-m", "app.cli", "--headless", "--fast", "--duration", "2",
                           "--record", str(path)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    session = DeskSession.create(SessionOptions(camera=f"replay:{path}", scenario="static"))
    w = MainWindow(session)
    qtbot.addWidget(w)
    w.resize(*SMALL)
    w.show()
    w.start()
    try:
        assert w.replay_bar is not None and w.replay_slider.height() >= TOUCH_PX
        qtbot.waitUntil(lambda: w._result is not None and w._state is not None, timeout=5000)
        w._refresh_status()
        assert w.replay_label.text().startswith("replay")
        w._dirty = True
        w.redraw()
        assert "recorded arm" in w.twin.legend_text()
        w.replay_slider.setValue(500)
        w.on_replay_seek()  # the replay continues from the middle
        dialog = w.show_recordings()
        assert dialog.list.count() == 1 and "2 s" in dialog.list.item(0).text()
        dialog.list.setCurrentRow(0)
        assert f"replay:{path}" in dialog.command_label.text()
        qtbot.mouseClick(dialog.estop_strip.stop_button, QtCore.Qt.MouseButton.LeftButton)
        assert not w.session.controller.armed
    finally:
        w.stop()
        session.close()
