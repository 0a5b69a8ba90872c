"""Marker-less objects in the window (issue 11, item 7): the perception worker runs the object
detectors, both camera views draw the objects, the Objects tab tunes the detectors live and picks
colours from a tap, and the Target tab's Object mode follows one (pytest-qt, offscreen, the
``objects`` scenario of the simulated desk started as ``deskarm --scenario objects --detector hsv``).

Tests wait on the window's own GUI-thread state (``window._result``, ``window._goal``, set by its
queued slots) with ``qtbot.waitUntil``, as tests/window/test_main_window.py does.
"""
import numpy as np
import pytest
from PySide6 import QtCore, QtWidgets

from app.gui import MainWindow
from core.detect import registry
from core.messages import TargetMode
from core.session import DeskSession, SessionOptions
from widgets._style import TOUCH_PX
from widgets.camera_view import CameraView, ObjectOverlay, object_label

SMALL = (800, 480)
TIMEOUT_MS = 10_000  # two cores shared with other test runs: frames can be slow
LEFT = QtCore.Qt.MouseButton.LeftButton
SMALL_BLOBS = ("red", "green", "blue")  # the balls: < 2000 px² at 640x480 (the yellow plush ~4500 px²)
BIG_ENOUGH_PX2 = 2500.0


def objects_window(qtbot, detectors=("hsv",), size=SMALL) -> MainWindow:
    session = DeskSession.create(SessionOptions(camera="sim", scenario="objects", robot="desk_rrr",
                                                detectors=detectors))
    w = MainWindow(session)
    qtbot.addWidget(w)
    w.resize(*size)
    w.show()
    qtbot.waitExposed(w)
    return w


@pytest.fixture
def window(qtbot):
    w = objects_window(qtbot)
    w.start()
    yield w
    w.stop()
    for worker in (w.workers.perception, w.workers.control, w.workers.bridge):
        assert worker.isFinished() and not worker.isRunning(), worker.objectName()


def result_with(qtbot, window, predicate, timeout=TIMEOUT_MS):
    """Wait for a perception result (as the window received it) for which ``predicate`` holds."""
    qtbot.waitUntil(lambda: window._result is not None and predicate(window._result), timeout=timeout)
    return window._result


def labels(result) -> set:
    return {o.label for o in result.objects if o.triangulated}


def seen(result, label):
    """The triangulated object labelled ``label`` in both views, or None."""
    return next((o for o in result.objects if o.label == label and o.triangulated
                 and o.left is not None and o.right is not None), None)


def click_image(qtbot, view: CameraView, x_px: float, y_px: float) -> None:
    pos = view.graphics_view.viewport().mapFrom(view, view.image_to_widget(x_px, y_px))
    qtbot.mouseClick(view.graphics_view.viewport(), LEFT, pos=pos)


def draw(window) -> None:
    window._dirty = True
    window.redraw()


def tab_index(window, title: str) -> int:
    return [window.tabs.tabText(i) for i in range(window.tabs.count())].index(title)


# --- the command line's detectors are on, and shown ------------------------------------------
def test_the_command_line_detector_runs_and_the_panel_shows_it(qtbot, window):
    assert window.detector_panel.enabled == ["hsv"]
    assert window.detector_panel.toggles["hsv"].isChecked()
    assert not window.detector_panel.toggles["circles"].isChecked()
    r = result_with(qtbot, window, lambda r: {"red", "green"} <= labels(r))
    assert "objects" in r.timings_ms and r.timings_ms["objects"] > 0
    # a new calibration (the wizard's): the objects are triangulated with it, the detectors stay
    before, perception = window.workers.perception.object_detectors(), window.session.object_perception
    window.workers.perception.set_calibration(window.session.calibration)
    qtbot.waitUntil(lambda: window.session.object_perception is not perception, timeout=TIMEOUT_MS)
    assert window.workers.perception.object_detectors() == before
    result_with(qtbot, window, lambda r2: r2.seq > r.seq + 3 and {"red", "green"} <= labels(r2))


