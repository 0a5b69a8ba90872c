"""The arm's 2D digital twin: a top view and a side view (the arm's vertical plane).

All inputs are in metres in ``robot_base`` (x right, y forward, z up, desk at z = 0); the
plots show centimetres. Both views have fixed ranges (:meth:`ArmTwin.set_view_range`, or
:meth:`ArmTwin.configure_for` from a profile's workspace), never auto-range, and reuse their
plot items, so a redraw is a handful of ``setData`` calls.

Any profile draws through the same calls: the chain from ``kinematics.chain_points(q)``, the
delta's three arms from ``DeltaKinematics.arm_segments(q)`` (:meth:`ArmTwin.set_extra_segments`),
and the joints' distance to their limits as coloured dots (:meth:`ArmTwin.set_joint_levels`,
levels from :func:`profile_joint_levels`).

This module is the widget (``TwinBase``, ``ArmTwin``); what it draws lives beside it, shared with
the optional 3D view (``widgets.arm_twin_3d``):
``widgets.arm_twin_geometry`` (colours, sizes and the pure helpers), ``widgets.arm_twin_plots``
(a view's plot and its reusable items) and ``widgets.arm_twin_legend`` (the legend row). Their
names are imported here too, so ``from widgets.arm_twin import …`` keeps working.
"""
from __future__ import annotations

import math
from contextlib import contextmanager
from typing import Any, Iterator, Mapping, Optional, Sequence

import numpy as np
from widgets._pyqtgraph import pg
from PySide6 import QtCore, QtWidgets

# also re-exported: the window, the 3D twin and the tests import these from widgets.arm_twin
from widgets.arm_twin_geometry import (
    AIMED_COLOUR,
    arm_azimuth,
    box_side_section,
    box_side_shadow,
    box_top_outline,
    chain_start_for,
    circle_outline,
    COMMANDED_COLOUR,
    DESK_COLOUR,
    DESK_MARGIN_COLOUR,
    desk_margin_for,
    joint_anchors_for,
    joint_dot_positions,
    joint_levels,
    keep_out_boxes_for,
    KEEP_OUT_COLOUR,
    LEVEL_COLOURS,
    LEVEL_DOT_PX,
    LEVELS,
    M_TO_CM,
    MARKER_COLOUR,
    MEASURED_COLOUR,
    normalise_level,
    outlines_with_gaps,
    polylines_with_gaps,
    PREVIEW_COLOUR,
    profile_joint_levels,
    REACHABLE_COLOUR,
    same_chains,
    same_marker_points,
    same_points,
    side_azimuth_for,
    side_view_coords,
    STRUCTURE_COLOUR,
    structure_segments,
    TELEOP_HAND_COLOUR,
    TELEOP_TARGET_COLOUR,
    UNREACHABLE_COLOUR,
    view_extent,
    WORKSPACE_COLOUR,
    workspace_outlines,
)
from widgets.arm_twin_legend import (
    break_lines,
    legend_entries,
    LegendLabel,
    make_legend_label,
    marker_entry,
    _plain,
    teleop_legend_entries,
)
from widgets.arm_twin_plots import (
    _finite_rows,
    _make_plot,
    place_labels,
    _set_curve,
    _set_points,
    Scatter,
    still,
    _ViewItems,
    _xy,
)



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

    @contextmanager
    def batch(self) -> Iterator[None]:
        """A frame's several calls (markers, arm, levels …) drawn together: a twin may leave
        what several of them change to the end (the 2D twin's side view). The 3D twin draws
        each call as it comes."""
        yield

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
        self._batching = False  # inside batch(): the side view's projections wait for its end
        self._side_pending = self._side_markers_pending = False
        self._level_brush = {k: pg.mkBrush(*LEVEL_COLOURS[k]) for k in LEVELS}
        self._level_pen = {"ok": pg.mkPen("k", width=1), "warn": pg.mkPen("w", width=2),
                           "limit": pg.mkPen("w", width=2)}

        self.top_plot = _make_plot("Top view (x, y cm)", "Top view (cm)", "Top")
        self.side_plot = _make_plot("Side view: arm plane (s, z cm)", "Side view (s, z cm)",
                                    "Side view", "Side")
        self._top = _ViewItems(self.top_plot)
        self._side = _ViewItems(self.side_plot)

        desk = still(pg.PlotDataItem([-1e4, 1e4], [0.0, 0.0], pen=pg.mkPen(DESK_COLOUR, width=2),
                                     fillLevel=-1e4, brush=pg.mkBrush(*DESK_COLOUR, 60)))
        desk.setZValue(-10)
        self.side_plot.addItem(desk)
        self._margin_line = still(pg.PlotDataItem(pen=pg.mkPen(DESK_MARGIN_COLOUR, width=1,
                                                               style=QtCore.Qt.PenStyle.DashLine)))
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
            if self._batching:
                self._side_pending = True  # with the markers of this frame, at the batch's end
            else:
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
        for view in (self._top, self._side):
            view.target.setPen(pen)
            view.drawn_target = None  # drawn again in its new colour
            view.target._deskarm_drawn = None  # (_set_points: even at the same place)

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
        if self._batching:
            self._side_markers_pending = True  # the arm may turn the side view's plane yet
        else:
            self._draw_side_markers()
        self._show_marker_positions(self._markers)

    @contextmanager
    def batch(self) -> Iterator[None]:
        """Calls inside it draw the side view's markers and the re-projections a turned plane
        needs once, at its end: a frame's new markers and new arm azimuth otherwise project the
        markers (and lay out their labels) twice. What the top view shows is drawn at once."""
        if self._batching:
            yield
            return
        self._batching, self._side_pending, self._side_markers_pending = True, False, False
        try:
            yield
        finally:
            self._batching = False
            if self._side_pending:
                self._redraw_side_extras()  # the side markers among them
            elif self._side_markers_pending:
                self._draw_side_markers()
            self._side_pending = self._side_markers_pending = False

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
        view.extra.setVisible(len(x) > 0)
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
            "hand": Scatter(symbol="o", size=14, brush=None, pen=pg.mkPen(TELEOP_HAND_COLOUR, width=3)),
            "mapped": Scatter(symbol="d", size=12, brush=pg.mkBrush(TELEOP_TARGET_COLOUR),
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
            # the top view's target depends on the points only, the side view's on the plane too;
            # a frame asks for it after the arm moved (side) and again with the new target
            drawn = (self._target, self._aimed, None if view is self._top else self._azimuth)
            last = view.drawn_target
            if (not self.redraw_unchanged and last is not None and last[0] is drawn[0]
                    and last[1] is drawn[1] and last[2] == drawn[2]):
                continue
            view.drawn_target = drawn
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
