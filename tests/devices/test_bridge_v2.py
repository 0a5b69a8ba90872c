"""SerialV2Bridge against an in-process fake board, e-stop on every bridge, and the URL scheme.

The fake board is a serial-like object (the bridge's ``serial_factory``) that decodes what the
bridge writes with the shared V2Decoder and answers PINGs with STATUS. No pty, no firmware:
the end-to-end tests with the real C core are in test_bridge_e2e.py.
"""
from __future__ import annotations

import math
import os
import threading
import time
import tty
from dataclasses import replace

import pytest
import serial
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.clock import SimClock
from core.devices import open_bridge
from core.devices import protocol_v2 as p
from core.devices.bridge import (
    BRIDGE_CHOICES,
    BridgeError,
    explain_serial_error,
    parse_bridge_url,
    split_bridge_url,
)
from core.devices.serial_v1 import SerialV1Bridge
from core.devices.serial_v2 import (
    JointPulseConfig,
    SerialV2Bridge,
    describe_flags,
    pulse_configs,
    to_servo_cdeg,
)
from core.devices.sim_arm import SimServoArm
from core.kinematics.profile import load_profile
from core.messages import JointCommand

TIMEOUT_S = 3.0


@pytest.fixture(scope="module")
def profile():
    return load_profile("desk_rrr")


@pytest.fixture(scope="module")
def narrow_profile(profile):
    """desk_rrr with servo ranges narrower than 0–180 and an offset, so clamping shows."""
    j0, j1, j2 = profile.joints
    joints = (replace(j0, servo_min_deg=10.0, servo_max_deg=170.5, home_servo_deg=10.0),
              replace(j1, servo_min_deg=20.25, servo_max_deg=160.0, max_speed_deg_s=2000.0),
              replace(j2, servo_min_deg=45.0, servo_max_deg=180.0, home_servo_deg=90.0))
    return replace(profile, joints=joints)


class FakeV2Board:
    """A v2 board behind a serial-like interface: decodes writes, answers PINGs with STATUS."""

    def __init__(self, n_joints: int = 3, reply: bool = True, **_kwargs):
        self.n_joints = n_joints
        self.reply = reply
        self.is_open = True
        self.decoder = p.V2Decoder()
        self.frames: list = []  # every frame the bridge wrote, decoded
        self.cond = threading.Condition()
        self._rx = bytearray()  # board -> host bytes waiting
        self.timeout = 0.005
        self.fail_reads = False
        self.reset()

    def reset(self) -> None:
        """Power-cycle: defaults, counters at zero (the host's CONFIG is forgotten)."""
        self.cfg = [(900, 2700, 180)] * self.n_joints
        self.cdeg = [None] * self.n_joints
        self.estopped = False
        self.flags = 0
        self.counter_base = (self.decoder.good_frames, self.decoder.bad_frames, self.decoder.dropped_bytes)

    # --- the serial interface the bridge uses
    def write(self, data: bytes) -> int:
        if not self.is_open:
            raise serial.PortNotOpenError()
        with self.cond:
            for f in self.decoder.feed(data):
                self.frames.append(f)
                self._handle(f)
            self.cond.notify_all()
        return len(data)

    def read(self, size: int = 1) -> bytes:
        with self.cond:
            if self.fail_reads or not self.is_open:
                raise serial.SerialException("read failed: [Errno 5] Input/output error")
            if not self._rx:
                self.cond.wait(self.timeout)
            out = bytes(self._rx[:size])
            del self._rx[:size]
            return out

    @property
    def in_waiting(self) -> int:
        return len(self._rx)

    def reset_input_buffer(self) -> None:
        with self.cond:
            self._rx.clear()

    def close(self) -> None:
        self.is_open = False

    # --- the board
    def _pulses(self) -> tuple[int, ...]:
        out = []
        for (lo, hi, _), c in zip(self.cfg, self.cdeg):
            out.append(0 if c is None or self.estopped else lo + round((hi - lo) * c / 18000))
        return tuple(out)

    def _handle(self, f) -> None:
        self.flags |= p.Flag.V2_MODE
        if isinstance(f, p.ConfigFrame):
            if f.joint >= self.n_joints:  # as the firmware: no such joint, nothing changes
                self.flags |= p.Flag.CONFIG_REJECTED
            else:
                self.cfg[f.joint] = (f.min_pulse_us, f.max_pulse_us, f.max_speed_dps)
        elif isinstance(f, p.SetJointsFrame) and not self.estopped:
            for j, a in enumerate(f.angles_cdeg[: self.n_joints]):
                if a is not None:
                    self.cdeg[j] = min(a, 18000)
            self.flags &= ~p.Flag.WATCHDOG
        elif isinstance(f, p.EstopFrame):
            self.estopped = True
        elif isinstance(f, p.ArmFrame):
            self.estopped = False
        elif isinstance(f, p.PingFrame) and self.reply:
            flags = self.flags | (p.Flag.ESTOP if self.estopped else 0)
            b = self.counter_base
            self._rx += p.encode_status(
                f.seq, int(flags), self._pulses(), (self.decoder.good_frames - b[0]) & 0xFFFF,
                (self.decoder.bad_frames - b[1]) & 0xFFFF, (self.decoder.dropped_bytes - b[2]) & 0xFFFF)

    def wait_frame(self, kind, since: int = 0, timeout: float = TIMEOUT_S):
        """The first frame of ``kind`` written at index ≥ ``since``."""
        deadline = time.monotonic() + timeout
        with self.cond:
            while True:
                for f in self.frames[since:]:
                    if isinstance(f, kind):
                        return f
                left = deadline - time.monotonic()
                if left <= 0:
                    raise AssertionError(f"no {kind.__name__} written within {timeout} s")
                self.cond.wait(left)

    def of(self, kind) -> list:
        with self.cond:
            return [f for f in self.frames if isinstance(f, kind)]


