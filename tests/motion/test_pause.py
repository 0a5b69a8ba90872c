"""ArmController.pause: the arm holds its last command while a reason to hold remains."""
from core.kinematics import build_kinematics, load_profile
from core.messages import Goal, TargetMode
from core.motion.control import ArmController

PROFILE = load_profile("desk_rrr")


def goal(p, t):
    return Goal(seq=1, t=t, mode=TargetMode.MANUAL, base_p_target=p, valid=True)


def test_paused_controller_repeats_its_last_command_until_every_reason_is_gone():
    c = ArmController(PROFILE, build_kinematics(PROFILE))
    first = c.step(goal((0.0, 0.15, 0.10), 0.0), PROFILE.q_home, 0.0)
    c.pause("a dialog is open")
    c.pause("another dialog")
    held = c.step(goal((0.10, 0.10, 0.05), 0.02), first.q, 0.02)
    assert held.q == first.q and "paused: a dialog is open, another dialog" == c.note
    c.resume("a dialog is open")
    assert c.step(goal((0.10, 0.10, 0.05), 0.04), first.q, 0.04).q == first.q  # one reason left
    c.resume("another dialog")
    c.resume("never paused for this")  # harmless
    moved = c.step(goal((0.10, 0.10, 0.05), 0.06), first.q, 0.06)
    assert moved.q != first.q and not c.paused


def test_estop_wins_over_pause():
    c = ArmController(PROFILE, build_kinematics(PROFILE))
    c.step(goal((0.0, 0.15, 0.10), 0.0), PROFILE.q_home, 0.0)
    c.pause("a dialog is open")
    c.estop()
    assert c.step(goal((0.0, 0.15, 0.10), 0.02), PROFILE.q_home, 0.02) is None
