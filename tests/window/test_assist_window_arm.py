"""The assistive view driving an arm (issue 12, the real path): the loop's joints go through the
safety chain to a protocol-v2 board — the firmware's logic compiled for the host
(firmware/host_firmware) on a pseudo-terminal, real serial I/O — or to the simulated servo arm.
The arm first moves from where it is to the ready pose, the press of box 7 is sent to the board,
STOP switches the board's pulses off, a board that goes away is a visible stop (no crash), and
``deskarm --assist`` refuses a real arm on the simulated panel. Waits on signals, never sleeps;
the worker is stopped and joined."""
from __future__ import annotations

import math

import numpy as np
import pytest

from app.assist_window import AssistSettings, AssistWindow, guarded_arm_factory, ready_pose_problem
from core.devices import open_bridge
from core.kinematics import build_kinematics, load_profile
from core.motion.safety import is_within_limits, workspace_violation

from test_assist_window import TIMEOUT_MS, click_image_point, sim_loop, wait_for_press  # noqa: E402

PROFILE = load_profile("assistive_5dof")
KIN = build_kinematics(PROFILE)
N = len(PROFILE.joints)


def recording(bridge):
    """``bridge`` with every command it is sent kept in ``bridge.sent`` (from the worker's thread)."""
    bridge.sent = []
    send = bridge.send

    def keep(command):
        if not bridge.is_estopped:
            bridge.sent.append(command)
        return send(command)

    bridge.send = keep
    return bridge


@pytest.fixture
def arm_window(qtbot):
    windows = []

    def make(bridge, worker_clock="sim"):
        w = AssistWindow(sim_loop, worker_clock=worker_clock, arm_factory=guarded_arm_factory(bridge))
        w.set_settings(AssistSettings(mode="touch"))
        qtbot.addWidget(w)
        w.resize(800, 480)
        w.show()
        texts = []
        w.sigStateText.connect(texts.append)
        w.start()
        windows.append(w)
        return w, texts

    yield make
    for w in windows:
        w.stop()
        assert w.worker.isFinished() and not w.worker.isRunning()


def all_safe(commands) -> bool:
    return all(is_within_limits(c.q, PROFILE) and workspace_violation(c.q, PROFILE, KIN) == "" for c in commands)


def test_a_v2_board_goes_to_the_ready_pose_presses_7_and_stop_turns_its_pulses_off(arm_window, qtbot, host_firmware):
    from host_board import Board

    board = Board(host_firmware, "--joints", str(N))
    try:
        bridge = recording(open_bridge(f"v2:{board.path}", PROFILE))
        w, texts = arm_window(bridge)
        qtbot.waitUntil(lambda: w.choosing, timeout=TIMEOUT_MS)  # offered only once the arm is at the ready pose
        assert "connected" in w.worker.arm_text and w.arm_label.isVisible()
        ready = w.worker.ready_q
        assert bridge.sent and np.allclose(bridge.sent[-1].q, ready, atol=1e-9)
        # the board itself gets there: its measured joints (STATUS) reach the ready pose's servo degrees
        qtbot.waitUntil(lambda: bridge.joint_state() is not None and bridge.joint_state().measured and
                        np.max(np.abs(np.subtract(bridge.joint_state().q, ready))) < math.radians(1.0),
                        timeout=TIMEOUT_MS)
        before = len(bridge.sent)
        x, y, bw, bh = w.hit_boxes[6]
        click_image_point(qtbot, w, (x + bw / 2, y + bh / 2))
        wait_for_press(qtbot, w, texts, 7)
        assert len(bridge.sent) > before + 30  # the whole approach and press went to the board
        assert all_safe(bridge.sent)
        w.emergency_stop()
        board.wait_pwm(*([0] * N))  # ESTOP reached the board: every pulse off
        qtbot.waitUntil(lambda: "E-STOP" in w.worker.arm_text, timeout=TIMEOUT_MS)
    finally:
        board.stop()


