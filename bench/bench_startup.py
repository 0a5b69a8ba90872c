"""Start-up: wall time from launching ``deskarm`` to its window showing and to its first camera frame.

Each repetition is a fresh child process (offscreen, a fresh temporary ``DESKARM_HOME``) that
starts the app as the ``deskarm`` command does: ``app.cli.main(["--camera", "sim", "--scenario",
"static", "--size", "1280x800"])`` — the start-up splash, the heavy imports, ``DeskSession.create``
and ``app.gui.run_window(options, (1280, 800), splash)``, blocking in ``app.exec()``. The parent
takes ``time.time()`` just before ``Popen`` and passes it in ``DESKARM_BENCH_SPAWN_T``; the child
measures every event against it. Before calling the app the child creates the QApplication itself
(``app.startup.make_app`` reuses ``QApplication.instance()``) with a timer that polls every POLL_MS
and records the first time it sees:

- ``visible``: any top-level widget visible (the splash, a placeholder, the window);
- ``window``: a top-level widget with a class named ``MainWindow`` visible ("time to window");
- ``frame``: that window's ``_drawn_result`` is not None and ``_drawn_result.frame`` is not None
  ("time to first frame"; a window that shows a placeholder first counts only once a camera frame
  is drawn).

The poll runs whenever the event loop does (also inside ``processEvents`` calls, e.g. the splash's),
so an event is seen at the first loop iteration after it: when Qt could first paint it. Once
``window`` and ``frame`` are both seen the child prints one JSON line, closes the window (which
stops its workers) and quits the app; after TIMEOUT_S from the spawn it prints what it saw
(``timed_out``) and quits, and the parent raises with that line. The breakdown: when the
interpreter reached this script (``python``), the seconds in ``app.startup.show_splash``, the import
of ``app.gui``, ``DeskSession.create`` and ``MainWindow.__init__`` (None when the app no longer
does that step that way).

The baseline, measured in the same run and interleaved with the app: a bare child (the same script
and polling) that only imports ``PySide6.QtWidgets``, creates a QApplication and shows an empty
QMainWindow — the time to window of an empty Qt app. One uncounted child of each runs first.

Run alone: ``python -m bench.bench_startup [--quick] [--root DIR]`` (``--root``: measure another
checkout of deskarm, e.g. a git worktree of an older commit, with this venv). The child is
``python bench/bench_startup.py --child app|bare``, run as a script in ``root`` with
``PYTHONPATH=root`` so that it imports that checkout's ``app`` (checked: ``app_file``).
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SPAWN_ENV = "DESKARM_BENCH_SPAWN_T"  # parent's time.time() just before Popen
TIMEOUT_ENV = "DESKARM_BENCH_TIMEOUT_S"  # the child's TIMEOUT_S as the parent chose it
APP_ARGV = ["--camera", "sim", "--scenario", "static"]  # the default simulated desk
WINDOW_SIZE = (1280, 800)  # app.cli's default --size
POLL_MS = 5
TIMEOUT_S = 10.0  # from the spawn; the child then prints what it saw and quits
KILL_MARGIN_S = 20.0  # the parent kills a child that has not exited this long after TIMEOUT_S
REPETITIONS = 5
REPO = Path(__file__).resolve().parents[1]
SCRIPT = Path(__file__).resolve()


# --------------------------------------------------------------------------------------------
# Parent: one subprocess per measurement


def run_child(kind: str, root: Path = REPO, timeout_s: float = TIMEOUT_S) -> dict:
    """One fresh child (``app`` or ``bare``) importing deskarm from ``root``; its JSON result.

    Raises RuntimeError when the child fails or has not seen what it waits for ``timeout_s``
    after the spawn (a test passes a long one: a loaded machine is slow, not broken).
    """
    if kind not in ("app", "bare"):
        raise ValueError(f"start-up bench child {kind!r}; allowed: app, bare")
    root = Path(root).resolve()
    cmd = [sys.executable, str(SCRIPT), "--child", kind]
    with tempfile.TemporaryDirectory(prefix="deskarm-bench-home-") as home:
        env = dict(os.environ, QT_QPA_PLATFORM="offscreen", DESKARM_HOME=home)
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(root), os.environ.get("PYTHONPATH")) if p)
        env[TIMEOUT_ENV] = repr(float(timeout_s))
        env[SPAWN_ENV] = repr(time.time())
        proc = subprocess.Popen(cmd, cwd=root, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True)
        try:
            out, err = proc.communicate(timeout=timeout_s + KILL_MARGIN_S)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, err = proc.communicate()
            raise RuntimeError(f"start-up bench child {kind} hung (killed after "
                               f"{timeout_s + KILL_MARGIN_S:g} s): {err.strip()[-800:]}") from None
    lines = [ln for ln in out.splitlines() if ln.startswith("{")]
    result = json.loads(lines[-1]) if lines else None
    wanted = ("window", "frame") if kind == "app" else ("window",)
    if result is None or proc.returncode != 0 or any(result.get(k) is None for k in wanted):
        raise RuntimeError(f"start-up bench child {kind} (root {root}) exited {proc.returncode}, "
                           f"saw {result}: {err.strip()[-800:]}")
    if kind == "app" and not Path(result.get("app_file") or "/").resolve().is_relative_to(root):
        raise RuntimeError(f"start-up bench child imported app from {result.get('app_file')}, not from {root}")
    return result


def measure(repetitions: int = REPETITIONS, root: Path = REPO, warmup: bool = True,
            timeout_s: float = TIMEOUT_S) -> dict:
    """``repetitions`` app and bare children, interleaved; lists of seconds per event.

    ``warmup`` first runs one uncounted child of each (bytecode caches, the OS file cache);
    ``timeout_s``: see ``run_child``.
    """
    if warmup:
        from bench.bench_pi import compile_sources

        compile_sources(Path(root))  # the bytecode caches a warm-up child cannot write with PYTHONDONTWRITEBYTECODE set
        run_child("bare", root, timeout_s)
        run_child("app", root, timeout_s)
    keys_app = ("python", "visible", "window", "frame", "import_app_gui", "session_create", "main_window_init",
                "show_splash")
    out: dict = {f"app_{k}": [] for k in keys_app}
    out["bare_window"] = []
    for _ in range(max(1, int(repetitions))):
        b = run_child("bare", root, timeout_s)
        out["bare_window"].append(b["window"])
        a = run_child("app", root, timeout_s)
        for k in keys_app:
            out[f"app_{k}"].append(a.get(k))
    return out


def _median_ms(values) -> str:
    import numpy as np

    vals = [v for v in values if v is not None]
    return f"{1000 * float(np.median(vals)):.0f} ms" if vals else "n/a"


def rows(quick: bool = False, root: Path = REPO) -> list[dict]:
    """Time to window and to first frame (ms) against an empty Qt window's time to window."""
    n = 1 if quick else REPETITIONS
    m = measure(n, root, warmup=not quick)
    base = "start-up: empty Qt window shown (baseline)"

    def ms(key: str) -> list[float]:
        return [1000.0 * v for v in m[key]]

    breakdown = (f"python up {_median_ms(m['app_python'])}, splash {_median_ms(m['app_show_splash'])}, "
                 f"import app.gui {_median_ms(m['app_import_app_gui'])}, "
                 f"DeskSession.create {_median_ms(m['app_session_create'])}, "
                 f"MainWindow() {_median_ms(m['app_main_window_init'])}")
    return [
        {"name": base, "unit": "ms", "samples": ms("bare_window"), "baseline": None,
         "extra": f"fresh process, offscreen: import QtWidgets, QApplication, QMainWindow.show(); n={n}"},
        {"name": "start-up: anything on screen (splash/window)", "unit": "ms", "samples": ms("app_visible"),
         "baseline": base, "extra": "deskarm --camera sim --scenario static, any top-level widget visible"},
        {"name": "start-up: time to window (MainWindow shown)", "unit": "ms", "samples": ms("app_window"),
         "baseline": base, "extra": breakdown},
        {"name": "start-up: time to first camera frame drawn", "unit": "ms", "samples": ms("app_frame"),
         "baseline": base, "extra": "MainWindow._drawn_result.frame set; from the spawn"},
    ]


