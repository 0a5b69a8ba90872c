"""The camera view's overlay graphics: the reusable items of one marker or object slot (outline,
id, label) and where the labels go — beside their thing, inside the image, never over another
label (``place_label``, ``free_places``, a plan shortened only when it must be).

Re-exported by ``widgets.camera_view``.
"""
from __future__ import annotations

import math
from typing import Optional, Sequence

import numpy as np
from PySide6 import QtCore, QtGui

from widgets._pyqtgraph import pg
from widgets.camera_overlays import (
    DARK_TEXT_LUMA,
    DETAIL_LABEL_Z,
    FOUND_COLOUR,
    FREE_PLACES_ENOUGH,
    LABEL_MARGIN_PX,
    LABEL_RINGS,
    LABEL_Z,
    LOST_COLOUR,
    MARKER_ID_PT,
    MARKER_Z,
    MarkerOverlay,
    object_colour,
    OBJECT_LABEL_PT,
    OBJECT_TAP_MARGIN_PX,
    OBJECT_Z,
    ObjectOverlay,
    RING_STEP_PX,
    same_objects,
)
Rect = tuple[float, float, float, float]  # x0, y0, x1, y1 (image px, y down)


def _overlaps(a: Rect, b: Rect) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def _label_lines(w: float, h: float, box: Rect, bounds: Rect, gap: float, on_box: bool,
                 step: Optional[float] = None):
    """The lines a w × h label about ``box`` may slide along, in the order they are preferred:
    (ring, axis, fixed, lo, hi, preferred) — ``axis`` 0: a row at y = ``fixed``, the label's x
    anywhere in [lo, hi], best at ``preferred``; axis 1: a column at x = ``fixed``, its y in
    [lo, hi]. On the box's centre first (``on_box``: a marker's id, not sliding); then above,
    below, right and left of the box — sliding along it but always sharing a quarter of its
    side, so a label never reads as its neighbour's — then half on its top or bottom edge and
    on its centre line; then ``step`` (default: the label's height) further out above and below
    (the next ring). Every line is moved inside ``bounds``."""
    x0, y0, x1, y1 = box
    bx0, by0, bx1, by1 = bounds
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    share_x, share_y = 0.25 * min(w, x1 - x0), 0.25 * min(h, y1 - y0)
    x_lo, x_hi = max(bx0, x0 - w + share_x), min(bx1 - w, x1 - share_x)
    y_lo, y_hi = max(by0, y0 - h + share_y), min(by1 - h, y1 - share_y)
    x_pref, y_pref = cx - 0.5 * w, cy - 0.5 * h
    step = h if step is None else min(step, h)

    def row(ring, y):
        return ring, 0, min(max(y, by0), by1 - h), x_lo, x_hi, x_pref

    def column(ring, x):
        return ring, 1, min(max(x, bx0), bx1 - w), y_lo, y_hi, y_pref

    if on_box:
        x = min(max(x_pref, bx0), bx1 - w)
        yield -1, 0, min(max(y_pref, by0), by1 - h), x, x, x
    for ring in range(LABEL_RINGS):
        yield row(ring, y0 - gap - h - ring * (step + gap))  # above
        yield row(ring, y1 + gap + ring * (step + gap))  # below
        if ring == 0:  # beside it (a label's width further out is too far to tell whose it is)
            yield column(ring, x1 + gap)  # right
            yield column(ring, x0 - gap - w)  # left
        if ring == 0 and not on_box:  # half on its own thing, then on it, rather than over another
            yield row(ring, y0 - 0.5 * h)
            yield row(ring, y1 - 0.5 * h)
            yield row(ring, y_pref)


def _free_spot(line, w: float, h: float, obstacles: Sequence[Rect]) -> Optional[tuple[float, float]]:
    """The top-left corner on ``line`` (see ``_label_lines``) nearest its preferred place where a
    w × h label overlaps none of ``obstacles``, or None."""
    _ring, axis, fixed, lo, hi, pref = line
    if lo > hi:
        return None
    length, across = (w, h) if axis == 0 else (h, w)
    band_lo, band_hi = fixed, fixed + across
    # the starts along the line that would overlap an obstacle: open intervals, sorted
    blocked = sorted((o[axis] - length, o[axis + 2]) for o in obstacles
                     if o[1 - axis] < band_hi and band_lo < o[3 - axis])
    best, start = None, lo
    for a, b in blocked + [(hi, math.inf)]:  # the free stretches between the blocked ones
        end = min(a, hi)
        if end >= start:
            s = min(max(pref, start), end)
            if best is None or abs(s - pref) < abs(best - pref):
                best = s
        start = max(start, b)
        if start > hi:
            break
    if best is None:
        return None
    return (best, fixed) if axis == 0 else (fixed, best)


