"""The e-stop feature on its own (app/features/estop.py): STOP asks to stop; set_engaged stops
the arm and shows RE-ARM, which asks to re-arm only after a full hold; a registered dialog
follows the state and its STOP stops too; a modal dialog without STOP pauses the arm. A real
session, STOP and RE-ARM shown, no MainWindow."""
import pytest
from PySide6 import QtCore, QtWidgets

from app.features.estop import MODAL_PAUSE, EStopFeature
from widgets.recordings_dialog import RecordingsDialog
from feature_rig import TIMEOUT_MS

LEFT = QtCore.Qt.MouseButton.LeftButton


@pytest.fixture
def estop(qtbot, session):
    host = QtWidgets.QWidget()
    feature = EStopFeature(session, None, host)
    feature.stops, feature.rearms = [], []
    feature.sigStopRequested.connect(lambda: (feature.stops.append(True), feature.set_engaged(True)))
    feature.sigRearmRequested.connect(lambda: (feature.rearms.append(True), feature.set_engaged(False)))
    layout = QtWidgets.QHBoxLayout(host)
    layout.addWidget(feature.rearm_button)
    layout.addWidget(feature.estop_button)
    qtbot.addWidget(host)
    host.resize(400, 80)
    host.show()
    qtbot.waitExposed(host)
    feature.host = host  # kept: qtbot holds it weakly
    yield feature
    feature.remove()


def test_stop_stops_and_rearm_shows_only_then_and_needs_a_full_hold(qtbot, estop, session):
    assert session.controller.armed and not estop.rearm_button.isVisible()
    qtbot.mouseClick(estop.estop_button, LEFT)
    assert estop.stops and not session.controller.armed and estop.estop_button.engaged
    assert estop.rearm_button.isVisible()
    qtbot.mouseClick(estop.rearm_button, LEFT)  # a tap is no hold
    assert not estop.rearms and not session.controller.armed
    with qtbot.waitSignal(estop.sigRearmRequested, timeout=TIMEOUT_MS):
        qtbot.mousePress(estop.rearm_button, LEFT)
    qtbot.mouseRelease(estop.rearm_button, LEFT)
    assert session.controller.armed and not estop.rearm_button.isVisible()


def test_a_registered_dialog_follows_the_state_and_its_stop_stops(qtbot, estop, session, tmp_path):
    dialog = RecordingsDialog(str(tmp_path))
    qtbot.addWidget(dialog)
    estop.add_dialog(dialog)
    estop.set_engaged(True)
    estop.set_engaged(False)
    dialog.show()
    qtbot.waitExposed(dialog)
    stop = next(b for b in dialog.findChildren(QtWidgets.QAbstractButton) if "STOP" in b.text())
    qtbot.mouseClick(stop, LEFT)
    assert estop.stops and not session.controller.armed


def test_a_modal_dialog_without_stop_pauses_the_arm_until_it_closes(qtbot, estop, session):
    box = QtWidgets.QDialog(estop.host)
    box.setModal(True)
    box.show()
    qtbot.waitUntil(lambda: QtWidgets.QApplication.activeModalWidget() is box, timeout=TIMEOUT_MS)
    assert estop.check_modal_dialog() and MODAL_PAUSE in session.controller.paused_by
    assert not estop.check_modal_dialog()  # nothing new
    box.close()
    qtbot.waitUntil(lambda: QtWidgets.QApplication.activeModalWidget() is None, timeout=TIMEOUT_MS)
    assert estop.check_modal_dialog() and not session.controller.paused