# --- overlays ---------------------------------------------------------------------------------
def test_objects_are_drawn_in_both_views_with_ids_and_the_followed_one_with_3d_text(qtbot, window):
    r = result_with(qtbot, window, lambda r: seen(r, "green") is not None and seen(r, "red") is not None)
    draw(window)
    for view, side in ((window.view_left, "left"), (window.view_right, "right")):
        drawn = view.object_labels()
        expected = {o.object_id: o.label for o in window._drawn_result.objects
                    if (o.left if side == "left" else o.right) is not None}
        assert set(drawn) == set(expected) and expected, side
        for object_id, label in expected.items():
            assert drawn[object_id].startswith(f"#{object_id} {label}"), drawn[object_id]
    # 800x480: compact labels ("#3 green"); the object being followed also shows where it is
    green = seen(r, "green")
    window.target_panel.mode_buttons["object"].click()
    window.target_panel.set_follow_object("green", green.object_id)
    assert window.session.targeter.follow_object_id == green.object_id
    result_with(qtbot, window, lambda r: (o := seen(r, "green")) is not None and o.velocity_base is not None)
    draw(window)
    text = window.view_left.object_labels()[green.object_id]
    lines = text.split("\n")
    assert lines[0].startswith(f"#{green.object_id} green 0.") and len(lines) == 3, text
    assert lines[1].startswith("x ") and lines[1].endswith(" cm") and lines[2].endswith(" cm/s"), text
    x_cm = float(lines[1].split()[1])
    assert x_cm == pytest.approx(100 * window._drawn_result.object_observation(green.object_id).base_p[0], abs=0.051)


def test_a_wide_view_labels_every_object_with_position_and_speed(qtbot):
    view = CameraView()
    qtbot.addWidget(view)
    view.resize(700, 560)
    view.show()
    view.show_image(np.zeros((480, 640, 3), np.uint8))
    from core.detect.base import Detection
    from core.detect.stereo import ObjectObservation

    disc = Detection("circle", "circle", 0.9, (100, 100, 40, 40), (120, 120), radius_px=20)
    blob = Detection("colour", "red", 0.95, (300, 200, 30, 20), (315, 210),
                     contour=np.array([[300, 200], [330, 200], [330, 220], [300, 220]]))
    obs = [ObjectObservation(object_id=3, kind="circle", label="circle", score=0.9, left=disc, right=disc,
                             camera_p=(0, 0, 0.5), base_p=(0.012, 0.153, -0.004), velocity_base=(0.03, -0.04, 0.0),
                             epipolar_dy_px=0.1, seen_left=True, seen_right=True),
           ObjectObservation(object_id=4, kind="colour", label="red", score=0.95, left=blob, right=None,
                             camera_p=None, base_p=(0.1, 0.2, 0.0), velocity_base=None, epipolar_dy_px=None,
                             seen_left=True, seen_right=False, triangulated=False)]
    view.set_objects([o for o in (ObjectOverlay.from_observation(x, "left") for x in obs) if o is not None])
    texts = view.object_labels()
    assert texts[3] == "#3 circle 0.90\nx 1.2 y 15.3 z -0.4 cm\nv 5.0 cm/s"
    assert texts[4] == "#4 red 0.95\none view only"
    assert object_label(obs[0], detailed=False) == "#3 circle"
    # a circle is drawn as a circle, a blob as its contour; a tap on a box picks its object
    shown = {o.object_id: o for o in view.shown_objects}
    assert len(shown[3].outline) > 4 and len(shown[4].outline) == 4
    assert view.object_at(120, 120) == 3 and view.object_at(315, 210) == 4 and view.object_at(500, 400) is None
    with qtbot.waitSignal(view.sigObjectClicked, timeout=2000) as blocker:
        click_image(qtbot, view, 310, 205)
    assert blocker.args == [4]
    # the same overlays again are skipped; fewer hide the rest of the reused slots
    view.set_objects([ObjectOverlay.from_observation(obs[0], "left")])
    assert list(view.object_labels()) == [3]


