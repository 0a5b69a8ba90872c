"""Benchmark: analytic IK of the desk_rrr arm, against its FK measured in the same run.

Run: ``.venv/bin/python -m bench.bench_ik`` (prints the figures; never a pass/fail assert).
``rows(n)`` feeds `make bench`'s table; ``bench_analytic_ik(n)`` returns the summary dict.
"""
from __future__ import annotations

import random
import time

import numpy as np

from core.robot_profile import build_kinematics, load_profile

FK_NAME = "FK desk_rrr"
IK_NAME = "analytic IK desk_rrr"
IK_FAR_NAME = "analytic IK desk_rrr, unreachable target"


def _cases(kin, n: int, seed: int = 1):
    """n random in-limit joint vectors, their FK targets (reachable) and warm-start joints."""
    rng = random.Random(seed)
    q = [tuple(rng.uniform(lo, hi) for lo, hi in zip(kin.q_min, kin.q_max)) for _ in range(n)]
    targets = [kin.fk_tuple(v) for v in q]
    # warm start: the previous tick's joints, a little away from the answer
    current = [tuple(min(max(v + rng.gauss(0.0, 0.05), lo), hi)
                     for v, lo, hi in zip(qq, kin.q_min, kin.q_max)) for qq in q]
    return q, targets, current


def _time_us(fn, args_list) -> list[float]:
    clock = time.perf_counter_ns
    out = []
    for args in args_list:
        t0 = clock()
        fn(*args)
        out.append((clock() - t0) * 1e-3)
    return out


def _samples(n: int):
    kin = build_kinematics(load_profile("desk_rrr"))
    q, targets, current = _cases(kin, n)
    rng = random.Random(2)
    far = [(rng.uniform(-0.5, 0.5), rng.uniform(0.3, 0.5), rng.uniform(-0.3, 0.5)) for _ in range(n)]
    for i in range(min(n, 500)):  # warm up
        kin.ik(targets[i], current[i])
        kin.fk(q[i])
    fk = _time_us(kin.fk, [(v,) for v in q])
    ik = _time_us(kin.ik, list(zip(targets, current)))
    ik_far = _time_us(kin.ik, list(zip(far, current)))
    return fk, ik, ik_far


def _summary(name: str, samples_us) -> dict:
    s = np.asarray(samples_us, dtype=float)
    return {"name": name, "median_us": float(np.median(s)), "p95_us": float(np.percentile(s, 95))}


def bench_analytic_ik(n: int = 20000) -> dict:
    """Median/p95 (µs) of ``RRRKinematics.ik`` on random reachable targets, with the FK baseline.

    Returns ``{"name", "median_us", "p95_us", "n", "baseline": {"name", "median_us", "p95_us"}}``.
    """
    fk, ik, _ = _samples(n)
    result = _summary(IK_NAME, ik)
    result["n"] = n
    result["baseline"] = _summary(FK_NAME, fk)
    return result


def rows(n: int = 20000) -> list[dict]:
    """Rows for `make bench`: FK (baseline), IK on reachable targets, IK on unreachable ones."""
    fk, ik, ik_far = _samples(n)
    return [
        {"name": FK_NAME, "unit": "us", "samples": fk, "baseline": None,
         "extra": "RRRKinematics.fk: math on 3 scalars, one numpy array out"},
        {"name": IK_NAME, "unit": "us", "samples": ik, "baseline": FK_NAME,
         "extra": "random reachable targets, warm start; every in-limit branch enumerated"},
        {"name": IK_FAR_NAME, "unit": "us", "samples": ik_far, "baseline": FK_NAME,
         "extra": "nearest reachable point on the workspace's boundary arcs"},
    ]


if __name__ == "__main__":
    r = bench_analytic_ik()
    b = r["baseline"]
    print(f"{r['name']}: median {r['median_us']:.2f} µs, p95 {r['p95_us']:.2f} µs (n={r['n']})")
    print(f"{b['name']}: median {b['median_us']:.2f} µs, p95 {b['p95_us']:.2f} µs")
