"""Jogging in the window: the Jog tab's ± buttons and the keys (arrows, Page Up/Down, [ ], J,
1–9) drive the arm through the targeter (Cartesian) or joint goals, on the simulated desk with
the workers running (pytest-qt, offscreen). Waits are on the window's GUI-thread state."""
from __future__ import annotations

import math

import pytest
from PySide6 import QtCore, QtWidgets

from app.gui import MainWindow
from core.messages import TargetMode
from core.session import DeskSession, SessionOptions
from widgets._style import TOUCH_PX
from widgets.jog_panel import CARTESIAN, JOINT, JogPanel, is_text_field, jog_key_action

Key = QtCore.Qt.Key
STEP_M = 0.005  # the default step


@pytest.fixture
def window(qtbot):
    session = DeskSession.create(SessionOptions(camera="sim", scenario="static", robot="desk_rrr"))
    w = MainWindow(session)
    qtbot.addWidget(w)
    w.resize(800, 480)
    w.show()
    w.start()
    w.target_panel.set_mode(TargetMode.MANUAL.value)  # the session starts following marker 23
    w.on_mode_changed(TargetMode.MANUAL.value)
    qtbot.waitUntil(lambda: at_rest(w), timeout=5000)  # tests start from an arm that stands still
    yield w
    w.stop()
    for worker in (w.workers.perception, w.workers.control, w.workers.bridge):
        assert worker.isFinished() or not worker.isRunning()


def at_rest(w) -> bool:
    """The arm has reached what it aims at (the manual target, or the followed marker)."""
    cmd = w._command
    if cmd is None or cmd.base_p_target is None:
        return False
    aim = w.session.targeter.manual_target if w.session.targeter.mode is TargetMode.MANUAL else cmd.base_p_target
    return math.dist(w.session.kinematics.fk(cmd.q), aim) < 1e-6 and math.dist(cmd.base_p_target, aim) < 1e-6


def tap(qtbot, w, key):
    """A key pressed and let go where the focus is (the window when nothing has it)."""
    target = QtWidgets.QApplication.focusWidget() or w
    qtbot.keyPress(target, key)
    qtbot.keyRelease(target, key)


def command_near(qtbot, w, q_or_p, joints: bool, tol=1e-6, timeout=3000):
    """Wait until a command reaches joints ``q`` (joints=True) or aims at point ``p``."""
    def ok():
        cmd = w._command
        if cmd is None:
            return False
        have = cmd.q if joints else cmd.base_p_target
        return have is not None and all(abs(a - b) <= tol for a, b in zip(have, q_or_p))
    qtbot.waitUntil(ok, timeout=timeout)


def test_arrow_and_page_keys_jog_the_manual_target_and_the_arm_follows(qtbot, window):
    s = window.session
    s.targeter.set_mode(TargetMode.FOLLOW)  # jogging takes over from another mode, starting at the tool
    window.target_panel.set_mode(TargetMode.FOLLOW.value)
    qtbot.waitUntil(lambda: at_rest(window) and window._goal.mode is TargetMode.FOLLOW, timeout=5000)
    tool = tuple(s.kinematics.fk(window._command.q))
    tap(qtbot, window, Key.Key_Right)
    assert s.targeter.mode is TargetMode.MANUAL and window.target_panel.mode == "manual"
    p = s.targeter.manual_target
    assert p[0] == pytest.approx(tool[0] + STEP_M, abs=2e-4) and p[1] == pytest.approx(tool[1], abs=2e-4)
    tap(qtbot, window, Key.Key_PageDown)
    tap(qtbot, window, Key.Key_Up)
    q = s.targeter.manual_target
    assert q == pytest.approx((p[0], p[1] + STEP_M, p[2] - STEP_M))
    command_near(qtbot, window, q, joints=False)
    tap(qtbot, window, Key.Key_BracketRight)  # a bigger step: 20 mm
    assert window.jog_panel.step_index == 2
    tap(qtbot, window, Key.Key_Left)
    assert s.targeter.manual_target[0] == pytest.approx(q[0] - 0.020)
    assert not window.jogger.holding


