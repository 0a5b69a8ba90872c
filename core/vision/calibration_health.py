"""Is the stereo calibration still right? Watch the vertical offset of matched markers.

After rectification a marker's centre lies on the same image row in both views. A camera knocked
on its mount, or a calibration made for another rig, shows up as a vertical offset between the
views. ``CalibrationHealth`` is fed every PerceptionResult and keeps the offsets of recent
detections; when their median exceeds the threshold (1 px) it says "calibration may have drifted"
with the number — the window shows that as a banner.
"""
from __future__ import annotations

import collections
from dataclasses import dataclass
from typing import Deque, Optional

import numpy as np

from core.messages import PerceptionResult

DRIFT_THRESHOLD_PX = 1.0


@dataclass(frozen=True)
class HealthStatus:
    """The calibration's health as the window shows it."""

    median_dy_px: Optional[float]  # median |vertical offset| of recent matched markers (px), None: too few
    samples: int  # detections in the window
    drifted: bool  # median above the threshold
    message: str  # "" when fine or unknown, else the banner text


class CalibrationHealth:
    """Median rectified vertical offset of matched marker centres over the last ``window`` detections."""

    def __init__(self, window: int = 60, threshold_px: float = DRIFT_THRESHOLD_PX, min_samples: int = 10):
        if not (1 <= window <= 100_000):
            raise ValueError(f"health window = {window} is outside 1 … 100000 detections")
        if not (0.05 <= threshold_px <= 100):
            raise ValueError(f"health threshold_px = {threshold_px} is outside 0.05 … 100 px")
        if not (1 <= min_samples <= window):
            raise ValueError(f"health min_samples = {min_samples} must be within 1 … window ({window})")
        self.window = int(window)
        self.threshold_px = float(threshold_px)
        self.min_samples = int(min_samples)
        self._dy: Deque[float] = collections.deque(maxlen=self.window)
        self._last_seq: Optional[int] = None

    def reset(self) -> None:
        """Forget the history (after loading a new calibration)."""
        self._dy.clear()
        self._last_seq = None

    def feed(self, result: PerceptionResult) -> None:
        """Add the matched markers of one result (a result seen twice is counted once)."""
        if result.seq == self._last_seq:
            return
        self._last_seq = result.seq
        for m in result.markers:
            if m.found and m.epipolar_dy_px is not None and np.isfinite(m.epipolar_dy_px):
                self._dy.append(abs(float(m.epipolar_dy_px)))

    def add(self, dy_px: float) -> None:
        """Add one offset directly (px)."""
        self._dy.append(abs(float(dy_px)))

    @property
    def samples(self) -> int:
        return len(self._dy)

    @property
    def median_dy_px(self) -> Optional[float]:
        if len(self._dy) < self.min_samples:
            return None
        return float(np.median(self._dy))

    @property
    def drifted(self) -> bool:
        med = self.median_dy_px
        return med is not None and med > self.threshold_px

    def message(self) -> str:
        """The banner text, "" while the calibration looks fine (or too few markers were seen)."""
        med = self.median_dy_px
        if med is None or med <= self.threshold_px:
            return ""
        return (f"calibration may have drifted: matched markers are {med:.1f} px apart vertically in the "
                f"rectified images (median of the last {len(self._dy)}, allowed {self.threshold_px:g} px) "
                f"— recalibrate with `deskarm calibrate`")

    def status(self) -> HealthStatus:
        med = self.median_dy_px
        return HealthStatus(med, len(self._dy), self.drifted, self.message())


__all__ = ["CalibrationHealth", "HealthStatus", "DRIFT_THRESHOLD_PX"]
