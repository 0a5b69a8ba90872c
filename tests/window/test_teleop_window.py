"""Teleoperation in the window: the Target tab's Teleop mode and page (source, Restart, target box,
state), the banner line and the twin's teleop boxes (pytest-qt, offscreen, workers running).

A scripted hand source stands in for the camera's wristband (``MainWindow.teleop_source_factory``)
with short gestures, so the whole calibrating → following → ended cycle takes about a second; the
``teleop`` scenario itself is only checked for its start (the headless tests run it through)."""
from __future__ import annotations

import threading

import numpy as np
import pytest
from PySide6 import QtCore, QtWidgets

from app.gui import MainWindow
from core.messages import TargetMode
from core.motion.jog import JogTeleopSource
from core.motion.teleop import (
    CALIBRATING,
    ENDED,
    FOLLOWING,
    HOLDING,
    Box,
    HandObservation,
    TeleopController,
    TeleopParams,
    TeleopStatus,
)
from core.session import DeskSession, SessionOptions
from widgets._style import TOUCH_PX
from widgets.teleop_panel import (
    KEYBOARD_SOURCE,
    TeleopPanel,
    target_box_problem,
    teleop_banner_text,
)

SMALL = (800, 480)
# gestures a test can make in a second or two: still 0.3 s per corner, the band covered 0.2 s to end;
# the stillness speed's window stays at 0.3 s so that it holds enough samples on a loaded machine
FAST = TeleopParams(still_hold_s=0.3, speed_window_s=0.3, cover_still_s=0.0, end_cover_s=0.2)
CORNER_A = (-0.06, 0.17, 0.14)
CORNER_B = (0.07, 0.25, 0.21)


class ScriptedHand:
    """A hand the test moves: ``move(p)`` puts it at p (robot_base, m), ``cover()`` hides it."""

    name = "scripted"

    def __init__(self):
        self._lock = threading.Lock()
        self._p, self._seen = np.asarray(CORNER_A, float), True

    def move(self, p):
        with self._lock:
            self._p, self._seen = np.asarray(p, float), True

    def cover(self):
        with self._lock:
            self._seen = False

    def reset(self):
        pass

    def hand(self, result, t):
        with self._lock:
            p, seen = tuple(float(v) for v in self._p), self._seen
        return HandObservation(float(t), seen, p if seen else None, (0.0, 0.0, 0.0) if seen else None,
                               measured_p=p if seen else None)


def make_window(qtbot, scenario="static"):
    session = DeskSession.create(SessionOptions(camera="sim", scenario=scenario, robot="desk_rrr"))
    w = MainWindow(session)
    qtbot.addWidget(w)
    w.resize(*SMALL)
    w.show()
    qtbot.waitExposed(w)
    return w


@pytest.fixture
def window(qtbot):
    w = make_window(qtbot)
    w.start()
    yield w
    w.stop()
    for worker in (w.workers.perception, w.workers.control, w.workers.bridge):
        assert worker.isFinished() or not worker.isRunning()


def banner(w) -> str:
    return w.target_status.text()


def choose_source(w, spec):
    combo = w.teleop_panel.source_combo
    index = combo.findData(spec)
    assert index >= 0, spec
    combo.setCurrentIndex(index)
    combo.activated.emit(index)


def test_the_teleop_scenario_starts_in_teleop_mode_following_the_wristband(qtbot):
    w = make_window(qtbot, scenario="teleop")
    try:
        s = w.session
        assert s.targeter.mode is TargetMode.TELEOP and w.target_panel.mode == "teleop"
        assert w.target_panel.mode_buttons["teleop"].isChecked()
        assert w.teleop_panel.source == "marker:23" and s.targeter.teleop.source.name == "marker:23"
        assert w.teleop_panel.accepted_box == s.targeter.teleop.target_box  # the box in use is shown
        w.start()
        qtbot.waitUntil(lambda: banner(w).startswith("teleop: calibrating"), timeout=10000)
    finally:
        w.stop()