def test_joint_keys_pick_a_joint_and_jog_it_with_joint_goals(qtbot, window):
    s = window.session
    q0 = window._command.q
    tap(qtbot, window, Key.Key_J)
    assert window.jog_panel.space == JOINT and len(window.jog_panel.plus_buttons) == 3
    tap(qtbot, window, Key.Key_2)
    assert window.jog_panel.selected_joint == 1
    tap(qtbot, window, Key.Key_Left)
    jog = s.controller.joint_jog
    assert jog is not None and jog[1] == pytest.approx(q0[1] - math.radians(5), abs=1e-9)
    assert jog[0] == pytest.approx(q0[0]) and jog[2] == pytest.approx(q0[2])
    command_near(qtbot, window, jog, joints=True)
    assert "°" in window.jog_panel.value_labels[1].text()
    tap(qtbot, window, Key.Key_J)  # back to x/y/z: the Cartesian target continues from the joints' tool point
    assert s.controller.joint_jog is None
    assert s.targeter.manual_target == pytest.approx(tuple(s.kinematics.fk(jog)), abs=1e-6)


def test_a_held_key_keeps_moving_and_stops_on_release(qtbot, window):
    s = window.session
    tap(qtbot, window, Key.Key_Down)  # start from the manual target
    y0 = s.targeter.manual_target[1]
    qtbot.keyPress(window, Key.Key_Down)  # held: no release yet
    assert s.targeter.manual_target[1] == pytest.approx(y0 - STEP_M)
    assert window.jogger.holding and window._jog_timer.isActive()
    # past the hold delay the timer moves it on, a step every 0.1 s
    qtbot.waitUntil(lambda: s.targeter.manual_target[1] < y0 - 2 * STEP_M, timeout=5000)
    qtbot.keyRelease(window, Key.Key_Down)
    stopped = s.targeter.manual_target
    assert not window.jogger.holding and not window._jog_timer.isActive()
    window._jog_tick()  # a late tick changes nothing
    assert s.targeter.manual_target == stopped
    command_near(qtbot, window, stopped, joints=False)


def test_a_text_field_keeps_its_arrow_keys(qtbot, window):
    s = window.session
    spin = window.target_panel.axes["x"].spin
    window.activateWindow()
    spin.setFocus()
    qtbot.waitUntil(lambda: QtWidgets.QApplication.focusWidget() is not None
                    and is_text_field(QtWidgets.QApplication.focusWidget()), timeout=3000)
    edit = spin.lineEdit()
    edit.setCursorPosition(0)
    before = s.targeter.manual_target
    qtbot.keyPress(QtWidgets.QApplication.focusWidget(), Key.Key_Right)
    qtbot.keyRelease(QtWidgets.QApplication.focusWidget(), Key.Key_Right)
    assert edit.cursorPosition() == 1, "the cursor moved: the text field had the key"
    assert s.targeter.manual_target == before and not window.jogger.holding
    qtbot.keyPress(QtWidgets.QApplication.focusWidget(), Key.Key_J)
    assert window.jog_panel.space == CARTESIAN, "J typed in a text field does not switch jogging"


def test_the_plus_button_steps_on_a_tap_and_jogs_while_held(qtbot, window):
    s = window.session
    window.tabs.setCurrentIndex(window._jog_tab_index)
    plus = window.jog_panel.plus_buttons[2]  # z +
    assert plus.height() >= TOUCH_PX and plus.width() >= TOUCH_PX
    qtbot.mouseClick(window.jog_panel.minus_buttons[2], QtCore.Qt.MouseButton.LeftButton)
    z0 = s.targeter.manual_target[2]
    qtbot.mousePress(plus, QtCore.Qt.MouseButton.LeftButton)
    assert s.targeter.manual_target[2] == pytest.approx(z0 + STEP_M)
    qtbot.waitUntil(lambda: s.targeter.manual_target[2] > z0 + 2 * STEP_M, timeout=5000)
    qtbot.mouseRelease(plus, QtCore.Qt.MouseButton.LeftButton)
    assert not window.jogger.holding
    assert "target x" in window.jog_panel.readout.text()