def test_a_board_that_goes_away_mid_approach_is_a_visible_stop(arm_window, qtbot, host_firmware):
    from host_board import Board

    board = Board(host_firmware, "--joints", str(N))
    stopped = False
    try:
        bridge = recording(open_bridge(f"v2:{board.path}", PROFILE))
        w, texts = arm_window(bridge, worker_clock="wall")  # real time: the approach lasts seconds
        qtbot.waitUntil(lambda: w.choosing, timeout=TIMEOUT_MS)
        x, y, bw, bh = w.hit_boxes[4]
        click_image_point(qtbot, w, (x + bw / 2, y + bh / 2))
        qtbot.waitUntil(lambda: "approaching 5" in texts or "aligning with 5" in texts, timeout=TIMEOUT_MS)
        board.stop()  # unplugged
        stopped = True
        qtbot.waitUntil(lambda: w.state_text == "stopped: arm not connected", timeout=TIMEOUT_MS)
        assert w.engaged and w.rearm_button.isVisible()
        assert w.arm_label.text() == "arm: not connected" and "NOT CONNECTED" in w.arm_label.toolTip()
        assert "plug it back in" in w.hint_label.text()
        assert not w.worker.loop.busy  # the loop no longer servos a camera whose arm does not move
        assert all_safe(bridge.sent)
        assert not any(t.startswith("done") for t in texts)  # it was stopped mid-approach
    finally:
        if not stopped:
            board.stop()


def test_a_board_that_goes_away_while_the_user_chooses_is_a_visible_stop(arm_window, qtbot, host_firmware):
    from host_board import Board

    board = Board(host_firmware, "--joints", str(N))
    w, texts = arm_window(open_bridge(f"v2:{board.path}", PROFILE))
    qtbot.waitUntil(lambda: w.choosing, timeout=TIMEOUT_MS)
    board.stop()
    qtbot.waitUntil(lambda: w.state_text == "stopped: arm not connected", timeout=TIMEOUT_MS)
    assert not w.choosing and w.arm_label.text() == "arm: not connected"


def test_re_arm_after_the_board_is_plugged_back_in_goes_to_the_ready_pose_and_offers_again(
        arm_window, qtbot, host_firmware, tmp_path):
    from host_board import Board

    link = tmp_path / "usb-deskarm-arm"  # a stable name (like /dev/serial/by-id/…) over changing ttys
    first = Board(host_firmware, "--joints", str(N))
    link.symlink_to(first.path)
    second = None
    try:
        w, texts = arm_window(open_bridge(f"v2:{link}", PROFILE))
        qtbot.waitUntil(lambda: w.choosing, timeout=TIMEOUT_MS)
        first.stop()
        qtbot.waitUntil(lambda: w.state_text == "stopped: arm not connected", timeout=TIMEOUT_MS)
        w.rearm()  # RE-ARM while still unplugged: refused by the board, still stopped
        qtbot.waitUntil(lambda: "NOT CONNECTED" in w.worker.arm_text and not w.choosing, timeout=TIMEOUT_MS)
        second = Board(host_firmware, "--joints", str(N))
        link.unlink()
        link.symlink_to(second.path)
        qtbot.waitUntil(lambda: w.choosing and len(w.boxes) >= 9, timeout=TIMEOUT_MS)
        assert "connected" in w.worker.arm_text and "NOT" not in w.worker.arm_text
    finally:
        first.stop()
        if second is not None:
            second.stop()


def test_the_simulated_servo_arm_presses_through_the_chain(arm_window, qtbot):
    bridge = recording(open_bridge("sim://", PROFILE))
    w, texts = arm_window(bridge)
    qtbot.waitUntil(lambda: w.choosing, timeout=TIMEOUT_MS)
    x, y, bw, bh = w.hit_boxes[2]
    click_image_point(qtbot, w, (x + bw / 2, y + bh / 2))
    wait_for_press(qtbot, w, texts, 3)
    assert all_safe(bridge.sent) and len(bridge.sent) > 30


def test_a_ready_pose_from_the_settings_is_checked_against_the_limits():
    assert ready_pose_problem((13.0, 82.0, -124.0, -78.0, 0.0), PROFILE) == ""
    assert "give 5 finite joint angles" in ready_pose_problem((13.0, 82.0), PROFILE)
    assert "give 5 finite joint angles" in ready_pose_problem((13.0, 82.0, float("nan"), 0.0, 0.0), PROFILE)
    problem = ready_pose_problem((13.0, 82.0, -170.0, -78.0, 0.0), PROFILE)
    assert "elbow -170°" in problem and "assist.toml" in problem


def test_deskarm_assist_refuses_a_real_arm_on_the_simulated_panel(capsys):
    from app.cli import main

    assert main(["--assist", "--bridge", "/dev/ttyUSB7"]) == 2
    err = capsys.readouterr().err
    assert "refused" in err and "--hand-camera webcam:N" in err and "--hand-camera sim" in err
