"""Constant-velocity Kalman filter, skew compensation of an unsynchronised pair, the sim's skew."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from core.clock import SimClock
from core.detect.kalman import ConstantVelocityKalman
from core.detect.skew import bring_to_instant, compensate_pair
from core.sim.camera import SimStereoCamera
from core.sim.rig import SimRig


def _line(n=120, seed=0, noise=0.002):
    """A point moving at 0.2 m/s along a diagonal, measured at ~30 Hz with jittered times."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.025, 0.042, n))
    direction = np.array([0.6, 0.8, 0.0])
    truth = np.array([0.1, -0.05, 0.02]) + np.outer(t - t[0], 0.2 * direction)
    return t, truth, truth + rng.normal(0, noise, truth.shape), 0.2 * direction


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kalman_velocity_and_smoothing_on_a_straight_line(seed):
    t, truth, meas, v_true = _line(seed=seed)  # 2 mm noise per coordinate
    kf = ConstantVelocityKalman(process_noise=0.001, measurement_noise=0.002)
    filtered, vel = [], []
    for ti, z in zip(t, meas):
        p, v = kf.update(ti, z)
        filtered.append(p)
        vel.append(v)
    filtered, vel = np.array(filtered), np.array(vel)
    settled = slice(len(t) // 2, None)  # after ~2 s
    v_err = np.linalg.norm(vel[settled] - v_true, axis=1) / 0.2
    assert np.percentile(v_err, 95) < 0.10, v_err
    assert np.linalg.norm(vel[settled].mean(axis=0) - v_true) / 0.2 < 0.03
    raw_rms = np.sqrt(np.mean(np.sum((meas[settled] - truth[settled]) ** 2, axis=1)))
    kf_rms = np.sqrt(np.mean(np.sum((filtered[settled] - truth[settled]) ** 2, axis=1)))
    print(f"seed {seed}: velocity error p95 {np.percentile(v_err, 95):.3f} max {v_err.max():.3f}; "
          f"position rms {kf_rms * 1000:.2f} mm filtered vs {raw_rms * 1000:.2f} mm raw")
    assert kf_rms < 0.7 * raw_rms, (kf_rms, raw_rms)
    assert kf.resets == 0


def test_kalman_predicts_without_measurements_and_restarts_on_a_jump():
    kf = ConstantVelocityKalman(process_noise=0.05, measurement_noise=0.001)
    assert kf.update(0.0, None) == (None, None)
    for k in range(30):
        kf.update(k / 30, (0.2 * k / 30, 0.0, 0.0))
    p, v = kf.update(1.5, None)  # half a second unseen: coasts on
    assert abs(p[0] - 0.3) < 0.01 and abs(v[0] - 0.2) < 0.02
    p, v = kf.update(1.55, (0.0, 0.4, 0.0))  # picked up and put elsewhere
    assert kf.resets == 1 and np.allclose(p, (0.0, 0.4, 0.0)) and np.allclose(v, 0.0)
    with pytest.raises(ValueError, match="backwards"):
        kf.update(1.0, (0.0, 0.4, 0.0))


def test_is_stopped_after_holding_still():
    kf = ConstantVelocityKalman(process_noise=0.02, measurement_noise=0.001)
    rng = np.random.default_rng(3)
    t = 0.0
    for k in range(30):  # moving at 0.2 m/s for 1 s
        t = k / 30
        kf.update(t, (0.2 * t + rng.normal(0, 0.001), 0.0, 0.0))
        assert not kf.is_stopped(0.05, 0.3)
    stop_t, stopped_at = t, None
    for k in range(1, 60):  # then still where it stopped
        t = stop_t + k / 30
        kf.update(t, (0.2 * stop_t + rng.normal(0, 0.001), 0.0, 0.0))
        if stopped_at is None and kf.is_stopped(0.05, 0.3):
            stopped_at = t - stop_t
    assert stopped_at is not None and 0.3 <= stopped_at < 1.2, stopped_at
    assert not kf.is_stopped(0.05, 5.0)  # not still that long


def test_bring_to_instant():
    assert bring_to_instant((100.0, 50.0), (200.0, -100.0), 1.0, 1.016) == pytest.approx((103.2, 48.4))
    assert bring_to_instant((100.0, 50.0), None, 1.0, 2.0) == (100.0, 50.0)


def _triangulate(rig: SimRig, left_px, right_px) -> np.ndarray:
    X = cv2.triangulatePoints(rig.projection("left"), rig.projection("right"),
                              np.asarray(left_px, float).reshape(2, 1), np.asarray(right_px, float).reshape(2, 1))
    return (X[:3] / X[3]).ravel()


def test_skew_compensation_removes_the_false_depth_of_a_moving_object():
    rig = SimRig()
    lag, fps = 0.016, 30.0
    T = rig.base_T_left
    x_axis, z_axis, origin = T[:3, 0], T[:3, 2], T[:3, 3]
    p0 = origin + 0.50 * z_axis  # 50 cm in front of the left camera, on its axis
    velocity = 0.2 * x_axis  # 0.2 m/s sideways (along the image x axis)

    def where(t):
        return p0 + velocity * t

    def seen(side, t):
        return rig.project(side, where(t))[0]

    def image_velocity(side, t):  # what a tracker measures: the last frame-to-frame motion
        return (seen(side, t) - seen(side, t - 1 / fps)) * fps

    t_left, t_right = 1.0, 1.0 + lag
    left, right = seen("left", t_left), seen("right", t_right)
    depth_true = rig.depth("left", where(t_left))[0]
    raw = _triangulate(rig, left, right)
    raw_err = abs(rig.depth("left", raw)[0] - depth_true)
    lc, rc = compensate_pair(left, image_velocity("left", t_left), t_left,
                             right, image_velocity("right", t_right), t_right)
    fixed = _triangulate(rig, lc, rc)
    fixed_err = abs(rig.depth("left", fixed)[0] - depth_true)
    print(f"depth error at {depth_true:.3f} m: {raw_err * 1000:.1f} mm raw, {fixed_err * 1000:.3f} mm compensated; "
          f"false disparity {np.linalg.norm(right - seen('right', t_left)):.2f} px")
    assert 0.022 < raw_err < 0.032  # ~27 mm
    assert fixed_err < 0.003
    assert np.linalg.norm(fixed - where(t_left)) < 0.003
    # to the right view's instant instead: the same point, 16 ms further on
    lc2, rc2 = compensate_pair(left, image_velocity("left", t_left), t_left,
                               right, image_velocity("right", t_right), t_right, t_common=t_right)
    assert np.linalg.norm(_triangulate(rig, lc2, rc2) - where(t_right)) < 0.003


def _one_frame(scenario: str, skew_s: float):
    cam = SimStereoCamera(scenario, clock=SimClock(), seed=1, skew_s=skew_s)
    cam.connect()
    try:
        cam.clock.advance(1.0)  # a second into the scenario: the wander scene is moving
        return cam.read()
    finally:
        cam.disconnect()


def test_sim_camera_right_view_lags_by_skew():
    moving0, moving = _one_frame("wander", 0.0), _one_frame("wander", 0.016)
    assert moving.skew_s == 0.016 and moving0.skew_s == 0.0
    assert np.array_equal(moving.left, moving0.left)
    assert not np.array_equal(moving.right, moving0.right)
    still0, still = _one_frame("static", 0.0), _one_frame("static", 0.016)
    assert np.array_equal(still.left, still0.left) and np.array_equal(still.right, still0.right)
    cam = SimStereoCamera("static", clock=SimClock())
    assert cam.skew_s == 0.0
    cam.skew_s = 0.03
    assert cam.skew_s == 0.03
    with pytest.raises(ValueError, match="skew_s"):
        cam.skew_s = -0.01
