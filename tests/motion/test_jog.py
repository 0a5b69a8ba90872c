"""Jogging (core.motion.jog.Jogger): steps, clipping to the workspace and the joint limits, held
inputs that move continuously and stop on release, and the goals it makes. No Qt."""
from __future__ import annotations

import math

import pytest

from core.kinematics import build_kinematics, load_profile
from core.messages import TargetMode
from core.motion.control import ArmController
from core.motion.jog import JogParams, Jogger, JogSpace, joint_display
from core.motion.safety import is_within_limits, workspace_violation

PROFILE = load_profile("desk_rrr")
KIN = build_kinematics(PROFILE)
HOME_P = tuple(float(v) for v in KIN.fk(PROFILE.q_home))


def close(a, b, tol=1e-9):
    assert len(a) == len(b) and all(abs(x - y) <= tol for x, y in zip(a, b)), f"{a} != {b} (±{tol})"


def cartesian_jogger(**params) -> Jogger:
    j = Jogger(PROFILE, KIN, JogParams(**params))
    j.start_cartesian(HOME_P)
    return j


def test_a_cartesian_step_moves_one_axis_by_the_chosen_step():
    j = cartesian_jogger()
    for index, step_m in enumerate((0.001, 0.005, 0.020)):
        j.set_step_index(index)
        before = j.base_p_target
        after = j.step_cartesian(1, +1)
        close(after, (before[0], before[1] + step_m, before[2]))
        assert j.note == ""
        close(j.step_cartesian(1, -1), before)


def test_step_sizes_stay_within_the_list_and_say_what_they_are():
    j = cartesian_jogger()
    assert j.change_step(+1) == 2 and j.change_step(+1) == 2
    assert j.step_label() == "20 mm / 15°"
    assert j.change_step(-5) == 0 and j.cartesian_step_m == 0.001


def test_jogging_down_stops_at_the_desk_margin():
    j = cartesian_jogger()
    j.set_step_index(2)
    for _ in range(40):
        p = j.step_cartesian(2, -1)
    assert p[2] == pytest.approx(PROFILE.workspace.desk_margin_m)
    assert "desk margin" in j.note


def test_jogging_out_stops_at_the_edge_of_the_reach():
    j = cartesian_jogger()
    j.set_step_index(2)
    for _ in range(30):
        p = j.step_cartesian(0, +1)
    reach = KIN.workspace_radius_range()[1]
    assert "out of reach" in j.note
    ik = KIN.ik(p, PROFILE.q_home)
    assert ik.error_m < 1e-3, "the clipped target is a point the arm reaches"
    assert p[0] <= reach + 1e-6
    further = j.step_cartesian(0, +1)
    assert math.dist(further, p) < 0.005 and KIN.ik(further, PROFILE.q_home).error_m < 1e-3, "it stays at the edge"


def test_a_joint_step_moves_one_joint_and_stops_at_its_limit():
    j = Jogger(PROFILE, KIN, space=JogSpace.JOINT)
    j.start_joints(PROFILE.q_home)
    q = j.step_joint_target(0, +1)
    assert q[0] == pytest.approx(PROFILE.q_home[0] + math.radians(5))
    close(q[1:], PROFILE.q_home[1:])
    for _ in range(100):
        q = j.step_joint_target(0, +1)
    assert q[0] == pytest.approx(PROFILE.joints[0].q_max)
    assert "at its limit" in j.note
    for _ in range(100):
        q = j.step_joint_target(0, -1)
    assert q[0] == pytest.approx(PROFILE.joints[0].q_min)
    assert is_within_limits(q, PROFILE)


def test_a_joint_step_into_the_desk_is_refused_and_named():
    j = Jogger(PROFILE, KIN, space=JogSpace.JOINT)
    j.start_joints(PROFILE.q_home)
    j.set_step_index(2)
    refused = False
    for _ in range(30):  # the shoulder tips the arm forward, the tool down towards the desk
        before = j.q_target
        q = j.step_joint_target(1, -1)
        assert workspace_violation(q, PROFILE, KIN) == ""
        if "joint step refused" in j.note:
            refused = True
            assert q == before
            break
    assert refused, "the forearm never met the desk"


