"""Reconnector: the backoff the window and the headless runner share, and its outage counts."""
from __future__ import annotations

import pytest

from core.clock import SimClock
from core.devices.bridge import BridgeError
from core.devices.reconnect import FIRST_RETRY_S, MAX_RETRY_S, Reconnector
from core.devices.sim_arm import SimServoArm
from core.kinematics.profile import load_profile


class Board(SimServoArm):
    """A simulated arm that can be unplugged and plugged in again."""

    def __init__(self, profile, clock):
        super().__init__(profile, clock=clock)
        self.plugged = True
        self.connect_times: list[float] = []

    def connect(self):
        self.connect_times.append(self.clock.now())
        if not self.plugged:
            raise BridgeError("/dev/ttyACM0: no such port — is the board plugged in?")
        super().connect()


@pytest.fixture
def clock():
    return SimClock()


@pytest.fixture
def board(clock):
    return Board(load_profile("desk_rrr"), clock)


def poll(rec, board, clock, until_s, dt=0.125):
    """Call ``ensure`` every ``dt`` until ``until_s`` (what a loop does; 1/8 s adds up exactly)."""
    while clock.now() < until_s:
        rec.ensure(board)
        clock.advance(dt)


def test_retries_at_once_then_after_a_doubling_delay_capped_at_5_s(clock, board):
    rec = Reconnector(now=clock.now)
    assert rec.ensure(board) and rec.disconnects == 0
    board.plugged = False
    board.disconnect()  # the device went away
    poll(rec, board, clock, 20.0)
    gaps = [round(b - a, 2) for a, b in zip(board.connect_times[1:], board.connect_times[2:])]
    assert board.connect_times[1] == 0.0  # the first retry at once
    assert gaps == [0.5, 1.0, 2.0, 4.0, 5.0, 5.0]
    assert (FIRST_RETRY_S, MAX_RETRY_S) == (0.5, 5.0)
    assert "no such port" in board.message and "retrying in 5 s" in board.message
    assert rec.disconnects == 1 and rec.is_down


def test_a_reconnect_resets_the_delay_and_the_outage_is_timed(clock, board):
    rec = Reconnector(now=clock.now)
    rec.ensure(board)
    board.plugged = False
    board.disconnect()
    poll(rec, board, clock, 2.0)  # attempts at 0, 0.5, 1.5: all refused
    board.plugged = True
    poll(rec, board, clock, 4.0)  # back at the attempt due at 3.5
    assert board.connect_times[-1] == pytest.approx(3.5)
    assert board.is_connected and not rec.is_down
    assert rec.disconnected_s() == pytest.approx(3.5)
    assert rec.delay_s == FIRST_RETRY_S
    clock.advance(10.0)
    assert rec.disconnected_s() == pytest.approx(3.5)  # connected time is not counted
    board.plugged = False
    board.disconnect()
    poll(rec, board, clock, 14.6)  # attempts at 14.0 and 14.5 (the delay started afresh)
    assert board.connect_times[-2:] == pytest.approx([14.0, 14.5])
    assert rec.disconnects == 2 and clock.now() == 14.625
    assert rec.disconnected_s() == pytest.approx(3.5 + 0.625)  # the ongoing outage counts too


def test_a_bridge_error_in_use_disconnects_a_bridge_that_still_claims_a_link(clock, board):
    rec = Reconnector(now=clock.now)
    rec.ensure(board)
    rec.lost(board, BridgeError("/dev/ttyACM0: write timed out"))
    assert not board.is_connected and rec.disconnects == 1
    assert board.message == "/dev/ttyACM0: write timed out"
    clock.advance(0.25)
    assert rec.ensure(board)  # plugged in: the next ensure reconnects at once
    assert rec.disconnected_s() == pytest.approx(0.25)


def test_a_connect_that_never_worked_is_no_disconnect(clock, board):
    board.plugged = False
    rec = Reconnector(now=clock.now)
    poll(rec, board, clock, 1.0)
    assert rec.disconnects == 0 and rec.disconnected_s() == 0.0
    assert len(board.connect_times) == 2  # at 0 and 0.5


def test_reset_forgets_the_backoff(clock, board):
    board.plugged = False
    rec = Reconnector(now=clock.now)
    poll(rec, board, clock, 2.0)
    rec.reset()
    rec.ensure(board)
    assert board.connect_times[-1] == pytest.approx(2.0)


@pytest.mark.parametrize("first, most", [(0.0, 5.0), (1.0, 0.5), (-1.0, 5.0)])
def test_bad_delays_name_the_fields_and_the_range(first, most):
    with pytest.raises(ValueError, match="first_retry_s .* expected 0 < first_retry_s ≤ max_retry_s"):
        Reconnector(first_retry_s=first, max_retry_s=most)
