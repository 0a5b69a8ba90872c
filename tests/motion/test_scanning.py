"""The three input modes as state machines: taps, two switches, one switch timed."""
import pytest

from core.motion.scanning import (OneSwitchScanner, TouchSelector, TwoSwitchScanner, one_switch_cost,
                                  reading_order)

BOXES = [(100, 100, 40, 40), (200, 100, 40, 40), (100, 200, 40, 40)]


def test_a_tap_selects_the_box_it_falls_in_and_taps_outside_are_ignored():
    sel = TouchSelector(BOXES)
    assert sel.tap(210, 120, 1.0).index == 1
    ev = sel.tap(5, 5, 2.0)
    assert ev.kind == "ignored" and ev.index is None


def test_two_switches_move_the_highlight_and_confirm():
    sc = TwoSwitchScanner(3)
    assert sc.next(0.5).index == 1
    assert sc.next(1.0).index == 2
    assert sc.next(1.5).index == 0  # wraps
    sc.next(2.0)
    ev = sc.confirm(2.5)
    assert ev.kind == "select" and ev.index == 1 and sc.presses == 5


def test_one_switch_highlight_advances_by_itself_and_a_short_press_confirms():
    sc = OneSwitchScanner(9, period_s=1.0)
    sc.start(0.0)
    steps = sc.tick(6.4)
    assert [e.index for e in steps] == [1, 2, 3, 4, 5, 6]
    sc.press(6.4)
    events = sc.release(6.55)
    assert events[-1].kind == "select" and events[-1].index == 6  # the 7th box
    assert sc.presses == 1


def test_one_switch_long_press_stops_and_cancels():
    sc = OneSwitchScanner(9, period_s=1.0, long_press_s=1.5)
    sc.start(0.0)
    sc.press(2.2)
    assert [e.kind for e in sc.tick(3.8)] == ["stop"]
    assert not any(e.kind == "select" for e in sc.release(4.0))
    assert sc.highlight == 2  # the highlight stood still while the switch was held


def test_one_switch_period_must_be_adjustable_within_half_to_five_seconds():
    with pytest.raises(ValueError, match="0.5"):
        OneSwitchScanner(3, period_s=0.2)
    OneSwitchScanner(3, period_s=5.0)


def test_button_seven_costs_one_press_and_six_periods_plus_reaction():
    cost = one_switch_cost(6, 1.0, reaction_s=0.4, press_s=0.15)
    assert cost == {"presses": 1, "seconds": pytest.approx(6.55)}


def test_reading_order_is_rows_then_columns():
    boxes = [(200, 205, 40, 40), (100, 100, 40, 40), (100, 202, 40, 40), (200, 98, 40, 40)]
    assert reading_order(boxes) == [1, 3, 2, 0]
