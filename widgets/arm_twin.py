"""The arm's 2D digital twin: a top view and a side view (the arm's vertical plane).

All inputs are in metres in ``robot_base`` (x right, y forward, z up, desk at z = 0); the
plots show centimetres. Both views have fixed ranges (:meth:`ArmTwin.set_view_range`, or
:meth:`ArmTwin.configure_for` from a profile's workspace), never auto-range, and reuse their
plot items, so a redraw is a handful of ``setData`` calls.

Any profile draws through the same calls: the chain from ``kinematics.chain_points(q)``, the
delta's three arms from ``DeltaKinematics.arm_segments(q)`` (:meth:`ArmTwin.set_extra_segments`),
and the joints' distance to their limits as coloured dots (:meth:`ArmTwin.set_joint_levels`,
levels from :func:`profile_joint_levels`). The helpers here that take a profile or a solver
are shared with the optional 3D view (``widgets.arm_twin_3d``).
"""
from __future__ import annotations

import html
import math
from typing import Any, Mapping, Optional, Sequence

import numpy as np
import pyqtgraph as pg
from PySide6 import QtCore, QtGui, QtWidgets

from widgets.camera_view import marker_label
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


def _swatch_words(colour: Sequence[int], glyph: str, text: str) -> list[str]:
    """A coloured glyph and its text as legend words (HTML): the glyph stays with the first word."""
    r, g, b = colour[:3]
    words = [html.escape(w) for w in text.split()] or [""]
    words[0] = (f'<span style="color: rgb({r},{g},{b}); font-weight: bold">{glyph}</span>'
                f"&nbsp;{words[0]}")
    return words


def marker_entry(marker_id: int, base_p: Sequence[float]) -> tuple[str, ...]:
    """One found marker as a legend entry (HTML words): its swatch, id and robot_base position
    in cm, e.g. "■ 23: x 3.1 y 15.2 z 0.0 cm" (the camera views' label, :func:`marker_label`)."""
    text = marker_label(int(marker_id), base_p)
    head, _, rest = text.partition(" ")  # "23:", "x 3.1 y 15.2 z 0.0 cm"
    if not rest:
        return tuple(_swatch_words(MARKER_COLOUR, "■", head))
    coords = rest.split(" ")
    # "x 3.1" never breaks between the letter and its number
    words = [html.escape(f"{coords[i]}\u00a0{coords[i + 1]}") for i in range(0, len(coords) - 1, 2)]
    if len(coords) % 2:
        words[-1] += html.escape(f"\u00a0{coords[-1]}")  # "cm" stays with z
    return tuple(_swatch_words(MARKER_COLOUR, "■", head)) + tuple(words)


def legend_entries(measured_label: str,
                   markers: Sequence[tuple[str, ...]] = ()) -> list[tuple[str, ...]]:
    """The twins' legend (chains, target, limit levels, aimed point, markers) as entries, each a
    tuple of HTML words. ``markers`` (from :func:`marker_entry`) replace the plain "■ markers"
    entry with each found marker's id and position."""
    def swatch(colour, glyph: str, text: str) -> tuple[str, ...]:
        return tuple(_swatch_words(colour, glyph, text))

    target = swatch(REACHABLE_COLOUR, "+", "target") + ("/",) + swatch(UNREACHABLE_COLOUR, "+",
                                                                       "out of reach")
    limits = swatch(LEVEL_COLOURS["warn"], "●", "near") + ("/",) + swatch(LEVEL_COLOURS["limit"],
                                                                         "●", "at limit")
    entries = [swatch(COMMANDED_COLOUR, "- -", "commanded"),
               swatch(MEASURED_COLOUR, "━●", measured_label), target, limits,
               swatch(AIMED_COLOUR, "○", "aimed")]
    return entries + (list(markers) if markers else [swatch(MARKER_COLOUR, "■", "markers")])


def teleop_legend_entries() -> list[tuple[str, ...]]:
    """The legend's teleop entries (while teleop boxes are drawn): the hand volume, the target box
    it maps to with the mapped point."""
    return [tuple(_swatch_words(TELEOP_HAND_COLOUR, "┅○", "hand")),
            tuple(_swatch_words(TELEOP_TARGET_COLOUR, "□◆", "teleop box"))]


def legend_html(measured_label: str) -> str:
    """The twins' legend row (rich text) on one line: chains, target, limit levels, aimed
    point, markers. :class:`LegendLabel` breaks it into lines that fit."""
    return LEGEND_ENTRY_GAP.join(" ".join(e) for e in legend_entries(measured_label))


def break_lines(entries: Sequence[Sequence[float]], width: float, entry_gap: float,
                word_gap: float) -> list[list[tuple[int, int, int]]]:
    """Fill lines of ``width`` px greedily with entries given as their words' widths (px).

    Lines break between entries; an entry wider than a whole line breaks between its words
    (a single word wider than the line gets a line of its own). Returns the lines, each a list
    of (entry index, first word, end word) spans.
    """
    lines: list[list[tuple[int, int, int]]] = [[]]
    used = 0.0
    for i, words in enumerate(entries):
        total = float(sum(words)) + word_gap * max(0, len(words) - 1)
        gap = entry_gap if lines[-1] else 0.0
        if used + gap + total <= width:
            lines[-1].append((i, 0, len(words)))
            used += gap + total
            continue
        if total <= width:  # on a line of its own
            lines.append([(i, 0, len(words))])
            used = total
            continue
        if lines[-1]:
            lines.append([])
        start, run = 0, 0.0
        for j, w in enumerate(words):
            if j > start and run + word_gap + w > width:
                lines[-1].append((i, start, j))
                lines.append([])
                start, run = j, float(w)
            else:
                run = float(w) if j == start else run + word_gap + w
        lines[-1].append((i, start, len(words)))
        used = run
    return [line for line in lines if line]


