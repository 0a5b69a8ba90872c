"""The emulated RTX controller, driven by calls with explicit times: strict replies, the arm's end
stops, and every fault it can inject."""
from __future__ import annotations

import pytest

from core.devices import rtx_protocol as p
from core.devices.rtx_emulator import RtxController


class Line:
    """Sends commands to a controller 10 ms apart (simulated time)."""

    def __init__(self, ctl: RtxController):
        self.ctl = ctl
        self.t = 0.0

    def __call__(self, cmd: bytes, gap: float = 0.01):
        self.t += gap
        return self.ctl.handle(cmd, self.t)

    def wait(self, seconds: float) -> None:
        self.t += seconds
        self.ctl.advance(self.t)

    def select(self, ip: int) -> None:
        if self.ctl.line != ip:
            assert self(p.toggle_once()) == b"\x00"


@pytest.fixture
def line():
    ctl = RtxController(clock=lambda: 0.0)
    ln = Line(ctl)
    for ip in (p.IP0, p.IP1):  # both chips out of their restarted state
        ln.select(ip)
        assert ln(p.identify()) == b"\x0f"
        assert ln(p.go_restart()) == b"\x00"
        assert ln(p.identify()) == bytes([0x20 | ip])
        if ip == p.IP0:
            assert ln(p.toggle_once()) == b"\x00"
    return ln


def test_a_restarted_chip_answers_only_go():
    ln = Line(RtxController(clock=lambda: 0.0))
    assert ln(p.toggle_off()) == b"\x0f" and ln(p.read_position(2)) == b"\x0f"
    assert ln(p.toggle_once()) == b"\x0f" and ln.ctl.line == p.IP0  # no hand-over while restarted
    assert ln(p.go_restart()) == b"\x00" and ln(p.identify()) == b"\x20"
    assert ln(p.toggle_once()) == b"\x00" and ln(p.identify()) == b"\x0f"  # IP1 still restarted


def test_strict_replies_to_what_the_controller_refuses(line):
    line.select(p.IP1)
    assert line(p.write_param(0, 100)) == bytes([p.ReplyCode.CMD_OOR])  # no DEF_WRITE1 before it
    assert line(p.select_write(p.Param.ERROR)) == bytes([p.ReplyCode.READ_ONLY])
    assert line(bytes([p.CMD_DEF_WRITE1, 15, 0])) == bytes([p.ReplyCode.PARAM_OOR])  # no such code
    assert line(p.select_write(p.Param.SPEED)) == b"\xe0"
    assert line(p.write_param(1, 30000)) == bytes([p.ReplyCode.PARAM_OOR])  # faster than the motor
    assert line(bytes([0x30])) == bytes([p.ReplyCode.CMD_NOT_SUPPORTED])
    line.select(p.IP0)
    assert line(p.read_position(0)) == bytes([p.ReplyCode.SELECT_OOR])  # IP0 has no controller 0
    assert line(p.numeric_go([1])) == bytes([p.ReplyCode.SELECT_OOR])
    assert line(p.identify(), gap=0.004) == bytes([p.ReplyCode.FRAME_OVERRUN])  # 4 ms after the last
    assert line.ctl.spacing_violations == 1


def test_a_move_is_new_position_then_go_and_a_busy_axis_refuses_go(line):
    line.select(p.IP1)
    assert line(p.select_write(p.Param.NEW_POSITION)) == b"\xe0"
    assert line(p.write_param(1, 1000)) == bytes([0xF0 | p.checksum(0xE8, 0x03)])
    assert line(p.numeric_go([1])) == b"\x00"
    assert line(p.motor_status(1))[1] & p.STAT_IN_PROGRESS
    assert line(p.numeric_go([1])) == bytes([p.ReplyCode.AXIS_BUSY])
    line.wait(2.0)
    assert not line(p.motor_status(1))[1] & p.STAT_IN_PROGRESS
    cp = p.Reply(line(p.read_position(1))).word()
    err = p.Reply(line(p.read_error(1))).word()
    assert cp == 1000 and abs(cp - err - 1000) <= 1


def test_driving_into_an_end_stop_trips_the_error_limit(line):
    line.select(p.IP1)
    assert line(p.manual_go({p.MOTOR_CTL[p.SHOULDER]: p.Drive.FWD})) == b"\x00"
    line.wait(10.0)
    status = line(p.motor_status(p.MOTOR_CTL[p.SHOULDER]))[1]
    assert status & p.STAT_RESET and status & p.STAT_ERROR_LIMIT and not status & p.STAT_IN_PROGRESS
    assert line(p.general_status())[1] & p.GEN_AXIS_RESET
    assert line.ctl.true_positions()[p.SHOULDER] == pytest.approx(2630.0)  # the end stop


def test_a_wrist_stop_blocks_both_wrist_motors(line):
    line.select(p.IP0)
    assert line(p.manual_go({2: p.Drive.RVS, 3: p.Drive.FWD})) == b"\x00"  # roll down
    line.wait(10.0)
    for ctl in (2, 3):
        assert line(p.motor_status(ctl))[1] & p.STAT_RESET
    pos = line.ctl.true_positions()
    assert pos[p.WRIST1] - pos[p.WRIST2] == pytest.approx(-3560.0)  # the roll stop (2 · 13.487 · −132°)


def test_faults_no_answer_garbage_restart_and_an_obstacle(line):
    line.ctl.no_answer(2)
    assert line(p.identify()) is None and line(p.identify()) is None
    assert line(p.identify()) == b"\x21"
    line.ctl.garbage(1)
    reply = line(p.identify())
    assert not p.is_known_reply_type(reply[0])
    line.ctl.no_answer(None)
    assert all(line(p.identify()) is None for _ in range(5))
    line.ctl.clear_faults()
    line.ctl.restart()
    assert line(p.identify()) == b"\x0f" and line.ctl.readings()[p.ELBOW] == 0
    assert line(p.go_restart()) == b"\x00"
    line.select(p.IP1)
    assert line(p.identify()) == b"\x0f"  # IP1 restarted too …
    assert line(p.go_restart()) == b"\x00" and line(p.identify()) == b"\x21"  # … and works after GO
    line.ctl.obstacle(p.ELBOW)
    assert line(p.manual_go({0: p.Drive.FWD})) == b"\x00"
    line.wait(5.0)
    assert line(p.motor_status(0))[1] & p.STAT_RESET
