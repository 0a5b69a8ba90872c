"""One camera's live view: the image or its disparity map, marker and object overlays, fps and a banner."""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Optional, Sequence

import cv2
import numpy as np
import pyqtgraph as pg
from PySide6 import QtCore, QtGui, QtWidgets

from core.messages import MarkerObservation
from widgets._style import TOUCH_PX, touch_button
from widgets.status import Banner

DISPLAY_MODES = ("image", "disparity")
DISPARITY_COLORMAP = "turbo"
FOUND_COLOUR = (40, 220, 60)
LOST_COLOUR = (255, 150, 0)
STARTING_TEXT = "starting cameras…"  # the placeholder until the first image
PLACEHOLDER_SCALE = 1.6  # the placeholder's font size, times the view's
OVERLAY_MIN_PT = 7.0  # overlay text shrinks to fit a small view, never below this
OVERLAY_INSET_PX = 4  # overlay text keeps this far from the edges of the area it sits in
# marker-less objects: one outline colour per track id (bright on a desk, apart from the markers'
# green and orange), the id's colour = OBJECT_COLOURS[id % len]
OBJECT_COLOURS = ((0, 200, 255), (255, 80, 220), (255, 225, 0), (255, 110, 60),
                  (110, 160, 255), (170, 255, 70), (255, 160, 190), (235, 235, 235))
OBJECT_TAP_MARGIN_PX = 6.0  # a tap this near an object's box (image px) still picks it
CIRCLE_POINTS = 40  # outline of a circle detection
OBJECT_LABEL_PT = 8.0  # object labels: several per view, bold but smaller than a marker's id
MARKER_ID_PT = 12.0  # a marker's id, on the marker
SMALL_VIEW_PX = 260  # a view narrower than this (800x480: ~185 px) draws its labels smaller:
SMALL_OBJECT_LABEL_PT, SMALL_MARKER_ID_PT = 7.0, 8.0  # a 640 px image is shown at ~1/3.5 there
SMALL_FPS_SCALE = 0.8  # and the fps label's font this much of the normal one
FPS_STYLE = "QLabel {{ background: rgba(0,0,0,150); color: white; padding: {padding}; }}"
LABEL_RINGS = 2  # rows of places tried above and below a thing before its label is shortened
RING_STEP_PX = 16.0  # the second row is this much farther out (screen px; a line of text)
LABEL_GAP_PX = 2.0  # screen px between a label and its thing, and between two labels
LAYOUT_RETRIES = 3  # a layout that shortened labels is tried again this often, those first
FREE_PLACES_ENOUGH = 3  # a label with free places on this many lines near its thing is placed after the others
LABEL_MARGIN_PX = 2.0  # between a label's text and the edge of its background
# what a label's colour word draws in: shades that read on a dark label (the 8 the HSV detector
# names by default and a few more); other SVG colour names are drawn as Qt knows them
NAMED_COLOURS = {
    "red": (255, 70, 70), "orange": (255, 150, 40), "yellow": (255, 230, 40), "green": (70, 220, 70),
    "blue": (90, 155, 255), "purple": (195, 110, 255), "violet": (205, 120, 255), "pink": (255, 135, 205),
    "magenta": (255, 70, 255), "cyan": (40, 225, 235), "brown": (190, 120, 60), "white": (245, 245, 245),
    "grey": (175, 175, 175), "gray": (175, 175, 175), "black": (20, 20, 20),
}
DARK_TEXT_LUMA = 90.0  # a colour darker than this (0…255) is drawn on a light label, not a dark one
OBJECT_Z, MARKER_Z = 9, 10  # the outlines: objects under markers
LABEL_Z, DETAIL_LABEL_Z = 11, 12  # every label over every outline; one with a position over the others
M_TO_CM = 100.0


@dataclass(frozen=True, eq=False)
class MarkerOverlay:
    """What to draw for one marker in one camera image.

    ``corners`` are the marker's 4 corners in this camera's raw image (pixels, OpenCV
    convention: pixel centres at integer coordinates). ``found`` False means the corners are a
    prediction or the last known position (drawn dashed orange). ``label`` is free text, e.g.
    "23: x 3.1 y 15.2 z 0.0 cm".
    """

    marker_id: int
    corners: np.ndarray  # (4, 2) px
    found: bool = True
    label: str = ""

    def __post_init__(self) -> None:
        corners = np.asarray(self.corners, dtype=float)
        if corners.shape != (4, 2):
            raise ValueError(f"MarkerOverlay.corners has shape {corners.shape}; expected (4, 2)")
        object.__setattr__(self, "corners", corners)

    @classmethod
    def from_observation(cls, obs: MarkerObservation, side: str = "left",
                         label: Optional[str] = None) -> Optional["MarkerOverlay"]:
        """The overlay of a perception observation in the ``side`` ("left"/"right") image.

        Returns None when the marker has no corners in that image. Without ``label``, the label
        is the id plus the robot_base position in cm when known.
        """
        corners = obs.left_corners if side == "left" else obs.right_corners
        if len(corners) != 4:
            return None
        if label is None:
            label = marker_label(obs.marker_id, obs.base_p_centre)
        return cls(obs.marker_id, np.asarray(corners, dtype=float), obs.found, label)


@dataclass(frozen=True)
class DrawnLabel:
    """A label as drawn over a camera image (``CameraView.drawn_labels``)."""

    kind: str  # "marker id", "marker" (a marker's position) or "object"
    key: int  # the marker id or the object id
    text: str  # as shown (a crowded view may show a shorter form)
    rect: QtCore.QRectF  # where it is drawn, background included, in the CameraView's coordinates
    colour: QtGui.QColor  # of the text
    fill: QtGui.QColor  # of the background


def same_overlays(a: Sequence[MarkerOverlay], b: Sequence[MarkerOverlay]) -> bool:
    """True when two overlay lists draw the same: ids, corners, found and labels, in order."""
    return len(a) == len(b) and all(
        x is y or (x.marker_id == y.marker_id and x.found == y.found and x.label == y.label
                   and np.array_equal(x.corners, y.corners))
        for x, y in zip(a, b))


def object_colour(object_id: int) -> tuple[int, int, int]:
    """The outline and text colour of track ``object_id`` (stable while the track lives)."""
    return OBJECT_COLOURS[int(object_id) % len(OBJECT_COLOURS)]


