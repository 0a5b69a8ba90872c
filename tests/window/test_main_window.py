"""The main window on the simulated desk, with its three workers running (pytest-qt, offscreen).

Tests wait on the window's own GUI-thread state (set by its queued slots) with
``qtbot.waitUntil`` — never ``waitSignal`` on a worker-thread signal: pytest-qt would run its
callback in the worker thread and race the GUI thread (seen as rare segfaults).
"""
import pytest
from PySide6 import QtCore

from app.gui import MainWindow, fit_window_size
from core.messages import TargetMode
from core.session import DeskSession, SessionOptions


def shown_window(qtbot, robot="desk_rrr"):
    """The main window for ``robot`` on the static simulated desk, shown at 800x480 (not started)."""
    session = DeskSession.create(SessionOptions(camera="sim", scenario="static", robot=robot))
    w = MainWindow(session)
    qtbot.addWidget(w)
    w.resize(800, 480)
    w.show()
    return w


@pytest.fixture
def window(qtbot):
    w = shown_window(qtbot)
    w.start()
    yield w
    w.stop()
    for worker in (w.workers.perception, w.workers.control, w.workers.bridge):
        assert worker.isFinished() or not worker.isRunning()


def first_result_with(qtbot, window, predicate, timeout=5000):
    """Wait until the window has received a perception result for which predicate holds."""
    qtbot.waitUntil(lambda: window._result is not None and predicate(window._result), timeout=timeout)


def command_with(qtbot, window, predicate, timeout=3000):
    """Wait until the window has received a (command, goal) for which predicate holds."""
    qtbot.waitUntil(lambda: window._command is not None and predicate(window._command, window._goal),
                    timeout=timeout)


def test_markers_are_found_and_drawn(qtbot, window):
    first_result_with(qtbot, window, lambda r: sum(m.found for m in r.markers) == 2)
    window.redraw()
    assert window._result is not None
    assert {m.marker_id for m in window._result.markers if m.found} == {23, 50}


def test_mode_switch_reaches_the_targeter(qtbot, window):
    panel = window.target_panel
    for mode in (TargetMode.LISSAJOUS, TargetMode.MANUAL, TargetMode.CUPS, TargetMode.FOLLOW):
        with qtbot.waitSignal(panel.sigModeChanged, timeout=1000):
            panel.mode_buttons[mode.value].click()
        assert window.session.targeter.mode is mode


def test_manual_slider_moves_the_arm_goal(qtbot, window):
    panel = window.target_panel
    panel.set_mode("manual")
    window.on_mode_changed("manual")
    with qtbot.waitSignal(panel.sigManualTargetChanged, timeout=1000):
        panel.axes["x"].spin.setValue(-6.5)
    assert window.session.targeter.manual_target[0] == pytest.approx(-0.065)
    # the control worker turns it into a command aimed at that point
    command_with(qtbot, window, lambda cmd, goal: abs(goal.base_p_target[0] + 0.065) < 1e-9)


def test_lissajous_on_and_off(qtbot, window):
    panel = window.target_panel
    panel.set_mode("lissajous")
    window.on_mode_changed("lissajous")
    with qtbot.waitSignal(panel.sigLissajousRunning, timeout=1000):
        panel.run_button.click()
    assert window.session.targeter.lissajous_running
    # the goal follows the curve: two commands some ticks apart aim at different points
    seen = []

    def moved(cmd, goal):
        seen.append(goal.base_p_target)
        return goal.mode is TargetMode.LISSAJOUS and len(seen) > 5 and seen[-1] != seen[0]

    command_with(qtbot, window, moved)
    with qtbot.waitSignal(panel.sigLissajousRunning, timeout=1000):
        panel.run_button.click()
    assert not window.session.targeter.lissajous_running


def test_disparity_is_computed_only_while_shown(qtbot, window):
    first_result_with(qtbot, window, lambda r: r.disparity is None)
    with qtbot.waitSignal(window.view_left.sigDisplayModeChanged, timeout=1000):
        window.view_left.toggle_button.click()
    first_result_with(qtbot, window, lambda r: r.disparity is not None)
    window._dirty = True
    window.redraw()
    with qtbot.waitSignal(window.view_left.sigDisplayModeChanged, timeout=1000):
        window.view_left.toggle_button.click()
    first_result_with(qtbot, window, lambda r: r.disparity is None)


@pytest.mark.parametrize("requested, available, expected", [
    ((1280, 800), (1920, 1050), ((1280, 800), False)),  # a desktop: the size asked for
    ((1280, 800), (800, 480), ((800, 480), True)),  # the Pi touch display: maximised, on screen
    ((1280, 800), (1024, 570), ((1024, 570), True)),  # a netbook with a panel
    ((800, 480), (800, 480), ((800, 480), True)),  # no room for a title bar: maximised
    ((1280, 800), (1280, 800), ((1280, 800), True)),  # the same at 1280x800 under a window manager
    ((1280, 800), (1366, 900), ((1280, 800), False)),  # room for the frame: as asked
    ((1280, 800), (0, 0), ((1280, 800), False)),  # no screen geometry: as asked
])
def test_the_window_never_opens_larger_than_the_screen(requested, available, expected):
    assert fit_window_size(requested, available) == expected