def place_labels(anchors: Sequence[tuple[float, float]], sizes: Sequence[tuple[float, float]],
                 bounds: tuple[float, float, float, float], gap: float = LABEL_GAP_PX,
                 dot_px: float = LABEL_DOT_PX) -> list[tuple[float, float]]:
    """Top-left corners for labels of ``sizes`` (w, h) beside their ``anchors`` (x, y), all in
    screen pixels (y down): inside ``bounds`` (x0, y0, x1, y1) and clear of each other.

    Each label tries the places around its anchor nearest first — upper right, upper left,
    lower right, lower left, then stacked further out — and takes the first one inside the
    bounds that overlaps no label placed before it nor another anchor's dot (``dot_px``
    square). When none is clear (a crowded, tiny view) it takes the one that overlaps least,
    moved inside the bounds.
    """
    x0, y0, x1, y1 = bounds
    half = 0.5 * dot_px
    dots = [(ax - half, ay - half, ax + half, ay + half) for ax, ay in anchors]
    placed: list[tuple[float, float, float, float]] = []
    out = []

    def overlap(a, b) -> float:
        w = min(a[2], b[2]) - max(a[0], b[0])
        h = min(a[3], b[3]) - max(a[1], b[1])
        return w * h if w > 0 and h > 0 else 0.0

    for k, ((ax, ay), (w, h)) in enumerate(zip(anchors, sizes)):
        xs = [ax + gap, ax - gap - w, ax + gap + (w + gap), ax - gap - w - (w + gap)]
        ys = [ay - gap - h, ay + gap] + [y for n in range(1, LABEL_STACK_STEPS + 1)
                                         for y in (ay - gap - h - n * (h + gap), ay + gap + n * (h + gap))]
        candidates = [(x, y) for y in ys for x in xs]
        # nearest first; the order above (upper right, upper left, …) breaks ties
        candidates.sort(key=lambda c: math.hypot(c[0] + 0.5 * w - ax, c[1] + 0.5 * h - ay))
        best, best_cost = None, math.inf
        for x, y in candidates:
            inside = x >= x0 and y >= y0 and x + w <= x1 and y + h <= y1
            if not inside:  # moved in; a label larger than the view keeps its start in it
                x, y = max(x0, min(x, x1 - w)), max(y0, min(y, y1 - h))
            rect = (x, y, x + w, y + h)
            cost = (1e3 * sum(overlap(rect, r) for r in placed)
                    + sum(overlap(rect, d) for i, d in enumerate(dots) if i != k))
            if not inside:
                cost += 1e-3  # a moved candidate only when no untouched one is as good
            if cost < best_cost:
                best, best_cost = (x, y), cost
                if cost == 0.0:
                    break
        x, y = best
        placed.append((x, y, x + w, y + h))
        out.append((x, y))
    return out


# --------------------------------------------------------------------------------------------
# Plot items


def _grid_pairs(step: float, extent: float) -> tuple[np.ndarray, np.ndarray]:
    """x, y of grid line segments (pairs of points) every ``step`` within ±``extent``."""
    ticks = np.arange(-extent, extent + step / 2, step)
    xs, ys = [], []
    for t in ticks:
        xs += [t, t, -extent, extent]
        ys += [-extent, extent, t, t]
    return np.array(xs), np.array(ys)


class _Plot(pg.PlotWidget):
    """A twin view: a title that names the units (no axis labels, whose rows a small view
    needs for the arm), the longest of its titles that fits its width."""

    def __init__(self, titles: Sequence[str]) -> None:
        self.titles = tuple(titles)  # longest first
        super().__init__()

    def fit_title(self) -> None:
        """Show the longest title that fits the title row (the last one when none does)."""
        item = self.getPlotItem()
        if item is None:
            return  # pyqtgraph resizes before the plot item exists
        label = item.titleLabel
        # from the widget, not the title item: the plot's layout is updated after this resize
        room = self.width() - item.getAxis("left").width() - 4.0
        font = QtGui.QFont(self.font())
        font.setPointSizeF(PLOT_TITLE_PT)
        metrics = QtGui.QFontMetricsF(font)
        margin = 2.0 * label.item.document().documentMargin()
        title = next((t for t in self.titles if metrics.horizontalAdvance(t) + margin <= room),
                     self.titles[-1])
        if title != label.text:
            item.setTitle(title, size=f"{PLOT_TITLE_PT:g}pt")
            item.layout.setRowFixedHeight(0, PLOT_TITLE_ROW_PX)
            label.setMaximumHeight(PLOT_TITLE_ROW_PX)

    def resizeEvent(self, event) -> None:  # noqa: N802 (Qt override)
        super().resizeEvent(event)
        self.fit_title()


def _make_plot(*titles: str) -> _Plot:
    """A fixed-range, aspect-locked view with a 10 cm grid; ``titles`` longest first."""
    plot = _Plot(titles)
    plot.setMinimumSize(*PLOT_MIN_SIZE)
    item = plot.getPlotItem()
    plot.fit_title()
    # pyqtgraph's showGrid() costs ~6 ms per view per repaint in software rendering; a fixed
    # 10 cm grid drawn as one curve of line pairs costs a fraction of that.
    grid = pg.PlotCurveItem(*_grid_pairs(GRID_STEP_CM, GRID_EXTENT_CM), connect="pairs",
                            pen=pg.mkPen(255, 255, 255, 40, width=1))
    grid.setZValue(-20)
    item.addItem(grid)
    item.setMouseEnabled(x=False, y=False)
    item.setMenuEnabled(False)
    item.hideButtons()
    item.disableAutoRange()
    item.setAspectLocked(True)
    return plot


