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

Workspace (the profile's ``[workspace]``, ``core.kinematics.profile.WorkspaceSpec``): after the
joint clamps, ``limit_to_workspace`` keeps every commanded pose clear of the desk and of the
keep-out boxes (``workspace_violation`` says what is wrong with a pose). What counts as "the
arm": every point of ``kinematics.chain_points(q)`` and, for the delta, every point of
``kinematics.arm_segments(q)``, and the straight segments between consecutive points.

- Desk: every *moving* point must have z ≥ ``desk_margin_m``; straight segments between points
  above the margin are above it too. Points fixed to the base — the ones that are at the same
  place in every configuration, such as robot_base's origin on the desk, the RRR arm's shoulder
  on its yaw axis or the delta's base plate — are the mount: the profile puts them where they
  are and no command can move them, so they are exempt (found by sampling the joint range once
  per solver, :func:`arm_layout`).
- Keep-out boxes: no segment with a moving end may intersect a box (slab method, closed box);
  segments with both ends fixed are exempt for the same reason.
- A pose whose points are not finite (a delta that does not assemble) is a violation.
"""
from __future__ import annotations

import math
import weakref
from dataclasses import dataclass
from typing import Any, Optional, Sequence, Union

import numpy as np

from core.kinematics.profile import (
    SERVO_MAX_DEG,
    SERVO_MIN_DEG,
    ProfileError,
    RobotProfile,
    WorkspaceSpec,
)

LIMIT_TOL_RAD = 1e-9  # is_within_limits accepts this much rounding beyond a limit
FIXED_POINT_TOL_M = 1e-9  # a chain point that moves less than this over the joint range is the mount
FIXED_POINT_SAMPLES = 8  # random in-limit configurations (besides limits and home) that find the mount
WORKSPACE_TOL_M = 1e-9  # FK rounding: a point this far under the margin is on it (a goal aimed at it)
WORKSPACE_BISECTIONS = 14  # limit_to_workspace: halvings of the step (2⁻¹⁴ of a tick's travel)


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


# --------------------------------------------------------------------------------------------
# Workspace: the desk plane and keep-out boxes


@dataclass(frozen=True)
class ArmLayout:
    """Which points of a solver's drawings are the mount, and what to call points and segments.

    ``chain_*`` describe ``kinematics.chain_points(q)`` (N points, N - 1 segments);
    ``arms_*`` the delta's ``arm_segments(q)`` (one polyline per arm), empty for serial arms.
    """

    chain_fixed: tuple[bool, ...]  # per chain point: fixed to the base (exempt)
    chain_names: tuple[str, ...]  # per chain point, e.g. "elbow"
    chain_segment_names: tuple[str, ...]  # per segment i → i + 1, e.g. "forearm"
    arms_fixed: tuple[tuple[bool, ...], ...] = ()  # per arm, per point
    arms_names: tuple[tuple[str, ...], ...] = ()
    arms_segment_names: tuple[tuple[str, ...], ...] = ()


_LAYOUTS: "weakref.WeakKeyDictionary[Any, ArmLayout]" = weakref.WeakKeyDictionary()


def _sample_qs(profile: RobotProfile, kinematics: Any) -> list[np.ndarray]:
    lo, hi = np.array(profile.q_min, dtype=float), np.array(profile.q_max, dtype=float)
    home = np.array(getattr(kinematics, "q_home", None) or profile.q_home, dtype=float)
    rng = np.random.default_rng(0)
    return [home, lo, hi, 0.5 * (lo + hi)] + list(rng.uniform(lo, hi, (FIXED_POINT_SAMPLES, len(lo))))


def _fixed_mask(samples: list[np.ndarray]) -> np.ndarray:
    """Per point (last axis but one): True when it is at the same finite place in every sample."""
    a = np.stack(samples)  # (S, ..., 3)
    with np.errstate(invalid="ignore"):
        spread = np.max(np.abs(a - a[0]), axis=(0, -1))
    return np.isfinite(a).all(axis=(0, -1)) & (spread <= FIXED_POINT_TOL_M)


def _names_for(profile: RobotProfile, kinematics: Any, n: int) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(point names, segment names) for ``chain_points``' n points."""
    if profile.kind == "rrr" and n == 4:
        return ("base", "shoulder", "elbow", "tool"), ("base column", "upper arm", "forearm")
    if profile.kind == "delta3" and n == 7:
        j0 = profile.joints[0].name
        return (("desk origin", "base centre", f"{j0} shoulder", f"{j0} elbow", f"{j0} effector joint",
                 "effector", "tool"),
                ("base post", "base plate", f"{j0} upper arm", f"{j0} forearm", "effector", "tool"))
    model = getattr(kinematics, "model", None)
    if model is not None and n == model.njoints + 1:
        tip = str(getattr(kinematics, "tip_frame", "tool"))
        points = ("base",) + tuple(str(model.names[j]) for j in range(1, model.njoints)) + (tip,)
        bodies: dict[int, str] = {}
        for f in model.frames:
            if str(f.type).endswith("BODY"):
                parent = f.parentJoint if hasattr(f, "parentJoint") else f.parent  # Pinocchio < 3: parent
                bodies.setdefault(int(parent), str(f.name))
        segments = tuple(bodies.get(j, f"{points[j]}–{points[j + 1]}") for j in range(n - 1))
        return points, segments
    points = ("base",) + tuple(f"point {i}" for i in range(1, n - 1)) + ("tool",)
    return points, tuple(f"{points[i]}–{points[i + 1]}" for i in range(n - 1))


def arm_layout(profile: RobotProfile, kinematics: Any) -> ArmLayout:
    """The :class:`ArmLayout` of a solver (cached per solver: computed by sampling its range once)."""
    try:
        cached = _LAYOUTS.get(kinematics)
    except TypeError:  # not weak-referenceable: compute every time
        cached = None
    if cached is not None:
        return cached
    qs = _sample_qs(profile, kinematics)
    chains = [np.asarray(kinematics.chain_points(q), dtype=float).reshape(-1, 3) for q in qs]
    n = len(chains[0])
    point_names, segment_names = _names_for(profile, kinematics, n)
    arms_fixed: tuple = ()
    arms_names: tuple = ()
    arms_segments: tuple = ()
    if hasattr(kinematics, "arm_segments"):
        arms = [np.asarray(kinematics.arm_segments(q), dtype=float) for q in qs]
        mask = _fixed_mask(arms)
        arms_fixed = tuple(tuple(bool(v) for v in row) for row in mask)
        names = []
        segs = []
        for i in range(mask.shape[0]):
            jn = profile.joints[i].name if i < len(profile.joints) else f"arm {i}"
            names.append((f"{jn} shoulder", f"{jn} elbow", f"{jn} effector joint", "effector")[:mask.shape[1]])
            segs.append((f"{jn} upper arm", f"{jn} forearm", "effector")[:mask.shape[1] - 1])
        arms_names, arms_segments = tuple(names), tuple(segs)
    layout = ArmLayout(tuple(bool(v) for v in _fixed_mask(chains)), point_names, segment_names,
                       arms_fixed, arms_names, arms_segments)
    try:
        _LAYOUTS[kinematics] = layout
    except TypeError:
        pass
    return layout


def segment_hits_box(a: Sequence[float], b: Sequence[float], box_min: Sequence[float],
                     box_max: Sequence[float]) -> bool:
    """True when the segment a–b (m) meets the closed axis-aligned box [box_min, box_max] (slab method).

    A segment of zero length is a point-in-box test. Non-finite ends count as a hit (unknown
    is unsafe).
    """
    t0, t1 = 0.0, 1.0
    for i in range(3):
        p, q = float(a[i]), float(b[i])
        lo, hi = float(box_min[i]), float(box_max[i])
        if not (math.isfinite(p) and math.isfinite(q)):
            return True
        d = q - p
        if d == 0.0:
            if p < lo or p > hi:
                return False
            continue
        ta, tb = (lo - p) / d, (hi - p) / d
        if ta > tb:
            ta, tb = tb, ta
        t0, t1 = max(t0, ta), min(t1, tb)
        if t0 > t1:
            return False
    return True


def _polylines(q: Sequence[float], kinematics: Any, layout: ArmLayout):
    """(points (N,3), fixed, point names, segment names) of every polyline of the arm at q."""
    out = [(np.asarray(kinematics.chain_points(q), dtype=float).reshape(-1, 3), layout.chain_fixed,
            layout.chain_names, layout.chain_segment_names)]
    if layout.arms_fixed:
        arms = np.asarray(kinematics.arm_segments(q), dtype=float)
        for pts, fixed, names, segs in zip(arms, layout.arms_fixed, layout.arms_names, layout.arms_segment_names):
            out.append((pts.reshape(-1, 3), fixed, names, segs))
    return out


def _format_z(z: float) -> str:
    mm = z * 1e3
    return f"{mm:.0f} mm" if abs(mm) >= 10.0 else f"{mm:.1f} mm"


@dataclass(frozen=True)
class WorkspaceAssessment:
    """How a pose stands against the workspace: the first reason and how bad it is."""

    reason: str  # "" when the pose is fine
    desk_depth_m: float  # how far the lowest moving point is below the margin (≤ tolerance: clear); inf if unknown
    box_hits: int  # (segment, box) pairs that intersect


def assess_workspace(q: Sequence[float], profile: RobotProfile, kinematics: Any,
                     workspace: Optional[WorkspaceSpec] = None) -> WorkspaceAssessment:
    """Check every moving point against the desk margin and every segment against the keep-out
    boxes; ``workspace`` defaults to the profile's."""
    ws = workspace if workspace is not None else getattr(profile, "workspace", None) or WorkspaceSpec()
    layout = arm_layout(profile, kinematics)
    margin = ws.desk_margin_m
    worst_depth, worst_name, worst_z = -math.inf, "", 0.0
    box_reason, hits = "", 0
    for pts, fixed, names, segs in _polylines(q, kinematics, layout):
        for k, (p, f) in enumerate(zip(pts, fixed)):
            if f:
                continue
            z = float(p[2])
            if not np.isfinite(p).all():
                return WorkspaceAssessment(f"arm shape undetermined at these joints ({names[k]})", math.inf,
                                           hits + 1)
            if margin - z > worst_depth:
                worst_depth, worst_name, worst_z = margin - z, names[k], z
        for box in ws.keep_out:
            for k in range(len(pts) - 1):
                if fixed[k] and fixed[k + 1]:
                    continue
                if segment_hits_box(pts[k], pts[k + 1], box.min_m, box.max_m):
                    hits += 1
                    if not box_reason:
                        box_reason = f"in keep-out box {box.name!r}: {segs[k]}"
    if worst_depth > WORKSPACE_TOL_M:
        reason = f"below the desk: {worst_name} at z = {_format_z(worst_z)}"
        if worst_z >= 0.0:
            reason += f" (margin {_format_z(margin)})"
    else:
        reason = box_reason
    return WorkspaceAssessment(reason, worst_depth, hits)


def workspace_violation(q: Sequence[float], profile: RobotProfile, kinematics: Any,
                        workspace: Optional[WorkspaceSpec] = None) -> str:
    """"" when the arm at ``q`` is clear of the desk margin and every keep-out box, else why not,
    e.g. "below the desk: elbow at z = -12 mm" or "in keep-out box 'monitor': forearm".

    ``workspace`` defaults to ``profile.workspace``. Points fixed to the base are exempt (see
    the module docstring).
    """
    return assess_workspace(q, profile, kinematics, workspace).reason


def _no_worse(new: WorkspaceAssessment, ref: WorkspaceAssessment) -> bool:
    """A pose that leaves an unsafe start: not deeper in the desk, not in more boxes."""
    return new.desk_depth_m <= max(ref.desk_depth_m, WORKSPACE_TOL_M) + 1e-12 and new.box_hits <= ref.box_hits


def limit_to_workspace(q_from: Sequence[float], q_to: Sequence[float], profile: RobotProfile,
                       kinematics: Any, workspace: Optional[WorkspaceSpec] = None,
                       ) -> tuple[tuple[float, ...], str]:
    """The farthest pose on the straight joint-space step ``q_from`` → ``q_to`` that respects the
    workspace, and the reason it stopped short ("" when ``q_to`` is fine).

    Both are expected within the joint limits. From a safe ``q_from`` the answer is safe: ``q_to``
    itself, or the farthest safe fraction of the step found by bisection, or ``q_from`` (hold).
    From an unsafe ``q_from`` (the arm was put there, or a box was added around it) a step is
    taken as far as it makes nothing worse — no point deeper below the margin, no more segments in
    boxes — so the arm can always be moved out.
    """
    q_from = tuple(float(v) for v in q_from)
    q_to = tuple(float(v) for v in q_to)
    target = assess_workspace(q_to, profile, kinematics, workspace)
    if not target.reason:
        return q_to, ""
    start = assess_workspace(q_from, profile, kinematics, workspace)
    if start.reason:
        if _no_worse(target, start):
            return q_to, target.reason

        def ok(a: WorkspaceAssessment) -> bool:
            return _no_worse(a, start)
    else:
        def ok(a: WorkspaceAssessment) -> bool:
            return not a.reason
    lo, hi = 0.0, 1.0
    best = q_from
    for _ in range(WORKSPACE_BISECTIONS):
        mid = 0.5 * (lo + hi)
        q_mid = tuple(a + mid * (b - a) for a, b in zip(q_from, q_to))
        if ok(assess_workspace(q_mid, profile, kinematics, workspace)):
            lo, best = mid, q_mid
        else:
            hi = mid
    return best, target.reason
