"""A Raspberry Pi budget: the loop and the 800x480 window held to a CPU quota (issue 28 item 3).

Every measurement is a child process in a cgroup v1 ``cpu`` group (``bench.cpu_quota``), in the
same run at three budgets: ``unthrottled`` (a group without a quota), ``Pi 5`` and ``Pi 4``.

Where the budgets come from. One published single-thread benchmark that also runs here:
sysbench 1.0.20 ``cpu --threads=1`` (primes up to 10000, events/s) on 64-bit Raspberry Pi OS —
Raspberry Pi 4 (Cortex-A72 @ 1.8 GHz) 1477.83, Raspberry Pi 5 (Cortex-A76 @ 2.4 GHz) 2737.49
("Raspberry Pi CPU Benchmarks", leoncode.co.uk) — and this machine's core (AMD EPYC, Zen 5 family
26, KVM) 5069 and 5156 events/s (measured 2026-11-28 in a cgroup with cpu.shares 8192, host load
about 10). So one Pi 4 core is 0.29 of this core and one Pi 5 core 0.54: PI_BUDGETS. (The issue
suggested a quarter core for a Pi 4; sysbench's integer loop is not Python's interpreter loop,
so take the ratios as ±30 %.)

Which approximation. A cgroup cannot make cores slower: it limits the CPU time of all the
child's threads together. A Pi 4 has four cores, each 0.29 of this one, so "the whole Pi 4"
would be a quota of 4 × 0.29 = 1.16 cores — but then the GUI thread alone would run at this
core's full speed, 3.4× a Pi core, and the GUI thread and the perception loop are what set the
frame rate (deskarm's work is mostly Python holding the GIL: one thread at a time). We hold the
whole process to ONE Pi core's speed (quota = ratio × one core): exact for work serialised by
the GIL, pessimistic for work running outside it in parallel (OpenCV and numpy calls, Qt's
rasterising). A real Pi lies between this row and 4× its CPU; the rows are a lower bound on its
frame rate and an upper bound on its latency. The short CFS period (bench.cpu_quota.PERIOD_US,
10 ms) makes the budget look like a slow core, not like 75 ms freezes.

What each (case, budget) measures, in the same run as the unthrottled figures:

- the window: ``deskarm <case> --size 800x480`` started as the ``deskarm`` command starts it
  (``app.cli.main``, offscreen), in a child that polls every 5 ms (``bench_startup``'s way) and
  hooks the running window: start-up to the first camera frame (from the spawn: throttled too),
  then after WARMUP_S one sample a second of the process CPU (% of one core), the loop's rate
  (perception results per second), the camera frames drawn per second and, for each new frame a
  command carries, frame → command latency (the control worker's clock at the command minus the
  frame's time, taken in the control thread as the command is handed to the bridge worker);
- the loop without a window: ``deskarm --headless --json`` (paced at 30 fps on the wall clock)
  — its fps and its frame → bytes latency p50/p95 (the headless runner's own figures);
- the assistive view (``deskarm --assist``): start-up to its first hand-camera frame, CPU, and
  the hand-camera frames it is handed per second (its loop has no frame → bytes figure).

Cases: ``markers`` (``--scenario wander``, the arm following a marker), ``hsv`` and ``desk``
(``--scenario objects --detector hsv|desk``) and ``assist``; with ``--full`` or ``--cases`` also
``hsv-roi``/``desk-roi`` (``--object-roi``) and ``hsv-replay``/``desk-replay``: a user with real
webcams — the objects scene recorded once in the run (``make_recording``: ``deskarm --headless
--fast --record``) and replayed (``--camera replay:PATH``) at its 30 fps, so each frame costs a
JPEG decoding per view instead of the simulator's rendering. The table's ``camera`` column says
which rows are which. The issue's goal in the Pi 4 budget:
30 fps with markers, ≥ 15 fps with one object detector, start-up to the first frame ≤ 5 s.

Run alone: ``python -m bench.bench_pi [--quick|--full] [--root DIR] [--cases markers,hsv]
[--budgets "Pi 4"] [--repeat N]`` (``--repeat``: N window runs per case and budget, interleaved,
their samples pooled and each run's median listed under its row: on a shared machine the host's
load moves a run's figures by a third) (``--root``: measure another checkout, e.g. ``git clone -q /work/main
/tmp/pi-root``, with this venv: the children run with ``cwd`` and ``PYTHONPATH`` = DIR). Prints
``make bench``'s table and the compact Pi table (``pi_table``). The window child is ``python
bench/bench_pi.py --child window --seconds N -- <deskarm arguments>``.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Optional

import numpy as np

# one core of a Pi relative to one core here (see the module docstring); None: no quota
PI_BUDGETS: tuple[tuple[str, Optional[float]], ...] = (("unthrottled", None), ("Pi 5", 0.54), ("Pi 4", 0.29))
CASES: dict[str, list[str]] = {
    "markers": ["--camera", "sim", "--scenario", "wander"],
    "hsv": ["--camera", "sim", "--scenario", "objects", "--detector", "hsv"],
    "desk": ["--camera", "sim", "--scenario", "objects", "--detector", "desk"],
    "assist": ["--assist"],
}
RECORDING = "{recording}"  # in a case's arguments: the run's recording (make_recording), made once per run
# not in the default run (it stays under 3 minutes): --cases hsv-roi,desk-roi,hsv-replay,desk-replay or --full
EXTRA_CASES: dict[str, list[str]] = {
    "hsv-roi": [*CASES["hsv"], "--object-roi"],  # detect around the tracked objects between full searches
    "desk-roi": [*CASES["desk"], "--object-roi"],
    # a user with real webcams: the objects scene recorded once (JPEG pairs), replayed at its
    # recorded 30 fps, so JPEG decoding takes the place of the simulator's rendering
    "hsv-replay": ["--camera", f"replay:{RECORDING}", "--detector", "hsv"],
    "desk-replay": ["--camera", f"replay:{RECORDING}", "--detector", "desk"],
}
ALL_CASES = {**CASES, **EXTRA_CASES}
RECORD_EXTRA_S = 30.0  # the recording outlasts the window's sampling by this (start-up in the Pi 4 budget, warm-up)
WINDOW_SIZE = "800x480"
GOALS = {"markers": 30.0, "hsv": 15.0, "desk": 15.0, "hsv-roi": 15.0, "desk-roi": 15.0,  # fps wanted in the
         "hsv-replay": 15.0, "desk-replay": 15.0}  # Pi 4 budget (issue 28)
FIRST_FRAME_GOAL_S = 5.0
SPAWN_ENV = "DESKARM_BENCH_SPAWN_T"  # the parent's time.time() just before the spawn
POLL_MS = 5  # until the first frame (start-up is timed to it)
SLOW_POLL_MS = 200  # after it
SAMPLE_MS = 1000
WARMUP_S = 2.0  # after the first frame: first layouts, IK warm-up, caches; not sampled
FIRST_FRAME_TIMEOUT_S = 90.0  # from the spawn; the child then reports what it saw and quits
REPO = Path(__file__).resolve().parents[1]
SCRIPT = Path(__file__).resolve()


def durations(quick: bool) -> tuple[float, float]:
    """(window sampling seconds, headless run seconds)."""
    return (3.0, 3.0) if quick else (15.0, 15.0)


# --------------------------------------------------------------------------------------------
# Parent


# The children run what `make run` installs: not the bench extra's onnxruntime, which the desk
# detector would take instead of OpenCV's DNN (2.3 against 3.3 ms of CPU a view here). A module of
# that name that refuses to import, first on the children's path, hides it.
HIDE_ONNXRUNTIME = 'raise ImportError("onnxruntime hidden by bench_pi: make run does not install it")\n'


def _env(root: Path, home: str) -> dict:
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", DESKARM_HOME=home)
    hide = Path(home) / "hide"
    hide.mkdir(exist_ok=True)
    (hide / "onnxruntime.py").write_text(HIDE_ONNXRUNTIME)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(hide), str(root), os.environ.get("PYTHONPATH")) if p)
    return env


def _run(argv: list[str], quota, root: Path, timeout_s: float, extra_env: dict | None = None) -> dict:
    """Run ``argv`` in ``quota``'s group; stdout, stderr, exit code, CPU seconds (rusage), wall seconds."""
    with tempfile.TemporaryDirectory(prefix="deskarm-bench-home-") as home:
        env = _env(root, home)
        env.update(extra_env or {})
        env[SPAWN_ENV] = repr(time.time())
        t0 = time.perf_counter()
        proc = subprocess.Popen(quota.command(argv), cwd=root, env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
        try:
            out, err = proc.communicate(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, err = proc.communicate()
            raise RuntimeError(f"pi bench child {' '.join(argv[1:])} hung (killed after {timeout_s:g} s): "
                               f"{err.strip()[-800:]}") from None
        wall = time.perf_counter() - t0
    return {"out": out, "err": err, "rc": proc.returncode, "wall_s": wall}


def _last_json(run: dict, what: str) -> dict:
    lines = [ln for ln in run["out"].splitlines() if ln.startswith("{")]
    if run["rc"] != 0 or not lines:
        raise RuntimeError(f"pi bench {what} exited {run['rc']}: {run['err'].strip()[-1500:]}")
    return json.loads(lines[-1])


def source_of(case: str) -> str:
    """What a case's camera is: "sim" (the simulator renders each frame in the process), "replay"
    (a recording's JPEG pairs, decoded as a webcam's MJPEG frames are) or "hand sim" (the assistive view)."""
    if case == "assist":
        return "hand sim"
    return "replay" if any(RECORDING in a for a in ALL_CASES[case]) else "sim"


def case_argv(case: str, recording: Optional[Path] = None) -> list[str]:
    """``case``'s deskarm arguments, the run's recording put in (ValueError when it needs one and has none)."""
    argv = ALL_CASES[case]
    if source_of(case) == "replay":
        if recording is None:
            raise ValueError(f"pi bench case {case} replays a recording: make one first (make_recording)")
        argv = [a.replace(RECORDING, str(recording)) for a in argv]
    return list(argv)


def make_recording(path: Path, seconds: float, root: Path = REPO) -> dict:
    """Record the objects scene (``deskarm --headless --fast --record PATH --scenario objects``,
    the simulated clock: 30 fps of camera time as fast as this machine renders it) for the replay
    cases; the runner's JSON. Made without a quota: it is the camera, not what is measured."""
    from bench.cpu_quota import CpuQuota

    argv = [sys.executable, "-m", "app.cli", "--headless", "--fast", "--json", "--duration", f"{seconds:g}",
            "--camera", "sim", "--scenario", "objects", "--record", str(path)]
    with CpuQuota(None, "recording") as quota:
        run = _run(argv, quota, root, 20 * seconds + 120)
    r = _last_json(run, "recording for the replay cases")
    if r.get("record_error") or not r.get("frames_recorded"):
        raise RuntimeError(f"pi bench recording {path} failed: {r.get('record_error')}; {run['err'].strip()[-800:]}")
    return r


def measure_window(case: str, budget: Optional[float], seconds: float, root: Path = REPO,
                   recording: Optional[Path] = None) -> dict:
    """One window child of ``case`` in a group of ``budget`` cores (None: no quota); its JSON."""
    from bench.cpu_quota import CpuQuota  # the parent's (the child imports deskarm from root)

    argv = [sys.executable, str(SCRIPT), "--child", "window", "--seconds", f"{seconds:g}", "--",
            *case_argv(case, recording)]
    with CpuQuota(budget, f"{case}-window") as quota:
        run = _run(argv, quota, root, FIRST_FRAME_TIMEOUT_S + WARMUP_S + 3 * seconds + 60)
        stats = quota.stats()
    r = _last_json(run, f"window child {case} (budget {budget})")
    if r.get("camera_finished") and not r.get("loop_fps"):
        raise RuntimeError(f"pi bench window child {case} (budget {budget}): the recording ended before "
                           f"the samples (first frame at {r.get('first_frame_s')} s): record longer")
    if r.get("timed_out") or r.get("first_frame_s") is None:
        raise RuntimeError(f"pi bench window child {case} (budget {budget}) saw no frame: {r}; "
                           f"{run['err'].strip()[-800:]}")
    app_file = Path(r.get("app_file") or "/").resolve()
    if not app_file.is_relative_to(Path(root).resolve()):
        raise RuntimeError(f"pi bench window child imported app from {app_file}, not from {root}")
    r["throttled"] = stats
    return r


def measure_headless(case: str, budget: Optional[float], seconds: float, root: Path = REPO,
                     recording: Optional[Path] = None) -> dict:
    """``deskarm --headless --json`` of ``case`` in a group of ``budget`` cores; the runner's JSON
    with the group's throttling counters and the child's wall seconds (start-up included) added."""
    from bench.cpu_quota import CpuQuota

    argv = [sys.executable, "-m", "app.cli", "--headless", "--json", "--duration", f"{seconds:g}",
            *case_argv(case, recording)]
    with CpuQuota(budget, f"{case}-headless") as quota:
        run = _run(argv, quota, root, 3 * seconds + 180)
        stats = quota.stats()
    r = _last_json(run, f"headless {case} (budget {budget})")
    r["throttled"] = stats
    r["child_wall_s"] = run["wall_s"]
    return r


SOURCE_PACKAGES = ("app", "core", "widgets", "bench")


def compile_sources(root: Path = REPO) -> None:
    """Byte-compile ``root``'s packages into their ``__pycache__`` as ``make setup`` does, so each
    child starts as a user's installed deskarm does: from cached bytecode. (With
    PYTHONDONTWRITEBYTECODE set, as on this machine, nothing else writes it, and every child spent
    about a second of the Pi 4 budget's start-up compiling deskarm's sources and pyqtgraph.)"""
    import compileall
    import sysconfig

    for package in SOURCE_PACKAGES:
        if (root / package).is_dir():
            compileall.compile_dir(str(root / package), quiet=1)
    # the libraries too, as make setup's install does (a venv made before it did would compile pyqtgraph
    # at every start); a few seconds when they are compiled already
    for lib in sorted({sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]}):
        compileall.compile_dir(lib, quiet=2, workers=0)  # quiet=2: templates that are not Python say nothing


def pool_runs(runs: list[dict]) -> dict:
    """Several window runs of one case and budget as one: their samples pooled, the median start-up,
    the throttling counters summed, and ``run_fps`` — each run's median loop fps (the spread between
    runs on a shared machine is wider than within one: the host's load comes and goes)."""
    if len(runs) == 1:
        return runs[0]
    pooled = dict(runs[0])
    for key in ("loop_fps", "drawn_fps", "latency_ms", "cpu_pct", "gui_pct"):
        pooled[key] = [x for r in runs for x in (r.get(key) or [])]
    pooled["first_frame_s"] = float(np.median([r["first_frame_s"] for r in runs]))
    pooled["run_fps"] = [_med(r["loop_fps"]) for r in runs]
    pooled["run_first_frame_s"] = [r["first_frame_s"] for r in runs]
    pooled["throttled"] = {k: sum(r["throttled"].get(k, 0) for r in runs) for k in runs[0]["throttled"]}
    return pooled


def measure_all(quick: bool = True, root: Path = REPO, cases=None, budgets=None, repeat: int = 1) -> list[dict]:
    """Every (case, budget) pair: one dict with ``case``, ``budget``, ``fraction``, ``window`` and
    ``headless`` (None for the assistive view). Budgets interleave within a case (same run, same load).
    ``repeat``: window runs per pair, pooled (``pool_runs``); the rounds interleave too."""
    from bench.cpu_quota import CpuQuotaUnavailable, available

    cases = list(cases or (ALL_CASES if not quick else CASES))
    unknown = [c for c in cases if c not in ALL_CASES]
    if unknown:
        raise ValueError(f"pi bench cases {', '.join(unknown)} unknown; known: {', '.join(ALL_CASES)}")
    why = available()
    if why:
        raise CpuQuotaUnavailable(f"pi budget bench unavailable: {why}")
    window_s, headless_s = durations(quick)
    compile_sources(root)
    out = []
    with tempfile.TemporaryDirectory(prefix="deskarm-bench-recording-") as folder:
        recording = None
        if any(source_of(c) == "replay" for c in cases):
            recording = Path(folder) / "objects"
            make_recording(recording, max(window_s, headless_s) + RECORD_EXTRA_S, root)
        for case in cases:
            pairs = list(budgets or PI_BUDGETS)
            windows = {name: [] for name, _ in pairs}
            for _ in range(max(1, int(repeat))):
                for name, fraction in pairs:
                    windows[name].append(measure_window(case, fraction, window_s, root, recording))
            for name, fraction in pairs:
                h = None if case == "assist" else measure_headless(case, fraction, headless_s, root, recording)
                out.append({"case": case, "budget": name, "fraction": fraction, "window": pool_runs(windows[name]),
                            "headless": h, "load": os.getloadavg()[0], "source": source_of(case)})
    return out


def _med(xs) -> float:
    xs = [x for x in xs if x is not None]
    return float(np.median(xs)) if xs else float("nan")


def _pct(xs, q) -> float:
    xs = [x for x in xs if x is not None]
    return float(np.percentile(xs, q)) if xs else float("nan")


def results_to_rows(results: list[dict]) -> list[dict]:
    """``make bench`` rows (bench/__main__.format_table): per case and budget, the window's loop fps,
    frame → command latency (ms), CPU (%), start-up to the first frame (ms) and the headless loop's fps;
    each budgeted row against the unthrottled row of the same case (same run)."""
    rows = []
    for r in results:
        case, budget, w, h = r["case"], r["budget"], r["window"], r["headless"]
        tag = f"pi {case}, {budget}"
        base = None if r["fraction"] is None else f"pi {case}, unthrottled"
        quota = "no quota" if r["fraction"] is None else f"{r['fraction']:g} core"
        loop = "hand-camera frames/s" if case == "assist" else "loop fps (window)"
        rows.append({"name": f"{tag}: {loop}", "unit": "", "samples": w["loop_fps"] or [0.0],
                     "baseline": None if base is None else f"{base}: {loop}", "less": "fewer",
                     "extra": f"{quota}; {r.get('source') or source_of(case)} camera; drawn {_med(w['drawn_fps']):.1f} fps; load {r['load']:.1f}; throttled "
                              f"{w['throttled'].get('nr_throttled', 0)}/{w['throttled'].get('nr_periods', 0)} periods"})
        if w["latency_ms"]:
            rows.append({"name": f"{tag}: frame->command latency (window)", "unit": "ms", "samples": w["latency_ms"],
                         "baseline": None if base is None else f"{base}: frame->command latency (window)",
                         "extra": ""})
        rows.append({"name": f"{tag}: window CPU", "unit": "%", "samples": w["cpu_pct"] or [0.0],
                     "baseline": None, "extra": f"GUI thread {_med(w['gui_pct']):.0f} % of a core"})
        rows.append({"name": f"{tag}: start-up to first frame", "unit": "ms",
                     "samples": [1000.0 * w["first_frame_s"]],
                     "baseline": None if base is None else f"{base}: start-up to first frame",
                     "extra": f"window shown at {1000.0 * (w['window_s'] or 0):.0f} ms"})
        if h is not None:
            rows.append({"name": f"{tag}: loop fps (headless)", "unit": "", "samples": [h["fps"]],
                         "baseline": None if base is None else f"{base}: loop fps (headless)", "less": "fewer",
                         "extra": f"frame->bytes latency p50 {h['latency_ms_p50']} ms, p95 {h['latency_ms_p95']} ms; "
                                  f"perception p50 {h['perception_ms_p50']} ms"
                                  + (f", objects p50 {h['object_perception_ms_p50']} ms"
                                     if h.get("object_perception_ms_p50") is not None else "")})
    return rows


def cpu_ms_per_frame(w: dict) -> float:
    """The window process's CPU time per loop frame (ms of this machine's core): what a frame costs,
    whatever the rate; a budget of b cores can hold at most b · 1000 / this frames per second."""
    per = [10.0 * c / f for c, f in zip(w["cpu_pct"], w["loop_fps"]) if f > 0]
    return _med(per)


def pi_table(results: list[dict]) -> str:
    """The compact table for the issue and the README: one line per case and budget (``ms/frame``:
    ``cpu_ms_per_frame``)."""
    head = (f"{'case':11s} {'camera':8s} {'budget':12s} {'loop fps':>8s} {'drawn':>6s} {'lat p50/p95 ms':>15s} {'CPU %':>6s} "
            f"{'ms/frame':>8s} {'1st frame s':>11s} {'headless fps':>12s} {'lat p50/p95 ms':>15s}  goal (Pi 4)")
    lines = [head, "-" * len(head)]
    for r in results:  # camera: sim = the simulator renders in the process; replay = JPEG pairs decoded
        w, h, case = r["window"], r["headless"], r["case"]
        lat = (f"{_med(w['latency_ms']):.0f}/{_pct(w['latency_ms'], 95):.0f}" if w["latency_ms"] else "—")
        hfps = f"{h['fps']:.1f}" if h else "—"
        hlat = f"{h['latency_ms_p50']:.0f}/{h['latency_ms_p95']:.0f}" if h and h.get("latency_ms_p50") is not None else "—"
        goal = ""
        if r["budget"] == "Pi 4":
            fps_goal = GOALS.get(case)
            ok_fps = fps_goal is None or _med(w["loop_fps"]) >= fps_goal - 0.5
            ok_start = w["first_frame_s"] <= FIRST_FRAME_GOAL_S  # (the median run's with --repeat)
            goal = (("" if fps_goal is None else f"{fps_goal:g} fps {'met' if ok_fps else 'MISSED'}, ")
                    + f"first frame ≤ {FIRST_FRAME_GOAL_S:g} s {'met' if ok_start else 'MISSED'}")
        lines.append(f"{case:11s} {r.get('source') or source_of(case):8s} {r['budget']:12s} {_med(w['loop_fps']):8.1f} {_med(w['drawn_fps']):6.1f} "
                     f"{lat:>15s} {_med(w['cpu_pct']):6.0f} {cpu_ms_per_frame(w):8.1f} {w['first_frame_s']:11.2f} "
                     f"{hfps:>12s} {hlat:>15s}  {goal}")
        if w.get("run_fps"):
            lines.append(f"{'':33s}runs' loop fps {' '.join(f'{x:.1f}' for x in w['run_fps'])}; first frame "
                         f"{' '.join(f'{x:.2f}' for x in w['run_first_frame_s'])} s")
    lines.append("camera: sim = the simulator renders both views in the process (its cost is in the figures); "
                 "replay = a recording of the same scene, JPEG pairs decoded as a webcam's MJPEG frames are")
    return "\n".join(lines)


def rows(quick: bool = False, root: Path = REPO) -> list[dict]:
    """``make bench``'s rows; raises cpu_quota.CpuQuotaUnavailable (an ImportError) when no CPU quota
    group can be made here (see cpu_quota.available), RuntimeError when a child fails."""
    return results_to_rows(measure_all(quick, root))


# --------------------------------------------------------------------------------------------
# Child: deskarm's window as the command starts it, hooked once it shows


def _since_spawn() -> float:
    return time.time() - float(os.environ.get(SPAWN_ENV, time.time()))


def child_window(seconds: float, app_argv: list[str]) -> int:
    """Start ``deskarm app_argv --size 800x480`` (offscreen) and print one JSON line: ``first_frame_s``,
    ``window_s`` (from the spawn), lists ``cpu_pct``, ``gui_pct``, ``loop_fps``, ``drawn_fps``,
    ``latency_ms``, and ``app_file`` (which checkout ran)."""
    seen: dict = {"python_s": _since_spawn(), "window_s": None, "first_frame_s": None, "timed_out": False,
                  "cpu_pct": [], "gui_pct": [], "loop_fps": [], "drawn_fps": [], "latency_ms": [],
                  "kind": None, "app_file": None, "argv": app_argv}
    from PySide6 import QtCore, QtWidgets

    qapp = QtWidgets.QApplication.instance() or QtWidgets.QApplication(sys.argv[:1])
    counts = {"loop": 0, "cmd_source_t": None}
    st: dict = {"w": None, "hooked": False, "sampling": False, "finishing": False, "printed": False}
    last: dict = {}

    def report() -> None:
        if not st["printed"]:
            st["printed"] = True
            print(json.dumps(seen), flush=True)

    def drawn(w) -> int:
        view = getattr(w, "view_left", None)
        if view is not None and hasattr(view, "frames_drawn"):
            return int(view.frames_drawn)
        return counts["loop"]  # the assistive view: every frame it is handed is drawn

    def hook(w) -> None:
        """Counters that run in the emitting worker's thread (DirectConnection): nothing queued."""
        direct = QtCore.Qt.ConnectionType.DirectConnection
        workers = getattr(w, "workers", None)
        if workers is not None:  # the main window
            seen["kind"] = "main"
            clock = w.session.clock

            def on_result(*_args) -> None:
                counts["loop"] += 1

            def on_command(command, _goal) -> None:
                t = getattr(command, "source_t", None)
                if t is not None and t != counts["cmd_source_t"]:  # the first command of a new frame
                    counts["cmd_source_t"] = t
                    if st["sampling"]:
                        seen["latency_ms"].append((clock.now() - t) * 1e3)

            workers.perception.sigResult.connect(on_result, direct)
            workers.control.sigCommand.connect(on_command, direct)
        else:  # the assistive view: its worker hands it frames
            seen["kind"] = "assist"

            def on_frame(*_args) -> None:
                counts["loop"] += 1

            w.worker.sigFrame.connect(on_frame, direct)
        st["hooked"] = True

    def first_frame_shown(w) -> bool:
        if seen["kind"] == "main":
            return drawn(w) > 0
        return counts["loop"] > 0

    def mark() -> None:
        w = st["w"]
        last.update(wall=time.perf_counter(), cpu=time.process_time(), gui=time.thread_time(),
                    loop=counts["loop"], drawn=drawn(w))

    def sample() -> None:
        w = st["w"]
        if counts["loop"] == last["loop"]:
            camera = getattr(getattr(w, "session", None), "camera", None)
            if camera is not None and getattr(camera, "finished", False):  # a replay that ended: no frame will come
                seen["camera_finished"] = True
                sampler.stop()
                st["sampling"] = False
                finish()
            return  # no frame in this sample yet (a starved process): it lasts until one comes
        wall, cpu, gui = time.perf_counter(), time.process_time(), time.thread_time()
        dt = wall - last["wall"]
        seen["cpu_pct"].append(100.0 * (cpu - last["cpu"]) / dt)
        seen["gui_pct"].append(100.0 * (gui - last["gui"]) / dt)
        seen["loop_fps"].append((counts["loop"] - last["loop"]) / dt)
        seen["drawn_fps"].append((drawn(w) - last["drawn"]) / dt)
        mark()
        if len(seen["cpu_pct"]) >= max(1, round(seconds * 1000 / SAMPLE_MS)):
            sampler.stop()
            st["sampling"] = False
            finish()

    def begin() -> None:
        mark()
        st["sampling"] = True
        sampler.start()

    def finish() -> None:
        camera = getattr(getattr(st["w"], "session", None), "camera", None)
        for name in ("frames_rendered", "frames_skipped", "frames_unread", "frames_repeated", "frames_delivered"):
            if isinstance(getattr(camera, name, None), int):  # what the camera made of the loop's pace
                seen[f"camera_{name}"] = getattr(camera, name)
        report()
        st["finishing"] = True
        w = st["w"]
        if w is not None:
            stop = getattr(w, "stop", None)
            if seen["kind"] == "assist" and stop is not None:
                stop()
            w.close()  # the main window's closeEvent stops and joins its workers
        qapp.quit()

    def poll() -> None:
        if st["finishing"]:
            qapp.quit()  # a quit inside a processEvents before app.exec() is lost: again
            return
        t = _since_spawn()
        w = st["w"]
        if w is None:
            for top in QtWidgets.QApplication.topLevelWidgets():
                names = {c.__name__ for c in type(top).__mro__}
                if top.isVisible() and names & {"MainWindow", "AssistWindow"}:
                    st["w"] = w = top
                    seen["window_s"] = t
                    hook(w)
                    break
        if w is not None and seen["first_frame_s"] is None and first_frame_shown(w):
            seen["first_frame_s"] = t
            poller.setInterval(SLOW_POLL_MS)  # from here it only waits for the end: not 200 wake-ups a second in what is measured
            QtCore.QTimer.singleShot(int(WARMUP_S * 1000), begin)
        if seen["first_frame_s"] is None and t > FIRST_FRAME_TIMEOUT_S:
            seen["timed_out"] = True
            finish()

    poller = QtCore.QTimer()
    poller.setInterval(POLL_MS)
    poller.timeout.connect(poll)
    poller.start()
    sampler = QtCore.QTimer()
    sampler.setInterval(SAMPLE_MS)
    sampler.timeout.connect(sample)

    from app import cli  # the `deskarm` entry point

    seen["app_file"] = getattr(sys.modules.get("app"), "__file__", None)
    rc = cli.main(list(app_argv) + ["--size", WINDOW_SIZE])
    report()
    return 0 if rc in (0, None) else int(rc)


def main(argv: list[str]) -> int:
    if "--child" in argv:
        seconds = float(argv[argv.index("--seconds") + 1]) if "--seconds" in argv else 3.0
        rest = argv[argv.index("--") + 1:] if "--" in argv else []
        return child_window(seconds, rest)
    from bench.__main__ import format_table

    root = Path(argv[argv.index("--root") + 1]) if "--root" in argv else REPO
    cases = argv[argv.index("--cases") + 1].split(",") if "--cases" in argv else None
    budgets = None
    if "--budgets" in argv:
        wanted = argv[argv.index("--budgets") + 1].split(",")
        budgets = [b for b in PI_BUDGETS if b[0] in wanted]
    repeat = int(argv[argv.index("--repeat") + 1]) if "--repeat" in argv else 1
    t0 = time.perf_counter()
    results = measure_all(quick="--full" not in argv, root=root, cases=cases, budgets=budgets, repeat=repeat)
    print(format_table(results_to_rows(results)))
    print()
    print(pi_table(results))
    print(f"\n(root {root}; {time.perf_counter() - t0:.0f} s; {os.cpu_count()} cores; "
          f"load {os.getloadavg()[0]:.1f})")
    if "--json" in argv:
        path = argv[argv.index("--json") + 1]
        Path(path).write_text(json.dumps(results))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