def object_label(obs, detailed: bool = True) -> str:
    """"#3 red 0.98" plus, when ``detailed`` and known, "x 4.0 y 2.0 z 2.5 cm" and "v 1.2 cm/s"
    (robot_base, from the triangulated position and the track's velocity); "#3 red" when not
    ``detailed`` (a small view, where every label covers part of the desk)."""
    if not detailed:
        return f"#{obs.object_id} {obs.label}"
    lines = [f"#{obs.object_id} {obs.label} {obs.score:.2f}"]
    if obs.triangulated and obs.base_p is not None:
        x_cm, y_cm, z_cm = (round(M_TO_CM * float(v), 1) + 0.0 for v in obs.base_p)  # + 0.0: no "-0.0"
        lines.append(f"x {x_cm:.1f} y {y_cm:.1f} z {z_cm:.1f} cm")
    elif not obs.triangulated:
        lines.append("one view only")
    if obs.velocity_base is not None:
        speed_cm_s = M_TO_CM * math.sqrt(sum(float(v) ** 2 for v in obs.velocity_base))
        lines.append(f"v {speed_cm_s:.1f} cm/s")
    return "\n".join(lines)


def _detection_outline(d) -> np.ndarray:
    """The outline to draw for a Detection (raw image px, open polygon): its contour when it has
    one, else its circle, else its box."""
    if d.contour is not None and len(d.contour) >= 3:
        return np.asarray(d.contour, dtype=float)
    if d.radius_px is not None and d.radius_px > 0:
        a = np.linspace(0.0, 2.0 * np.pi, CIRCLE_POINTS, endpoint=False)
        cx, cy = d.centre_px
        return np.stack([cx + d.radius_px * np.cos(a), cy + d.radius_px * np.sin(a)], axis=1)
    x, y, w, h = d.box
    return np.array([[x, y], [x + w, y], [x + w, y + h], [x, y + h]], dtype=float)


@dataclass(frozen=True, eq=False)
class ObjectOverlay:
    """What to draw for one marker-less object in one camera image.

    ``box`` is (x, y, w, h) in this camera's raw image px (what a tap hits); ``outline`` the
    drawn shape (N, 2) px (the blob's contour, the circle or the box). ``seen`` False: a track's
    single-view or predicted detection (drawn dashed). ``label`` may have several lines.
    ``colour`` (r, g, b) of the outline and the label's text; None: the colour the label names
    (:func:`named_colour`: "#8 orange" is orange), else the track's (:func:`object_colour`).
    """

    object_id: int
    box: tuple[float, float, float, float]
    outline: np.ndarray
    label: str = ""
    seen: bool = True
    colour: Optional[tuple[int, int, int]] = None

    def __post_init__(self) -> None:
        outline = np.asarray(self.outline, dtype=float).reshape(-1, 2)
        if len(outline) < 2:
            raise ValueError(f"ObjectOverlay.outline has {len(outline)} points; expected ≥ 2")
        object.__setattr__(self, "outline", outline)
        object.__setattr__(self, "box", tuple(float(v) for v in self.box))
        colour = self.colour if self.colour is not None else named_colour(self.label)
        if colour is not None:
            object.__setattr__(self, "colour", tuple(int(c) for c in colour))

    @classmethod
    def from_observation(cls, obs, side: str = "left", detailed: bool = True,
                         label: Optional[str] = None) -> Optional["ObjectOverlay"]:
        """The overlay of a ``core.detect.stereo.ObjectObservation`` in the ``side`` image; None
        when that view did not see it. ``detailed``: position and speed lines in the label."""
        d = obs.left if side == "left" else obs.right
        if d is None:
            return None
        if label is None:
            label = object_label(obs, detailed)
        return cls(obs.object_id, d.box, _detection_outline(d), label, bool(obs.triangulated),
                   named_colour(str(obs.label)))


def same_objects(a: Sequence[ObjectOverlay], b: Sequence[ObjectOverlay]) -> bool:
    """True when two object overlay lists draw the same (ids, boxes, outlines, labels, colours, state)."""
    return len(a) == len(b) and all(
        x is y or (x.object_id == y.object_id and x.seen == y.seen and x.label == y.label and x.box == y.box
                   and x.colour == y.colour and x.outline.shape == y.outline.shape
                   and np.array_equal(x.outline, y.outline))
        for x, y in zip(a, b))


def marker_label(marker_id: int, base_p: Optional[Sequence[float]]) -> str:
    """"23: x 3.1 y 15.2 z 0.0 cm" from a position in metres (just "23" when unknown)."""
    if base_p is None:
        return str(marker_id)
    x_cm, y_cm, z_cm = (round(100.0 * float(v), 1) + 0.0 for v in base_p)  # + 0.0: no "-0.0"
    return f"{marker_id}: x {x_cm:.1f} y {y_cm:.1f} z {z_cm:.1f} cm"


_TOGETHER = re.compile(r"(?<=\b[xyzXYZ]) (?=[-+]?\d)|(?<=\d) (?=(?:mm|cm|m|px|fps)\b)")


def keep_together(text: str) -> str:
    """``text`` with the spaces in "x -12.3" and "412 mm" made non-breaking, so wrapped overlay
    text never puts a coordinate's letter, its number and its unit on different lines."""
    return _TOGETHER.sub("\u00a0", text)


def disparity_to_index(disp_px: np.ndarray, max_disparity: float) -> np.ndarray:
    """Map disparities to uint8 colour-table indices: ≤ 0 or NaN → 0 (black), (0, max] → 1…255."""
    disp = np.asarray(disp_px, dtype=np.float32)
    scale = 254.0 / max(float(max_disparity), 1e-6)
    # saturating |d·scale + 1| in one OpenCV pass (~0.06 ms at 640×480, 7× numpy), then zero
    # the invalid pixels: NaN > 0 is False, so NaN ends up black too
    index = cv2.convertScaleAbs(disp, alpha=scale, beta=1.0)
    np.multiply(index, disp > 0, out=index)
    return index


