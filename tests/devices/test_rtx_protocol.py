"""The UMI-RTX protocol as pure code: each command's bytes, reply lengths and values, chip mapping."""
from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from core.devices import rtx_protocol as p


def test_each_command_is_the_drivers_bytes():
    assert p.identify() == b"\x01"
    assert p.go_restart() == b"\x00"
    assert p.toggle_off() == b"\x28" and p.toggle_once() == b"\x29" and p.toggle_on() == b"\x2a"
    assert p.version() == b"\x38"
    assert p.stop(p.StopMode.DEAD) == b"\x24" and p.stop(p.StopMode.FREE_OFF) == b"\x27"
    assert p.define_home() == b"\x21" and p.reload_pids() == b"\x22"
    assert p.motor_status(3) == b"\x13" and p.general_status() == b"\x17"
    assert p.read_position(2) == b"\x4a" and p.read_error(2) == b"\x42"
    assert p.write_position(1, -2) == b"\x59\xfe\xff"
    assert p.select_write(p.Param.NEW_POSITION) == b"\x70\x03\x00"
    assert p.write_param(0, 440) == b"\x78\xb8\x01"
    assert p.select_read(p.Param.MAX_FORCE) == b"\x60\x0a\x00"
    assert p.read_param(4) == b"\x6c"


def test_go_bits_follow_the_drivers_layout():
    # numeric GO: one bit per controller; the whole IP1 arm is 0xBF, the wrist on IP0 0xAC
    assert p.numeric_go(range(5)) == b"\xbf"
    assert p.numeric_go([p.MOTOR_CTL[p.WRIST1], p.MOTOR_CTL[p.WRIST2]]) == b"\xac"
    # manual: two bits per controller, FWD = 1, RVS = 2 (elbow ctl 0 and yaw ctl 3 reverse: 0x82)
    assert p.manual_go({0: p.Drive.RVS, 3: p.Drive.RVS}) == b"\x80\x82\x00"
    assert p.manual_go({2: p.Drive.RVS, 3: p.Drive.FWD}) == b"\x80\x60\x00"
    assert p.manual_go({4: p.Drive.RVS}) == b"\x80\x00\x02"


def test_motors_sit_on_the_drivers_chips_and_controllers():
    assert {p.MOTOR_NAMES[m] for m, ip in p.MOTOR_IP.items() if ip == p.IP0} == {"WRIST1", "WRIST2"}
    assert {p.MOTOR_NAMES[m] for m, ip in p.MOTOR_IP.items() if ip == p.IP1} == {
        "ELBOW", "SHOULDER", "ZED", "YAW", "GRIPPER"}
    assert (p.MOTOR_CTL[p.ELBOW], p.MOTOR_CTL[p.SHOULDER], p.MOTOR_CTL[p.ZED], p.MOTOR_CTL[p.YAW],
            p.MOTOR_CTL[p.GRIPPER]) == (0, 1, 2, 3, 4)
    assert (p.MOTOR_CTL[p.WRIST1], p.MOTOR_CTL[p.WRIST2]) == (2, 3)
    assert p.motor_of(p.IP0, 0) is None and p.motor_of(p.IP0, 3) == p.WRIST2


def test_values_that_do_not_fit_16_bits_or_a_controller_are_refused():
    with pytest.raises(p.RtxProtocolError, match="16-bit"):
        p.write_param(0, 40000)
    with pytest.raises(p.RtxProtocolError, match="controller 5"):
        p.read_position(5)


def test_command_length_comes_from_the_first_byte():
    three = [p.write_position(0, 1), p.select_write(p.Param.SPEED), p.write_param(3, 1),
             p.select_read(p.Param.SPEED), p.manual_go({0: p.Drive.FWD}), bytes([p.CMD_MODE_SET, 0, 0])]
    one = [p.identify(), p.toggle_once(), p.read_position(4), p.read_error(0), p.read_param(2),
           p.numeric_go([0, 1]), p.stop(p.StopMode.RAMP), p.general_status(), p.motor_status(4), p.version()]
    assert all(p.command_length(c[0]) == 3 == len(c) for c in three)
    assert all(p.command_length(c[0]) == 1 == len(c) for c in one)


def test_reply_lengths_and_types():
    assert p.reply_length(0x8A, p.CMD_IM_READ_CP) == 3  # position read
    assert p.reply_length(0x12, 0x12) == 3  # motor status
    assert p.reply_length(0x21, p.CMD_VERSION) == 3 and p.reply_length(0x21, p.CMD_IDENTIFY) == 1
    assert p.reply_length(0xE0, p.CMD_DEF_WRITE1) == 1 and p.reply_length(0x05, 0x78) == 1
    assert not p.is_known_reply_type(0x3C) and not p.is_known_reply_type(0x5A)
    assert p.Reply(b"\x21").identified_chip() == 1 and p.Reply(b"\x0f").is_restart


@given(st.integers(p.WORD_MIN, p.WORD_MAX))
def test_read_replies_carry_a_signed_word_with_its_checksum(value):
    data = p.word_reply(p.RESP_TYPE_IM_READ, value)
    assert p.Reply(data).word() == value
    corrupt = bytes([data[0] ^ 0x01]) + data[1:]
    with pytest.raises(p.RtxProtocolError, match="checksum"):
        p.Reply(corrupt).word()


def test_error_replies_are_said_in_words():
    assert "restarted" in p.describe_reply(0x0F) and "encoder positions are lost" in p.describe_reply(0x0E)
    assert "busy" in p.describe_reply(p.ReplyCode.AXIS_BUSY)
    assert p.describe_reply(0x7E) == "unknown reply 0x7E"