def test_no_jogging_while_stopped(qtbot, window):
    s = window.session
    tap(qtbot, window, Key.Key_Escape)  # Esc stays STOP
    assert not s.controller.armed
    before = s.targeter.manual_target
    tap(qtbot, window, Key.Key_Right)
    assert s.targeter.manual_target == before
    assert "RE-ARM" in window.jog_panel.note_label.text()


@pytest.mark.parametrize("key, space, expected", [
    (Key.Key_Left, CARTESIAN, ("jog", 0, -1)), (Key.Key_Up, CARTESIAN, ("jog", 1, 1)),
    (Key.Key_PageUp, CARTESIAN, ("jog", 2, 1)), (Key.Key_BracketLeft, CARTESIAN, ("step", 0, -1)),
    (Key.Key_Plus, JOINT, ("step", 0, 1)), (Key.Key_J, JOINT, ("space", 0, 0)),
    (Key.Key_3, JOINT, ("joint", 2, 0)), (Key.Key_Up, JOINT, ("jog", 1, 1)),
    (Key.Key_9, JOINT, None), (Key.Key_3, CARTESIAN, None), (Key.Key_A, CARTESIAN, None),
])
def test_key_table(key, space, expected):
    action = jog_key_action(key, space, selected_joint=1, joint_count=3)
    assert (None if action is None else (action.kind, action.channel, action.direction)) == expected


def test_the_panel_rebuilds_its_rows_per_space_and_names_the_selected_joint(qtbot):
    panel = JogPanel()
    qtbot.addWidget(panel)
    panel.set_joints(["base", "shoulder", "elbow", "wrist"])
    with qtbot.waitSignal(panel.sigSpaceChanged) as sig:
        panel.space_buttons[JOINT].click()
    assert sig.args == [JOINT] and len(panel.plus_buttons) == 4
    panel.set_selected_joint(2)
    assert "elbow" in panel.name_labels[2].text() and "◀" in panel.name_labels[2].text()
    with qtbot.waitSignals([panel.sigPressed, panel.sigReleased]):
        qtbot.mouseClick(panel.minus_buttons[3], QtCore.Qt.MouseButton.LeftButton)
    panel.show_state((0.1, 0.0, 0.2), ["1.0°", "2.0°", "3.0°", "4.0°"], "shoulder at its limit")
    assert panel.value_labels[3].text() == "4.0°" and not panel.note_label.isHidden()


def test_a_six_joint_arm_jogs_from_the_pose_tab_and_keeps_the_joints_orientation(qtbot):
    """umi_rtx has a Pose tab: jogging sits below the pose (eight tabs do not fit 800 px); back
    from a joint jog the manual pose takes the orientation the joints gave the tool."""
    from widgets.pose_panel import pose_target_from_matrix

    session = DeskSession.create(SessionOptions(camera="sim", scenario="static", robot="umi_rtx"))
    w = MainWindow(session)
    qtbot.addWidget(w)
    w.resize(800, 480)
    w.show()
    w.start()
    try:
        qtbot.waitUntil(lambda: w._command is not None, timeout=5000)
        assert w.tabs.tabText(w._jog_tab_index) == "Pose"
        assert w.tabs.widget(w._jog_tab_index).widget().isAncestorOf(w.jog_panel)
        tap(qtbot, w, Key.Key_J)
        tap(qtbot, w, Key.Key_6)
        assert w.jog_panel.selected_joint == 5 and len(w.jog_panel.plus_buttons) == 6
        tap(qtbot, w, Key.Key_Right)
        jog = session.controller.joint_jog
        assert jog is not None
        command_near(qtbot, w, jog, joints=True)
        tap(qtbot, w, Key.Key_J)
        expected = pose_target_from_matrix(session.kinematics.fk_pose(jog))
        assert session.targeter.manual_rpy == pytest.approx(expected.rpy, abs=1e-9)
        assert session.targeter.manual_target == pytest.approx(expected.base_p, abs=1e-9)
    finally:
        w.stop()
