"""The physical STOP / RE-ARM rules (core.motion.estop_switches): a held, latched, stuck or bouncing
switch never re-arms; only a fresh, unbroken, full hold of a different switch does."""
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core.motion.estop_switches import REARM, REARM_HOLD_S, STOP, EStopSwitchLogic

STOPS = ("gpio:17", "key:F12")
REARMS = ("gamepad:BTN_EAST", "gpio:27")
HOLD = REARM_HOLD_S


def stopped_machine(t=0.0):
    """A machine whose arm was stopped by STOP switch gpio:17 (pressed and released by ``t``)."""
    m = EStopSwitchLogic(STOPS, REARMS)
    assert m.feed("gpio:17", True, t - 0.2) == STOP
    assert m.feed("gpio:17", False, t) is None
    return m


def test_every_press_of_a_stop_switch_stops_and_nothing_else():
    m = EStopSwitchLogic(STOPS, REARMS)
    assert m.armed
    assert m.feed("key:F12", True, 1.0) == STOP
    assert not m.armed
    assert m.feed("key:F12", False, 1.1) is None
    assert m.feed("key:F12", True, 1.2) == STOP  # again: stopping twice is stopping
    assert m.feed("gpio:17", True, 1.3) == STOP
    assert m.poll(10.0) is None and not m.armed


def test_a_fresh_rearm_press_held_the_full_hold_rearms_once():
    m = stopped_machine(1.0)
    assert m.feed("gpio:27", True, 2.0) is None
    assert m.poll(2.0 + HOLD - 0.001) is None
    assert m.hold("gpio:27", 2.5).fresh and m.hold("gpio:27", 2.5).held_s == pytest.approx(0.5)
    assert m.poll(2.0 + HOLD) == REARM
    assert m.armed
    assert m.poll(5.0) is None  # once


def test_a_held_stop_switch_blocks_every_rearm_like_a_latched_mushroom():
    m = EStopSwitchLogic(STOPS, REARMS)
    assert m.feed("gpio:17", True, 1.0) == STOP  # latched down
    m.feed("gpio:27", True, 2.0)
    assert m.poll(10.0) is None
    assert m.hold("gpio:27", 10.0).why_not == "stop_down"
    assert m.stop_switches_down() == ["gpio:17"]
    assert m.rearmed(11.0) == STOP  # the on-screen RE-ARM is refused too: stop again
    assert not m.armed
    m.feed("gpio:17", False, 12.0)  # unlatched, RE-ARM still held since 2.0: never
    assert m.poll(30.0) is None and m.hold("gpio:27", 30.0).why_not == "before_stop"
    m.feed("gpio:27", False, 31.0)
    m.feed("gpio:27", True, 32.0)  # released and pressed again: a fresh press
    assert m.poll(32.0 + HOLD) == REARM


def test_a_rearm_switch_already_held_when_the_arm_stopped_never_rearms():
    m = EStopSwitchLogic(STOPS, REARMS)
    m.feed("gpio:27", True, 1.0)  # held while armed (a foot resting on the pedal)
    assert m.poll(5.0) is None  # armed: nothing to do
    m.stopped(6.0)  # the on-screen STOP
    for t in (7.0, 60.0, 3600.0):
        assert m.poll(t) is None
    assert m.hold("gpio:27", 60.0).why_not == "before_stop"


def test_a_press_that_began_while_a_stop_switch_was_down_never_rearms():
    m = EStopSwitchLogic(STOPS, REARMS)
    m.feed("key:F12", True, 1.0)
    m.feed("gpio:27", True, 1.5)
    m.feed("key:F12", False, 2.0)
    assert m.poll(2.0 + 10 * HOLD) is None


def test_a_bounce_restarts_the_hold():
    m = stopped_machine(1.0)
    m.feed("gpio:27", True, 2.0)
    assert m.poll(2.9) is None
    m.feed("gpio:27", False, 2.9)  # bounce
    m.feed("gpio:27", True, 2.905)
    assert m.poll(3.5) is None  # 1.5 s since the first press, 0.6 s since the bounce
    assert m.poll(2.905 + HOLD - 0.001) is None
    assert m.poll(2.905 + HOLD + 1e-9) == REARM


def test_any_stop_during_a_hold_cancels_it():
    m = stopped_machine(1.0)
    m.feed("gpio:27", True, 2.0)
    m.stopped(2.5)  # STOP tapped again on the screen (or Esc) during the hold
    assert m.poll(10.0) is None
    m2 = stopped_machine(1.0)
    m2.feed("gpio:27", True, 2.0)
    m2.feed("key:F12", True, 2.5)
    m2.feed("key:F12", False, 2.6)
    assert m2.poll(10.0) is None


def test_a_switch_found_down_stops_or_never_rearms():
    m = stopped_machine(1.0)
    m.found_down("gamepad:BTN_EAST", 2.0)  # the pedal was down when the gamepad appeared
    assert m.poll(100.0) is None and m.hold("gamepad:BTN_EAST", 100.0).why_not == "before_stop"
    m.feed("gamepad:BTN_EAST", False, 101.0)
    m.feed("gamepad:BTN_EAST", True, 102.0)
    assert m.poll(102.0 + HOLD) == REARM
    assert m.found_down("gpio:17", 103.0) == STOP  # a latched STOP found at start-up
    assert not m.armed and m.stop_switches_down() == ["gpio:17"]


def test_a_press_reported_twice_without_a_release_never_rearms():
    m = stopped_machine(1.0)
    m.feed("gpio:27", True, 2.0)
    m.feed("gpio:27", True, 2.5)  # a release was lost: was it held all along? Not known
    assert m.poll(10.0) is None