def place_label(size: tuple[float, float], box: Rect, bounds: Rect, taken: Sequence[Rect],
                avoid: Sequence[Rect] = (), gap: float = 2.0, on_box: bool = False,
                step: Optional[float] = None) -> Optional[tuple[float, float]]:
    """Where a label of ``size`` (w, h) about ``box`` goes: its top-left corner inside
    ``bounds``, clear of every rectangle in ``taken`` (other labels, with ``gap`` between), or
    None when there is no such place near the box (all rectangles x0, y0, x1, y1 in one frame,
    y down).

    The nearest ring of lines with a clear place wins (see ``_label_lines``); in it, the first
    line with a clear place that covers none of ``avoid`` (the other things' outlines), else the
    first clear place. Nothing farther: a label away from its thing would read as another's.
    ``step``: how much farther out the next ring is (at most the label's height).
    """
    w, h = size
    bx0, by0, bx1, by1 = bounds
    if w > bx1 - bx0 or h > by1 - by0:
        return None
    taken = [(t[0] - gap, t[1] - gap, t[2] + gap, t[3] + gap) for t in taken]
    both = taken + list(avoid)
    first_clear, first_ring = None, None
    for line in _label_lines(w, h, box, bounds, gap, on_box, step):
        ring = line[0]
        if first_clear is not None and ring != first_ring:
            return first_clear  # a clear place that covers a thing beats a farther one
        if ring >= 0:
            spot = _free_spot(line, w, h, both)
            if spot is not None:
                return spot
        spot = _free_spot(line, w, h, taken)
        if spot is not None:
            if ring < 0:  # a marker's id on its marker
                return spot
            if first_clear is None:
                first_clear, first_ring = spot, ring
    return first_clear


def free_places(size: tuple[float, float], box: Rect, bounds: Rect, blocked: Sequence[Rect],
                avoid: Sequence[Rect], gap: float = 2.0, enough: int = FREE_PLACES_ENOUGH) -> int:
    """How many of the nearest lines (the first ring of ``_label_lines``) a label of ``size``
    about ``box`` has a place on that covers nothing in ``blocked`` nor ``avoid``, counted up to
    ``enough``: the labels with the fewest are placed first, before the others take them."""
    w, h = size
    bx0, by0, bx1, by1 = bounds
    if w > bx1 - bx0 or h > by1 - by0:
        return 0
    obstacles = list(blocked) + list(avoid)
    count = 0
    for line in _label_lines(w, h, box, bounds, gap, False):
        if line[0] > 0:
            break
        if _free_spot(line, w, h, obstacles) is not None:
            count += 1
            if count >= enough:
                break
    return count


def _text_size(text: str, font: QtGui.QFont) -> tuple[float, float]:
    """The size (screen px) a pg.TextItem with ``font`` draws ``text`` in, fill included."""
    key = (text, font.key())
    size = _TEXT_SIZES.get(key)
    if size is None:
        if not _TEXT_DOC:  # measures as QGraphicsTextItem does (document margin included)
            _TEXT_DOC.append(QtGui.QTextDocument())
            _TEXT_DOC[0].setDocumentMargin(LABEL_MARGIN_PX)
        doc = _TEXT_DOC[0]
        doc.setDefaultFont(font)
        doc.setPlainText(text)
        s = doc.size()
        size = _TEXT_SIZES[key] = (float(s.width()), float(s.height()))
        if len(_TEXT_SIZES) > 2000:  # moving labels with numbers: keep the cache small
            _TEXT_SIZES.clear()
    return size


_TEXT_SIZES: dict[tuple[str, str], tuple[float, float]] = {}
_TEXT_DOC: list[QtGui.QTextDocument] = []  # one, made with the first label (needs the QApplication)


def shorter_texts(text: str, object_id: Optional[int] = None) -> list[str]:
    """``text`` and shorter forms of it for a crowded view, longest first: its first line,
    then "#id" (an object) — a label with no room near its thing says less rather than cover
    another label or stray from its thing."""
    out = [text]
    first = text.split("\n", 1)[0]
    if first != text:
        out.append(first)
    if object_id is not None and f"#{object_id}" != first:
        out.append(f"#{object_id}")
    return out


