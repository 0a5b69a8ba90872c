"""The Python bridges against the firmware's C core (firmware/host_firmware) over a pseudo-terminal.

host_firmware prints ``PORT <path>`` and then ``PWM <us> ...`` whenever a pulse changes; the
bridges open that path exactly as they open /dev/ttyACM0. A reader thread puts the PWM lines in
a queue; every wait is a queue read or an event with a timeout, never a fixed sleep. The board
process is always terminated.
"""
from __future__ import annotations

import os
import queue
import random
import select
import threading
import tty
from dataclasses import replace
from pathlib import Path
from typing import Iterator

import pytest
import serial
from host_board import (  # tests/ is on sys.path (pytest rootdir conftest)
    TIMEOUT_S,
    Board,
)

from core.devices import open_bridge
from core.devices import protocol_v2 as p
from core.devices.bridge import BridgeError
from core.devices.serial_v1 import SerialV1Bridge
from core.devices.serial_v2 import SerialV2Bridge
from core.kinematics.profile import load_profile
from core.messages import JointCommand

ROOT = Path(__file__).resolve().parents[2]
FIRMWARE = ROOT / "firmware"


@pytest.fixture(scope="module")
def profile():
    return load_profile("desk_rrr")


@pytest.fixture
def v2(board, profile) -> Iterator[SerialV2Bridge]:
    bridge = open_bridge(f"v2:{board.path}", profile)
    bridge.connect()
    try:
        yield bridge
    finally:
        bridge.disconnect()


def cmd(profile, *servo_deg: float, seq: int = 1) -> JointCommand:
    return JointCommand(seq, 0.0, profile.from_servo_deg(servo_deg))


def ramp(start, target, step_us):
    """The PWM lines of a rate-limited move, tick by tick, ending at the target."""
    out, cur = [], list(start)
    while cur != list(target):
        cur = [min(c + step_us, t) if t > c else max(c - step_us, t) for c, t in zip(cur, target)]
        out.append(tuple(cur))
    return out


# ------------------------------------------------------------------ v1: the seed protocol


def test_v1_bridge_home_command_gives_pwm_900_1800_1800_and_estop_stops_sending(board, profile):
    bridge = open_bridge(board.path, profile)  # a plain port is protocol v1, as always
    assert isinstance(bridge, SerialV1Bridge)
    with bridge:
        assert bridge.send(JointCommand(1, 0.0, profile.q_home)) == (0, 90, 90)  # FB 00 FC 5A FD 5A
        assert board.wait_pwm(900, 1800, 1800) == [(900, 1800, 1800)]
        assert bridge.joint_state().measured is False  # no feedback: the twin shows commands
        bridge.estop()
        assert bridge.send(cmd(profile, 90, 90, 90)) == ()
        assert board.pwm_until_silent(0.2) == []  # nothing was written, nothing moved
        bridge.rearm()
        bridge.send(cmd(profile, 90, 90, 90))
        assert board.wait_pwm(1800, 1800, 1800) == [(1800, 1800, 1800)]


# ------------------------------------------------------------------ v2


def test_v2_connect_then_set_joints_ramp_at_the_profile_speed_and_status_is_measured(board, v2, profile):
    assert v2.is_connected and v2.has_feedback
    assert v2.send(JointCommand(1, 0.0, profile.q_home)) == (0.0, 90.0, 90.0)
    assert board.wait_pwm(900, 1800, 1800) == [(900, 1800, 1800)]  # the first command jumps
    target = (30.0, 60.0, 120.0)
    assert v2.send(cmd(profile, *target, seq=2)) == target
    # desk_rrr: 300 deg/s -> CONFIG 300 -> 6 deg = 60 us per 20 ms tick
    assert board.wait_pwm(1200, 1500, 2100) == ramp((900, 1800, 1800), (1200, 1500, 2100), 60)
    reply = v2.wait_for_status(TIMEOUT_S, lambda s: p.Flag.MOVING not in s.flags)
    assert reply.pulses_us == (1200, 1500, 2100) and reply.flags == p.Flag.V2_MODE
    state = v2.joint_state()
    assert state.measured is True
    assert state.q == pytest.approx(profile.from_servo_deg(target), abs=1e-3)
    c = v2.counters()
    assert (c.board_bad_frames, c.host_bad_frames, c.commands_written) == (0, 0, 2)


def test_closing_the_port_under_the_bridge_then_reconnecting_works(board, v2, profile):
    v2.send(JointCommand(1, 0.0, profile.q_home))
    board.wait_pwm(900, 1800, 1800)
    v2._port.close()  # the port vanishes under the I/O thread
    assert v2.wait_disconnected(TIMEOUT_S)
    status = v2.status()
    assert not status.connected and "the device went away (unplugged?)" in status.message
    with pytest.raises(BridgeError, match="not connected"):
        v2.send(cmd(profile, 10, 90, 90))
    v2.connect()  # what the bridge worker does, after its backoff
    assert v2.is_connected
    v2.send(cmd(profile, 6, 90, 90, seq=2))
    assert board.wait_pwm(960, 1800, 1800) == [(960, 1800, 1800)]
    assert v2.wait_for_status(TIMEOUT_S, seq=v2.ping()).pulses_us == (960, 1800, 1800)


