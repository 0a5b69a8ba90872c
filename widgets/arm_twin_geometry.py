"""What the arm twins (2D and 3D) draw, as pure numbers: their colours and sizes, and the helpers
that need no widget — projections onto the side view, joint levels, a profile's workspace,
structure and keep-out boxes, the views' extent.

All inputs are in metres in ``robot_base`` (x right, y forward, z up, desk at z = 0). Used by
``widgets.arm_twin`` (the 2D twin) and ``widgets.arm_twin_3d``; re-exported by ``widgets.arm_twin``.
"""
from __future__ import annotations

import math
from typing import Any, Mapping, Optional, Sequence

import numpy as np

from widgets.joint_readout import limit_level
M_TO_CM = 100.0
MIN_AZIMUTH_RADIUS_M = 1e-3  # below this the tool is over the base axis: keep the last azimuth

COMMANDED_COLOUR = (120, 180, 255, 170)
MEASURED_COLOUR = (255, 170, 40)
REACHABLE_COLOUR = (60, 220, 90)
UNREACHABLE_COLOUR = (240, 50, 50)
AIMED_COLOUR = (255, 235, 60)
WORKSPACE_COLOUR = (160, 160, 160, 150)
PREVIEW_COLOUR = (230, 100, 230, 110)
MARKER_COLOUR = (60, 220, 230)
DESK_COLOUR = (150, 110, 70)
STRUCTURE_COLOUR = (150, 150, 150)  # fixed parts from the profile: delta base plate, UMI-RTX column
KEEP_OUT_COLOUR = (235, 40, 40)  # the profile's keep-out boxes: red outline …
KEEP_OUT_FILL_ALPHA = 50  # … over a translucent red fill
TELEOP_HAND_COLOUR = (235, 235, 235)  # teleop: the calibrated hand volume (dashed) and the hand (not marker cyan)
TELEOP_TARGET_COLOUR = (255, 120, 200)  # teleop: the target box the hand volume maps to, the mapped point
DESK_MARGIN_COLOUR = (235, 40, 40, 160)  # the desk margin line (side view), dashed
GRID_STEP_CM = 10.0
GRID_EXTENT_CM = 200.0

# Joint levels: how close a joint is to a limit (fractions of its range, as JointReadout).
LEVELS = ("ok", "warn", "limit")
LEVEL_ALIASES = {"near": "warn", "at": "limit"}  # JointReadout.levels() spells them so
LEVEL_COLOURS = {"ok": MEASURED_COLOUR, "warn": (255, 140, 0), "limit": (235, 30, 30)}
LEVEL_DOT_PX = {"ok": 10, "warn": 17, "limit": 20}  # warn/limit dots also get a white ring

SAME_POINT_TOL_M = 1e-6  # a point that moved less has not moved: the plots are in centimetres

# Labels in the views: ids beside their dots, kept inside the view box and apart
LABEL_GAP_PX = 2.0  # between a label and its dot, and between stacked labels
LABEL_DOT_PX = 9.0  # a marker dot's size: other labels keep off it
LABEL_STACK_STEPS = 3  # how many label heights further out a crowded label may go
LABEL_MARGIN_PX = 1  # QGraphicsTextItem's document margin (its default, 4, wastes a small view)

# The legend row under a twin
LEGEND_ENTRY_GAP = "&nbsp;&nbsp;&nbsp;"  # between two entries on a line
LEGEND_SAFETY_PX = 2.0  # measured and rendered line widths may differ by rounding

PLOT_TITLE_PT = 8.0
PLOT_TITLE_ROW_PX = 16  # pyqtgraph reserves 30 px for a title; an 8 pt one needs 16
PLOT_MIN_SIZE = (160, 60)

VIEW_MARGIN_FRACTION = 0.08  # configure_for: room around the workspace …
VIEW_MARGIN_M = 0.02  # … plus this much
MIN_VIEW_HALF_WIDTH_M = 0.10
TOP_CIRCLE_POINTS = 121


# --------------------------------------------------------------------------------------------
# Pure helpers (no widgets): projections, joint levels, what to draw for a profile


