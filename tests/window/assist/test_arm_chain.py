"""The assistive view's arm chain on its own (app.assist.arm_chain.ArmChain, no AssistWindow): the
simulated desk's loop on its worker thread, the simulated servo arm behind the safety chain, the
images in a view, the boxes and the loop's status as signals in the GUI thread, the arm line, STOP,
and a loop that cannot be built (pytest-qt, offscreen). Waits on signals; the worker is joined."""
import numpy as np
import pytest
from PySide6 import QtWidgets

from app.assist.arm_chain import ArmChain, guarded_arm_factory
from core.devices import open_bridge
from core.kinematics.profile import load_profile
from widgets.assist_view import AssistView

from tests.window.test_assist_window import TIMEOUT_MS, sim_loop  # the simulated desk's loop, built once


@pytest.fixture
def chain(qtbot):
    made = []

    def make(loop_factory=sim_loop, arm=True):
        host = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(host)
        view = AssistView()
        layout.addWidget(view)
        stopped = {"engaged": False}
        factory = guarded_arm_factory(open_bridge("sim://", load_profile("assistive_5dof"))) if arm else None
        c = ArmChain(loop_factory, "sim", view, lambda: stopped["engaged"], host, arm_factory=factory)
        layout.addWidget(c.label)
        qtbot.addWidget(host)
        host.show()
        made.append((c, host))  # (pytest-qt keeps only a weak reference to the host)
        return c, view, stopped

    yield make
    for c, _ in made:
        c.stop()
        assert c.worker.isFinished() and not c.worker.isRunning()


def test_the_arm_goes_to_its_ready_pose_then_the_boxes_come_with_the_image(chain, qtbot):
    c, view, _ = chain()
    with qtbot.waitSignal(c.sigBoxes, timeout=TIMEOUT_MS) as offered:
        c.start()
    boxes = offered.args[0]
    assert len(boxes) == 9 and all(len(b) == 4 for b in boxes)
    qtbot.waitUntil(lambda: view._image is not None, timeout=TIMEOUT_MS)  # the image reached the view
    assert c.label.isVisible() and c.label.text() == "arm: simulated"
    assert np.allclose(c.worker.last_command.q, c.worker.ready_q, atol=1e-9)  # sent through the chain
    assert c.camera_message() == ""


def test_a_choice_is_followed_in_the_view_and_stop_turns_the_arm_line_red(chain, qtbot):
    c, view, stopped = chain()
    with qtbot.waitSignal(c.sigBoxes, timeout=TIMEOUT_MS):
        c.start()
    states = []
    c.sigStatus.connect(lambda s: states.append(s.state))
    c.worker.select(6)
    qtbot.waitUntil(lambda: "APPROACH" in states, timeout=TIMEOUT_MS)
    qtbot.waitUntil(lambda: view.chosen_centre is not None, timeout=TIMEOUT_MS)  # followed while it moves
    stopped["engaged"] = True
    c.worker.emergency_stop()
    qtbot.waitUntil(lambda: c.label.text() == "arm: E-STOP", timeout=TIMEOUT_MS)
    assert "E-STOP" in c.label.toolTip() and "b00020" in c.label.styleSheet()
    qtbot.waitUntil(lambda: states[-1] == "IDLE", timeout=TIMEOUT_MS)
    assert c.worker.loop.fsm.event_log()[-1]["reason"] == "stopped by the user"


def test_without_an_arm_the_line_stays_hidden_and_the_loop_s_joints_are_the_arm(chain, qtbot):
    c, _, _ = chain(arm=False)
    with qtbot.waitSignal(c.sigBoxes, timeout=TIMEOUT_MS):
        c.start()
    assert c.label.isHidden() and c.worker.arm is None


def test_a_loop_that_cannot_be_built_is_an_error_signal(chain, qtbot):
    def broken():
        raise OSError("no hand camera here")

    c, _, _ = chain(loop_factory=broken, arm=False)
    with qtbot.waitSignal(c.sigError, timeout=TIMEOUT_MS) as failed:
        c.start()
    assert failed.args == ["the assistive loop stopped: OSError: no hand camera here"]
    c.worker.wait(TIMEOUT_MS)
