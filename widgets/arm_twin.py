"""The arm's 2D digital twin: a top view and a side view (the arm's vertical plane).

All inputs are in metres in ``robot_base`` (x right, y forward, z up, desk at z = 0); the
plots show centimetres. Both views have fixed ranges (:meth:`ArmTwin.set_view_range`), never
auto-range, and reuse their plot items, so a redraw is a handful of ``setData`` calls.
"""
from __future__ import annotations

import html
import math
from typing import Mapping, Optional, Sequence

import numpy as np
import pyqtgraph as pg
from PySide6 import QtCore, QtGui, QtWidgets

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
GRID_STEP_CM = 10.0
GRID_EXTENT_CM = 200.0


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


def side_view_coords(points_m: np.ndarray, azimuth_rad: float) -> np.ndarray:
    """Project robot_base points (N,3) onto the arm plane: (N,2) columns s, z in metres.

    s = p · (cos a, sin a, 0) is the signed horizontal distance from the base axis along the
    arm's azimuth a (positive on the tool's side); z is kept.
    """
    p = np.asarray(points_m, dtype=float).reshape(-1, 3)
    direction = np.array([math.cos(azimuth_rad), math.sin(azimuth_rad)])
    return np.column_stack([p[:, :2] @ direction, p[:, 2]])


def _grid_pairs(step: float, extent: float) -> tuple[np.ndarray, np.ndarray]:
    """x, y of grid line segments (pairs of points) every ``step`` within ±``extent``."""
    ticks = np.arange(-extent, extent + step / 2, step)
    xs, ys = [], []
    for t in ticks:
        xs += [t, t, -extent, extent]
        ys += [-extent, extent, t, t]
    return np.array(xs), np.array(ys)


def _make_plot(title: str, x_label: str, y_label: str) -> pg.PlotWidget:
    plot = pg.PlotWidget()
    plot.setMinimumSize(160, 120)
    item = plot.getPlotItem()
    item.setTitle(title, size="8pt")
    item.setLabel("bottom", x_label)
    item.setLabel("left", y_label)
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
                                                       style=QtCore.Qt.PenStyle.DashLine))
        self.preview = pg.PlotDataItem(pen=pg.mkPen(PREVIEW_COLOUR, width=1))
        self.commanded = pg.PlotDataItem(pen=pg.mkPen(COMMANDED_COLOUR, width=2,
                                                      style=QtCore.Qt.PenStyle.DashLine))
        self.measured = pg.PlotDataItem(pen=pg.mkPen(MEASURED_COLOUR, width=5),
                                        symbol="o", symbolSize=10,
                                        symbolBrush=pg.mkBrush(MEASURED_COLOUR),
                                        symbolPen=pg.mkPen("k", width=1))
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
        for z, item in enumerate((self.workspace, self.preview, self.base, self.markers,
                                  self.commanded, self.measured, self.aim_line, self.aimed,
                                  self.target)):
            item.setZValue(z)
            plot.addItem(item)

    def set_marker_labels(self, ids: Sequence[int], xy_cm: np.ndarray) -> None:
        while len(self.marker_labels) < len(ids):
            label = pg.TextItem(color=MARKER_COLOUR, anchor=(0.0, 1.0))
            label.setZValue(20)
            self.plot.addItem(label)
            self.marker_labels.append(label)
        for label, marker_id, (x, y) in zip(self.marker_labels, ids, xy_cm):
            label.setText(str(marker_id))
            label.setPos(float(x), float(y))
            label.setVisible(True)
        for label in self.marker_labels[len(ids):]:
            label.setVisible(False)


def _xy(points: Optional[np.ndarray], cols: slice = slice(0, 2)) -> tuple[np.ndarray, np.ndarray]:
    if points is None or len(points) == 0:
        return np.empty(0), np.empty(0)
    a = np.asarray(points, dtype=float)[:, cols] * M_TO_CM
    return a[:, 0], a[:, 1]


