"""The seed protocol v1, byte for byte, and the v1 bridge over pyserial's loop://."""
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from core.clock import SimClock
from core.devices import open_bridge
from core.devices.bridge import BridgeError, parse_bridge_url
from core.devices.protocol_v1 import encode_v1, v1_pulse_us
from core.devices.serial_v1 import SerialV1Bridge
from core.devices.sim_arm import SimServoArm
from core.kinematics.profile import load_profile
from core.messages import JointCommand


@pytest.fixture(scope="module")
def profile():
    return load_profile("desk_rrr")


def test_home_pose_encodes_as_the_seed_bytes():
    assert encode_v1([0, 90, 90]) == bytes.fromhex("FB00FC5AFD5A")


def test_seed_pulse_mapping():
    assert [v1_pulse_us(a) for a in (0, 90, 180)] == [900, 1800, 2700]


@pytest.mark.parametrize("bad", [[-1, 0, 0], [0, 181, 0], [0, 0, 90.5], [0, 0, 0, 0], []])
def test_encoder_refuses_what_the_firmware_would_misread(bad):
    with pytest.raises(ValueError):
        encode_v1(bad)


def test_home_q_through_the_loop_bridge_gives_the_seed_bytes(profile):
    bridge = SerialV1Bridge("loop://", profile, clock=SimClock())
    with bridge:
        sent = bridge.send(JointCommand(1, 0.0, (0.0, math.pi / 2, -math.pi / 2)))
        assert sent == (0, 90, 90)
        assert bridge.read_available() == bytes.fromhex("FB00FC5AFD5A")
        state = bridge.joint_state()
        assert state.measured is False  # v1 has no feedback: the twin shows commanded angles


@given(st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=3, max_size=3))
def test_no_byte_sequence_from_random_q_leaves_the_limits(q):
    profile = load_profile("desk_rrr")
    bridge = SerialV1Bridge("loop://", profile, clock=SimClock())
    with bridge:
        sent = bridge.send(JointCommand(1, 0.0, tuple(q)))
        data = bridge.read_available()
    assert data[0::2] == bytes((0xFB, 0xFC, 0xFD))
    for angle, joint in zip(data[1::2], profile.joints):
        assert 0 <= angle <= 180
        assert joint.servo_min_deg - 0.5 <= angle <= joint.servo_max_deg + 0.5
    assert tuple(data[1::2]) == sent


def test_sim_arm_moves_at_servo_speed_in_whole_degrees(profile):
    clock = SimClock()
    arm = SimServoArm(profile, clock=clock)
    arm.connect()
    start = arm.position_deg[1]
    arm.send(JointCommand(1, 0.0, profile.from_servo_deg((0, start + 60, 90))))
    clock.advance(0.085)  # half the MG996R's 0.17 s per 60°
    mid = arm.position_deg if arm.joint_state() else None
    assert 20 <= mid[1] - start <= 40
    assert all(float(v).is_integer() for v in mid)
    clock.advance(0.2)
    arm.joint_state()
    assert arm.position_deg[1] == start + 60
    assert arm.is_settled()


def test_unknown_bridge_url_names_the_valid_ones():
    with pytest.raises(ValueError, match="sim://"):
        parse_bridge_url("bluetooth:arm")


def test_missing_serial_port_says_what_to_do(profile):
    bridge = open_bridge("/dev/ttyDOESNOTEXIST0", profile)
    with pytest.raises(BridgeError, match="plugged in|no such|could not open"):
        bridge.connect()
