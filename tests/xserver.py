"""A real X server for the tests that need one: Xvfb (optionally with openbox), a child process's
output read line by line, and xdotool for real key and pointer events.

Those tests do not gate CI (a clean machine has no Xvfb): they run with ``DESKARM_TEST_XVFB=1``
after ``apt-get install -y xvfb xdotool openbox``.
"""
from __future__ import annotations

import contextlib
import os
import queue
import shutil
import subprocess
import sys
import threading
from pathlib import Path
from typing import Iterator

OPT_IN_ENV = "DESKARM_TEST_XVFB"
WAIT_S = 60.0  # generous: a loaded 2-core machine starts a window in a few seconds
REPO = Path(__file__).resolve().parents[1]


def why_no_xvfb() -> str:
    """Why a real-X test cannot (or should not) run here, or ""."""
    if os.environ.get(OPT_IN_ENV) != "1":
        return f"real X server test: set {OPT_IN_ENV}=1 to run it (apt-get install -y xvfb xdotool openbox)"
    for tool in ("Xvfb", "xdotool", "openbox"):
        if shutil.which(tool) is None:
            return f"{tool} is not installed (apt-get install -y xvfb xdotool openbox)"
    return ""


class ChildLines:
    """A child's output lines, waited on one by one (a reader thread; no sleeps)."""

    def __init__(self, stream):
        self._q: queue.Queue = queue.Queue()
        self.seen: list[str] = []
        threading.Thread(target=self._read, args=(stream,), daemon=True).start()

    def _read(self, stream) -> None:
        for line in stream:
            self._q.put(line.strip())
        self._q.put(None)

    def wait_for(self, prefix: str) -> tuple[str, list[str]]:
        """The first line starting with ``prefix`` and the lines before it (since the last wait)."""
        before = []
        while True:
            try:
                line = self._q.get(timeout=WAIT_S)
            except queue.Empty:
                raise AssertionError(f"no {prefix!r} within {WAIT_S:g} s; the window said {self.seen[-8:]}")
            if line is None:
                raise AssertionError(f"the window exited before {prefix!r}; it said {self.seen[-8:]}")
            self.seen.append(line)
            if line.startswith(prefix):
                return line, before
            before.append(line)


class XSession:
    """A running Xvfb (and window manager): ``env`` for children, ``start`` a child, ``xdo``."""

    def __init__(self, env: dict, procs: list):
        self.env = env
        self._procs = procs

    def start(self, script: Path) -> tuple[subprocess.Popen, ChildLines]:
        """Run ``script`` with this display; its output as :class:`ChildLines`."""
        child = subprocess.Popen([sys.executable, str(script)],
                                 env=self.env, cwd=str(REPO), stdout=subprocess.PIPE,
                                 stderr=subprocess.DEVNULL, text=True)
        self._procs.append(child)
        return child, ChildLines(child.stdout)

    def xdo(self, *args: str) -> None:
        """xdotool on this display (real X key and pointer events)."""
        subprocess.run(["xdotool", *args], env=self.env, check=True, timeout=30)


@contextlib.contextmanager
def x_server(home: Path, window_manager: bool, size: str = "800x480") -> Iterator[XSession]:
    """Xvfb at ``size`` (with openbox when ``window_manager``); DESKARM_HOME = ``home``; every
    process it started is ended on the way out."""
    xvfb = subprocess.Popen(["Xvfb", "-displayfd", "1", "-screen", "0", f"{size}x24", "-nolisten", "tcp"],
                            stdout=subprocess.PIPE, text=True)
    procs: list = [xvfb]
    try:
        display = f":{xvfb.stdout.readline().strip()}"
        env = dict(os.environ, DISPLAY=display, QT_QPA_PLATFORM="xcb", DESKARM_HOME=str(home), PYTHONPATH=str(REPO))
        env.pop("WAYLAND_DISPLAY", None)
        if window_manager:
            procs.append(subprocess.Popen(["openbox"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        yield XSession(env, procs)
    finally:
        for p in reversed(procs):
            if p.poll() is None:
                p.terminate()
                try:
                    p.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    p.kill()
