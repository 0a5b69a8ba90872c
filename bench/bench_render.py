"""Benchmark: one simulated stereo pair (640×480, cups scenario: 2 markers on cups, the arm drawn).

Run: ``.venv/bin/python -m bench.bench_render`` (prints the figures; never a pass/fail assert).
``rows(n)`` feeds `make bench`'s table.
"""
from __future__ import annotations

import time

import numpy as np

from core.sim.desk import SimDesk
from core.sim.rig import SimRig

# base → shoulder → elbow → tool, robot_base (m): the arm reaching over the cups
ARM_POINTS = np.array([(0.0, 0.0, 0.0), (0.0, 0.0, 0.066), (0.0, 0.06, 0.17), (0.0, 0.15, 0.12)])


def _samples_ms(desk: SimDesk, n: int) -> np.ndarray:
    for i in range(5):  # warm up: caches, first-call allocations
        desk.render(i / 30.0, ARM_POINTS)
    times = []
    for i in range(n):
        t = 3.0 + i / 30.0  # walks through swaps, so the cups move
        t0 = time.perf_counter()
        desk.render(t, ARM_POINTS)
        times.append(time.perf_counter() - t0)
    return np.array(times) * 1e3


def bench_render(n: int = 200) -> dict:
    """Median and 95th percentile wall time (ms) of ``SimDesk.render`` for a 640×480 stereo pair."""
    ms = _samples_ms(SimDesk(SimRig(), scenario="cups"), n)
    return {
        "name": "render stereo pair 640x480",
        "median_ms": float(np.median(ms)),
        "p95_ms": float(np.percentile(ms, 95)),
    }


def rows(n: int = 200) -> list[dict]:
    """Rows for `make bench`: the full render, and the same without blur and noise."""
    full = _samples_ms(SimDesk(SimRig(), scenario="cups"), n)
    bare = _samples_ms(SimDesk(SimRig(), scenario="cups", blur_sigma_px=0.0, noise_sigma=0.0), n)
    return [
        {"name": "render stereo pair 640x480", "unit": "ms", "samples": list(full), "baseline": None,
         "extra": "cups scenario, arm drawn, blur 0.6 px + noise"},
        {"name": "render stereo pair 640x480, no blur/noise", "unit": "ms", "samples": list(bare),
         "baseline": None, "extra": ""},
    ]


if __name__ == "__main__":
    r = bench_render()
    print(f"{r['name']}: median {r['median_ms']:.2f} ms, p95 {r['p95_ms']:.2f} ms")
