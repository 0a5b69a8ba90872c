"""When the control step runs (ControlSchedule) and how far a step may move (ArmController)."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core.kinematics import build_kinematics, load_profile
from core.messages import Goal, TargetMode
from core.motion.control import ArmController
from core.motion.schedule import ControlSchedule, rate_cap_interval

PERIOD = 0.02
CAP = 0.01  # a 100 Hz bridge


def test_the_first_step_is_due_at_once_then_every_tick():
    s = ControlSchedule(PERIOD, CAP)
    assert s.due(5.0)
    s.ran(5.0)
    assert not s.due(5.019)
    assert s.next_due(5.001) == pytest.approx(5.02)


def test_a_new_goal_runs_at_once_when_the_rate_cap_allows():
    s = ControlSchedule(PERIOD, CAP)
    s.ran(0.0)
    s.goal_arrived(0.013)
    assert s.due(0.013)
    s.ran(0.013)
    assert s.event_steps == 1
    assert s.next_due(0.014) == pytest.approx(0.033)  # the tick restarts after the goal's step


def test_a_goal_just_after_a_step_waits_for_the_rate_cap_not_for_the_tick():
    s = ControlSchedule(PERIOD, CAP)
    s.ran(0.0)
    s.goal_arrived(0.004)
    assert not s.due(0.004)
    assert s.next_due(0.004) == pytest.approx(0.010)


def test_tick_driven_makes_a_new_goal_wait_for_the_tick_grid():
    s = ControlSchedule(PERIOD, CAP, event_driven=False)
    s.ran(0.0)
    s.goal_arrived(0.013)
    assert not s.due(0.013)
    assert s.next_due(0.013) == pytest.approx(0.02)
    s.ran(0.02)
    s.ran(0.04)
    assert s.event_steps == 0 and s.tick_steps == 3


def test_a_tick_just_before_an_expected_frame_moves_onto_the_frame():
    s = ControlSchedule(PERIOD, CAP)
    s.ran(0.0)
    # the tick (0.020) would make a frame at 0.024 wait until 0.030: the frame's step does its work
    assert s.next_due(0.001, next_goal_t=0.024) == pytest.approx(0.024)
    # a frame well after the tick does not delay it, nor does one before it
    assert s.next_due(0.001, next_goal_t=0.033) == pytest.approx(0.020)
    assert s.next_due(0.001, next_goal_t=0.015) == pytest.approx(0.020)
    # never by half a period or more, whatever the rate cap
    slow = ControlSchedule(PERIOD, PERIOD)
    slow.ran(0.0)
    assert slow.next_due(0.001, next_goal_t=0.0333) == pytest.approx(0.020)


@pytest.mark.parametrize("period, cap", [(0, 0), (-1, 0), (math.nan, 0), (0.02, 0.03), (0.02, -0.001)])
def test_bad_periods_and_caps_are_refused_with_their_range(period, cap):
    with pytest.raises(ValueError, match="period_s|min_interval_s"):
        ControlSchedule(period, cap)


def test_the_rate_cap_comes_from_the_bridge():
    class Bridge:
        max_command_hz = 50.0

    assert rate_cap_interval(Bridge(), PERIOD) == pytest.approx(0.02)
    Bridge.max_command_hz = 200.0
    assert rate_cap_interval(Bridge(), PERIOD) == pytest.approx(0.005)
    Bridge.max_command_hz = 0.0  # no cap
    assert rate_cap_interval(Bridge(), PERIOD) == 0.0
    assert rate_cap_interval(object(), PERIOD) == 0.0


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.floats(0.0, 0.05), st.booleans(), st.one_of(st.none(), st.floats(0.0, 0.05))),
                min_size=1, max_size=80),
       st.booleans())
def test_steps_are_never_closer_than_the_rate_cap_nor_further_than_a_tick_and_a_half(events, event_driven):
    """Random goals and frame hints: a loop that runs whenever the schedule says so."""
    s = ControlSchedule(PERIOD, CAP, event_driven)
    now, runs = 0.0, []
    for gap, goal, hint in events:
        target = now + gap
        while s.next_due(now, None if hint is None else now + hint) <= target:
            now = max(now, s.next_due(now, None if hint is None else now + hint))
            s.ran(now)
            runs.append(now)
        now = target
        if goal:
            s.goal_arrived(now)
            if s.due(now):
                s.ran(now)
                runs.append(now)
    gaps = np.diff(runs)
    assert (gaps >= CAP - 1e-9).all(), gaps.min()
    assert (gaps <= 1.5 * PERIOD + 1e-9).all(), gaps.max()


PROFILE = load_profile("desk_rrr")
KIN = build_kinematics(PROFILE)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(0.0, 0.06), st.floats(-0.25, 0.25), st.floats(0.05, 0.3), st.floats(0.0, 0.25)),
                min_size=2, max_size=40))
def test_steps_that_come_sooner_move_less_so_every_joint_keeps_its_speed_limit(steps):
    """Whatever the step times (events, ticks, stalls), no joint moves faster than its limit
    over any interval between two commands, counting at most one tick after a pause."""
    c = ArmController(PROFILE, KIN)
    speed = [math.radians(j.max_speed_deg_s) for j in PROFILE.joints]
    t, q_now, last = 0.0, PROFILE.q_home, None
    for k, (gap, x, y, z) in enumerate(steps):
        t += gap
        cmd = c.step(Goal(k + 1, t, (x, y, z), TargetMode.MANUAL), q_now, t)
        if last is not None:
            dt = min(cmd.t - last.t, c.period_s)
            for j, (a, b) in enumerate(zip(last.q, cmd.q)):
                assert abs(b - a) <= speed[j] * dt + 1e-9, (j, a, b, dt)
        last, q_now = cmd, cmd.q