def hug_text(item: pg.TextItem, margin_px: float = LABEL_MARGIN_PX) -> None:
    """A label's background hugs its text (Qt's default margin is 4 px on every side); a label
    moved by its layout calls no Python back (:func:`quiet_moves`)."""
    item.textItem.document().setDocumentMargin(margin_px)
    item.updateTextPos()
    quiet_moves(item)


def quiet_moves(item: pg.GraphicsObject) -> pg.GraphicsObject:
    """``item`` (added to a view box with ``ignoreBounds=True``) moved or turned without Qt
    calling its Python ``itemChange`` twice per ``setPos``: pyqtgraph asks for those calls only to
    tell the view box its bounds changed, for an auto-range that ignores this item anyway
    (a label layout moves a dozen labels a frame, each call a trip into Python for the GUI
    thread). Parent and scene changes still call it (pyqtgraph follows its view with those)."""
    item.setFlag(item.GraphicsItemFlag.ItemSendsGeometryChanges, False)
    return item


class SteadyLabel(pg.TextItem):
    """A ``pg.TextItem`` that draws the same for less of the GUI thread per frame.

    pyqtgraph's asks for its transform again at every repaint of its scene (a Python slot on
    the scene's ``sigPrepareForPaint``, for every label in the view) and works its bounds out
    in Python each of the several times Qt asks while painting. The transform only follows the
    view's scale, and pyqtgraph already calls ``viewTransformChanged`` when that changes (and
    ``setVisible`` when a hidden label shows); the bounds change only with the text, the font
    or the view's scale, which all go through ``updateTextPos``: that is where they are dropped.
    """

    _rect: Optional[QtCore.QRectF] = None

    def updateTextPos(self) -> None:  # noqa: N802 (pyqtgraph's name)
        super().updateTextPos()
        if self._rect is not None:
            self.prepareGeometryChange()
            self._rect = None

    def boundingRect(self) -> QtCore.QRectF:  # noqa: N802 (Qt override)
        if self._rect is None:
            self._rect = pg.TextItem.boundingRect(self)
        return QtCore.QRectF(self._rect)

    def paint(self, p: QtGui.QPainter, *args) -> None:
        """pyqtgraph's paint (its background), without the per-repaint transform check."""
        scene = self.scene()
        if scene is not self._lastScene:  # as pyqtgraph's: the first paint in a scene
            self._lastScene = scene
            self.updateTransform()
            p.setTransform(self.sceneTransform())
        if self.border.style() != QtCore.Qt.PenStyle.NoPen or self.fill.style() != QtCore.Qt.BrushStyle.NoBrush:
            p.setPen(self.border)
            p.setBrush(self.fill)
            p.setRenderHint(QtGui.QPainter.RenderHint.Antialiasing, True)
            p.drawPolygon(self.textItem.mapToParent(self.textItem.boundingRect()))


def _bold_label(point_size: float, fill_alpha: int) -> pg.TextItem:
    """A white bold label of ``point_size`` on a black background of ``fill_alpha``, hugging its text."""
    item = SteadyLabel(anchor=(0.0, 0.0), color="w", fill=pg.mkBrush(0, 0, 0, fill_alpha))
    font = QtGui.QFont()
    font.setPointSizeF(point_size)
    font.setBold(True)
    item.setFont(font)
    hug_text(item)
    return item


def _plan_labels(requests, boxes: Sequence[Rect], bounds: Rect, taken: Sequence[Rect], gap: float,
                 px: tuple[float, float]) -> tuple[dict, set]:
    """Place labels in the order of ``requests`` ((item, index of its thing in ``boxes``, on the
    thing, texts longest first) each) with :func:`place_label`: {item: (text, top-left) or None}
    and the set of items that had to say less (a shorter text, or none)."""
    taken = list(taken)
    plan, cut = {}, set()
    for item, k, on_box, texts in requests:
        font = item.textItem.font()
        # a marker's id on the marker may cover what the marker sits on (it names the marker)
        avoid = [] if on_box else list(boxes[:k]) + list(boxes[k + 1:])
        plan[item] = None
        for n, text in enumerate(texts):
            w, h = _text_size(text, font)
            size = (w * px[0], h * px[1])
            spot = place_label(size, boxes[k], bounds, taken, avoid, gap, on_box, RING_STEP_PX * px[1])
            if spot is not None:
                plan[item] = (text, spot)
                taken.append((spot[0], spot[1], spot[0] + size[0], spot[1] + size[1]))
                if n:
                    cut.add(item)
                break
        if plan[item] is None:
            cut.add(item)
    return plan, cut


