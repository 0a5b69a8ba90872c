"""The bridge QThread: reconnects with backoff after failures and shows the state."""
import pytest
from PySide6 import QtCore

from app.workers import BridgeWorker, Latest
from core.devices.bridge import BridgeError
from core.devices.sim_arm import SimServoArm
from core.session import DeskSession, SessionOptions


class FlakyArm(SimServoArm):
    """A simulated arm whose first ``failures`` connects fail like an unplugged board."""

    def __init__(self, profile, failures):
        super().__init__(profile)
        self.failures = failures
        self.attempts = 0

    def connect(self):
        self.attempts += 1
        if self.attempts <= self.failures:
            raise BridgeError("/dev/ttyACM0: no such port — is the board plugged in?")
        super().connect()


class StatusLog(QtCore.QObject):
    """Collects statuses in the GUI thread (a slot of a GUI-thread QObject: queued delivery)."""

    def __init__(self):
        super().__init__()
        self.items = []

    @QtCore.Slot(object)
    def add(self, status):
        self.items.append(status)


@pytest.fixture
def session():
    s = DeskSession.create(SessionOptions(camera="sim", scenario="static"))
    yield s
    s.close()


def test_reconnects_with_backoff_and_reports_each_state(qtbot, session):
    session.bridge = FlakyArm(session.profile, failures=2)
    worker = BridgeWorker(session, Latest(), Latest())
    log = StatusLog()
    worker.sigStatus.connect(log.add)
    worker.start()
    try:
        qtbot.waitUntil(lambda: any(st.connected for st in log.items), timeout=8000)
    finally:
        worker.stop()
    statuses = log.items
    assert session.bridge.attempts == 3
    assert any(not st.connected and "plugged in" in st.message for st in statuses)
    assert worker.isFinished()


def test_switching_to_an_unfit_bridge_keeps_the_working_one(qtbot, session):
    worker = BridgeWorker(session, Latest(), Latest())
    session.bridge.connect()
    before = session.bridge
    log = StatusLog()
    worker.sigStatus.connect(log.add)
    worker.start()
    try:
        worker.request_bridge("v2:loop://")  # a v2 board must answer; loop:// cannot
        qtbot.waitUntil(lambda: any("could not switch" in st.message for st in log.items), timeout=8000)
    finally:
        worker.stop()
    assert worker.isFinished()
    assert session.bridge is before and before.is_connected
    assert "no reply" in before.message and "still on sim://" in before.message


class CommandLog(QtCore.QObject):
    def __init__(self):
        super().__init__()
        self.items = []

    @QtCore.Slot(object, object)
    def add(self, command, goal):
        self.items.append((command, goal))


def test_a_user_input_makes_the_control_worker_step_at_once(qtbot, session):
    """A new manual target rings the control worker; the step that follows is an early one."""
    from app.workers import ControlWorker
    from core.messages import TargetMode

    session.targeter.set_mode(TargetMode.MANUAL)
    worker = ControlWorker(session, Latest(), Latest(), Latest())
    worker.schedule.period_s = 3600.0  # no tick in this test: only a goal can make a step
    log = CommandLog()
    worker.sigCommand.connect(log.add)
    worker.start()
    try:
        qtbot.waitUntil(lambda: len(log.items) == 1, timeout=5000)  # the first step runs at once
        session.targeter.set_manual_target((0.05, 0.18, 0.06))
        qtbot.waitUntil(lambda: len(log.items) == 2, timeout=5000)
    finally:
        worker.stop()
    command, goal = log.items[-1]
    assert goal.base_p_target == (0.05, 0.18, 0.06)
    assert worker.schedule.event_steps == 1
    assert worker.isFinished()
