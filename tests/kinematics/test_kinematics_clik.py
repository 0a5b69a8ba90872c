"""Closed-loop IK of URDF arms (umi_rtx, assistive_5dof, UR5-like, Panda-like): FK against DH,
Jacobians against finite differences, FK∘IK round trips, limits on every answer, unreachable
targets, branch continuity, weights, URDF errors."""
from __future__ import annotations

import math
import threading
from pathlib import Path

import numpy as np
import pytest
from checks import assert_close  # tests/ is on sys.path
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.kinematics import ProfileError, build_kinematics, load_profile
from core.kinematics.base import IKResult, pose_matrix, rotation_angle, rpy_to_matrix
from core.kinematics.clik import EPS_POS_M, EPS_ROT_RAD, ClikKinematics
from core.kinematics.urdf import read_urdf_chain

DATA = Path(__file__).resolve().parents[1] / "data"
UR5 = f"urdf:{DATA / 'ur5_like.urdf'}"
PANDA = f"urdf:{DATA / 'panda_like.urdf'}"
PI = math.pi


@pytest.fixture(scope="module")
def arms():
    """Every CLIK arm of the tests, built once (the seed banks are the slow part)."""
    return {name: build_kinematics(load_profile(spec)) for name, spec in
            [("umi_rtx", "umi_rtx"), ("assistive_5dof", "assistive_5dof"), ("ur5", UR5), ("panda", PANDA)]}


def random_q(kin, n, seed):
    return np.random.default_rng(seed).uniform(kin.q_min, kin.q_max, (n, kin.n_joints))


def assert_in_limits(kin, q, what=""):
    q = np.asarray(q)
    assert np.all(np.isfinite(q)), f"{what}: q not finite: {q}"
    assert np.all(q >= np.array(kin.q_min)) and np.all(q <= np.array(kin.q_max)), (
        f"{what}: q {q.tolist()} outside {kin.q_min}…{kin.q_max}")


# ---------------------------------------------------------------------------------------------
# Profiles and URDF reading


def test_umi_rtx_profile_has_the_published_joints_and_limits():
    p = load_profile("umi_rtx")
    assert p.kind == "urdf" and not p.has_servos
    assert p.joint_names == ("column", "shoulder", "elbow", "wrist_yaw", "wrist_roll", "wrist_pitch")
    assert p.joint_types == ("prismatic",) + ("revolute",) * 5
    assert_close(p.q_min, (0.033, -1.57, -3.14, -1.92, -3.16, -1.71), 1e-12, "lower limits")
    assert_close(p.q_max, (0.948, 1.57, 2.64, 1.92, 2.3, 0.07), 1e-12, "upper limits")
    assert p.gripper is not None and (p.gripper.min_m, p.gripper.max_m) == (0.0, 0.05)
    assert p.q_home == (0.25, -1.5, 2.6, 0.0, 0.0, -1.5)  # parked, out of the cameras' view


def test_umi_rtx_geometry_two_0_252_links_and_a_0_15_hand(arms):
    kin = arms["umi_rtx"]
    # everything straight: the tool is 0.252 + 0.252 + 0.15 m ahead (+y) at the column height
    assert_close(kin.fk((0.5, 0.0, 0.0, 0.0, 0.0, 0.0)), (0.0, 0.654, 0.5), 1e-12, "stretched forward")
    # elbow folded back by pi/2 to the right, hand pitched straight down
    assert_close(kin.fk((0.3, 0.0, -PI / 2, 0.0, 0.0, -PI / 2)), (0.252, 0.252, 0.15), 1e-12, "folded, hand down")
    # the wrist differential's roll spins the hand about its own axis: no effect when level
    assert_close(kin.fk((0.3, 0.2, 0.3, 0.1, 1.0, 0.0)), kin.fk((0.3, 0.2, 0.3, 0.1, -2.0, 0.0)), 1e-12, "roll")
    pts = kin.chain_points(kin.q_home)
    assert pts.shape == (8, 3) and np.all(pts[0] == 0.0)
    assert_close(pts[-1], kin.fk(kin.q_home), 0.0, "chain ends at the tool")