def _set_points(item: pg.ScatterPlotItem, x: np.ndarray, y: np.ndarray) -> None:
    """setData, hiding the item when empty (an empty scatter still costs ~0.15 ms a paint)."""
    item.setData(x, y)
    item.setVisible(len(x) > 0)


class ArmTwin(QtWidgets.QWidget):
    """Top view (x, y) and side view (s, z) of the arm, its target, markers and workspace.

    The side view shows the vertical plane through the base axis at the arm's azimuth (from
    the measured, else commanded, tool point); every 3D point is projected onto it with
    :func:`side_view_coords`. The two plots sit side by side on wide widgets and stacked on
    tall ones. Inputs are metres in robot_base; the plots are in centimetres.

    Signals: none (display only).
    """

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._azimuth = math.pi / 2
        self._commanded: Optional[np.ndarray] = None
        self._measured: Optional[np.ndarray] = None
        self._target: Optional[np.ndarray] = None
        self._reachable = True
        self._aimed: Optional[np.ndarray] = None
        self._preview: Optional[np.ndarray] = None
        self._markers: dict[int, np.ndarray] = {}

        self.top_plot = _make_plot("Top view", "x (cm)", "y (cm)")
        self.side_plot = _make_plot("Side view (arm plane)", "s (cm)", "z (cm)")
        self._top = _ViewItems(self.top_plot)
        self._side = _ViewItems(self.side_plot)

        desk = pg.PlotDataItem([-1e4, 1e4], [0.0, 0.0], pen=pg.mkPen(DESK_COLOUR, width=2),
                               fillLevel=-1e4, brush=pg.mkBrush(*DESK_COLOUR, 60))
        desk.setZValue(-10)
        self.side_plot.addItem(desk)

        # The legend is a row of text under the plots rather than a pg.LegendItem: on a small
        # screen an in-plot legend hides the arm, and pyqtgraph's hides a curve when tapped.
        self._measured_label = "measured"
        self.legend_label = QtWidgets.QLabel()
        self.legend_label.setTextFormat(QtCore.Qt.TextFormat.RichText)
        # no word wrap (a height-for-width label makes parent layouts over-allocate height);
        # when narrow the least important entries at the end are cut off instead
        self.legend_label.setSizePolicy(QtWidgets.QSizePolicy.Policy.Ignored,
                                        QtWidgets.QSizePolicy.Policy.Fixed)
        font = self.legend_label.font()
        font.setPointSizeF(max(7.0, font.pointSizeF() * 0.85))
        self.legend_label.setFont(font)
        # same dark background as the plots, so the plot colours read the same
        self.legend_label.setStyleSheet("QLabel { background: black; color: #dddddd;"
                                        " padding: 2px 4px; }")
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

    def set_view_range(self, xy_half_width_m: float, z_max_m: float) -> None:
        """Fix both views' ranges: x, y, s in ±half width, z from just below the desk to max."""
        hw = xy_half_width_m * M_TO_CM
        z_max = z_max_m * M_TO_CM
        self.top_plot.setRange(xRange=(-hw, hw), yRange=(-hw, hw), padding=0.0)
        self.side_plot.setRange(xRange=(-hw, hw), yRange=(-0.1 * z_max, z_max), padding=0.0)

    def set_arm(self, commanded: Optional[np.ndarray], measured: Optional[np.ndarray]) -> None:
        """Draw the commanded (dashed) and measured (thick) chains, (N,3) base→tool, or None."""
        self._commanded = None if commanded is None else np.asarray(commanded, dtype=float)
        self._measured = None if measured is None else np.asarray(measured, dtype=float)
        azimuth = arm_azimuth(self._commanded, self._measured, self._azimuth)
        moved = abs(azimuth - self._azimuth) > 1e-4
        self._azimuth = azimuth
        for chain, top, side in ((self._commanded, self._top.commanded, self._side.commanded),
                                 (self._measured, self._top.measured, self._side.measured)):
            top.setData(*_xy(chain))
            side.setData(*self._side_xy(chain))
        if moved:
            self._redraw_side_extras()

    def set_measured_label(self, text: str) -> None:
        """Rename the measured chain in the legend, e.g. "commanded (no feedback)"."""
        self._measured_label = text
        self._update_legend()

    def set_target(self, p: Optional[Sequence[float]], reachable: bool = True) -> None:
        """Draw the target point (m) as a cross, green when reachable, red when not."""
        self._target = None if p is None else np.asarray(p, dtype=float).reshape(3)
        self._reachable = bool(reachable)
        pen = pg.mkPen(REACHABLE_COLOUR if reachable else UNREACHABLE_COLOUR, width=3)
        self._top.target.setPen(pen)
        self._side.target.setPen(pen)
        self._draw_target()

    def set_aimed_point(self, p: Optional[Sequence[float]]) -> None:
        """Draw the point actually aimed at (nearest reachable), linked to the target."""
        self._aimed = None if p is None else np.asarray(p, dtype=float).reshape(3)
        self._draw_target()

    def set_workspace(self, top_outline: Optional[np.ndarray],
                      side_outline: Optional[np.ndarray]) -> None:
        """Draw the reachable outlines: top (M,2) x, y and side (K,2) s, z, in metres."""
        for outline, item in ((top_outline, self._top.workspace),
                              (side_outline, self._side.workspace)):
            if outline is None or len(outline) == 0:
                item.setData([], [])
                continue
            a = np.asarray(outline, dtype=float).reshape(-1, 2) * M_TO_CM
            a = np.vstack([a, a[:1]])  # closed
            item.setData(a[:, 0], a[:, 1])

    def set_preview(self, points: Optional[np.ndarray]) -> None:
        """Draw a faint preview curve (P,3) in both views (e.g. the Lissajous path)."""
        self._preview = None if points is None else np.asarray(points, dtype=float).reshape(-1, 3)
        self._top.preview.setData(*_xy(self._preview))
        self._side.preview.setData(*self._side_xy(self._preview))

    def set_markers(self, points: Mapping[int, np.ndarray]) -> None:
        """Draw marker positions {id: (3,) m} as labelled dots in both views."""
        self._markers = {int(k): np.asarray(v, dtype=float).reshape(3) for k, v in points.items()}
        ids = sorted(self._markers)
        xyz = np.array([self._markers[i] for i in ids]).reshape(-1, 3)
        top = xyz[:, :2] * M_TO_CM
        _set_points(self._top.markers, top[:, 0], top[:, 1])
        self._top.set_marker_labels(ids, top)
        self._draw_side_markers()

    # ----------------------------------------------------------------------------- internals
    def _update_legend(self) -> None:
        def swatch(colour, glyph: str, text: str) -> str:
            r, g, b = colour[:3]
            return (f'<span style="color: rgb({r},{g},{b}); font-weight: bold">{glyph}</span>'
                    f"&nbsp;{html.escape(text)}")
        target = swatch(REACHABLE_COLOUR, "+", "target") + " / " + swatch(
            UNREACHABLE_COLOUR, "+", "out of reach")
        items = [swatch(COMMANDED_COLOUR, "- -", "commanded"),
                 swatch(MEASURED_COLOUR, "━●", self._measured_label), target,
                 swatch(AIMED_COLOUR, "○", "aimed"), swatch(MARKER_COLOUR, "■", "markers")]
        self.legend_label.setText("&nbsp;&nbsp; ".join(items))

    def legend_text(self) -> str:
        """The legend as plain text (for tests and accessibility)."""
        return QtGui.QTextDocumentFragment.fromHtml(self.legend_label.text()).toPlainText()

    def _side_xy(self, points: Optional[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        if points is None or len(points) == 0:
            return np.empty(0), np.empty(0)
        sz = side_view_coords(points, self._azimuth) * M_TO_CM
        return sz[:, 0], sz[:, 1]

    def _redraw_side_extras(self) -> None:
        """Re-project what depends on the azimuth (target, preview, markers) into the side view."""
        self._side.preview.setData(*self._side_xy(self._preview))
        self._draw_target()
        self._draw_side_markers()

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
                view.aim_line.setData(*project(np.vstack([target, aimed])))
            else:
                view.aim_line.setData([], [])

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