def disparity_lut() -> np.ndarray:
    """The (256, 3) colour table used by :func:`disparity_to_index`: black, then the colormap."""
    cmap = pg.colormap.get(DISPARITY_COLORMAP)
    table = cmap.getLookupTable(nPts=255, alpha=False).astype(np.uint8)
    return np.vstack([np.zeros((1, 3), np.uint8), table])


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


def named_colour(label: str) -> Optional[tuple[int, int, int]]:
    """The colour a label's words name, as drawn on the camera views ("#8 orange" -> orange,
    "red ball" -> red), None when it names none ("#3 circle"). Common colour words first
    (shades that read on a dark label), then any SVG colour name Qt knows ("gold", "navy")."""
    words = re.findall(r"[a-z]+", label.split("\n", 1)[0].lower())
    for word in words:
        if word in NAMED_COLOURS:
            return NAMED_COLOURS[word]
    for word in words:
        if len(word) > 2 and QtGui.QColor.isValidColorName(word):
            c = QtGui.QColor(word)
            return c.red(), c.green(), c.blue()
    return None


def _tight(item: pg.TextItem) -> None:
    """A label's background hugs its text (Qt's default margin is 4 px on every side)."""
    item.textItem.document().setDocumentMargin(LABEL_MARGIN_PX)
    item.updateTextPos()


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


class _MarkerGraphics:
    """The reusable graphics items of one marker slot (outline, id, label).

    The view places the id and the label (``CameraView._layout_labels``): the id on the
    marker, the label beside it, neither over another label.
    """

    def __init__(self, view_box: pg.ViewBox) -> None:
        self.view_box = view_box
        self.outline = pg.PlotCurveItem(antialias=True)
        self.id_text = pg.TextItem(anchor=(0.0, 0.0), color="w", fill=pg.mkBrush(0, 0, 0, 150))
        font = QtGui.QFont()
        font.setPointSizeF(MARKER_ID_PT)
        font.setBold(True)
        self.id_text.setFont(font)
        _tight(self.id_text)
        self.label_text = pg.TextItem(anchor=(0.0, 0.0), color="w",
                                      fill=pg.mkBrush(0, 0, 0, 150))
        _tight(self.label_text)
        self.outline.setZValue(MARKER_Z)
        for item in (self.id_text, self.label_text):
            item.setZValue(LABEL_Z)
        for item in (self.outline, self.id_text, self.label_text):
            view_box.addItem(item, ignoreBounds=True)
        self.marker_id: Optional[int] = None
        self.polygon = QtGui.QPolygonF()
        self.box: Optional[Rect] = None  # the marker's bounding box (image px)
        self.label = ""  # the label the overlay asks for (the item may show less, or none)
        self._found: Optional[bool] = None  # the outline's pen and the id's colour are for this

    def show(self, m: MarkerOverlay) -> None:
        closed = np.vstack([m.corners, m.corners[:1]])
        colour = FOUND_COLOUR if m.found else LOST_COLOUR
        if m.found != self._found:  # a marker moving in view: only its place changes
            style = QtCore.Qt.PenStyle.SolidLine if m.found else QtCore.Qt.PenStyle.DashLine
            self.outline.setPen(pg.mkPen(colour, width=3, style=style))
            self.id_text.setColor(colour)
            self._found = m.found
        self.outline.setData(closed[:, 0], closed[:, 1])
        if m.marker_id != self.marker_id:
            self.id_text.setText(str(m.marker_id))
        self.label = m.label
        lo, hi = m.corners.min(axis=0), m.corners.max(axis=0)
        self.box = (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))
        self.outline.setVisible(True)
        self.marker_id = m.marker_id
        self.polygon = QtGui.QPolygonF([QtCore.QPointF(float(x), float(y)) for x, y in m.corners])

    def hide(self) -> None:
        for item in (self.outline, self.id_text, self.label_text):
            item.setVisible(False)
        self.marker_id = self.box = None
        self.label = ""
        self.polygon = QtGui.QPolygonF()

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
        self.outline = pg.PlotCurveItem(antialias=True)
        self.label_text = pg.TextItem(anchor=(0.0, 0.0), color="w", fill=pg.mkBrush(0, 0, 0, 170))
        font = QtGui.QFont()
        font.setPointSizeF(OBJECT_LABEL_PT)
        font.setBold(True)
        self.label_text.setFont(font)
        _tight(self.label_text)
        self.outline.setZValue(OBJECT_Z)
        self.label_text.setZValue(LABEL_Z)
        for item in (self.outline, self.label_text):
            view_box.addItem(item, ignoreBounds=True)
        self.object_id: Optional[int] = None
        self.box: Optional[tuple[float, float, float, float]] = None
        self.colour: Optional[tuple[int, int, int]] = None  # of the outline and the label's text
        self._style: Optional[tuple[tuple[int, int, int], bool]] = None  # (colour, seen) of the pen
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
        if (colour, o.seen) != self._style:  # a moving object: only its place and text change
            style = QtCore.Qt.PenStyle.SolidLine if o.seen else QtCore.Qt.PenStyle.DashLine
            self.outline.setPen(pg.mkPen(colour, width=3, style=style))
            self.label_text.setColor(colour)
            self.label_text.fill = _fill_for(colour)
            self.label_text.update()
            self._style = (colour, o.seen)
        if shown is None or shown.outline.shape != o.outline.shape or not np.array_equal(shown.outline, o.outline):
            closed = np.vstack([o.outline, o.outline[:1]])
            self.outline.setData(closed[:, 0], closed[:, 1])
        # a label with a position (the followed object in a small view) goes over the others
        self.label_text.setZValue(DETAIL_LABEL_Z if "\n" in o.label else LABEL_Z)
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


