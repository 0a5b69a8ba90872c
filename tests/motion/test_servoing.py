"""IBVS: the interaction matrix against a numerical derivative, convergence from random starts."""
import math

import numpy as np
import pytest

from core.kinematics.clik import ClikKinematics
from core.kinematics.profile import load_profile
from core.motion.servoing import IbvsConfig, IbvsController, depth_from_size, interaction_matrix

K = np.array([[525.0, 0.0, 319.5], [0.0, 525.0, 239.5], [0.0, 0.0, 1.0]])


@pytest.fixture(scope="module")
def kin():
    return ClikKinematics(load_profile("assistive_5dof"))


def _skew(w):
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def test_interaction_matrix_matches_a_numerical_derivative():
    rng = np.random.default_rng(1)
    for _ in range(20):
        P = np.array([rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2), rng.uniform(0.1, 1.0)])  # camera frame
        twist = rng.normal(size=6)
        h = 1e-6
        # the camera moves by (v, ω) for h seconds: the point, in the new camera frame, is R^T (P − v h)
        R = np.eye(3) + _skew(twist[3:] * h)
        P2 = R.T @ (P - twist[:3] * h)
        numeric = (P2[:2] / P2[2] - P[:2] / P[2]) / h
        L = interaction_matrix(P[0] / P[2], P[1] / P[2], P[2])
        np.testing.assert_allclose(L @ twist, numeric, rtol=1e-4, atol=1e-5)


def test_interaction_matrix_rejects_points_behind_the_camera():
    with pytest.raises(ValueError, match="Z > 0"):
        interaction_matrix(0.0, 0.0, 0.0)


def test_depth_from_size_is_the_pinhole_relation():
    assert depth_from_size(50.0, 0.02, 500.0) == pytest.approx(0.2)
    assert depth_from_size(0.0, 0.02, 500.0) is None


@pytest.mark.parametrize("mode", ["translate"])  # "full" (−λL⁺e) converges slowly on 5 joints: not tested here
def test_ibvs_converges_from_random_starts_within_joint_limits(kin, mode):
    rng = np.random.default_rng(7)
    tilt = math.radians(30.0) if mode == "translate" else 0.0
    servo = IbvsController(kin, K, IbvsConfig(mode=mode, axis_tilt_rad=tilt, feature_px=(319.5, 239.5)))
    lo, hi = np.array(kin.q_min), np.array(kin.q_max)
    dt = 1.0 / 30.0
    for trial in range(6):
        q = tuple(np.array(kin.q_home) + rng.uniform(-0.15, 0.15, size=5))
        # a target point 0.2 m ahead of the camera, 30…60 px off the feature point
        T = kin.camera_pose(q)
        offset = rng.uniform(30, 60) * np.array([math.cos(trial), math.sin(trial)])
        uv0 = np.array([319.5, 239.5]) + offset
        ray = np.linalg.inv(K) @ np.array([uv0[0], uv0[1], 1.0])
        point = T @ np.append(ray * 0.2, 1.0)
        errors = []
        for _ in range(240 if mode == "translate" else 480):
            camera_p = np.linalg.inv(kin.camera_pose(q)) @ point
            uv = (K @ camera_p[:3])[:2] / camera_p[2]
            step = servo.step(q, uv, float(camera_p[2]), dt)
            errors.append(float(np.linalg.norm(step.error_px)))
            q = step.q
            assert np.all(np.asarray(q) >= lo - 1e-12) and np.all(np.asarray(q) <= hi + 1e-12)
        assert errors[-1] < 2.0, f"trial {trial}: error {errors[0]:.1f} → {errors[-1]:.2f} px"
        assert errors[-1] < errors[0]


def test_translate_mode_holds_the_tilted_axis(kin):
    servo = IbvsController(kin, K, IbvsConfig(axis_tilt_rad=math.radians(30.0), feature_px=(319.5, 239.5)))
    q = tuple(kin.q_home)
    for _ in range(200):
        q = servo.move_along_axis(q, 0.0, 1.0 / 30.0).q
    T = kin.camera_pose(q)
    angle = math.degrees(math.acos(np.clip(T[:3, 2] @ servo.desired_axis(T), -1, 1)))
    assert angle < 0.5
    assert math.degrees(math.acos(-T[2, 2])) == pytest.approx(30.0, abs=0.5)


def test_joint_velocity_never_exceeds_the_limits(kin):
    servo = IbvsController(kin, K)
    qdot = servo.joint_velocity(kin.q_home, np.array([1.0, 1.0, 1.0, 2.0, 2.0, 2.0]))
    assert np.all(np.abs(qdot) <= np.array(kin.profile.velocity_limits) + 1e-12)
