"""Bring the two views of an unsynchronised webcam pair to one instant.

Two webcams are not triggered together: the left and right images of a "pair" are taken a few
milliseconds apart (``StereoFrame.skew_s``). A moving object has moved in between, and that
motion reads as disparity: 0.2 m/s sideways with a 16 ms lag is 3.2 mm, ~2.7 px at 50 cm with
f = 430 px, and with B = 6 cm ~27 mm of depth error (δZ = Z²·δd / (f·B)). Each view's tracker
knows its object's image velocity (px/s), so each centre can be moved to a common instant
before triangulating: first order, exact for motion that is uniform in the image over the lag.
"""
from __future__ import annotations

from typing import Optional

import numpy as np


def _vec2(value, name: str) -> np.ndarray:
    a = np.asarray(value, dtype=float).reshape(-1)
    if a.shape != (2,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be 2 finite numbers (x, y), got {value!r}")
    return a


def bring_to_instant(centre_px, velocity_px_s, t_observed: float, t_target: float) -> tuple[float, float]:
    """Where a centre seen at ``t_observed`` moving at ``velocity_px_s`` is at ``t_target``.

    ``velocity_px_s`` None (unknown) leaves the centre where it was seen.
    """
    c = _vec2(centre_px, "centre_px")
    if velocity_px_s is not None:
        c = c + _vec2(velocity_px_s, "velocity_px_s") * (float(t_target) - float(t_observed))
    return (float(c[0]), float(c[1]))


def compensate_pair(left_px, left_v, t_left: float, right_px, right_v, t_right: float,
                    t_common: Optional[float] = None) -> tuple[tuple[float, float], tuple[float, float]]:
    """Left and right centres moved to one instant ``t_common`` (default: ``t_left``, the
    frame's timestamp for a pair whose right view is the later one).

    Velocities are each view's own image velocity (px/s, e.g. ``TrackState.velocity_px_s``);
    None for a view leaves its centre unchanged.
    """
    t = float(t_left) if t_common is None else float(t_common)
    return (bring_to_instant(left_px, left_v, t_left, t),
            bring_to_instant(right_px, right_v, t_right, t))
