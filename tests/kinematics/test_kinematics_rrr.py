"""Analytic RRR kinematics: FK against Pinocchio, Jacobian, exact IK, nearest point, branches."""
from __future__ import annotations

import math
import re
import zlib

import numpy as np
import pytest
from checks import assert_close  # tests/ is on sys.path
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.kinematics import build_kinematics, load_profile
from core.kinematics.rrr import IKResult, RRRKinematics

H, L1, L2 = 0.0662, 0.125, 0.090  # desk_rrr geometry (m)
ROUND_TRIP_TOL_M = 1e-9
BRUTE_FORCE_TOL_M = 1e-6


def write_profile(folder, name, joints, geometry=(H, L1, L2)):
    """A desk-arm TOML profile with the given (servo_min, servo_max, offset, direction) joints."""
    h, l1, l2 = geometry
    text = (
        f'name = "{name}"\nkind = "rrr"\n\n[geometry]\nshoulder_height_m = {h}\n'
        f"upper_arm_m = {l1}\nforearm_m = {l2}\n"
    )
    for jname, (lo, hi, off, d) in zip(("base_yaw", "shoulder", "elbow"), joints):
        text += (
            f'\n[[joints]]\nname = "{jname}"\nservo_min_deg = {lo}\nservo_max_deg = {hi}\n'
            f"offset_deg = {off}\ndirection = {d}\n"
        )
    path = folder / f"{name}.toml"
    path.write_text(text)
    return load_profile(path)


@pytest.fixture(scope="module")
def kin() -> RRRKinematics:
    return build_kinematics(load_profile("desk_rrr"))


@pytest.fixture(scope="module")
def variants(tmp_path_factory):
    """Other offsets/directions: narrowed yaw, both elbow bends, mirrored servos, narrow ranges."""
    d = tmp_path_factory.mktemp("profiles")
    return {
        # yaw narrowed to 20…160° (the azimuth of many targets is outside)
        "narrow_yaw": RRRKinematics(write_profile(
            d, "narrow_yaw", [(20, 160, 0, 1), (0, 180, 0, 1), (0, 180, 180, 1)])),
        # yaw −90…+90° (servo mirrored), shoulder −45…135°, elbow −90…+90° (both bends)
        "both_elbows": RRRKinematics(write_profile(
            d, "both_elbows", [(0, 180, 90, -1), (0, 180, 45, 1), (0, 180, 90, 1)])),
        # shoulder and elbow servos mounted mirrored: same limits as desk_rrr, other mapping
        "mirrored": RRRKinematics(write_profile(
            d, "mirrored", [(0, 180, 180, -1), (0, 180, 180, -1), (0, 180, 0, -1)])),
        # narrow everything: 30…150° on every servo
        "narrow_all": RRRKinematics(write_profile(
            d, "narrow_all", [(30, 150, 0, 1), (30, 150, 0, 1), (30, 150, 180, 1)])),
    }


def fk_formula(q):
    """The FK of the design document, written out independently of the solver (numpy, (N,3))."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    q1, q2, q3 = q[:, 0], q[:, 1], q[:, 2]
    s = L1 * np.cos(q2) + L2 * np.cos(q2 + q3)
    return np.stack([s * np.cos(q1), s * np.sin(q1), H + L1 * np.sin(q2) + L2 * np.sin(q2 + q3)], 1)


def fk_grid(k: RRRKinematics, q):
    """Vectorised FK for any profile's geometry (brute force reference)."""
    q1, q2, q3 = q[..., 0], q[..., 1], q[..., 2]
    s = k.upper_arm_m * np.cos(q2) + k.forearm_m * np.cos(q2 + q3)
    z = k.shoulder_height_m + k.upper_arm_m * np.sin(q2) + k.forearm_m * np.sin(q2 + q3)
    return np.stack([s * np.cos(q1), s * np.sin(q1), z], -1)


