"""The 2D twin's plots: a titled ``PlotWidget`` per view with its fixed grid, the reusable plot
items of one view (``_ViewItems``: workspace, arm chains, markers and their labels, target …),
the marker labels' placement (``place_labels``) and the small setData helpers that skip work.

Re-exported by ``widgets.arm_twin``.
"""
from __future__ import annotations

import math
from typing import Optional, Sequence

import numpy as np
from widgets._pyqtgraph import pg
from PySide6 import QtCore, QtGui, QtWidgets

from widgets.camera_overlay_items import SteadyLabel, hug_text
from widgets.arm_twin_geometry import (
    AIMED_COLOUR,
    COMMANDED_COLOUR,
    GRID_EXTENT_CM,
    GRID_STEP_CM,
    KEEP_OUT_COLOUR,
    KEEP_OUT_FILL_ALPHA,
    LABEL_DOT_PX,
    LABEL_GAP_PX,
    LABEL_MARGIN_PX,
    LABEL_STACK_STEPS,
    MARKER_COLOUR,
    MEASURED_COLOUR,
    M_TO_CM,
    PLOT_MIN_SIZE,
    PLOT_TITLE_PT,
    PLOT_TITLE_ROW_PX,
    PREVIEW_COLOUR,
    REACHABLE_COLOUR,
    STRUCTURE_COLOUR,
    WORKSPACE_COLOUR,
)
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

# Items that keep their drawing for many frames (the grid, the workspace, the desk …) are drawn
# once into a pixmap the size of the view and blitted after that: a twin view repaints whenever
# the arm moves, and pyqtgraph's paint of an item is a few hundred µs of Python on a Pi 4 core.
STILL = QtWidgets.QGraphicsItem.CacheMode.DeviceCoordinateCache


def still(item):
    """``item`` drawn from a cached pixmap until it changes (its data, pen, view or size); a
    PlotDataItem draws nothing itself: its curve and symbols are cached."""
    for part in (item.curve, item.scatter) if isinstance(item, pg.PlotDataItem) else (item,):
        part.setCacheMode(STILL)
    return item


FAST_SYMBOLS = 16  # Scatter.paint draws up to this many symbols itself
CLIP_PX = 2.0 ** 30


class Scatter(pg.ScatterPlotItem):
    """A ScatterPlotItem whose bounding rectangle is computed once per data and view.

    Qt asks an item for it several times per repaint; pyqtgraph's scatter works it out each
    time from its data and the view's pixel size (~25 µs of Python each, 18 times per twin
    view repaint). It changes only with the points (new data array), the symbols' sizes or the
    view's transform (``viewTransformChanged``), so those are its cache key.
    """

    _rect_key = None
    _rect = None

    def boundingRect(self) -> QtCore.QRectF:  # noqa: N802 (Qt override)
        key = (self.data, self._maxSpotWidth, self._maxSpotPxWidth)
        cached = self._rect_key
        if (cached is None or cached[0] is not key[0] or cached[1:] != key[1:]):
            self._rect = pg.ScatterPlotItem.boundingRect(self)
            self._rect_key = key
        return QtCore.QRectF(self._rect)

    def viewTransformChanged(self) -> None:  # noqa: N802 (pyqtgraph override)
        self._rect_key = None
        super().viewTransformChanged()

    def paint(self, p, option, widget) -> None:
        """A handful of symbols (the twin's are one to a dozen) straight from the symbol atlas:
        the pixmap fragments pyqtgraph would draw, at the same centres, without its culling and
        array bookkeeping (~70 µs of Python a paint). Points off the view are clipped by the
        view box as pyqtgraph's culling would leave them out. Anything else: pyqtgraph's paint."""
        data = self.data
        if (len(data) > FAST_SYMBOLS or self.opts["pxMode"] is not True or not self.opts["useCache"]
                or self._exportOpts is not False or self.opts.get("compositionMode") is not None
                or widget is None or widget.devicePixelRatioF() != self.fragmentAtlas.devicePixelRatio()
                or not data["visible"].all() or not data["sourceRect"]["w"].all()):
            pg.ScatterPlotItem.paint(self, p, option, widget)
            return
        to_device = p.transform()
        pixmap = self.fragmentAtlas.pixmap
        p.resetTransform()
        for x, y, (sx, sy, sw, sh) in zip(data["x"].tolist(), data["y"].tolist(), data["sourceRect"].tolist()):
            centre = to_device.map(QtCore.QPointF(x, y))
            if abs(centre.x()) < CLIP_PX and abs(centre.y()) < CLIP_PX:  # pyqtgraph clips to ±2^30
                p.drawPixmapFragments(QtGui.QPainter.PixmapFragment.create(
                    centre, QtCore.QRectF(sx, sy, sw, sh)), 1, pixmap)


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


