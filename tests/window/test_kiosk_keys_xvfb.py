"""Kiosk keys on a real X server (issue 22 item 4): Esc, F1 and Ctrl+Q at start-up and after a dialog.

With no window manager, X11 leaves the keyboard focus on the root window at start-up and gives it
back to the root window whenever a dialog closes: the keys then reach no window. This test starts
``deskarm`` in a child process on Xvfb (with and without openbox) and types with ``xdotool`` —
real X key and pointer events — reading what the window did from the child's output.

Like the 3D twin's Xvfb test it does not gate CI (a clean machine has no Xvfb): set
``DESKARM_TEST_XVFB=1`` to run it, after ``apt-get install -y xvfb xdotool openbox``.
"""
import os
import queue
import shutil
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
OPT_IN_ENV = "DESKARM_TEST_XVFB"
WAIT_S = 60.0  # generous: a loaded 2-core machine starts the window in a few seconds

CHILD = textwrap.dedent('''
    import sys
    from PySide6 import QtCore, QtWidgets
    from app import gui

    def say(*words):
        print(*words, flush=True)

    original_estop, original_help, original_close = (gui.MainWindow.on_estop, gui.MainWindow.show_help,
                                                     gui.MainWindow.closeEvent)
    original_show = gui.MainWindow.showEvent

    def on_estop(self, engaged):
        say("ESTOP", engaged)
        original_estop(self, engaged)

    def show_help(self):
        dialog = original_help(self)
        def where():
            close = next(b for b in dialog.findChildren(QtWidgets.QPushButton) if b.text().startswith("Close"))
            c = close.mapToGlobal(close.rect().center())
            say("HELP", c.x(), c.y())
        QtCore.QTimer.singleShot(500, where)  # once the window manager has placed it
        return dialog

    def close_event(self, event):
        say("CLOSE")
        original_close(self, event)

    def shown(self, event):
        original_show(self, event)
        QtCore.QTimer.singleShot(1500, lambda: say("READY"))

    gui.MainWindow.on_estop, gui.MainWindow.show_help, gui.MainWindow.closeEvent = on_estop, show_help, close_event
    gui.MainWindow.showEvent = shown
    from app.cli import main
    sys.exit(main(["--scenario", "static"]))
''')


def _why_not() -> str:
    if os.environ.get(OPT_IN_ENV) != "1":
        return f"real X server test: set {OPT_IN_ENV}=1 to run it (apt-get install -y xvfb xdotool openbox)"
    for tool in ("Xvfb", "xdotool", "openbox"):
        if shutil.which(tool) is None:
            return f"{tool} is not installed (apt-get install -y xvfb xdotool openbox)"
    return ""


class Lines:
    """The child's output lines, waited on one by one (a reader thread; no sleeps)."""

    def __init__(self, stream):
        self._q: queue.Queue = queue.Queue()
        threading.Thread(target=self._read, args=(stream,), daemon=True).start()
        self.seen: list[str] = []

    def _read(self, stream) -> None:
        for line in stream:
            self._q.put(line.strip())
        self._q.put(None)

    def wait_for(self, prefix: str) -> str:
        while True:
            try:
                line = self._q.get(timeout=WAIT_S)
            except queue.Empty:
                raise AssertionError(f"no {prefix!r} from the window within {WAIT_S:g} s; it said {self.seen[-8:]}")
            if line is None:
                raise AssertionError(f"the window exited before {prefix!r}; it said {self.seen[-8:]}")
            self.seen.append(line)
            if line.startswith(prefix):
                return line


@pytest.mark.skipif(bool(_why_not()), reason=_why_not() or "-")
@pytest.mark.parametrize("window_manager", [False, True], ids=["no-window-manager", "openbox"])
def test_esc_f1_and_ctrl_q_work_at_start_and_after_a_dialog_on_a_real_x_server(tmp_path, window_manager):
    xvfb = subprocess.Popen(["Xvfb", "-displayfd", "1", "-screen", "0", "800x480x24", "-nolisten", "tcp"],
                            stdout=subprocess.PIPE, text=True)
    procs = [xvfb]
    try:
        display = f":{xvfb.stdout.readline().strip()}"
        env = dict(os.environ, DISPLAY=display, QT_QPA_PLATFORM="xcb", DESKARM_HOME=str(tmp_path),
                   PYTHONPATH=str(ROOT))
        env.pop("WAYLAND_DISPLAY", None)
        if window_manager:
            procs.append(subprocess.Popen(["openbox"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        script = tmp_path / "child.py"
        script.write_text(CHILD)
        child = subprocess.Popen([sys.executable, str(script)], env=env, cwd=str(ROOT), stdout=subprocess.PIPE,
                                 stderr=subprocess.DEVNULL, text=True)
        procs.append(child)
        out = Lines(child.stdout)

        def xdo(*args):
            subprocess.run(["xdotool", *args], env=env, check=True, timeout=30)

        out.wait_for("READY")
        xdo("key", "Escape")  # before any tap
        assert out.wait_for("ESTOP") == "ESTOP True"
        xdo("key", "F1")
        _, x, y = out.wait_for("HELP").split()
        xdo("mousemove", x, y, "click", "1")  # Help's Close: focus falls to the root window with no WM
        xdo("key", "Escape")
        assert out.wait_for("ESTOP") == "ESTOP True"
        xdo("key", "ctrl+q")
        out.wait_for("CLOSE")
        assert child.wait(timeout=WAIT_S) == 0
    finally:
        for p in reversed(procs):
            if p.poll() is None:
                p.terminate()
                try:
                    p.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    p.kill()
