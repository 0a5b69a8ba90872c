"""What the window leaves until after its first frame (issue 28 item 3: first frame ≤ 5 s on a Pi 4).

The hidden tabs' pages join their tabs when first opened (or once the first camera frame is
drawn), STOP's application-wide guard starts watching when the window shows, and the start-up's
garbage collection waits for the first frame. Nothing here is timed: the figures are in
``python -m bench.bench_pi`` (start-up to the first frame).
"""
from __future__ import annotations

import gc
import json
import os
import subprocess
import sys
from pathlib import Path

from PySide6 import QtCore, QtWidgets

from app.gui import collect_in_the_gui_thread
from app.startup import GuiThreadGarbage
from app.window_frame import FIRST_FRAME_POLL_MS, after_first_frame
from tests.window.test_touch_window import make_window
from widgets.estop import EStopButton, StopGuard

TIMEOUT_MS = 30_000
REPO = Path(__file__).resolve().parents[2]
LEFT = QtCore.Qt.MouseButton.LeftButton


def _tab_index(window, title: str) -> int:
    return [window.tabs.tabText(i) for i in range(window.tabs.count())].index(title)


def test_hidden_tabs_join_when_first_opened_and_all_once_the_first_frame_is_drawn(qtbot):
    w = make_window(qtbot)
    try:
        assert w.isAncestorOf(w.target_panel) and w.isAncestorOf(w.jog_panel)  # the first screen, at once
        waiting = [w.stereo_panel, w.markers_table, w.detector_panel, w.camera_page, w.robot.page]
        assert not any(w.isAncestorOf(page) for page in waiting)
        # a tap on the Stereo tab: its page is there, shown
        bar = w.tabs.tabBar()
        qtbot.mouseClick(bar, LEFT, pos=bar.tabRect(_tab_index(w, "Stereo")).center())
        qtbot.waitUntil(w.stereo_panel.isVisible, timeout=TIMEOUT_MS)
        assert w.tabs.currentWidget().isAncestorOf(w.stereo_panel)
        assert not w.isAncestorOf(w.markers_table)
        w.start()
        qtbot.waitUntil(lambda: w._drawn_result is not None and w._drawn_result.frame is not None,
                        timeout=TIMEOUT_MS)
        qtbot.waitUntil(lambda: all(w.isAncestorOf(page) for page in waiting), timeout=TIMEOUT_MS)
        assert w.tabs.deferred.pending == []
        # each page in its own tab
        for title, page in (("Markers", w.markers_table), ("Objects", w.detector_panel),
                            ("Camera", w.camera_page), ("Robot", w.robot.page)):
            assert w.tabs.widget(_tab_index(w, title)).isAncestorOf(page), title
    finally:
        w.stop()


def test_work_after_the_first_frame_runs_once_the_frame_is_drawn(qtbot):
    w = make_window(qtbot)
    seen = []
    after_first_frame(w, lambda: seen.append((w._drawn_result is not None and w._drawn_result.frame is not None,
                                             gc.get_freeze_count())))
    try:
        w.start()
        qtbot.waitUntil(lambda: bool(seen), timeout=TIMEOUT_MS)
        assert seen[0][0], "called before a camera frame was drawn"
        qtbot.wait(3 * FIRST_FRAME_POLL_MS)  # a few more polls: it calls once
        assert len(seen) == 1
    finally:
        w.stop()


def test_the_start_up_s_objects_are_collected_and_frozen_after_the_first_frame(qtbot):
    """Then the GUI thread's timer collects (GuiThreadGarbage); until then the collector stays
    off, as app.cli.start_up leaves it."""
    app = QtWidgets.QApplication.instance()
    before = set(app.findChildren(GuiThreadGarbage))
    w = make_window(qtbot)
    was_enabled = gc.isenabled()
    gc.disable()
    after_first_frame(w, lambda: collect_in_the_gui_thread(app))
    try:
        w.start()
        qtbot.waitUntil(lambda: bool(set(app.findChildren(GuiThreadGarbage)) - before), timeout=TIMEOUT_MS)
        assert w._drawn_result is not None and w._drawn_result.frame is not None
        assert gc.get_freeze_count() > 0 and not gc.isenabled()
    finally:
        w.stop()
        for garbage in set(app.findChildren(GuiThreadGarbage)) - before:
            garbage.stop()
            garbage.setParent(None)
        gc.unfreeze()
        if was_enabled:
            gc.enable()


class _CountingGuard(StopGuard):
    calls = 0  # events of anything but the guarded window itself

    def eventFilter(self, obj, event):  # noqa: N802 (Qt override)
        if obj is not self.window:
            type(self).calls += 1
        return super().eventFilter(obj, event)


def test_stop_guard_watches_the_application_from_its_window_s_first_show(qtbot):
    window = QtWidgets.QWidget()
    qtbot.addWidget(window)
    layout = QtWidgets.QVBoxLayout(window)
    stop = EStopButton()
    layout.addWidget(stop)
    guard = _CountingGuard(stop, window)
    _CountingGuard.calls = 0
    try:
        for _ in range(20):  # building the rest of the window: thousands of events in the real one
            layout.addWidget(QtWidgets.QPushButton("x"))
        QtWidgets.QApplication.processEvents()
        assert _CountingGuard.calls == 0 and not guard.watching_application
        window.show()
        qtbot.waitExposed(window)
        assert guard.watching_application
        with qtbot.waitSignal(guard.sigStopRequested, timeout=TIMEOUT_MS):
            qtbot.mouseClick(stop, LEFT)  # a press on STOP's rectangle: the guard's own stop
    finally:
        guard.remove()


def test_the_simulated_desk_renders_nothing_while_the_window_is_built(tmp_path):
    """Its frames would be thrown away (the scene starts over once the window is up), and on a
    Pi-class core its renders would take the CPU the window's start-up needs. Run as
    ``deskarm --screenshot`` runs it, in a process of its own (it runs and quits the application)."""
    script = f"""
import json
import app.gui
from core.session import SessionOptions

seen = []


class Watched(app.gui.MainWindow):
    def __init__(self, session):
        seen.append((session.camera.is_connected, session.camera.frames_rendered))
        super().__init__(session)
        seen.append((session.camera.is_connected, session.camera.frames_rendered))


app.gui.MainWindow = Watched
rc = app.gui.take_screenshot(SessionOptions(camera="sim", scenario="wander"), {str(tmp_path / "w.png")!r}, 1.0,
                             (800, 480))
print(json.dumps({{"rc": rc, "seen": seen}}))
"""
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", PYTHONPATH=str(REPO), DESKARM_HOME=str(tmp_path))
    out = subprocess.run([sys.executable, "-c", script], cwd=REPO, env=env, capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    result = json.loads(out.stdout.splitlines()[-1])
    assert result["rc"] == 0 and (tmp_path / "w.png").is_file()
    (connected, rendered), (still_connected, rendered_after) = result["seen"]
    assert not connected and not still_connected and rendered_after == rendered
