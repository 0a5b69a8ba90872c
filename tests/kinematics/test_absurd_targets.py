"""Solvers and absurd targets: NaN, ±inf, 1e308, -1e300, 5e-324 never raise and never leave the limits."""
from __future__ import annotations

import math
from pathlib import Path

import pytest
from checks import assert_close  # tests/ is on sys.path

from core.kinematics import build_kinematics, load_profile
from core.kinematics.base import pose_matrix, rpy_to_matrix
from core.kinematics.profile import parse_profile

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

MAX = 1.7976931348623157e308  # the largest float
HUGE_TARGETS = [
    (1e308, 0.0, 0.0),
    (-1e300, 0.0, 0.1),
    (1e308, -1e308, 1e308),
    (MAX, -MAX, MAX),  # its distance from anything overflows: error_m is inf
    (0.0, 0.0, -1e150),
    (1e6, 1e6, -1e6),
]
NON_FINITE_TARGETS = [(math.nan, 0.1, 0.1), (0.1, math.inf, 0.1), (0.1, 0.1, -math.inf), (math.nan,) * 3]
Q_CURRENT = ["none", "home", "nan"]


def equal_radii_delta():
    """A valid but odd delta: effector as wide as the base (the forearms hang vertically at
    q = 90°, where the old nearest-point descent hit singular matrices)."""
    data = tomllib.loads(Path(load_profile("delta").source).read_text())
    data["geometry"]["effector_radius_m"] = data["geometry"]["base_radius_m"]
    data["name"] = "delta_equal_radii"
    return parse_profile(data, "delta_equal_radii")


@pytest.fixture(scope="module")
def solvers():
    out = {name: build_kinematics(load_profile(name)) for name in ("desk_rrr", "umi_rtx", "assistive_5dof", "delta")}
    out["delta_equal_radii"] = build_kinematics(equal_radii_delta())
    return out


NAMES = ["desk_rrr", "umi_rtx", "assistive_5dof", "delta", "delta_equal_radii"]


def distance(a, b) -> float:
    """|a − b| without intermediate overflow (inf only when the distance itself overflows)."""
    return math.hypot(*(float(x) - float(y) for x, y in zip(a, b)))


def q_current(kin, which):
    if which == "none":
        return None
    if which == "home":
        return kin.q_home
    return (math.nan,) * len(kin.q_min)


def assert_safe(kin, res, what):
    """q finite and within the limits, a failure says why."""
    assert len(res.q) == len(kin.q_min), what
    assert kin.within_limits(res.q), f"{what}: q = {res.q} leaves the limits {kin.q_min} … {kin.q_max}"
    if not res.success:
        assert res.message and not res.reachable and res.branches == (), f"{what}: {res}"


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("target", HUGE_TARGETS)
@pytest.mark.parametrize("which", Q_CURRENT)
def test_huge_finite_targets_give_the_nearest_point_without_raising(solvers, name, target, which):
    kin = solvers[name]
    res = kin.ik(target, q_current(kin, which))
    assert_safe(kin, res, f"{name} ik{target}")
    assert not res.success and res.message.startswith("out of reach by")
    # the distance is measured to the real target (inf only when it overflows the float range)
    assert res.error_m == distance(res.base_p_reached, target)
    assert res.error_m >= 0.9 * max(abs(c) for c in target)


@pytest.mark.parametrize("name", ["umi_rtx", "assistive_5dof"])
@pytest.mark.parametrize("target", HUGE_TARGETS[:3])
@pytest.mark.parametrize("rpy", [(0.0, 0.0, 0.0), (1e308, -1e308, 3.0)])
def test_huge_pose_targets_give_an_unreached_pose_without_raising(solvers, name, target, rpy):
    kin = solvers[name]
    res = kin.ik_pose(pose_matrix(target, rpy_to_matrix(*rpy)), kin.q_home)
    assert_safe(kin, res, f"{name} ik_pose{target} rpy {rpy}")
    assert not res.success and math.isfinite(res.error_rad)


def test_the_nearest_point_of_a_far_target_is_the_arm_stretched_towards_it(solvers):
    kin = solvers["umi_rtx"]
    near = kin.ik((0.0, 1e4, 0.5), kin.q_home)  # far, but squares stay finite
    absurd = kin.ik((0.0, 1e308, 0.5e304), kin.q_home)  # the same ray, 1e304 times farther
    assert not near.success and not absurd.success
    assert_close(absurd.base_p_reached, near.base_p_reached, 1e-6, "nearest point of a far target")


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("target", [(5e-324, -5e-324, 1e-300), (1e-300, 0.0, 0.0)])
def test_tiny_targets_are_ordinary_points(solvers, name, target):
    kin = solvers[name]
    res = kin.ik(target, kin.q_home)
    assert_safe(kin, res, f"{name} ik{target}")
    assert math.isfinite(res.error_m)


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("target", NON_FINITE_TARGETS)
@pytest.mark.parametrize("which", Q_CURRENT)
def test_non_finite_targets_are_unreachable_with_an_infinite_error(solvers, name, target, which):
    kin = solvers[name]
    res = kin.ik(target, q_current(kin, which))
    assert_safe(kin, res, f"{name} ik{target}")
    assert not res.success and res.error_m == math.inf and res.message == "target is not finite"


@pytest.mark.parametrize("name", ["umi_rtx", "assistive_5dof"])
@pytest.mark.parametrize("rpy", [(math.inf, 0.0, 0.0), (0.0, -math.inf, 0.0), (0.0, 0.0, math.nan)])
def test_non_finite_orientations_are_unreachable_not_a_traceback(solvers, name, rpy):
    kin = solvers[name]
    res = kin.ik_pose(pose_matrix((0.1, 0.3, 0.3), rpy_to_matrix(*rpy)), kin.q_home)
    assert_safe(kin, res, f"{name} rpy {rpy}")
    assert not res.success and res.message == "target is not finite"


def test_a_delta_with_equal_radii_loads_and_solves_ordinary_targets(solvers):
    kin = solvers["delta_equal_radii"]
    for q in ((0.3, 0.3, 0.3), (0.1, 0.6, 1.2), kin.q_home):
        p = kin.fk(q)
        res = kin.ik(tuple(p), kin.q_home)
        assert res.success, res
        assert_close(kin.fk(res.q), p, 1e-9, f"round trip at {q}")
    # out of reach: the nearest-point descent meets singular poses on the way (it used to raise
    # LinAlgError for a quarter of such targets)
    for target in ((-0.3, -0.3, -0.2), (-0.3, -0.3, 0.2), (0.3, -0.3, 0.2), (0.0, 0.0, 1.0), (-0.2, 0.4, -0.5)):
        res = kin.ik(target, kin.q_home)
        assert_safe(kin, res, f"ik{target}")
        assert not res.success and math.isfinite(res.error_m)
