"""The RANGE message (an HC-SR04 reading from the v2 board): the shared vectors, the pure
codec, and end to end — the firmware's host build simulating a sensor, SerialV2Bridge reading
it over a real pseudo-terminal. Every wait is a read or a condition with a timeout."""
from __future__ import annotations

import json
import queue
import subprocess
import threading
import time
from pathlib import Path

import pytest
import serial
from hypothesis import given
from hypothesis import strategies as st

from core.devices import protocol_v2 as p
from core.devices.serial_v2 import SerialV2Bridge
from core.kinematics.profile import load_profile

VECTORS = json.loads((Path(__file__).resolve().parents[2] / "firmware" / "vectors.json").read_text())
TIMEOUT_S = 3.0


# ---- codec ------------------------------------------------------------------------------


@pytest.mark.parametrize("vec", VECTORS["v2_range_frames"], ids=[v["name"] for v in VECTORS["v2_range_frames"]])
def test_range_frame_vector_encodes_and_decodes(vec):
    wire = bytes.fromhex(vec["wire_hex"])
    f = vec["fields"]
    expected = p.RangeFrame(seq=vec["seq"], distance_mm=f["distance_mm"], tick=f["tick"])
    assert p.decode_frame(wire) == expected
    assert p.encode(expected) == wire
    assert p.encode_frame(p.MsgType.RANGE, vec["seq"], bytes.fromhex(vec["payload_hex"])) == wire
    body = bytes((p.RANGE_LEN, p.MsgType.RANGE, vec["seq"])) + bytes.fromhex(vec["payload_hex"])
    assert p.crc16_ccitt(body) == int(vec["crc_hex"], 16)
    assert not set(wire) & set(p.V1_SELECTORS)


def test_range_distance_is_in_metres_and_none_without_a_valid_reading():
    assert p.RangeFrame(0, 350, 0).distance_m == pytest.approx(0.35)
    assert p.RangeFrame(0, p.RANGE_NO_READING, 0).distance_m is None
    assert p.RangeFrame(0, 4000, 0).distance_m == pytest.approx(4.0)
    # outside the sensor's 20-4000 mm: a conforming board never sends it, a reader never trusts it
    assert p.RangeFrame(0, 19, 0).distance_m is None
    assert p.RangeFrame(0, 4001, 0).distance_m is None
    assert p.decode_frame(p.encode_range(3, None, 7)).distance_mm == p.RANGE_NO_READING


def test_range_with_a_wrong_length_is_a_bad_frame():
    for payload in (b"\x01\x5e\x04", b"\x01\x5e\x04\xd2\x00"):
        dec = p.V2Decoder()
        assert dec.feed(p.encode_frame(p.MsgType.RANGE, 0, payload)) == []
        assert dec.bad_frames == 1


@given(st.integers(0, 255), st.integers(0, 0xFFFF), st.integers(0, 0xFFFF))
def test_every_range_frame_round_trips(seq, distance_mm, tick):
    frame = p.RangeFrame(seq, distance_mm, tick)
    assert p.decode_frame(p.encode(frame)) == frame


# ---- end to end over a pseudo-terminal -------------------------------------------------


