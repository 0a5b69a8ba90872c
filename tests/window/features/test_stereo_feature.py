"""The stereo feature on its own (app/features/stereo.py): a preset typed and saved on the Stereo
tab is written for this camera pair and offered again, and deleted; the disparity views get depth
marks for the settings; disparity runs only while a view shows it. A real session and perception
worker, the Stereo tab and two camera views shown, no MainWindow."""
import pytest
from PySide6 import QtCore

from app.features.stereo import StereoFeature
from core.vision.disparity import list_presets
from widgets.camera_view import CameraView
from feature_rig import show_page

LEFT = QtCore.Qt.MouseButton.LeftButton


@pytest.fixture
def stereo(qtbot, session, workers):
    views = (CameraView("Left"), CameraView("Right"))
    feature = StereoFeature(session, workers.perception, views)
    feature.host = show_page(qtbot, *views, feature.page, size=(500, 900))  # kept: qtbot holds it weakly
    return feature


def test_a_preset_typed_and_saved_is_offered_again_and_can_be_deleted(qtbot, stereo, session):
    panel = stereo.stereo_panel
    edit = panel.preset_combo.lineEdit()
    edit.setFocus()
    qtbot.keyClicks(edit, "bright room")
    qtbot.mouseClick(panel.save_preset_button, LEFT)
    pair = session.camera.pair_id
    assert "bright room" in list_presets(pair)
    assert "saved “bright room”" in panel.preset_status.text()
    assert panel.preset_combo.findText("bright room") >= 0
    qtbot.mouseClick(panel.delete_preset_button, LEFT)
    assert "bright room" not in list_presets(pair) and "deleted" in panel.preset_status.text()


def test_the_views_get_depth_marks_and_disparity_runs_only_while_shown(qtbot, stereo, workers):
    stereo.update_legend()
    assert all(view.depth_legend for view in stereo.views)
    left = stereo.views[0]
    qtbot.mouseClick(left.toggle_button, LEFT)  # the view's image / disparity switch
    assert left.display_mode == "disparity" and workers.perception._want_disparity.is_set()
    qtbot.mouseClick(left.toggle_button, LEFT)
    assert left.display_mode == "image" and not workers.perception._want_disparity.is_set()
