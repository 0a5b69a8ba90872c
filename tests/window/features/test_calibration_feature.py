"""The calibration feature on its own (app/features/calibration.py): the Camera tab says which
calibration is in use, "Calibrate cameras…" opens the wizard (announced, so STOP can follow it;
its worker joined on close), and the simulated desk's camera settings go to the perception
worker. A real session and perception worker, the Camera tab shown, no MainWindow."""
import pytest
from PySide6 import QtCore, QtWidgets

from app.features.calibration import CalibrationFeature
from feature_rig import TIMEOUT_MS

LEFT = QtCore.Qt.MouseButton.LeftButton


@pytest.fixture
def calibration(qtbot, session, workers):
    host = QtWidgets.QWidget()  # the window the wizards open over
    feature = CalibrationFeature(session, workers.perception, host)
    QtWidgets.QVBoxLayout(host).addWidget(feature.page)
    qtbot.addWidget(host)
    host.resize(420, 480)
    host.show()
    qtbot.waitExposed(host)
    feature.kept = host  # qtbot holds it weakly
    yield feature
    feature.close()


def test_the_camera_tab_says_which_calibration_is_in_use(calibration):
    assert calibration.calibration_label.text() == "Calibration: the simulated rig's exact one."
    assert calibration.camera_panel is not None and calibration.device_panel is None  # the simulated desk


def test_calibrate_opens_the_wizard_once_and_announces_it(qtbot, calibration):
    made = []
    calibration.sigDialogMade.connect(made.append)
    qtbot.mouseClick(calibration.calibrate_button, LEFT)
    controller = calibration.calibration_controller
    assert made == [controller] and controller.wizard is not None
    qtbot.waitUntil(lambda: controller.wizard.isVisible(), timeout=TIMEOUT_MS)
    qtbot.mouseClick(calibration.calibrate_button, LEFT)  # again: the same wizard comes to the front
    assert made == [controller]
    calibration.close()
    assert not controller.active  # its worker is stopped and joined


def test_a_camera_setting_tapped_on_its_slider_goes_to_the_perception_worker(qtbot, calibration, workers):
    panel = calibration.camera_panel
    slider = panel.sliders["exposure"].findChild(QtWidgets.QAbstractSlider)  # beside its value label
    assert panel.settings().exposure == 0.0
    with qtbot.waitSignal(panel.sigSettingsChanged, timeout=TIMEOUT_MS):  # after the throttle
        qtbot.mouseClick(slider, LEFT, pos=QtCore.QPoint(slider.width() - 5, slider.height() // 2))
    assert workers.perception._pending_settings.exposure == pytest.approx(4.0)  # its right end
