"""PhidgetServoBridge against a fake ``Phidget22`` (injected into sys.modules): a small
simulation of a Phidget servo board's RCServo channels that records every call, can refuse to
attach and can be unplugged and plugged back in mid-run. The real package is never needed."""
from __future__ import annotations

import math
import sys
import types
from dataclasses import replace

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.devices import open_bridge, parse_bridge_url, split_bridge_url
from core.devices.bridge import BridgeError
from core.devices.phidget import PhidgetServoBridge, parse_phidget_url
from core.devices.serial_v2 import to_servo_cdeg
from core.kinematics.profile import load_profile
from core.messages import JointCommand

EPHIDGET_TIMEOUT, EPHIDGET_INVALIDARG, EPHIDGET_NOTATTACHED = 3, 21, 52


class FakePhidgetException(Exception):
    def __init__(self, code: int, description: str = "") -> None:
        super().__init__(description)
        self.code = code
        self.description = description
        self.details = ""


class FakeBoard:
    """The board on the (fake) USB bus: its serial number, whether it is plugged in, its channels."""

    def __init__(self, serial_number: int = 123456, n_channels: int = 8) -> None:
        self.serial_number = serial_number
        self.n_channels = n_channels
        self.plugged = True
        self.opened: list = []  # every channel object ever opened

    def open_channels(self) -> list:
        return [ch for ch in self.opened if ch.is_open]

    def channel(self, number: int) -> object:
        (ch,) = [c for c in self.open_channels() if c.channel == number]
        return ch

    def unplug(self) -> None:
        self.plugged = False
        for ch in self.open_channels():
            if ch.attached:
                ch.attached = False
                ch.engaged = False
                if ch.on_detach:
                    ch.on_detach(ch)

    def replug(self) -> None:
        """Plugged back in: the library re-attaches open channels, with the board's defaults."""
        self.plugged = True
        for ch in self.open_channels():
            ch.reset_to_defaults()
            ch.attached = True
            if ch.on_attach:
                ch.on_attach(ch)