class Chain:
    """A polyline with a dot at each point (the measured arm): a curve and a scatter, as a
    PlotDataItem with symbols draws them, without its per-call bookkeeping (its setData cost
    three times the two items' own). ``setData``/``getData`` as a PlotDataItem's; the parts
    are added to the plot by the owner (``curve`` below ``scatter``)."""

    def __init__(self, pen, scatter: "Scatter") -> None:
        self.curve = pg.PlotCurveItem(pen=pen)
        self.scatter = scatter
        self._xy: tuple = (None, None)

    def setData(self, x, y) -> None:  # noqa: N802 (pyqtgraph's name)
        """The points (cm); the very points already drawn are not set again (the measured arm
        holding still while the commanded one moves: most frames)."""
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        shown = len(x) > 0
        drawn_x, drawn_y = self._xy
        if (shown and drawn_x is not None and drawn_x.shape == x.shape and drawn_y.shape == y.shape
                and np.array_equal(drawn_x, x) and np.array_equal(drawn_y, y)):
            return
        self.curve.setData(x, y)
        self.scatter.setData(x, y)
        for part in (self.curve, self.scatter):  # an empty item is not painted at all
            if part.isVisible() != shown:
                part.setVisible(shown)
        self._xy = (x, y) if shown else (None, None)

    def getData(self) -> tuple:  # noqa: N802 (pyqtgraph's name)
        """(x, y) as set, (None, None) when empty (as a PlotDataItem's)."""
        return self._xy