def test_a_press_stamped_before_the_stop_is_older_than_the_stop():
    m = EStopSwitchLogic(STOPS, REARMS)
    m.stopped(5.0)
    m.feed("gpio:27", True, 4.99)  # a device thread stamped it just before the GUI stopped the arm
    assert m.poll(10.0) is None
    m.feed("gpio:27", True, 5.0)  # exactly at the stop is not after it either
    assert m.poll(10.0) is None


def test_unknown_switches_do_nothing_and_the_roles_must_differ():
    m = stopped_machine(1.0)
    assert m.feed("key:A", True, 2.0) is None and m.poll(10.0) is None
    with pytest.raises(ValueError, match="both a STOP and a RE-ARM switch"):
        EStopSwitchLogic(["gpio:17"], ["gpio:17"])
    for bad in (0, -1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="hold"):
            EStopSwitchLogic(STOPS, REARMS, hold_s=bad)


def test_a_machine_made_stopped_rearms_only_after_a_noted_stop():
    m = EStopSwitchLogic(STOPS, REARMS, armed=False)
    m.stopped(0.0)  # what the window does when it starts stopped
    m.feed("gpio:27", True, 0.5)
    assert m.poll(0.5 + HOLD) == REARM


# -- random sequences against an oracle that reads the whole history ----------------------------------

NAMES = STOPS + REARMS * 2 + ("key:A",)  # RE-ARM switches twice as often
KINDS = ("press",) * 4 + ("release",) * 4 + ("found", "stopped", "rearmed") + ("poll",) * 3  # weights


def oracle_rearms(history, armed, t_now, hold=HOLD):
    """Whether a re-arm is due at ``t_now``, judged from the whole ``history`` ((kind, name, t)
    in order): the arm stopped, no STOP switch down, and a RE-ARM switch whose last event is a
    press edge (after a release or nothing) that began strictly after every STOP input and was
    held since, for the whole hold."""
    if armed:
        return False
    stop_inputs = []
    down = {}
    for kind, name, t in history:
        if kind in ("stopped", "stop_out"):
            stop_inputs.append(t)
        elif name in STOPS:
            if kind in ("press", "found"):
                stop_inputs.append(t)
                down[name] = True
            elif kind == "release" and down.get(name):
                stop_inputs.append(t)
                down[name] = False
    if any(down.get(n) for n in STOPS):
        return False
    for r in REARMS:
        events = [(kind, t) for kind, name, t in history if name == r]
        if not events or events[-1][0] != "press":
            continue
        if len(events) > 1 and events[-2][0] != "release":
            continue  # after a found-down or a second press: not an edge we can trust
        t_press = events[-1][1]
        if all(s < t_press for s in stop_inputs) and t_now - t_press >= hold:
            return True
    return False


# time steps: simultaneous, a bounce (0.5–30 ms), a hold's length exactly, or anything up to 1.6 s
step = st.tuples(st.sampled_from(KINDS), st.sampled_from(NAMES),
                 st.one_of(st.just(0.0), st.floats(0.0005, 0.03), st.just(HOLD), st.floats(0.03, 1.6)))


@settings(max_examples=1500, deadline=None)
@given(st.lists(step, min_size=1, max_size=40), st.booleans())
def test_random_presses_releases_bounces_and_stops_rearm_exactly_when_the_oracle_says(steps, armed_at_start):
    m = EStopSwitchLogic(STOPS, REARMS, armed=armed_at_start)
    if not armed_at_start:
        m.stopped(0.0)
    armed = armed_at_start
    history = [] if armed_at_start else [("stopped", "", 0.0)]
    t = 0.0
    for kind, name, dt in steps:
        t += dt
        if kind == "stopped":
            m.stopped(t)
            armed = False
            history.append(("stopped", "", t))
        elif kind == "rearmed":
            stop_down = any(m.is_down(n) for n in STOPS)
            out = m.rearmed(t)
            assert (out == STOP) == stop_down  # a latched STOP refuses the on-screen RE-ARM too
            if out == STOP:
                history.append(("stop_out", "", t))
            armed = out is None
        elif kind in ("press", "release", "found"):
            out = m.feed(name, kind == "press", t) if kind != "found" else m.found_down(name, t)
            if name in STOPS and kind in ("press", "found"):
                assert out == STOP
                armed = False
            else:
                assert out is None
            history.append((kind, name, t))
        due = oracle_rearms(history, armed, t)
        got = m.poll(t)
        assert (got == REARM) == due, (history, t)
        if got == REARM:
            armed = True
        assert m.armed == armed


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(0.0005, 2 * HOLD), min_size=1, max_size=12), st.floats(0.0005, 0.02))
def test_a_bouncing_rearm_switch_rearms_only_a_full_hold_after_its_last_press(gaps, bounce_s):
    m = stopped_machine(0.0)
    t = 0.1
    m.feed("gpio:27", True, t)
    last_press = t
    for gap in gaps:  # held for ``gap``, then a bounce (up for bounce_s, down again)
        if m.poll(t + gap) == REARM:
            assert gap >= HOLD and t + gap - last_press >= HOLD
            return
        t += gap
        m.feed("gpio:27", False, t)
        t += bounce_s
        m.feed("gpio:27", True, t)
        last_press = t
        assert m.poll(t) is None
    assert m.poll(last_press + HOLD - 1e-6) is None
    assert m.poll(last_press + HOLD + 1e-9) == REARM  # (+1 ns: float rounding)