def brute_force_distance(k: RRRKinematics, p, coarse=(33, 65, 65), seeds=16) -> float:
    """Distance from p to the reachable set by a dense joint grid, then zoomed local grids.

    The dense grid finds the basins; each of the best ``seeds`` grid points is refined by
    repeatedly shrinking a 9×9×9 grid around the best point (always inside the limits). The
    result is an upper bound of the true distance, tight to far below 1e-6 m.
    """
    lo, hi = np.array(k.q_min), np.array(k.q_max)
    p = np.asarray(p, dtype=float)
    axes = [np.linspace(lo[i], hi[i], coarse[i]) for i in range(3)]
    Q = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    d = np.linalg.norm(fk_grid(k, Q) - p, axis=1)
    order = np.argsort(d)[:seeds]
    cell = (hi - lo) / (np.array(coarse) - 1)
    best = float(d[order[0]])
    u = np.linspace(-1.0, 1.0, 9)
    for idx in order:
        centre, half = Q[idx].copy(), cell * 1.5
        while half.max() > 1e-11:
            g = [np.clip(centre[i] + half[i] * u, lo[i], hi[i]) for i in range(3)]
            G = np.stack(np.meshgrid(*g, indexing="ij"), -1).reshape(-1, 3)
            dg = np.linalg.norm(fk_grid(k, G) - p, axis=1)
            j = int(np.argmin(dg))
            centre = G[j]
            best = min(best, float(dg[j]))
            half = half * 0.35
    return best


def joint_grid(k: RRRKinematics, n=(9, 13, 13)):
    """Joint values on a grid over the limits, edges included exactly."""
    axes = [np.linspace(k.q_min[i], k.q_max[i], n[i]) for i in range(3)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)


def check_exact(k: RRRKinematics, target, q_current, what=""):
    """IK hits the target, with every branch within limits and on the target."""
    res = k.ik(target, q_current)
    assert res.success and res.reachable, f"{what}: {target} not solved: {res}"
    assert res.error_m == 0.0 and res.message == ""
    assert k.within_limits(res.q), f"{what}: q {res.q} outside {k.q_min}…{k.q_max}"
    assert_close(k.fk(res.q), target, ROUND_TRIP_TOL_M, f"{what}: FK(IK(p)) vs p")
    assert_close(res.base_p_reached, target, ROUND_TRIP_TOL_M, f"{what}: base_p_reached vs p")
    assert res.q in res.branches
    for b in res.branches:
        assert k.within_limits(b), f"{what}: branch {b} outside the limits"
        assert_close(k.fk(b), target, ROUND_TRIP_TOL_M, f"{what}: FK(branch {b}) vs p")
    return res


# ---------------------------------------------------------------------------------------------
# Forward kinematics and Jacobian


def test_home_pose_has_the_upper_arm_up_and_the_forearm_along_plus_x(kin):
    assert_close(kin.fk((0.0, math.pi / 2, -math.pi / 2)), (L2, 0.0, H + L1), 1e-15, "home tool")
    assert_close(
        kin.chain_points((0.0, math.pi / 2, -math.pi / 2)),
        [(0, 0, 0), (0, 0, H), (0, 0, H + L1), (L2, 0, H + L1)],
        1e-15,
        "home chain",
    )


def test_straight_ahead_yaw_points_along_plus_y(kin):
    assert_close(kin.fk((math.pi / 2, 0.0, 0.0)), (0.0, L1 + L2, H), 1e-15, "stretched ahead")


def test_fk_matches_the_design_formula_on_random_joints(kin):
    rng = np.random.default_rng(1)
    q = rng.uniform(kin.q_min, kin.q_max, size=(200, 3))
    assert_close(np.array([kin.fk(v) for v in q]), fk_formula(q), 1e-15, "fk vs formula")


