"""The window's CPU use: process CPU seconds per wall second (% of one core), offscreen at 800x480.

Two situations, each in its own subprocess (Qt state, threads and CPU accounting isolated):
``idle`` — the static simulated desk, arm settled on the marker — and ``follow`` — the wander
scenario, the arm following a moving marker at 30 fps. Each runs twice: with
``MainWindow.redraw_only_changes = False`` (every frame redraws everything: the baseline) and
with the default (only what changed is redrawn). A child samples ``time.process_time()``
against ``time.perf_counter()`` once per second after a warm-up, and counts the camera frames
the window actually drew (``CameraView.frames_drawn`` of the left view) per second.

Recording: each situation once more with the ● REC button pressed before the warm-up (the
recorder's thread encodes and writes; the GUI thread only queues): the drawn fps against the
redraw-changed run's, and the recording's megabytes per second (a fresh temporary DESKARM_HOME
holds it).

Run alone: ``python -m bench.bench_window [--quick] [--root DIR]`` (``--root``: measure another
checkout of deskarm, e.g. a git worktree of an older commit, with this venv). The child is
``python bench/bench_window.py --child idle|follow --seconds N [--redraw-all]``, run as a script in
``root`` with ``PYTHONPATH=root`` so that it imports that checkout's ``app``, ``core`` and ``widgets``.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

SCENARIOS = {"idle": "static", "follow": "wander"}  # child mode -> simulated desk scenario
WINDOW_SIZE = (800, 480)
WARMUP_S = 2.0  # first frames, first layout, IK warm-up: not sampled
SAMPLE_MS = 1000  # one CPU sample per second
CHILD_TIMEOUT_MARGIN_S = 60.0  # start-up and shutdown on top of warm-up + sampling
REPO = Path(__file__).resolve().parents[1]


# --------------------------------------------------------------------------------------------
# Parent: one subprocess per measurement


def measure(mode: str, seconds: float, redraw_all: bool, root: Path = REPO, record: bool = False) -> dict:
    """Run one child on the checkout ``root``; its JSON result (``cpu_pct``, ``gui_pct``, ``drawn_fps`` lists)."""
    if mode not in SCENARIOS:
        raise ValueError(f"window bench mode {mode!r}; allowed: {', '.join(SCENARIOS)}")
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", mode, "--seconds", f"{seconds:g}"]
    if redraw_all:
        cmd.append("--redraw-all")
    if record:
        cmd.append("--record")
    import tempfile

    with tempfile.TemporaryDirectory(prefix="deskarm-bench-home-") as home:
        env = dict(os.environ, QT_QPA_PLATFORM="offscreen", DESKARM_HOME=home)
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(root), os.environ.get("PYTHONPATH")) if p)
        proc = subprocess.run(cmd, cwd=root, env=env, capture_output=True, text=True, check=False,
                              timeout=WARMUP_S + seconds + CHILD_TIMEOUT_MARGIN_S)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("{")]
    if proc.returncode != 0 or not lines:
        raise RuntimeError(f"window bench child {' '.join(cmd[2:])} exited {proc.returncode}: "
                           f"{proc.stderr.strip()[-800:]}")
    return json.loads(lines[-1])


def rows(quick: bool = False, root: Path = REPO) -> list[dict]:
    """Idle and follow, redraw-all (baseline) and redraw-changed: % of one core, per second."""
    seconds = 4.0 if quick else 20.0
    out = []
    for mode, what in (("idle", "idle (static desk)"), ("follow", "following a marker (wander)")):
        base_name = f"window CPU {what}, redraw-all"
        for redraw_all in (True, False):
            r = measure(mode, seconds, redraw_all, root)
            if not redraw_all:
                plain_fps, plain_status = float(np.median(r["drawn_fps"])), r["status_fps"]
            name = base_name if redraw_all else f"window CPU {what}, redraw-changed"
            extra = (f"800x480 offscreen, {seconds:g} s: drawn {np.median(r['drawn_fps']):.1f} fps"
                     f" (status bar {r['status_fps']}), GUI thread {np.median(r['gui_pct']):.0f} %"
                     f" of a core")
            out.append({"name": name, "unit": "%", "samples": r["cpu_pct"],
                        "baseline": None if redraw_all else base_name, "extra": extra})
        r = measure(mode, seconds, False, root, record=True)
        fps = float(np.median(r["drawn_fps"]))
        rec = r["record"]
        mb_s = rec["bytes"] / 1e6 / rec["seconds"] if rec["seconds"] > 0 else float("nan")
        # the still desk draws no camera frame (nothing changed): its status bar says the loop's rate
        versus = (f"{fps / plain_fps:.3f}x the drawn fps of the redraw-changed run without recording ({plain_fps:.1f})"
                  if plain_fps > 0 else f"drawn {fps:.1f} fps vs {plain_fps:.1f} without recording")
        out.append({"name": f"window drawn fps {what}, recording", "unit": "", "samples": r["drawn_fps"],
                    "baseline": None,
                    "extra": f"{versus}; status bar {r['status_fps']} vs {plain_status}; {mb_s:.2f} MB/s recorded "
                             f"({rec['frames_written']} frames, {rec['frames_still']} re-used, "
                             f"{rec['frames_dropped']} dropped)"})
    return out


# --------------------------------------------------------------------------------------------
# Child: the window as app/gui.py:run_window makes it, sampled once a second


def child(mode: str, seconds: float, redraw_all: bool, record: bool = False) -> dict:
    """Open the window offscreen, warm up, sample CPU once a second, stop the workers, return."""
    import time

    from PySide6 import QtCore

    from app.gui import MainWindow
    from core.session import DeskSession, SessionOptions, freeze_startup_objects

    try:
        from app.startup import make_app
    except ImportError:  # a checkout from before app/startup.py
        from app.gui import _make_app as make_app

    app = make_app()
    session = DeskSession.create(SessionOptions(camera="sim", scenario=SCENARIOS[mode]))
    window = MainWindow(session)
    window.redraw_only_changes = not redraw_all
    app.aboutToQuit.connect(window.stop)
    window.resize(*WINDOW_SIZE)
    window.show()

    view = window.view_left  # view.frames_drawn: the camera frames the window actually drew
    cpu_pct: list[float] = []
    gui_pct: list[float] = []
    drawn_fps: list[float] = []
    last: dict = {}

    def mark() -> None:
        last.update(wall=time.perf_counter(), cpu=time.process_time(), gui=time.thread_time(),
                    drawn=view.frames_drawn)

    recorded: dict = {}

    def sample() -> None:
        wall, cpu, gui = time.perf_counter(), time.process_time(), time.thread_time()
        dt = wall - last["wall"]
        cpu_pct.append(100.0 * (cpu - last["cpu"]) / dt)
        gui_pct.append(100.0 * (gui - last["gui"]) / dt)  # this slot runs in the GUI thread
        drawn_fps.append((view.frames_drawn - last["drawn"]) / dt)
        mark()
        if len(cpu_pct) >= max(1, round(seconds * 1000 / SAMPLE_MS)):
            sampler.stop()
            rec = window.recorder
            if rec is not None:
                window.record_button.click()  # stop: the recorder's thread finishes the file
                from core.record.recorder import folder_size

                recorded.update(bytes=folder_size(rec.path), seconds=rec.elapsed_s, frames_written=rec.frames_written,
                                frames_still=getattr(rec, "frames_still", 0), frames_dropped=rec.frames_dropped)
            window.close()  # stops and joins the workers
            app.quit()

    sampler = QtCore.QTimer()
    sampler.setInterval(SAMPLE_MS)
    sampler.timeout.connect(sample)

    def begin() -> None:
        mark()
        sampler.start()

    freeze_startup_objects()  # as run_window does
    window.start()
    if record:
        window.record_button.click()  # ● REC, as the user starts it
    QtCore.QTimer.singleShot(int(WARMUP_S * 1000), begin)
    app.exec()
    window.stop()  # safe twice: already stopped by close/aboutToQuit
    return {"mode": mode, "redraw_all": redraw_all, "cpu_pct": cpu_pct, "gui_pct": gui_pct,
            "drawn_fps": drawn_fps, "status_fps": window.status_items.fps_label.text(), "record": recorded}


def main(argv: list[str]) -> int:
    if "--child" in argv:
        mode = argv[argv.index("--child") + 1]
        seconds = float(argv[argv.index("--seconds") + 1]) if "--seconds" in argv else 20.0
        print(json.dumps(child(mode, seconds, "--redraw-all" in argv, "--record" in argv)), flush=True)
        return 0
    if str(REPO) not in sys.path:  # run as a script: the table formatter lives in bench/__main__
        sys.path.insert(0, str(REPO))
    from bench.__main__ import format_table

    root = Path(argv[argv.index("--root") + 1]) if "--root" in argv else REPO
    print(format_table(rows(quick="--quick" in argv, root=root)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