# --------------------------------------------------------------------------------------------
# Child: started as a script; everything it imports before the app is what any Qt app imports


def _since_spawn() -> float:
    return time.time() - float(os.environ[SPAWN_ENV])


def child(kind: str) -> int:
    seen: dict = {"kind": kind, "python": _since_spawn(), "visible": None, "window": None, "frame": None,
                  "import_app_gui": None, "session_create": None, "main_window_init": None,
                  "show_splash": None, "app_file": None, "timed_out": False}
    from PySide6 import QtCore, QtWidgets

    qapp = QtWidgets.QApplication.instance() or QtWidgets.QApplication(sys.argv[:1])
    timeout_s = float(os.environ.get(TIMEOUT_ENV, TIMEOUT_S))
    done = {"printed": False, "finishing": False, "closed": None}
    main_window: dict = {}

    def report() -> None:
        if not done["printed"]:
            done["printed"] = True
            print(json.dumps(seen), flush=True)

    def finish() -> None:
        """Report, then close the window and quit on every poll until the app has left its loop:
        the poll also runs inside ``processEvents`` before ``app.exec()`` (the splash's, on a slow
        machine), where a quit does nothing and the window is still to come."""
        report()
        done["finishing"] = True
        w = main_window.get("w")
        if w is not None and done["closed"] is not w:
            done["closed"] = w
            w.close()  # deskarm's closeEvent stops and joins its workers
        qapp.quit()

    def poll() -> None:
        if done["finishing"]:
            if main_window.get("w") is None:  # a window shown after the time-out: close it too
                for top in QtWidgets.QApplication.topLevelWidgets():
                    if top.isVisible() and any(c.__name__ == "MainWindow" for c in type(top).__mro__):
                        main_window["w"] = top
            finish()
            return
        t = _since_spawn()
        w = main_window.get("w")
        if w is None or seen["visible"] is None:
            for top in QtWidgets.QApplication.topLevelWidgets():
                if not top.isVisible():
                    continue
                if seen["visible"] is None:
                    seen["visible"] = t
                if w is None and any(c.__name__ == "MainWindow" for c in type(top).__mro__):
                    main_window["w"] = w = top
                    break
        if w is not None and w.isVisible():
            if seen["window"] is None:
                seen["window"] = t
            drawn = getattr(w, "_drawn_result", None)
            if seen["frame"] is None and drawn is not None and getattr(drawn, "frame", None) is not None:
                seen["frame"] = t
        if seen["window"] is not None and (kind == "bare" or seen["frame"] is not None):
            finish()
        elif t > timeout_s:
            seen["timed_out"] = True
            finish()

    poller = QtCore.QTimer()
    poller.setInterval(POLL_MS)
    poller.timeout.connect(poll)
    poller.start()

    if kind == "bare":
        window = QtWidgets.QMainWindow()
        window.resize(*WINDOW_SIZE)
        main_window["w"] = window  # the baseline's window is a bare QMainWindow
        window.show()
        rc = qapp.exec()
    else:
        rc = _run_app(seen)
    report()  # the app returned without the loop ever seeing both events
    return 0 if rc in (0, None) else int(rc)


