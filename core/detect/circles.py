"""Round things: ``cv2.HoughCircles`` on a median-blurred grey image, largest first."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import cv2
import numpy as np

from core.detect.base import BaseDetector, Detection, options_factory
from core.settings import SettingsError, check_range

CIRCLE_METHODS = {"HOUGH_GRADIENT": cv2.HOUGH_GRADIENT, "HOUGH_GRADIENT_ALT": cv2.HOUGH_GRADIENT_ALT}
_SUPPORT_SAMPLES = 64  # points on each circle checked for an edge (the score)
_CIRCLE_UNIT = np.stack([np.cos(np.linspace(0, 2 * np.pi, _SUPPORT_SAMPLES, endpoint=False)),
                         np.sin(np.linspace(0, 2 * np.pi, _SUPPORT_SAMPLES, endpoint=False))], axis=1)


@dataclass(frozen=True)
class CircleParams:
    """Settings of ``CircleDetector`` (names follow ``cv2.HoughCircles``)."""

    method: str = "HOUGH_GRADIENT"  # HOUGH_GRADIENT or HOUGH_GRADIENT_ALT (more accurate, needs param2 ≤ 1)
    dp: float = 1.0  # accumulator resolution: image px per accumulator cell, 1 … 4
    min_dist_px: float = 20.0  # closest two circle centres may be, px, 1 … 10000
    param1: float = 100.0  # Canny high threshold, 1 … 1000 (ALT works best near 300)
    param2: float = 30.0  # GRADIENT: accumulator votes, 1 … 1000 (fewer = more false circles); ALT: perfectness 0.01 … 1
    min_radius_px: int = 5  # smallest radius, px, 0 … 10000
    max_radius_px: int = 0  # largest radius, px, 0 (image size) or min_radius_px … 10000
    blur_px: int = 5  # median blur aperture, px, odd 1 (off) … 15
    max_objects: int = 10  # most circles reported (largest first), 1 … 1000
    min_score: float = 0.6  # least edge support kept (see CircleDetector), 0 (keep all) … 1

    def __post_init__(self) -> None:
        if self.method not in CIRCLE_METHODS:
            raise SettingsError(f"circles.method = {self.method!r} must be one of {', '.join(CIRCLE_METHODS)}")
        check_range("circles", "dp", self.dp, 1.0, 4.0)
        check_range("circles", "min_dist_px", self.min_dist_px, 1.0, 10000.0)
        check_range("circles", "param1", self.param1, 1.0, 1000.0)
        if self.method == "HOUGH_GRADIENT_ALT":
            check_range("circles", "param2", self.param2, 0.01, 1.0)
        else:
            check_range("circles", "param2", self.param2, 1.0, 1000.0)
        for field in ("min_radius_px", "max_radius_px", "blur_px", "max_objects"):
            value = getattr(self, field)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise SettingsError(f"circles.{field} = {value!r} must be a whole number")
        check_range("circles", "min_radius_px", self.min_radius_px, 0, 10000)
        if self.max_radius_px != 0:
            check_range("circles", "max_radius_px", self.max_radius_px, max(1, self.min_radius_px), 10000)
        check_range("circles", "blur_px", self.blur_px, 1, 15)
        if self.blur_px % 2 == 0:
            raise SettingsError(f"circles.blur_px = {self.blur_px} must be odd (1 = off, 3, 5, …, 15)")
        check_range("circles", "max_objects", self.max_objects, 1, 1000)
        check_range("circles", "min_score", self.min_score, 0.0, 1.0)


class CircleDetector(BaseDetector):
    """Circles by the Hough transform, largest radius first (as the delta controller picked them).

    ``score`` is the fraction of 64 points on the circle that lie within 1 px of a Canny edge
    (thresholds param1 / 2 … param1): ~1 for a crisp full circle, lower for arcs and ghosts;
    circles below ``min_score`` are dropped (HOUGH_GRADIENT without a maximum radius otherwise
    reports image-sized circles through unrelated edges, which "largest first" would put on top).
    """

    name = "circles"
    params_type = CircleParams

    def __init__(self, params: Optional[CircleParams] = None):
        super().__init__(params)

    def _detect(self, image: np.ndarray) -> list[Detection]:
        p = self._params
        grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image
        if p.blur_px > 1:
            grey = cv2.medianBlur(grey, p.blur_px)
        circles = cv2.HoughCircles(grey, CIRCLE_METHODS[p.method], p.dp, p.min_dist_px,
                                   param1=p.param1, param2=p.param2,
                                   minRadius=p.min_radius_px, maxRadius=p.max_radius_px)
        if circles is None:
            return []
        circles = np.asarray(circles, dtype=np.float64).reshape(-1, circles.shape[-1])[:, :3]
        circles = circles[np.argsort(-circles[:, 2], kind="stable")]
        edges = cv2.dilate(cv2.Canny(grey, p.param1 / 2, p.param1), np.ones((3, 3), np.uint8))
        H, W = grey.shape
        out = []
        for cx, cy, r in circles:
            pts = np.rint(np.array([cx, cy]) + r * _CIRCLE_UNIT).astype(int)
            inside = (pts[:, 0] >= 0) & (pts[:, 0] < W) & (pts[:, 1] >= 0) & (pts[:, 1] < H)
            pts = pts[inside]
            support = min(1.0, float(np.count_nonzero(edges[pts[:, 1], pts[:, 0]])) / _SUPPORT_SAMPLES)
            if support < p.min_score:
                continue  # a ghost: HOUGH_GRADIENT's large circles through unrelated edges
            out.append(Detection(kind="circle", label="circle", score=support,
                                 box=(cx - r, cy - r, 2 * r, 2 * r), centre_px=(cx, cy), radius_px=r))
            if len(out) == p.max_objects:
                break
        return out


def make_circles(**options) -> CircleDetector:
    """Registry factory: ``CircleDetector(CircleParams(**options))``."""
    return options_factory(CircleDetector, CircleParams, "circles")(**options)
