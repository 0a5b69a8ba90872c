"""Recording figures (`deskarm --headless --record`): what a recording costs and weighs.

- the recorder thread's cost per frame (two JPEG encodes + CDR + MCAP write), in a paced run;
- the loop with and without recording: frames per second and frame -> bytes latency of two paced
  headless runs of the same scenario and length, one after the other (the ratio is the cost the
  loop pays: queue puts only, plus the recorder thread competing for the 2 cores);
- megabytes per minute of recording, and JPEG encode of one image isolated.

The "wander" scenario moves its markers, so frames are rarely repeated (a repeated frame reuses
its JPEGs and costs nearly nothing): the per-frame cost is the real one.

A still desk ("static"): the loop's fps with and without recording, and megabytes per second of
recording, against the same run recording with ``still=False`` (every pair encoded, chunks
uncompressed: what the recorder did before a still pair re-used the last JPEGs) as the baseline.
The first second of the simulated desk is not still (its noise settles), so these runs last
at least STILL_S.
"""
from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from core.session import DeskSession, SessionOptions, freeze_startup_objects

SCENARIO = "wander"
STILL_SCENARIO = "static"
STILL_S = 6.0  # seconds of each still-desk run at least


def paced_run(duration_s: float, record_to: Path | None, scenario: str = SCENARIO, **recorder_kwargs):
    """(metrics, recorder or None) of a headless run paced at 30 fps on the simulated desk."""
    from app.headless import HeadlessRunner
    from core.record.recorder import Recorder

    session = DeskSession.create(SessionOptions(camera="sim", scenario=scenario))
    recorder = None
    if record_to is not None:
        recorder = Recorder.for_session(session, record_to, **recorder_kwargs)
        recorder.start(session.calibration, session.perception.base_T_camera, session.bridge.is_estopped)
    runner = HeadlessRunner(session, duration_s, recorder=recorder)
    freeze_startup_objects()
    try:
        metrics = runner.run()
    finally:
        if recorder is not None:
            recorder.close()
    return metrics, recorder


def jpeg_ms(n: int, quality: int = 85):
    """ms per cv2.imencode of one simulated-desk image, and the image's shape."""
    import cv2

    session = DeskSession.create(SessionOptions(camera="sim", scenario=SCENARIO))
    frame = session.camera.read()
    session.close()
    out = []
    for _ in range(n):
        t0 = time.perf_counter()
        cv2.imencode(".jpg", frame.left, [cv2.IMWRITE_JPEG_QUALITY, quality])
        out.append((time.perf_counter() - t0) * 1e3)
    return out, frame.left.shape


def rows(quick: bool = False) -> list[dict]:
    from core.record.recorder import folder_size

    duration = 2.0 if quick else 10.0
    out: list[dict] = []
    plain, _ = paced_run(duration, None)
    with tempfile.TemporaryDirectory(prefix="deskarm-bench-record-") as tmp:
        path = Path(tmp) / "bench"
        recorded, rec = paced_run(duration, path)
        size = folder_size(path)
    fps_plain = plain.frames / plain.wall_s
    fps_rec = recorded.frames / recorded.wall_s
    costs = list(rec.frame_costs_ms) or [float("nan")]
    out.append({"name": f"record: recorder thread per frame ({SCENARIO})", "unit": "ms", "samples": costs,
                "baseline": None,
                "extra": f"2 JPEG (q{rec.jpeg_quality}) + CDR + MCAP write; {rec.frames_written} frames written, "
                         f"{rec.frames_dropped} dropped, error: {rec.error or 'none'}"})
    samples, shape = jpeg_ms(30 if quick else 200)
    out.append({"name": f"record: JPEG encode one {shape[1]}x{shape[0]} image", "unit": "ms", "samples": samples,
                "baseline": None, "extra": "cv2.imencode, quality 85, isolated"})
    out.append({"name": f"record: loop fps, paced 30 fps, not recording ({SCENARIO})", "unit": "", "samples": [fps_plain],
                "baseline": None, "extra": f"{plain.frames} frames in {plain.wall_s:.1f} s"})
    out.append({"name": f"record: loop fps, paced 30 fps, recording ({SCENARIO})", "unit": "", "samples": [fps_rec],
                "baseline": None,
                "extra": f"{fps_rec / fps_plain:.3f}x the fps without recording (the same {duration:g} s run)"})
    base = f"record: latency frame->bytes, not recording ({SCENARIO})"
    out.append({"name": base, "unit": "ms", "samples": plain.latency_ms, "baseline": None, "extra": ""})
    out.append({"name": f"record: latency frame->bytes, recording ({SCENARIO})", "unit": "ms",
                "samples": recorded.latency_ms, "baseline": base,
                "extra": f"perception p50 {np.median(recorded.perception_ms):.2f} ms recording vs "
                         f"{np.median(plain.perception_ms):.2f} ms not"})
    mb_min = size / 1e6 / recorded.sim_s * 60.0 if recorded.sim_s > 0 else float("nan")
    out.append({"name": f"record: MB per minute at 30 fps ({SCENARIO})", "unit": "", "samples": [mb_min],
                "baseline": None, "extra": f"{size / 1e6:.1f} MB for {recorded.sim_s:.1f} s, JPEG quality "
                                           f"{rec.jpeg_quality}, both cameras, every topic"})
    return out + still_rows(duration)


def still_rows(duration: float) -> list[dict]:
    """A still desk: loop fps with and without recording; MB/s with still pairs re-used vs every pair encoded."""
    from core.record.recorder import folder_size

    duration = max(duration, STILL_S)
    plain, _ = paced_run(duration, None, STILL_SCENARIO)
    runs = {}
    for still in (False, True):
        with tempfile.TemporaryDirectory(prefix="deskarm-bench-record-") as tmp:
            metrics, rec = paced_run(duration, Path(tmp) / "bench", STILL_SCENARIO, still=still)
            runs[still] = (metrics, rec, folder_size(Path(tmp) / "bench"))
    fps_plain = plain.frames / plain.wall_s
    metrics, rec, size = runs[True]
    fps_rec = metrics.frames / metrics.wall_s
    tag = f"still desk ({STILL_SCENARIO})"
    base_mb = f"record: MB/s, {tag}, as before (every pair, no zstd)"
    out = [
        {"name": f"record: loop fps, paced 30 fps, not recording ({STILL_SCENARIO})", "unit": "", "samples": [fps_plain],
         "baseline": None, "extra": f"{plain.frames} frames in {plain.wall_s:.1f} s"},
        {"name": f"record: loop fps, paced 30 fps, recording ({STILL_SCENARIO})", "unit": "", "samples": [fps_rec],
         "baseline": None, "extra": f"{fps_rec / fps_plain:.3f}x the fps without recording (the same {duration:g} s run)"},
    ]
    for still, name in ((False, base_mb), (True, f"record: MB/s, {tag}, still pairs re-use their JPEGs")):
        m, r, sz = runs[still]
        mb_s = sz / 1e6 / m.sim_s if m.sim_s > 0 else float("nan")
        costs = list(r.frame_costs_ms) or [float("nan")]
        out.append({"name": name, "unit": "", "samples": [mb_s], "baseline": None if not still else base_mb, "less": "less",
                    "extra": f"{sz / 1e6:.2f} MB for {m.sim_s:.1f} s; {r.frames_written} frames, {r.frames_still} "
                             f"re-used, {r.frames_dropped} dropped; recorder thread p50 {np.median(costs):.2f} ms/frame"})
    return out


if __name__ == "__main__":
    from bench.__main__ import format_table

    print(format_table(rows()))