def test_fk_and_jacobian_match_a_pinocchio_model_of_the_arm(kin):
    pin = pytest.importorskip("pinocchio")
    model = pin.Model()
    axis_down = np.array([0.0, -1.0, 0.0])  # rotating about -y lifts +x towards +z
    j1 = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "base_yaw")
    j2 = model.addJoint(j1, pin.JointModelRevoluteUnaligned(axis_down),
                        pin.SE3(np.eye(3), np.array([0.0, 0.0, H])), "shoulder")
    j3 = model.addJoint(j2, pin.JointModelRevoluteUnaligned(axis_down),
                        pin.SE3(np.eye(3), np.array([L1, 0.0, 0.0])), "elbow")
    tool = model.addFrame(pin.Frame("tool", j3, 0, pin.SE3(np.eye(3), np.array([L2, 0.0, 0.0])),
                                    pin.FrameType.OP_FRAME))
    data = model.createData()
    rng = np.random.default_rng(2)
    for q in rng.uniform(kin.q_min, kin.q_max, size=(50, 3)):
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        assert_close(kin.fk(q), data.oMf[tool].translation, 1e-14, f"fk vs pinocchio at {q}")
        J = pin.computeFrameJacobian(model, data, q, tool, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        assert_close(kin.jacobian(q), J[:3, :], 1e-14, f"jacobian vs pinocchio at {q}")


def test_jacobian_matches_central_finite_differences(kin):
    rng = np.random.default_rng(3)
    eps = 1e-6
    for q in rng.uniform(kin.q_min, kin.q_max, size=(50, 3)):
        J_fd = np.zeros((3, 3))
        for i in range(3):
            dq = np.zeros(3)
            dq[i] = eps
            J_fd[:, i] = (kin.fk(q + dq) - kin.fk(q - dq)) / (2 * eps)
        assert_close(kin.jacobian(q), J_fd, 1e-9, f"jacobian vs finite differences at {q}")


# ---------------------------------------------------------------------------------------------
# Exact IK


def test_ik_round_trip_on_a_dense_joint_grid_including_every_limit_edge(kin, variants):
    for name, k in [("desk_rrr", kin), *variants.items()]:
        grid = joint_grid(k)
        for q_true in grid:
            target = tuple(k.fk(q_true))
            check_exact(k, target, k.q_home, f"{name} q={tuple(q_true)}")
            # from the true configuration, IK must give it back (or an equivalent pose)
            res = k.ik(target, tuple(q_true))
            assert_close(k.fk(res.q), target, ROUND_TRIP_TOL_M, f"{name} warm q={tuple(q_true)}")


def test_ik_round_trip_on_a_dense_cartesian_grid(kin):
    xs = np.linspace(-0.25, 0.25, 21)  # contains x = 0 exactly
    ys = np.linspace(-0.25, 0.25, 21)
    zs = np.linspace(-0.05, 0.30, 15)
    solved = unreachable = 0
    for x in xs:
        for y in ys:
            for z in zs:
                res = kin.ik((x, y, z), kin.q_home)
                assert kin.within_limits(res.q)
                if res.success:
                    check_exact(kin, (x, y, z), kin.q_home, "cartesian grid")
                    solved += 1
                else:
                    assert res.error_m > 0.0 and not res.branches
                    unreachable += 1
    assert solved > 1000 and unreachable > 1000  # the grid straddles the workspace boundary


def test_ik_solves_straight_ahead_targets_with_yaw_half_pi(kin):
    for y, z in [(0.1, 0.1), (0.2, 0.07), (0.05, 0.25), (0.15, 0.0)]:
        res = check_exact(kin, (0.0, y, z), kin.q_home, "straight ahead")
        assert_close(res.q[0], math.pi / 2, 1e-15, "yaw straight ahead")


def test_ik_on_the_yaw_axis_keeps_the_current_yaw(kin):
    for z in [H + 0.035, H + 0.1, H + 0.2, H + L1 + L2]:
        for yaw in [0.0, 0.3, math.pi / 2, 2.9, math.pi]:
            res = check_exact(kin, (0.0, 0.0, z), (yaw, 1.0, -1.0), "yaw axis")
            assert res.q[0] == yaw


def test_ik_on_the_yaw_axis_clamps_a_current_yaw_outside_the_limits(kin):
    res = check_exact(kin, (0.0, 0.0, H + 0.1), (-0.5, 1.0, -1.0), "yaw axis, yaw below limit")
    assert res.q[0] == 0.0


@pytest.mark.parametrize("name", ["desk_rrr", "narrow_yaw", "both_elbows", "mirrored", "narrow_all"])
def test_ik_on_the_stretched_folded_and_joint_limit_boundaries(kin, variants, name):
    k = kin if name == "desk_rrr" else variants[name]
    lo, hi = k.q_min, k.q_max
    t = np.linspace(0.0, 1.0, 41)
    qs = []
    for q1 in (lo[0], hi[0], 0.5 * (lo[0] + hi[0]), math.pi / 2 if lo[0] <= math.pi / 2 <= hi[0] else lo[0]):
        for u in t:
            q2 = lo[1] + (hi[1] - lo[1]) * u
            q3 = lo[2] + (hi[2] - lo[2]) * u
            qs += [(q1, q2, lo[2]), (q1, q2, hi[2]), (q1, lo[1], q3), (q1, hi[1], q3)]
            for q3s in (0.0, -math.pi, math.pi):  # stretched / folded, when within the limits
                if lo[2] <= q3s <= hi[2]:
                    qs.append((q1, q2, q3s))
    for q in qs:
        check_exact(k, tuple(k.fk(q)), k.q_home, f"{name} boundary q={q}")
        check_exact(k, tuple(k.fk(q)), q, f"{name} boundary q={q}, warm")


def test_ik_reaches_the_corners_of_the_joint_box(kin, variants):
    for name, k in [("desk_rrr", kin), *variants.items()]:
        for q1 in (k.q_min[0], k.q_max[0]):
            for q2 in (k.q_min[1], k.q_max[1]):
                for q3 in (k.q_min[2], k.q_max[2]):
                    check_exact(k, tuple(k.fk((q1, q2, q3))), k.q_home, f"{name} corner")


def test_targets_on_the_x_axis_have_a_front_and_an_over_the_back_branch(kin):
    res = check_exact(kin, (0.05, 0.0, 0.25), kin.q_home, "x axis")
    yaws = sorted(round(b[0], 12) for b in res.branches)
    assert yaws == [0.0, round(math.pi, 12)], res.branches
    assert kin.ik((0.05, 0.0, 0.25), (3.0, 2.0, -1.0)).q[0] == math.pi
    assert kin.ik((0.05, 0.0, 0.25), (0.1, 1.0, -1.0)).q[0] == 0.0


def test_ik_picks_the_elbow_branch_nearest_the_current_joints(variants):
    k = variants["both_elbows"]
    target = (0.0, 0.15, 0.12)
    res = check_exact(k, target, k.q_home, "both elbows")
    front = [b for b in res.branches if abs(b[0] - math.pi / 2) < 1e-12]
    back = [b for b in res.branches if abs(b[0] + math.pi / 2) < 1e-12]
    assert len(res.branches) == 3 and len(back) == 1  # yaw −π/2, reaching over the back
    assert sorted(b[2] > 0 for b in front) == [False, True]
    assert k.ik(target, (0.0, 0.3, 0.8)).q[2] > 0
    assert k.ik(target, (0.0, 1.2, -0.8)).q[2] < 0


def test_small_target_moves_give_small_joint_moves(kin, variants):
    for name, k, path in [
        # a horizontal arc around the base and a vertical sweep, 1 mm steps
        ("desk_rrr", kin, [(0.15 * math.cos(a), 0.15 * math.sin(a), 0.12)
                           for a in np.linspace(0.1, math.pi - 0.1, 400)]),
        ("desk_rrr", kin, [(0.03, 0.12, z) for z in np.linspace(0.0, 0.2, 200)]),
        ("both_elbows", variants["both_elbows"],
         [(0.02, 0.17, z) for z in np.linspace(0.05, 0.15, 100)]),
    ]:
        q = k.ik(path[0], k.q_home).q
        elbow_sign = math.copysign(1.0, q[2])
        for p in path[1:]:
            res = check_exact(k, p, q, f"{name} path")
            jump = max(abs(a - b) for a, b in zip(res.q, q))
            assert jump < 0.05, f"{name}: joint jump {jump:.3f} rad at {p}: {q} -> {res.q}"
            assert math.copysign(1.0, res.q[2]) == elbow_sign or abs(res.q[2]) < 1e-9
            q = res.q


# ---------------------------------------------------------------------------------------------
# Unreachable targets


def check_unreachable(k: RRRKinematics, target, q_current, what=""):
    res = k.ik(target, q_current)
    assert isinstance(res, IKResult)
    assert not res.success and not res.reachable and res.branches == ()
    assert k.within_limits(res.q), f"{what}: q {res.q} outside the limits"
    assert_close(res.base_p_reached, k.fk(res.q), 1e-15, f"{what}: base_p_reached is FK(q)")
    assert_close(res.error_m, np.linalg.norm(np.subtract(target, res.base_p_reached)), 1e-15,
                 f"{what}: error_m is |target - reached|")
    assert re.fullmatch(r"out of reach by [0-9.e+-]+ mm", res.message), res.message
    brute = brute_force_distance(k, target)
    assert res.error_m <= brute + 1e-9, f"{what}: analytic {res.error_m} worse than brute {brute}"
    assert_close(res.error_m, brute, BRUTE_FORCE_TOL_M, f"{what}: error_m vs brute force")
    return res


UNREACHABLE_DESK = {
    "far away ahead": (0.1, 0.35, 0.1),
    "far away up": (0.0, 0.1, 0.40),
    "far right at desk level": (0.5, 0.0, 0.0),
    "too close to the shoulder": (0.01, 0.01, H + 0.01),
    "on the shoulder": (0.0, 0.0, H),
    "straight above, too high": (0.0, 0.0, 0.5),
    "under the desk far away": (0.1, 0.25, -0.2),
    "under the desk near": (0.02, 0.05, -0.05),
    "behind, low": (0.05, -0.15, 0.05),
    "behind, in the over-the-back hole": (0.0, -0.12, 0.1),
    "behind, far": (-0.2, -0.3, 0.1),
    "just outside the stretched sphere": (0.0, 0.2151, H),
}


@pytest.mark.parametrize("what", sorted(UNREACHABLE_DESK))
def test_unreachable_target_gives_the_nearest_point_and_its_distance(kin, what):
    target = UNREACHABLE_DESK[what]
    res = check_unreachable(kin, target, kin.q_home, what)
    assert res.error_m > 0.0


def test_unreachable_target_just_outside_the_sphere_is_out_by_a_tenth_of_a_mm(kin):
    res = kin.ik((0.0, 0.2151, H), kin.q_home)
    assert_close(res.error_m, 1e-4, 1e-12, "error just outside")
    assert res.message == "out of reach by 0.1 mm"
    assert kin.ik((0.0, 0.238, H), kin.q_home).message == "out of reach by 23 mm"


@pytest.mark.parametrize("name", ["narrow_yaw", "both_elbows", "mirrored", "narrow_all"])
def test_unreachable_targets_match_brute_force_for_other_servo_mappings(variants, name):
    k = variants[name]
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    count = 0
    # random targets around the arm; keep the unreachable ones (plus the yaw-limit cases)
    candidates = [(0.2, 0.02, 0.1), (-0.2, 0.02, 0.1), (0.0, -0.2, 0.1)]
    candidates += [tuple(v) for v in rng.uniform((-0.35, -0.35, -0.15), (0.35, 0.35, 0.4), (60, 3))]
    for target in candidates:
        if k.ik(target, k.q_home).success:
            continue
        check_unreachable(k, target, k.q_home, f"{name} {target}")
        count += 1
        if count >= 12:
            break
    assert count >= 8


def test_a_target_inside_the_azimuth_gap_of_a_narrow_yaw_lands_in_the_yaw_limit_plane(variants):
    k = variants["narrow_yaw"]
    lo1 = k.q_min[0]
    # azimuth 10° is outside 20…160°: the nearest point is in the 20° plane, r sin(10°) away
    r, a = 0.15, math.radians(10)
    res = check_unreachable(k, (r * math.cos(a), r * math.sin(a), 0.1), k.q_home, "azimuth gap")
    assert_close(res.q[0], lo1, 1e-12, "yaw at its limit")
    assert_close(res.error_m, r * math.sin(lo1 - a), 1e-12, "out-of-plane distance")


def test_nan_or_inf_target_returns_the_clamped_current_pose(kin):
    for target in [(math.nan, 0.1, 0.1), (0.1, math.inf, 0.1), (0.1, 0.1, -math.inf)]:
        res = kin.ik(target, (0.5, 1.0, -1.0))
        assert not res.success and res.error_m == math.inf
        assert res.q == (0.5, 1.0, -1.0) and res.message == "target is not finite"
    res = kin.ik((math.nan, 0.0, 0.0), (-5.0, math.nan, 9.0))
    assert res.q == (0.0, math.pi / 2, 0.0)


finite_or_not = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(min_value=-0.5, max_value=0.5),
    st.sampled_from([0.0, -0.0, 1e-300, -1e-300, 1e300, -1e300, 1.7e308, H, math.pi]),
)


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(target=st.tuples(finite_or_not, finite_or_not, finite_or_not),
       q_current=st.tuples(finite_or_not, finite_or_not, finite_or_not))
