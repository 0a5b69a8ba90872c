"""Where a jog starts and what a jog panel reads (core.motion.jog.Jogger.begin / readout /
tool_point): the window's jog feature used to decide these itself. No Qt."""
from __future__ import annotations

import math

from core.kinematics import build_kinematics, load_profile
from core.motion.jog import Jogger, JogSpace, joint_display

PROFILE = load_profile("desk_rrr")
KIN = build_kinematics(PROFILE)
Q_ARM = tuple(float(v) + d for v, d in zip(PROFILE.q_home, (0.1, -0.1, 0.1)))  # the joints the arm is commanded to
Q_JOG = tuple(float(v) + d for v, d in zip(PROFILE.q_home, (0.2, -0.2, 0.2)))  # a joint jog's target


def close(a, b, tol=1e-9):
    assert len(a) == len(b) and all(abs(x - y) <= tol for x, y in zip(a, b)), f"{a} != {b} (±{tol})"


def test_a_cartesian_jog_in_manual_mode_starts_at_the_manual_target():
    j = Jogger(PROFILE, KIN)
    manual = tuple(float(v) for v in KIN.fk(PROFILE.q_home))
    close(j.begin(Q_ARM, manual_target=manual), manual)


def test_a_cartesian_jog_out_of_another_mode_starts_at_the_tool_not_at_an_old_target():
    j = Jogger(PROFILE, KIN)
    start = j.begin(Q_ARM, manual_target=None, joint_jog=Q_JOG)  # the joint jog counts only in MANUAL
    close(start, KIN.fk(Q_ARM), 1e-6)


def test_a_cartesian_jog_after_a_joint_jog_in_manual_mode_starts_at_the_joints_tool_point():
    j = Jogger(PROFILE, KIN)
    manual = (0.0, 0.2, 0.1)
    close(j.begin(Q_ARM, manual_target=manual, joint_jog=Q_JOG), KIN.fk(Q_JOG), 1e-6)


def test_a_joint_jog_starts_at_the_joint_jogs_target_in_manual_mode_else_at_the_arm():
    j = Jogger(PROFILE, KIN, space=JogSpace.JOINT)
    close(j.begin(Q_ARM, manual_target=(0.0, 0.2, 0.1), joint_jog=Q_JOG), Q_JOG)
    close(j.begin(Q_ARM, manual_target=None, joint_jog=Q_JOG), Q_ARM)
    close(j.begin(Q_ARM, manual_target=(0.0, 0.2, 0.1)), Q_ARM)


def test_the_tool_point_of_a_joint_target_is_plain_floats_in_robot_base():
    p = Jogger(PROFILE, KIN).tool_point(Q_JOG)
    assert all(type(v) is float for v in p)
    close(p, KIN.fk(Q_JOG))


def test_the_readout_shows_the_manual_target_and_the_commanded_joints_in_cartesian_space():
    j = Jogger(PROFILE, KIN)
    p, joints = j.readout(Q_ARM, (0.01, 0.2, 0.05), joint_jog=Q_JOG)
    assert p == (0.01, 0.2, 0.05) and joints == joint_display(PROFILE, Q_ARM)


def test_the_readout_shows_the_joint_jog_and_its_tool_point_in_joint_space():
    j = Jogger(PROFILE, KIN, space=JogSpace.JOINT)
    p, joints = j.readout(Q_ARM, (0.01, 0.2, 0.05), joint_jog=Q_JOG)
    close(p, KIN.fk(Q_JOG))
    assert joints == joint_display(PROFILE, Q_JOG)


def test_the_readout_before_any_command_shows_home():
    j = Jogger(PROFILE, KIN, space=JogSpace.JOINT)
    p, joints = j.readout(None, (0.0, 0.2, 0.1))
    close(p, KIN.fk(PROFILE.q_home))
    assert joints == joint_display(PROFILE, PROFILE.q_home)
    assert all(math.isfinite(float(t.rstrip("°m "))) for t in joints)
