"""The markers feature on its own (app/features/markers.py): a tapped row of the Markers table
does what the markers file says — follow the marker, or pick it up and carry it to its place
(the sequence steps with the measured joints). A real session, the table shown, no MainWindow."""
from types import SimpleNamespace

import numpy as np
import pytest
from PySide6 import QtCore

from app.features.markers import MarkersFeature
from core.messages import MarkerObservation, TargetMode
from core.vision.markers import MarkersConfig, MarkerSpec
from widgets.target_panel import TargetPanel
from feature_rig import TIMEOUT_MS, show_page

LEFT = QtCore.Qt.MouseButton.LeftButton
CONFIG = MarkersConfig(dictionary="DICT_APRILTAG_36h11",
                       markers=(MarkerSpec(23, "cup A", "pick_place", "bin"), MarkerSpec(50, "pen", "follow")),
                       places={"bin": (0.15, 0.05, 0.02)})


@pytest.fixture
def markers(qtbot, session):
    panel = TargetPanel()
    calls = SimpleNamespace(modes=[], notes=[], result=None, state=None)

    def set_mode(mode):
        calls.modes.append(mode)
        panel.set_mode(mode)
        session.targeter.set_mode(TargetMode(mode))

    feature = MarkersFeature(session, panel, set_mode, lambda: calls.result, lambda: calls.state)
    feature.markers_table.set_config(CONFIG)
    feature.sigNote.connect(calls.notes.append)
    feature.calls = calls
    feature.host = show_page(qtbot, feature.page)  # kept: qtbot holds it weakly
    return feature


def tap_row(qtbot, feature, marker_id):
    t = feature.markers_table.table
    rect = t.visualItemRect(t.item(feature.markers_table.row_of(marker_id), 0))
    with qtbot.waitSignal(feature.markers_table.sigMarkerChosen, timeout=TIMEOUT_MS):
        qtbot.mouseClick(t.viewport(), LEFT, pos=rect.center())


def test_a_follow_marker_tapped_in_the_table_is_followed(qtbot, markers, session):
    tap_row(qtbot, markers, 50)
    assert markers.calls.modes == ["follow"] and session.targeter.mode is TargetMode.FOLLOW
    assert session.targeter.follow_id == 50 and markers.calls.notes[-1] == "following marker 50"


def test_a_pick_place_marker_not_seen_says_so(qtbot, markers):
    tap_row(qtbot, markers, 23)
    assert markers.pick_place is None and "it must be seen by both cameras" in markers.calls.notes[0]


def test_a_pick_place_marker_seen_is_carried_to_its_place_step_by_step(qtbot, markers, session):
    cup = MarkerObservation(23, True, base_p_centre=(0.05, 0.15, 0.0))
    markers.calls.result = SimpleNamespace(marker=lambda marker_id: cup if marker_id == 23 else None)
    tap_row(qtbot, markers, 23)
    seq = markers.pick_place
    assert seq is not None and session.targeter.mode is TargetMode.MANUAL
    assert tuple(session.targeter.manual_target) == pytest.approx((0.05, 0.15, 0.05))  # above the cup
    # the measured tool reaches each waypoint: the next one becomes the manual target
    kin = session.kinematics
    for point, _closes, _what in seq.waypoints:
        ik = kin.ik(tuple(point))
        markers.calls.state = SimpleNamespace(q=ik.q)
        assert np.linalg.norm(np.asarray(kin.fk(ik.q))[:3] - point) < seq.tolerance_m, "the test's IK"
        markers.step_pick_place()
    assert markers.pick_place is None and "placed" in markers.calls.notes[-1]
