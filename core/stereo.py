"""Dense disparity on the rectified pair (StereoSGBM), computed only while a view shows it."""
from __future__ import annotations

import threading

import cv2
import numpy as np

from core.calibration import StereoCalibration
from core.settings import SgbmParams

_MODES = {
    "SGBM": cv2.StereoSGBM_MODE_SGBM,
    "HH": cv2.StereoSGBM_MODE_HH,
    "SGBM_3WAY": cv2.StereoSGBM_MODE_SGBM_3WAY,
    "HH4": cv2.StereoSGBM_MODE_HH4,
}


def make_sgbm(params: SgbmParams, channels: int = 1):
    """A cv2.StereoSGBM configured from ``params`` (P1/P2 automatic where 0)."""
    p1, p2 = params.penalties(channels)
    return cv2.StereoSGBM_create(
        minDisparity=params.min_disparity,
        numDisparities=params.num_disparities,
        blockSize=params.block_size,
        P1=p1,
        P2=p2,
        disp12MaxDiff=params.disp12_max_diff,
        preFilterCap=params.pre_filter_cap,
        uniquenessRatio=params.uniqueness_ratio,
        speckleWindowSize=params.speckle_window_size,
        speckleRange=params.speckle_range,
        mode=_MODES[params.mode],
    )


class DisparityComputer:
    """Rectify a raw stereo pair and compute float disparity (px) of the left rectified view.

    ``set_params`` may be called from the GUI thread; ``compute`` runs in the perception worker.
    """

    def __init__(self, calib: StereoCalibration, params: SgbmParams | None = None):
        self.calib = calib
        (self._lx, self._ly), (self._rx, self._ry) = calib.rectify_maps()
        self._lock = threading.Lock()
        self.params = params or SgbmParams()
        self._matcher = make_sgbm(self.params)

    def set_params(self, params: SgbmParams) -> None:
        with self._lock:
            self.params = params
            self._matcher = make_sgbm(params)

    def rectify(self, left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The rectified pair (same type as the input)."""
        return (
            cv2.remap(left, self._lx, self._ly, cv2.INTER_LINEAR),
            cv2.remap(right, self._rx, self._ry, cv2.INTER_LINEAR),
        )

    def compute(self, left: np.ndarray, right: np.ndarray) -> np.ndarray:
        """Disparity in pixels (float32) of the rectified left view; invalid pixels are < min."""
        gl = cv2.cvtColor(left, cv2.COLOR_BGR2GRAY) if left.ndim == 3 else left
        gr = cv2.cvtColor(right, cv2.COLOR_BGR2GRAY) if right.ndim == 3 else right
        rl, rr = self.rectify(gl, gr)
        with self._lock:
            matcher = self._matcher
        raw = matcher.compute(rl, rr)
        # SGBM returns fixed-point int16 with 4 fractional bits (TECH_NOTES: divide by 16)
        return raw.astype(np.float32) / 16.0

    def depth_m(self, disparity_px: np.ndarray) -> np.ndarray:
        """Per-pixel 3D points (H,W,3) in the rectified left camera (m) from float disparity."""
        return cv2.reprojectImageTo3D(disparity_px, self.calib.Q)
