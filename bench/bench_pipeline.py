"""Whole-pipeline figures: the headless runner paced at 30 fps, and SGBM disparity."""
from __future__ import annotations

import time

import cv2

from core.session import DeskSession, SessionOptions


def headless_rows(duration_s: float) -> list[dict]:
    from app.headless import HeadlessRunner

    session = DeskSession.create(SessionOptions(camera="sim", scenario="static"))
    runner = HeadlessRunner(session, duration_s)
    m = runner.run()
    s = m.summary()
    extra = (f"paced run {duration_s:g} s: {s['fps']} fps, 3D error p50 {s['error_3d_mm_p50']} mm "
             f"p95 {s['error_3d_mm_p95']} mm, limit violations {s['limit_violations']}")
    return [
        {"name": "headless frame -> bytes written latency", "unit": "ms", "samples": m.latency_ms,
         "extra": extra},
    ]


def sgbm_rows(n: int) -> list[dict]:
    from bench.bench_perception import render_frames
    from core.settings import SgbmParams
    from core.stereo import DisparityComputer

    rig, frames = render_frames(3)
    calib = rig.calibration()
    rows = []
    for size in ((640, 480), (544, 288)):
        left = cv2.resize(frames[0].left, size)
        right = cv2.resize(frames[0].right, size)
        from core.calibration import StereoCalibration

        scale = size[0] / 640.0
        M = calib.M1.copy()
        M[0, :] *= scale
        M[1, :] *= size[1] / 480.0
        c = StereoCalibration(M, calib.D1, M.copy(), calib.D2, calib.R, calib.T, size)
        for mode in ("SGBM_3WAY", "SGBM"):
            d = DisparityComputer(c, SgbmParams(mode=mode))
            samples = []
            for _ in range(n):
                t0 = time.perf_counter()
                d.compute(left, right)
                samples.append((time.perf_counter() - t0) * 1e3)
            rows.append({"name": f"SGBM {mode} nd64 bs5 {size[0]}x{size[1]} (+remap)", "unit": "ms", "samples": samples})
    return rows


def rows(quick: bool = False) -> list[dict]:
    return headless_rows(2.0 if quick else 5.0) + sgbm_rows(3 if quick else 15)
