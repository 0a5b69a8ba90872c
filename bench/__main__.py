"""`make bench`: deskarm's performance table (median and p95; ratios against a baseline
measured in the same run). Figures live here, never as timing asserts in tests.

``python -m bench`` (``make bench``) takes fewer samples and shorter runs (a few minutes on 2
cores); ``python -m bench --full`` (``make bench-full``) the long ones (about 20 minutes)."""
from __future__ import annotations

import sys
import time

import numpy as np


def _row(name, unit, samples, baseline=None, extra=""):
    return {"name": name, "unit": unit, "samples": list(samples), "baseline": baseline, "extra": extra}


# the bench modules, in the table's order (bench_assist_window compares with bench_window's idle row)
MODULES = ("bench_perception", "bench_ik", "bench_render", "bench_calibration", "bench_serial", "bench_rtx", "bench_pipeline",
           "bench_record", "bench_window", "bench_assist_window", "bench_detect", "bench_assist", "bench_startup",
           "bench_remote", "bench_teach")
OPTIONAL = {"bench_ik", "bench_render", "bench_remote", "bench_teach"}  # a missing extra (ikpy, zenoh…) skips only these


def _module_rows(name: str, quick: bool) -> list[dict]:
    import importlib

    mod = importlib.import_module(f"bench.{name}")
    if name == "bench_perception":
        return mod.bench_perception(60 if quick else 300)
    if name == "bench_ik":
        return mod.rows(2000 if quick else 20000)
    if name == "bench_render":
        return mod.rows(20 if quick else 200)
    return mod.rows(quick)


def collect(quick: bool = False, timings: dict | None = None) -> list[dict]:
    """Run every benchmark; ``quick`` uses fewer samples (``make bench``; ``--full``: the long
    runs). ``timings`` (when given) receives the wall seconds each module took."""
    rows: list[dict] = []
    for name in MODULES:
        t0 = time.perf_counter()
        try:
            rows += _module_rows(name, quick)
        except (ImportError, RuntimeError) as exc:
            if name not in OPTIONAL or (isinstance(exc, RuntimeError) and name != "bench_remote"):
                raise
            print(f"bench: {name} unavailable: {exc}", file=sys.stderr)  # reported, not hidden
        if timings is not None:
            timings[name] = time.perf_counter() - t0
    return rows


def format_table(rows: list[dict]) -> str:
    by_name = {r["name"]: r for r in rows}
    lines = [f"{'benchmark':48s} {'median':>11s} {'p95':>11s} {'n':>6s}  vs baseline"]
    lines.append("-" * 100)
    for r in rows:
        s = np.asarray(r["samples"], dtype=float)
        med, p95 = float(np.median(s)), float(np.percentile(s, 95))
        ratio = ""
        base = by_name.get(r.get("baseline") or "")
        if base is not None:
            bmed = float(np.median(base["samples"]))
            if med > 0 and med <= bmed:  # a row of sizes says "less" (``less``), of times "faster"
                ratio = f"{bmed / med:5.2f}x {r.get('less', 'faster')} than '{base['name']}'"
            elif bmed > 0:
                ratio = f"{med / bmed:5.2f}x the time of '{base['name']}'"
        unit = r["unit"]
        lines.append(f"{r['name']:48s} {med:9.3f}{unit:>2s} {p95:9.3f}{unit:>2s} {len(s):6d}  {ratio}")
        if r.get("extra"):
            lines.append(f"{'':48s}   {r['extra']}")
    return "\n".join(lines)


def main() -> int:
    import os

    if "--pi" in sys.argv:  # python -m bench --pi (make bench-pi): the Pi budget table only (bench/bench_pi.py)
        from bench import bench_pi

        return bench_pi.main([a for a in sys.argv[1:] if a != "--pi"])
    full = "--full" in sys.argv
    t0 = time.perf_counter()
    timings: dict = {}
    rows = collect(quick=not full, timings=timings)
    print(format_table(rows))
    spent = ", ".join(f"{k.removeprefix('bench_')} {v:.0f} s" for k, v in timings.items())
    print(f"\n({'--full' if full else 'default (fewer samples; --full for the long runs)'}: total "
          f"{time.perf_counter() - t0:.1f} s — {spent}; {os.cpu_count()} cores, "
          f"cv2 threads {__import__('cv2').getNumThreads()})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
