"""A detector that is unsure says so (issue 27, item 6): the Objects tab's "Sure above" sets
per-class score thresholds; a camera view draws an object below its class's threshold grey and
dotted with "unsure" in its label, a tap on it does not follow it, and lowering that class's
threshold with the slider (real key events) makes it an object like any other. A real session,
perception worker signal and CameraView; no MainWindow."""
from types import SimpleNamespace

import numpy as np
import pytest
from PySide6 import QtCore

from app.features.objects import ObjectsFeature
from core.detect.base import Detection
from core.detect.stereo import ObjectObservation
from core.messages import PerceptionResult, TargetMode
from widgets.camera_overlays import UNSURE_COLOUR
from widgets.camera_view import CameraView, ObjectOverlay
from widgets.target_panel import TargetPanel
from feature_rig import show_page

LEFT = QtCore.Qt.MouseButton.LeftButton


def observation(object_id, label, score, box, kind="object"):
    x, y, w, h = box
    d = Detection(kind=kind, label=label, score=score, box=box, centre_px=(x + w / 2, y + h / 2))
    return ObjectObservation(object_id=object_id, kind=kind, label=label, score=score, left=d, right=d,
                             camera_p=(0.0, 0.0, 0.5), base_p=(0.2, 0.1, 0.03), velocity_base=None,
                             epipolar_dy_px=0.0, seen_left=True, seen_right=True)


CUP = observation(1, "cup", 0.41, (100.0, 120.0, 80.0, 90.0))  # a learned class below 0.5: unsure
BALL = observation(2, "ball", 0.92, (380.0, 200.0, 60.0, 60.0))
RED = observation(3, "red", 0.30, (250.0, 330.0, 50.0, 40.0), kind="colour")  # a colour blob: sure at any score
RESULT = PerceptionResult(seq=1, t=0.0, markers=(), timings_ms={}, full_frame_search=False, objects=(CUP, BALL, RED))


@pytest.fixture
def rig(qtbot, session, workers):
    result = SimpleNamespace(value=RESULT)
    panel = TargetPanel()
    feature = ObjectsFeature(session, workers.perception, panel, lambda: result.value)
    notes = []
    feature.sigNote.connect(notes.append)
    view = CameraView("Left")
    view.show_image(np.full((480, 640, 3), 90, np.uint8))
    view.sigObjectClicked.connect(feature.follow_tapped)  # as the window wires it
    host = show_page(qtbot, view, feature.page, size=(640, 900))
    feature.attach_views([view])
    view.set_objects([ObjectOverlay.from_observation(o, "left") for o in RESULT.objects])
    with qtbot.waitSignal(workers.perception.sigResult):
        workers.perception.sigResult.emit(RESULT)  # the classes seen reach the threshold's list
    return SimpleNamespace(feature=feature, view=view, notes=notes, host=host, session=session)


def tap(qtbot, view, box):
    x, y, w, h = box
    pos = view.graphics_view.viewport().mapFrom(view, view.image_to_widget(x + w / 2, y + h / 2))
    qtbot.mouseClick(view.graphics_view.viewport(), LEFT, pos=pos)


def test_an_unsure_object_is_grey_and_says_so_the_sure_ones_keep_their_colours(rig):
    colours, labels = rig.view.object_colours(), rig.view.object_labels()
    assert colours[1] == UNSURE_COLOUR and "unsure" in labels[1].splitlines()[0]
    assert colours[2] != UNSURE_COLOUR and "unsure" not in labels[2]
    assert colours[3] != UNSURE_COLOUR and "unsure" not in labels[3]  # a blob's 0.30 is sure by default
    assert rig.feature.detector_panel.known_classes == ["ball", "cup", "red"]


def test_a_tap_on_an_unsure_object_does_not_follow_it(qtbot, rig):
    rig.session.targeter.set_mode(TargetMode.OBJECT)
    tap(qtbot, rig.view, CUP.left.box)
    assert "cup #1 is unsure (score 0.41 < 0.50): not followed" in rig.notes[-1]
    assert rig.session.targeter.follow_object_id != 1
    tap(qtbot, rig.view, BALL.left.box)
    assert rig.notes[-1] == "following ball #2" and rig.session.targeter.follow_object_id == 2


def test_lowering_the_cups_threshold_with_the_slider_makes_it_sure(qtbot, rig):
    panel = rig.feature.detector_panel
    rig.session.targeter.set_mode(TargetMode.OBJECT)
    panel.class_combo.setFocus()
    qtbot.keyClick(panel.class_combo, QtCore.Qt.Key.Key_Home)
    for _ in range(panel.class_combo.findData("cup")):
        qtbot.keyClick(panel.class_combo, QtCore.Qt.Key.Key_Down)
    assert panel.class_combo.currentData() == "cup" and panel.threshold_slider.value() == 0.5
    panel.threshold_slider.slider.setFocus()
    with qtbot.waitSignal(panel.sigThresholdsChanged):
        for _ in range(2):  # page steps of 0.1: 0.5 -> 0.3
            qtbot.keyClick(panel.threshold_slider.slider, QtCore.Qt.Key.Key_PageDown)
    assert panel.thresholds.per_class == {"cup": pytest.approx(0.3)}
    assert rig.view.object_colours()[1] != UNSURE_COLOUR and "unsure" not in rig.view.object_labels()[1]
    assert rig.session.targeter.object_thresholds.is_sure(CUP)
    tap(qtbot, rig.view, CUP.left.box)
    assert rig.notes[-1] == "following cup #1"
    # the ball keeps the learned default: raising that above its 0.92 greys it
    qtbot.keyClick(panel.class_combo, QtCore.Qt.Key.Key_Home)  # "any learned class"
    panel.threshold_slider.slider.setFocus()
    qtbot.keyClick(panel.threshold_slider.slider, QtCore.Qt.Key.Key_End)
    assert rig.view.object_colours()[2] == UNSURE_COLOUR and rig.view.object_colours()[1] != UNSURE_COLOUR