def make_bridge(profile, board: FakeV2Board, **kwargs) -> SerialV2Bridge:
    def factory(url, **serial_kwargs):
        assert serial_kwargs["baudrate"] == 9600 and serial_kwargs["exclusive"] is True
        board.is_open = True
        return board

    return SerialV2Bridge("v2:fake", profile, clock=SimClock(), serial_factory=factory, **kwargs)


@pytest.fixture
def board():
    return FakeV2Board()


@pytest.fixture
def bridge(profile, board):
    b = make_bridge(profile, board)
    b.connect()
    try:
        yield b
    finally:
        b.disconnect()


# ------------------------------------------------------------------ pure helpers


def test_flags_are_described_in_words_and_v2_mode_is_not_news():
    assert describe_flags(p.Flag.V2_MODE) == []
    words = describe_flags(p.Flag.V2_MODE | p.Flag.WATCHDOG | p.Flag.ESTOP)
    assert words == ["e-stop (pulses off until re-armed)", "watchdog tripped (no frame for 0.5 s: holding)"]


def test_pulse_configs_come_from_the_profile_with_speed_capped_at_1000(narrow_profile):
    cfgs = pulse_configs(narrow_profile)
    assert [(c.min_pulse_us, c.max_pulse_us) for c in cfgs] == [(900, 2700)] * 3
    assert [c.max_speed_dps for c in cfgs] == [300, 1000, 300]


def test_a_pulse_maps_back_to_the_servo_angle_the_firmware_mapped_it_from():
    cfg = JointPulseConfig(900, 2700, 180)
    for cdeg in (0, 1, 4550, 9000, 17999, 18000):
        pulse = 900 + round(1800 * cdeg / 18000)
        assert abs(cfg.pulse_to_servo_deg(pulse) - cdeg / 100) <= 0.05 + 1e-9
    with pytest.raises(ValueError, match="max_pulse_us"):
        JointPulseConfig(900, 3100, 180)


def test_centidegrees_stay_inside_each_joints_servo_range(narrow_profile):
    prof = narrow_profile
    assert to_servo_cdeg(prof.from_servo_deg((0.0, 0.0, 0.0)), prof) == (1000, 2025, 4500)
    assert to_servo_cdeg(prof.from_servo_deg((180.0, 180.0, 180.0)), prof) == (17050, 16000, 18000)
    assert to_servo_cdeg(prof.from_servo_deg((12.344, 90.005, 100.0)), prof) == (1234, 9001, 10000)
    nan = float("nan")
    middle = to_servo_cdeg((nan, nan, nan), prof)  # the middle of each range, ± rounding
    assert [abs(a - b) <= 1 for a, b in zip(middle, (9025, 9012, 11250))] == [True] * 3


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True) | st.sampled_from([1e300, -1e300, 7.0]),
                min_size=3, max_size=3))
def test_no_set_joints_from_random_q_leaves_the_joint_limits(narrow_profile, q):
    board = FakeV2Board()
    bridge = make_bridge(narrow_profile, board, max_command_hz=0, heartbeat_hz=0)
    with bridge:
        sent = bridge.send(JointCommand(1, 0.0, tuple(q)))
        frame = board.wait_frame(p.SetJointsFrame)
    assert frame.angles_deg == sent
    for a, joint in zip(frame.angles_cdeg, narrow_profile.joints):
        assert 0 <= a <= p.ANGLE_MAX_CDEG
        assert joint.servo_min_deg * 100 <= a <= joint.servo_max_deg * 100


