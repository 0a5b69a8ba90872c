"""Joint goals (``Goal.joint_target``, joint-space jogging) go through the same safety as solved
goals: joint limits, the per-tick speed limit, the desk and keep-out boxes, the e-stop. The
random test drives every profile with joint targets inside, outside and far outside the limits
(and NaN and inf) and checks every command."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.clock import SimClock
from core.kinematics import build_kinematics, load_profile
from core.kinematics.profile import KeepOutBox, WorkspaceSpec
from core.messages import Goal, TargetMode
from core.motion.control import ArmController
from core.motion.safety import clamp_to_limits, is_within_limits, workspace_violation
from core.motion.targeting import Targeter

NAMES = ("desk_rrr", "umi_rtx", "assistive_5dof", "delta")
BOXES = {  # one box per arm inside its reach, clear of home
    "desk_rrr": KeepOutBox("mug", (0.06, 0.06, 0.0), (0.12, 0.14, 0.09)),
    "umi_rtx": KeepOutBox("monitor", (0.2, 0.2, 0.0), (0.5, 0.3, 0.5)),
    "assistive_5dof": KeepOutBox("lamp", (0.15, 0.15, 0.0), (0.35, 0.3, 0.3)),
    "delta": KeepOutBox("part", (0.05, -0.05, 0.0), (0.12, 0.05, 0.06)),
}
PROFILES = {n: replace(p, workspace=WorkspaceSpec(0.005, (BOXES[n],)))
            for n, p in ((n, load_profile(n)) for n in NAMES)}
KINS = {n: build_kinematics(p) for n, p in PROFILES.items()}
RRR = PROFILES["desk_rrr"]
RRR_KIN = KINS["desk_rrr"]


def joint_goal(q, t=0.0, mode=TargetMode.MANUAL, valid=True) -> Goal:
    return Goal(1, t, (0.0, 0.0, 0.0), mode, valid=valid, joint_target=tuple(q))


def moving_points_above_margin(name, q) -> bool:
    """An independent desk check: every chain point that moved away from the desk origin's
    column (the mount is at the same place for every q) is above the margin."""
    p, k = PROFILES[name], KINS[name]
    margin = p.workspace.desk_margin_m
    mount = np.asarray(k.chain_points(p.q_home), dtype=float)
    pts = np.asarray(k.chain_points(q), dtype=float)
    for a, b in zip(pts, mount):
        if np.allclose(a, b, atol=1e-9) and a[2] < margin:  # a fixed point of the mount (e.g. the base on the desk)
            other = np.asarray(k.chain_points(p.q_min), dtype=float)
            if any(np.allclose(a, o, atol=1e-9) for o in other):
                continue
        if a[2] < margin - 1e-9:
            return False
    return True


def joint_value(lo, hi):
    span = hi - lo
    return st.one_of(
        st.floats(lo, hi),  # inside
        st.floats(lo - 2 * span, hi + 2 * span),  # around, often outside
        st.floats(-1e9, 1e9),  # far outside
        st.sampled_from([math.nan, math.inf, -math.inf]),
    )


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(name=st.sampled_from(NAMES), data=st.data())
def test_no_joint_target_ever_commands_outside_the_limits_or_the_workspace(name, data):
    p, k = PROFILES[name], KINS[name]
    start = data.draw(st.one_of(st.just(tuple(p.q_home)),
                                st.tuples(*(st.floats(lo, hi) for lo, hi in zip(p.q_min, p.q_max)))))
    start_safe = workspace_violation(start, p, k) == ""
    c = ArmController(p, k)
    q, t = start, 0.0
    for _ in range(data.draw(st.integers(1, 3))):
        target = data.draw(st.tuples(*(joint_value(lo, hi) for lo, hi in zip(p.q_min, p.q_max))))
        for _ in range(8):
            dt = data.draw(st.sampled_from([0.02, 0.02, 0.005, 0.0, 0.5]))
            t += dt
            before = c.last.q if c.last is not None else tuple(q)
            allowance = c.step_allowance(t)  # the speed limit × the time since the last command
            cmd = c.step(joint_goal(target, t), q, t)
            what = f"{name} from {start} to {target}"
            if cmd is None:  # a non-finite target before the first command: nothing to hold
                assert any(not math.isfinite(v) for v in target), what
                assert "not a finite number" in c.note
                continue
            assert all(math.isfinite(v) for v in cmd.q), what
            assert is_within_limits(cmd.q, p), f"{what}: {cmd.q} outside the limits"
            assert all(a <= m + 1e-12 for a, m in zip(allowance, c.max_step_rad))
            if all(math.isfinite(v) for v in target):
                for a, b, s in zip(before, cmd.q, allowance):
                    assert abs(b - a) <= s + 1e-9, f"{what}: a step of {abs(b - a)} rad > {s} rad"
            if start_safe:
                assert workspace_violation(cmd.q, p, k) == "", f"{what}: {cmd.q} breaks the workspace"
                assert moving_points_above_margin(name, cmd.q), f"{what}: a point of {cmd.q} under the desk"
            q = cmd.q


def test_a_joint_target_goes_there_without_ik():
    c = ArmController(RRR, RRR_KIN)
    target = (0.3, 1.2, -1.0)
    cmd = None
    for i in range(50):
        cmd = c.step(joint_goal(target, i * 0.02), RRR.q_home, i * 0.02)
    assert cmd.q == pytest.approx(target)
    assert cmd.reachable and c.note == "" and not cmd.clamped
    assert cmd.base_p_target == pytest.approx(tuple(RRR_KIN.fk(target)))


def test_a_joint_target_beyond_the_limits_stops_at_the_limit_and_says_so():
    c = ArmController(RRR, RRR_KIN)
    cmd = None
    for i in range(60):
        cmd = c.step(joint_goal((5.0, RRR.q_home[1], RRR.q_home[2]), i * 0.02), RRR.q_home, i * 0.02)
    assert cmd.q[0] == pytest.approx(RRR.joints[0].q_max)
    assert f"beyond the limits of {RRR.joints[0].name}" in c.note
    assert not cmd.reachable and cmd.clamped


def test_a_joint_target_through_the_desk_stops_at_the_desk():
    c = ArmController(RRR, RRR_KIN)
    cmd = None
    for i in range(80):  # the shoulder tipped all the way forward: the tool would go through the desk
        cmd = c.step(joint_goal((0.0, 0.0, -1.5), i * 0.02), RRR.q_home, i * 0.02)
    assert workspace_violation((0.0, 0.0, -1.5), RRR, RRR_KIN).startswith("below the desk")
    assert workspace_violation(cmd.q, RRR, RRR_KIN) == ""
    assert c.note.startswith("below the desk") and not cmd.reachable and cmd.reach_error_m > 0


@pytest.mark.parametrize("bad, says", [((math.nan, 0.0, 0.0), "base_yaw = nan is not a finite number"),
                                       ((0.0, 1.0), "has 2 values but profile 'desk_rrr' has 3 joints"),
                                       (("a", 0, 0), "is not 3 numbers")])
def test_a_bad_joint_target_holds_the_last_command_and_says_why(bad, says):
    c = ArmController(RRR, RRR_KIN)
    first = c.step(joint_goal(RRR.q_home), RRR.q_home, 0.0)
    held = c.step(joint_goal(bad, 0.02), RRR.q_home, 0.02)
    assert held.q == first.q
    assert says in c.note


def test_the_e_stop_and_a_pause_stop_joint_goals_too():
    c = ArmController(RRR, RRR_KIN)
    first = c.step(joint_goal(RRR.q_home), RRR.q_home, 0.0)
    c.pause("a dialog is open")
    assert c.step(joint_goal((1.0, 1.0, -1.0), 0.02), RRR.q_home, 0.02).q == first.q
    c.resume("a dialog is open")
    c.estop()
    assert c.step(joint_goal((1.0, 1.0, -1.0), 0.04), RRR.q_home, 0.04) is None
    c.rearm()
    assert c.step(joint_goal((1.0, 1.0, -1.0), 0.06), RRR.q_home, 0.06).q != first.q


def test_the_joint_jog_turns_manual_goals_into_joint_goals_until_the_user_takes_over():
    clock = SimClock()
    targeter = Targeter(clock, manual_target=(0.1, 0.0, 0.1))
    c = ArmController(RRR, RRR_KIN)
    jog = (0.2, 1.4, -1.2)
    c.set_joint_jog(jog, targeter.manual_target)
    cmd = None
    for i in range(40):
        cmd = c.step(targeter.update(None), RRR.q_home, i * 0.02)
    assert cmd.q == pytest.approx(jog) and c.joint_jog == jog
    targeter.set_manual_target((0.12, 0.0, 0.1))  # the user moves the Cartesian target: the jog ends
    c.step(targeter.update(None), RRR.q_home, 1.0)
    assert c.joint_jog is None
    c.set_joint_jog(jog, targeter.manual_target)
    targeter.set_mode(TargetMode.LISSAJOUS)  # another mode: the jog ends too
    c.step(targeter.update(None), RRR.q_home, 1.1)
    assert c.joint_jog is None
    with pytest.raises(ValueError, match="not a finite number"):
        c.set_joint_jog((math.inf, 0.0, 0.0))
    assert clamp_to_limits(cmd.q, RRR)[1] is False


def test_a_joint_jog_survives_the_step_between_a_new_jog_and_its_manual_target():
    """The window sets the jog, then the targeter's manual target to the jog's tool point; a control
    step in between still sees the previous point and must not end the jog."""
    clock = SimClock()
    targeter = Targeter(clock)
    c = ArmController(RRR, RRR_KIN)
    q1, q2 = (0.2, 1.4, -1.2), (0.25, 1.4, -1.2)
    p1, p2 = (tuple(float(v) for v in RRR_KIN.fk(q)) for q in (q1, q2))
    targeter.set_manual_target(p1)
    c.set_joint_jog(q1, p1)
    c.step(targeter.update(None), RRR.q_home, 0.0)
    c.set_joint_jog(q2, p2)
    c.step(targeter.update(None), RRR.q_home, 0.02)  # the targeter still says p1
    assert c.joint_jog == q2
    targeter.set_manual_target(p2)
    cmd = None
    for i in range(40):
        cmd = c.step(targeter.update(None), RRR.q_home, 0.04 + i * 0.02)
    assert c.joint_jog == q2 and cmd.q == pytest.approx(q2)
    c.set_joint_jog(q1, p1)  # a new jog: p1 and (until the targeter catches up) p2 count
    targeter.set_manual_target((0.0, 0.15, 0.1))  # the user's own target: the jog ends
    c.step(targeter.update(None), RRR.q_home, 2.0)
    assert c.joint_jog is None
