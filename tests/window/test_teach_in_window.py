"""The Teach panel lives in the main window's Objects tab (below the detectors), and a model it
saves is picked up at once: the running desk detector is built anew (off, then on), so it loads
the taught model — no restart."""
from __future__ import annotations

from tests.window.test_objects_window import TIMEOUT_MS, objects_window


def test_the_teach_panel_is_in_the_objects_tab(qtbot):
    w = objects_window(qtbot, detectors=("hsv",))
    try:
        objects_tab = w.tabs.widget([w.tabs.tabText(i) for i in range(w.tabs.count())].index("Objects"))
        w.tabs.setCurrentWidget(objects_tab)  # (a hidden tab's page joins it when first opened)
        assert objects_tab.isAncestorOf(w.detector_panel) and objects_tab.isAncestorOf(w.teach.page)
        qtbot.waitUntil(lambda: w.teach.page.isVisible(), timeout=TIMEOUT_MS)
    finally:
        w.stop()


def test_a_saved_taught_model_rebuilds_the_running_desk_detector(qtbot):
    w = objects_window(qtbot, detectors=("desk",))
    w.start()
    try:
        perception = w.workers.perception
        qtbot.waitUntil(lambda: w._result is not None, timeout=TIMEOUT_MS)
        before = [d for d in perception.object_detectors() if d.spec_name == "desk"]
        assert len(before) == 1
        applied = []
        perception.sigDetectorsApplied.connect(lambda running: applied.append([n for n, _ in running]))
        w.teach.sigModelChanged.emit("/tmp/taught.onnx")  # what the Teach feature says after saving
        qtbot.waitUntil(lambda: len(applied) >= 2, timeout=TIMEOUT_MS)
        assert "desk" not in applied[0] and "desk" in applied[1]  # off, then on again
        after = [d for d in perception.object_detectors() if d.spec_name == "desk"]
        assert len(after) == 1 and after[0] is not before[0]  # a new detector: it loaded the model anew
    finally:
        w.stop()