# ------------------------------------------------------------------ connect


def test_connect_configures_every_joint_then_pings(profile, board, bridge):
    configs = board.of(p.ConfigFrame)
    assert [(c.joint, c.min_pulse_us, c.max_pulse_us, c.max_speed_dps) for c in configs] == [
        (0, 900, 2700, 300), (1, 900, 2700, 300), (2, 900, 2700, 300)]
    assert isinstance(board.frames[3], p.PingFrame)
    assert bridge.is_connected and bridge.has_feedback
    state = bridge.joint_state()
    assert state.measured is False  # a fresh board drives nothing yet: home is shown, not measured
    assert state.q == pytest.approx(profile.q_home)


def test_a_silent_port_is_no_reply_with_a_hint_at_v1(profile):
    board = FakeV2Board(reply=False)
    bridge = make_bridge(profile, board, reply_timeout_s=0.2)
    with pytest.raises(BridgeError, match=r"fake: no reply — wrong firmware or baud rate\? .*use v1:fake"):
        bridge.connect()
    assert not bridge.is_connected and not board.is_open


def test_a_pty_with_nothing_behind_it_is_no_reply(profile):
    master, slave = os.openpty()
    tty.setraw(slave)
    try:
        bridge = open_bridge("v2:" + os.ttyname(slave), profile)
        bridge.reply_timeout_s = 0.2
        with pytest.raises(BridgeError, match="no reply — wrong firmware or baud rate"):
            bridge.connect()
        assert os.read(master, 100).startswith(b"\xf5\xf5")  # it did send frames
    finally:
        os.close(master)
        os.close(slave)


def test_a_board_with_too_few_joints_is_refused_with_the_reason(profile):
    bridge = make_bridge(profile, FakeV2Board(n_joints=2))
    with pytest.raises(BridgeError, match="drives 2 joints but profile 'desk_rrr' needs 3"):
        bridge.connect()


def test_a_board_found_e_stopped_stays_e_stopped_until_the_user_rearms(profile, board):
    board.estopped = True
    with make_bridge(profile, board) as bridge:
        assert bridge.is_estopped
        assert bridge.send(JointCommand(1, 0.0, profile.q_home)) == ()
        assert "E-STOP" in bridge.status().message
        assert not board.of(p.SetJointsFrame)


# ------------------------------------------------------------------ commands


def test_send_returns_the_clamped_servo_angles_and_the_board_gets_centidegrees(profile, board, bridge):
    sent = bridge.send(JointCommand(1, 0.0, profile.from_servo_deg((12.345, 95.5, 200.0))))
    assert sent == (12.35, 95.5, 180.0)
    assert board.wait_frame(p.SetJointsFrame).angles_cdeg == (1235, 9550, 18000)
    assert bridge.status().commands_sent == 1 and bridge.status().bytes_written == 14


def test_a_caller_faster_than_50_hz_keeps_only_its_newest_command(profile, board, bridge):
    cmds = [profile.from_servo_deg((d, 90.0, 90.0)) for d in range(10, 20)]
    for k, q in enumerate(cmds):
        assert bridge.send(JointCommand(k, 0.0, q))[0] == 10 + k  # what was queued
    first = board.wait_frame(p.SetJointsFrame)
    n = len(board.frames)
    last = board.wait_frame(p.SetJointsFrame, since=n)  # flushed by the I/O thread at its slot
    assert (first.angles_cdeg[0], last.angles_cdeg[0]) == (1000, 1900)
    assert len(board.of(p.SetJointsFrame)) == 2
    assert bridge.counters().commands_coalesced == 8


def test_measured_state_follows_the_pulses_in_status(profile, board, bridge):
    target = (30.0, 60.0, 120.0)
    bridge.send(JointCommand(1, 0.0, profile.from_servo_deg(target)))
    board.wait_frame(p.SetJointsFrame)
    reply = bridge.wait_for_status(TIMEOUT_S, seq=bridge.ping())
    assert reply.pulses_us == (1200, 1500, 2100)
    state = bridge.joint_state()
    assert state.measured is True
    assert state.q == pytest.approx(profile.from_servo_deg(target), abs=math.radians(0.06))


