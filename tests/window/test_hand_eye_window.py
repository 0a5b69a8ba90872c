"""The window's camera→arm calibration and Markers tab (pytest-qt, offscreen, simulated desk)."""
import numpy as np
import pytest
from PySide6 import QtCore

from app.gui import MainWindow
from core.handeye import HandEyeResult
from core.messages import TargetMode
from core.session import DeskSession, SessionOptions

LEFT = QtCore.Qt.MouseButton.LeftButton


@pytest.fixture
def window(qtbot):
    offset = (0.03, -0.02, 0.01, 0.05, -0.04, 0.03)  # m, rad: a rig mounted off its nominal pose
    session = DeskSession.create(SessionOptions(camera="sim", scenario="static", rig_offset=offset))
    w = MainWindow(session)
    qtbot.addWidget(w)
    w.resize(800, 480)
    w.show()
    w.start()
    yield w
    w.stop()
    session.close()


def test_status_bar_says_nominal_until_calibrated_then_the_rms(qtbot, window):
    window._refresh_status()
    assert "NOMINAL" in window.status_items.robot_label.text()
    truth = window.session.camera.true_base_T_camera()
    result = HandEyeResult(base_T_camera=truth, method="sweep", poses_used=10, residuals_mm=(1.0,) * 10,
                           rms_mm=1.0, max_mm=1.0, worst_index=0, rejected=(), warnings=(), camera_pair="sim",
                           created="2026-11-24T08:00:00", ok=True, problem="")
    window.session.use_hand_eye(result)
    window._refresh_status()
    assert window.status_items.robot_label.text() == "camera→arm: calibrated, 1.0 mm RMS"
    assert np.allclose(window.session.perception.base_T_camera, truth)


def test_the_sweep_drives_the_arm_through_the_targeter_and_cancel_gives_the_mode_back(qtbot, window):
    window.tabs.setCurrentIndex(window.tabs.count() - 1)  # Robot tab
    qtbot.mouseClick(window.hand_eye_button, LEFT)
    controller = window.hand_eye
    wizard = controller.wizard
    qtbot.waitExposed(wizard)
    before = window.session.targeter.mode
    wizard.start("sweep", 6)
    assert controller.running and window.session.targeter.mode is TargetMode.MANUAL
    first = controller.sweep.points[0]
    qtbot.waitUntil(lambda: np.allclose(window.session.targeter.manual_target, first), timeout=5000)
    qtbot.waitUntil(lambda: controller.sweep is None or controller.sweep.phase != "moving", timeout=10000)
    assert "pose 1" in wizard.progress_text()
    qtbot.mouseClick(wizard.stop_button, LEFT)  # the wizard's own STOP stops the arm
    assert not window.session.controller.armed
    wizard.sigCancelRequested.emit()
    assert not controller.running and window.session.targeter.mode is before


def test_markers_tab_lists_the_markers_and_a_tap_follows(qtbot, window):
    index = [window.tabs.tabText(i) for i in range(window.tabs.count())].index("Markers")
    table = window.markers_table
    qtbot.waitUntil(lambda: window._result is not None and sum(m.found for m in window._result.markers) >= 2,
                    timeout=5000)
    window.tabs.setCurrentIndex(index)
    assert window.dirty
    window.redraw()  # switching to the tab marked the window dirty: the table is filled now
    row = table.row_of(50)
    texts = table.row_texts(row)
    assert texts[2] == "L R" and len(texts[3].split()) == 3  # seen by both cameras; x y z in cm
    table.sigMarkerChosen.emit(50)
    assert window.session.targeter.mode is TargetMode.FOLLOW and window.session.targeter.follow_id == 50


def test_a_pick_place_marker_is_carried_to_its_place(qtbot, tmp_path):
    markers = tmp_path / "markers.toml"
    markers.write_text('dictionary = "DICT_6X6_250"\n[places]\nbin = [-0.08, 0.14, 0.03]\n'
                       '[[marker]]\nid = 23\nname = "cup A"\naction = "pick_place"\nplace = "bin"\n'
                       '[[marker]]\nid = 50\nname = "cup B"\naction = "follow"\n')
    session = DeskSession.create(SessionOptions(camera="sim", scenario="static", markers=str(markers)))
    w = MainWindow(session)
    qtbot.addWidget(w)
    w.resize(800, 480)
    w.show()
    w.start()
    try:
        qtbot.waitUntil(lambda: w._result is not None and w._result.marker(23) is not None
                        and w._result.marker(23).found and w._state is not None, timeout=5000)
        w.markers_table.sigMarkerChosen.emit(23)
        assert w.pick_place is not None and w.session.targeter.mode is TargetMode.MANUAL
        qtbot.waitUntil(lambda: w.pick_place is None, timeout=30000)
        assert "placed" in w._note, w._note
        tip = np.asarray(w.session.kinematics.fk(w._state.q))[:3]
        assert np.linalg.norm(tip - np.array([-0.08, 0.14, 0.08])) < 0.02  # back up above the bin
    finally:
        w.stop()
        session.close()