def test_assistive_5dof_has_five_revolute_joints_and_a_camera_looking_along_the_hand(arms):
    kin = arms["assistive_5dof"]
    assert kin.n_joints == 5 and kin.profile.joint_types == ("revolute",) * 5
    for q in random_q(kin, 20, 4):
        tool, cam = kin.fk_pose(q), kin.camera_pose(q)
        # optical z is the hand's x (the direction from the wrist to the tool point)
        assert_close(cam[:3, 2], tool[:3, 0], 1e-12, "camera looks along the hand")
        assert_close(cam[:3, 1], -tool[:3, 2], 1e-12, "camera y is down on the hand")


def test_ur5_like_fk_matches_the_standard_dh_parameters(arms):
    kin = arms["ur5"]
    d = [0.089159, 0, 0, 0.10915, 0.09465, 0.0823]
    a = [0, -0.425, -0.39225, 0, 0, 0]
    alpha = [PI / 2, 0, 0, PI / 2, -PI / 2, 0]

    def dh(q):
        T = np.eye(4)
        for i in range(6):
            ct, st_, ca, sa = math.cos(q[i]), math.sin(q[i]), math.cos(alpha[i]), math.sin(alpha[i])
            T = T @ np.array([[ct, -st_ * ca, st_ * sa, a[i] * ct], [st_, ct * ca, -ct * sa, a[i] * st_],
                              [0, sa, ca, d[i]], [0, 0, 0, 1]])
        return T

    for q in random_q(kin, 50, 5):
        assert_close(kin.fk_pose(q), dh(q), 1e-12, f"UR5 FK vs DH at {q}")


def test_panda_like_fk_matches_the_modified_dh_parameters(arms):
    kin = arms["panda"]
    a = [0, 0, 0, 0.0825, -0.0825, 0, 0.088]
    d = [0.333, 0, 0.316, 0, 0.384, 0, 0]
    alpha = [0, -PI / 2, PI / 2, PI / 2, -PI / 2, PI / 2, PI / 2]

    def mdh(q):
        T = np.eye(4)
        for i in range(7):
            ct, st_, ca, sa = math.cos(q[i]), math.sin(q[i]), math.cos(alpha[i]), math.sin(alpha[i])
            T = T @ np.array([[ct, -st_, 0, a[i]], [st_ * ca, ct * ca, -sa, -sa * d[i]],
                              [st_ * sa, ct * sa, ca, ca * d[i]], [0, 0, 0, 1]])
        flange = np.eye(4)
        flange[2, 3] = 0.107
        tcp = pose_matrix((0, 0, 0.1034), rpy_to_matrix(0, 0, -PI / 4))
        return T @ flange @ tcp

    for q in random_q(kin, 50, 6):
        assert_close(kin.fk_pose(q), mdh(q), 1e-12, f"Panda FK vs modified DH at {q}")


def test_urdf_profile_reads_joints_limits_and_velocities_from_the_file():
    p = load_profile(UR5)
    assert p.name == "ur5_like" and p.kind == "urdf" and p.geometry.tip_frame == "tool0"
    assert p.n_joints == 6 and p.q_max[2] == pytest.approx(PI) and p.q_min[0] == pytest.approx(-2 * PI)
    assert p.velocity_limits == pytest.approx((3.15,) * 6)
    assert p.q_home == (0.0,) * 6


def test_tip_option_shortens_the_chain():
    p = load_profile(UR5, tip="link3")
    assert p.joint_names == ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint")
    kin = build_kinematics(p)
    assert kin.n_joints == 3 and kin.tip_frame == "link3"


def test_unknown_tip_names_the_frame_and_lists_the_valid_ones():
    with pytest.raises(ProfileError) as err:
        load_profile(UR5, tip="gripper")
    msg = str(err.value)
    assert "ur5_like.urdf" in msg and "no frame 'gripper'" in msg and "tool0" in msg and "link3" in msg, msg


def test_tip_on_a_non_urdf_profile_is_refused():
    with pytest.raises(ProfileError, match="--tip 'tool' applies only to URDF profiles"):
        load_profile("desk_rrr", tip="tool")