def test_an_unknown_joint_or_a_zero_direction_is_an_error_that_says_so():
    j = Jogger(PROFILE, KIN, space=JogSpace.JOINT)
    j.start_joints(PROFILE.q_home)
    with pytest.raises(ValueError, match="joint 7 does not exist"):
        j.step_joint_target(7, +1)
    with pytest.raises(ValueError, match="must be \\+1 or -1"):
        j.step_joint_target(0, 0)
    with pytest.raises(RuntimeError, match="start_cartesian"):
        Jogger(PROFILE, KIN).step_cartesian(0, 1)


def test_a_tap_moves_one_step_and_nothing_more():
    j = cartesian_jogger()
    x0 = j.base_p_target[0]
    j.press(0, +1, 10.0)
    assert j.update(10.2) is None  # within the hold delay: no continuous motion
    j.release(0, 10.25)
    assert j.base_p_target[0] == pytest.approx(x0 + 0.005)
    assert j.update(12.0) is None and not j.holding


def test_a_held_key_moves_continuously_and_stops_on_release():
    j = cartesian_jogger(hold_delay_s=0.3, repeat_period_s=0.1)
    x0 = j.base_p_target[0]
    j.press(0, +1, 0.0)
    t = 0.0
    xs = []
    while t < 1.3 - 1e-9:
        t += 0.02
        j.update(t)
        xs.append(j.base_p_target[0])
    assert all(b >= a for a, b in zip(xs, xs[1:])), "moves one way only"
    # one step at the press, then 1.0 s at 5 mm / 0.1 s = 50 mm/s
    assert j.base_p_target[0] == pytest.approx(x0 + 0.005 + 0.050, abs=1e-9)
    stopped = j.release(0, 1.3)
    for later in (1.4, 2.0, 5.0):
        assert j.update(later) is None
    assert j.base_p_target == stopped


def test_a_held_key_never_goes_faster_than_the_cap_and_a_stalled_timer_never_jumps():
    j = cartesian_jogger(hold_delay_s=0.0, max_tool_speed_m_s=0.05)
    j.set_step_index(2)  # 20 mm per 0.1 s would be 200 mm/s: capped at 50 mm/s
    j.press(1, -1, 0.0)
    y = j.base_p_target[1]
    j.update(0.1)
    assert y - j.base_p_target[1] == pytest.approx(0.005, abs=1e-9)
    y = j.base_p_target[1]
    j.update(10.0)  # 9.9 s without an update (a stalled GUI) counts as max_dt_s
    assert y - j.base_p_target[1] == pytest.approx(0.05 * JogParams().max_dt_s, abs=1e-9)


def test_a_held_joint_moves_at_most_at_its_speed_limit():
    j = Jogger(PROFILE, KIN, JogParams(hold_delay_s=0.0), space=JogSpace.JOINT)
    j.start_joints(PROFILE.q_home)
    j.set_step_index(2)  # 15 deg per 0.1 s = 150 deg/s, under the 300 deg/s of desk_rrr
    j.press(0, +1, 0.0)
    q0 = j.q_target[0]
    j.update(0.1)
    assert j.q_target[0] - q0 == pytest.approx(math.radians(15.0))
    j.release(0, 0.1)


def test_switching_space_releases_what_is_held():
    j = cartesian_jogger(hold_delay_s=0.0)
    j.press(0, +1, 0.0)
    assert j.holding
    assert j.toggle_space() is JogSpace.JOINT
    assert not j.holding and j.channel_count == 3


def test_goals_carry_the_point_or_the_joint_target_and_the_controller_follows_them():
    j = cartesian_jogger()
    goal = j.goal(0.0)
    assert goal.mode is TargetMode.MANUAL and goal.joint_target is None
    close(goal.base_p_target, HOME_P)
    j.set_space(JogSpace.JOINT)
    j.start_joints(PROFILE.q_home)
    j.step_joint_target(0, +1)
    goal = j.goal(0.0)
    assert goal.joint_target == j.q_target
    close(goal.base_p_target, KIN.fk(j.q_target))
    controller = ArmController(PROFILE, KIN)
    cmd = None
    for i in range(20):
        cmd = controller.step(goal, PROFILE.q_home, i * 0.02)
    close(cmd.q, j.q_target)