class CameraView(QtWidgets.QWidget):
    """One camera's live image (or disparity map) with marker and object overlays, fps and a banner.

    Coordinates everywhere are the raw image's pixels in the OpenCV convention (x right,
    y down, pixel centres at integers). Mouse pan/zoom and the context menu are off so taps
    are only taps. Marker and object overlays are shown in image mode only: their corners are raw-image
    pixels while the disparity map lives in the rectified image. In disparity mode the colour
    bar can carry depth labels (``set_depth_legend``) and a tapped pixel a depth probe
    (``set_probe``).

    Signals (all emitted from the GUI thread):
        sigClicked(float x_px, float y_px): the user clicked/tapped the image at that pixel
            (in disparity mode: a pixel of the rectified left view, where the window measures depth).
        sigObjectClicked(int object_id): the click was on (or within a few px of) a drawn
            object's box (emitted after sigClicked, before sigMarkerClicked).
        sigMarkerClicked(int marker_id): the click was inside a drawn marker outline
            (emitted after sigClicked).
        sigDisplayModeChanged(str mode): the user switched the toggle; "image" or "disparity".
    """

    sigClicked = QtCore.Signal(float, float)
    sigMarkerClicked = QtCore.Signal(int)
    sigObjectClicked = QtCore.Signal(int)
    sigDisplayModeChanged = QtCore.Signal(str)

    # True: show_image/show_disparity/set_markers redraw even what is already shown (the
    # window's redraw-all mode, the baseline of bench/bench_window.py). False: the very array
    # already on screen, or the same overlays, are not set again.
    redraw_unchanged = False

    def __init__(self, title: str = "Left", parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._mode = "image"
        self._shape: Optional[tuple[int, int]] = None  # (rows, cols) of what is displayed
        self._last_image: Optional[np.ndarray] = None
        self._last_disparity: Optional[tuple[np.ndarray, float]] = None
        # what the image items show now: a source re-delivers the very same array for a
        # frame that did not change, so identity (no pixel hashing) tells a frame to skip
        self._shown_image: Optional[np.ndarray] = None
        self._shown_disparity: Optional[tuple[np.ndarray, float]] = None
        self._shown_overlays: list[MarkerOverlay] = []
        self._frames_drawn = 0
        self._max_disparity = 64.0
        self._markers: list[_MarkerGraphics] = []
        self._objects: list[_ObjectGraphics] = []
        self._shown_objects: list[ObjectOverlay] = []

        self._title = QtWidgets.QLabel(title)
        font = self._title.font()
        font.setBold(True)
        font.setPointSizeF(font.pointSizeF() * 1.25)
        self._title.setFont(font)
        self.toggle_button = touch_button("Disparity", checkable=True)
        self.toggle_button.setToolTip("Image / Disparity: show the camera image or the "
                                      "stereo disparity map")
        self.toggle_button.toggled.connect(self._on_toggled)

        self._graphics = pg.GraphicsLayoutWidget()
        self._graphics.setMinimumSize(160, 120)
        self._graphics.ci.setContentsMargins(0, 0, 0, 0)
        self._view_box = self._graphics.addViewBox(row=0, col=0, lockAspect=True, invertY=True,
                                                   enableMouse=False, enableMenu=False)
        self._view_box.disableAutoRange()
        self._view_box.setDefaultPadding(0.0)
        # Shift by half a pixel so view coordinates are OpenCV pixel coordinates.
        self._image_item = pg.ImageItem()
        self._disparity_item = pg.ImageItem()
        for item in (self._image_item, self._disparity_item):
            item.setPos(-0.5, -0.5)
            self._view_box.addItem(item)
        self._disparity_item.setLookupTable(disparity_lut())
        self._disparity_item.setVisible(False)
        self._colour_bar = pg.ColorBarItem(values=(0.0, self._max_disparity),
                                           colorMap=DISPARITY_COLORMAP,
                                           interactive=False, width=14, colorMapMenu=False)
        self._colour_bar.setContentsMargins(0, 14, 0, 14)  # room for the end marks' labels
        self._graphics.addItem(self._colour_bar, row=0, col=1)
        self._colour_bar.setVisible(False)
        # the depth probe: a cross at the tapped pixel (in the scene) and its depth as an overlay
        # label (a scene text would be scaled with a small view and run out of it)
        self._probe_mark = pg.ScatterPlotItem(size=26, symbol="+", pen=pg.mkPen("k", width=1.5),
                                              brush=pg.mkBrush("w"))
        self._probe_mark.setZValue(20)
        self._probe_mark.setVisible(False)
        self._view_box.addItem(self._probe_mark, ignoreBounds=True)
        self._probe: Optional[tuple[float, float, str]] = None
        self._legend: list[tuple[float, str]] = []
        self._graphics.scene().sigMouseClicked.connect(self._on_scene_clicked)

        # Overlays are child widgets of the graphics view, placed on resize.
        self._banner = Banner(self._graphics)
        self._fps_label = QtWidgets.QLabel("— fps", self._graphics)
        self._fps_label.setStyleSheet(FPS_STYLE.format(padding="2px 6px"))
        self._fps_pt = self._fps_label.font().pointSizeF()
        self._fps_small: Optional[bool] = None  # the fps label's size is for a small view
        self._fps_label.setAttribute(QtCore.Qt.WidgetAttribute.WA_TransparentForMouseEvents)
        # margins, not style-sheet padding, and a bold font, not font-weight: what heightForWidth
        # and the font metrics measure is then what is drawn
        self._probe_label = QtWidgets.QLabel("", self._graphics)
        self._probe_label.setStyleSheet("QLabel { background: rgba(0,0,0,190); color: white; }")
        self._probe_label.setContentsMargins(6, 2, 6, 2)
        self._probe_label.setWordWrap(True)
        self._probe_label.setAttribute(QtCore.Qt.WidgetAttribute.WA_TransparentForMouseEvents)
        self._probe_label.hide()
        probe_font = self._probe_label.font()
        probe_font.setBold(True)
        self._probe_label.setFont(probe_font)
        self._probe_pt = probe_font.pointSizeF()  # the size it shrinks from
        # "starting cameras…" until the first image: a black view looks broken
        self._placeholder = QtWidgets.QLabel("", self._graphics)
        self._placeholder.setStyleSheet("QLabel { background: transparent; color: #e0e0e0; }")
        self._placeholder.setContentsMargins(6, 6, 6, 6)
        self._placeholder.setWordWrap(True)
        self._placeholder.setAlignment(QtCore.Qt.AlignmentFlag.AlignCenter)
        self._placeholder.setAttribute(QtCore.Qt.WidgetAttribute.WA_TransparentForMouseEvents)
        placeholder_font = self._placeholder.font()
        placeholder_font.setBold(True)
        placeholder_font.setPointSizeF(placeholder_font.pointSizeF() * PLACEHOLDER_SCALE)
        self._placeholder.setFont(placeholder_font)
        self._placeholder_pt = placeholder_font.pointSizeF()
        self._placeholder_text = ""
        self._placeholder.hide()
        self._graphics.installEventFilter(self)
        # overlays that follow the image's place on screen: the colour bar's width, a resize
        self._view_box.sigTransformChanged.connect(self._on_view_transform)

        header = QtWidgets.QHBoxLayout()
        header.setContentsMargins(4, 0, 0, 0)
        header.addWidget(self._title)
        header.addStretch(1)
        header.addWidget(self.toggle_button)
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(2)
        layout.addLayout(header)
        layout.addWidget(self._graphics, 1)
        self._set_range(480, 640)
        self.set_placeholder(STARTING_TEXT)

    # ----------------------------------------------------------------------------- public API
    @property
    def display_mode(self) -> str:
        """"image" or "disparity"."""
        return self._mode

    @property
    def title(self) -> str:
        """The view's title ("Left", "Right")."""
        return self._title.text()

    def set_title(self, title: str) -> None:
        """Change the title shown above the image."""
        self._title.setText(title)

    def set_display_mode(self, mode: str) -> None:
        """Show "image" or "disparity" without emitting sigDisplayModeChanged."""
        if mode not in DISPLAY_MODES:
            raise ValueError(f"display mode {mode!r}; allowed: {', '.join(DISPLAY_MODES)}")
        blocked = self.toggle_button.blockSignals(True)
        self.toggle_button.setChecked(mode == "disparity")
        self.toggle_button.blockSignals(blocked)
        self._apply_mode(mode)

    @property
    def frames_drawn(self) -> int:
        """How many images (camera or disparity) were handed to the image items so far."""
        return self._frames_drawn

    def show_image(self, bgr: np.ndarray) -> None:
        """Display a BGR, BGRA or grey uint8 image (kept to re-show after disparity mode).

        The array already on screen (the same object) is not drawn again. The first image
        clears the placeholder (:meth:`set_placeholder`).
        """
        if self._placeholder_text:
            self.set_placeholder("")
        self._last_image = bgr
        if self._mode != "image":
            return
        if bgr is self._shown_image and not self.redraw_unchanged:
            return
        # cv2 swaps channels in ~0.1 ms; a reversed numpy view makes pyqtgraph copy slowly
        if bgr.ndim == 3 and bgr.shape[2] == 3:
            rgb = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
        elif bgr.ndim == 3 and bgr.shape[2] == 4:
            rgb = cv2.cvtColor(bgr, cv2.COLOR_BGRA2RGBA)
        else:
            rgb = bgr
        # no levels: a uint8 image then becomes a QImage as is; levels=(0, 255) made
        # pyqtgraph rescale every pixel (~0.6 ms a frame at 640x480)
        self._image_item.setImage(rgb, autoLevels=False)
        self._shown_image = bgr
        self._frames_drawn += 1
        self._ensure_range(bgr.shape[0], bgr.shape[1])

    def show_disparity(self, disp_px: np.ndarray, max_disparity: float) -> None:
        """Display a float32 disparity map (px) colour-mapped over 0…max; ≤ 0 shows black.

        The first map clears the placeholder (:meth:`set_placeholder`).
        """
        if self._placeholder_text:
            self.set_placeholder("")
        self._last_disparity = (disp_px, max_disparity)
        if max_disparity != self._max_disparity:
            self._max_disparity = float(max_disparity)
            self._colour_bar.setLevels((0.0, self._max_disparity))
        if self._mode != "disparity":
            return
        shown = self._shown_disparity
        if (shown is not None and shown[0] is disp_px and shown[1] == max_disparity
                and not self.redraw_unchanged):
            return
        index = disparity_to_index(disp_px, max_disparity)
        self._disparity_item.setImage(index, autoLevels=False, levels=(0, 255))
        self._shown_disparity = (disp_px, max_disparity)
        self._frames_drawn += 1
        self._ensure_range(index.shape[0], index.shape[1])

    def set_depth_legend(self, ticks: Sequence[tuple[float, str]]) -> None:
        """Label the disparity colour bar: (disparity px, text) marks, e.g. (32.0, "32 px\n41 cm")."""
        self._legend = [(float(d), str(t)) for d, t in ticks]
        self._colour_bar.axis.setTicks([self._legend])
        self._colour_bar.axis.setWidth(58 if any("\n" in str(t) for _, t in ticks) else 45)

    @property
    def depth_legend(self) -> list[tuple[float, str]]:
        """The colour bar's marks as last set by :meth:`set_depth_legend`."""
        return list(self._legend)

    def set_probe(self, x_px: float, y_px: float, text: str) -> None:
        """Mark pixel (x, y) of the disparity map with a cross and ``text`` (shown in disparity mode).

        The text sits in the image's bottom-left corner, wrapped and if need be in a smaller
        font so it stays inside the image and off the colour bar. The same probe again is
        skipped (the window sets it on every disparity frame).
        """
        probe = (float(x_px), float(y_px), text)
        if probe == self._probe and not self.redraw_unchanged:
            return
        if self._probe is None or probe[:2] != self._probe[:2] or self.redraw_unchanged:
            self._probe_mark.setData([probe[0]], [probe[1]])
        self._probe = probe
        shown = keep_together(text)
        if shown != self._probe_label.text():
            self._probe_label.setText(shown)
        self._update_probe_visibility()

    def clear_probe(self) -> None:
        """Remove the depth probe."""
        self._probe = None
        self._update_probe_visibility()

    @property
    def probe(self) -> Optional[tuple[float, float, str]]:
        """(x px, y px, text) of the depth probe, or None."""
        return self._probe

    def probe_text(self) -> str:
        """The depth probe's text as shown ("" when hidden)."""
        return "" if self._probe_label.isHidden() or self._probe is None else self._probe[2]

    def _update_probe_visibility(self) -> None:
        visible = self._probe is not None and self._mode == "disparity"
        self._probe_mark.setVisible(visible)
        self._probe_label.setVisible(visible)
        self._place_overlays()

    def set_markers(self, markers: Sequence[MarkerOverlay]) -> None:
        """Draw these marker outlines (replacing the previous ones); the same again is skipped."""
        if same_overlays(markers, self._shown_overlays) and not self.redraw_unchanged:
            return
        self._shown_overlays = list(markers)
        while len(self._markers) < len(markers):
            self._markers.append(_MarkerGraphics(self._view_box))
        for slot, marker in zip(self._markers, markers):
            slot.show(marker)
            slot.set_visible(self._mode == "image")
        for slot in self._markers[len(markers):]:
            slot.hide()
        self._layout_labels()

    def set_objects(self, objects: Sequence[ObjectOverlay]) -> None:
        """Draw these marker-less objects (replacing the previous ones); the same again is
        skipped. Graphics items are reused between frames (only hidden when unused)."""
        if same_objects(objects, self._shown_objects) and not self.redraw_unchanged:
            return
        self._shown_objects = list(objects)
        while len(self._objects) < len(objects):
            self._objects.append(_ObjectGraphics(self._view_box))
        changed = False
        for slot, overlay in zip(self._objects, objects):
            changed |= slot.show(overlay, force=self.redraw_unchanged)
            slot.set_visible(self._mode == "image")
        for slot in self._objects[len(objects):]:
            if slot.object_id is not None:
                slot.hide()
                changed = True
        if changed:
            self._layout_labels()

    @property
    def shown_objects(self) -> list[ObjectOverlay]:
        """The object overlays last set (drawn in image mode)."""
        return list(self._shown_objects)

    def object_labels(self) -> dict[int, str]:
        """The text each drawn object's label shows, by object id ("" when there was no room
        for it): the overlay's label, or a shorter form of it in a crowded view."""
        return {slot.object_id: slot.label_text.toPlainText() if slot.label_text.isVisible() else ""
                for slot in self._objects if slot.object_id is not None and slot.outline.isVisible()}

    def drawn_labels(self) -> list[DrawnLabel]:
        """Every label drawn over the image now (marker ids, marker labels, object labels) with
        where it is in this widget and its colours (tests, screenshots)."""
        out = []
        items = [("marker id", s.marker_id, s.id_text) for s in self._markers if s.marker_id is not None]
        items += [("marker", s.marker_id, s.label_text) for s in self._markers if s.marker_id is not None]
        items += [("object", s.object_id, s.label_text) for s in self._objects if s.object_id is not None]
        for kind, key, item in items:
            if not item.isVisible():
                continue
            view_rect = self._graphics.viewportTransform().mapRect(item.sceneBoundingRect())
            rect = view_rect.translated(QtCore.QPointF(self._graphics.viewport().mapTo(self, QtCore.QPoint(0, 0))))
            out.append(DrawnLabel(kind, int(key), item.toPlainText(), rect, QtGui.QColor(item.color),
                                  QtGui.QColor(item.fill.color())))
        return out

    def object_colours(self) -> dict[int, tuple[int, int, int]]:
        """The outline colour of each drawn object, by object id (the pen's, as drawn)."""
        out = {}
        for slot in self._objects:
            if slot.object_id is not None and slot.outline.isVisible():
                c = slot.outline.opts["pen"].color()
                out[slot.object_id] = (c.red(), c.green(), c.blue())
        return out

    def object_at(self, x_px: float, y_px: float) -> Optional[int]:
        """The id of the drawn object whose box (plus a small margin) holds (x, y) px, else None;
        the smallest box wins where boxes overlap."""
        hits = [(slot.box[2] * slot.box[3], slot.object_id) for slot in self._objects
                if slot.object_id is not None and slot.contains(x_px, y_px)]
        return min(hits)[1] if hits else None

    def set_fps(self, fps: float) -> None:
        """Show the frame rate in the view's bottom-left corner (NaN or ≤ 0: "— fps")."""
        text = f"{fps:.1f} fps" if math.isfinite(fps) and fps > 0 else "— fps"
        if text == self._fps_label.text():
            return  # no resize, no re-placing of the overlays
        self._fps_label.setText(text)
        self._fps_label.adjustSize()
        self._place_overlays()

    def set_banner(self, text: Optional[str], level: str = "warn") -> None:
        """Show a coloured banner over the top of the image; None or "" removes it."""
        if text:
            self._banner.show_message(text, level)
        else:
            self._banner.clear()
        self._place_overlays()

    def banner_text(self) -> str:
        """The banner's text ("" when hidden)."""
        return "" if self._banner.isHidden() else self._banner.text()

    def set_placeholder(self, text: str) -> None:
        """Show ``text`` large in the middle of the view until an image comes, e.g. "starting
        cameras…" (the default) or "CAMERA MISSING — plug it in"; "" removes it.

        The first :meth:`show_image` or :meth:`show_disparity` removes it too. The text wraps
        and, in a small view, takes a smaller font, so it is never cut.
        """
        text = str(text)
        if text == self._placeholder_text:
            return
        self._placeholder_text = text
        self._placeholder.setText(text)
        self._placeholder.setVisible(bool(text))
        self._place_overlays()

    def placeholder_text(self) -> str:
        """The placeholder's text ("" when none is shown)."""
        return self._placeholder_text

    def image_rect(self) -> QtCore.QRect:
        """Where the displayed image is in the graphics view's coordinates (px), within the
        view box: the area overlay text such as the depth probe must stay in."""
        rows, cols = self._shape if self._shape is not None else (480, 640)
        image = QtCore.QRectF(-0.5, -0.5, float(cols), float(rows))
        scene = self._view_box.mapViewToScene(image).boundingRect()
        scene = scene.intersected(self._view_box.sceneBoundingRect())
        return self._scene_rect_to_graphics(scene)

    def colour_bar_rect(self) -> QtCore.QRect:
        """Where the disparity colour bar (bar and labels) is in the graphics view's
        coordinates (px); empty when it is hidden."""
        if not self._colour_bar.isVisible():
            return QtCore.QRect()
        return self._scene_rect_to_graphics(self._colour_bar.sceneBoundingRect())

    def overlay_widgets(self) -> dict[str, QtWidgets.QLabel]:
        """The text overlays (children of :attr:`graphics_view`): "probe", "placeholder",
        "fps" (for tests that measure them)."""
        return {"probe": self._probe_label, "placeholder": self._placeholder,
                "fps": self._fps_label}

    def marker_at(self, x_px: float, y_px: float) -> Optional[int]:
        """The id of the drawn marker whose outline contains (x, y) px, else None."""
        point = QtCore.QPointF(x_px, y_px)
        for slot in reversed(self._markers):  # last drawn is on top
            if slot.marker_id is not None and slot.outline.isVisible() and \
                    slot.polygon.containsPoint(point, QtCore.Qt.FillRule.OddEvenFill):
                return slot.marker_id
        return None

    def image_to_widget(self, x_px: float, y_px: float) -> QtCore.QPoint:
        """Where image pixel (x, y) is in this widget's coordinates (tests, overlays)."""
        scene_pos = self._view_box.mapViewToScene(QtCore.QPointF(x_px, y_px))
        view_pos = self._graphics.mapFromScene(scene_pos)
        return self._graphics.viewport().mapTo(self, view_pos)

    @property
    def graphics_view(self) -> pg.GraphicsView:
        """The pyqtgraph view (tests send mouse events to its viewport)."""
        return self._graphics

    def sizeHint(self) -> QtCore.QSize:  # noqa: N802 (Qt override)
        """A 320×240 image plus the header; pyqtgraph's own hint is far larger."""
        return QtCore.QSize(320, 240 + TOUCH_PX + 4)

    # ----------------------------------------------------------------------------- internals
    def _on_toggled(self, checked: bool) -> None:
        mode = "disparity" if checked else "image"
        self._apply_mode(mode)
        self.sigDisplayModeChanged.emit(mode)

    def _apply_mode(self, mode: str) -> None:
        if mode == self._mode:
            return
        self._mode = mode
        disparity = mode == "disparity"
        self._image_item.setVisible(not disparity)
        self._disparity_item.setVisible(disparity)
        self._colour_bar.setVisible(disparity)
        for slot in (*self._markers, *self._objects):
            slot.set_visible(not disparity)
        self._layout_labels()
        self._update_probe_visibility()
        if disparity and self._last_disparity is not None:
            self.show_disparity(*self._last_disparity)
        elif not disparity and self._last_image is not None:
            self.show_image(self._last_image)

    def _ensure_range(self, rows: int, cols: int) -> None:
        if self._shape != (rows, cols):
            self._set_range(rows, cols)

    def _set_range(self, rows: int, cols: int) -> None:
        # Fixed range, set only when the image size changes: no auto-range per frame.
        self._shape = (rows, cols)
        self._view_box.setRange(xRange=(-0.5, cols - 0.5), yRange=(-0.5, rows - 0.5),
                                padding=0.0)

    def _on_scene_clicked(self, event) -> None:
        if event.button() != QtCore.Qt.MouseButton.LeftButton:
            return
        if not self._view_box.sceneBoundingRect().contains(event.scenePos()):
            return  # on the colour bar, not the image
        pos = self._view_box.mapSceneToView(event.scenePos())
        x_px, y_px = float(pos.x()), float(pos.y())
        self.sigClicked.emit(x_px, y_px)
        object_id = self.object_at(x_px, y_px) if self._mode == "image" else None
        if object_id is not None:
            self.sigObjectClicked.emit(object_id)
        marker_id = self.marker_at(x_px, y_px)
        if marker_id is not None:
            self.sigMarkerClicked.emit(marker_id)

    def eventFilter(self, watched: QtCore.QObject, event: QtCore.QEvent) -> bool:  # noqa: N802
        if watched is self._graphics and event.type() == QtCore.QEvent.Type.Resize:
            self._place_overlays()
        return super().eventFilter(watched, event)

    def _on_view_transform(self, *_: object) -> None:
        """The image moved or was rescaled on screen: the labels and the probe follow."""
        self._layout_labels()
        if not self._probe_label.isHidden():
            self._place_probe()

    def _scene_rect_to_graphics(self, rect: QtCore.QRectF) -> QtCore.QRect:
        viewport = self._graphics.viewport()
        polygon = self._graphics.mapFromScene(rect)  # viewport coordinates
        return polygon.boundingRect().translated(viewport.mapTo(self._graphics, QtCore.QPoint(0, 0)))

    def _place_overlays(self) -> None:
        width = self._graphics.width()
        if not self._banner.isHidden():
            height = max(TOUCH_PX - 8, self._banner.heightForWidth(width))
            self._banner.setGeometry(0, 0, width, height)
            self._banner.raise_()
        small = width < SMALL_VIEW_PX
        if small != self._fps_small:  # a small view: a smaller fps label, more room for labels
            self._fps_small = small
            self._fps_label.setStyleSheet(FPS_STYLE.format(padding="1px 3px" if small else "2px 6px"))
            font = self._fps_label.font()
            font.setPointSizeF(self._fps_pt * (SMALL_FPS_SCALE if small else 1.0))
            self._fps_label.setFont(font)
        self._fps_label.adjustSize()
        self._fps_label.move(4, self._graphics.height() - self._fps_label.height() - 4)
        self._fps_label.raise_()
        if not self._placeholder.isHidden():
            area = self._graphics.rect().adjusted(OVERLAY_INSET_PX, OVERLAY_INSET_PX,
                                                  -OVERLAY_INSET_PX, -OVERLAY_INSET_PX)
            size = _fit_text(self._placeholder, area.width(), area.height(), self._placeholder_pt)
            self._placeholder.setGeometry(QtWidgets.QStyle.alignedRect(
                QtCore.Qt.LayoutDirection.LeftToRight, QtCore.Qt.AlignmentFlag.AlignCenter,
                size, area))
            self._placeholder.raise_()
        if not self._probe_label.isHidden():
            self._place_probe()
        self._layout_labels()  # the banner and the fps label are places no label may take

    def _image_rect_of(self, widget: QtWidgets.QWidget) -> Rect:
        """Where an overlay widget (a child of the graphics view) is, in image px."""
        geometry = widget.geometry()
        offset = self._graphics.viewport().pos()
        rect = QtCore.QRectF(geometry.translated(-offset))
        view = self._view_box.mapSceneToView(self._graphics.mapToScene(rect.toRect())).boundingRect()
        return view.left(), view.top(), view.right(), view.bottom()

    def _layout_labels(self) -> None:
        """Place every marker id, marker label and object label so that none covers another,
        nor the fps label or the banner: each at the nearest free place around its thing (a
        marker's id on the marker), preferring places that cover no other thing; in a shorter
        form when no place near it is free (:func:`shorter_texts`); left out when even that
        has no room near its thing (never drawn far away, where it would name a neighbour).
        Fonts are smaller in a small view."""
        if self._mode != "image":
            return
        (x0, x1), (y0, y1) = self._view_box.viewRange()
        px_w, px_h = self._view_box.viewPixelSize()  # image px per screen px
        if not all(math.isfinite(v) and v > 0 for v in (px_w, px_h)):
            return
        markers = sorted((s for s in self._markers if s.marker_id is not None and s.outline.isVisible()),
                         key=lambda s: s.marker_id)
        objects = [s for s in self._objects if s.object_id is not None and s.outline.isVisible()]
        small = self._graphics.width() < SMALL_VIEW_PX
        object_pt = SMALL_OBJECT_LABEL_PT if small else OBJECT_LABEL_PT
        marker_pt = SMALL_MARKER_ID_PT if small else MARKER_ID_PT
        for s in markers:
            _set_font_size(s.id_text, marker_pt)
            if not s.label:
                _set_visible(s.label_text, False)
        for s in objects:
            _set_font_size(s.label_text, object_pt)
            if not s.label:
                _set_visible(s.label_text, False)
        boxes = [s.box for s in markers] + [(x, y, x + w, y + h) for x, y, w, h in (s.box for s in objects)]
        bounds = (x0, y0, x1, y1)
        taken = [self._image_rect_of(w) for w in (self._fps_label, self._banner) if not w.isHidden()]
        gap = LABEL_GAP_PX * px_w
        # (item, index of its thing in boxes, centred on it, texts to try)
        requests = [(s.id_text, k, True, [str(s.marker_id)]) for k, s in enumerate(markers)]
        requests += [(s.label_text, k, False, [s.label]) for k, s in enumerate(markers) if s.label]
        # objects: the followed one (with its position) first, then those with the fewest free
        # places near them, before the others take those
        order = []
        for k, s in enumerate(objects):
            if not s.label:
                continue
            i = len(markers) + k
            w, h = _text_size(s.label, s.label_text.textItem.font())
            free = free_places((w * px_w, h * px_h), boxes[i], bounds, taken, boxes[:i] + boxes[i + 1:], gap)
            order.append(("\n" not in s.label, free, s.object_id, s, i))
        objects_first = [(s.label_text, i, False, shorter_texts(s.label, s.object_id)) for *_, s, i in sorted(order)]
        plan, cut = _plan_labels(requests + objects_first, boxes, bounds, taken, gap, (px_w, px_h))
        # some had to say less: again with those first (and those of the tries before), the
        # best plan wins — the fewest left out, then the fewest shortened
        score, first = _plan_score(plan, cut), []
        for _ in range(LAYOUT_RETRIES):
            if not cut:
                break
            first += [r for r in objects_first if r[0] in cut and r not in first]
            again = first + [r for r in objects_first if r not in first]
            plan_b, cut = _plan_labels(requests + again, boxes, bounds, taken, gap, (px_w, px_h))
            if _plan_score(plan_b, cut) < score:
                plan, score = plan_b, _plan_score(plan_b, cut)
        for item, place in plan.items():
            if place is None:  # no room near it, not even shortened: left out rather than over another
                _set_visible(item, False)
                continue
            text, spot = place
            if item.toPlainText() != text:
                item.setText(text)
            pos = item.pos()
            if (pos.x(), pos.y()) != spot:
                item.setPos(*spot)
            _set_visible(item, True)

    def _place_probe(self) -> None:
        """The depth probe's text in the image's bottom-left corner, above the fps label,
        inside the image (never on the colour bar to its right)."""
        area = self.image_rect().adjusted(OVERLAY_INSET_PX, OVERLAY_INSET_PX,
                                          -OVERLAY_INSET_PX, -OVERLAY_INSET_PX)
        bar = self.colour_bar_rect()
        if not bar.isEmpty() and area.right() >= bar.left():
            area.setRight(bar.left() - OVERLAY_INSET_PX)
        if area.width() <= 0 or area.height() <= 0:
            return
        bottom = area.bottom() + 1
        fps = self._fps_label.geometry()
        if fps.top() < bottom and fps.right() >= area.left():  # the fps label is in the image
            above_fps = fps.top() - 2
            if above_fps - area.top() >= self._probe_label.fontMetrics().height() * 2:
                bottom = above_fps  # else the image is too short: over the fps label
        size = _fit_text(self._probe_label, area.width(), bottom - area.top(), self._probe_pt)
        y = max(area.top(), bottom - size.height())
        self._probe_label.setGeometry(area.left(), y, size.width(), size.height())
        self._probe_label.raise_()


def _fit_text(label: QtWidgets.QLabel, width: int, height: int, max_pt: float) -> QtCore.QSize:
    """Size a word-wrapped label to fit ``width`` × ``height`` px: the largest font size from
    ``max_pt`` down to OVERLAY_MIN_PT in which every word fits the width and the wrapped text
    the height. Returns the label's size (as small as its text allows)."""
    margins = label.contentsMargins()
    extra_w = margins.left() + margins.right() + 2 * label.margin()
    text = label.text()
    words = [w for w in re.split(r"[ \n]+", text) if w] or [""]  # non-breaking spaces stay
    lines = text.split("\n")
    font = QtGui.QFont(label.font())
    pt = max_pt
    while True:
        font.setPointSizeF(pt)
        metrics = QtGui.QFontMetricsF(font)
        natural = max(metrics.horizontalAdvance(line) for line in lines) + extra_w
        longest = max(metrics.horizontalAdvance(word) for word in words) + extra_w
        w = math.ceil(min(natural + 1.0, float(width)))
        if longest <= w or pt <= OVERLAY_MIN_PT:
            if label.font().pointSizeF() != pt:
                label.setFont(font)
            h = label.heightForWidth(w)
            if h <= height or pt <= OVERLAY_MIN_PT:
                return QtCore.QSize(w, min(h, height))
        pt = max(OVERLAY_MIN_PT, pt - 1.0)
