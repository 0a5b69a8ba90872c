"""What a camera view draws over its image, as plain records and text: one marker's or one
marker-less object's overlay (``MarkerOverlay``, ``ObjectOverlay``), their labels' words, the
overlay colours and sizes, and the disparity map's colour table. No widget here.

Re-exported by ``widgets.camera_view``.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from typing import Optional, Sequence

import cv2
import numpy as np
from PySide6 import QtCore, QtGui

from core.messages import MarkerObservation
from widgets._pyqtgraph import pg
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
UNSURE_COLOUR = (135, 135, 135)  # an object scoring below its class's threshold: grey, dotted, "unsure"
UNSURE_TEXT = "unsure"
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
    ``score``, ``kind`` and ``class_label`` are the observation's (for per-class thresholds:
    ``judged``); ``unsure``: below its class's threshold — drawn grey and dotted, nothing acts on it.
    """

    object_id: int
    box: tuple[float, float, float, float]
    outline: np.ndarray
    label: str = ""
    seen: bool = True
    colour: Optional[tuple[int, int, int]] = None
    score: Optional[float] = None
    kind: str = ""
    class_label: str = ""
    unsure: bool = False

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
                   named_colour(str(obs.label)), float(obs.score), str(obs.kind), str(obs.label))

    def judged(self, thresholds) -> "ObjectOverlay":
        """This overlay as ``thresholds`` (``core.detect.thresholds.ClassThresholds``) see it: an
        object scoring below its class's threshold becomes unsure (grey, dotted, "unsure" after the
        label's first line); one without a score, or sure, is returned as it is."""
        if thresholds is None or self.score is None or self.unsure:
            return self
        if self.score >= thresholds.threshold(self.kind, self.class_label or self.label):
            return self
        first, sep, rest = self.label.partition("\n")
        return replace(self, label=f"{first} {UNSURE_TEXT}{sep}{rest}", colour=UNSURE_COLOUR, unsure=True)


def same_objects(a: Sequence[ObjectOverlay], b: Sequence[ObjectOverlay]) -> bool:
    """True when two object overlay lists draw the same (ids, boxes, outlines, labels, colours, state)."""
    return len(a) == len(b) and all(
        x is y or (x.object_id == y.object_id and x.seen == y.seen and x.label == y.label and x.box == y.box
                   and x.unsure == y.unsure
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