def test_teleop_mode_and_a_source_calibrate_follow_end_and_restart(qtbot, window):
    w, s = window, window.session
    qtbot.mouseClick(w.target_panel.mode_buttons["teleop"], QtCore.Qt.MouseButton.LeftButton)
    assert s.targeter.mode is TargetMode.TELEOP
    assert isinstance(s.targeter.teleop, TeleopController)  # the panel's source (a wristband marker)
    hand = ScriptedHand()
    w.teleop_source_factory = lambda spec: hand
    w.teleop_params = FAST
    choose_source(w, "marker:50")
    assert s.targeter.teleop.source is hand and s.targeter.mode is TargetMode.TELEOP
    qtbot.waitUntil(lambda: banner(w) == "teleop: calibrating — hold still at the opposite corner (2/2)", timeout=10000)
    assert "1/2" not in w.teleop_panel.state_label.text() and "2/2" in w.teleop_panel.state_label.text()
    hand.move(CORNER_B)
    qtbot.waitUntil(lambda: banner(w) == "teleop: following", timeout=10000)
    status = s.targeter.teleop_status()
    assert status.state == FOLLOWING and status.hand_box.contains(CORNER_A, 2e-3) and status.hand_box.contains(CORNER_B, 2e-3)
    # the arm follows into the target box; the twin shows both boxes, the hand and the mapped point
    hand.move((0.0, 0.21, 0.17))
    box = s.targeter.teleop.target_box
    qtbot.waitUntil(lambda: w._goal is not None and w._goal.valid and w._goal.mode is TargetMode.TELEOP
                    and np.allclose(w._goal.base_p_target, box.centre, atol=0.01), timeout=10000)
    qtbot.waitUntil(lambda: set(w.twin.teleop_drawn("top")) == {"hand_box", "target_box", "hand", "mapped"},
                    timeout=3000)
    top = w.twin.teleop_drawn("top")
    assert np.allclose(top["target_box"].min(axis=0), np.asarray(box.lo[:2]) * 100)
    assert np.allclose(top["hand_box"].max(axis=0), np.asarray(CORNER_B[:2]) * 100, atol=0.2)
    assert np.allclose(top["hand"][0], np.array([0.0, 21.0]), atol=0.1)
    assert set(w.twin.teleop_drawn("side")) == {"hand_box", "target_box", "hand", "mapped"}
    assert "teleop box" in w.twin.legend_text()
    # the end gesture: the hand still (a still run begun after the calibration), then covered
    gestures = s.targeter.teleop.gestures
    qtbot.waitUntil(lambda: bool(gestures._still) and gestures._still_run_t0 > gestures._calibrated_t, timeout=10000)
    hand.cover()
    qtbot.waitUntil(lambda: banner(w) == "teleop: ended — Restart to calibrate again", timeout=10000)
    assert s.targeter.teleop_status().state == ENDED and not w._goal.valid
    qtbot.mouseClick(w.teleop_panel.restart_button, QtCore.Qt.MouseButton.LeftButton)
    assert s.targeter.teleop_status().state == CALIBRATING
    hand.move(CORNER_A)
    qtbot.waitUntil(lambda: "teleop: calibrating" in banner(w), timeout=10000)
    # other modes clear the twin's teleop items
    w.target_panel.set_mode(TargetMode.MANUAL.value)
    w.on_mode_changed(TargetMode.MANUAL.value)
    qtbot.waitUntil(lambda: w.twin.teleop_drawn("top") == {}, timeout=3000)


