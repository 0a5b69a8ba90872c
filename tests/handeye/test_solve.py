"""Rigid, touch-point and planar hand-eye solves on synthetic and simulated-rig data."""
import math

import numpy as np
import pytest

from core.handeye import (PlanarMap, kabsch, pose_error, solve_planar, solve_rigid, solve_touch_points,
                          tool_marker_of, DEFAULT_TOOL_MARKER)
from core.sim.rig import SimRig, SimRigConfig, rot_xyz


def random_pose(rng):
    T = np.eye(4)
    T[:3, :3] = rot_xyz(*rng.uniform(-1, 1, 3))
    T[:3, 3] = rng.uniform(-0.5, 0.5, 3)
    return T


def to_camera(base_T_camera, base_points):
    camera_T_base = np.linalg.inv(base_T_camera)
    return base_points @ camera_T_base[:3, :3].T + camera_T_base[:3, 3]


def workspace_points(rng, n):
    return np.column_stack([rng.uniform(-0.15, 0.15, n), rng.uniform(0.05, 0.25, n), rng.uniform(0.03, 0.2, n)])


def test_kabsch_recovers_an_exact_transform():
    rng = np.random.default_rng(1)
    T = random_pose(rng)
    B = workspace_points(rng, 8)
    t_mm, r_deg = pose_error(kabsch(to_camera(T, B), B), T)
    assert t_mm < 1e-6 and r_deg < 1e-6


def test_solve_rigid_rejects_an_outlier_and_reports_residuals():
    rng = np.random.default_rng(2)
    T = random_pose(rng)
    B = workspace_points(rng, 12)
    C = to_camera(T, B) + rng.normal(0, 0.0003, (12, 3))
    C[5] += (0.03, 0.0, 0.0)  # a 30 mm blunder
    res = solve_rigid(C, B, camera_pair="p")
    assert res.ok and res.rejected == (5,) and res.poses_used == 11
    assert len(res.residuals_mm) == 12 and res.residuals_mm[5] > 20
    assert res.rms_mm < 1.0 and res.worst_index != 5 and res.camera_pair == "p" and res.created
    t_mm, r_deg = pose_error(res.base_T_camera, T)
    assert t_mm < 2.0 and r_deg < 0.3
    assert any("rejected" in w for w in res.warnings)


def test_too_few_poses_is_not_ok_and_says_the_fix():
    rng = np.random.default_rng(3)
    B = workspace_points(rng, 3)
    res = solve_rigid(to_camera(np.eye(4), B), B)
    assert not res.ok and "only 3 usable" in res.problem and "--poses" in res.problem


def test_no_points_says_the_marker_was_never_seen():
    res = solve_rigid(np.zeros((0, 3)), np.zeros((0, 3)), skipped=12)
    assert not res.ok and "never seen" in res.problem


def test_large_residuals_are_not_ok():
    rng = np.random.default_rng(4)
    B = workspace_points(rng, 10)
    C = to_camera(np.eye(4), B) + rng.normal(0, 0.01, (10, 3))  # 1 cm noise everywhere
    res = solve_rigid(C, B)
    assert not res.ok and "residuals too large" in res.problem and res.rms_mm > 5.0


def test_flat_point_sets_warn_about_their_spread():
    rng = np.random.default_rng(5)
    B = workspace_points(rng, 10)
    B[:, 2] = 0.1 + rng.uniform(-0.005, 0.005, 10)  # all at one height
    res = solve_rigid(to_camera(np.eye(4), B), B)
    assert any("span too little volume" in w and "spread the poses" in w for w in res.warnings)


def offset_rig(offset):
    return SimRig(SimRigConfig(mount_offset=offset))


def test_touch_points_on_the_simulated_rig_recover_its_mount():
    rng = np.random.default_rng(6)
    rig = offset_rig((0.03, -0.02, 0.015, math.radians(3), math.radians(-4), math.radians(2)))
    # six desk markers (z = 0) and two on cups (z = 9 cm): the tip touched each centre (FK ± 0.5 mm)
    B = np.column_stack([rng.uniform(-0.15, 0.15, 8), rng.uniform(0.08, 0.25, 8), [0] * 6 + [0.09] * 2])
    C = to_camera(rig.base_T_camera, B) + rng.normal(0, 0.0003, (8, 3))
    tip = B + rng.normal(0, 0.0003, (8, 3))
    res = solve_touch_points(C, tip, camera_pair="sim")
    assert res.ok and res.method == "touch_points"
    t_mm, r_deg = pose_error(res.base_T_camera, rig.base_T_camera)
    assert t_mm < 2.0 and r_deg < 0.3, (t_mm, r_deg)


def test_planar_map_from_one_downward_camera(tmp_path):
    rng = np.random.default_rng(7)
    rig = offset_rig((0.02, 0.01, 0.0, 0.0, math.radians(2), 0.0))
    B = np.column_stack([rng.uniform(-0.15, 0.15, 9), rng.uniform(0.05, 0.25, 9), np.zeros(9)])
    px = rig.project("left", B) + rng.normal(0, 0.1, (9, 2))
    m = solve_planar(px, B[:, :2], B[:, 2], camera_pair="sim")
    assert m.ok and m.rms_mm < 1.0 and m.z_coeffs[:2] == (0.0, 0.0)
    probe = np.array([0.05, 0.12, 0.0])
    assert np.linalg.norm(np.subtract(m.apply(rig.project("left", probe[None])[0]), probe)) < 0.002
    m.save(tmp_path / "planar.toml")
    again = PlanarMap.load(tmp_path / "planar.toml")
    assert np.allclose(again.H, m.H) and again.z_coeffs == m.z_coeffs and again.rms_mm == m.rms_mm


def test_planar_with_too_few_points_is_not_ok():
    m = solve_planar(np.zeros((3, 2)), np.zeros((3, 2)), np.zeros(3))
    assert not m.ok and "at least 4" in m.problem


def test_profiles_without_a_tool_marker_get_the_default():
    class P:
        pass

    assert tool_marker_of(P()) == DEFAULT_TOOL_MARKER
    P.tool_marker = type("TM", (), {"marker_id": 9, "offset_m": (0, 0, 0.02), "size_m": 0.025})()
    tm = tool_marker_of(P())
    assert tm.marker_id == 9 and tm.offset_m == (0.0, 0.0, 0.02) and tm.size_m == 0.025
    with pytest.raises(ValueError, match="size_m"):
        type(DEFAULT_TOOL_MARKER)(7, (0, 0, 0), 1.0)