def _run_app(seen: dict) -> int:
    """``deskarm --camera sim --scenario static``, timing ``import app.gui`` and ``DeskSession.create``."""
    import builtins

    real_import = builtins.__import__
    # timed once their module is imported (app.cli imports core.session only when a run needs it)
    later = {"core.session": ("DeskSession", "create", "session_create")}

    def hook_imported() -> None:
        for module_name, (owner, attr, key) in list(later.items()):
            module = sys.modules.get(module_name)
            if module is not None and hasattr(module, owner):
                del later[module_name]
                # a plain function on the class: DeskSession.create(options) calls it unbound
                _time_calls(getattr(module, owner), attr, seen, key)

    def timed_import(name, *args, **kwargs):
        if name == "app.gui" and "app.gui" not in sys.modules:
            t0 = time.perf_counter()
            try:
                return real_import(name, *args, **kwargs)
            finally:
                seen["import_app_gui"] = time.perf_counter() - t0
                # the window's constructor (a plain function on the class binds like a method)
                _time_calls(getattr(sys.modules.get("app.gui"), "MainWindow", None), "__init__",
                            seen, "main_window_init")
                hook_imported()
        try:
            return real_import(name, *args, **kwargs)
        finally:
            if later:
                hook_imported()

    builtins.__import__ = timed_import
    from app import cli  # the `deskarm` entry point (app.cli:main)

    seen["app_file"] = getattr(sys.modules.get("app"), "__file__", None)  # which checkout: see run_child
    hook_imported()  # (an older app.cli imports core.session with itself)
    _time_calls(sys.modules.get("app.startup") or _import_or_none("app.startup"), "show_splash", seen,
                "show_splash")
    try:
        return cli.main(list(APP_ARGV) + ["--size", f"{WINDOW_SIZE[0]}x{WINDOW_SIZE[1]}"])
    finally:
        builtins.__import__ = real_import


def _import_or_none(name: str):
    import importlib

    try:
        return importlib.import_module(name)
    except ImportError:
        return None


def _time_calls(owner, attr: str, seen: dict, key: str) -> None:
    """Replace ``owner.attr`` by a wrapper that stores the seconds of its first call in ``seen[key]``."""
    real = getattr(owner, attr, None) if owner is not None else None
    if real is None:
        return

    def timed(*args, **kwargs):
        t0 = time.perf_counter()
        try:
            return real(*args, **kwargs)
        finally:
            if seen.get(key) is None:
                seen[key] = time.perf_counter() - t0

    setattr(owner, attr, timed)


def main(argv: list[str]) -> int:
    if "--child" in argv:
        return child(argv[argv.index("--child") + 1])
    if str(REPO) not in sys.path:  # run as a script: the table formatter lives in bench/__main__
        sys.path.insert(0, str(REPO))
    from bench.__main__ import format_table

    root = Path(argv[argv.index("--root") + 1]) if "--root" in argv else REPO
    print(format_table(rows(quick="--quick" in argv, root=root)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
