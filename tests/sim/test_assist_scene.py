"""The assistive view's simulated panel answers the arm: a pushed button goes down as far as the
tip goes (its travel at most), half its travel registers the call and lights its ring for a while;
a tip beside the buttons or above them does nothing."""
import numpy as np

from core.sim.assist_scene import LIT_S, AssistPanelScene
from core.sim.scenarios import Panel


def test_a_push_goes_down_registers_once_and_lights_for_a_while():
    scene = AssistPanelScene(Panel(-0.03, 0.13, yaw=0.05))
    p = scene.base_panel
    top = np.array(p.button_centre(7))
    scene.feel(top + [0, 0, 0.002], 0.0)  # above: nothing
    assert scene.panel(0.0).pressed == () and scene.calls == []
    scene.feel(top - [0, 0, 0.001], 0.1)  # a third of the travel: down, not registered
    assert scene.panel(0.1).pressed == (7,) and scene.calls == []
    scene.feel(top + [0.003, 0, -0.010], 0.2)  # past the travel: held at the bottom, registered
    assert scene.pressed_depth_m == p.press_depth_m and scene.calls == [(0.2, 7)]
    assert scene.panel(0.2).lit == (7,)
    scene.feel(top - [0, 0, 0.003], 0.3)  # still down: not registered twice
    assert scene.calls == [(0.2, 7)]
    scene.feel(top + [0, 0, 0.05], 0.4)  # back up
    assert scene.panel(0.4).pressed == () and scene.panel(0.4).lit == (7,)
    assert scene.panel(0.2 + LIT_S + 0.01).lit == ()


def test_a_tip_beside_every_button_presses_nothing():
    scene = AssistPanelScene(Panel(-0.03, 0.13))
    p = scene.base_panel
    a, b = np.array(p.button_centre(5)), np.array(p.button_centre(6))
    scene.feel((a + b) / 2 - [0, 0, 0.002], 0.0)  # between 5 and 6, at button height
    assert scene.panel(0.0).pressed == () and scene.calls == []


def test_the_passing_hand_comes_and_goes():
    scene = AssistPanelScene(Panel(-0.03, 0.13), passing_hand=True)
    seen = [bool(scene.state(t).hands) for t in np.arange(0.0, 30.0, 0.5)]
    assert any(seen) and not all(seen)
    assert AssistPanelScene(Panel(-0.03, 0.13)).state(8.0).hands == ()