def test_unplug_and_replug_behind_a_stable_by_id_link(host_firmware, profile, tmp_path):
    link = tmp_path / "usb-Texas_Instruments_MSP_Tools_Driver_1234-if02"
    first = Board(host_firmware)
    second = None
    try:
        os.symlink(first.path, link)
        bridge = open_bridge(f"v2:{link}", profile)
        bridge.connect()
        bridge.send(JointCommand(1, 0.0, profile.q_home))
        first.wait_pwm(900, 1800, 1800)
        first.stop()  # unplugged: the line hangs up
        assert bridge.wait_disconnected(TIMEOUT_S)
        assert "the device went away (unplugged?)" in bridge.status().message
        link.unlink()  # udev removes the link with the device
        with pytest.raises(BridgeError, match="no such port — is the board plugged in"):
            bridge.connect()
        second = Board(host_firmware)  # plugged in again: a new tty, the same stable name
        os.symlink(second.path, link)
        bridge.connect()
        bridge.send(JointCommand(2, 0.0, profile.q_home))
        assert second.wait_pwm(900, 1800, 1800) == [(900, 1800, 1800)]
        bridge.disconnect()
    finally:
        first.stop()
        if second is not None:
            second.stop()


def test_watchdog_holds_after_500_ms_without_heartbeat(board, profile):
    slow = replace(profile, joints=tuple(replace(j, max_speed_deg_s=20.0) for j in profile.joints))
    bridge = SerialV2Bridge(f"v2:{board.path}", slow)  # 20 deg/s: 0.4 deg = 4 us per tick
    with bridge:
        bridge.send(cmd(slow, 0, 90, 90))
        board.wait_pwm(900, 1800, 1800)
        bridge.send(cmd(slow, 180, 90, 90, seq=2))  # 9 s away
        moving = [board.next_pwm() for _ in range(35)]  # 0.7 s: the heartbeat feeds the watchdog
        # 4 us per tick; a loaded machine may coalesce ticks into one printed line
        steps = [b[0] - a[0] for a, b in zip([(900,)] + moving, moving)]
        assert all(st > 0 and st % 4 == 0 for st in steps), steps
        assert moving[-1][0] >= 904 + 4 * 34
        bridge.heartbeat_hz = 0  # silence from now on
        tail = board.pwm_until_silent()
        # 25 ticks (500 ms) after the last PING, which left at most 0.1 s before the switch,
        # it holds mid-ramp (bounds allow for lines queued before the switch and a busy machine)
        assert 10 <= len(tail) <= 60
        held = tail[-1]
        assert moving[-1][0] < held[0] < 2700 and (held[0] - 900) % 4 == 0
        reply = bridge.wait_for_status(TIMEOUT_S, seq=bridge.ping())
        assert p.Flag.WATCHDOG in reply.flags and p.Flag.MOVING not in reply.flags
        assert reply.pulses_us == held  # pulses stay on: the servos hold
        assert "watchdog tripped" in bridge.status().message
        bridge.heartbeat_hz = 10  # the host is back; the flag stays until a new command
        assert p.Flag.WATCHDOG in bridge.wait_for_status(TIMEOUT_S).flags
        bridge.send(cmd(slow, 180, 90, 90, seq=3))
        assert board.next_pwm() == (held[0] + 4, 1800, 1800)
        assert bridge.wait_for_status(TIMEOUT_S, lambda s: p.Flag.WATCHDOG not in s.flags) is not None


def test_estop_turns_the_pulses_off_until_rearmed(board, v2, profile):
    v2.send(cmd(profile, 90, 45, 0))
    board.wait_pwm(1800, 1350, 900)
    q_before = v2.wait_for_status(TIMEOUT_S, seq=v2.ping()) and v2.joint_state().q
    v2.estop()
    assert board.wait_pwm(0, 0, 0) == [(0, 0, 0)]
    assert v2.send(cmd(profile, 10, 10, 10, seq=2)) == ()  # refused by the bridge
    v2.write_raw(p.encode_set_joints(200, [10, 10, 10]))  # and ignored by the board
    reply = v2.wait_for_status(TIMEOUT_S, seq=v2.ping())
    assert p.Flag.ESTOP in reply.flags and reply.pulses_us == (0, 0, 0)
    assert v2.pulses_off and v2.joint_state().q == pytest.approx(q_before)  # last angles kept
    assert v2.status().message.startswith("E-STOP: pulses off on the board; re-arm to resume")
    v2.rearm()
    assert board.wait_pwm(1800, 1350, 900) == [(1800, 1350, 900)]  # resumes where it stopped
    v2.send(cmd(profile, 96, 45, 0, seq=3))
    assert board.wait_pwm(1860, 1350, 900) == [(1860, 1350, 900)]
    assert p.Flag.ESTOP not in v2.wait_for_status(TIMEOUT_S, seq=v2.ping()).flags


