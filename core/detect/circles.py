"""Round things: circles seen straight on, or obliquely as ellipses; largest first.

Two paths (``CircleParams.ellipses``):

- ellipses (the default): webcams look at the desk obliquely, so a disc's, a cylinder's or a
  cup's round top is an ellipse (minor/major axis ~0.7 at the default rig). OpenCV-contrib's
  EdgeDrawing (``cv2.ximgproc``) traces edge segments, joins arcs and fits ellipses, keeping
  those its a-contrario test (NFA) finds unlikely to be chance; here every ellipse must also be
  round enough (``min_aspect``), of a size in the radius range and lie on edges along most of
  its perimeter (``min_score``). Ellipses nested in or overlapping a better-supported one (a
  ball's shading rings, a cylinder's whole outline around its top, an arc joined with a shadow)
  are dropped. ~5 ms per 640×480 image here; larger images are downscaled first
  (``max_side_px``).
- Hough circles (``ellipses=False``): ``cv2.HoughCircles`` on a median-blurred grey image, as
  the delta controller used them when its camera looked straight down.

Edges follow the image's contrast (``adaptive_edges``, the default): when the fixed thresholds
find nothing, the edge thresholds of both EdgeDrawing and the edge support drop below their fixed
values on a quiet image (its median gradient is low), so grey photos and low-saturation round
things — coins, washers, bottle caps, lift buttons, a step of ~10 grey levels from the desk — are
found; an image where the fixed thresholds find circles keeps exactly those (lowering them there
added faint ghosts that moved the assistive arm's press off its button).

Both report kind "circle", label "circle" (the shape says nothing about the colour: name a
colour with the ``hsv`` detector), ``radius_px`` the semi-major axis and ``score`` the edge
support (see ``CircleDetector``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import cv2
import numpy as np

from core.detect.base import BaseDetector, Detection, options_factory
from core.settings import SettingsError, check_range

CIRCLE_METHODS = {"HOUGH_GRADIENT": cv2.HOUGH_GRADIENT, "HOUGH_GRADIENT_ALT": cv2.HOUGH_GRADIENT_ALT}
_SUPPORT_SAMPLES = 72  # points on each circle or ellipse checked for an edge (the score)
_ANGLES = np.linspace(0, 2 * np.pi, _SUPPORT_SAMPLES, endpoint=False)
_DILATE = np.ones((3, 3), np.uint8)  # an edge within 1 px counts
_OUTLINE_POINTS = 36  # points of an ellipse's outline (Detection.contour)
# EdgeDrawing: the shortest edge segment traced (px of the image it runs on). Shorter arcs are
# mostly wood grain; a 5 px circle is still 31 px round.
_ED_MIN_PATH_PX = 30
# adaptive_edges: thresholds as multiples of the image's median gradient (|Sobel x| + |Sobel y| of
# the median-blurred grey image: on a quiet image that is the noise's gradient), never above the
# fixed ones. A step of d grey levels gives a Sobel response of ~4 d.
_CANNY_NOISE_FACTOR = 5.0  # the support's Canny high threshold: this x the median gradient …
_CANNY_MIN = 15.0  # … but at least this
_ED_GRADIENT_DEFAULT = 20  # EdgeDrawing's own GradientThresholdValue
_ED_NOISE_FACTOR = 2.5  # adaptive: this x the median gradient …
_ED_GRADIENT_MIN = 8  # … but at least this


def has_ellipse_detector() -> bool:
    """True when this OpenCV build has opencv-contrib's EdgeDrawing ellipse detector."""
    return hasattr(cv2, "ximgproc") and hasattr(cv2.ximgproc, "createEdgeDrawing")


