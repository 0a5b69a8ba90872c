"""Perception per stereo pair at 640x480 with 2 markers: our pipeline vs a naive one, same run.

The naive pipeline is what a first implementation does (and what the original framework did):
remap both images into the rectified pair, detect markers on both full frames every frame,
match by id and triangulate. Rendering is excluded: frames are rendered up front.
"""
from __future__ import annotations

import time

import cv2
import numpy as np

from core.sim.desk import SimDesk
from core.sim.rig import SimRig
from core.vision.perception import (
    StereoMarkerPerception,
    detect_markers,
    make_detector,
    quad_centre,
)


class NaiveStereoPerception:
    """Full-frame detection in both rectified images every frame (the baseline)."""

    def __init__(self, calib, base_T_camera):
        self.calib = calib
        self.base_T_camera = base_T_camera
        (self.lx, self.ly), (self.rx, self.ry) = calib.rectify_maps()
        self.detector = make_detector()

    def process(self, left, right) -> dict[int, np.ndarray]:
        rl = cv2.remap(left, self.lx, self.ly, cv2.INTER_LINEAR)
        rr = cv2.remap(right, self.rx, self.ry, cv2.INTER_LINEAR)
        dl = detect_markers(self.detector, rl)
        dr = detect_markers(self.detector, rr)
        out = {}
        for i in sorted(set(dl) & set(dr)):
            cl, cr = quad_centre(dl[i]), quad_centre(dr[i])
            X = cv2.triangulatePoints(self.calib.P1, self.calib.P2, cl.reshape(2, 1), cr.reshape(2, 1))
            cam = self.calib.R1.T @ (X[:3, 0] / X[3, 0])
            out[i] = self.base_T_camera[:3, :3] @ cam + self.base_T_camera[:3, 3]
        return out


def render_frames(n: int, scenario: str = "static", seed: int = 0):
    """n stereo pairs of the simulated desk (markers moving slowly in 'wander')."""
    from core.messages import StereoFrame

    rig = SimRig()
    desk = SimDesk(rig, scenario=scenario, seed=seed)
    frames = []
    for k in range(n):
        left, right, truth = desk.render(k / 30.0)
        frames.append(StereoFrame(seq=k + 1, t=k / 30.0, left=left, right=right, truth=truth))
    return rig, frames


def bench_perception(n: int = 300) -> list[dict]:
    """Median/p95 ms per stereo pair for ours and the naive pipeline, plus the 3D errors."""
    rig, frames = render_frames(n)
    calib = rig.calibration()
    ours = StereoMarkerPerception(calib, rig.base_T_camera)
    naive = NaiveStereoPerception(calib, rig.base_T_camera)
    t_ours, t_naive, err_ours, err_naive = [], [], [], []
    for f in frames:  # interleave so both see the same machine state
        t0 = time.perf_counter()
        r = ours.process(f)
        t1 = time.perf_counter()
        found = naive.process(f.left, f.right)
        t2 = time.perf_counter()
        t_ours.append((t1 - t0) * 1e3)
        t_naive.append((t2 - t1) * 1e3)
        for obj in f.truth.objects:
            if obj.marker_id < 0:
                continue
            obs = r.marker(obj.marker_id)
            if obs is not None and obs.found:
                err_ours.append(np.linalg.norm(np.subtract(obs.base_p_centre, obj.base_p_centre)) * 1e3)
            if obj.marker_id in found:
                err_naive.append(np.linalg.norm(found[obj.marker_id] - obj.base_p_centre) * 1e3)
    return [
        {"name": "perception, ours (ROI + point rectify)", "unit": "ms", "samples": t_ours,
         "baseline": "perception, naive (remap + full frames)",
         "extra": f"3D error p50 {np.median(err_ours):.2f} mm p95 {np.percentile(err_ours, 95):.2f} mm"},
        {"name": "perception, naive (remap + full frames)", "unit": "ms", "samples": t_naive,
         "extra": f"3D error p50 {np.median(err_naive):.2f} mm p95 {np.percentile(err_naive, 95):.2f} mm"},
    ]