def test_garbage_to_the_board_is_counted_and_shown_and_the_link_survives(board, v2, profile):
    rng = random.Random(5)
    junk = bytes(rng.randrange(256) for _ in range(400))
    broken_ping = p.encode_ping(9)[:-3] + b"\x00\x00\xf7"  # wrong CRC
    v2.write_raw(junk + broken_ping)
    reply = v2.wait_for_status(TIMEOUT_S, seq=v2.ping())
    c = v2.counters()
    assert c.board_bad_frames >= 1 and c.board_dropped_bytes > 0
    assert reply.bad_frames >= 1
    assert f"bad frames: {c.board_bad_frames} at the board, 0 here" in v2.status().message
    v2.send(JointCommand(1, 0.0, profile.q_home))
    assert board.wait_pwm(900, 1800, 1800)[-1] == (900, 1800, 1800)


class Relay:
    """A second pty pair between the bridge and the board that can damage the replies."""

    def __init__(self, board_path: str) -> None:
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)
        self.board = serial.Serial(board_path, 9600, timeout=0)
        self.corrupt_next = threading.Event()
        self.corrupted = threading.Event()
        self.inject: "queue.Queue[bytes]" = queue.Queue()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            ready, _, _ = select.select([self.master, self.board.fd], [], [], 0.02)
            if self.master in ready:
                self.board.write(os.read(self.master, 4096))
            if self.board.fd in ready:
                data = bytearray(self.board.read(4096))
                if self.corrupt_next.is_set() and len(data) >= 12:
                    data[len(data) // 2] ^= 0x01  # one flipped bit in the middle of a STATUS
                    self.corrupt_next.clear()
                    self.corrupted.set()
                os.write(self.master, bytes(data))
            while not self.inject.empty():
                os.write(self.master, self.inject.get())

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=TIMEOUT_S)
        self.board.close()
        os.close(self.master)
        os.close(self.slave)


def test_garbage_on_the_way_back_is_counted_and_shown_and_the_link_survives(board, profile):
    relay = Relay(board.path)
    bridge = open_bridge(f"v2:{relay.path}", profile)
    try:
        bridge.connect()
        relay.corrupt_next.set()
        assert relay.corrupted.wait(TIMEOUT_S)  # the next heartbeat's STATUS is damaged...
        relay.inject.put(b"\x00\x13\xf5\xf5\x07\x81\xf7\x42")  # ...and junk follows
        reply = bridge.wait_for_status(TIMEOUT_S, seq=bridge.ping())  # later replies still arrive
        assert reply is not None and reply.bad_frames == 0  # the board saw nothing wrong
        c = bridge.counters()
        assert c.host_bad_frames == 2 and c.host_dropped_bytes == 3  # 00 13 .. 42; F5 F5 07 81 F7 is bad
        assert "bad frames: 0 at the board, 2 here" in bridge.status().message
        bridge.send(JointCommand(1, 0.0, profile.q_home))
        assert board.wait_pwm(900, 1800, 1800) == [(900, 1800, 1800)]
    finally:
        bridge.disconnect()
        relay.close()


def test_a_second_bridge_on_the_same_port_is_told_the_port_is_busy(board, v2, profile):
    other = open_bridge(f"v2:{board.path}", profile)
    with pytest.raises(BridgeError, match="port busy — close the other program using it"):
        other.connect()
    assert v2.wait_for_status(TIMEOUT_S, seq=v2.ping()) is not None  # the first one is unharmed


def test_bench_rows_have_samples_and_a_missing_compiler_gives_a_row_not_a_crash(host_firmware, monkeypatch):
    from bench import bench_serial

    rows = bench_serial.rows(quick=True)
    assert [r["name"].split(" ")[1] for r in rows] == ["v2", "v2", "bytes", "bytes", "v2"]
    assert all(r["samples"] for r in rows)
    assert set(rows[2]["samples"]) == {6}  # v1: FB a1 FC a2 FD a3
    assert "all accepted by the board, 0 bad frames" in rows[4]["extra"]
    monkeypatch.setattr(bench_serial, "_build", lambda: (None, "make and gcc are needed"))
    (row,) = bench_serial.rows(quick=True)
    assert row["samples"] and "SKIPPED — make and gcc are needed" in row["extra"]


def test_a_second_v1_instance_on_the_same_port_is_refused_and_the_first_keeps_driving(board, profile):
    """v1 ports were opened without the lock v2 uses: two deskarms could drive one arm."""
    first = open_bridge(board.path, profile)
    second = open_bridge(board.path, profile)
    with first:
        with pytest.raises(BridgeError, match="port busy — close the other program using it"):
            second.connect()
        assert first.send(JointCommand(1, 0.0, profile.q_home)) == (0, 90, 90)
        assert board.wait_pwm(900, 1800, 1800) == [(900, 1800, 1800)]
