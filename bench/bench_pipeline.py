"""Whole-pipeline figures: the headless runner paced at 30 fps on the simulated desk, as a user
runs it (`deskarm --headless --scenario S --json`).

- frame -> bytes written latency, tick-driven (the control step waits for its 50 Hz tick, as
  before) against event-driven (it runs at once for each new perception result), per scenario;
- perception as it costs inside those runs (computed frames only; repeated frames whose answer
  is reused cost nothing and are left out), against the isolated perception bench of the same
  run (``bench_perception``: frames rendered up front, processed back to back).
"""
from __future__ import annotations

import numpy as np

from core.session import DeskSession, SessionOptions, freeze_startup_objects

SCENARIOS = ("cups", "static", "wander")
ISOLATED = "perception, ours (ROI + point rectify)"  # bench_perception's row


def headless_run(scenario: str, event_driven: bool, duration_s: float):
    from app.headless import HeadlessRunner

    session = DeskSession.create(SessionOptions(camera="sim", scenario=scenario, event_driven=event_driven))
    runner = HeadlessRunner(session, duration_s)
    freeze_startup_objects()  # as `deskarm --headless` does
    return runner.run()


def _p95(values) -> float:
    return float(np.percentile(values, 95)) if len(values) else float("nan")


def rows(quick: bool = False) -> list[dict]:
    # SGBM/BM timings live in bench_calibration (every mode, both resolutions, WLS, half-res)
    duration = 1.5 if quick else 6.0
    out: list[dict] = []
    for scenario in SCENARIOS:
        tick = headless_run(scenario, False, duration)
        event = headless_run(scenario, True, duration)
        tick_name = f"latency frame->bytes, tick-driven ({scenario})"
        target = _p95(event.perception_ms) + 5.0
        verdict = "met" if _p95(event.latency_ms) <= target else "NOT met"
        out.append({"name": tick_name, "unit": "ms", "samples": tick.latency_ms, "baseline": None,
                    "extra": f"as before: a new goal waits for the 50 Hz tick; {tick.frames / tick.wall_s:.1f} fps"})
        out.append({"name": f"latency frame->bytes, event-driven ({scenario})", "unit": "ms",
                    "samples": event.latency_ms, "baseline": tick_name,
                    "extra": f"target p95 <= perception p95 + 5 ms = {target:.1f} ms: {verdict}; "
                             f"{event.frames / event.wall_s:.1f} fps, {event.frames_reused} of {event.frames} "
                             f"frames repeated (reused), limit violations {event.limit_violations}"})
        samples = event.perception_ms
        out.append({"name": f"perception in the headless pipeline ({scenario})", "unit": "ms",
                    "samples": samples if len(samples) else [float("nan")], "baseline": ISOLATED,
                    "extra": f"{len(samples)} computed frames of a paced {duration:g} s run; target p50 <= 1.3x isolated"})
    return out