def test_the_target_box_refuses_what_the_arm_does_not_reach(qtbot, window):
    w, s = window, window.session
    w.target_panel.set_mode(TargetMode.TELEOP.value)
    w.on_mode_changed(TargetMode.TELEOP.value)
    controller = s.targeter.teleop
    before = controller.target_box
    x_max = w.teleop_panel.box_spins["x"][1]
    x_max.setValue(60.0)  # 60 cm: far beyond the desk arm's reach
    message = w.teleop_panel.box_message
    assert message.isVisibleTo(w.teleop_panel) and "out of reach" in message.text()
    assert controller.target_box == before and x_max.value() == pytest.approx(before.hi[0] * 100)
    z_min = w.teleop_panel.box_spins["z"][0]
    z_min.setValue(before.hi[2] * 100 + 1.0)  # above z max
    assert "min must be below max along z" in message.text() and controller.target_box == before
    # a smaller box inside is taken, and the controller maps into it
    x_max.setValue(before.hi[0] * 100 - 2.0)
    assert not message.isVisibleTo(w.teleop_panel)
    assert controller.target_box.hi[0] == pytest.approx(before.hi[0] - 0.02)
    # a preset
    presets = w.teleop_panel.preset_combo
    assert presets.count() >= 2
    presets.setCurrentIndex(1)
    presets.activated.emit(1)
    assert controller.target_box == w.teleop_panel.accepted_box
    assert controller.target_box.extent[0] == pytest.approx(before.extent[0] / 2)


def test_the_keyboard_source_moves_the_teleop_target_with_the_jog_keys(qtbot, window):
    w, s = window, window.session
    choose_source(w, KEYBOARD_SOURCE)
    assert s.targeter.mode is TargetMode.TELEOP and isinstance(s.targeter.teleop, JogTeleopSource)
    qtbot.waitUntil(lambda: w._goal is not None and w._goal.mode is TargetMode.TELEOP and w._goal.valid, timeout=10000)
    start = tuple(s.targeter.teleop.jogger.base_p_target)
    w.setFocus()
    qtbot.keyPress(w, QtCore.Qt.Key.Key_Right)
    qtbot.keyRelease(w, QtCore.Qt.Key.Key_Right)
    assert s.targeter.mode is TargetMode.TELEOP  # the keys drive teleop, not Manual
    moved = tuple(s.targeter.teleop.jogger.base_p_target)
    assert moved[0] == pytest.approx(start[0] + 0.005, abs=1e-3) and moved[1] == pytest.approx(start[1], abs=1e-6)
    qtbot.waitUntil(lambda: w._goal.valid and np.allclose(w._goal.base_p_target, moved, atol=1e-6), timeout=3000)
    qtbot.waitUntil(lambda: banner(w).startswith("teleop: keyboard"), timeout=3000)


def test_a_bad_pose_model_is_a_message_and_the_source_stays(qtbot, window, tmp_path):
    w, s = window, window.session
    w.target_panel.set_mode(TargetMode.TELEOP.value)
    w.on_mode_changed(TargetMode.TELEOP.value)
    before = s.targeter.teleop
    bad = tmp_path / "pose.onnx"
    bad.write_bytes(b"not a model")
    w.teleop_panel.set_pose_model(str(bad))
    assert s.targeter.teleop is before and "teleop source pose:" in w._note
    assert w.teleop_panel.source == before.source.name


def test_the_teleop_page_fits_800x480_with_finger_sized_controls(qtbot, window):
    w = window
    w.target_panel.set_mode(TargetMode.TELEOP.value)
    w.on_mode_changed(TargetMode.TELEOP.value)
    w.tabs.setCurrentIndex(0)
    QtWidgets.QApplication.processEvents()
    hint = w.minimumSizeHint()
    assert hint.width() <= SMALL[0] and hint.height() <= SMALL[1], hint
    assert w.tabs.widget(0).horizontalScrollBar().maximum() == 0
    page = w.teleop_panel
    assert page.isVisibleTo(w)
    for control in [page.source_combo, page.restart_button, page.preset_combo,
                    *[spin for pair in page.box_spins.values() for spin in pair],
                    *w.target_panel.mode_buttons.values()]:
        assert control.height() >= TOUCH_PX, control.objectName() or control.text()
        assert control.width() >= TOUCH_PX
    # the mode buttons wrap into even rows and all show their text
    for button in w.target_panel.mode_buttons.values():
        assert button.width() >= button.minimumSizeHint().width()