# --- the detector panel tunes the worker's detectors ------------------------------------------
def test_raising_the_minimum_area_drops_the_small_objects(qtbot, window):
    result_with(qtbot, window, lambda r: {"green", "yellow"} <= labels(r))
    panel = window.detector_panel
    panel.show_settings_of("hsv")
    with qtbot.waitSignal(panel.sigDetectorsChanged, timeout=2000) as blocker:
        panel.hsv_sliders["min_area_px"].slider.setValue(int(BIG_ENOUGH_PX2))
    assert dict(blocker.args[0])["hsv"]["min_area_px"] == BIG_ENOUGH_PX2
    qtbot.waitUntil(lambda: [d.params.min_area_px for d in window.workers.perception.object_detectors()]
                    == [BIG_ENOUGH_PX2], timeout=TIMEOUT_MS)
    seq = window._result.seq
    for wait in (2, 8):  # frames run with the new minimum: no ball is big enough any more
        r = result_with(qtbot, window, lambda r: r.seq > seq + wait and "objects" in r.timings_ms)
        assert not labels(r) & set(SMALL_BLOBS), labels(r)
    # and down again: the balls come back
    panel.hsv_sliders["min_area_px"].slider.setValue(30)
    result_with(qtbot, window, lambda r: "green" in labels(r))


def test_switching_detectors_on_and_off(qtbot, window):
    panel = window.detector_panel
    result_with(qtbot, window, lambda r: "green" in labels(r))
    panel.toggles["hsv"].click()  # all off: no objects
    qtbot.waitUntil(lambda: window.workers.perception.object_detectors() == [], timeout=TIMEOUT_MS)
    seq = window._result.seq
    result_with(qtbot, window, lambda r: r.seq > seq and r.objects == ())
    assert window.target_panel.object_hint.text()  # Object mode says a detector is needed
    panel.toggles["circles"].click()  # Hough circles on: the balls and discs are round
    qtbot.waitUntil(lambda: window._detectors_running == ["circles"], timeout=TIMEOUT_MS)
    result_with(qtbot, window, lambda r: any(o.kind == "circle" for o in r.objects))
    assert not window.target_panel.object_hint.text()
    with qtbot.waitSignal(panel.sigDetectorsChanged, timeout=2000) as blocker:
        panel.circle_sliders["min_radius_px"].slider.setValue(150)
        panel.circle_sliders["max_radius_px"].slider.setValue(100)  # below the minimum: the minimum follows
    options = dict(blocker.args[0])["circles"]
    assert options["min_radius_px"] == options["max_radius_px"] == 100
    qtbot.waitUntil(lambda: window.workers.perception.object_detectors()[0].params.max_radius_px == 100,
                    timeout=TIMEOUT_MS)
    # the ellipse finder's own settings (round tops seen at an angle)
    panel.circle_sliders["min_aspect"].slider.setValue(80)  # hundredths: 0.80
    assert panel.circle_params.min_aspect == pytest.approx(0.8)
    qtbot.waitUntil(lambda: window.workers.perception.object_detectors()[0].params.min_aspect
                    == pytest.approx(0.8), timeout=TIMEOUT_MS)