def _plan_score(plan: dict, cut: set) -> tuple[int, int]:
    """(labels left out, labels shortened) of a plan from :func:`_plan_labels`: lower is better."""
    hidden = sum(1 for item in cut if plan[item] is None)
    return hidden, len(cut) - hidden


def _set_font_size(item: pg.TextItem, pt: float) -> None:
    font = item.textItem.font()
    if font.pointSizeF() != pt:
        font.setPointSizeF(pt)
        item.setFont(font)


def _fill_for(colour: tuple[int, int, int]) -> QtGui.QBrush:
    """A label's background: dark under a light colour, light under a dark one (navy, black)."""
    r, g, b = colour
    light = 0.299 * r + 0.587 * g + 0.114 * b >= DARK_TEXT_LUMA
    return pg.mkBrush(0, 0, 0, 170) if light else pg.mkBrush(235, 235, 235, 215)


OUTLINE_PAD_PX = 4.0  # an outline layer's bounds reach this far (screen px) past its points: half the widest pen and the antialiasing


class _OutlineLayer(pg.GraphicsObject):
    """Every outline of one kind (objects, or markers) in one camera view, in one graphics item.

    Each outline draws what a ``pg.PlotCurveItem(antialias=True)`` with its pen and points
    draws (the same path, pen and render hint: the same pixels), in the order the outlines
    were made, as a PlotCurveItem each at the layer's z-value would stack. One item instead of
    one per outline: a repaint makes one call into Python for them instead of a ``paint`` and a
    few ``boundingRect`` calls per outline, and an outline moving in a frame only stores its
    path — no PlotCurveItem bookkeeping, no geometry change of its own (on a Pi 4 core each of
    those was some 0.1 ms, for eight objects in two views at every draw).
    """

    def __init__(self, z: float) -> None:
        super().__init__()
        self.outlines: list["_Outline"] = []
        self._rect: Optional[QtCore.QRectF] = None  # the bounds Qt was last given; None: to work out
        self.setZValue(z)

    @classmethod
    def of(cls, view_box: pg.ViewBox, z: float) -> "_OutlineLayer":
        """The view box's layer at ``z``, made (and added to it) the first time."""
        layers = view_box.__dict__.setdefault("_deskarm_outline_layers", {})
        layer = layers.get(z)
        if layer is None:
            layer = layers[z] = cls(z)
            view_box.addItem(layer, ignoreBounds=True)
        return layer

    def changed(self) -> None:
        """An outline's points, pen or visibility changed: repaint (and new bounds, once until
        Qt asks for them)."""
        if self._rect is not None:
            self.prepareGeometryChange()  # also repaints the old and the new bounds
            self._rect = None
        else:
            self.update()

    def boundingRect(self) -> QtCore.QRectF:  # noqa: N802 (Qt override)
        if self._rect is None:
            boxes = [o.bounds for o in self.outlines if o.visible and o.bounds is not None]
            if not boxes:
                self._rect = QtCore.QRectF()
            else:
                px, py = self.pixelVectors()
                pad_x = OUTLINE_PAD_PX * (0.0 if px is None else px.length())
                pad_y = OUTLINE_PAD_PX * (0.0 if py is None else py.length())
                x0, y0 = min(b[0] for b in boxes) - pad_x, min(b[1] for b in boxes) - pad_y
                x1, y1 = max(b[2] for b in boxes) + pad_x, max(b[3] for b in boxes) + pad_y
                self._rect = QtCore.QRectF(x0, y0, x1 - x0, y1 - y0)
        return QtCore.QRectF(self._rect)

    def viewTransformChanged(self) -> None:  # noqa: N802 (pyqtgraph override)
        """Another scale on screen: the padding (screen px) is other image px."""
        if self._rect is not None:
            self.prepareGeometryChange()
            self._rect = None

    def paint(self, p: QtGui.QPainter, *args) -> None:
        p.setRenderHint(QtGui.QPainter.RenderHint.Antialiasing, True)
        p.setBrush(QtCore.Qt.BrushStyle.NoBrush)
        for o in self.outlines:
            if o.visible and o.path is not None:
                p.setPen(o.opts["pen"])
                p.drawPath(o.path)


