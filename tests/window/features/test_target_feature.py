"""The target feature on its own (app/features/target.py): a mode tapped on the Target tab goes
to the window's mode handler; the Lissajous mode draws its preview in the twins and says how much
is out of reach; a manual target typed in the X box becomes the targeter's. A real session, the
Target tab shown, no MainWindow."""
from types import SimpleNamespace

import pytest
from PySide6 import QtCore

from app.features.target import TargetFeature
from core.messages import TargetMode
from feature_rig import show_page

LEFT = QtCore.Qt.MouseButton.LeftButton


class Twin:
    """Stands in for an arm twin: what the preview would draw."""

    def __init__(self):
        self.preview = "never set"

    def set_preview(self, points):
        self.preview = points


@pytest.fixture
def target(qtbot, session):
    twin = Twin()
    feature = TargetFeature(session, lambda: [twin])
    feature.calls = SimpleNamespace(modes=[], poses=[], notes=[], twin=twin)
    feature.sigNote.connect(feature.calls.notes.append)
    feature.connect_panels(feature.calls.modes.append, feature.calls.poses.append)
    feature.host = show_page(qtbot, feature.target_panel, size=(420, 700))  # kept: qtbot holds it weakly
    return feature


def test_a_mode_tapped_goes_to_the_window_and_lissajous_draws_its_preview(qtbot, target, session):
    qtbot.mouseClick(target.target_panel.mode_buttons["lissajous"], LEFT)
    assert target.calls.modes == ["lissajous"]
    target.set_mode("lissajous")  # what the window's handler does first
    assert session.targeter.mode is TargetMode.LISSAJOUS
    assert target.calls.twin.preview is not None and len(target.calls.twin.preview) > 10
    target.set_mode("manual")
    assert target.calls.twin.preview is None and target.preview_note == ""


def test_the_cups_game_on_a_scene_without_cups_says_so(target):
    target.set_mode("cups")
    assert "--scenario cups" in target.calls.notes[-1]
    assert "--scenario cups" in target.target_panel.cups_hint.text()


def test_a_manual_target_typed_in_x_becomes_the_targeters(qtbot, target, session):
    session.targeter.set_mode(TargetMode.MANUAL)
    spin = target.target_panel.axes["x"].spin
    spin.setFocus()
    spin.selectAll()
    qtbot.keyClicks(spin, "3")
    qtbot.keyClick(spin, QtCore.Qt.Key.Key_Return)
    qtbot.waitUntil(lambda: abs(session.targeter.manual_target[0] - 0.03) < 1e-6, timeout=5000)