@pytest.mark.parametrize("text, expected", [
    ("<robot", "not valid XML"),
    ("<model name='x'/>", "the root element is <model>, expected <robot>"),
    ('<robot name="x"><link name="a"/><joint name="j" type="revolute"><parent link="a"/><child link="b"/>'
     '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>',
     "joint 'j' names child link 'b', which is not defined"),
    ('<robot name="x"><link name="a"/><link name="b"/><joint name="j" type="revolute"><parent link="a"/>'
     '<child link="b"/><axis xyz="0 0 1"/></joint></robot>', "joint 'j' (revolute) needs <limit lower=... upper=...>"),
    ('<robot name="x"><link name="a"/><link name="b"/><joint name="j" type="slider"><parent link="a"/>'
     '<child link="b"/></joint></robot>', "joint 'j' has type 'slider'"),
    ('<robot name="x" xmlns:xacro="http://ros.org/wiki/xacro"><xacro:macro name="m"/></robot>', "is a xacro file"),
    ('<robot name="x"><link name="a"/><link name="b"/><joint name="j" type="fixed"><parent link="a"/>'
     '<child link="b"/></joint></robot>', "does not move"),
])
def test_malformed_urdf_gives_one_clear_error_naming_the_file(tmp_path, text, expected):
    path = tmp_path / "broken.urdf"
    path.write_text(text)
    with pytest.raises(ProfileError) as err:
        load_profile(f"urdf:{path}")
    assert str(err.value).startswith(f"{path}: ") and expected in str(err.value), str(err.value)


def test_missing_urdf_file_is_named(tmp_path):
    with pytest.raises(ProfileError, match=r"nope\.urdf: no such file"):
        load_profile(f"urdf:{tmp_path / 'nope.urdf'}")


def test_continuous_joints_become_revolute_within_two_pi(tmp_path):
    path = tmp_path / "wheel.urdf"
    path.write_text('<robot name="w"><link name="a"/><link name="b"/><link name="c"/>'
                    '<joint name="spin" type="continuous"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint>'
                    '<joint name="arm" type="fixed"><parent link="b"/><child link="c"/><origin xyz="0.1 0 0"/></joint></robot>')
    p = load_profile(f"urdf:{path}", tip="c")
    assert p.q_min == pytest.approx((-2 * PI,)) and p.q_max == pytest.approx((2 * PI,))
    kin = build_kinematics(p)
    res = kin.ik((0.0, -0.1, 0.0))
    assert res.success and kin.within_limits(res.q)


def test_toml_overrides_narrow_urdf_limits_and_refuse_to_widen_them(tmp_path):
    urdf = DATA / "ur5_like.urdf"
    base = f'name = "ur5"\nkind = "urdf"\n[geometry]\nurdf = "{urdf}"\ntip = "tool0"\n'
    ok = tmp_path / "ok.toml"
    ok.write_text(base + '[[joints]]\nname = "elbow_joint"\nlower = -1.0\nupper = 2.0\nhome = 0.5\nmax_velocity = 1.5\n')
    p = load_profile(ok)
    assert (p.q_min[2], p.q_max[2], p.q_home[2], p.velocity_limits[2]) == (-1.0, 2.0, 0.5, 1.5)
    bad = tmp_path / "bad.toml"
    bad.write_text(base + '[[joints]]\nname = "elbow_joint"\nupper = 4.0\n')
    with pytest.raises(ProfileError, match=r"joints\[0\]\.upper = 4\.0 is outside .* stay inside the URDF's limits"):
        load_profile(bad)
    wrong = tmp_path / "wrong.toml"
    wrong.write_text(base + '[[joints]]\nname = "gripper"\n')
    with pytest.raises(ProfileError, match=r"joints\[0\]\.name = 'gripper' is not a joint between the URDF's root and tip"):
        load_profile(wrong)


def test_a_profile_without_servos_has_no_servo_angles():
    p = load_profile("umi_rtx")
    with pytest.raises(ProfileError, match="'umi_rtx' has no servo mapping"):
        p.to_servo_deg(p.q_home)
    assert p.to_display(p.q_home)[0] == pytest.approx(250.0)  # column in mm
    assert p.joints[1].display_unit == "deg"


