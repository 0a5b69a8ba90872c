"""The objects feature on its own (app/features/objects.py): a detector switched on in the
Objects tab runs in the perception worker and comes back as running (the Target tab's hint goes);
"Pick colour" says what the next tap does; a tapped object is followed only in Object mode. A
real session and perception worker, the DetectorPanel shown, no MainWindow."""
from types import SimpleNamespace

import pytest
from PySide6 import QtCore

from app.features.objects import NO_DETECTOR_HINT, ObjectsFeature
from core.messages import TargetMode
from widgets.target_panel import TargetPanel
from feature_rig import TIMEOUT_MS, show_page

LEFT = QtCore.Qt.MouseButton.LeftButton


@pytest.fixture
def objects(qtbot, session, workers):
    panel = TargetPanel()
    result = SimpleNamespace(value=None)
    feature = ObjectsFeature(session, workers.perception, panel, lambda: result.value)
    feature.notes, feature.result = [], result
    feature.sigNote.connect(feature.notes.append)
    feature.host = show_page(qtbot, feature.page, size=(420, 600))  # kept: qtbot holds it weakly
    workers.perception.start()
    return feature


def test_a_detector_switched_on_runs_and_the_hint_goes(qtbot, objects):
    assert objects.running == [] and objects.target_panel.object_hint.text() == NO_DETECTOR_HINT
    with qtbot.waitSignal(objects.sigChanged, timeout=TIMEOUT_MS):
        qtbot.mouseClick(objects.detector_panel.toggles["hsv"], LEFT)
    assert objects.running == ["hsv"] and objects.target_panel.object_hint.text() == ""
    with qtbot.waitSignal(objects.sigChanged, timeout=TIMEOUT_MS):
        qtbot.mouseClick(objects.detector_panel.toggles["hsv"], LEFT)
    assert objects.running == [] and objects.target_panel.object_hint.text() == NO_DETECTOR_HINT


def test_pick_colour_says_what_the_next_tap_sets(qtbot, objects):
    qtbot.mouseClick(objects.detector_panel.pick_button, LEFT)
    assert objects.picking and "tap the object" in objects.notes[-1]


def test_a_tapped_object_is_followed_only_in_object_mode(qtbot, objects, session):
    obs = SimpleNamespace(label="red ball", object_id=3)
    objects.result.value = SimpleNamespace(object_observation=lambda object_id: obs if object_id == 3 else None)
    session.targeter.set_mode(TargetMode.MANUAL)
    objects.follow_tapped(3)
    assert "choose the Target tab's Object mode" in objects.notes[-1]
    session.targeter.set_mode(TargetMode.OBJECT)
    objects.follow_tapped(3)
    assert objects.notes[-1] == "following red ball #3"
    assert session.targeter.follow_object_id == 3 and session.targeter.follow_object_label == "red ball"
