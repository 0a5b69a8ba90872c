"""The assistive view's CPU use: process CPU seconds per wall second (% of one core), offscreen at
800x480, as ``deskarm --assist`` runs it (wall clock, the simulated servo arm behind the safety
chain).

Two situations, each in its own subprocess (Qt state, threads and CPU accounting isolated):
``choosing`` — the arm at its ready pose, the hand camera's live view, a one-switch scan moving
the highlight — and ``pressing`` — presses one after the other (a random box each time the
boxes are offered: align, approach, press, back). A child samples ``time.process_time()``
against ``time.perf_counter()`` once per second after a warm-up (WARMUP_S and the first
WARMUP_FRAMES hand-camera frames, however long a loaded machine takes for them), and counts the
hand-camera frames the window was handed per second; a sample waits for at least one frame
(a second without any on a loaded machine is measured as a longer sample, not as 0 frames/s).

The baseline is the main window's idle row of ``bench_window`` (``window CPU idle (static desk),
redraw-changed``), measured in the same ``make bench`` run: the assistive view's cost as a
multiple of the main window at rest. Run alone (no baseline): ``python -m bench.bench_assist_window
[--quick]``; the child is ``python bench/bench_assist_window.py --child choosing|pressing --seconds N``.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

MODES = ("choosing", "pressing")
WINDOW_SIZE = (800, 480)
WARMUP_S = 3.0
WARMUP_FRAMES = 3  # frames the window must have been handed before sampling starts
SAMPLE_MS = 1000
REPO = Path(__file__).resolve().parents[1]
BASELINE = "window CPU idle (static desk), redraw-changed"  # bench_window's row


def measure(mode: str, seconds: float, timeout_s: float | None = None) -> dict:
    """The child's JSON result; ``timeout_s`` (default WARMUP_S + seconds + 90) only bounds a hung child."""
    if mode not in MODES:
        raise ValueError(f"assist window bench mode {mode!r}; allowed: {', '.join(MODES)}")
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", mode, "--seconds", f"{seconds:g}"]
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen")
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p)
    proc = subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True, check=False,
                          timeout=timeout_s if timeout_s is not None else WARMUP_S + seconds + 90)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("{")]
    if proc.returncode != 0 or not lines:
        raise RuntimeError(f"assist window bench child {mode} failed ({proc.returncode}): {proc.stderr[-2000:]}")
    return json.loads(lines[-1])


def rows(quick: bool = False) -> list[dict]:
    seconds = 4.0 if quick else 20.0
    out = []
    for mode, what in (("choosing", "choosing (live view, 1-switch scan)"), ("pressing", "pressing buttons")):
        r = measure(mode, seconds)
        extra = (f"800x480 offscreen, {seconds:g} s: {np.median(r['frames_fps']):.1f} frames/s shown, GUI thread "
                 f"{np.median(r['gui_pct']):.0f} % of a core, {r['presses']} presses")
        out.append({"name": f"assist window CPU {what}", "unit": "%", "samples": r["cpu_pct"],
                    "baseline": BASELINE, "extra": extra})
    return out


def child(mode: str, seconds: float) -> dict:
    """The assistive window as run_assist_window makes it (sim desk, sim:// arm), sampled once a second."""
    import random
    import time

    from PySide6 import QtCore

    from app.assist_window import AssistSettings, AssistWindow, build_sim_loop, guarded_arm_factory
    from app.startup import make_app
    from core.devices import open_bridge
    from core.kinematics.profile import load_profile

    app = make_app()
    bridge = open_bridge("sim://", load_profile("assistive_5dof"))
    window = AssistWindow(lambda: build_sim_loop(0), worker_clock="wall", arm_factory=guarded_arm_factory(bridge))
    window.set_settings(AssistSettings(mode="scan1" if mode == "choosing" else "touch", scan_period_s=1.0))
    window.resize(*WINDOW_SIZE)
    window.show()
    frames = [0]
    window.worker.sigFrame.connect(lambda: frames.__setitem__(0, frames[0] + 1))
    rng = random.Random(0)
    presses = [0]
    cpu_pct: list[float] = []
    gui_pct: list[float] = []
    frames_fps: list[float] = []
    last: dict = {}

    def mark() -> None:
        last.update(wall=time.perf_counter(), cpu=time.process_time(), gui=time.thread_time(), frames=frames[0])

    def sample() -> None:
        if frames[0] == last["frames"]:
            return  # no frame yet in this sample: it lasts until one comes
        wall, cpu, gui = time.perf_counter(), time.process_time(), time.thread_time()
        dt = wall - last["wall"]
        cpu_pct.append(100.0 * (cpu - last["cpu"]) / dt)
        gui_pct.append(100.0 * (gui - last["gui"]) / dt)
        frames_fps.append((frames[0] - last["frames"]) / dt)
        mark()
        if len(cpu_pct) >= max(1, round(seconds * 1000 / SAMPLE_MS)):
            sampler.stop()
            chooser.stop()
            window.stop()
            app.quit()

    def choose() -> None:  # pressing: a random box whenever a choice is offered
        if mode == "pressing" and window.choosing and window.boxes:
            window._choose(rng.randrange(len(window.boxes)))
            presses[0] += 1

    sampler = QtCore.QTimer()
    sampler.setInterval(SAMPLE_MS)
    sampler.timeout.connect(sample)
    chooser = QtCore.QTimer()
    chooser.setInterval(200)
    chooser.timeout.connect(choose)

    def begin() -> None:
        if frames[0] < WARMUP_FRAMES:  # a loaded machine: the live view has not started yet
            QtCore.QTimer.singleShot(SAMPLE_MS // 10, begin)
            return
        mark()
        sampler.start()

    window.start()
    chooser.start()
    QtCore.QTimer.singleShot(int(WARMUP_S * 1000), begin)
    app.exec()
    window.stop()
    return {"mode": mode, "cpu_pct": cpu_pct, "gui_pct": gui_pct, "frames_fps": frames_fps, "presses": presses[0]}


def main(argv: list[str]) -> int:
    if "--child" in argv:
        mode = argv[argv.index("--child") + 1]
        seconds = float(argv[argv.index("--seconds") + 1]) if "--seconds" in argv else 10.0
        print(json.dumps(child(mode, seconds)))
        return 0
    from bench.__main__ import format_table

    print(format_table(rows("--quick" in argv)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
