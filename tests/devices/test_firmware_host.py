"""The firmware's host build (firmware/host_firmware) driven over a pseudo-terminal.

host_firmware runs the same C core as the MSP430 on a pty, prints ``PORT <path>`` and then
``PWM <us> ...`` whenever a pulse changes, and answers v2 PINGs over the pty. These tests talk
to it exactly as the app talks to a board: with pyserial. Every wait is a read with a timeout.
"""
from __future__ import annotations

import signal
import subprocess
from pathlib import Path

import pytest
from host_board import Board  # tests/ is on sys.path (pytest rootdir conftest)

from core.devices import protocol_v2 as p

ROOT = Path(__file__).resolve().parents[2]
FIRMWARE = ROOT / "firmware"


def test_v1_home_command_gives_pwm_900_1800_1800(board):
    port = board.open()
    port.write(bytes.fromhex("FB 00 FC 5A FD 5A"))
    board.wait_pwm(900, 1800, 1800)


def test_v2_set_joints_ramps_at_the_rate_limit_and_ends_at_the_target(board):
    port = board.open()
    port.write(p.encode_set_joints(board.next_seq(), [90, 90, 90]))
    assert board.wait_pwm(1800, 1800, 1800) == [(1800, 1800, 1800)]  # the first command jumps
    port.write(p.encode_set_joints(board.next_seq(), [120, 90, 60]))
    seen = board.wait_pwm(2100, 1800, 1500)
    # default 180 deg/s at 50 Hz: 3.6 deg = 36 us per tick, up for joint 1, down for joint 3
    expected = [(min(1800 + 36 * k, 2100), 1800, max(1800 - 36 * k, 1500)) for k in range(1, 10)]
    assert seen == expected
    assert board.status(port).flags == p.Flag.V2_MODE  # arrived: no longer MOVING


def test_v2_ping_gets_a_status_reply(board):
    port = board.open()
    port.write(bytes.fromhex("FB 00 FC 5A FD 5A"))
    board.wait_pwm(900, 1800, 1800)
    reply = board.status(port)
    assert reply.pulses_us == (900, 1800, 1800)
    assert reply.flags == p.Flag.V2_MODE  # the PING itself locked the board into v2
    assert (reply.good_frames, reply.bad_frames) == (1, 0)


def test_joints_option_sets_the_number_of_pulses(host_firmware):
    b = Board(host_firmware, "--joints", "5")
    try:
        port = b.open()
        port.write(p.encode_set_joints(b.next_seq(), [0, 45, 90, 135, 180]))
        b.wait_pwm(900, 1350, 1800, 2250, 2700)
        assert b.status(port).pulses_us == (900, 1350, 1800, 2250, 2700)
    finally:
        b.stop()


def test_watchdog_holds_and_flags_after_500_ms_of_silence(board):
    port = board.open()
    port.write(p.encode_config(board.next_seq(), p.CONFIG_ALL_JOINTS, 900, 2700, 20))
    port.write(p.encode_set_joints(board.next_seq(), [0, 0, 0]))
    board.wait_pwm(900, 900, 900)
    port.write(p.encode_set_joints(board.next_seq(), [180, None, None]))  # 9 s away at 20 deg/s
    ramp = board.pwm_until_silent()
    assert ramp, "the ramp should have started"
    held = ramp[-1]
    assert 900 < held[0] < 2700, f"held mid-ramp, got {held}"
    assert all(b[0] - a[0] == 4 for a, b in zip(ramp, ramp[1:]))  # 0.4 deg per tick
    reply = board.status(port)
    assert p.Flag.WATCHDOG in reply.flags
    assert p.Flag.MOVING not in reply.flags
    assert reply.pulses_us == held
    # a new SET_JOINTS clears the flag and moves again
    port.write(p.encode_set_joints(board.next_seq(), [180, None, None]))
    nxt = board.wait_pwm(held[0] + 4, 900, 900)
    assert nxt == [(held[0] + 4, 900, 900)]
    assert p.Flag.WATCHDOG not in board.status(port).flags


def test_estop_turns_pulses_off_until_arm(board):
    port = board.open()
    port.write(p.encode_set_joints(board.next_seq(), [90, 45, 0]))
    board.wait_pwm(1800, 1350, 900)
    port.write(p.encode_estop(board.next_seq()))
    board.wait_pwm(0, 0, 0)
    port.write(p.encode_set_joints(board.next_seq(), [10, 10, 10]))
    reply = board.status(port)  # answered after the SET_JOINTS was handled
    assert reply.pulses_us == (0, 0, 0)
    assert p.Flag.ESTOP in reply.flags
    port.write(p.encode_arm(board.next_seq()))
    assert board.wait_pwm(1800, 1350, 900) == [(1800, 1350, 900)]
    assert p.Flag.ESTOP not in board.status(port).flags


def test_closing_the_port_mid_run_and_reopening_keeps_working(board):
    port = board.open()
    port.write(bytes.fromhex("FB 5A"))
    board.wait_pwm(1800, 0, 0)
    port.write(p.encode_set_joints(board.next_seq(), [90, 45, 0])[:7])  # half a frame...
    port.close()  # ...and gone
    port = board.open()
    reply = board.status(port)
    assert reply.pulses_us == (1800, 0, 0)
    assert reply.bad_frames == 1  # the half frame, cut short by the PING's sync bytes
    port.close()
    port = board.open()
    port.write(p.encode_set_joints(board.next_seq(), [90, 45, 0]))
    board.wait_pwm(1800, 1350, 900)
    reply = board.status(port)
    assert reply.pulses_us == (1800, 1350, 900)
    assert (reply.good_frames, reply.bad_frames) == (3, 1)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_host_firmware_exits_cleanly_on_a_signal(host_firmware, sig):
    b = Board(host_firmware)
    try:
        port = b.open()
        port.write(bytes.fromhex("FD 5A"))
        b.wait_pwm(0, 0, 1800)
    finally:
        assert b.stop(sig) == 0


def test_host_firmware_refuses_a_bad_joints_option(host_firmware):
    done = subprocess.run(
        [str(host_firmware), "--joints", "9"], capture_output=True, text=True, timeout=10
    )
    assert done.returncode == 2
    assert "expected a number from 1 to 8" in done.stderr
