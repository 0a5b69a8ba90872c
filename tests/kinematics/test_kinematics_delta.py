"""Delta robot: closed-form IK/FK round trips to 1e-9 m, Jacobian, nearest point, profile checks."""
from __future__ import annotations

import copy
import math

import numpy as np
import pytest
import tomli_w
from checks import assert_close  # tests/ is on sys.path

from core.kinematics import ProfileError, build_kinematics, load_profile
from core.kinematics.delta import DeltaKinematics

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

ROUND_TRIP_TOL_M = 1e-9


@pytest.fixture(scope="module")
def kin() -> DeltaKinematics:
    return build_kinematics(load_profile("delta"))


def test_delta_profile_is_three_servo_arms_with_the_published_kind_of_geometry(kin):
    p = kin.profile
    assert p.kind == "delta3" and p.has_servos and p.n_joints == 3
    assert p.q_min == pytest.approx((math.radians(-40),) * 3) and p.q_max == pytest.approx((math.pi / 2,) * 3)
    g = p.geometry
    assert (g.base_radius_m, g.effector_radius_m, g.upper_arm_m, g.forearm_m) == (0.10, 0.03, 0.16, 0.30)


def test_symmetric_joints_put_the_effector_on_the_axis_at_the_expected_height(kin):
    g = kin.geometry
    for th in (-0.5, 0.0, 0.5, 1.2, math.pi / 2):
        rho = g.base_radius_m - g.effector_radius_m + g.upper_arm_m * math.cos(th)
        z = g.base_height_m - g.upper_arm_m * math.sin(th) - math.sqrt(g.forearm_m ** 2 - rho ** 2) - g.tool_offset_m
        assert_close(kin.fk((th, th, th)), (0.0, 0.0, z), 1e-15, f"symmetric pose {th}")


def test_ik_fk_round_trip_on_random_joints_is_below_1e_9_m(kin):
    for q in np.random.default_rng(1).uniform(kin.q_min, kin.q_max, (3000, 3)):
        p = kin.fk(q)
        res = kin.ik(p, None)
        assert res.success and res.reachable and res.message == "", (q, res)
        assert kin.within_limits(res.q)
        assert_close(kin.fk(res.q), p, ROUND_TRIP_TOL_M, f"FK(IK(p)) vs p at {q}")
        assert_close(res.q, q, 1e-9, "the knee-out branch gives the joints back")


def test_ik_fk_round_trip_on_the_joint_box_corners_and_edges(kin):
    axes = [np.linspace(lo, hi, 7) for lo, hi in zip(kin.q_min, kin.q_max)]
    for q in np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3):
        res = kin.ik(kin.fk(q), kin.q_home)
        assert res.success, (q, res)
        assert_close(kin.fk(res.q), kin.fk(q), ROUND_TRIP_TOL_M, f"round trip at {q}")


def test_jacobian_matches_central_finite_differences(kin):
    eps = 1e-6
    for q in np.random.default_rng(2).uniform(kin.q_min, kin.q_max, (50, 3)):
        J_fd = np.column_stack([(kin.fk(q + eps * e) - kin.fk(q - eps * e)) / (2 * eps) for e in np.eye(3)])
        assert_close(kin.jacobian(q), J_fd, 1e-8, f"Jacobian at {q}")


def test_arm_segments_have_the_link_lengths(kin):
    g = kin.geometry
    for q in np.random.default_rng(3).uniform(kin.q_min, kin.q_max, (20, 3)):
        seg = kin.arm_segments(q)
        assert seg.shape == (3, 4, 3)
        for arm in seg:
            assert math.dist(arm[0], arm[1]) == pytest.approx(g.upper_arm_m, abs=1e-12)
            assert math.dist(arm[1], arm[2]) == pytest.approx(g.forearm_m, abs=1e-12)
            assert math.dist(arm[2], arm[3]) == pytest.approx(g.effector_radius_m, abs=1e-12)
        pts = kin.chain_points(q)
        assert pts.shape == (7, 3) and np.all(np.isfinite(pts))
        assert_close(pts[-1], kin.fk(q), 0.0, "chain ends at the tool")


def brute_force_distance(kin, p, n=41):
    axes = [np.linspace(lo, hi, n) for lo, hi in zip(kin.q_min, kin.q_max)]
    Q = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    pts = np.array([kin.fk_tuple(q) for q in Q])
    return float(np.min(np.linalg.norm(pts - np.asarray(p), axis=1)))


@pytest.mark.parametrize("target", [(0.0, 0.3, 0.1), (0.05, 0.05, 0.3), (0.0, 0.0, -0.2), (0.1, -0.2, 0.05), (0.3, 0.0, 0.0)])
def test_unreachable_target_gives_the_nearest_point_and_its_distance(kin, target):
    res = kin.ik(target, kin.q_home)
    assert not res.success and not res.reachable and res.branches == ()
    assert kin.within_limits(res.q)
    assert_close(res.error_m, np.linalg.norm(np.subtract(target, res.base_p_reached)), 1e-15, "error_m")
    brute = brute_force_distance(kin, target)
    # the grid is an upper bound; the solver must be at least as close (to its spacing's error)
    assert res.error_m <= brute + 1e-9, (res.error_m, brute)
    assert res.error_m >= brute - 2e-3, (res.error_m, brute)
    assert res.message.startswith("out of reach by ")


def test_non_finite_target_holds_the_clamped_current_joints(kin):
    res = kin.ik((math.nan, 0.0, 0.1), (0.2, math.nan, 9.0))
    assert not res.success and res.error_m == math.inf and res.message == "target is not finite"
    assert res.q == pytest.approx((0.2, 0.5 * (kin.q_min[1] + kin.q_max[1]), kin.q_max[2]))


def test_workspace_is_reported_from_sampled_fk(kin):
    lo, hi = kin.workspace_radius_range()
    assert lo == 0.0 and 0.1 < hi < 0.3
    outline = kin.workspace_outline_side()
    assert outline.shape[1] == 2 and np.all(outline[:, 0] >= 0.0) and np.all(outline[0] == outline[-1])


def test_a_delta_whose_forearms_cannot_meet_is_refused_when_loading(tmp_path):
    data = tomllib.loads(open(load_profile("delta").source).read())
    bad = copy.deepcopy(data)
    bad["geometry"]["forearm_m"] = 0.12
    path = tmp_path / "bad_delta.toml"
    path.write_bytes(tomli_w.dumps(bad).encode())
    with pytest.raises(ProfileError, match=r"bad_delta\.toml: geometry\.forearm_m = 0\.12 is too short"):
        load_profile(path)
    bad = copy.deepcopy(data)
    bad["geometry"]["upper_arm_m"] = 0
    path.write_bytes(tomli_w.dumps(bad).encode())
    with pytest.raises(ProfileError, match=r"geometry\.upper_arm_m = 0 is outside 0…5"):
        load_profile(path)