def test_heartbeat_pings_about_ten_times_a_second(bridge):
    for _ in range(3):  # three PINGs answered without anyone calling ping()
        assert bridge.wait_for_status(TIMEOUT_S) is not None
    assert bridge.counters().pings_sent >= 4
    assert bridge.rtt_samples_s()


def test_estop_sends_estop_drops_commands_and_rearm_sends_arm(profile, board, bridge):
    bridge.send(JointCommand(1, 0.0, profile.q_home))
    board.wait_frame(p.SetJointsFrame)
    bridge.estop()
    board.wait_frame(p.EstopFrame)
    assert bridge.is_estopped
    assert bridge.send(JointCommand(2, 0.0, profile.from_servo_deg((45.0, 45.0, 45.0)))) == ()
    reply = bridge.wait_for_status(TIMEOUT_S, seq=bridge.ping())
    assert p.Flag.ESTOP in reply.flags and reply.pulses_us == (0, 0, 0)
    assert bridge.pulses_off
    assert bridge.joint_state().q == pytest.approx(profile.q_home, abs=1e-3)  # last angle kept
    assert bridge.status().message.startswith("E-STOP: pulses off on the board")
    assert len(board.of(p.SetJointsFrame)) == 1
    n = len(board.frames)
    bridge.rearm()
    board.wait_frame(p.ArmFrame, since=n)
    assert not bridge.is_estopped
    bridge.send(JointCommand(3, 0.0, profile.from_servo_deg((45.0, 45.0, 45.0))))
    assert board.wait_frame(p.SetJointsFrame, since=n).angles_cdeg == (4500, 4500, 4500)


def test_an_estop_that_got_lost_is_sent_again(profile, board, bridge):
    bridge.estop()
    board.wait_frame(p.EstopFrame)
    board.estopped = False  # as if the frame had been corrupted on the line
    n = len(board.frames)
    bridge.ping()
    board.wait_frame(p.EstopFrame, since=n)
    assert bridge.wait_for_status(TIMEOUT_S, lambda s: p.Flag.ESTOP in s.flags) is not None


def test_a_board_restart_is_noticed_and_config_sent_again(profile, board, bridge):
    for _ in range(5):
        bridge.wait_for_status(TIMEOUT_S, seq=bridge.ping())
    n = len(board.frames)
    board.reset()
    board.wait_frame(p.ConfigFrame, since=n)
    assert bridge.counters().board_resets == 1
    assert "CONFIG sent again" in bridge.status().message


def test_status_names_bad_frames_at_both_ends(profile, board, bridge):
    bridge.write_raw(p.encode_ping(7)[:-1] + b"\x00")  # a PING whose end byte is wrong
    board._rx += b"\xf5\xf5\x03\x81\x00\xf7"  # a broken reply on the way back
    reply = bridge.wait_for_status(TIMEOUT_S, seq=bridge.ping())
    assert reply.bad_frames >= 1
    c = bridge.counters()
    assert c.board_bad_frames == 1 and c.host_bad_frames == 1
    assert "bad frames: 1 at the board, 1 here" in bridge.status().message


def test_a_read_error_marks_it_disconnected_in_plain_words_and_connect_reopens(profile, board, bridge):
    board.fail_reads = True
    assert bridge.wait_disconnected(TIMEOUT_S)
    assert not bridge.is_connected
    status = bridge.status()
    assert not status.connected and "the device went away (unplugged?)" in status.message
    with pytest.raises(BridgeError, match="not connected"):
        bridge.send(JointCommand(1, 0.0, profile.q_home))
    board.fail_reads = False
    bridge.connect()
    assert bridge.is_connected
    assert bridge.wait_for_status(TIMEOUT_S, seq=bridge.ping()) is not None


def test_disconnect_joins_the_io_thread(profile, board):
    bridge = make_bridge(profile, board)
    bridge.connect()
    thread = bridge._thread
    assert thread.is_alive() and thread.daemon and "v2" in thread.name
    bridge.disconnect()
    assert not thread.is_alive() and not board.is_open
    bridge.disconnect()  # twice is fine


# ------------------------------------------------------------------ e-stop on the other bridges


def test_v1_estop_writes_nothing_until_rearmed(profile):
    bridge = SerialV1Bridge("loop://", profile, clock=SimClock())
    with bridge:
        bridge.estop()
        assert bridge.send(JointCommand(1, 0.0, profile.q_home)) == ()
        assert bridge.read_available() == b""
        assert "protocol v1 cannot switch the servos off" in bridge.status().message
        bridge.rearm()
        assert bridge.send(JointCommand(2, 0.0, profile.q_home)) == (0, 90, 90)
        assert bridge.read_available() == bytes.fromhex("FB00FC5AFD5A")