def test_ik_never_raises_and_never_leaves_the_limits(kin, target, q_current):
    res = kin.ik(target, q_current)
    assert kin.within_limits(res.q), res
    assert all(math.isfinite(v) for v in res.q)
    assert res.error_m >= 0.0 and (res.success == (res.error_m == 0.0))
    for b in res.branches:
        assert kin.within_limits(b)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(u=st.tuples(*[st.floats(0.0, 1.0)] * 3), cur=st.tuples(*[st.floats(-4.0, 4.0)] * 3))
def test_ik_of_any_reachable_point_round_trips(kin, variants, u, cur):
    for k in (kin, variants["both_elbows"]):
        q = tuple(lo + (hi - lo) * t for lo, hi, t in zip(k.q_min, k.q_max, u))
        check_exact(k, tuple(k.fk(q)), cur, f"random q={q}")


# ---------------------------------------------------------------------------------------------
# Workspace helpers


def test_workspace_radius_range_is_folded_to_stretched(kin, variants):
    assert_close(kin.workspace_radius_range(), (L1 - L2, L1 + L2), 1e-15, "radius range")
    lo, hi = variants["narrow_all"].workspace_radius_range()
    assert L1 - L2 < lo < hi < L1 + L2


def test_workspace_outline_is_a_closed_curve_of_reachable_points(kin, variants):
    for k in (kin, variants["both_elbows"]):
        pts = k.workspace_outline_side(24)
        assert pts.ndim == 2 and pts.shape[1] == 2
        finite = pts[np.isfinite(pts[:, 0])]
        for s, z in finite:
            assert k.ik((s, 0.0, z), k.q_home).success, (s, z)
    outline = kin.workspace_outline_side(24)
    assert np.all(np.isfinite(outline))  # desk_rrr: no singular arc strictly inside the box
    assert_close(outline[0], outline[-1], 1e-15, "outline closes")
    assert_close(outline[:, 0].max(), L1 + L2, 1e-12, "outline reaches the stretched arm")
    # the both-elbow profile has the stretched arm strictly inside its elbow range
    assert np.isnan(variants["both_elbows"].workspace_outline_side(24)[:, 0]).any()


def test_build_kinematics_returns_an_rrr_solver_for_the_default_profile():
    assert isinstance(build_kinematics(load_profile("desk_rrr")), RRRKinematics)