def arm_azimuth(commanded: Optional[np.ndarray], measured: Optional[np.ndarray],
                previous: float = math.pi / 2) -> float:
    """Azimuth (rad) of the arm's vertical plane: atan2(y, x) of the measured tool point.

    Falls back to the commanded tool point, then to ``previous`` when there is no chain or the
    tool is right above the base axis (where the azimuth is undefined). The default previous
    value, π/2, is straight ahead (+y).
    """
    for chain in (measured, commanded):
        if chain is None or len(chain) == 0:
            continue
        tool = np.asarray(chain, dtype=float)[-1]
        if math.hypot(tool[0], tool[1]) >= MIN_AZIMUTH_RADIUS_M:
            return math.atan2(tool[1], tool[0])
        return previous
    return previous


def same_points(a: Optional[Sequence], b: Optional[Sequence], tol: float = SAME_POINT_TOL_M) -> bool:
    """True when two point sets (arrays, sequences or None) are equal within ``tol`` (m).

    Same shape and every coordinate within ``tol``; NaN equals NaN (the gaps between chains);
    None equals only None. The twins use it to skip redrawing what did not move.
    """
    if a is None or b is None:
        return a is None and b is None
    if a is b:
        return True
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape:
        return False
    d = np.abs(a - b)  # not np.allclose: 4x slower on these few points, at up to 30 calls a frame
    if (d <= tol).all():
        return True
    nan = np.isnan(a)
    return bool(nan.any() and np.array_equal(nan, np.isnan(b)) and (d[~nan] <= tol).all())


def same_chains(a: Sequence[np.ndarray], b: Sequence[np.ndarray], tol: float = SAME_POINT_TOL_M) -> bool:
    """:func:`same_points` for two lists of chains."""
    return len(a) == len(b) and all(same_points(x, y, tol) for x, y in zip(a, b))


def same_marker_points(a: Mapping[int, np.ndarray], b: Mapping[int, np.ndarray],
                       tol: float = SAME_POINT_TOL_M) -> bool:
    """:func:`same_points` for two {marker id: (3,) m} maps (same ids, same places)."""
    return a.keys() == b.keys() and all(same_points(a[k], b[k], tol) for k in a)


def side_view_coords(points_m: np.ndarray, azimuth_rad: float) -> np.ndarray:
    """Project robot_base points (N,3) onto the arm plane: (N,2) columns s, z in metres.

    s = p · (cos a, sin a, 0) is the signed horizontal distance from the base axis along the
    arm's azimuth a (positive on the tool's side); z is kept.
    """
    p = np.asarray(points_m, dtype=float).reshape(-1, 3)
    direction = np.array([math.cos(azimuth_rad), math.sin(azimuth_rad)])
    return np.column_stack([p[:, :2] @ direction, p[:, 2]])


def normalise_level(level: str) -> str:
    """"ok", "warn" or "limit" for a level; JointReadout's "near"/"at" are accepted too."""
    out = LEVEL_ALIASES.get(level, level)
    if out not in LEVELS:
        raise ValueError(f"joint level {level!r} is unknown; expected one of "
                         f"{', '.join(LEVELS)} (or {', '.join(LEVEL_ALIASES)})")
    return out


def joint_levels(q: Optional[Sequence[float]], q_min: Sequence[float],
                 q_max: Sequence[float]) -> list[str]:
    """Per joint "ok", "warn" (within 10 % of its range from a limit) or "limit" (within 2 %).

    Same thresholds as the joint table (``joint_readout.limit_level``); units do not matter
    (rad, m) since only fractions of the range count. None or NaN entries are "ok".
    """
    if q is None:
        return ["ok"] * len(q_min)
    out = []
    for i, (lo, hi) in enumerate(zip(q_min, q_max)):
        v = q[i] if i < len(q) else None
        out.append(normalise_level(limit_level(None if v is None else float(v), lo, hi)))
    return out


def profile_joint_levels(profile: Any, q: Optional[Sequence[float]]) -> list[str]:
    """:func:`joint_levels` of ``q`` (rad or m) against a RobotProfile's q_min/q_max."""
    return joint_levels(q, profile.q_min, profile.q_max)


def joint_anchors_for(profile: Any) -> list[tuple[int, int]]:
    """Where each joint's dot sits: (chain, point index), chain -1 = the measured chain,
    k ≥ 0 = extra segment k.

    - ``rrr``: chain_points are base, shoulder, elbow, tool: joint i is point i;
    - ``urdf``: chain_points are the root, each joint's origin, the tool: joint i is point i+1;
    - ``delta3``: joint i is arm i's shoulder, the first point of extra segment i
      (``DeltaKinematics.arm_segments``).
    """
    n = len(profile.joints)
    if profile.kind == "delta3":
        return [(i, 0) for i in range(n)]
    if profile.kind == "urdf":
        return [(-1, i + 1) for i in range(n)]
    return [(-1, i) for i in range(n)]