def test_sim_arm_estop_freezes_the_servos_mid_move(profile):
    clock = SimClock()
    arm = SimServoArm(profile, clock=clock)
    arm.connect()
    start = arm.position_deg[1]
    arm.send(JointCommand(1, 0.0, profile.from_servo_deg((0, start + 60, 90))))
    clock.advance(0.06)
    arm.estop()
    frozen = list(arm.position_deg)
    assert start < frozen[1] < start + 60
    clock.advance(1.0)
    arm.joint_state()
    assert arm.position_deg == frozen and arm.is_settled()
    assert arm.send(JointCommand(2, 0.0, profile.q_home)) == ()
    assert "E-STOP" in arm.status().message
    arm.rearm()
    arm.send(JointCommand(3, 0.0, profile.from_servo_deg((0, start + 60, 90))))
    clock.advance(1.0)
    arm.joint_state()
    assert arm.position_deg[1] == start + 60


# ------------------------------------------------------------------ URLs and errors


@pytest.mark.parametrize("url, expected", [
    ("sim://", ("sim", "sim://")),
    ("/dev/ttyACM0", ("v1", "/dev/ttyACM0")),
    ("COM3", ("v1", "COM3")),
    ("loop://", ("v1", "loop://")),
    ("v1:/dev/ttyUSB0", ("v1", "/dev/ttyUSB0")),
    ("v2:/dev/ttyACM0", ("v2", "/dev/ttyACM0")),
    ("V2:/dev/pts/5", ("v2", "/dev/pts/5")),
    ("v2:/dev/serial/by-id/usb-TI_MSP430-if02", ("v2", "/dev/serial/by-id/usb-TI_MSP430-if02")),
])
def test_bridge_urls_name_the_protocol(url, expected):
    assert split_bridge_url(url) == expected


@pytest.mark.parametrize("url", ["v2:", "v3:/dev/ttyACM0", "v2:bluetooth", "auto:/dev/ttyACM0"])
def test_bad_bridge_urls_name_the_valid_forms(url):
    with pytest.raises(ValueError, match="v2:<port>"):
        parse_bridge_url(url)


def test_open_bridge_picks_the_implementation_from_the_url(profile):
    assert isinstance(open_bridge("v2:/dev/ttyACM0", profile), SerialV2Bridge)
    assert open_bridge("v2:/dev/ttyACM0", profile).url == "v2:/dev/ttyACM0"
    assert isinstance(open_bridge("v1:/dev/ttyACM0", profile), SerialV1Bridge)
    assert isinstance(open_bridge("/dev/ttyACM0", profile), SerialV1Bridge)
    assert parse_bridge_url("/dev/ttyACM0") == "serial" and parse_bridge_url("v2:COM4") == "serial-v2"


def test_choices_say_why_there_is_no_auto_detection():
    assert "v2:<port>" in BRIDGE_CHOICES and "v1:<port>" in BRIDGE_CHOICES
    assert "No auto-detection" in BRIDGE_CHOICES
    import core.devices.bridge

    assert "0x00" in core.devices.bridge.__doc__ and "could move the arm" in core.devices.bridge.__doc__


@pytest.mark.parametrize("exc, words", [
    (serial.SerialException(13, "could not open port /dev/ttyACM0: [Errno 13] Permission denied: '/dev/ttyACM0'"),
     "permission denied — add your user to the 'dialout' group"),
    (serial.SerialException(2, "could not open port /dev/ttyACM0: [Errno 2] No such file or directory"),
     "no such port — is the board plugged in?"),
    (serial.SerialException(11, "Could not exclusively lock port /dev/ttyACM0: [Errno 11] Resource temporarily unavailable"),
     "port busy"),
    (serial.SerialException(16, "could not open port /dev/ttyACM0: [Errno 16] Device or resource busy"), "port busy"),
    (serial.SerialException(25, "could not open port /dev/ttyACM0: [Errno 25] Inappropriate ioctl for device"),
     "not a serial port"),
    (serial.SerialException("read failed: [Errno 5] Input/output error"), "the device went away (unplugged?)"),
    (serial.SerialException("device reports readiness to read but returned no data (device disconnected or multiple "
                            "access on port?)"), "the device went away"),
    (serial.SerialTimeoutException("Write timeout"), "write timed out"),
])
def test_serial_errors_are_explained_in_plain_words(exc, words):
    assert words in explain_serial_error("/dev/ttyACM0", exc)
