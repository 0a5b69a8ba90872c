"""The robot feature on its own (app/features/robot.py): "Simulated arm" on the Robot tab asks the
bridge worker for sim:// and the picker says it is connecting, then shows the bridge's answer; the
joint readout shows the commanded joints. A real session and bridge worker, the Robot tab shown,
no MainWindow."""
from types import SimpleNamespace

import pytest
from PySide6 import QtCore

from app.features.robot import RobotFeature
from feature_rig import TIMEOUT_MS, show_page

LEFT = QtCore.Qt.MouseButton.LeftButton


@pytest.fixture
def robot(qtbot, session, workers):
    feature = RobotFeature(session, workers.bridge)
    feature.host = show_page(qtbot, feature.page, size=(420, 600))  # kept: qtbot holds it weakly
    return feature


def test_simulated_arm_asks_the_bridge_worker_and_shows_its_answer(qtbot, robot, session, workers):
    session.bridge.connect()
    workers.bridge.start()
    with qtbot.waitSignal(workers.bridge.sigStatus, timeout=TIMEOUT_MS,
                          check_params_cb=lambda status: status.url.startswith("sim")) as blocker:
        qtbot.mouseClick(robot.bridge_picker.sim_button, LEFT)
        assert "connecting to sim://" in robot.bridge_picker.status_label.text()
    robot.show_bridge_status(blocker.args[0])
    assert "connecting" not in robot.bridge_picker.status_label.text()


def test_the_joint_readout_shows_the_commanded_and_measured_joints_in_servo_degrees(robot, session):
    assert robot.joints.row_texts(1)[1:3] == ("—", "—")
    q = session.profile.q_home  # servo degrees 0, 90, 90 on the desk arm
    robot.draw(SimpleNamespace(q=q), None)
    assert robot.joints.row_texts(1)[1:3] == ("90.0", "—")
    robot.draw(SimpleNamespace(q=q), SimpleNamespace(q=q))
    assert robot.joints.row_texts(1)[1:3] == ("90.0", "90.0")