@dataclass(frozen=True)
class CircleParams:
    """Settings of ``CircleDetector`` (Hough names follow ``cv2.HoughCircles``)."""

    ellipses: bool = True  # find ellipses (round tops seen obliquely, EdgeDrawing) instead of Hough circles
    min_aspect: float = 0.5  # ellipses: least minor/major axis ratio, 0.05 … 1 (1: circles only)
    max_side_px: int = 800  # ellipses: an image whose longer side exceeds this is downscaled first, 64 … 10000
    method: str = "HOUGH_GRADIENT"  # Hough: HOUGH_GRADIENT or HOUGH_GRADIENT_ALT (more accurate, needs param2 ≤ 1)
    dp: float = 1.0  # Hough: accumulator resolution, image px per accumulator cell, 1 … 4
    min_dist_px: float = 20.0  # Hough: closest two circle centres may be, px, 1 … 10000
    param1: float = 100.0  # Canny high threshold of the edge support (and Hough's), 1 … 1000 (ALT works best near 300)
    param2: float = 30.0  # Hough GRADIENT: accumulator votes, 1 … 1000 (fewer = more false circles); ALT: perfectness 0.01 … 1
    min_radius_px: int = 5  # smallest radius (ellipses: semi-major axis), px, 0 … 10000
    max_radius_px: int = 0  # largest radius (ellipses: semi-major axis), px, 0 (image size) or min_radius_px … 10000
    blur_px: int = 5  # median blur aperture before the edges, px, odd 1 (off) … 15
    max_objects: int = 10  # most circles reported (largest first), 1 … 1000
    min_score: float = 0.75  # least edge support kept (see CircleDetector), 0 (keep all) … 1
    # edge thresholds follow the image's noise (grey, low-contrast round things); False: param1 and
    # EdgeDrawing's fixed threshold alone, as before
    adaptive_edges: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.ellipses, (bool, np.bool_)):
            raise SettingsError(f"circles.ellipses = {self.ellipses!r} must be true or false")
        if not isinstance(self.adaptive_edges, (bool, np.bool_)):
            raise SettingsError(f"circles.adaptive_edges = {self.adaptive_edges!r} must be true or false")
        if self.ellipses and not has_ellipse_detector():
            raise SettingsError("circles.ellipses needs OpenCV's contrib module ximgproc, which this OpenCV "
                                "lacks: install opencv-contrib-python-headless, or set ellipses=False")
        check_range("circles", "min_aspect", self.min_aspect, 0.05, 1.0)
        if self.method not in CIRCLE_METHODS:
            raise SettingsError(f"circles.method = {self.method!r} must be one of {', '.join(CIRCLE_METHODS)}")
        check_range("circles", "dp", self.dp, 1.0, 4.0)
        check_range("circles", "min_dist_px", self.min_dist_px, 1.0, 10000.0)
        check_range("circles", "param1", self.param1, 1.0, 1000.0)
        if self.method == "HOUGH_GRADIENT_ALT":
            check_range("circles", "param2", self.param2, 0.01, 1.0)
        else:
            check_range("circles", "param2", self.param2, 1.0, 1000.0)
        for field in ("min_radius_px", "max_radius_px", "blur_px", "max_objects", "max_side_px"):
            value = getattr(self, field)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise SettingsError(f"circles.{field} = {value!r} must be a whole number")
        check_range("circles", "max_side_px", self.max_side_px, 64, 10000)
        check_range("circles", "min_radius_px", self.min_radius_px, 0, 10000)
        if self.max_radius_px != 0:
            check_range("circles", "max_radius_px", self.max_radius_px, max(1, self.min_radius_px), 10000)
        check_range("circles", "blur_px", self.blur_px, 1, 15)
        if self.blur_px % 2 == 0:
            raise SettingsError(f"circles.blur_px = {self.blur_px} must be odd (1 = off, 3, 5, …, 15)")
        check_range("circles", "max_objects", self.max_objects, 1, 1000)
        check_range("circles", "min_score", self.min_score, 0.0, 1.0)


def ellipse_points(cx: float, cy: float, a: float, b: float, angle_rad: float, n: int) -> np.ndarray:
    """``n`` points (n, 2) evenly spaced in angle on an ellipse: centre, semi-axes ``a`` (along
    ``angle_rad`` from the image x axis) and ``b``."""
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    x, y = a * np.cos(t), b * np.sin(t)
    return np.stack([cx + x * c - y * s, cy + x * s + y * c], axis=1)


def _inside_ellipse(point, e) -> bool:
    """Is ``point`` (x, y) inside the ellipse ``e`` = (cx, cy, a, b, angle_rad)?"""
    cx, cy, a, b, ang = e
    dx, dy = point[0] - cx, point[1] - cy
    c, s = math.cos(ang), math.sin(ang)
    u, v = dx * c + dy * s, -dx * s + dy * c
    return (u / a) ** 2 + (v / b) ** 2 <= 1.0