class _Outline:
    """One outline (a closed polyline) in an :class:`_OutlineLayer`, with the part of a
    PlotCurveItem's interface the overlay slots use: ``setPen``, ``setData``, ``setVisible``,
    ``isVisible`` and ``opts["pen"]``."""

    def __init__(self, layer: _OutlineLayer) -> None:
        self.layer = layer
        self.opts = {"pen": pg.mkPen("w")}
        self.path: Optional[QtGui.QPainterPath] = None
        self.bounds: Optional[Rect] = None  # of the points (image px)
        self.visible = True
        layer.outlines.append(self)

    def setPen(self, pen: QtGui.QPen) -> None:  # noqa: N802 (PlotCurveItem's name)
        self.opts["pen"] = pen
        if self.visible and self.path is not None:
            self.layer.changed()

    def setData(self, x: np.ndarray, y: np.ndarray) -> None:  # noqa: N802 (PlotCurveItem's name)
        """The points, x and y (image px): drawn as one polyline, first to last."""
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        self.path = pg.functions.arrayToQPath(x, y, connect="all") if len(x) > 1 else None
        self.bounds = (float(x.min()), float(y.min()), float(x.max()), float(y.max())) if len(x) else None
        if self.visible:
            self.layer.changed()

    def setVisible(self, visible: bool) -> None:  # noqa: N802 (Qt's name)
        visible = bool(visible)
        if visible != self.visible:
            self.visible = visible
            if self.path is not None:
                self.layer.changed()

    def isVisible(self) -> bool:  # noqa: N802 (Qt's name)
        return self.visible


class _MarkerGraphics:
    """The reusable graphics items of one marker slot (outline, id, label).

    The view places the id and the label (``CameraView._layout_labels``): the id on the
    marker, the label beside it, neither over another label.
    """

    def __init__(self, view_box: pg.ViewBox) -> None:
        self.view_box = view_box
        self.outline = _Outline(_OutlineLayer.of(view_box, MARKER_Z))
        self.id_text = _bold_label(MARKER_ID_PT, 150)
        self.label_text = SteadyLabel(anchor=(0.0, 0.0), color="w", fill=pg.mkBrush(0, 0, 0, 150))
        hug_text(self.label_text)
        for item in (self.id_text, self.label_text):
            item.setZValue(LABEL_Z)
            view_box.addItem(item, ignoreBounds=True)
        self.marker_id: Optional[int] = None
        self._polygon: Optional[QtGui.QPolygonF] = None  # made when first asked for (a tap)
        self.box: Optional[Rect] = None  # the marker's bounding box (image px)
        self.label = ""  # the label the overlay asks for (the item may show less, or none)
        self._found: Optional[bool] = None  # the outline's pen and the id's colour are for this
        self._corners: Optional[np.ndarray] = None  # the outline, box and polygon are of these corners

    def show(self, m: MarkerOverlay, force: bool = False) -> None:
        """Draw ``m``: its outline again only where its corners moved (all of it with ``force``)."""
        colour = FOUND_COLOUR if m.found else LOST_COLOUR
        if m.found != self._found:  # a marker moving in view: only its place changes
            style = QtCore.Qt.PenStyle.SolidLine if m.found else QtCore.Qt.PenStyle.DashLine
            self.outline.setPen(pg.mkPen(colour, width=3, style=style))
            self.id_text.setColor(colour)
            self._found = m.found
        if m.marker_id != self.marker_id:
            self.id_text.setText(str(m.marker_id))
        self.label = m.label
        corners = self._corners
        if force or corners is None or corners.shape != m.corners.shape or not np.array_equal(corners, m.corners):
            # a marker lying still (most of a desk's): its outline stays as drawn
            closed = np.vstack([m.corners, m.corners[:1]])
            self.outline.setData(closed[:, 0], closed[:, 1])
            lo, hi = m.corners.min(axis=0), m.corners.max(axis=0)
            self.box = (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))
            self._polygon = None
            self._corners = np.array(m.corners, dtype=float)
        self.outline.setVisible(True)
        self.marker_id = m.marker_id

    @property
    def polygon(self) -> QtGui.QPolygonF:
        """The marker's outline (image px) for hit tests: made when a tap asks, not at every frame
        the marker moves."""
        if self._polygon is None:
            corners = () if self._corners is None else self._corners
            self._polygon = QtGui.QPolygonF([QtCore.QPointF(float(x), float(y)) for x, y in corners])
        return self._polygon

    def hide(self) -> None:
        for item in (self.outline, self.id_text, self.label_text):
            item.setVisible(False)
        self.marker_id = self.box = self._corners = self._polygon = None
        self.label = ""

    def set_visible(self, visible: bool) -> None:
        """Outline only: the view's label layout shows the id and label it finds room for."""
        if self.marker_id is None:
            return
        self.outline.setVisible(visible)
        if not visible:
            _set_visible(self.id_text, False)
            _set_visible(self.label_text, False)