def status(state, source="marker:23", message="", corner_a=None):
    return TeleopStatus(state=state, source=source, message=message, hand_seen=True, base_p_hand=None,
                        base_p_mapped=None, corner_a=corner_a, hand_box=None,
                        target_box=Box((0, 0, 0), (1, 1, 1)), events=(), state_s={})


def test_the_banner_lines_for_each_teleop_state():
    assert teleop_banner_text(status(CALIBRATING)) == ("teleop: calibrating — hold still at a corner (1/2)", True)
    assert teleop_banner_text(status(CALIBRATING, corner_a=(0, 0, 0)))[0].endswith("(2/2)")
    thin = "teleop: calibrating — hand volume 1.0 × 5.0 × 5.0 cm is too thin along x — hold still …"
    assert teleop_banner_text(status(CALIBRATING, message=thin)) == (thin, False)
    assert teleop_banner_text(status(FOLLOWING)) == ("teleop: following", True)
    assert teleop_banner_text(status(FOLLOWING, KEYBOARD_SOURCE, "teleop: keyboard — moving x+"))[0] == \
        "teleop: keyboard — moving x+"
    assert teleop_banner_text(status(HOLDING, message="teleop: hand lost — holding")) == \
        ("teleop: hand lost — holding", False)
    assert teleop_banner_text(status(ENDED)) == ("teleop: ended — Restart to calibrate again", False)


def test_target_box_problem_names_thin_low_and_unreachable_boxes():
    session = DeskSession.create(SessionOptions(camera="sim", scenario="static", robot="desk_rrr"))
    kin = session.kinematics
    assert target_box_problem(kin, Box((-0.05, 0.08, 0.04), (0.05, 0.15, 0.10)), 0.02) == ""
    assert "too thin along y" in target_box_problem(kin, Box((-0.05, 0.10, 0.04), (0.05, 0.105, 0.10)))
    assert "below the desk margin" in target_box_problem(kin, Box((-0.05, 0.08, 0.0), (0.05, 0.15, 0.10)), 0.02)
    assert "out of reach" in target_box_problem(kin, Box((-0.05, 0.08, 0.04), (0.60, 0.15, 0.10)))


def test_the_panel_keeps_the_chosen_source_and_refusal_goes_back(qtbot):
    panel = TeleopPanel()
    qtbot.addWidget(panel)
    panel.set_sources([23, 50], ["green"])
    assert panel.source is None
    panel.set_source("marker:50")
    panel.set_sources([23], ["green"])  # 50 no longer offered: still chosen
    assert panel.source == "marker:50"
    box = Box((-0.05, 0.08, 0.04), (0.05, 0.15, 0.10))
    panel.show_target_box(box)
    with qtbot.waitSignal(panel.sigTargetBoxChanged) as blocker:
        panel.box_spins["y"][1].setValue(20.0)
    assert blocker.args[1][1] == pytest.approx(0.20)
    panel.refuse_target_box("no")
    assert panel.box_spins["y"][1].value() == pytest.approx(15.0) and panel.box_message.text() == "no"


def test_a_joint_jog_s_commands_carry_the_joint_goal_the_controller_used(qtbot, window):
    """sigCommand's goal is the one the control step used: a joint jog turns the MANUAL goal into
    a joint goal (``Goal.joint_target``), and the window (and a recording) sees that."""
    w, s = window, window.session
    w.target_panel.set_mode(TargetMode.MANUAL.value)
    w.on_mode_changed(TargetMode.MANUAL.value)
    qtbot.waitUntil(lambda: w._goal is not None and w._goal.mode is TargetMode.MANUAL, timeout=10000)
    w.setFocus()
    for key in (QtCore.Qt.Key.Key_J, QtCore.Qt.Key.Key_Left):
        qtbot.keyPress(w, key)
        qtbot.keyRelease(w, key)
    jog = s.controller.joint_jog
    assert jog is not None
    qtbot.waitUntil(lambda: w._goal.joint_target is not None, timeout=3000)
    assert w._goal.joint_target == pytest.approx(jog) and w._goal.mode is TargetMode.MANUAL