# --- tap to pick a colour -----------------------------------------------------------------------
def test_a_tap_with_pick_colour_adds_a_colour_that_finds_the_tapped_object(qtbot, window):
    panel = window.detector_panel
    panel.show_settings_of("hsv")
    while len(panel.hsv_params.colours) > 1:  # red alone (Remove), whatever the defaults are
        panel.colour_combo.setCurrentIndex(panel.colour_combo.count() - 1)
        panel.remove_colour_button.click()
    assert [c.name for c in panel.hsv_params.colours] == ["red"] and not panel.remove_colour_button.isEnabled()
    qtbot.waitUntil(lambda: [c.name for d in window.workers.perception.object_detectors()
                             for c in d.params.colours] == ["red"], timeout=TIMEOUT_MS)
    # results already on their way were computed with the seven colours: wait for one of red alone
    r = result_with(qtbot, window, lambda r: r.frame is not None and r.frame.truth is not None
                    and bool(labels(r)) and labels(r) <= {"red"})
    truth = next(o for o in r.frame.truth.objects if o.label == "purple disc")
    x, y = window.session.camera.rig.project("left", truth.base_p_centre)[0]
    panel.name_edit.setText("violet")
    panel.pick_button.click()
    assert panel.picking
    draw(window)
    with qtbot.waitSignal(panel.sigDetectorsChanged, timeout=2000) as blocker:
        click_image(qtbot, window.view_left, x, y)
    assert not panel.picking  # one tap, then the toggle is off
    colours = dict(blocker.args[0])["hsv"]["colours"]
    assert [c.name for c in colours] == ["red", "violet"] and "violet" in window._note
    r = result_with(qtbot, window, lambda r: seen(r, "violet") is not None)
    bx, by, bw, bh = seen(r, "violet").left.box
    assert bx - 3 <= x <= bx + bw + 3 and by - 3 <= y <= by + bh + 3
    assert window.session.targeter.manual_target == pytest.approx((0.0, 0.15, 0.10))  # the tap moved no target


# --- Object mode: follow one ------------------------------------------------------------------
def test_object_mode_follows_the_object_chosen_in_the_list_or_tapped(qtbot, window):
    panel = window.target_panel
    with qtbot.waitSignal(panel.sigModeChanged, timeout=2000):
        panel.mode_buttons["object"].click()
    assert window.session.targeter.mode is TargetMode.OBJECT
    assert panel.mode_buttons["object"].height() >= TOUCH_PX
    r = result_with(qtbot, window, lambda r: seen(r, "yellow") is not None and seen(r, "green") is not None)
    draw(window)
    yellow, green = seen(r, "yellow"), seen(r, "green")
    combo = panel.object_combo
    entries = [tuple(combo.itemData(i)) for i in range(combo.count())]
    assert ("yellow", yellow.object_id) in entries and ("yellow", None) in entries, entries
    index = entries.index(("yellow", yellow.object_id))
    combo.setCurrentIndex(index)
    t = window.session.targeter
    assert (t.follow_object_label, t.follow_object_id) == ("yellow", yellow.object_id)
    qtbot.waitUntil(lambda: window._goal is not None and window._goal.mode is TargetMode.OBJECT
                    and window._goal.valid and "yellow" in window._goal.note, timeout=TIMEOUT_MS)


    def strip_says_following():
        draw(window)
        return window.target_status.text().startswith(f"following yellow #{yellow.object_id}")

    qtbot.waitUntil(strip_says_following, timeout=TIMEOUT_MS)  # the plush is in reach
    # a tap on the (still) green ball's box follows it instead, and says so
    box = next(o.box for o in window.view_left.shown_objects if o.object_id == green.object_id)
    click_image(qtbot, window.view_left, box[0] + box[2] / 2, box[1] + box[3] / 2)
    assert (t.follow_object_label, t.follow_object_id) == ("green", green.object_id)
    assert panel.follow_object == ("green", green.object_id)
    assert window._note == f"following green #{green.object_id}"
    assert t.mode is TargetMode.OBJECT  # not turned into a manual target by the tap
    qtbot.waitUntil(lambda: window._goal is not None and window._goal.valid and "green" in window._goal.note,
                    timeout=TIMEOUT_MS)
    # the list keeps the user's choice while other objects come and go
    panel.set_objects_seen([("red", 99)])
    assert panel.follow_object == ("green", green.object_id) and "not seen" in combo.currentText()