class _ViewItems:
    """The reusable plot items of one view (top or side)."""

    def __init__(self, plot: pg.PlotWidget) -> None:
        self.plot = plot
        self.workspace = pg.PlotCurveItem(pen=pg.mkPen(WORKSPACE_COLOUR, width=1,
                                                       style=QtCore.Qt.PenStyle.DashLine),
                                          connect="finite")
        self.structure = pg.PlotCurveItem(pen=pg.mkPen(STRUCTURE_COLOUR, width=3),
                                          connect="finite")
        # keep-out boxes: closed outlines (NaN rows between boxes), each filled translucent red
        self.keep_out = pg.PlotCurveItem(pen=pg.mkPen(KEEP_OUT_COLOUR, width=2), connect="finite",
                                         fillLevel="enclosed",
                                         brush=pg.mkBrush(*KEEP_OUT_COLOUR, KEEP_OUT_FILL_ALPHA))
        self.keep_out.setVisible(False)
        self.preview = pg.PlotDataItem(pen=pg.mkPen(PREVIEW_COLOUR, width=1))
        self.commanded = pg.PlotDataItem(pen=pg.mkPen(COMMANDED_COLOUR, width=2,
                                                      style=QtCore.Qt.PenStyle.DashLine))
        # the extra chains (the delta's arms): one curve, NaN rows between the chains
        self.extra = pg.PlotCurveItem(pen=pg.mkPen(MEASURED_COLOUR, width=4), connect="finite")
        self.extra_points = pg.ScatterPlotItem(symbol="o", size=8,
                                               brush=pg.mkBrush(MEASURED_COLOUR),
                                               pen=pg.mkPen("k", width=1))
        self.measured = pg.PlotDataItem(pen=pg.mkPen(MEASURED_COLOUR, width=5),
                                        symbol="o", symbolSize=10,
                                        symbolBrush=pg.mkBrush(MEASURED_COLOUR),
                                        symbolPen=pg.mkPen("k", width=1))
        self.joints = pg.ScatterPlotItem(symbol="o")
        self.aim_line = pg.PlotDataItem(pen=pg.mkPen(AIMED_COLOUR, width=1,
                                                     style=QtCore.Qt.PenStyle.DotLine))
        self.aimed = pg.ScatterPlotItem(symbol="o", size=14, brush=None,
                                        pen=pg.mkPen(AIMED_COLOUR, width=2))
        self.target = pg.ScatterPlotItem(symbol="+", size=22, pen=pg.mkPen(REACHABLE_COLOUR,
                                                                          width=3))
        self.markers = pg.ScatterPlotItem(symbol="s", size=9, brush=pg.mkBrush(MARKER_COLOUR),
                                          pen=pg.mkPen("k", width=1))
        self.base = pg.ScatterPlotItem([0.0], [0.0], symbol="s", size=12,
                                       brush=pg.mkBrush(90, 90, 90), pen=pg.mkPen("w"))
        self.marker_labels: list[pg.TextItem] = []
        self._label_points = np.zeros((0, 2))  # where the shown labels' dots are, (n,2) view cm
        self.joints.setVisible(False)
        self.extra_points.setVisible(False)
        for z, item in enumerate((self.keep_out, self.workspace, self.structure, self.preview, self.base,
                                  self.markers, self.commanded, self.extra, self.extra_points,
                                  self.measured, self.joints, self.aim_line, self.aimed,
                                  self.target)):
            item.setZValue(z)
            plot.addItem(item)
        self.view_box = plot.getPlotItem().vb
        # a label's size in view units changes with the view's scale: lay them out again
        self.view_box.sigTransformChanged.connect(self.layout_labels)

    def set_marker_labels(self, ids: Sequence[int], xy_cm: np.ndarray) -> None:
        """Label the marker dots at ``xy_cm`` (n,2) with their ids, laid out by
        :meth:`layout_labels`."""
        while len(self.marker_labels) < len(ids):
            label = pg.TextItem(color=MARKER_COLOUR, anchor=(0.0, 0.0),
                                fill=pg.mkBrush(0, 0, 0, 140))
            label.textItem.document().setDocumentMargin(LABEL_MARGIN_PX)
            label.setZValue(20)
            self.plot.addItem(label, ignoreBounds=True)
            self.marker_labels.append(label)
        for label, marker_id in zip(self.marker_labels, ids):
            if label.toPlainText() != str(marker_id):
                label.setText(str(marker_id))
            if not label.isVisible():  # TextItem.setVisible(True) re-computes its transform
                label.setVisible(True)
        for label in self.marker_labels[len(ids):]:
            if label.isVisible():
                label.setVisible(False)
        self._label_points = np.asarray(xy_cm, dtype=float).reshape(-1, 2)[:len(ids)]
        self.layout_labels()

    def shown_labels(self) -> list[pg.TextItem]:
        """The marker labels in use, in id order."""
        return self.marker_labels[:len(self._label_points)]

    def layout_labels(self, *_: object) -> None:
        """Place each label beside its dot, inside the view box and off the other labels
        (:func:`place_labels`, in scene pixels)."""
        n = len(self._label_points)
        if n == 0:
            return
        vb = self.view_box
        box = vb.sceneBoundingRect()
        if box.width() <= 0 or box.height() <= 0:
            return  # not laid out yet: sigTransformChanged comes back
        anchors = []
        for x, y in self._label_points:
            p = vb.mapViewToScene(QtCore.QPointF(float(x), float(y)))
            anchors.append((p.x(), p.y()))
        labels = self.marker_labels[:n]
        sizes = [(r.width(), r.height()) for r in (lb.textItem.boundingRect() for lb in labels)]
        corners = place_labels(anchors, sizes, (box.left(), box.top(), box.right(), box.bottom()))
        for label, (x, y) in zip(labels, corners):
            label.setPos(vb.mapSceneToView(QtCore.QPointF(x, y)))


def _xy(points: Optional[np.ndarray], cols: slice = slice(0, 2)) -> tuple[np.ndarray, np.ndarray]:
    if points is None or len(points) == 0:
        return np.empty(0), np.empty(0)
    a = np.asarray(points, dtype=float)[:, cols] * M_TO_CM
    return a[:, 0], a[:, 1]


def _set_points(item: pg.ScatterPlotItem, x: np.ndarray, y: np.ndarray, **kwargs) -> None:
    """setData, hiding the item when empty (an empty scatter still costs ~0.15 ms a paint).

    Emptying an item that is already hidden (so empty) does nothing: the aimed point and the
    like are usually absent, every frame.
    """
    if len(x) == 0 and not item.isVisible():
        return
    item.setData(x, y, **kwargs)
    item.setVisible(len(x) > 0)


def _set_curve(item: pg.PlotDataItem, x: np.ndarray, y: np.ndarray) -> None:
    """setData, skipped when emptying a curve that is already empty (preview, aim line)."""
    if len(x) == 0 and getattr(item, "_deskarm_empty", False):
        return
    item.setData(x, y)
    item._deskarm_empty = len(x) == 0