def circle_outline(radii_m: Sequence[float], n: int = TOP_CIRCLE_POINTS) -> np.ndarray:
    """Closed circles around the base axis, (M,2) x, y rows, separated by NaN rows."""
    a = np.linspace(0.0, 2.0 * math.pi, n)
    ring = np.column_stack([np.cos(a), np.sin(a)])
    parts = []
    for r in radii_m:
        if parts:
            parts.append(np.full((1, 2), np.nan))
        parts.append(float(r) * ring)
    return np.vstack(parts) if parts else np.zeros((0, 2))


def workspace_outlines(kinematics: Any, profile: Any = None) -> tuple[Optional[np.ndarray],
                                                                       Optional[np.ndarray]]:
    """(top (M,2) x, y; side (K,2) s, z) outlines of the reachable set, in metres, or None.

    Side: ``workspace_outline_side()`` as the solver gives it (NaN rows separate polylines);
    a delta's (s ≥ 0 only) is mirrored, since its side view shows a fixed plane through the
    base axis in which the tool can be on either side. Top: the circle of the largest
    horizontal reach and, when the tool cannot come near the base axis, the inner circle —
    radii from ``workspace_radius_range()`` and the side outline's horizontal extent (an RRR
    arm's radius range is measured from the shoulder, not horizontally: its outline, which
    crosses the axis, keeps the inner circle away).
    """
    side = None
    if hasattr(kinematics, "workspace_outline_side"):
        side = np.asarray(kinematics.workspace_outline_side(), dtype=float).reshape(-1, 2)
        if len(side) == 0:
            side = None
    if side is not None and profile is not None and profile.kind == "delta3":
        half = side[:-1] if np.array_equal(side[0], side[-1]) else side  # open: no edge on the axis
        side = np.vstack([half, half[::-1] * (-1.0, 1.0)])
    r_min, r_max = None, None
    if hasattr(kinematics, "workspace_radius_range"):
        r_min, r_max = (float(v) for v in kinematics.workspace_radius_range())
    if side is not None:
        s = side[np.isfinite(side).all(axis=1), 0]
        if len(s):
            outer = float(np.max(np.abs(s)))
            r_max = outer if r_max is None else max(r_max, outer)
            inner = float(np.min(s))
            r_min = 0.0 if inner <= 0.0 else (inner if r_min is None else max(r_min, inner))
    if r_max is None or not r_max > 0.0:
        return None, side
    radii = [r_max] + ([r_min] if r_min is not None and r_min > 0.02 * r_max else [])
    return circle_outline(radii), side


def structure_segments(profile: Any, kinematics: Any = None) -> list[np.ndarray]:
    """Fixed parts to draw for a profile, as (N,3) polylines in robot_base (m).

    The delta's base plate (the triangle through its shoulder axes); for a URDF arm whose first
    joint is prismatic (the UMI-RTX's column), that joint's travel, from the solver's chain at
    the joint's two limits. Other arms have none: their chain starts at the base.
    """
    if profile is None:
        return []
    if profile.kind == "delta3":
        g = profile.geometry
        corners = [(g.base_radius_m * math.cos(a), g.base_radius_m * math.sin(a), g.base_height_m)
                   for a in g.arm_azimuths_rad]
        return [np.array(corners + corners[:1])]
    if (profile.kind == "urdf" and kinematics is not None and profile.joints
            and profile.joints[0].joint_type == "prismatic"):
        q = list(_home_q(profile, kinematics))
        ends = []
        for v in (profile.q_min[0], profile.q_max[0]):
            q[0] = v
            ends.append(np.asarray(kinematics.chain_points(q), dtype=float)[1])
        return [np.array([(ends[0][0], ends[0][1], 0.0), ends[1]])]  # from the desk up
    return []


def keep_out_boxes_for(profile: Any) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """The profile's keep-out boxes as (name, min (3,), max (3,)) in m, robot_base; [] without."""
    workspace = getattr(profile, "workspace", None)
    boxes = getattr(workspace, "keep_out", ()) or ()
    return [(b.name, np.asarray(b.min_m, dtype=float), np.asarray(b.max_m, dtype=float)) for b in boxes]


