"""The assistive view on a screen (app.assist.screens, no AssistWindow): a window fills its screen's
available geometry, and ``--screenshot``'s capture waits for the boxes, then saves a PNG of exactly
the size asked for and closes the window (pytest-qt, offscreen; the capture runs its own event loop
to the application's end, so it runs in a child process, as ``deskarm --assist --screenshot`` does)."""
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

from PySide6 import QtGui, QtWidgets

from app.assist.screens import show_filling_screen

REPO = Path(__file__).resolve().parents[3]


def test_a_window_fills_the_available_geometry_of_its_screen(qtbot):
    w = QtWidgets.QWidget()
    qtbot.addWidget(w)
    show_filling_screen(w, (800, 480))
    qtbot.waitExposed(w)
    assert w.geometry() == w.screen().availableGeometry()


CHILD = textwrap.dedent('''
    import json, sys
    from PySide6 import QtCore, QtWidgets
    from app.assist.screens import screenshot_when_ready

    class Ready(QtWidgets.QLabel):
        """A stand-in for the window: ``choosing`` turns True when its timer says the boxes came."""

        def __init__(self):
            super().__init__("boxes")
            self.choosing, self.state_text, self.stopped = False, "starting the arm…", False
            QtCore.QTimer.singleShot(300, self.offer)

        def offer(self):
            self.choosing, self.state_text = True, "choose a button"

        def stop(self):
            self.stopped = True

    app = QtWidgets.QApplication([])
    w = Ready()
    w.setFixedSize(640, 360)
    w.show()
    result = screenshot_when_ready(app, w, sys.argv[1], (640, 360), after_s=0.0)
    print(json.dumps(dict(result, stopped=w.stopped, visible=w.isVisible())))
''')


def test_the_screenshot_waits_for_the_boxes_and_has_exactly_the_size_asked_for(tmp_path):
    path = tmp_path / "shot.png"
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", PYTHONPATH=str(REPO))
    done = subprocess.run([sys.executable, "-c", CHILD, str(path)], cwd=REPO, env=env, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["saved"] and result["state"] == "choose a button" and result["stopped"] and not result["visible"]
    image = QtGui.QImage(str(path))
    assert (image.width(), image.height()) == (640, 360)