class _ObjectGraphics:
    """The reusable graphics items of one object slot (outline and label), in the colour its
    name says ("#8 orange": orange) or, for a name that is no colour, its track's colour."""

    def __init__(self, view_box: pg.ViewBox) -> None:
        self.view_box = view_box
        self.outline = _Outline(_OutlineLayer.of(view_box, OBJECT_Z))
        self.label_text = _bold_label(OBJECT_LABEL_PT, 170)
        self.label_text.setZValue(LABEL_Z)
        view_box.addItem(self.label_text, ignoreBounds=True)
        self.object_id: Optional[int] = None
        self.box: Optional[tuple[float, float, float, float]] = None
        self.colour: Optional[tuple[int, int, int]] = None  # of the outline and the label's text
        self._style: Optional[tuple] = None  # (colour, seen, unsure) of the pen
        self._shown: Optional[ObjectOverlay] = None  # what the items show now

    @property
    def label(self) -> str:
        """The label the overlay asks for (the item may show a shorter one, or none)."""
        return "" if self._shown is None else self._shown.label

    def show(self, o: ObjectOverlay, force: bool = False) -> bool:
        """Draw ``o``; only what differs from what the items show (all of it with ``force``).
        Returns whether anything changed (the labels must then be laid out again)."""
        shown = None if force else self._shown
        if shown is not None and shown.object_id == o.object_id and same_objects([o], [shown]):
            return False  # a still object (most of a desk): nothing to set
        colour = o.colour if o.colour is not None else object_colour(o.object_id)
        if (colour, o.seen, o.unsure) != self._style:  # a moving object: only its place and text change
            style = (QtCore.Qt.PenStyle.DotLine if o.unsure else
                     QtCore.Qt.PenStyle.SolidLine if o.seen else QtCore.Qt.PenStyle.DashLine)
            self.outline.setPen(pg.mkPen(colour, width=2 if o.unsure else 3, style=style))
            self.label_text.setColor(colour)
            self.label_text.fill = _fill_for(colour)
            self.label_text.update()
            self._style = (colour, o.seen, o.unsure)
        if shown is None or shown.outline.shape != o.outline.shape or not np.array_equal(shown.outline, o.outline):
            closed = np.vstack([o.outline, o.outline[:1]])
            self.outline.setData(closed[:, 0], closed[:, 1])
        # a label with a position (the followed object in a small view) goes over the others
        z = DETAIL_LABEL_Z if "\n" in o.label else LABEL_Z
        if self.label_text.zValue() != z:  # a z-value set calls back into Python (itemChange)
            self.label_text.setZValue(z)
        self.object_id, self.box, self._shown, self.colour = o.object_id, o.box, o, colour
        self.outline.setVisible(True)
        return True

    def contains(self, x_px: float, y_px: float) -> bool:
        if self.box is None or not self.outline.isVisible():
            return False
        x, y, w, h = self.box
        m = OBJECT_TAP_MARGIN_PX
        return x - m <= x_px <= x + w + m and y - m <= y_px <= y + h + m

    def hide(self) -> None:
        self._shown = None
        self.outline.setVisible(False)
        self.label_text.setVisible(False)
        self.object_id = self.box = self.colour = None

    def set_visible(self, visible: bool) -> None:
        """Outline only: the view's label layout shows the label where it finds room."""
        if self.object_id is None:
            return
        self.outline.setVisible(visible)
        if not visible:
            _set_visible(self.label_text, False)


def _set_visible(item: pg.TextItem, visible: bool) -> None:
    """TextItem.setVisible(True) re-computes the item's transform even when it is shown: skip
    it when the visibility does not change (every frame of a moving marker)."""
    if item.isVisible() != visible:
        item.setVisible(visible)
