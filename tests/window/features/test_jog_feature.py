"""The jog feature on its own (app/features/jog.py): the Jog tab's ± buttons and the jog keys move
the session's MANUAL target; nothing jogs while the arm is stopped; a held button moves on until
it is let go. A real session, the JogPanel shown, no MainWindow."""
from types import SimpleNamespace

import pytest
from PySide6 import QtCore

from app.features.jog import JogFeature
from core.messages import TargetMode
from feature_rig import TIMEOUT_MS, show_page

LEFT = QtCore.Qt.MouseButton.LeftButton


@pytest.fixture
def jog(qtbot, session):
    t = session.targeter
    calls = SimpleNamespace(modes=[], shown=[], inputs=[])

    def set_mode(mode):
        calls.modes.append(mode)
        t.set_mode(TargetMode(mode))

    target = SimpleNamespace(set_mode=set_mode, set_manual_target=t.set_manual_target,
                             show_manual_target=calls.shown.append, set_pose=None)
    feature = JogFeature(session, target, lambda: calls.inputs.append(True), lambda: None, lambda: None)
    feature.calls = calls
    host = show_page(qtbot, feature.page)
    feature.window = host  # the keys jog while the focus is in this window
    feature.install()
    yield feature
    feature.stop()
    feature.uninstall()


def test_a_tap_on_x_plus_moves_the_manual_target_one_step_and_chooses_manual_mode(qtbot, jog, session):
    t = session.targeter
    t.set_mode(TargetMode.FOLLOW)
    start = tuple(t.manual_target)
    plus_x = jog.jog_panel.plus_buttons[0]
    qtbot.mousePress(plus_x, LEFT)
    qtbot.mouseRelease(plus_x, LEFT)
    step_m = jog.jogger.cartesian_step_m
    assert t.mode is TargetMode.MANUAL and jog.calls.modes == ["manual"]
    # out of Follow mode the jog starts at the tool of the arm's start pose, one step along x
    moved = tuple(t.manual_target)
    assert moved != start and jog.calls.shown[-1] == moved
    qtbot.mousePress(plus_x, LEFT)
    qtbot.mouseRelease(plus_x, LEFT)
    assert t.manual_target[0] == pytest.approx(moved[0] + step_m, abs=1e-6)
    assert t.manual_target[1:] == pytest.approx(moved[1:], abs=1e-6)
    assert not jog.timer.isActive() and not jog.jogger.holding


def test_a_held_button_moves_on_with_the_timer_until_it_is_let_go(qtbot, jog, session):
    t = session.targeter
    t.set_mode(TargetMode.MANUAL)
    plus_y = jog.jog_panel.plus_buttons[1]
    qtbot.mousePress(plus_y, LEFT)
    first = tuple(t.manual_target)
    assert jog.jogger.holding and jog.timer.isActive()
    qtbot.waitUntil(lambda: t.manual_target[1] > first[1] + 1e-4, timeout=TIMEOUT_MS)  # past the hold delay
    qtbot.mouseRelease(plus_y, LEFT)
    assert not jog.jogger.holding and not jog.timer.isActive()
    stopped = tuple(t.manual_target)
    jog.tick()  # a late tick changes nothing
    assert tuple(t.manual_target) == stopped


def test_the_arrow_keys_jog_anywhere_in_the_window(qtbot, jog, session):
    t = session.targeter
    t.set_mode(TargetMode.MANUAL)
    before = tuple(t.manual_target)
    jog.jog_panel.plus_buttons[0].setFocus()
    qtbot.keyPress(jog.jog_panel.plus_buttons[0], QtCore.Qt.Key.Key_Up)
    qtbot.keyRelease(jog.jog_panel.plus_buttons[0], QtCore.Qt.Key.Key_Up)
    assert t.manual_target[1] == pytest.approx(before[1] + jog.jogger.cartesian_step_m, abs=1e-6)
    qtbot.keyClick(jog.jog_panel.plus_buttons[0], QtCore.Qt.Key.Key_BracketRight)  # a bigger step
    assert jog.jogger.step_index == 2 and jog.jog_panel.step_index == 2


def test_nothing_jogs_while_the_arm_is_stopped_and_the_panel_says_why(qtbot, jog, session):
    t = session.targeter
    t.set_mode(TargetMode.MANUAL)
    before = tuple(t.manual_target)
    session.controller.estop()
    try:
        plus_x = jog.jog_panel.plus_buttons[0]
        qtbot.mousePress(plus_x, LEFT)
        qtbot.mouseRelease(plus_x, LEFT)
        assert tuple(t.manual_target) == before and not jog.timer.isActive()
        assert "hold RE-ARM" in jog.jog_panel.note_label.text()
    finally:
        session.controller.rearm()


def test_joint_space_moves_a_joint_goal_and_the_manual_target_follows_the_tool(qtbot, jog, session):
    t, c = session.targeter, session.controller
    t.set_mode(TargetMode.MANUAL)
    qtbot.mouseClick(jog.jog_panel.space_buttons["joint"], LEFT)
    assert jog.jogger.space.value == "joint"
    plus = jog.jog_panel.plus_buttons[0]
    qtbot.mousePress(plus, LEFT)
    qtbot.mouseRelease(plus, LEFT)
    assert c.joint_jog is not None
    assert tuple(t.manual_target) == pytest.approx(tuple(session.kinematics.fk(c.joint_jog)), abs=1e-6)
    qtbot.mouseClick(jog.jog_panel.space_buttons["cartesian"], LEFT)  # back: from where the joints put the tool
    assert c.joint_jog is None and jog.jogger.space.value == "cartesian"