class SensorBoard:
    """host_firmware with a simulated HC-SR04 (``--range MM``); ``set_range`` moves the target."""

    def __init__(self, exe: Path, *args: str) -> None:
        self.proc = subprocess.Popen([str(exe), *args], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)
        self.lines: "queue.Queue[str]" = queue.Queue()
        threading.Thread(target=self._drain, daemon=True).start()
        first = self.lines.get(timeout=TIMEOUT_S)
        assert first.startswith("PORT "), f"expected 'PORT <path>' first, got {first!r}"
        self.path = first.split(" ", 1)[1]

    def _drain(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:  # PWM lines: read so the pipe never fills
            self.lines.put(line.rstrip("\n"))

    def set_range(self, text: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(f"RANGE {text}\n")
        self.proc.stdin.flush()

    def stop(self) -> int:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        for pipe in (self.proc.stdin, self.proc.stdout, self.proc.stderr):
            if pipe is not None:
                pipe.close()
        return self.proc.returncode


@pytest.fixture(scope="module")
def profile():
    return load_profile("desk_rrr")


@pytest.fixture
def sensor_board(host_firmware):
    b = SensorBoard(host_firmware, "--range", "350")
    try:
        yield b
    finally:
        assert b.stop() == 0


def test_bridge_reads_the_simulated_sensor_and_follows_the_target(sensor_board, profile):
    bridge = SerialV2Bridge("v2:" + sensor_board.path, profile)
    bridge.connect()
    try:
        first = bridge.wait_for_range(TIMEOUT_S)
        assert first is not None, "no RANGE within 3 s from a board with a sensor"
        assert first.distance_m == pytest.approx(0.350, abs=0.0005)
        assert bridge.range_m() == pytest.approx(0.350, abs=0.0005)
        nxt = bridge.wait_for_range(TIMEOUT_S)
        assert nxt is not None and nxt.seq == (first.seq + 1) % 256  # nothing lost on a quiet line
        # at 10 Hz on the board's 50 Hz tick: 5 ticks apart
        assert (nxt.board_tick - first.board_tick) % 65536 == 5

        sensor_board.set_range("1234")
        moved = bridge.wait_for_range(TIMEOUT_S, lambda r: r.distance_m is not None and r.distance_m > 1.0)
        assert moved is not None and moved.distance_m == pytest.approx(1.234, abs=0.0005)

        sensor_board.set_range("none")
        gone = bridge.wait_for_range(TIMEOUT_S, lambda r: r.distance_m is None)
        assert gone is not None
        assert bridge.range_m() is None
        assert "range: no echo" in bridge.status().message

        sensor_board.set_range("10")  # nearer than the HC-SR04's 20 mm: no valid reading either
        sensor_board.set_range("4500")  # and farther than its 4 m
        sensor_board.set_range("20")
        near = bridge.wait_for_range(TIMEOUT_S, lambda r: r.distance_m is not None)
        assert near is not None and near.distance_m == pytest.approx(0.020)

        c = bridge.counters()
        assert c.range_frames >= 4
        assert c.host_bad_frames == 0  # RANGE frames are understood, not counted as bad
    finally:
        bridge.disconnect()


def test_a_board_without_a_sensor_sends_no_range_and_the_bridge_says_none(board, profile):
    bridge = SerialV2Bridge("v2:" + board.path, profile)
    bridge.connect()
    try:
        # a few heartbeats' worth of STATUS: ~0.3 s, in which a sensor would have sent 3 RANGEs
        for _ in range(3):
            assert bridge.wait_for_status(TIMEOUT_S) is not None
        assert bridge.range_reading() is None
        assert bridge.range_m() is None
        assert bridge.counters().range_frames == 0
    finally:
        bridge.disconnect()


def test_a_board_in_v1_mode_keeps_the_line_quiet_even_with_a_sensor(sensor_board):
    port = serial.Serial(sensor_board.path, 9600, timeout=0.05)
    try:
        port.write(bytes.fromhex("FB 00 FC 5A FD 5A"))  # v1: the board stays in v1 mode
        deadline = time.monotonic() + TIMEOUT_S
        while sensor_board.lines.get(timeout=TIMEOUT_S) != "PWM 900 1800 1800":
            assert time.monotonic() < deadline
        heard = b""
        end = time.monotonic() + 0.4  # four RANGE periods: a v1 board must send none of them
        while time.monotonic() < end:
            heard += port.read(64)
        assert heard == b""
        port.write(p.encode_ping(1))  # the first v2 frame switches RANGE on
        dec = p.V2Decoder()
        deadline = time.monotonic() + TIMEOUT_S
        ranges = []
        while not ranges and time.monotonic() < deadline:
            ranges = [f for f in dec.feed(port.read(64)) if isinstance(f, p.RangeFrame)]
        assert ranges and ranges[0].distance_mm == 350
    finally:
        port.close()
