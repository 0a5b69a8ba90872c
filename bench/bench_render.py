"""Benchmark: one simulated stereo pair (640×480, cups scenario: 2 markers on cups, the arm drawn).

Run: ``.venv/bin/python -m bench.bench_render`` (prints the figures; never a pass/fail assert).
``rows(n)`` feeds `make bench`'s table.

``--scenes``: the two scenes the Pi bench uses, as the app renders them (the default robot's
arm drawn from its kinematics, carrying its tool marker), each with the arm moving (following a
marker, pointing) and still (idle): the median CPU ms (all of the process's threads — what a CPU
quota counts — and the rendering thread's own, as a per-thread profile shows the sim camera's
thread) and wall ms of ``SimDesk.render`` per stereo pair.
``--threads N`` sets OpenCV's threads first (a Pi-budget process is better measured with 1: a
quota counts the pool's idle spinning too). ``--against PATH`` renders the same frames with
another version of ``core/sim/desk.py`` too (e.g. ``git show 6dc2fe5:core/sim/desk.py >
/tmp/desk_before.py``: the desk before issue 28's third round), in alternating blocks of frames:
before and after in the same sitting.
"""
from __future__ import annotations

import argparse
import importlib.util
import sys
import time

import numpy as np

from core.sim.desk import SimDesk
from core.sim.rig import SimRig

# base → shoulder → elbow → tool, robot_base (m): the arm reaching over the cups
ARM_POINTS = np.array([(0.0, 0.0, 0.0), (0.0, 0.0, 0.066), (0.0, 0.06, 0.17), (0.0, 0.15, 0.12)])
SCENES = (("wander", True), ("wander", False), ("objects", False), ("objects", True))  # (scenario, arm moving)
BLOCK = 20  # --against: frames rendered by one desk before the other takes its turn


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


# -- the Pi bench's scenes ------------------------------------------------------------------


def _app_arm():
    """(chain points at time t, tool marker) of the default robot: the arm sweeping slowly over
    the desk (a few cm a second at the tool, like following a marker)."""
    from core.handeye.solve import tool_marker_of
    from core.kinematics import build_kinematics, load_profile

    profile = load_profile("desk_rrr")
    kinematics = build_kinematics(profile)

    def arm_at(t: float) -> np.ndarray:
        q = (0.4 * np.sin(0.7 * t), 0.6 + 0.2 * np.sin(0.5 * t), -0.9 + 0.2 * np.cos(0.6 * t))
        return np.asarray(kinematics.chain_points(q))

    return arm_at, tool_marker_of(profile)


def _desk_class(path: str):
    """``SimDesk`` of another version of core/sim/desk.py (a file)."""
    spec = importlib.util.spec_from_file_location("desk_under_comparison", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # (its dataclasses look their module up)
    spec.loader.exec_module(module)
    return module.SimDesk


def scene_pairs(n: int = 300, against: str | None = None) -> list[dict]:
    """Per scene of SCENES: median CPU and wall ms of a stereo pair (``n`` renders at 30 fps of
    scenario time), for this desk and, with ``against``, the other version's (same frames)."""
    arm_at, tool = _app_arm()
    versions = {"this": SimDesk}
    if against:
        versions = {"against": _desk_class(against), "this": SimDesk}
    out = []
    for scenario, moving in SCENES:
        desks = {k: cls(SimRig(), scenario=scenario, tool_marker=tool) for k, cls in versions.items()}
        cpu: dict = {k: [] for k in desks}
        own: dict = {k: [] for k in desks}
        wall: dict = {k: [] for k in desks}
        for d in desks.values():
            for i in range(5):
                d.render(i / 30.0, arm_at(i / 30.0 if moving else 0.0))
        for b in range(max(1, n // BLOCK)):
            order = list(desks.items()) if b % 2 == 0 else list(reversed(desks.items()))
            for k, d in order:
                for i in range(BLOCK):
                    t = (b * BLOCK + i) / 30.0
                    arm = arm_at(t if moving else 0.0)
                    c0, o0, w0 = time.process_time(), time.thread_time(), time.perf_counter()
                    d.render(t, arm)
                    cpu[k].append(time.process_time() - c0)
                    own[k].append(time.thread_time() - o0)
                    wall[k].append(time.perf_counter() - w0)
        for k in desks:
            out.append({"scene": scenario, "arm": "moving" if moving else "still", "desk": k,
                        "cpu_ms": float(np.median(cpu[k]) * 1e3), "thread_cpu_ms": float(np.median(own[k]) * 1e3),
                        "wall_ms": float(np.median(wall[k]) * 1e3),
                        "renders": len(cpu[k])})
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", action="store_true", help="the Pi bench's scenes (wander, objects) as the app renders them")
    ap.add_argument("--n", type=int, default=300, help="renders per scene and desk (default 300)")
    ap.add_argument("--threads", type=int, default=None, help="cv2.setNumThreads first (e.g. 1)")
    ap.add_argument("--against", default=None, help="another core/sim/desk.py to render the same frames with")
    args = ap.parse_args(argv)
    if args.threads is not None:
        import cv2

        cv2.setNumThreads(args.threads)
    if not args.scenes:
        r = bench_render()
        print(f"{r['name']}: median {r['median_ms']:.2f} ms, p95 {r['p95_ms']:.2f} ms")
        return
    for r in scene_pairs(args.n, args.against):
        print(f"{r['scene']:8s} arm {r['arm']:6s} {r['desk']:8s} CPU {r['cpu_ms']:5.2f} ms (rendering thread "
              f"{r['thread_cpu_ms']:5.2f})  wall {r['wall_ms']:5.2f} ms  a stereo pair (median of {r['renders']})")


if __name__ == "__main__":
    main()
