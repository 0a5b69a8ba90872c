"""Whole-pipeline figures: the headless runner paced at 30 fps."""
from __future__ import annotations

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


def rows(quick: bool = False) -> list[dict]:
    # SGBM/BM timings live in bench_calibration (every mode, both resolutions, WLS, half-res)
    return headless_rows(2.0 if quick else 5.0)