def test_the_seed_bank_and_model_are_shared_read_only_and_each_thread_has_its_own_data(arms):
    kin = arms["ur5"]
    targets = [kin.fk_pose(q) for q in random_q(kin, 40, 9)]
    expected = [kin.ik_pose(T, q0).q for T, q0 in zip(targets, random_q(kin, 40, 10))]
    results: dict = {}

    def worker(k):
        results[k] = [kin.ik_pose(T, q0).q for T, q0 in zip(targets, random_q(kin, 40, 10))]

    threads = [threading.Thread(target=worker, args=(k,)) for k in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for k in range(3):
        assert_close(results[k], expected, 0.0, f"thread {k} answers like the main thread")


# ---------------------------------------------------------------------------------------------
# Jacobians


@pytest.mark.parametrize("name", ["umi_rtx", "assistive_5dof", "ur5", "panda"])
def test_jacobian_matches_central_finite_differences(arms, name):
    kin = arms[name]
    eps = 1e-6
    for q in random_q(kin, 20, 11):
        J = kin.jacobian(q)
        J_fd = np.column_stack([(kin.fk(q + eps * np.eye(kin.n_joints)[i]) - kin.fk(q - eps * np.eye(kin.n_joints)[i]))
                                / (2 * eps) for i in range(kin.n_joints)])
        assert_close(J, J_fd, 1e-8, f"{name} position Jacobian vs finite differences at {q}")
        # angular rows: the rotation between R(q - eps) and R(q + eps), in robot_base
        Jw = kin.jacobian_pose(q)[3:]
        for i in range(kin.n_joints):
            Rp = kin.fk_pose(q + eps * np.eye(kin.n_joints)[i])[:3, :3]
            Rm = kin.fk_pose(q - eps * np.eye(kin.n_joints)[i])[:3, :3]
            W = (Rp @ Rm.T - Rm @ Rp.T) / (4 * eps)  # skew(ω) to first order
            assert_close(Jw[:, i], (W[2, 1], W[0, 2], W[1, 0]), 1e-8, f"{name} angular column {i}")


# ---------------------------------------------------------------------------------------------
# Round trips


@pytest.mark.parametrize("name, n", [("umi_rtx", 150), ("ur5", 150), ("panda", 150)])
def test_cold_full_pose_round_trip(arms, name, n):
    kin = arms[name]
    failed = 0
    for q_true in random_q(kin, n, 12):
        T = kin.fk_pose(q_true)
        res = kin.ik_pose(T, None)
        assert_in_limits(kin, res.q, f"{name} pose")
        if not res.success:
            failed += 1
            continue
        F = kin.fk_pose(res.q)
        assert np.linalg.norm(F[:3, 3] - T[:3, 3]) <= EPS_POS_M and res.error_m <= EPS_POS_M
        assert rotation_angle(F[:3, :3], T[:3, :3]) <= 1.5 * EPS_ROT_RAD
        assert res.branches == (res.q,) and res.iterations >= 0
    assert failed <= 1, f"{name}: {failed} of {n} cold pose solves failed"


@pytest.mark.parametrize("name", ["umi_rtx", "assistive_5dof", "ur5", "panda"])
def test_cold_position_round_trip(arms, name):
    kin = arms[name]
    for q_true in random_q(kin, 150, 13):
        p = kin.fk(q_true)
        res = kin.ik(p)
        assert res.success, f"{name}: {p} not solved: {res}"
        assert_in_limits(kin, res.q, name)
        assert_close(kin.fk(res.q), p, EPS_POS_M, f"{name}: FK(IK(p)) vs p")
        assert_close(res.base_p_reached, kin.fk(res.q), 1e-15, "base_p_reached is FK(q)")


@pytest.mark.parametrize("name", ["umi_rtx", "ur5", "panda"])
def test_warm_pose_solve_from_nearby_joints_returns_the_same_branch(arms, name):
    kin = arms[name]
    rng = np.random.default_rng(14)
    for q_true in random_q(kin, 100, 15):
        q0 = np.clip(q_true + rng.normal(0.0, 0.02, kin.n_joints), kin.q_min, kin.q_max)
        res = kin.ik_pose(kin.fk_pose(q_true), q0)
        assert res.success and res.restarts == 0 and res.iterations <= 10, res
        # near singular or redundant (Panda) configurations the solution is not unique, but it
        # must be the nearby one: no other branch (elbow, wrist flip, 2π shift)
        assert_close(res.q, q_true, 0.1, f"{name}: warm solve stays on the branch of q_true")


@pytest.mark.parametrize("name", ["umi_rtx", "ur5"])
def test_targets_whose_solution_sits_on_joint_limits_converge_from_starts_on_the_limits(arms, name):
    kin = arms[name]
    lo, hi = np.array(kin.q_min), np.array(kin.q_max)
    rng = np.random.default_rng(23)
    for q_true in random_q(kin, 40, 23):
        pinned = rng.choice(kin.n_joints, size=2, replace=False)
        q_true[pinned[0]], q_true[pinned[1]] = lo[pinned[0]], hi[pinned[1]]
        T = kin.fk_pose(q_true)
        # the warm start holds the pinned joints on their limits, the others a little away
        q0 = np.clip(q_true + rng.normal(0.0, 0.01, kin.n_joints), lo, hi)
        q0[pinned] = q_true[pinned]
        res = kin.ik_pose(T, q0)
        assert res.success and res.restarts == 0, res
        assert kin.within_limits(res.q)
        assert_close(kin.fk_pose(res.q), T, 1e-5, f"{name}: pose with joints {pinned} on limits")


def test_small_target_moves_give_small_joint_moves_without_elbow_flips(arms):
    kin = arms["umi_rtx"]
    q = kin.ik((0.25, 0.35, 0.3), kin.q_home).q
    elbow_sign = math.copysign(1.0, q[2])
    for a in np.linspace(0.0, 2 * PI, 400):  # a 10 cm circle, 1.6 mm steps
        target = (0.15 + 0.1 * math.cos(a), 0.35 + 0.1 * math.sin(a), 0.3 + 0.05 * math.sin(2 * a))
        res = kin.ik(target, q)
        assert res.success and res.restarts == 0
        jump = float(np.max(np.abs(np.subtract(res.q, q))))
        assert jump < 0.05, f"joint jump {jump:.3f} at {target}"
        assert math.copysign(1.0, res.q[2]) == elbow_sign
        q = res.q


def test_five_joints_reach_a_pose_with_the_tool_yaw_left_free(arms):
    kin = arms["assistive_5dof"]
    down = rpy_to_matrix(0.0, PI / 2, 0.0)  # the tool's x axis pointing down
    for x, y in [(0.1, 0.35), (-0.15, 0.3), (0.2, 0.2)]:
        T = pose_matrix((x, y, 0.1), down)
        res = kin.ik_pose(T, kin.q_home, weights=(1, 1, 1, 1, 1, 0))
        assert res.success, res
        assert_close(kin.fk(res.q), (x, y, 0.1), EPS_POS_M, "position")
        assert_close(kin.fk_pose(res.q)[:3, 0], (0, 0, -1), 1e-4, "tool pointing down")


def test_scaled_weights_still_converge_on_the_raw_error_and_report_it_unweighted(arms):
    kin = arms["ur5"]
    rng = np.random.default_rng(17)
    for q_true in random_q(kin, 30, 17):
        T = kin.fk_pose(q_true)
        q0 = np.clip(q_true + rng.normal(0.0, 0.02, kin.n_joints), kin.q_min, kin.q_max)
        res = kin.ik_pose(T, q0, weights=(5.0, 0.5, 2.0, 0.2, 3.0, 1.0))
        assert res.success, res
        reached = kin.fk_pose(res.q)
        dist = float(np.linalg.norm(reached[:3, 3] - T[:3, 3]))
        assert dist < math.sqrt(3) * EPS_POS_M
        assert res.error_m == pytest.approx(dist, abs=1e-12)
        assert res.error_rad == pytest.approx(rotation_angle(reached[:3, :3], T[:3, :3]), abs=1e-7)


def test_zero_rotation_weights_make_a_position_solve(arms):
    kin = arms["ur5"]
    T = kin.fk_pose(random_q(kin, 1, 16)[0])
    res = kin.ik_pose(T, None, weights=(1, 1, 1, 0, 0, 0))
    assert res.success and res.error_rad == 0.0
    assert_close(kin.fk(res.q), T[:3, 3], EPS_POS_M, "position")


def test_bad_weights_are_refused(arms):
    with pytest.raises(ValueError, match="weights"):
        arms["ur5"].ik_pose(np.eye(4), None, weights=(1, 1, 1))
    with pytest.raises(ValueError, match="weights"):
        arms["ur5"].ik_pose(np.eye(4), None, weights=(0, 0, 0, 1, 1, 1))


# ---------------------------------------------------------------------------------------------
# Unreachable targets and limits


def test_unreachable_target_above_the_column_gives_the_nearest_point_and_distance(arms):
    kin = arms["umi_rtx"]
    target = (0.1, 0.3, 2.0)
    res = kin.ik(target, kin.q_home)
    assert isinstance(res, IKResult) and not res.success and not res.reachable and res.branches == ()
    assert_in_limits(kin, res.q, "unreachable")
    # column at its top, hand pointing straight up (rolled half a turn, then pitched -90°)
    top = 0.948 + 0.15
    assert_close(res.error_m, 2.0 - top, 1e-6, "distance to the workspace")
    assert_close(res.base_p_reached, (0.1, 0.3, top), 1e-5, "nearest point")
    assert res.message.startswith("out of reach by ")
    cold = kin.ik(target)
    assert_close(cold.error_m, 2.0 - top, 1e-6, "cold: same distance")


def test_a_pose_the_arm_cannot_take_is_reported_with_both_errors(arms):
    kin = arms["umi_rtx"]
    # hand pitched 60° up: the wrist pitch stops at +0.07 rad
    T = pose_matrix((0.0, 0.45, 0.3), rpy_to_matrix(0.0, -PI / 3, PI / 2))
    res = kin.ik_pose(T, kin.q_home)
    assert not res.success and res.error_rad > 0.5 and res.message.startswith("pose not reached")
    assert_in_limits(kin, res.q, "pose out of reach")


@pytest.mark.parametrize("target", [(math.nan, 0.1, 0.1), (0.1, math.inf, 0.1), (0.1, 0.1, -math.inf)])
def test_non_finite_target_returns_the_clamped_current_pose(arms, target):
    kin = arms["umi_rtx"]
    res = kin.ik(target, (0.0, 9.0, math.nan, 0.1, 0.2, 0.0))
    assert not res.success and res.error_m == math.inf and res.message == "target is not finite"
    assert res.q[0] == kin.q_min[0] and res.q[1] == kin.q_max[1]
    assert res.q[2] == pytest.approx(0.5 * (kin.q_min[2] + kin.q_max[2]))


coord = st.one_of(st.floats(-1.5, 1.5), st.sampled_from([0.0, 2.0, -2.0, 1e6]))
angle = st.floats(-PI, PI)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(name=st.sampled_from(["umi_rtx", "assistive_5dof", "panda"]), p=st.tuples(coord, coord, coord),
       rpy=st.one_of(st.none(), st.tuples(angle, angle, angle)),
       q_cur=st.one_of(st.none(), st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=7, max_size=7)))
def test_no_solution_ever_leaves_the_joint_limits(arms, name, p, rpy, q_cur):
    kin = arms[name]
    q0 = None if q_cur is None else q_cur[: kin.n_joints]
    if rpy is None:
        res = kin.ik(p, q0)
    else:
        res = kin.ik_pose(pose_matrix(p, rpy_to_matrix(*rpy)), q0)
    assert_in_limits(kin, res.q, f"{name} target {p} {rpy}")
    assert res.error_m >= 0.0 and math.isfinite(res.error_m)
    if res.success:  # success is never claimed for a pose it does not reach
        assert res.error_m <= EPS_POS_M and (rpy is None or res.error_rad <= EPS_ROT_RAD), res
    else:
        assert res.branches == () and res.message


def test_read_urdf_chain_is_cached_per_file_version(tmp_path):
    a = read_urdf_chain(DATA / "ur5_like.urdf", "tool0")
    b = read_urdf_chain(DATA / "ur5_like.urdf", "tool0")
    assert a is b and a.robot_name == "ur5_like" and len(a.joints) == 6


def test_clik_refuses_a_non_urdf_profile():
    with pytest.raises(ProfileError, match="needs a URDF profile"):
        ClikKinematics(load_profile("desk_rrr"))
