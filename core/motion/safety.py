"""Safety clamps: small pure functions between the IK and the motor bridge (LeRobot style).

Order in the control loop::

    q = limit_step(q_prev, q_ik, max_step_rad)      # rate limit per tick
    q, clamped = clamp_to_limits(q, profile)         # joint limits
    angles_deg = to_servo_bytes_deg(q, profile)      # whole degrees for the v1 protocol

Nothing non-finite ever comes out of these functions. The rules, the same everywhere:

- a NaN joint value with a previous value to hold (``limit_step``) holds the previous value;
- a NaN joint value without one (``clamp_to_limits``, ``to_servo_bytes_deg``) becomes the
  middle of that joint's range;
- ±inf is an ordinary (very large) number: it clamps to the limit on its side, or moves by at
  most one step towards it.

The firmware clamps again; these are the first line, not the only one. Targets are checked
earlier still, where they enter (``require_finite``): a NaN or infinite target is refused with
an error naming the field instead of being turned into some joint value downstream.
"""
from __future__ import annotations

import math
from typing import Optional, Sequence, Union

from core.kinematics.profile import (
    SERVO_MAX_DEG,
    SERVO_MIN_DEG,
    ProfileError,
    RobotProfile,
)

LIMIT_TOL_RAD = 1e-9  # is_within_limits accepts this much rounding beyond a limit


def require_finite(field: str, values: Sequence[float], unit: str, axes: Sequence[str] = "xyz") -> tuple[float, ...]:
    """``values`` as a float tuple, one per name in ``axes``; ValueError naming the field otherwise.

    The message names the field and the axis, e.g. "manual target z = nan must be a finite
    number (m)". Used where targets enter (Targeter setters, grab points).
    """
    try:
        out = tuple(float(v) for v in values)
    except (TypeError, ValueError):
        raise ValueError(f"{field} = {values!r} must be {len(axes)} numbers ({', '.join(axes)} in {unit})") from None
    if len(out) != len(axes):
        raise ValueError(f"{field} = {values!r} must be {len(axes)} numbers ({', '.join(axes)} in {unit})")
    for axis, v in zip(axes, out):
        if not math.isfinite(v):
            raise ValueError(f"{field} {axis} = {v!r} must be a finite number ({unit})")
    return out


def require_finite_number(field: str, value: float, unit: str) -> float:
    """``value`` as a float; ValueError ("grip_m = inf must be a finite number (m)") otherwise."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{field} = {value!r} must be a number ({unit})") from None
    if not math.isfinite(v):
        raise ValueError(f"{field} = {v!r} must be a finite number ({unit})")
    return v


def _check_len(q: Sequence[float], profile: RobotProfile) -> None:
    if len(q) != len(profile.joints):
        raise ValueError(
            f"q has {len(q)} values but profile {profile.name!r} has {len(profile.joints)} joints"
        )


def clamp_to_limits(q: Sequence[float], profile: RobotProfile) -> tuple[tuple[float, ...], bool]:
    """Clamp each joint value (rad, or m for prismatic joints) into the profile's limits;
    return (q_clamped, changed). Works for every profile, servo or not.

    NaN becomes the middle of the joint's range (and counts as a change).
    """
    _check_len(q, profile)
    out = []
    changed = False
    for v, joint in zip(q, profile.joints):
        lo, hi = joint.q_min, joint.q_max
        v = float(v)
        if v != v:
            c = 0.5 * (lo + hi)
        else:
            c = lo if v < lo else hi if v > hi else v
        changed = changed or c != v
        out.append(c)
    return tuple(out), changed


def limit_step(
    q_prev: Sequence[float],
    q_new: Sequence[float],
    max_step_rad_per_joint: Union[float, Sequence[float]],
    q_fallback: Optional[Sequence[float]] = None,
) -> tuple[float, ...]:
    """Move from ``q_prev`` towards ``q_new`` by at most ``max_step_rad_per_joint`` per joint.

    ``max_step_rad_per_joint`` is one number for every joint or one per joint (rad per call,
    e.g. max speed × tick period); NaN or a negative step holds the joint, inf lets it go.
    Non-finite values: a NaN in ``q_new`` holds ``q_prev``; a non-finite ``q_prev`` (no
    history yet) lets a finite ``q_new`` through unchanged; when both are unusable the joint
    takes ``q_fallback`` (e.g. the home pose) or 0.0.
    """
    n = len(q_prev)
    if len(q_new) != n:
        raise ValueError(f"q_prev has {n} values but q_new has {len(q_new)}")
    if isinstance(max_step_rad_per_joint, (int, float)):
        steps = [float(max_step_rad_per_joint)] * n
    else:
        steps = [float(s) for s in max_step_rad_per_joint]
        if len(steps) != n:
            raise ValueError(f"max_step_rad_per_joint has {len(steps)} values for {n} joints")
    if q_fallback is not None and len(q_fallback) != n:
        raise ValueError(f"q_fallback has {len(q_fallback)} values for {n} joints")
    out = []
    for i in range(n):
        prev, new, step = float(q_prev[i]), float(q_new[i]), steps[i]
        if not math.isfinite(prev):
            if math.isfinite(new):
                out.append(new)
            else:
                fb = float(q_fallback[i]) if q_fallback is not None else 0.0
                out.append(fb if math.isfinite(fb) else 0.0)
            continue
        if new != new or not step >= 0.0:  # NaN target, or NaN/negative step: hold
            out.append(prev)
            continue
        delta = new - prev  # may be ±inf, never NaN: prev is finite, new is not NaN
        if delta > step:
            delta = step
        elif delta < -step:
            delta = -step
        v = prev + delta
        out.append(v if math.isfinite(v) else prev)  # inf step with an inf target
    return tuple(out)


def to_servo_bytes_deg(q: Sequence[float], profile: RobotProfile) -> tuple[int, ...]:
    """Whole servo degrees for ``q`` (rad), each inside the joint's servo range and 0…180.

    The joint value is clamped to its limits first (NaN → middle of the range), converted
    through offset and direction, rounded half up, and clamped again so rounding can never
    leave the range. These are the v1 protocol's angle bytes (0x00–0xB4). Raises ProfileError
    for a profile without servos (umi_rtx, URDF arms).
    """
    _check_len(q, profile)
    if not profile.has_servos:
        raise ProfileError(
            f"profile {profile.name!r} has no hobby servos (its joint limits are in rad or m):"
            " servo angles and the v1 protocol apply only to servo profiles such as desk_rrr or delta"
        )
    q_safe, _ = clamp_to_limits(q, profile)
    out = []
    for v, joint in zip(q_safe, profile.joints):
        lo = max(SERVO_MIN_DEG, joint.servo_min_deg)
        hi = min(SERVO_MAX_DEG, joint.servo_max_deg)
        lo_i, hi_i = int(math.ceil(lo)), int(math.floor(hi))
        deg = joint.to_servo_deg(v)
        d = int(math.floor(deg + 0.5)) if math.isfinite(deg) else lo_i
        out.append(min(max(d, lo_i), hi_i))
    return tuple(out)


def is_within_limits(q: Sequence[float], profile: RobotProfile, tol: float = LIMIT_TOL_RAD) -> bool:
    """True when ``q`` has one finite value per joint, each within its limits (± ``tol`` rad)."""
    if len(q) != len(profile.joints):
        return False
    for v, joint in zip(q, profile.joints):
        v = float(v)
        if not (math.isfinite(v) and joint.q_min - tol <= v <= joint.q_max + tol):
            return False
    return True
