"""A switch user's presses without Qt: one held switch, a hold that stops (or re-arms), and key
releases that are only the X server's auto-repeat (core.motion.switch_presses)."""
from core.motion.switch_presses import KEY_REPEAT_GRACE_S, SwitchPresses, is_auto_repeat_pair

LONG_S = 1.5


def test_a_second_switch_pressed_while_one_is_held_is_ignored():
    p = SwitchPresses()
    assert p.press("key:Space", "next", 10.0, engaged=False)
    assert not p.press("key:Return", "confirm", 10.1, engaged=False)
    assert p.release("key:Return") is None  # not the held one
    held = p.release("key:Space")
    assert held.role == "next" and held.t == 10.0 and not held.fired and p.down is None


def test_a_hold_stops_once_and_a_hold_begun_stopped_re_arms():
    p = SwitchPresses()
    p.press("key:Space", "single", 0.0, engaged=False)
    assert p.hold(LONG_S - 0.01, LONG_S) is None
    assert p.hold(LONG_S, LONG_S) == "stop"
    assert p.hold(5.0, LONG_S) is None  # one hold, one action
    assert p.release("key:Space").fired
    p.press("key:Space", "single", 10.0, engaged=True)
    assert p.hold(10.0 + LONG_S, LONG_S) == "rearm"


def test_a_key_release_with_a_timestamp_waits_and_its_auto_repeat_press_cancels_it():
    p = SwitchPresses()
    p.press("key:Space", "next", 0.0, engaged=False)
    assert p.keep_release("key:Space", 0.7, stamp=700)
    assert not p.is_repeat_press("key:Space", 701)  # a millisecond later: a person, not the repeat
    assert p.is_repeat_press("key:Space", 700) and p.pending is None
    assert p.down is not None  # the key never came up
    assert p.due_release() is None


def test_a_pending_release_acts_when_its_grace_has_passed_as_released_when_it_came():
    p = SwitchPresses()
    p.press("key:Space", "next", 0.0, engaged=False)
    assert p.keep_release("key:Space", 1.0, stamp=1000)
    assert p.due_release(1.0 + KEY_REPEAT_GRACE_S / 2) is None
    pending = p.due_release(1.0 + KEY_REPEAT_GRACE_S)
    assert pending.name == "key:Space" and pending.t == 1.0 and p.pending is None


def test_a_hold_measured_while_a_release_is_pending_ends_at_the_release():
    p = SwitchPresses()
    p.press("key:Space", "single", 0.0, engaged=False)
    p.keep_release("key:Space", 1.0, stamp=1000)  # released at 1.0 s: short, even if the wait ends later
    assert p.hold(LONG_S + 1.0, LONG_S) is None


def test_synthetic_releases_and_other_keys_are_never_kept():
    p = SwitchPresses()
    assert not p.keep_release("key:Space", 0.0, stamp=500)  # nothing held
    p.press("key:Space", "next", 0.0, engaged=False)
    assert not p.keep_release("key:Space", 0.1, stamp=0)  # no timestamp: cannot be told apart
    assert not p.keep_release("key:Return", 0.1, stamp=100)
    assert not is_auto_repeat_pair(0, 0) and is_auto_repeat_pair(5, 5) and not is_auto_repeat_pair(5, 6)


def test_reset_forgets_the_held_switch_and_the_pending_release():
    p = SwitchPresses()
    p.press("key:Space", "next", 0.0, engaged=False)
    p.keep_release("key:Space", 0.2, stamp=200)
    p.reset()
    assert p.down is None and p.pending is None and p.due_release() is None