def _make_plot(*titles: str) -> _Plot:
    """A fixed-range, aspect-locked view with a 10 cm grid; ``titles`` longest first."""
    plot = _Plot(titles)
    plot.setMinimumSize(*PLOT_MIN_SIZE)
    item = plot.getPlotItem()
    plot.fit_title()
    # pyqtgraph's showGrid() costs ~6 ms per view per repaint in software rendering; a fixed
    # 10 cm grid drawn as one curve of line pairs costs a fraction of that.
    grid = still(pg.PlotCurveItem(*_grid_pairs(GRID_STEP_CM, GRID_EXTENT_CM), connect="pairs",
                                  pen=pg.mkPen(255, 255, 255, 40, width=1)))
    grid.setZValue(-20)
    item.addItem(grid)
    for side in ("left", "bottom"):  # fixed ranges: the axes change only with the view's size
        still(item.getAxis(side))
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
        # the still parts (cached pixmaps): they change with the profile or the side view's plane
        self.workspace = still(pg.PlotCurveItem(pen=pg.mkPen(WORKSPACE_COLOUR, width=1,
                                                             style=QtCore.Qt.PenStyle.DashLine),
                                                connect="finite"))
        self.structure = still(pg.PlotCurveItem(pen=pg.mkPen(STRUCTURE_COLOUR, width=3),
                                                connect="finite"))
        # keep-out boxes: closed outlines (NaN rows between boxes), each filled translucent red
        self.keep_out = still(pg.PlotCurveItem(pen=pg.mkPen(KEEP_OUT_COLOUR, width=2), connect="finite",
                                               fillLevel="enclosed",
                                               brush=pg.mkBrush(*KEEP_OUT_COLOUR, KEEP_OUT_FILL_ALPHA)))
        self.keep_out.setVisible(False)
        self.preview = pg.PlotDataItem(pen=pg.mkPen(PREVIEW_COLOUR, width=1))
        # a curve item, not a PlotDataItem: the same line for a third of its setData's Python
        self.commanded = pg.PlotCurveItem(pen=pg.mkPen(COMMANDED_COLOUR, width=2,
                                                       style=QtCore.Qt.PenStyle.DashLine))
        # the extra chains (the delta's arms): one curve, NaN rows between the chains
        self.extra = pg.PlotCurveItem(pen=pg.mkPen(MEASURED_COLOUR, width=4), connect="finite")
        self.extra_points = Scatter(symbol="o", size=8,
                                               brush=pg.mkBrush(MEASURED_COLOUR),
                                               pen=pg.mkPen("k", width=1))
        self.measured = Chain(pg.mkPen(MEASURED_COLOUR, width=5), Scatter(
            symbol="o", size=10, brush=pg.mkBrush(MEASURED_COLOUR), pen=pg.mkPen("k", width=1)))
        self.joints = Scatter(symbol="o")
        self.aim_line = pg.PlotDataItem(pen=pg.mkPen(AIMED_COLOUR, width=1,
                                                     style=QtCore.Qt.PenStyle.DotLine))
        self.aimed = Scatter(symbol="o", size=14, brush=None,
                                        pen=pg.mkPen(AIMED_COLOUR, width=2))
        self.target = Scatter(symbol="+", size=22, pen=pg.mkPen(REACHABLE_COLOUR,
                                                                          width=3))
        self.markers = Scatter(symbol="s", size=9, brush=pg.mkBrush(MARKER_COLOUR),
                                          pen=pg.mkPen("k", width=1))
        self.base = still(Scatter([0.0], [0.0], symbol="s", size=12,
                                  brush=pg.mkBrush(90, 90, 90), pen=pg.mkPen("w")))
        self.drawn_target = None  # (target, aimed point, side plane) last drawn (ArmTwin._draw_target)
        self.marker_labels: list[pg.TextItem] = []
        self._label_points = np.zeros((0, 2))  # where the shown labels' dots are, (n,2) view cm
        self.joints.setVisible(False)
        self.extra.setVisible(False)  # drawn only for the delta's arms
        self.extra_points.setVisible(False)
        for z, item in enumerate((self.keep_out, self.workspace, self.structure, self.preview, self.base,
                                  self.markers, self.commanded, self.extra, self.extra_points,
                                  self.measured, self.joints, self.aim_line, self.aimed,
                                  self.target)):
            for part in (item.curve, item.scatter) if isinstance(item, Chain) else (item,):
                part.setZValue(z)  # a chain's dots over its line: the order they are added in
                plot.addItem(part)
        self.view_box = plot.getPlotItem().vb
        # a label's size in view units changes with the view's scale: lay them out again
        self.view_box.sigTransformChanged.connect(self.layout_labels)

    def set_marker_labels(self, ids: Sequence[int], xy_cm: np.ndarray) -> None:
        """Label the marker dots at ``xy_cm`` (n,2) with their ids, laid out by
        :meth:`layout_labels`."""
        while len(self.marker_labels) < len(ids):
            # a label that asks for its transform only when the view's scale changes, not at
            # every repaint, keeps its bounds and is moved without a Python call back
            label = SteadyLabel(color=MARKER_COLOUR, anchor=(0.0, 0.0), fill=pg.mkBrush(0, 0, 0, 140))
            hug_text(label, LABEL_MARGIN_PX)
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
    drawn = getattr(item, "_deskarm_drawn", None)
    # the very points and style already drawn (and nothing else has set the item's data since):
    # the joints of an arm holding still, frame after frame
    if (drawn is not None and drawn[3] is item.data and len(x) == len(drawn[0]) and len(y) == len(drawn[1])
            and np.array_equal(drawn[0], x) and np.array_equal(drawn[1], y) and drawn[2] == kwargs
            and item.isVisible() == (len(x) > 0)):
        return
    item.setData(x, y, **kwargs)
    item.setVisible(len(x) > 0)
    item._deskarm_drawn = (np.array(x, dtype=float), np.array(y, dtype=float), kwargs, item.data)


def _set_curve(item: pg.PlotDataItem, x: np.ndarray, y: np.ndarray) -> None:
    """setData, skipped when emptying a curve that is already empty (preview, aim line); an
    empty curve is hidden (Qt then neither paints it nor asks for its bounds)."""
    if len(x) == 0 and getattr(item, "_deskarm_empty", False):
        return
    item.setData(x, y)
    item._deskarm_empty = len(x) == 0
    item.setVisible(len(x) > 0)


def _finite_rows(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    keep = np.isfinite(x) & np.isfinite(y)
    return x[keep], y[keep]
