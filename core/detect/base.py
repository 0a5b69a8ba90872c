"""What every detector returns and how it is called: ``Detection``, ``Detector`` and the ROI helpers.

A detector looks at one BGR image (optionally only inside a region of interest) and returns
``Detection`` objects in full-image pixel coordinates (OpenCV's convention: pixel (0, 0) is
centred at 0.0). Its settings are a frozen dataclass validated in ``__post_init__``;
``with_params(**changes)`` returns a new detector with some settings changed.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, replace
from typing import Any, Optional, Protocol, Sequence, runtime_checkable

import numpy as np

DETECTION_KINDS = ("marker", "colour", "circle", "object", "board", "diamond")

Box = tuple[int, int, int, int]  # (x, y, w, h) in px


@dataclass(frozen=True, eq=False)
class Detection:
    """One thing found in an image, in full-image pixel coordinates."""

    kind: str  # one of DETECTION_KINDS
    label: str  # marker id as text, colour name, or class name
    score: float  # confidence 0 … 1 (markers 1.0; see each detector for its meaning)
    box: tuple[float, float, float, float]  # (x, y, w, h) px, axis-aligned, top-left corner first
    centre_px: tuple[float, float]  # (x, y) px
    radius_px: Optional[float] = None  # circles and blobs: radius (px); None when meaningless
    corners: Optional[np.ndarray] = None  # markers: (4, 2) float64 px, OpenCV's corner order
    contour: Optional[np.ndarray] = None  # blobs: (N, 2) px outline
    points: Optional[np.ndarray] = None  # boards: (N, 2) px, the chessboard corners found
    point_ids: Optional[tuple[int, ...]] = None  # boards: each point's corner id on the board

    def __post_init__(self) -> None:
        if self.kind not in DETECTION_KINDS:
            raise ValueError(f"detection.kind = {self.kind!r} must be one of {', '.join(DETECTION_KINDS)}")
        score = float(self.score)
        if not (0.0 <= score <= 1.0):
            raise ValueError(f"detection.score = {self.score!r} is outside the allowed range 0…1")
        object.__setattr__(self, "score", score)
        object.__setattr__(self, "label", str(self.label))
        object.__setattr__(self, "box", tuple(float(v) for v in self.box))
        object.__setattr__(self, "centre_px", tuple(float(v) for v in self.centre_px))
        if self.radius_px is not None:
            object.__setattr__(self, "radius_px", float(self.radius_px))
        if self.corners is not None:
            c = np.asarray(self.corners, dtype=np.float64).reshape(4, 2)
            c.setflags(write=False)
            object.__setattr__(self, "corners", c)
        if self.contour is not None:
            c = np.asarray(self.contour, dtype=np.float64).reshape(-1, 2)
            c.setflags(write=False)
            object.__setattr__(self, "contour", c)
        if self.points is not None:
            c = np.asarray(self.points, dtype=np.float64).reshape(-1, 2)
            c.setflags(write=False)
            object.__setattr__(self, "points", c)
        if self.point_ids is not None:
            object.__setattr__(self, "point_ids", tuple(int(i) for i in self.point_ids))

    def shifted(self, dx: float, dy: float) -> "Detection":
        """The same detection moved by (dx, dy) px (a crop's result into full-image coordinates)."""
        if dx == 0 and dy == 0:
            return self
        offset = np.array([dx, dy], dtype=np.float64)
        x, y, w, h = self.box
        return replace(
            self,
            box=(x + dx, y + dy, w, h),
            centre_px=(self.centre_px[0] + dx, self.centre_px[1] + dy),
            corners=None if self.corners is None else self.corners + offset,
            contour=None if self.contour is None else self.contour + offset,
            points=None if self.points is None else self.points + offset,
        )

    def to_dict(self, contour: bool = False) -> dict[str, Any]:
        """Plain JSON-ready data (the contour only when asked: it can be long)."""
        out: dict[str, Any] = {
            "kind": self.kind,
            "label": self.label,
            "score": round(self.score, 4),
            "box": [round(v, 2) for v in self.box],
            "centre_px": [round(v, 2) for v in self.centre_px],
            "radius_px": None if self.radius_px is None else round(self.radius_px, 2),
        }
        if self.corners is not None:
            out["corners"] = [[round(float(x), 2), round(float(y), 2)] for x, y in self.corners]
        if self.points is not None:
            out["points"] = [[round(float(x), 2), round(float(y), 2)] for x, y in self.points]
        if self.point_ids is not None:
            out["point_ids"] = list(self.point_ids)
        if contour and self.contour is not None:
            out["contour"] = [[round(float(x), 2), round(float(y), 2)] for x, y in self.contour]
        return out


@runtime_checkable
class Detector(Protocol):
    """Anything that finds ``Detection`` objects in a BGR image."""

    name: str  # short name, as in the registry ("hsv", "circles", "aruco", "onnx:…")

    @property
    def params(self) -> Any:
        """The frozen settings dataclass this detector runs with."""

    def detect(self, image_bgr: np.ndarray, roi: Optional[Sequence[int]] = None) -> list[Detection]:
        """Detections in ``image_bgr`` (only inside ``roi`` = (x, y, w, h) when given), full-image px."""

    def with_params(self, **changes) -> "Detector":
        """A new detector of the same kind with some settings changed (validated)."""


def check_image(image_bgr: np.ndarray) -> np.ndarray:
    """``image_bgr`` when it is an 8-bit BGR (H, W, 3) or grey (H, W) image, else ValueError."""
    if not isinstance(image_bgr, np.ndarray) or image_bgr.dtype != np.uint8 or not (
        image_bgr.ndim == 2 or (image_bgr.ndim == 3 and image_bgr.shape[2] == 3)
    ) or image_bgr.size == 0:
        what = f"{image_bgr.dtype} array of shape {image_bgr.shape}" if isinstance(image_bgr, np.ndarray) \
            else type(image_bgr).__name__
        raise ValueError(f"image must be an 8-bit BGR (H, W, 3) or grey (H, W) array, not a {what}")
    return image_bgr


def clip_roi(roi: Optional[Sequence[float]], shape) -> Optional[Box]:
    """``roi`` (x, y, w, h) clipped to an image of ``shape``; None for the whole image.

    ValueError when the ROI is malformed or lies entirely outside the image.
    """
    if roi is None:
        return None
    try:
        x, y, w, h = (float(v) for v in roi)
    except (TypeError, ValueError):
        raise ValueError(f"roi = {roi!r} must be (x, y, w, h) in px") from None
    if not all(math.isfinite(v) for v in (x, y, w, h)) or w <= 0 or h <= 0:
        raise ValueError(f"roi = {roi!r} must have finite values and a positive width and height")
    H, W = shape[:2]
    x0, y0 = max(0, int(math.floor(x))), max(0, int(math.floor(y)))
    x1, y1 = min(W, int(math.ceil(x + w))), min(H, int(math.ceil(y + h)))
    if x1 <= x0 or y1 <= y0:
        raise ValueError(f"roi = {roi!r} lies outside the {W}x{H} image")
    return x0, y0, x1 - x0, y1 - y0


class BaseDetector:
    """Shared plumbing: image check, ROI crop and shift back, ``with_params``.

    Subclasses set ``name`` and ``params_type`` and implement ``_detect(image)`` on the (cropped)
    image, returning detections in that image's coordinates.
    """

    name = "base"
    params_type: type = object
    heavy = False  # a network a view (StereoObjectPerception then searches one view a frame between full searches)

    def __init__(self, params=None):
        if params is None:
            params = self.params_type()
        if not isinstance(params, self.params_type):
            raise TypeError(f"{type(self).__name__} needs a {self.params_type.__name__}, not {type(params).__name__}")
        self._params = params

    @property
    def params(self):
        return self._params

    def with_params(self, **changes):
        """A new detector with ``changes`` applied to the settings (SettingsError when out of range)."""
        return type(self)(replace(self._params, **changes))

    def detect(self, image_bgr: np.ndarray, roi: Optional[Sequence[float]] = None) -> list[Detection]:
        """Detections in the image, or only inside ``roi`` = (x, y, w, h); full-image px either way."""
        image = check_image(image_bgr)
        box = clip_roi(roi, image.shape)
        if box is None:
            return self._detect(image)
        x, y, w, h = box
        return [d.shifted(x, y) for d in self._detect(image[y:y + h, x:x + w])]

    def _detect(self, image: np.ndarray) -> list[Detection]:  # pragma: no cover - abstract
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self._params!r})"


def box_of_points(pts: np.ndarray) -> tuple[float, float, float, float]:
    """Axis-aligned (x, y, w, h) around points (N, 2)."""
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    return float(lo[0]), float(lo[1]), float(hi[0] - lo[0]), float(hi[1] - lo[1])


def options_factory(detector_type, params_type, what: str):
    """A factory building ``detector_type(params_type(**options))``; an unknown option is a
    ValueError naming the valid ones (for the registry)."""
    fields = [f.name for f in dataclasses.fields(params_type)]

    def factory(**options):
        unknown = sorted(set(options) - set(fields))
        if unknown:
            raise ValueError(f"{what} detector has no option {', '.join(unknown)}; valid: {', '.join(fields)}")
        return detector_type(params_type(**options))

    factory.__name__ = f"make_{what}"
    return factory
