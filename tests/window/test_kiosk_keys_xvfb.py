"""Kiosk keys on a real X server (issue 22 item 4): Esc, F1 and Ctrl+Q at start-up and after a dialog.

With no window manager, X11 leaves the keyboard focus on the root window at start-up and gives it
back to the root window whenever a dialog closes: the keys then reach no window. This test starts
``deskarm`` in a child process on Xvfb (with and without openbox) and types with ``xdotool`` —
real X key and pointer events — reading what the window did from the child's output.

Like the 3D twin's Xvfb test it does not gate CI (a clean machine has no Xvfb): set
``DESKARM_TEST_XVFB=1`` to run it, after ``apt-get install -y xvfb xdotool openbox``.
"""
import textwrap

import pytest
from xserver import WAIT_S, why_no_xvfb, x_server

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


@pytest.mark.skipif(bool(why_no_xvfb()), reason=why_no_xvfb() or "-")
@pytest.mark.parametrize("window_manager", [False, True], ids=["no-window-manager", "openbox"])
def test_esc_f1_and_ctrl_q_work_at_start_and_after_a_dialog_on_a_real_x_server(tmp_path, window_manager):
    with x_server(tmp_path, window_manager) as x:
        script = tmp_path / "child.py"
        script.write_text(CHILD)
        child, out = x.start(script)
        out.wait_for("READY")
        x.xdo("key", "Escape")  # before any tap
        assert out.wait_for("ESTOP")[0] == "ESTOP True"
        x.xdo("key", "F1")
        _, px, py = out.wait_for("HELP")[0].split()
        x.xdo("mousemove", px, py, "click", "1")  # Help's Close: focus falls to the root window with no WM
        x.xdo("key", "Escape")
        assert out.wait_for("ESTOP")[0] == "ESTOP True"
        x.xdo("key", "ctrl+q")
        out.wait_for("CLOSE")
        assert child.wait(timeout=WAIT_S) == 0