def make_fake_library(board: FakeBoard, construct_error: Exception | None = None):
    """The modules of a fake Phidget22 package speaking to ``board``."""

    class FakeRCServo:
        def __init__(self) -> None:
            if construct_error is not None:
                raise construct_error
            self.calls: list[tuple] = []
            self.serial_number = -1
            self.channel = 0
            self.on_attach = None
            self.on_detach = None
            self.is_open = False
            self.attached = False
            self.reset_to_defaults()

        def reset_to_defaults(self) -> None:
            self.min_pulse, self.max_pulse = 544.0, 2400.0  # what a fresh channel starts with
            self.min_position, self.max_position = 0.0, 180.0
            self.velocity_limit = 1900.0
            self.engaged = False
            self.target = None

        def _record(self, *call) -> None:
            self.calls.append(call)

        def _need_attached(self) -> None:
            if not self.attached:
                raise FakePhidgetException(EPHIDGET_NOTATTACHED, "Device not Attached")

        def setDeviceSerialNumber(self, n):
            self._record("setDeviceSerialNumber", n)
            self.serial_number = n

        def setChannel(self, c):
            self._record("setChannel", c)
            self.channel = c

        def setOnAttachHandler(self, h):
            self.on_attach = h

        def setOnDetachHandler(self, h):
            self.on_detach = h

        def openWaitForAttachment(self, timeout_ms):
            self._record("openWaitForAttachment", timeout_ms)
            self.is_open = True
            board.opened.append(self)
            matches = self.serial_number in (-1, board.serial_number) and self.channel < board.n_channels
            if not (board.plugged and matches):
                raise FakePhidgetException(EPHIDGET_TIMEOUT, "Timed Out")
            self.attached = True
            if self.on_attach:
                self.on_attach(self)

        def close(self):
            self._record("close")
            self.is_open = False
            self.attached = False
            self.engaged = False

        def getMaxPulseWidth(self):
            return self.max_pulse

        def setMinPulseWidth(self, v):
            self._need_attached()
            if not v < self.max_pulse:
                raise FakePhidgetException(EPHIDGET_INVALIDARG, "min pulse width must be below max")
            self._record("setMinPulseWidth", v)
            self.min_pulse = v

        def setMaxPulseWidth(self, v):
            self._need_attached()
            if not v > self.min_pulse:
                raise FakePhidgetException(EPHIDGET_INVALIDARG, "max pulse width must be above min")
            self._record("setMaxPulseWidth", v)
            self.max_pulse = v

        def setMinPosition(self, v):
            self._need_attached()
            self._record("setMinPosition", v)
            self.min_position = v

        def setMaxPosition(self, v):
            self._need_attached()
            self._record("setMaxPosition", v)
            self.max_position = v

        def setVelocityLimit(self, v):
            self._need_attached()
            self._record("setVelocityLimit", v)
            self.velocity_limit = v

        def setTargetPosition(self, v):
            self._need_attached()
            if not self.min_position <= v <= self.max_position:
                raise FakePhidgetException(EPHIDGET_INVALIDARG, f"target {v} out of range")
            self._record("setTargetPosition", v)
            self.target = v

        def setEngaged(self, on):
            self._need_attached()
            self._record("setEngaged", bool(on))
            self.engaged = bool(on)

        def getPosition(self):
            self._need_attached()
            if self.target is None:
                raise FakePhidgetException(51, "Unknown or Invalid Value")
            return self.target

        def pulse_us(self) -> float:
            """The pulse this channel produces now (0 = off), as the board maps it."""
            if not (self.attached and self.engaged and self.target is not None):
                return 0.0
            span = self.max_position - self.min_position
            return self.min_pulse + (self.max_pulse - self.min_pulse) * (self.target - self.min_position) / span

    root = types.ModuleType("Phidget22")
    devices = types.ModuleType("Phidget22.Devices")
    rcservo = types.ModuleType("Phidget22.Devices.RCServo")
    rcservo.RCServo = FakeRCServo
    exc = types.ModuleType("Phidget22.PhidgetException")
    exc.PhidgetException = FakePhidgetException
    return {"Phidget22": root, "Phidget22.Devices": devices, "Phidget22.Devices.RCServo": rcservo,
            "Phidget22.PhidgetException": exc}, FakeRCServo




@pytest.fixture
def board(monkeypatch):
    b = FakeBoard()
    modules, _ = make_fake_library(b)
    for name, module in modules.items():
        monkeypatch.setitem(sys.modules, name, module)
    return b


@pytest.fixture(scope="module")
def profile():
    return load_profile("desk_rrr")


@pytest.fixture(scope="module")
def narrow_profile(profile):
    """desk_rrr with servo ranges narrower than 0–180°, so any overshoot would show."""
    j0, j1, j2 = profile.joints
    joints = (replace(j0, servo_min_deg=10.0, servo_max_deg=170.5, home_servo_deg=10.0),
              replace(j1, servo_min_deg=20.25, servo_max_deg=160.0),
              replace(j2, servo_min_deg=45.0, servo_max_deg=180.0, home_servo_deg=90.0))
    return replace(profile, joints=joints)


def command(q, seq=1) -> JointCommand:
    return JointCommand(seq=seq, t=0.0, q=tuple(q))


def targets(board: FakeBoard, channels) -> tuple:
    return tuple(board.channel(c).target for c in channels)


# ---- URLs --------------------------------------------------------------------------------


def test_phidget_urls_parse_and_choose_the_phidget_bridge_without_importing_the_library(profile, monkeypatch):
    monkeypatch.delitem(sys.modules, "Phidget22", raising=False)
    assert parse_phidget_url("phidget://").serial_number is None
    spec = parse_phidget_url("phidget://123456?channels=4,5,6")
    assert (spec.serial_number, spec.channels) == (123456, (4, 5, 6))
    assert split_bridge_url("phidget://123456") == ("phidget", "phidget://123456")
    assert parse_bridge_url("phidget://") == "phidget"
    bridge = open_bridge("phidget://?channels=2,0,1", profile)
    assert isinstance(bridge, PhidgetServoBridge) and bridge.channels == (2, 0, 1)
    assert "Phidget22" not in sys.modules  # imported only by connect()