def desk_margin_for(profile: Any) -> float:
    """The profile's desk margin (m): no moving arm point lower; 0 without a workspace."""
    workspace = getattr(profile, "workspace", None)
    return float(getattr(workspace, "desk_margin_m", 0.0) or 0.0)


def box_top_outline(box_min: Sequence[float], box_max: Sequence[float]) -> np.ndarray:
    """A box's footprint as a closed (5,2) x, y polyline (m)."""
    x0, y0, x1, y1 = float(box_min[0]), float(box_min[1]), float(box_max[0]), float(box_max[1])
    return np.array([(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)])


def box_side_section(box_min: Sequence[float], box_max: Sequence[float],
                     azimuth_rad: float) -> Optional[np.ndarray]:
    """Where a box cuts the side view's plane (the vertical plane through the base axis at
    ``azimuth_rad``): a closed (5,2) s, z rectangle (m), or None when the plane misses it.

    The section, not the box's shadow: the serial arms move in that plane, so what it cuts is
    what the arm can hit there; a box beside the plane shows in the top view only.
    """
    d = (math.cos(azimuth_rad), math.sin(azimuth_rad))
    s0, s1 = -math.inf, math.inf
    for axis in (0, 1):
        lo, hi = float(box_min[axis]), float(box_max[axis])
        if abs(d[axis]) < 1e-12:
            if not lo <= 0.0 <= hi:
                return None
            continue
        a, b = lo / d[axis], hi / d[axis]
        s0, s1 = max(s0, min(a, b)), min(s1, max(a, b))
    if not s0 <= s1:
        return None
    z0, z1 = float(box_min[2]), float(box_max[2])
    return np.array([(s0, z0), (s1, z0), (s1, z1), (s0, z1), (s0, z0)])


