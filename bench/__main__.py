"""`make bench`: deskarm's performance table (median and p95; ratios against a baseline
measured in the same run). Figures live here, never as timing asserts in tests."""
from __future__ import annotations

import sys
import time

import numpy as np


def _row(name, unit, samples, baseline=None, extra=""):
    return {"name": name, "unit": unit, "samples": list(samples), "baseline": baseline, "extra": extra}


def collect(quick: bool = False) -> list[dict]:
    """Run every benchmark; ``quick`` uses fewer samples (used by the test of this table)."""
    rows: list[dict] = []
    from bench import bench_perception

    rows += bench_perception.bench_perception(60 if quick else 300)
    try:
        from bench import bench_ik

        rows += bench_ik.rows(2000 if quick else 20000)
    except ImportError as exc:  # pragma: no cover - reported, not hidden
        print(f"bench: IK benchmarks unavailable: {exc}", file=sys.stderr)
    try:
        from bench import bench_render

        rows += bench_render.rows(20 if quick else 200)
    except ImportError as exc:  # pragma: no cover
        print(f"bench: render benchmark unavailable: {exc}", file=sys.stderr)
    from bench import bench_calibration

    rows += bench_calibration.rows(quick)
    from bench import bench_serial

    rows += bench_serial.rows(quick)
    from bench import bench_pipeline

    rows += bench_pipeline.rows(quick)
    from bench import bench_record

    rows += bench_record.rows(quick)
    from bench import bench_window

    rows += bench_window.rows(quick)
    from bench import bench_assist_window

    rows += bench_assist_window.rows(quick)  # against bench_window's idle row
    from bench import bench_detect

    rows += bench_detect.rows(quick)
    from bench import bench_assist

    rows += bench_assist.rows(quick)
    from bench import bench_startup

    rows += bench_startup.rows(quick)
    try:
        from bench import bench_remote

        rows += bench_remote.rows(quick)
    except (ImportError, RuntimeError) as exc:  # pragma: no cover - no zenoh, or no loopback session
        print(f"bench: remote desk benchmark unavailable: {exc}", file=sys.stderr)
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
            if med > 0 and med <= bmed:
                ratio = f"{bmed / med:5.2f}x faster than '{base['name']}'"
            elif bmed > 0:
                ratio = f"{med / bmed:5.2f}x the time of '{base['name']}'"
        unit = r["unit"]
        lines.append(f"{r['name']:48s} {med:9.3f}{unit:>2s} {p95:9.3f}{unit:>2s} {len(s):6d}  {ratio}")
        if r.get("extra"):
            lines.append(f"{'':48s}   {r['extra']}")
    return "\n".join(lines)


def main() -> int:
    t0 = time.perf_counter()
    rows = collect(quick="--quick" in sys.argv)
    print(format_table(rows))
    print(f"\n(total {time.perf_counter() - t0:.1f} s; 2 cores, cv2 threads {__import__('cv2').getNumThreads()})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