def test_window_fits_800x480(window):
    window.redraw()
    hint = window.minimumSizeHint()
    assert hint.width() <= 800 and hint.height() <= 480, hint


@pytest.mark.parametrize("robot", ["desk_rrr", "umi_rtx"])
def test_no_panel_page_is_clipped_or_scrolls_sideways_at_800x480(qtbot, robot):
    w = shown_window(qtbot, robot)
    qtbot.waitExposed(w)
    left = w.splitter.widget(0)
    assert left.width() >= left.minimumSizeHint().width()  # the camera views keep their room
    for i in range(w.tabs.count()):
        w.tabs.setCurrentIndex(i)
        area = w.tabs.widget(i)
        qtbot.waitUntil(lambda: area.isVisible())
        page = area.widget()
        assert area.horizontalScrollBar().maximum() == 0, w.tabs.tabText(i)
        assert page.width() >= page.minimumSizeHint().width(), (
            f"{w.tabs.tabText(i)} page {page.width()} px wide, needs {page.minimumSizeHint().width()}")
    assert w.tabs.tabBar().sizeHint().width() <= w.tabs.width(), "every tab title visible"


def test_estop_stops_commands_until_rearmed(qtbot, window):
    command_with(qtbot, window, lambda cmd, goal: True)
    window.estop_button.click()
    assert window.estop_button.engaged and not window.session.controller.armed
    assert "E-STOP" in window.banner.text()
    # a tick already in flight may still arrive; after that nothing is commanded
    qtbot.wait(200)
    seq = window._command.seq
    qtbot.wait(300)  # a negative check needs a span of time: 15 control ticks
    assert window._command.seq == seq
    assert window.rearm_button.isVisible()
    hold_to_rearm(qtbot, window)
    assert window.session.controller.armed and not window.rearm_button.isVisible()
    command_with(qtbot, window, lambda cmd, goal: cmd.seq > seq)


def hold_to_rearm(qtbot, window):
    """Press RE-ARM and keep it down until it acts (its hold), then release."""
    button = window.rearm_button
    with qtbot.waitSignal(button.sigHeld, timeout=5000):
        qtbot.mousePress(button, QtCore.Qt.MouseButton.LeftButton)
    qtbot.mouseRelease(button, QtCore.Qt.MouseButton.LeftButton)


def test_a_double_tap_on_stop_stays_stopped(qtbot, window):
    """Two taps 150 ms apart (a panicked double tap, a bouncing touch screen) stop twice."""
    command_with(qtbot, window, lambda cmd, goal: True)
    qtbot.mouseClick(window.estop_button, QtCore.Qt.MouseButton.LeftButton)
    qtbot.wait(150)
    qtbot.mouseClick(window.estop_button, QtCore.Qt.MouseButton.LeftButton)
    assert not window.session.controller.armed and window.estop_button.engaged
    assert window.estop_button.text() == "STOPPED"
    for _ in range(5):  # and any number of taps more
        window.estop_button.click()
    assert not window.session.controller.armed


def test_rearm_needs_a_hold_not_a_tap(qtbot, window):
    window.estop_button.click()
    button = window.rearm_button
    for _ in range(3):  # taps and a double tap on RE-ARM do nothing
        qtbot.mouseClick(button, QtCore.Qt.MouseButton.LeftButton)
        assert not button.holding  # released: the hold is cancelled, nothing is pending
    assert not window.session.controller.armed
    qtbot.mousePress(button, QtCore.Qt.MouseButton.LeftButton)
    assert button.holding
    qtbot.mouseRelease(button, QtCore.Qt.MouseButton.LeftButton)  # let go early
    assert not button.holding and not window.session.controller.armed
    hold_to_rearm(qtbot, window)
    assert window.session.controller.armed and window.estop_button.text() == "STOP"


def test_escape_key_engages_the_estop(qtbot, window):
    window.activateWindow()
    qtbot.keyClick(window, QtCore.Qt.Key.Key_Escape)
    assert window.estop_button.engaged


def test_unknown_bridge_url_keeps_the_working_bridge(qtbot, window):
    before = window.session.bridge
    window.on_bridge_requested("bluetooth:arm")
    qtbot.waitUntil(lambda: window._bridge_status is not None and "bluetooth" in window._bridge_status.message,
                    timeout=3000)
    assert window.session.bridge is before and before.is_connected


@pytest.mark.parametrize("robot", ["umi_rtx", "delta"])
def test_any_profile_runs_in_the_window(qtbot, robot):
    w = shown_window(qtbot, robot)
    w.start()
    try:
        qtbot.waitUntil(lambda: w._state is not None and w._result is not None, timeout=5000)
        w._dirty = True
        w.redraw()
        assert (w.pose_panel is not None) == (robot == "umi_rtx")  # 6-DOF arms get the Pose tab
        assert not w.view_3d_button.isEnabled()  # offscreen: no GL context, the 2D twin stays
        if robot == "umi_rtx":
            from widgets.pose_panel import PoseTarget

            w.on_pose_target(PoseTarget((0.3, 0.2, 0.3), (0.0, 0.5, 0.3), 0.02))
            assert w.session.targeter.manual_rpy == pytest.approx((0.0, 0.5, 0.3))
            qtbot.waitUntil(lambda: w._goal is not None and w._goal.orientation_rpy is not None, timeout=3000)
    finally:
        w.stop()
