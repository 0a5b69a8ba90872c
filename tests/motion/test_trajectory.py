"""Trajectories: cubic/quintic end conditions, velocity and acceleration limits, 50 Hz streaming,
the UMI-RTX Lissajous defaults and every arm's scaled curve inside its workspace."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core.kinematics import build_kinematics, load_profile
from core.motion.safety import is_within_limits
from core.motion.trajectory import (
    UMI_RTX_LISSAJOUS,
    PointToPoint,
    default_lissajous,
    follow_cartesian,
    joint_move,
    lissajous_points,
    min_duration,
    stream,
)

PROFILES = ("desk_rrr", "umi_rtx", "assistive_5dof", "delta")


@pytest.mark.parametrize("shape", ["cubic", "quintic"])
def test_point_to_point_starts_and_ends_at_rest_on_the_given_points(shape):
    move = PointToPoint((0.0, 1.0, -2.0), (1.0, 0.5, 2.0), 2.0, shape)
    a, b = move.sample(0.0), move.sample(2.0)
    assert a.q == (0.0, 1.0, -2.0) and b.q == (1.0, 0.5, 2.0)
    assert a.qd == (0.0, 0.0, 0.0) and b.qd == (0.0, 0.0, 0.0)
    # just inside the ends the velocity tends to zero too (the formula, not the clamp)
    for t in (1e-9, 2.0 - 1e-9):
        assert max(abs(v) for v in move.sample(t).qd) < 1e-7
    mid = move.sample(1.0)
    assert mid.q == pytest.approx((0.5, 0.75, 0.0))
    if shape == "quintic":
        for t in (1e-9, 2.0 - 1e-9):
            assert max(abs(v) for v in move.sample(t).qdd) < 1e-6


@pytest.mark.parametrize("shape", ["cubic", "quintic"])
def test_velocity_and_acceleration_match_finite_differences(shape):
    move = PointToPoint((0.2, -0.4), (1.1, 0.3), 1.5, shape)
    h = 1e-6
    for t in np.linspace(0.05, 1.45, 15):
        sp = move.sample(t)
        qd = (np.array(move.sample(t + h).q) - np.array(move.sample(t - h).q)) / (2 * h)
        qdd = (np.array(move.sample(t + h).qd) - np.array(move.sample(t - h).qd)) / (2 * h)
        assert np.allclose(sp.qd, qd, atol=1e-6) and np.allclose(sp.qdd, qdd, atol=1e-5)


@pytest.mark.parametrize("shape", ["cubic", "quintic"])
def test_the_shortest_duration_keeps_every_joint_within_its_limits(shape):
    v, a = (1.0, 0.5, 2.0), (3.0, 10.0, 0.5)
    start, goal = (0.0, 0.0, 0.0), (1.0, -2.0, 0.3)
    T = min_duration(start, goal, v, a, shape)
    move = PointToPoint(start, goal, T, shape)
    ts = np.linspace(0.0, T, 2001)
    qd = np.array([move.sample(t).qd for t in ts])
    qdd = np.array([move.sample(t).qdd for t in ts])
    assert np.all(np.abs(qd).max(0) <= np.array(v) + 1e-9)
    assert np.all(np.abs(qdd).max(0) <= np.array(a) + 1e-9)
    # and it is the shortest: one axis sits on its velocity or acceleration limit
    assert np.any(np.isclose(np.abs(qd).max(0), v, rtol=1e-3) | np.isclose(np.abs(qdd).max(0), a, rtol=1e-3))


def test_joint_move_uses_the_profiles_limits_and_stretches_a_too_short_duration():
    profile = load_profile("umi_rtx")
    q0, q1 = profile.q_home, (0.9, -1.0, 1.5, 0.0, 1.0, -1.5)
    move = joint_move(profile, q0, q1, duration=0.1)
    assert move.duration > 0.1
    assert all(p <= v + 1e-12 for p, v in zip(move.peak_velocity(), profile.velocity_limits))
    assert all(p <= a + 1e-12 for p, a in zip(move.peak_acceleration(), profile.acceleration_limits))
    slow = joint_move(profile, q0, q1, duration=60.0, shape="quintic")
    assert slow.duration == 60.0
    clamped = joint_move(profile, q0, (5.0,) * 6)
    assert is_within_limits(clamped.goal, profile, tol=0.0)


def test_stream_is_on_the_50_hz_grid_and_ends_exactly_at_the_goal_at_rest():
    move = PointToPoint((0.0,), (1.0,), 0.51)
    pts = list(stream(move, 50.0, t0=10.0))
    assert [round(p.t - 10.0, 9) for p in pts[:3]] == [0.0, 0.02, 0.04]
    assert pts[-1].t == pytest.approx(10.51) and pts[-1].q == (1.0,) and pts[-1].qd == (0.0,)
    assert len(pts) == 27  # 0 … 0.50 on the grid (26) + the exact end
    assert list(stream(PointToPoint((0.0,), (1.0,), 0.5)))[-1].t == pytest.approx(0.5)
    assert len(list(stream(PointToPoint((0.0,), (1.0,), 0.5)))) == 26


def test_bad_arguments_are_refused_with_the_reason():
    with pytest.raises(ValueError, match="shape = 'linear'"):
        PointToPoint((0,), (1,), 1.0, "linear")
    with pytest.raises(ValueError, match="duration"):
        PointToPoint((0,), (1,), -1.0)
    with pytest.raises(ValueError, match="start has 1 values but goal has 2"):
        PointToPoint((0,), (1, 2), 1.0)


def test_umi_rtx_lissajous_is_the_originals_curve():
    for t in np.linspace(0.0, 60.0, 31):
        x, y, z = UMI_RTX_LISSAJOUS.point(t)
        assert (x, y, z) == pytest.approx((0.2 * math.sin(0.5 * t), 0.3 + 0.1 * math.sin(0.3 * t),
                                           0.3 + 0.2 * math.sin(0.2 * t)), abs=1e-12)


@pytest.mark.parametrize("name", PROFILES)
def test_each_arms_lissajous_stays_inside_its_workspace_within_its_joint_speeds(name):
    profile = load_profile(name)
    kin = build_kinematics(profile)
    params = default_lissajous(kin)
    if name == "umi_rtx":
        assert params == UMI_RTX_LISSAJOUS
    pts = lissajous_points(params)
    q = kin.ik(tuple(pts[0]), kin.q_home).q
    for p in pts:  # every point solved, warm-started along the curve like the control loop
        res = kin.ik(tuple(p), q)
        assert res.success, f"{name}: Lissajous point {p} out of reach: {res.message}"
        assert res.restarts == 0, f"{name}: branch change at {p}: {res.message}"  # no jumps
        q = res.q
    # streamed at 50 Hz from the curve's start, the commands respect limits and speeds
    start = kin.ik(params.point(0.0), kin.q_home).q
    prev = start
    for sp in follow_cartesian(kin, profile, params.point, 20.0, start):
        assert is_within_limits(sp.q, profile, tol=0.0)
        assert sp.reachable
        for a, b, v in zip(prev, sp.q, profile.velocity_limits):
            assert abs(b - a) <= v / 50.0 + 1e-12
        prev = sp.q