def _finite_rows(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    keep = np.isfinite(x) & np.isfinite(y)
    return x[keep], y[keep]


class LegendLabel(QtWidgets.QLabel):
    """The legend under a twin: entries (rich text) that wrap between entries, never inside
    one unless it is wider than the whole row, so no entry is ever cut.

    The label breaks its lines itself (:func:`break_lines`) for its width, on every resize
    and on :meth:`set_entries`; its height follows the line count. (QLabel's own word wrap
    would make it a height-for-width widget, which makes parent layouts over-allocate height.)

    Signals: none.
    """

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._entries: list[tuple[str, ...]] = []
        self._lines: list[list[tuple[int, int, int]]] = []
        self._widths: dict[str, float] = {}
        self._broken_for = -1  # the text width the lines were broken for
        self.setTextFormat(QtCore.Qt.TextFormat.RichText)
        self.setWordWrap(False)
        # the width is the twin's; the height is what the lines need
        self.setSizePolicy(QtWidgets.QSizePolicy.Policy.Ignored,
                           QtWidgets.QSizePolicy.Policy.Fixed)
        font = self.font()
        font.setPointSizeF(max(7.0, font.pointSizeF() * 0.85))
        self.setFont(font)
        # same dark background as the plots, so the plot colours read the same
        self.setStyleSheet("QLabel { background: black; color: #dddddd; }")
        self.setContentsMargins(4, 2, 4, 2)  # not in the style sheet: contentsRect() holds them

    def set_entries(self, entries: Sequence[Sequence[str]]) -> None:
        """Show these entries, each a sequence of HTML words (:func:`legend_entries`)."""
        entries = [tuple(e) for e in entries]
        if entries == self._entries:
            return
        self._entries = entries
        self._relayout(force=True)

    def entries(self) -> list[tuple[str, ...]]:
        """The entries as set."""
        return list(self._entries)

    def line_count(self) -> int:
        """How many lines the legend takes at its current width."""
        return len(self._lines)

    def lines_text(self) -> list[str]:
        """Each line as plain text (for tests and accessibility)."""
        return [_plain(html_line) for html_line in self.text().split("<br>")] if self.text() else []

    def height_for_width(self, width: int) -> int:
        """The height (px) the legend takes when the label is ``width`` px wide."""
        m = self.contentsMargins()
        lines = break_lines(self._entry_widths(), max(1.0, width - m.left() - m.right()
                                                      - LEGEND_SAFETY_PX), *self._gaps())
        doc = QtGui.QTextDocument()  # as QLabel lays out rich text
        doc.setDefaultFont(self.font())
        doc.setDocumentMargin(0)
        doc.setHtml("<br>".join(["x"] * max(1, len(lines))))
        return math.ceil(doc.size().height()) + m.top() + m.bottom()

    def text_width(self) -> int:
        """The width (px) the lines must fit: the label's minus its margins."""
        return self.contentsRect().width()

    def resizeEvent(self, event) -> None:  # noqa: N802 (Qt override)
        super().resizeEvent(event)
        if event.size().width() != event.oldSize().width():
            self._relayout()

    def changeEvent(self, event) -> None:  # noqa: N802 (Qt override)
        super().changeEvent(event)
        if event.type() == QtCore.QEvent.Type.FontChange:
            self._widths.clear()
            self._relayout(force=True)

    def _measure(self, fragment: str) -> float:
        width = self._widths.get(fragment)
        if width is None:
            if len(self._widths) > 512:  # marker positions make new words every frame
                self._widths.clear()
            doc = QtGui.QTextDocument()
            doc.setDefaultFont(self.font())
            doc.setDocumentMargin(0)
            doc.setHtml(fragment)
            width = self._widths[fragment] = doc.idealWidth()
        return width

    def _entry_widths(self) -> list[list[float]]:
        return [[self._measure(w) for w in entry] for entry in self._entries]

    def _gaps(self) -> tuple[float, float]:
        """(between entries, between words) in px."""
        metrics = QtGui.QFontMetricsF(self.font())
        return 3.0 * metrics.horizontalAdvance("\u00a0"), metrics.horizontalAdvance(" ")

    def _relayout(self, force: bool = False) -> None:
        width = self.text_width()
        if not force and width == self._broken_for:
            return
        self._broken_for = width
        self._lines = break_lines(self._entry_widths(), max(1.0, width - LEGEND_SAFETY_PX),
                                  *self._gaps())
        text = "<br>".join(LEGEND_ENTRY_GAP.join(" ".join(self._entries[i][a:b]) for i, a, b in line)
                           for line in self._lines)
        if text != self.text():
            self.setText(text)  # updates the geometry: a new line count gives a new height


def _plain(fragment: str) -> str:
    """Plain text of an HTML fragment, non-breaking spaces as spaces."""
    return QtGui.QTextDocumentFragment.fromHtml(fragment).toPlainText().replace("\u00a0", " ")


def make_legend_label() -> LegendLabel:
    """The legend row under a twin (2D or 3D): small rich text on the plots' black."""
    return LegendLabel()


class TwinBase:
    """The part of the 2D and 3D twins' API that is the same: target and aimed point, joint-level
    colouring and the legend's name for the measured arm. A subclass sets ``_levels = None``
    and ``_measured_label``, and provides ``legend_label``, ``_colour_target``,
    ``_draw_target`` and ``_draw_joints``."""

    _levels: Optional[list[str]]
    _measured_label: str
    # True: every set_* call redraws, even when nothing moved (the window's redraw-all mode,
    # the baseline of bench/bench_window.py); False: a call with what is drawn is skipped
    redraw_unchanged = False
    _coloured_reachable: Optional[bool] = None  # the reachability the target is coloured for

    def _take_arm(self, commanded, measured) -> bool:
        """Keep the chains (N,3 m, or None) of ``set_arm``; False when both are where they were
        drawn (:func:`same_points`) and nothing needs drawing."""
        commanded = None if commanded is None else np.asarray(commanded, dtype=float)
        measured = None if measured is None else np.asarray(measured, dtype=float)
        if (not self.redraw_unchanged and same_points(commanded, self._commanded)
                and same_points(measured, self._measured)):
            return False  # the arm holds still
        self._commanded, self._measured = commanded, measured
        return True

    def set_joint_levels(self, levels: Optional[Sequence[str]]) -> None:
        """Colour the measured arm's joint dots: per joint "ok", "warn" (orange) or "limit"
        (red); None hides them. See :func:`profile_joint_levels`.

        JointReadout's "near"/"at" are accepted too. Without ``configure_for`` joint i's dot is
        point i of the measured chain (the RRR arm's layout).
        """
        new = None if levels is None else [normalise_level(v) for v in levels]
        if new == self._levels:  # the usual frame: set_arm already moved the dots
            return
        self._levels = new
        self._draw_joints()

    def joint_levels(self) -> Optional[list[str]]:
        """The levels last set with :meth:`set_joint_levels` (normalised), or None."""
        return None if self._levels is None else list(self._levels)

    def set_measured_label(self, text: str) -> None:
        """Rename the measured chain in the legend, e.g. "commanded (no feedback)"."""
        if text == self._measured_label and not self.redraw_unchanged:
            return
        self._measured_label = text
        self._update_legend()

    _marker_entries: tuple[tuple[str, ...], ...] = ()  # the legend's rows for found markers

    def _update_legend(self) -> None:
        self.legend_label.set_entries(legend_entries(self._measured_label, self._marker_entries))

    def _show_marker_positions(self, markers: Mapping[int, np.ndarray]) -> None:
        """Each marker's id and position (cm) in the legend: readable at any size."""
        entries = tuple(marker_entry(i, markers[i]) for i in sorted(markers))
        if entries != self._marker_entries:
            self._marker_entries = entries
            self._update_legend()

    def marker_texts(self) -> list[str]:
        """The markers' rows in the legend as plain text, e.g. "■ 23: x 3.1 y 15.2 z 0.0 cm"."""
        return [_plain(" ".join(e)) for e in self._marker_entries]

    def legend_text(self) -> str:
        """The legend as plain text, one line per row shown (for tests and accessibility)."""
        return "\n".join(self.legend_label.lines_text())

    def set_target(self, p: Optional[Sequence[float]], reachable: bool = True) -> None:
        """Draw the target point (m), green when reachable, red when not."""
        target = None if p is None else np.asarray(p, dtype=float).reshape(3)
        reachable = bool(reachable)
        recolour = reachable != self._coloured_reachable or self.redraw_unchanged
        if not recolour and same_points(target, self._target):
            return  # the usual frame while the arm holds a target
        self._target, self._reachable = target, reachable
        if recolour:
            self._coloured_reachable = reachable
            self._colour_target(REACHABLE_COLOUR if reachable else UNREACHABLE_COLOUR)
        self._draw_target()

    def set_aimed_point(self, p: Optional[Sequence[float]]) -> None:
        """Draw the point actually aimed at (nearest reachable), linked to the target."""
        aimed = None if p is None else np.asarray(p, dtype=float).reshape(3)
        if same_points(aimed, self._aimed) and not self.redraw_unchanged:
            return
        self._aimed = aimed
        self._draw_target()

    def _colour_target(self, colour: str) -> None:  # pragma: no cover - every twin overrides
        raise NotImplementedError

    def _draw_target(self) -> None:  # pragma: no cover - every twin overrides it
        raise NotImplementedError

    def _draw_joints(self) -> None:  # pragma: no cover - every twin overrides it
        raise NotImplementedError


class ArmTwin(TwinBase, QtWidgets.QWidget):
    """Top view (x, y) and side view (s, z) of the arm, its target, markers and workspace.

    The side view shows the vertical plane through the base axis at the arm's azimuth (from
    the measured, else commanded, tool point, unless pinned with :meth:`set_side_azimuth`);
    every 3D point is projected onto it with :func:`side_view_coords`. The two plots sit side
    by side on wide widgets and stacked on tall ones. Inputs are metres in robot_base; the
    plots are in centimetres. Marker ids label their dots inside each view, laid out so they
    never overlap (:func:`place_labels`); the legend under the plots (:class:`LegendLabel`)
    wraps to fit and lists each marker's id and position in cm.

    Signals: none (display only).
    """

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._azimuth = math.pi / 2
        self._fixed_azimuth: Optional[float] = None
        self._commanded: Optional[np.ndarray] = None
        self._measured: Optional[np.ndarray] = None
        self._extra: Optional[np.ndarray] = None  # (M,3) chains with NaN rows between them
        self._extra_chains: list[np.ndarray] = []
        self._levels: Optional[list[str]] = None
        self._anchors: Optional[list[tuple[int, int]]] = None
        self._target: Optional[np.ndarray] = None
        self._reachable = True
        self._aimed: Optional[np.ndarray] = None
        self._preview: Optional[np.ndarray] = None
        self._markers: dict[int, np.ndarray] = {}
        self._structure: Optional[np.ndarray] = None
        self._chain_start = 0  # chain points before this index are not drawn (chain_start_for)
        self._keep_out: list[tuple[str, np.ndarray, np.ndarray]] = []  # (name, min, max) m
        self._desk_margin = 0.0  # m; the side view's dashed line
        self._drawn_keep_out_azimuth: Optional[float] = None  # the side sections are for this plane
        # teleoperation (set_teleop): boxes as (lo, hi) tuples in m, points (3,) m
        self._teleop_boxes: tuple = (None, None)  # (hand volume, target box)
        self._teleop_points: tuple = (None, None)  # (hand, mapped point)
        self._level_brush = {k: pg.mkBrush(*LEVEL_COLOURS[k]) for k in LEVELS}
        self._level_pen = {"ok": pg.mkPen("k", width=1), "warn": pg.mkPen("w", width=2),
                           "limit": pg.mkPen("w", width=2)}

        self.top_plot = _make_plot("Top view (x, y cm)", "Top view (cm)", "Top")
        self.side_plot = _make_plot("Side view: arm plane (s, z cm)", "Side view (s, z cm)",
                                    "Side view", "Side")
        self._top = _ViewItems(self.top_plot)
        self._side = _ViewItems(self.side_plot)

        desk = pg.PlotDataItem([-1e4, 1e4], [0.0, 0.0], pen=pg.mkPen(DESK_COLOUR, width=2),
                               fillLevel=-1e4, brush=pg.mkBrush(*DESK_COLOUR, 60))
        desk.setZValue(-10)
        self.side_plot.addItem(desk)
        self._margin_line = pg.PlotDataItem(pen=pg.mkPen(DESK_MARGIN_COLOUR, width=1,
                                                         style=QtCore.Qt.PenStyle.DashLine))
        self._margin_line.setZValue(-9)
        self._margin_line.setVisible(False)
        self.side_plot.addItem(self._margin_line)
        self._teleop_items = {view: self._make_teleop_items(plot)
                              for view, plot in (("top", self.top_plot), ("side", self.side_plot))}

        # The legend is a row of text under the plots rather than a pg.LegendItem: on a small
        # screen an in-plot legend hides the arm, and pyqtgraph's hides a curve when tapped.
        self._measured_label = "measured"
        self.legend_label = make_legend_label()
        self._update_legend()

        self._layout = QtWidgets.QBoxLayout(QtWidgets.QBoxLayout.Direction.LeftToRight)
        self._layout.setContentsMargins(0, 0, 0, 0)
        self._layout.setSpacing(4)
        self._layout.addWidget(self.top_plot, 1)
        self._layout.addWidget(self.side_plot, 1)
        outer = QtWidgets.QVBoxLayout(self)
        outer.setContentsMargins(0, 0, 0, 0)
        outer.setSpacing(0)
        outer.addLayout(self._layout, 1)
        outer.addWidget(self.legend_label)
        self.set_view_range(0.25, 0.30)

    # ----------------------------------------------------------------------------- public API
    @property
    def azimuth(self) -> float:
        """The azimuth (rad) of the plane the side view shows."""
        return self._azimuth

    def set_view_range(self, xy_half_width_m: float, z_max_m: float,
                       z_min_m: Optional[float] = None) -> None:
        """Fix both views' ranges: x, y, s in ±half width, z from ``z_min_m`` (default: just
        below the desk, -10 % of z max) to ``z_max_m``."""
        hw = xy_half_width_m * M_TO_CM
        z_max = z_max_m * M_TO_CM
        z_min = -0.1 * z_max if z_min_m is None else z_min_m * M_TO_CM
        self.top_plot.setRange(xRange=(-hw, hw), yRange=(-hw, hw), padding=0.0)
        self.side_plot.setRange(xRange=(-hw, hw), yRange=(z_min, z_max), padding=0.0)

    def configure_for(self, profile: Any, kinematics: Any) -> None:
        """Set up the views for a robot profile and its solver (call again on a profile change).

        View ranges that hold the workspace and the arm in any in-limit configuration
        (:func:`view_extent`), the workspace outlines (:func:`workspace_outlines`), fixed parts
        (:func:`structure_segments`: the delta's base plate, the UMI-RTX's column), the joint
        dots' places (:func:`joint_anchors_for`), the chain points to draw
        (:func:`chain_start_for`) and a fixed side-view plane for the delta
        (:func:`side_azimuth_for`). Clears the arm, its extra segments and joint levels, which
        belonged to the previous profile.
        """
        half_width, z_min, z_max = view_extent(profile, kinematics)
        self.set_view_range(half_width, z_max, z_min)
        self.set_workspace(*workspace_outlines(kinematics, profile))
        self._anchors = joint_anchors_for(profile)
        self._chain_start = chain_start_for(profile)
        self._structure = polylines_with_gaps(structure_segments(profile, kinematics))
        self._top.structure.setData(*_xy(self._structure), connect="finite")
        self._levels = None
        self.set_keep_out(keep_out_boxes_for(profile), desk_margin_for(profile))
        self.set_extra_segments(None)
        self.set_arm(None, None)
        self.set_side_azimuth(side_azimuth_for(profile))

    def set_keep_out(self, boxes: Sequence[tuple[str, Sequence[float], Sequence[float]]],
                     desk_margin_m: float = 0.0) -> None:
        """Draw keep-out boxes — (name, min, max) in m, robot_base — outlined in translucent red:
        their footprints in the top view and their section by the arm plane in the side view;
        and the desk margin as a dashed red line in the side view (none when 0)."""
        self._keep_out = [(str(n), np.asarray(lo, dtype=float).reshape(3), np.asarray(hi, dtype=float).reshape(3))
                          for n, lo, hi in boxes]
        self._desk_margin = float(desk_margin_m)
        top = outlines_with_gaps([box_top_outline(lo, hi) for _, lo, hi in self._keep_out]) * M_TO_CM
        self._top.keep_out.setData(top[:, 0], top[:, 1], connect="finite")
        self._top.keep_out.setVisible(len(top) > 0)
        if self._desk_margin > 0.0:
            z = self._desk_margin * M_TO_CM
            self._margin_line.setData([-1e4, 1e4], [z, z])
        self._margin_line.setVisible(self._desk_margin > 0.0)
        self._drawn_keep_out_azimuth = None
        self._draw_side_keep_out()

    def keep_out_outlines(self, view: str = "top") -> np.ndarray:
        """The keep-out outlines drawn in ``view``: (M,2) cm, x, y ("top") or s, z ("side"),
        NaN rows between boxes; (0,2) when none is drawn."""
        item = (self._top if view == "top" else self._side).keep_out
        if not item.isVisible():
            return np.zeros((0, 2))
        x, y = item.getData()
        return np.column_stack([x, y]) if x is not None else np.zeros((0, 2))

    def desk_margin_line_cm(self) -> Optional[float]:
        """Height (cm) of the desk margin line in the side view, or None when not drawn."""
        if not self._margin_line.isVisible():
            return None
        return float(self._margin_line.getData()[1][0])

    def set_side_azimuth(self, azimuth_rad: Optional[float]) -> None:
        """Pin the side view to the vertical plane at ``azimuth_rad`` (rad), or None to follow
        the tool's azimuth (the default)."""
        self._fixed_azimuth = None if azimuth_rad is None else float(azimuth_rad)
        if self._fixed_azimuth is not None:
            self._azimuth = self._fixed_azimuth
        else:
            self._azimuth = arm_azimuth(self._commanded, self._measured, self._azimuth)
        self._redraw_side()

    def set_arm(self, commanded: Optional[np.ndarray], measured: Optional[np.ndarray]) -> None:
        """Draw the commanded (dashed) and measured (thick) chains, (N,3) base→tool, or None.

        Nothing is redrawn when both chains are where they were drawn (:func:`same_points`).
        """
        if not self._take_arm(commanded, measured):
            return
        if self._fixed_azimuth is None:
            azimuth = arm_azimuth(self._commanded, self._measured, self._azimuth)
        else:
            azimuth = self._fixed_azimuth
        moved = abs(azimuth - self._azimuth) > 1e-4
        self._azimuth = azimuth
        for chain, top, side in ((self._commanded, self._top.commanded, self._side.commanded),
                                 (self._measured, self._top.measured, self._side.measured)):
            chain = self._drawn(chain)
            top.setData(*_xy(chain))
            side.setData(*self._side_xy(chain))
        if moved:
            self._redraw_side_extras()
        self._draw_joints()

    def set_extra_segments(self, segments: Optional[Sequence[np.ndarray]]) -> None:
        """Draw more chains beside the measured one, each (N,3) m, or None to clear.

        For the delta: ``DeltaKinematics.arm_segments(q)`` (3 arms × shoulder, elbow,
        effector joint, effector centre), drawn in the measured arm's colour.
        """
        chains = [] if segments is None else [np.asarray(s, dtype=float).reshape(-1, 3) for s in segments]
        if same_chains(chains, self._extra_chains) and not self.redraw_unchanged:
            return
        self._extra_chains = chains
        self._extra = polylines_with_gaps(self._extra_chains)
        self._draw_extra(self._top, _xy)
        self._draw_extra(self._side, self._side_xy)
        self._draw_joints()


    def _update_legend(self) -> None:
        entries = legend_entries(self._measured_label, self._marker_entries)
        if getattr(self, "_teleop_boxes", (None, None)) != (None, None):
            entries += teleop_legend_entries()
        self.legend_label.set_entries(entries)

    def _colour_target(self, colour: str) -> None:
        pen = pg.mkPen(colour, width=3)  # a cross in both views
        self._top.target.setPen(pen)
        self._side.target.setPen(pen)

    def set_workspace(self, top_outline: Optional[np.ndarray],
                      side_outline: Optional[np.ndarray]) -> None:
        """Draw the reachable outlines: top (M,2) x, y and side (K,2) s, z, in metres.

        NaN rows separate polylines (each drawn as given, e.g. an RRR arm's extra arcs); an
        outline without NaN rows is closed.
        """
        for outline, item in ((top_outline, self._top.workspace),
                              (side_outline, self._side.workspace)):
            if outline is None or len(outline) == 0:
                item.setData([], [])
                continue
            a = np.asarray(outline, dtype=float).reshape(-1, 2) * M_TO_CM
            if np.isfinite(a).all() and not np.array_equal(a[0], a[-1]):
                a = np.vstack([a, a[:1]])  # closed
            item.setData(a[:, 0], a[:, 1], connect="finite")

    def set_preview(self, points: Optional[np.ndarray]) -> None:
        """Draw a faint preview curve (P,3) in both views (e.g. the Lissajous path)."""
        self._preview = None if points is None else np.asarray(points, dtype=float).reshape(-1, 3)
        _set_curve(self._top.preview, *_xy(self._preview))
        _set_curve(self._side.preview, *self._side_xy(self._preview))

    def set_markers(self, points: Mapping[int, np.ndarray]) -> None:
        """Draw marker positions {id: (3,) m} as dots with their ids in both views, and list
        each one's id and position (x, y, z cm in robot_base) in the legend."""
        markers = {int(k): np.asarray(v, dtype=float).reshape(3) for k, v in points.items()}
        if same_marker_points(markers, self._markers) and not self.redraw_unchanged:
            return
        self._markers = markers
        ids = sorted(self._markers)
        xyz = np.array([self._markers[i] for i in ids]).reshape(-1, 3)
        top = xyz[:, :2] * M_TO_CM
        _set_points(self._top.markers, top[:, 0], top[:, 1])
        self._top.set_marker_labels(ids, top)
        self._draw_side_markers()
        self._show_marker_positions(self._markers)

    def set_teleop(self, hand_box=None, target_box=None, base_p_hand=None, base_p_mapped=None) -> None:
        """Teleoperation in both views: the calibrated hand volume (dashed, white), the target box it
        maps to (pink), the hand (white ring) and the mapped point (pink diamond, on the target cross). Boxes are
        ``core.motion.teleop.Box`` (or anything with ``lo``/``hi``) in m, robot_base, or None; all
        None clears. Only what changed is set again (the window calls this with every draw)."""
        boxes = tuple(None if b is None else (tuple(map(float, b.lo)), tuple(map(float, b.hi)))
                      for b in (hand_box, target_box))
        points = tuple(None if p is None else np.asarray(p, dtype=float).reshape(3)
                       for p in (base_p_hand, base_p_mapped))
        if boxes != self._teleop_boxes or self.redraw_unchanged:
            legend = (boxes != (None, None)) != (self._teleop_boxes != (None, None))
            self._teleop_boxes = boxes
            self._draw_teleop_boxes("top")
            self._draw_teleop_boxes("side")
            if legend:  # the legend names the boxes while they are drawn (no labels in the small plots)
                self._update_legend()
        if (self.redraw_unchanged or not all(same_points(a, b) for a, b in zip(points, self._teleop_points))):
            self._teleop_points = points
            self._draw_teleop_points("top")
            self._draw_teleop_points("side")

    def teleop_drawn(self, view: str = "top") -> dict[str, np.ndarray]:
        """What the teleop items show in ``view`` (cm): {"hand_box", "target_box": (5,2) outlines,
        "hand", "mapped": (1,2) points}; only the visible ones."""
        out = {}
        for name, item in self._teleop_items[view].items():
            if not item.isVisible():
                continue
            x, y = item.getData()
            out[name] = np.column_stack([x, y])
        return out

    def marker_labels(self, view: str = "top") -> list[pg.TextItem]:
        """The id labels shown in ``view`` ("top" or "side"), in id order."""
        return (self._top if view == "top" else self._side).shown_labels()

    def joint_dots(self, view: str = "top") -> list[tuple[float, float, str]]:
        """The joint dots drawn in ``view``: (x, y) cm in "top", (s, z) cm in "side", and the
        level, worst last."""
        item = (self._top if view == "top" else self._side).joints
        if not item.isVisible():
            return []
        return [(float(p.pos().x()), float(p.pos().y()), p.data()) for p in item.points()]

    # ----------------------------------------------------------------------------- internals
    def _side_xy(self, points: Optional[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        if points is None or len(points) == 0:
            return np.empty(0), np.empty(0)
        sz = side_view_coords(points, self._azimuth) * M_TO_CM
        return sz[:, 0], sz[:, 1]

    def _drawn(self, chain: Optional[np.ndarray]) -> Optional[np.ndarray]:
        return chain if chain is None or not self._chain_start else chain[self._chain_start:]

    def _redraw_side(self) -> None:
        """Re-project everything in the side view (after the azimuth changed)."""
        for chain, item in ((self._commanded, self._side.commanded),
                            (self._measured, self._side.measured)):
            item.setData(*self._side_xy(self._drawn(chain)))
        self._side.structure.setData(*self._side_xy(self._structure), connect="finite")
        self._redraw_side_extras()
        self._draw_joints()

    def _draw_side_keep_out(self) -> None:
        """The boxes' sections by the side view's plane (only when the plane moved)."""
        if self._drawn_keep_out_azimuth == self._azimuth:
            return
        self._drawn_keep_out_azimuth = self._azimuth
        item = self._side.keep_out
        sections = [box_side_section(lo, hi, self._azimuth) for _, lo, hi in self._keep_out]
        side = outlines_with_gaps([sec for sec in sections if sec is not None]) * M_TO_CM
        if len(side) == 0 and not item.isVisible():
            return
        item.setData(side[:, 0], side[:, 1], connect="finite")
        item.setVisible(len(side) > 0)

    def _redraw_side_extras(self) -> None:
        """Re-project what depends on the azimuth (target, preview, markers, extra chains,
        keep-out sections)."""
        self._draw_side_keep_out()
        _set_curve(self._side.preview, *self._side_xy(self._preview))
        self._draw_extra(self._side, self._side_xy)
        self._draw_target()
        self._draw_side_markers()
        if any(b is not None for b in self._teleop_boxes):
            self._draw_teleop_boxes("side")
        if any(p is not None for p in self._teleop_points):
            self._draw_teleop_points("side")

    def _draw_extra(self, view: _ViewItems, project) -> None:
        if self._extra is None and not view.extra_points.isVisible():
            return  # nothing drawn, nothing to draw (serial arms, every frame)
        x, y = project(self._extra)
        view.extra.setData(x, y, connect="finite")
        _set_points(view.extra_points, *_finite_rows(x, y))

    def _draw_joints(self) -> None:
        if (self._levels is None or self._measured is None) and not self._top.joints.isVisible():
            return  # nothing drawn, nothing to draw
        pts, levels = joint_dot_positions(self._levels, self._anchors, self._measured,
                                          self._extra_chains)
        kwargs = dict(brush=[self._level_brush[v] for v in levels],
                      pen=[self._level_pen[v] for v in levels],
                      size=[LEVEL_DOT_PX[v] for v in levels], data=levels)
        _set_points(self._top.joints, *_xy(pts), **kwargs)
        _set_points(self._side.joints, *self._side_xy(pts), **kwargs)

    @staticmethod
    def _make_teleop_items(plot: pg.PlotWidget) -> dict:
        items = {
            "hand_box": pg.PlotCurveItem(pen=pg.mkPen(TELEOP_HAND_COLOUR, width=2, style=QtCore.Qt.PenStyle.DashLine)),
            "target_box": pg.PlotCurveItem(pen=pg.mkPen(TELEOP_TARGET_COLOUR, width=2)),
            "hand": pg.ScatterPlotItem(symbol="o", size=14, brush=None, pen=pg.mkPen(TELEOP_HAND_COLOUR, width=3)),
            "mapped": pg.ScatterPlotItem(symbol="d", size=12, brush=pg.mkBrush(TELEOP_TARGET_COLOUR),
                                         pen=pg.mkPen("k", width=1)),
        }
        for z, item in zip((2.5, 2.6, 13.5, 13.6), items.values()):
            item.setZValue(z)  # boxes above the workspace, below the arm; the points above the target cross
            item.setVisible(False)
            plot.addItem(item)
        return items

    def _draw_teleop_boxes(self, view: str) -> None:
        items = self._teleop_items[view]
        for name, box in zip(("hand_box", "target_box"), self._teleop_boxes):
            item = items[name]
            if box is None:
                if item.isVisible():
                    item.setVisible(False)
                continue
            outline = (box_top_outline(*box) if view == "top" else box_side_shadow(*box, self._azimuth)) * M_TO_CM
            item.setData(outline[:, 0], outline[:, 1])
            item.setVisible(True)

    def _draw_teleop_points(self, view: str) -> None:
        items = self._teleop_items[view]
        project = _xy if view == "top" else self._side_xy
        for name, p in zip(("hand", "mapped"), self._teleop_points):
            _set_points(items[name], *project(None if p is None else p[None, :]))

    def _draw_side_markers(self) -> None:
        ids = sorted(self._markers)
        if not ids:
            _set_points(self._side.markers, np.empty(0), np.empty(0))
            self._side.set_marker_labels([], np.empty((0, 2)))
            return
        xyz = np.array([self._markers[i] for i in ids])
        sz = side_view_coords(xyz, self._azimuth) * M_TO_CM
        _set_points(self._side.markers, sz[:, 0], sz[:, 1])
        self._side.set_marker_labels(ids, sz)

    def _draw_target(self) -> None:
        for view, project in ((self._top, _xy), (self._side, self._side_xy)):
            target = None if self._target is None else self._target[None, :]
            _set_points(view.target, *project(target))
            aimed = None if self._aimed is None else self._aimed[None, :]
            _set_points(view.aimed, *project(aimed))
            if target is not None and aimed is not None:
                _set_curve(view.aim_line, *project(np.vstack([target, aimed])))
            else:
                _set_curve(view.aim_line, np.empty(0), np.empty(0))

    def sizeHint(self) -> QtCore.QSize:  # noqa: N802 (Qt override)
        """Modest, so a layout shares space by stretch instead of starving its neighbours."""
        return QtCore.QSize(480, 260)

    def resizeEvent(self, event) -> None:  # noqa: N802 (Qt override)
        """Side by side when wide, stacked when tall."""
        size = event.size()
        wide = size.width() >= 1.3 * size.height()
        direction = (QtWidgets.QBoxLayout.Direction.LeftToRight if wide
                     else QtWidgets.QBoxLayout.Direction.TopToBottom)
        if self._layout.direction() != direction:
            self._layout.setDirection(direction)
        super().resizeEvent(event)