def box_side_shadow(box_min: Sequence[float], box_max: Sequence[float],
                    azimuth_rad: float) -> np.ndarray:
    """A box's shadow on the side view's plane: the closed (5,2) s, z rectangle (m) its eight
    corners project to (for the teleop boxes, which the arm reaches into from anywhere)."""
    lo, hi = np.asarray(box_min, float).reshape(3), np.asarray(box_max, float).reshape(3)
    corners = np.array([(x, y, z) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    sz = side_view_coords(corners, azimuth_rad)
    s0, s1, z0, z1 = sz[:, 0].min(), sz[:, 0].max(), lo[2], hi[2]
    return np.array([(s0, z0), (s1, z0), (s1, z1), (s0, z1), (s0, z0)])


def outlines_with_gaps(outlines: Sequence[np.ndarray]) -> np.ndarray:
    """2D polylines (each (N,2)) as one (M,2) array with NaN rows between them (empty: (0,2))."""
    parts = []
    for o in outlines:
        if parts:
            parts.append(np.full((1, 2), np.nan))
        parts.append(np.asarray(o, dtype=float).reshape(-1, 2))
    return np.vstack(parts) if parts else np.zeros((0, 2))


def chain_start_for(profile: Any) -> int:
    """Index of the first chain point to draw: 2 for the delta, whose ``chain_points`` begin
    with the desk origin and the base centre (drawing aids, no real part), else 0."""
    return 2 if profile is not None and profile.kind == "delta3" else 0


def _home_q(profile: Any, kinematics: Any) -> tuple[float, ...]:
    q = getattr(kinematics, "q_home", None)
    return tuple(profile.q_home if q is None else q)


EXTENT_SAMPLES = 200  # random in-limit configurations whose drawings set the view extent


def drawing_points(profile: Any, kinematics: Any, samples: int = EXTENT_SAMPLES) -> np.ndarray:
    """Points of the arm's drawing (chain, extra segments, structure) over the home pose and
    ``samples`` random in-limit configurations (fixed seed), (N,3) m: what the views must hold.
    """
    rng = np.random.default_rng(0)
    lo, hi = np.array(profile.q_min, dtype=float), np.array(profile.q_max, dtype=float)
    qs = [np.array(_home_q(profile, kinematics), dtype=float)]
    qs += list(rng.uniform(lo, hi, (max(0, int(samples)), len(lo))))
    start = chain_start_for(profile)
    pts = [np.asarray(kinematics.chain_points(q), dtype=float).reshape(-1, 3)[start:] for q in qs]
    if hasattr(kinematics, "arm_segments"):
        pts += [np.asarray(kinematics.arm_segments(q), dtype=float).reshape(-1, 3) for q in qs]
    pts += structure_segments(profile, kinematics)
    out = np.vstack(pts)
    return out[np.isfinite(out).all(axis=1)]


def view_extent(profile: Any, kinematics: Any) -> tuple[float, float, float]:
    """(xy half width, z min, z max) in metres that hold the workspace outlines and the arm's
    drawing in any in-limit configuration (sampled, :func:`drawing_points`).

    z min is just below the desk (-10 % of z max), or lower when the arm can reach below the
    desk plane (the assistive arm can): a collision with the desk must be seen, not cut off.
    """
    top, side = workspace_outlines(kinematics, profile)
    pts = drawing_points(profile, kinematics)
    reach = float(np.max(np.hypot(pts[:, 0], pts[:, 1]))) if len(pts) else 0.0
    z_lo = float(np.min(pts[:, 2])) if len(pts) else 0.0
    z_hi = float(np.max(pts[:, 2])) if len(pts) else 0.0
    if top is not None:
        reach = max(reach, float(np.nanmax(np.abs(top))))
    if side is not None:
        finite = side[np.isfinite(side).all(axis=1)]
        if len(finite):
            reach = max(reach, float(np.max(np.abs(finite[:, 0]))))
            z_lo = min(z_lo, float(np.min(finite[:, 1])))
            z_hi = max(z_hi, float(np.max(finite[:, 1])))
    grow = 1.0 + VIEW_MARGIN_FRACTION
    half_width = max(MIN_VIEW_HALF_WIDTH_M, reach * grow + VIEW_MARGIN_M)
    z_max = max(MIN_VIEW_HALF_WIDTH_M, z_hi * grow + VIEW_MARGIN_M)
    z_min = min(-0.1 * z_max, z_lo * grow - VIEW_MARGIN_M) if z_lo < 0.0 else -0.1 * z_max
    return half_width, z_min, z_max


def side_azimuth_for(profile: Any) -> Optional[float]:
    """A fixed side-view plane for a profile (rad), or None to follow the tool.

    The delta's tool moves around its axis, so following it would spin the side view; it
    shows arm 0's plane instead. Serial arms follow the tool's azimuth.
    """
    if profile is not None and profile.kind == "delta3":
        return float(profile.geometry.arm_azimuths_rad[0])
    return None


def polylines_with_gaps(segments: Optional[Sequence[np.ndarray]]) -> Optional[np.ndarray]:
    """Polylines (each (N,3)) as one (M,3) array with NaN rows between them, or None."""
    if segments is None:
        return None
    parts = []
    for seg in segments:
        a = np.asarray(seg, dtype=float).reshape(-1, 3)
        if len(a) == 0:
            continue
        if parts:
            parts.append(np.full((1, 3), np.nan))
        parts.append(a)
    return np.vstack(parts) if parts else None


def joint_dot_positions(levels: Optional[Sequence[str]], anchors: Optional[Sequence[tuple[int, int]]],
                        measured: Optional[np.ndarray],
                        extra_chains: Sequence[np.ndarray]) -> tuple[np.ndarray, list[str]]:
    """Where to draw the joint dots and their levels: ((k,3) m, k levels), worst level last.

    ``anchors`` as :func:`joint_anchors_for` (None: joint i on measured point i); joints whose
    anchor has no point are left out, and nothing is drawn without a measured chain. The
    worst level comes last so a red dot is never hidden under another joint's (the UMI-RTX's
    three wrist joints share one point).
    """
    if levels is None or measured is None:
        return np.zeros((0, 3)), []
    anchors = list(anchors) if anchors else [(-1, i) for i in range(len(levels))]
    found = []
    for i, (chain, index) in enumerate(anchors[:len(levels)]):
        points = measured if chain < 0 else (
            extra_chains[chain] if chain < len(extra_chains) else None)
        if points is not None and 0 <= index < len(points) and np.isfinite(points[index]).all():
            found.append((LEVELS.index(levels[i]), i, points[index]))
    found.sort(key=lambda t: (t[0], t[1]))
    if not found:
        return np.zeros((0, 3)), []
    return np.array([p for _, _, p in found], dtype=float), [levels[i] for _, i, _ in found]