@pytest.mark.parametrize("url, words", [
    ("phidget://abc", "serial number 'abc'"),
    ("phidget://?channels=0,x,2", "channel numbers separated by commas"),
    ("phidget://?channels=0,0,1", "used twice"),
    ("phidget://?channels=0,1,16", "channel 16 is outside 0…15"),
    ("phidget://?speed=3", "unknown option 'speed'"),
])
def test_bad_phidget_urls_say_what_is_wrong(url, words):
    with pytest.raises(ValueError, match=words):
        split_bridge_url(url)


def test_a_channel_per_joint_and_servo_joints_are_required(profile):
    with pytest.raises(BridgeError, match="2 channels for the 3 joints"):
        PhidgetServoBridge("phidget://?channels=0,1", profile)
    with pytest.raises(BridgeError, match="without a servo mapping"):
        PhidgetServoBridge("phidget://", load_profile("umi_rtx"))


# ---- library missing ---------------------------------------------------------------------


def test_a_missing_library_gives_the_install_command(profile, monkeypatch):
    monkeypatch.setitem(sys.modules, "Phidget22", None)  # import Phidget22 raises ImportError
    bridge = PhidgetServoBridge("phidget://", profile)
    with pytest.raises(BridgeError, match=r"Phidget22 is not installed: pip install 'deskarm\[phidget\]'"):
        bridge.connect()
    assert not bridge.is_connected


def test_a_missing_native_library_names_libusb(profile, monkeypatch):
    modules, _ = make_fake_library(FakeBoard(), construct_error=OSError("libusb-1.0.so.0: cannot open shared object file"))
    for name, module in modules.items():
        monkeypatch.setitem(sys.modules, name, module)
    with pytest.raises(BridgeError, match="libusb-1.0.*apt install libusb-1.0-0"):
        PhidgetServoBridge("phidget://", profile).connect()


# ---- connect and commands ----------------------------------------------------------------


def test_connect_configures_each_channel_and_leaves_the_servos_off(board, profile):
    bridge = PhidgetServoBridge("phidget://123456?channels=4,5,6", profile)
    bridge.connect()
    assert bridge.is_connected
    for j, c in enumerate((4, 5, 6)):
        ch = board.channel(c)
        assert ch.serial_number == 123456
        assert (ch.min_pulse, ch.max_pulse) == (900.0, 2700.0)  # the v2 firmware's mapping
        assert (ch.min_position, ch.max_position) == (0.0, 180.0)
        assert ch.velocity_limit == pytest.approx(min(1000.0, profile.joints[j].max_speed_deg_s), abs=0.5)
        assert not ch.engaged and ch.target is None  # nothing moves before a command
    assert bridge.joint_state() is None
    bridge.disconnect()
    assert not board.open_channels()


def test_commands_reach_the_right_channels_in_servo_degrees(board, profile):
    bridge = PhidgetServoBridge("phidget://?channels=4,5,6", profile)
    bridge.connect()
    q = (0.3, 1.0, -0.8)
    sent = bridge.send(command(q))
    expected = tuple(c / 100.0 for c in to_servo_cdeg(q, profile))
    assert sent == expected
    assert targets(board, (4, 5, 6)) == expected
    for j, c in enumerate((4, 5, 6)):
        ch = board.channel(c)
        assert ch.engaged
        # the target went out before the pulses were switched on
        names = [call[0] for call in ch.calls]
        assert names.index("setTargetPosition") < names.index("setEngaged")
        assert ch.pulse_us() == pytest.approx(900 + 10 * expected[j])  # 900 + 10·deg µs, as v1/v2
        assert math.isclose(profile.joints[j].to_servo_deg(q[j]), expected[j], abs_tol=0.005)
    state = bridge.joint_state()
    assert not state.measured
    assert state.q == pytest.approx(q, abs=math.radians(0.01))
    # channels not named in the URL are never touched
    assert {ch.channel for ch in board.opened} == {4, 5, 6}


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=3, max_size=3))
def test_no_command_ever_leaves_a_joint_servo_range(board, narrow_profile, q):
    bridge = PhidgetServoBridge("phidget://", narrow_profile)
    bridge.connect()
    try:
        sent = bridge.send(command(q))
        for j, joint in enumerate(narrow_profile.joints):
            target = board.channel(j).target
            assert target == sent[j]
            assert max(0.0, joint.servo_min_deg) <= target <= min(180.0, joint.servo_max_deg)
    finally:
        bridge.disconnect()