class CircleDetector(BaseDetector):
    """Circles, or ellipses (round things seen obliquely), largest radius first.

    ``score`` is the edge support: the fraction of 72 points on the circle or ellipse that lie
    within 1 px of a Canny edge (thresholds param1 / 2 … param1, lower on a quiet image with
    ``adaptive_edges``; on the median-blurred image:
    its colour for ellipses, grey for Hough):
    ~1 for a crisp whole outline, lower for arcs and ghosts; below ``min_score`` a shape is
    dropped (HOUGH_GRADIENT without a maximum radius otherwise reports image-sized circles
    through unrelated edges, which "largest first" would put on top; EdgeDrawing joins a ball's
    lower arc with its shadow's). See the module docstring for the two paths.
    """

    name = "circles"
    params_type = CircleParams

    def __init__(self, params: Optional[CircleParams] = None):
        super().__init__(params)

    def _detect(self, image: np.ndarray) -> list[Detection]:
        p = self._params
        grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image
        scored = self._scored(image, grey, p.param1, _ED_GRADIENT_DEFAULT)
        if not scored and p.adaptive_edges:  # nothing at the fixed thresholds: a quiet image's lower ones
            canny_high, ed_threshold = self._edge_thresholds(grey)
            if (canny_high, ed_threshold) != (p.param1, _ED_GRADIENT_DEFAULT):
                scored = self._scored(image, grey, canny_high, ed_threshold)
        scored.sort(key=lambda se: -se[1][2])  # largest first
        out = []
        for support, (cx, cy, a, b, ang) in scored[: p.max_objects]:
            outline = ellipse_points(cx, cy, a, b, ang, _OUTLINE_POINTS) if p.ellipses else None
            hw = math.hypot(a * math.cos(ang), b * math.sin(ang))
            hh = math.hypot(a * math.sin(ang), b * math.cos(ang))
            out.append(Detection(kind="circle", label="circle", score=support,
                                 box=(cx - hw, cy - hh, 2 * hw, 2 * hh), centre_px=(cx, cy), radius_px=a,
                                 contour=outline))
        return out

    def _scored(self, image: np.ndarray, grey: np.ndarray, canny_high: float, ed_threshold: int) -> list:
        """(support, shape) of the shapes found with these edge thresholds that pass min_score."""
        p = self._params
        if p.ellipses:
            shapes = self._ellipses(grey, ed_threshold)
            # edges of the colour image (Canny takes the strongest channel): a purple top on brown
            # wood is nearly the same grey
            support_image = image
        else:
            blurred = cv2.medianBlur(grey, p.blur_px) if p.blur_px > 1 else grey
            shapes = self._hough(blurred)
            support_image = grey
        scored = []
        for e in shapes:
            support = self._support(support_image, e, canny_high)
            if support >= p.min_score:
                scored.append((support, e))
        if p.ellipses:
            scored = self._suppress_nested(scored)
        return scored

    def _hough(self, blurred: np.ndarray) -> list[tuple]:
        """Hough circles as ellipses (cx, cy, r, r, 0)."""
        p = self._params
        circles = cv2.HoughCircles(blurred, CIRCLE_METHODS[p.method], p.dp, p.min_dist_px,
                                   param1=p.param1, param2=p.param2,
                                   minRadius=p.min_radius_px, maxRadius=p.max_radius_px)
        if circles is None:
            return []
        circles = np.asarray(circles, dtype=np.float64).reshape(-1, circles.shape[-1])[:, :3]
        return [(float(cx), float(cy), float(r), float(r), 0.0) for cx, cy, r in circles]

    def _edge_thresholds(self, grey: np.ndarray) -> tuple[float, int]:
        """(the support's Canny high threshold, EdgeDrawing's gradient threshold) for this image:
        the fixed ones, or with ``adaptive_edges`` lower ones on a quiet image (see the module)."""
        p = self._params
        if not p.adaptive_edges:
            return p.param1, _ED_GRADIENT_DEFAULT
        blurred = cv2.medianBlur(grey, p.blur_px) if p.blur_px > 1 else grey
        step = max(1, min(grey.shape) // 120)  # the median of a grid of pixels is enough
        gx = cv2.Sobel(blurred, cv2.CV_16S, 1, 0)[::step, ::step]
        gy = cv2.Sobel(blurred, cv2.CV_16S, 0, 1)[::step, ::step]
        median = float(np.median(np.abs(gx.astype(np.int32)) + np.abs(gy.astype(np.int32))))
        canny_high = min(p.param1, max(_CANNY_MIN, _CANNY_NOISE_FACTOR * median))
        ed = int(round(min(_ED_GRADIENT_DEFAULT, max(_ED_GRADIENT_MIN, _ED_NOISE_FACTOR * median))))
        return canny_high, ed

    def _ellipses(self, grey: np.ndarray, gradient_threshold: int = _ED_GRADIENT_DEFAULT) -> list[tuple]:
        """EdgeDrawing's ellipses (cx, cy, a ≥ b, b, angle of a in rad), round and sized enough."""
        p = self._params
        H, W = grey.shape
        scale = min(1.0, p.max_side_px / max(H, W))
        small = grey if scale == 1.0 else cv2.resize(grey, (max(1, round(W * scale)), max(1, round(H * scale))),
                                                     interpolation=cv2.INTER_AREA)
        ed = cv2.ximgproc.createEdgeDrawing()
        ed_params = cv2.ximgproc.EdgeDrawing.Params()
        ed_params.MinPathLength = _ED_MIN_PATH_PX
        ed_params.GradientThresholdValue = int(gradient_threshold)
        ed.setParams(ed_params)
        ed.detectEdges(small)
        found = ed.detectEllipses()
        if found is None:
            return []
        max_r = p.max_radius_px if p.max_radius_px > 0 else max(H, W)
        out = []
        # each row: x, y, radius (a circle) or 0, then semi-axes a, b and the angle of a (degrees)
        for x, y, r, a, b, angle_deg in np.asarray(found, dtype=np.float64).reshape(-1, 6):
            if r > 0:
                a = b = r
                angle_deg = 0.0
            ang = math.radians(angle_deg)
            if b > a:
                a, b, ang = b, a, ang + math.pi / 2
            a, b, x, y = a / scale, b / scale, x / scale, y / scale
            if a <= 0 or b / a < p.min_aspect or not (p.min_radius_px <= a <= max_r):
                continue
            out.append((x, y, a, b, ang))
        return out

    def _support(self, image: np.ndarray, e: tuple, canny_high: Optional[float] = None) -> float:
        """Fraction of the shape's perimeter samples within 1 px of an edge (outside the image: not).

        The edges are found only in the shape's box (grown by a margin for the blur and the
        Canny apertures): a few small crops cost less than the whole image."""
        p = self._params
        cx, cy, a, b, ang = e
        pts = np.rint(ellipse_points(cx, cy, a, b, ang, _SUPPORT_SAMPLES)).astype(int)
        H, W = image.shape[:2]
        inside = (pts[:, 0] >= 0) & (pts[:, 0] < W) & (pts[:, 1] >= 0) & (pts[:, 1] < H)
        pts = pts[inside]
        if len(pts) == 0:
            return 0.0
        margin = p.blur_px // 2 + 4
        x0, y0 = max(0, int(pts[:, 0].min()) - margin), max(0, int(pts[:, 1].min()) - margin)
        x1, y1 = min(W, int(pts[:, 0].max()) + margin + 1), min(H, int(pts[:, 1].max()) + margin + 1)
        crop = image[y0:y1, x0:x1]
        if p.blur_px > 1:
            crop = cv2.medianBlur(crop, p.blur_px)
        high = p.param1 if canny_high is None else canny_high
        edges = cv2.dilate(cv2.Canny(crop, high / 2, high), _DILATE)
        return min(1.0, float(np.count_nonzero(edges[pts[:, 1] - y0, pts[:, 0] - x0])) / _SUPPORT_SAMPLES)

    @staticmethod
    def _suppress_nested(scored: list) -> list:
        """Best supported first (larger first on a tie); an ellipse whose centre lies inside a kept
        one, or that holds a kept one's centre, is the same round thing seen worse: dropped."""
        kept: list = []
        for support, e in sorted(scored, key=lambda se: (-se[0], -se[1][2])):
            if any(_inside_ellipse(e[:2], k) or _inside_ellipse(k[:2], e) for _, k in kept):
                continue
            kept.append((support, e))
        return kept


def make_circles(**options) -> CircleDetector:
    """Registry factory: ``CircleDetector(CircleParams(**options))``."""
    return options_factory(CircleDetector, CircleParams, "circles")(**options)
