"""Trajectories: Lissajous curves, point-to-point moves with zero end velocities, 50 Hz streaming.

- ``UMI_RTX_LISSAJOUS``: the ROS 2 UMI-RTX system's curve, x = 0.2 sin 0.5t,
  y = 0.3 + 0.1 sin 0.3t, z = 0.3 + 0.2 sin 0.2t (m, s), as a ``core.settings.LissajousParams``;
  ``default_lissajous(kin)`` scales it to any arm and checks every point is reachable.
- ``PointToPoint``: cubic (zero end velocities, as in the delta-robot paper) or quintic (zero
  end velocities and accelerations) between two vectors — joints or a Cartesian point —
  synchronised over all axes; ``joint_move`` picks the shortest duration that keeps every
  joint within its velocity and acceleration limits; ``straight_move`` is a Cartesian one along a
  straight line, its duration from the distance and a tool speed and acceleration (the approach to
  an object that stopped, ``core.motion.targeting``).
- ``stream(trajectory, rate_hz=50)`` yields setpoints on the 50 Hz control grid, ending
  exactly at the goal; ``follow_cartesian`` turns a Cartesian path into joint setpoints with
  warm-started IK and a per-tick joint velocity limit.

SI units throughout (m, rad, s).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Iterator, Optional, Sequence

import numpy as np

from core.motion.safety import require_finite
from core.settings import LissajousParams

STREAM_RATE_HZ = 50.0  # the control loop's rate (the servo PWM frame)
SHAPES = ("cubic", "quintic")
# peak |velocity| and |acceleration| of the unit move s(τ), τ = t/T ∈ [0, 1], times Δ/T and Δ/T²
_PEAK_VEL = {"cubic": 1.5, "quintic": 15.0 / 8.0}
_PEAK_ACC = {"cubic": 6.0, "quintic": 10.0 / math.sqrt(3.0)}

# The original UMI-RTX curve: x = 0.2 sin 0.5t, y = 0.3 + 0.1 sin 0.3t, z = 0.3 + 0.2 sin 0.2t
UMI_RTX_LISSAJOUS = LissajousParams(
    centre=(0.0, 0.3, 0.3),
    amplitude=(0.2, 0.1, 0.2),
    frequency_hz=(0.5 / (2 * math.pi), 0.3 / (2 * math.pi), 0.2 / (2 * math.pi)),
    phase_rad=(0.0, 0.0, 0.0),
)
UMI_RTX_REACH_M = 0.654  # the UMI-RTX's horizontal reach (2 × 0.252 + 0.15 m), the scale of its curve
LISSAJOUS_PERIOD_S = 2 * math.pi / 0.1  # the UMI curve repeats after lcm(2π/0.5, 2π/0.3, 2π/0.2)
LISSAJOUS_CHECK_POINTS = 240  # points of one period checked for reachability
SHRINK_STEPS = (1.0, 0.8, 0.6, 0.45, 0.3, 0.2, 0.1)  # amplitude factors tried by default_lissajous


@dataclass(frozen=True)
class Setpoint:
    """One sample of a trajectory: position, velocity and acceleration at time t."""

    t: float  # s, from the trajectory's start
    q: tuple[float, ...]  # rad or m (joints), or m (Cartesian)
    qd: tuple[float, ...]  # per second
    qdd: tuple[float, ...]  # per second²


def _unit_profile(shape: str, tau: float) -> tuple[float, float, float]:
    """s, ds/dτ, d²s/dτ² of the normalised move (s(0) = 0, s(1) = 1, zero end velocities)."""
    if shape == "cubic":
        return 3 * tau * tau - 2 * tau ** 3, 6 * tau - 6 * tau * tau, 6 - 12 * tau
    t2, t3 = tau * tau, tau ** 3
    return 10 * t3 - 15 * t3 * tau + 6 * t3 * t2, 30 * t2 - 60 * t3 + 30 * t2 * t2, 60 * tau - 180 * t2 + 120 * t3


def min_duration(
    start: Sequence[float], goal: Sequence[float], v_max: Sequence[float], a_max: Sequence[float],
    shape: str = "cubic",
) -> float:
    """Shortest duration (s) of a ``shape`` move from ``start`` to ``goal`` keeping every axis
    within its velocity ``v_max`` and acceleration ``a_max`` (per axis, > 0)."""
    if shape not in SHAPES:
        raise ValueError(f"shape = {shape!r} must be one of {', '.join(SHAPES)}")
    T = 0.0
    for a, b, v, acc in zip(start, goal, v_max, a_max):
        if not (v > 0 and acc > 0):
            raise ValueError(f"velocity and acceleration limits must be > 0, got {v!r}, {acc!r}")
        d = abs(float(b) - float(a))
        T = max(T, _PEAK_VEL[shape] * d / v, math.sqrt(_PEAK_ACC[shape] * d / acc))
    return T


class PointToPoint:
    """A synchronised move from ``start`` to ``goal`` in ``duration`` s with zero end velocities.

    ``shape`` "cubic": q(t) = q0 + Δ·(3τ² − 2τ³); "quintic": q0 + Δ·(10τ³ − 15τ⁴ + 6τ⁵), which
    also starts and ends with zero acceleration. Before 0 it holds ``start``, after
    ``duration`` it holds ``goal``.
    """

    def __init__(self, start: Sequence[float], goal: Sequence[float], duration: float, shape: str = "cubic"):
        if shape not in SHAPES:
            raise ValueError(f"shape = {shape!r} must be one of {', '.join(SHAPES)}")
        if len(start) != len(goal):
            raise ValueError(f"start has {len(start)} values but goal has {len(goal)}")
        if not (math.isfinite(duration) and duration >= 0.0):
            raise ValueError(f"duration = {duration!r} s must be finite and ≥ 0")
        self.start = tuple(float(v) for v in start)
        self.goal = tuple(float(v) for v in goal)
        if not all(math.isfinite(v) for v in self.start + self.goal):
            raise ValueError("start and goal must be finite")
        self.duration = float(duration)
        self.shape = shape

    def sample(self, t: float) -> Setpoint:
        """Position, velocity and acceleration at time ``t`` (s); ValueError for a NaN time."""
        if math.isnan(t):
            raise ValueError("t = nan s: a trajectory is sampled at a number")
        T = self.duration
        if T <= 0.0 or t >= T:
            zero = (0.0,) * len(self.goal)
            return Setpoint(t, self.goal, zero, zero)
        if t <= 0.0:
            zero = (0.0,) * len(self.goal)
            return Setpoint(t, self.start, zero, zero)
        s, ds, dds = _unit_profile(self.shape, t / T)
        q = tuple(a + (b - a) * s for a, b in zip(self.start, self.goal))
        qd = tuple((b - a) * ds / T for a, b in zip(self.start, self.goal))
        qdd = tuple((b - a) * dds / (T * T) for a, b in zip(self.start, self.goal))
        return Setpoint(t, q, qd, qdd)

    def peak_velocity(self) -> tuple[float, ...]:
        """Largest |velocity| per axis over the move."""
        if self.duration <= 0.0:
            return (0.0,) * len(self.goal)
        return tuple(_PEAK_VEL[self.shape] * abs(b - a) / self.duration for a, b in zip(self.start, self.goal))

    def peak_acceleration(self) -> tuple[float, ...]:
        """Largest |acceleration| per axis over the move."""
        if self.duration <= 0.0:
            return (0.0,) * len(self.goal)
        T2 = self.duration * self.duration
        return tuple(_PEAK_ACC[self.shape] * abs(b - a) / T2 for a, b in zip(self.start, self.goal))


def joint_move(
    profile, q_start: Sequence[float], q_goal: Sequence[float], shape: str = "cubic",
    duration: Optional[float] = None, speed_scale: float = 1.0,
) -> PointToPoint:
    """A joint-space move within the profile's velocity and acceleration limits.

    ``duration`` None: the shortest allowed; a given duration shorter than that is stretched
    to it (never faster than the limits). ``speed_scale`` (0 … 1] slows the move down.
    The goal is clamped into the joint limits.
    """
    if not (0.0 < speed_scale <= 1.0):
        raise ValueError(f"speed_scale = {speed_scale!r} must be in (0, 1]")
    lo, hi = profile.q_min, profile.q_max
    goal = tuple(min(max(float(v), a), b) for v, a, b in zip(q_goal, lo, hi))
    v = [s * speed_scale for s in profile.velocity_limits]
    acc = [s * speed_scale * speed_scale for s in profile.acceleration_limits]
    T = min_duration(q_start, goal, v, acc, shape)
    if duration is not None:
        T = max(T, float(duration))
    return PointToPoint(q_start, goal, T, shape)


def straight_move(start: Sequence[float], goal: Sequence[float], max_speed: float, max_acceleration: float,
                  shape: str = "cubic", min_duration_s: float = 0.0) -> PointToPoint:
    """A straight-line move from ``start`` to ``goal`` (points, m) with zero end velocities whose
    speed along the line stays within ``max_speed`` (m/s) and ``max_acceleration`` (m/s²).

    The limits apply to the speed along the path (the norm), not per axis as in ``min_duration``:
    a cubic's peak speed is 1.5·d/T and its peak acceleration 6·d/T², so
    T = max(1.5·d/v, √(6·d/a), ``min_duration_s``). ValueError for limits ≤ 0 or non-finite points.
    """
    if not (max_speed > 0 and max_acceleration > 0 and math.isfinite(max_speed) and math.isfinite(max_acceleration)):
        raise ValueError(f"max_speed = {max_speed!r} m/s and max_acceleration = {max_acceleration!r} m/s² "
                         "must be finite and > 0")
    if shape not in SHAPES:
        raise ValueError(f"shape = {shape!r} must be one of {', '.join(SHAPES)}")
    a = np.asarray(start, dtype=float).reshape(-1)
    b = np.asarray(goal, dtype=float).reshape(-1)
    if a.shape != b.shape or not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError(f"start {tuple(a)} and goal {tuple(b)} must be finite points of the same size")
    d = float(np.linalg.norm(b - a))
    T = max(_PEAK_VEL[shape] * d / max_speed, math.sqrt(_PEAK_ACC[shape] * d / max_acceleration),
            max(0.0, float(min_duration_s)))
    return PointToPoint(tuple(a), tuple(b), T, shape)


def stream(trajectory, rate_hz: float = STREAM_RATE_HZ, t0: float = 0.0) -> Iterator[Setpoint]:
    """Setpoints every 1/``rate_hz`` s from ``t0`` (s), the last one exactly at the end.

    ``trajectory`` has ``duration`` and ``sample(t)``; each Setpoint's ``t`` is ``t0`` plus the
    time along the trajectory.
    """
    if not rate_hz > 0:
        raise ValueError(f"rate_hz = {rate_hz!r} must be > 0")
    dt = 1.0 / rate_hz
    n = int(math.floor(trajectory.duration / dt + 1e-9))
    for k in range(n + 1):
        sp = trajectory.sample(k * dt)
        yield Setpoint(t0 + sp.t, sp.q, sp.qd, sp.qdd)
    if n * dt < trajectory.duration - 1e-12:
        sp = trajectory.sample(trajectory.duration)
        yield Setpoint(t0 + trajectory.duration, sp.q, sp.qd, sp.qdd)


@dataclass(frozen=True)
class CartesianSetpoint:
    """A joint setpoint made from a Cartesian path point."""

    t: float  # s
    base_p_target: tuple[float, float, float]  # the path point (m, robot_base)
    q: tuple[float, ...]  # joint command after IK and the velocity limit (rad or m)
    reachable: bool  # IK reached the path point
    error_m: float  # IK's distance to the path point
    limited: bool  # the joint velocity limit held the command back


def follow_cartesian(
    kin, profile, path: Callable[[float], Sequence[float]], duration: float, q_start: Sequence[float],
    rate_hz: float = STREAM_RATE_HZ,
) -> Iterator[CartesianSetpoint]:
    """Joint setpoints at ``rate_hz`` following ``path(t)`` (robot_base, m) for ``duration`` s.

    Each point is solved by warm-started IK from the previous command (branch continuity), and
    each joint moves at most ``velocity_limit / rate_hz`` per tick; the joint limits always
    hold. An unreachable point sends the arm to the nearest reachable one and says so; a NaN or
    infinite one holds the joints (the solvers answer it with the current joints). ValueError
    for a non-finite ``q_start``.
    """
    dt = 1.0 / rate_hz
    v = profile.velocity_limits
    lo, hi = profile.q_min, profile.q_max
    q_start = require_finite("q_start", q_start, "rad or m", tuple(profile.joint_names))
    q = tuple(min(max(x, a), b) for x, a, b in zip(q_start, lo, hi))
    n = int(math.floor(duration / dt + 1e-9))
    for k in range(n + 1):
        t = k * dt
        p = tuple(float(c) for c in path(t))
        res = kin.ik(p, q)
        limited = False
        nxt = []
        for qi, gi, vi, a, b in zip(q, res.q, v, lo, hi):
            step = vi * dt
            d = gi - qi
            if d > step:
                d, limited = step, True
            elif d < -step:
                d, limited = -step, True
            nxt.append(min(max(qi + d, a), b))
        q = tuple(nxt)
        yield CartesianSetpoint(t, p, q, bool(res.success), float(res.error_m), limited)


def lissajous_points(params: LissajousParams, n: int = LISSAJOUS_CHECK_POINTS,
                     period_s: float = LISSAJOUS_PERIOD_S) -> np.ndarray:
    """``n`` points of the curve over ``period_s`` (m, robot_base), shape (n, 3)."""
    return np.array([params.point(t) for t in np.linspace(0.0, period_s, n, endpoint=False)])


def _all_reachable(kin, points: np.ndarray, q_start) -> bool:
    q = q_start
    for p in points:
        res = kin.ik(tuple(p), q)
        if not res.success:
            return False
        q = res.q
    return True


def default_lissajous(kin, profile_name: Optional[str] = None) -> LissajousParams:
    """The Lissajous curve for an arm: the UMI-RTX's own for umi_rtx, a scaled copy otherwise.

    The UMI curve is scaled by the arm's reach (``workspace_radius_range``) over the UMI-RTX's,
    centred first where the scaling puts it, then at the arm's home tool point; the first
    candidate (shrinking the amplitudes in ``SHRINK_STEPS``) whose ``LISSAJOUS_CHECK_POINTS``
    points are all reachable by warm-started IK is returned. Raises ValueError if none is.
    """
    name = profile_name or getattr(getattr(kin, "profile", None), "name", "")
    if name == "umi_rtx":
        return UMI_RTX_LISSAJOUS
    base = UMI_RTX_LISSAJOUS
    reach = float(kin.workspace_radius_range()[1])
    k = reach / UMI_RTX_REACH_M
    home_tool = tuple(float(c) for c in kin.fk(kin.q_home))
    centres = [tuple(c * k for c in base.centre), home_tool]
    for factor in SHRINK_STEPS:
        amp = tuple(min(0.5, a * k * factor) for a in base.amplitude)
        for centre in centres:
            centre = tuple(max(-1.0, min(1.0, c)) for c in centre)
            params = LissajousParams(centre=centre, amplitude=amp, frequency_hz=base.frequency_hz,
                                     phase_rad=base.phase_rad)
            pts = lissajous_points(params)
            first = kin.ik(tuple(pts[0]), kin.q_home)
            if first.success and _all_reachable(kin, pts, first.q):
                return params
    raise ValueError(f"no scaled Lissajous curve fits the workspace of {name or 'this arm'}")
