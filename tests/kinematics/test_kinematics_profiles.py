"""Every built-in profile: loads, builds its solver, keeps the app's solver interface, and the
safety clamps and the simulated arm work for it (servo or not); q never leaves the limits."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core.clock import SimClock
from core.devices.serial_v1 import SerialV1Bridge
from core.devices.sim_arm import SimServoArm
from core.kinematics import ProfileError, build_kinematics, list_profiles, load_profile
from core.kinematics.profile import JointSpec
from core.messages import JointCommand
from core.motion.safety import (
    clamp_to_limits,
    is_within_limits,
    limit_step,
    to_servo_bytes_deg,
)

PROFILES = ("desk_rrr", "umi_rtx", "assistive_5dof", "delta")


@pytest.fixture(scope="module")
def built():
    return {name: (load_profile(name), build_kinematics(load_profile(name))) for name in PROFILES}


def test_every_arm_of_the_original_systems_is_a_built_in_profile():
    assert set(PROFILES) <= set(list_profiles())


@pytest.mark.parametrize("name", PROFILES)
def test_solver_keeps_the_interface_the_app_uses(built, name):
    profile, kin = built[name]
    q = profile.q_home
    p = kin.fk(q)
    assert p.shape == (3,) and np.all(np.isfinite(p))
    pts = kin.chain_points(q)
    assert pts.ndim == 2 and pts.shape[1] == 3 and len(pts) >= 3 and np.all(np.isfinite(pts))
    assert kin.jacobian(q).shape == (3, profile.n_joints)
    res = kin.ik(tuple(p), q)
    for field in ("q", "success", "reachable", "error_m", "base_p_reached", "branches", "message"):
        assert hasattr(res, field), field
    assert res.success and len(res.q) == profile.n_joints
    lo, hi = kin.workspace_radius_range()
    assert 0.0 <= lo < hi
    outline = np.asarray(kin.workspace_outline_side())
    assert outline.ndim == 2 and outline.shape[1] == 2


@pytest.mark.parametrize("name", ["umi_rtx", "assistive_5dof"])
def test_six_dof_capable_solvers_add_pose_fk_and_ik(built, name):
    profile, kin = built[name]
    T = kin.fk_pose(profile.q_home)
    assert T.shape == (4, 4) and np.allclose(T[3], (0, 0, 0, 1))
    weights = (1, 1, 1, 1, 1, 1) if profile.n_joints >= 6 else (1, 1, 1, 1, 1, 0)
    assert kin.ik_pose(T, profile.q_home, weights=weights).success


any_float = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.floats(-10, 10),
                      st.sampled_from([math.nan, math.inf, -math.inf, 0.0, 0.033, 0.948]))


@settings(max_examples=150, deadline=None)
@given(name=st.sampled_from(PROFILES), data=st.data())
def test_clamps_keep_every_profile_within_its_limits(name, data):
    profile = load_profile(name)
    n = profile.n_joints
    q = data.draw(st.lists(any_float, min_size=n, max_size=n))
    prev = data.draw(st.lists(any_float, min_size=n, max_size=n))
    out, changed = clamp_to_limits(q, profile)
    assert is_within_limits(out, profile, tol=0.0), (q, out)
    stepped = limit_step(prev, out, [v * 0.02 for v in profile.velocity_limits], q_fallback=profile.q_home)
    final, _ = clamp_to_limits(stepped, profile)
    assert is_within_limits(final, profile, tol=0.0)
    if profile.has_servos:
        deg = to_servo_bytes_deg(q, profile)
        assert all(0 <= d <= 180 for d in deg)


def test_servo_bytes_are_refused_for_a_profile_without_servos():
    with pytest.raises(ProfileError, match="'umi_rtx' has no hobby servos"):
        to_servo_bytes_deg(load_profile("umi_rtx").q_home, load_profile("umi_rtx"))


def test_plain_joints_validate_their_limits():
    with pytest.raises(ProfileError, match=r"joint 'z': upper = 0\.1 is outside 0\.2…5 \(it must be greater than lower\)"):
        JointSpec("z", joint_type="prismatic", lower=0.2, upper=0.1)
    with pytest.raises(ProfileError, match=r"joint 'z': missing lower"):
        JointSpec("z", joint_type="prismatic")
    with pytest.raises(ProfileError, match=r"joint 'z': type = 'helical' must be one of revolute, prismatic"):
        JointSpec("z", joint_type="helical", lower=0.0, upper=1.0)
    with pytest.raises(ProfileError, match=r"joint 'z': a servo joint is revolute"):
        JointSpec("z", 0, 180, 90, 1, lower=0.0)
    j = JointSpec("z", joint_type="prismatic", lower=0.0, upper=0.5, max_velocity=0.2)
    assert j.velocity_limit == 0.2 and math.radians(j.max_speed_deg_s) == pytest.approx(0.2)
    assert j.q_home == 0.0 and j.unit == "m" and not j.has_servo


@pytest.mark.parametrize("name", PROFILES)
def test_the_simulated_arm_moves_every_profile_at_its_joint_speeds_and_clamps_commands(name):
    profile = load_profile(name)
    clock = SimClock()
    arm = SimServoArm(profile, clock=clock)
    arm.connect()
    start = arm.joint_state().q
    assert start == pytest.approx(profile.q_home, abs=math.radians(0.5))
    # command beyond every upper limit: the arm goes to the limits, never past them
    arm.send(JointCommand(1, clock.now(), tuple(v + 10.0 for v in profile.q_max)))
    clock.advance(0.1)
    mid = arm.joint_state().q
    # servos turn at the MG996R's speed in whole degrees; other joints at their velocity limits
    speeds = [math.radians(arm.speed_deg_s)] * 3 if profile.has_servos else profile.velocity_limits
    for a, b, v in zip(start, mid, speeds):
        resolution = math.radians(1.0) if profile.has_servos else 1e-12
        assert abs(b - a) <= v * 0.1 + resolution + 1e-9, (a, b, v)
    for _ in range(600):
        clock.advance(0.05)
        if arm.is_settled():
            break
    end = arm.joint_state().q
    assert arm.is_settled() and is_within_limits(end, profile, tol=1e-9)
    assert end == pytest.approx(profile.q_max, abs=math.radians(0.6))


def test_the_simulated_desk_arm_keeps_its_whole_degree_servo_model():
    profile = load_profile("desk_rrr")
    clock = SimClock()
    arm = SimServoArm(profile, clock=clock)
    arm.connect()
    sent = arm.send(JointCommand(1, 0.0, (math.radians(30.4), math.radians(90), math.radians(-90))))
    assert sent == (30, 90, 90)
    clock.advance(0.02)
    arm.joint_state()
    assert arm.position_deg == [7.0, 90.0, 90.0]  # 353 °/s × 20 ms = 7.06°, whole degrees


def test_joint_space_sim_arm_returns_no_servo_angles_but_records_the_command():
    profile = load_profile("umi_rtx")
    arm = SimServoArm(profile, clock=SimClock())
    arm.connect()
    assert arm.send(JointCommand(1, 0.0, (2.0,) + profile.q_home[1:])) == ()
    assert arm.last_sent_q[0] == 0.948 and arm.commands_sent == 1


def test_protocol_v1_refuses_arms_it_cannot_drive():
    with pytest.raises(Exception, match="protocol v1 drives 3 joints"):
        SerialV1Bridge("loop://", load_profile("umi_rtx"))