def test_an_object_that_is_not_seen_holds_and_says_so(qtbot, window):
    # the control worker sends nothing for a goal that is invalid from the start (no command to
    # hold yet): let the first command through before following what is not there
    qtbot.waitUntil(lambda: window._command is not None, timeout=TIMEOUT_MS)
    window.target_panel.set_follow_object("unicorn", None)  # no such thing on the desk
    window.target_panel.mode_buttons["object"].click()
    assert window.session.targeter.follow_object_label == "unicorn"
    qtbot.waitUntil(lambda: window._goal is not None and not window._goal.valid
                    and "unicorn" in window._goal.note, timeout=TIMEOUT_MS)
    draw(window)
    status = window.target_status.text()
    assert "unicorn" in status and "not seen" in status and "holding" in status, status


# --- failures are messages -----------------------------------------------------------------------
def test_a_bad_onnx_file_is_a_message_and_the_window_keeps_working(qtbot, window, tmp_path):
    panel = window.detector_panel
    result_with(qtbot, window, lambda r: "green" in labels(r))
    missing = tmp_path / "no_such_model.onnx"
    panel.add_onnx(str(missing))
    qtbot.waitUntil(lambda: "not found" in panel.message(), timeout=TIMEOUT_MS)
    assert str(missing) in panel.message() and str(missing) in window.banner.text()
    assert not panel.onnx_toggle.isChecked() and panel.enabled == ["hsv"]
    seq = window._result.seq
    result_with(qtbot, window, lambda r: r.seq > seq + 3 and "green" in labels(r))
    assert window.workers.perception.isRunning()


def test_a_detector_that_raises_is_turned_off_with_a_message(qtbot, window, monkeypatch):
    class Exploding:
        name = "exploding"
        params = None

        def detect(self, image, roi=None):
            raise RuntimeError("the model ran out of memory")

    monkeypatch.setitem(registry._NAMED, "exploding", lambda **options: Exploding())
    window.workers.perception.request_detectors([("hsv", {}), ("exploding", {})])
    qtbot.waitUntil(lambda: "exploding failed" in window.detector_panel.message(), timeout=TIMEOUT_MS)
    assert "out of memory" in window.detector_panel.message()
    qtbot.waitUntil(lambda: window._detectors_running == ["hsv"], timeout=TIMEOUT_MS)
    seq = window._result.seq
    result_with(qtbot, window, lambda r: r.seq > seq + 3 and "green" in labels(r))


# --- fit and touch ----------------------------------------------------------------------------------
def test_the_objects_tab_fits_800x480_with_finger_sized_controls(qtbot):
    w = objects_window(qtbot)
    try:
        hint = w.minimumSizeHint()
        assert hint.width() <= SMALL[0] and hint.height() <= SMALL[1], hint
        w.tabs.setCurrentIndex(tab_index(w, "Objects"))
        panel = w.detector_panel
        panel.add_onnx("/nowhere/model.onnx")  # the model's toggle shows too (not started: not built)
        touch = (QtWidgets.QPushButton, QtWidgets.QAbstractSlider, QtWidgets.QComboBox, QtWidgets.QLineEdit)
        for name in [panel.settings_combo.itemData(i) for i in range(panel.settings_combo.count())]:
            panel.show_settings_of(name)
            QtWidgets.QApplication.processEvents()
            area = w.tabs.currentWidget()
            assert area.horizontalScrollBar().maximum() == 0, name
            for control in panel.findChildren(QtWidgets.QWidget):
                if isinstance(control, touch) and control.isVisibleTo(panel):
                    assert control.height() >= TOUCH_PX, (name, type(control).__name__, control.height())
        # the toggles are at the top: visible without scrolling
        area = w.tabs.currentWidget()
        area.verticalScrollBar().setValue(0)
        for button in panel.toggles.values():
            bottom = button.mapTo(area.viewport(), QtCore.QPoint(0, button.height())).y()
            assert bottom <= area.viewport().height(), button.text()
        # the Target tab's Object page too
        w.tabs.setCurrentIndex(0)
        w.target_panel.mode_buttons["object"].click()
        QtWidgets.QApplication.processEvents()
        assert w.target_panel.object_combo.height() >= TOUCH_PX
        assert w.tabs.currentWidget().horizontalScrollBar().maximum() == 0
    finally:
        w.stop()