# ---- e-stop ----------------------------------------------------------------------------------


def test_estop_disengages_every_channel_is_idempotent_and_rearm_waits_for_a_command(board, profile):
    bridge = PhidgetServoBridge("phidget://", profile)
    bridge.connect()
    bridge.send(command((0.1, 1.0, -0.5)))
    assert all(board.channel(c).engaged for c in range(3))
    bridge.estop()
    assert bridge.is_estopped
    assert not any(board.channel(c).engaged for c in range(3))
    assert bridge.engaged() == (False, False, False)
    before = [len(board.channel(c).calls) for c in range(3)]
    bridge.estop()  # again: still off, nothing breaks
    assert not any(board.channel(c).engaged for c in range(3))
    assert bridge.send(command((0.5, 1.2, -0.2))) == ()  # nothing written while stopped
    assert all(not any(call[0] == "setTargetPosition" for call in board.channel(c).calls[before[c]:])
               for c in range(3))
    assert "E-STOP" in bridge.status().message
    bridge.rearm()
    assert not any(board.channel(c).engaged for c in range(3))  # nothing moves until asked
    bridge.send(command((0.5, 1.2, -0.2)))
    assert all(board.channel(c).engaged for c in range(3))


def test_estop_while_unplugged_or_disconnected_never_raises(board, profile):
    bridge = PhidgetServoBridge("phidget://", profile)
    bridge.estop()  # not even connected
    bridge.connect()
    board.unplug()
    bridge.estop()
    assert bridge.is_estopped


# ---- unplug and replug -------------------------------------------------------------------


def test_unplugging_is_visible_and_the_library_reattaching_brings_it_back(board, profile):
    bridge = PhidgetServoBridge("phidget://", profile)
    bridge.connect()
    bridge.send(command((0.1, 1.0, -0.5)))
    board.unplug()
    assert not bridge.is_connected
    assert "detached (unplugged?)" in bridge.status().message
    with pytest.raises(BridgeError, match="detached .unplugged.. — plug it back in"):
        bridge.send(command((0.2, 1.0, -0.5)))
    assert bridge.detaches == 1
    board.replug()  # the board forgot its configuration: the bridge sets it again
    assert bridge.is_connected
    for c in range(3):
        ch = board.channel(c)
        assert (ch.min_pulse, ch.max_pulse) == (900.0, 2700.0)
        assert not ch.engaged  # off until the next command
    bridge.send(command((0.2, 1.0, -0.5)))
    assert all(board.channel(c).engaged for c in range(3))


def test_connect_after_an_unplug_reopens_once_the_board_is_back(board, profile):
    bridge = PhidgetServoBridge("phidget://", profile, attach_timeout_s=0.1)
    bridge.connect()
    board.unplug()
    board.plugged = False
    with pytest.raises(BridgeError, match="no Phidget servo board attached .* check the USB cable"):
        bridge.connect()  # what the reconnector does while it is still unplugged
    assert not bridge.is_connected
    assert not board.open_channels()  # a failed connect leaves nothing open
    board.plugged = True
    bridge.connect()
    assert bridge.is_connected
    bridge.send(command((0.0, 1.0, -0.5)))
    assert all(board.channel(c).engaged for c in range(3))


def test_a_board_that_never_attaches_says_check_the_cable(board, profile):
    board.plugged = False
    bridge = PhidgetServoBridge("phidget://", profile, attach_timeout_s=0.1)
    with pytest.raises(BridgeError, match="no Phidget servo board attached"):
        bridge.connect()
    other = PhidgetServoBridge("phidget://999", profile, attach_timeout_s=0.1)
    board.plugged = True
    with pytest.raises(BridgeError, match=r"serial 999.*check the USB cable"):
        other.connect()  # a board with another serial number is not ours
    with pytest.raises(BridgeError, match="not connected"):
        other.send(command((0.0, 1.0, -0.5)))