def test_joint_display_names_units():
    assert joint_display(PROFILE, (0.0, math.pi / 2, -0.1)) == ["0.0°", "90.0°", "-5.7°"]


def test_the_jogger_drives_teleop_mode_as_a_teleop_source():
    """The teleop framework (``Targeter.set_teleop``) takes the jogger like a hand: a held key
    moves TELEOP's goal with the targeter's clock, a release stops it."""
    from core.clock import SimClock
    from core.motion.jog import JogTeleopSource
    from core.motion.targeting import Targeter

    clock = SimClock()
    targeter = Targeter(clock, mode=TargetMode.TELEOP)
    source = JogTeleopSource(Jogger(PROFILE, KIN, JogParams(hold_delay_s=0.0)), start_base_p=HOME_P)
    targeter.set_teleop(source)
    goal = targeter.update(None)
    assert goal.valid and goal.mode is TargetMode.TELEOP
    close(goal.base_p_target, HOME_P)
    source.press(2, -1, clock.now())  # z down: one step at once, then 50 mm/s
    for _ in range(10):  # 0.2 s of control ticks
        clock.advance(0.02)
        goal = targeter.update(None)
    assert goal.base_p_target[2] == pytest.approx(HOME_P[2] - 0.005 - 0.010, abs=1e-9)
    assert "moving z−" in goal.note
    source.release(2, clock.now())
    clock.advance(1.0)
    stopped = targeter.update(None)
    assert stopped.base_p_target == goal.base_p_target and "holding" in stopped.note
    assert targeter.teleop_status().state == "following"
    source.jogger.set_space(JogSpace.JOINT)
    assert not targeter.update(None).valid, "joint space has no point to give: TELEOP holds"


def test_a_gamepad_jogs_through_the_same_jogger_with_a_fake_device():
    """python-evdev-like events from a fake device: the D-pad held moves x on and stops on release,
    the shoulder buttons move z, X/Y change the step, Select switches to joints."""
    from core.motion.jog import (ABS_HAT0X, ABS_HAT0Y, BTN_NORTH, BTN_SELECT, BTN_TL, BTN_TR, EV_ABS, EV_KEY,
                                 GamepadJog)

    j = cartesian_jogger(hold_delay_s=0.0)
    pad = GamepadJog(j)
    p0 = j.base_p_target
    pad.feed(EV_ABS, ABS_HAT0X, 1, 0.0)  # D-pad right, held 0.1 s
    j.update(0.1)
    pad.feed(EV_ABS, ABS_HAT0X, 0, 0.1)
    assert j.base_p_target[0] == pytest.approx(p0[0] + 0.005 + 0.005) and not j.holding
    pad.feed(EV_ABS, ABS_HAT0Y, -1, 0.2)  # D-pad up: +y
    pad.feed(EV_ABS, ABS_HAT0Y, 0, 0.2)
    assert j.base_p_target[1] == pytest.approx(p0[1] + 0.005)
    pad.feed(EV_KEY, BTN_NORTH, 1, 0.3)
    pad.feed(EV_KEY, BTN_NORTH, 0, 0.3)
    assert j.cartesian_step_m == 0.020
    pad.feed(EV_KEY, BTN_TL, 1, 0.4)
    pad.feed(EV_KEY, BTN_TL, 0, 0.4)
    assert j.base_p_target[2] == pytest.approx(p0[2] - 0.020)
    pad.feed(EV_KEY, BTN_SELECT, 1, 0.5)
    assert j.space is JogSpace.JOINT
    j.start_joints(PROFILE.q_home)
    pad.feed(EV_KEY, BTN_TR, 1, 0.6)  # next joint
    pad.feed(EV_ABS, ABS_HAT0X, -1, 0.6)
    pad.feed(EV_ABS, ABS_HAT0X, 0, 0.6)
    assert j.q_target[1] == pytest.approx(PROFILE.q_home[1] - math.radians(15)) and not j.holding
