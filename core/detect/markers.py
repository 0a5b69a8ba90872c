"""ArUco / AprilTag markers as ``Detection`` objects (an adapter over ``core.vision.perception``)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from core.detect.base import BaseDetector, Detection, box_of_points, check_image, clip_roi, options_factory
from core.settings import SettingsError
from core.vision.perception import (
    DEFAULT_DICTIONARY,
    CropDetector,
    detect_markers,
    dictionary_name,
    dictionary_size,
    make_detector,
    quad_centre,
)


@dataclass(frozen=True)
class ArucoParams:
    """Settings of ``ArucoDetector``."""

    dictionary: str = DEFAULT_DICTIONARY  # a name of ARUCO_DICTIONARIES (or an alias, stored canonical)
    fast: bool = False  # one 15 px threshold window: ~5x faster on a textured desk, weaker in hard light
    ids: tuple[int, ...] = ()  # report only these ids (empty: every id of the dictionary)

    def __post_init__(self) -> None:
        try:
            name = dictionary_name(self.dictionary)
        except ValueError as exc:
            raise SettingsError(f"aruco.dictionary: {exc}") from None
        object.__setattr__(self, "dictionary", name)
        if not isinstance(self.fast, bool):
            raise SettingsError(f"aruco.fast = {self.fast!r} must be true or false")
        try:
            ids = tuple(int(i) for i in self.ids)
        except (TypeError, ValueError):
            raise SettingsError(f"aruco.ids = {self.ids!r} must be whole numbers") from None
        size = dictionary_size(name)
        bad = [i for i in ids if not 0 <= i < size]
        if bad:
            raise SettingsError(f"aruco.ids {bad} are outside the allowed range 0…{size - 1} of {name}")
        object.__setattr__(self, "ids", ids)


class ArucoDetector(BaseDetector):
    """Markers of one dictionary: label = the id as text, score 1.0, ``corners`` (4, 2) in
    OpenCV's order (top-left, top-right, bottom-right, bottom-left of the printed marker), centre
    at the diagonals' intersection, radius = half the mean side."""

    name = "aruco"
    params_type = ArucoParams

    def __init__(self, params: Optional[ArucoParams] = None):
        super().__init__(params)
        self._detector = make_detector(self._params.dictionary, fast=self._params.fast)
        self._crops = CropDetector()

    def detect(self, image_bgr: np.ndarray, roi: Optional[Sequence[float]] = None) -> list[Detection]:
        """As ``BaseDetector.detect``; inside a ROI the smallest marker accepted stays the full
        image's (``CropDetector``), so a window search is faster than the full frame, not slower."""
        image = check_image(image_bgr)
        box = clip_roi(roi, image.shape)
        if box is None:
            return self._detect(image)
        x, y, w, h = box
        crop_detector = self._crops.for_crop(self._detector, max(image.shape[:2]), max(w, h))
        return [d.shifted(x, y) for d in self._detections(detect_markers(crop_detector, image[y:y + h, x:x + w]))]

    def _detect(self, image: np.ndarray) -> list[Detection]:
        return self._detections(detect_markers(self._detector, image))

    def _detections(self, found: dict) -> list[Detection]:
        wanted = set(self._params.ids)
        out = []
        for marker_id, corners in sorted(found.items()):
            if wanted and marker_id not in wanted:
                continue
            sides = np.linalg.norm(corners - np.roll(corners, -1, axis=0), axis=1)
            out.append(Detection(kind="marker", label=str(marker_id), score=1.0, box=box_of_points(corners),
                                 centre_px=tuple(quad_centre(corners)), radius_px=float(sides.mean()) / 2,
                                 corners=corners))
        return out


def make_aruco(**options) -> ArucoDetector:
    """Registry factory: ``ArucoDetector(ArucoParams(**options))``."""
    return options_factory(ArucoDetector, ArucoParams, "aruco")(**options)
