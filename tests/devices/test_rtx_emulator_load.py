"""The emulated RTX on a loaded host: a starved emulator neither takes the host's pacing for a
spacing error nor makes the host wait while it catches up on the arm's physics — and it still
refuses a host that really writes two commands back to back.

The serving thread runs on a clock the test holds: "starved" is the thread stopped inside its
clock call while the host writes, so nothing here depends on how fast the machine is.
"""
from __future__ import annotations

import os
import select
import threading
import time
import tty

import pytest

from core.devices import rtx_protocol as p
from core.devices.rtx_emulator import MAX_CATCH_UP_S, RtxController, RtxEmulator

WAIT = 10.0  # s: an upper bound for the thread to answer, never a measured duration


class HeldClock:
    """A clock the test sets; ``hold()`` stops the next thread that reads it until ``release()``."""

    def __init__(self, t: float = 1.0):
        self.t = t
        self._open = threading.Event()
        self._open.set()
        self.stopped = threading.Event()  # a reader is held

    def __call__(self) -> float:
        if not self._open.is_set():
            self.stopped.set()
            self._open.wait()
        return self.t

    def hold(self) -> None:
        self.stopped.clear()
        self._open.clear()

    def release(self) -> None:
        self._open.set()


@pytest.fixture
def served():
    clock = HeldClock()
    emu = RtxEmulator(RtxController(clock=clock))
    path = emu.start()
    fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(fd)
    try:
        yield emu, clock, fd
    finally:
        clock.release()
        emu.stop()
        os.close(fd)


def read_reply(fd: int, n: int) -> bytes:
    """``n`` bytes from the line, waiting on the descriptor (None of them after WAIT s: short)."""
    data = b""
    deadline = time.monotonic() + WAIT
    while len(data) < n:
        ready, _, _ = select.select([fd], [], [], max(0.0, deadline - time.monotonic()))
        if not ready:
            break
        data += os.read(fd, n - len(data))
    return data


def test_two_commands_bunched_by_a_starved_emulator_are_not_refused_as_too_close(served):
    emu, clock, fd = served
    clock.hold()
    assert clock.stopped.wait(WAIT), "the serving thread never read its clock"
    os.write(fd, p.toggle_off())  # the host writes, gives up waiting for the answer ...
    clock.t += 0.2
    os.write(fd, p.toggle_off())  # ... and writes again 200 ms later: both wait in the pty
    clock.t += 0.001
    clock.release()  # the emulator runs again and reads both at once
    # a restarted chip's answer to each (the controller has just powered up), no frame overrun
    assert read_reply(fd, 2) == bytes([p.RESP_IP_RESTART, p.RESP_IP_RESTART])
    assert emu.controller.spacing_violations == 0


def test_a_host_writing_two_commands_back_to_back_is_still_refused(served):
    emu, clock, fd = served
    os.write(fd, p.toggle_off() + p.toggle_off())  # one write, no time between them on the clock
    assert read_reply(fd, 2) == bytes([p.RESP_IP_RESTART, p.ReplyCode.FRAME_OVERRUN])
    assert emu.controller.spacing_violations == 1


def test_the_window_a_command_was_written_in_decides_the_spacing():
    ctl = RtxController(clock=lambda: 0.0)
    restarted = bytes([p.RESP_IP_RESTART])  # a powered-up chip's answer: the command was taken
    assert ctl.handle(p.toggle_off(), 1.0, written_after=0.9) == restarted
    # read 1 ms later, but it can have been written 100 ms after the first: not certainly too close
    assert ctl.handle(p.toggle_off(), 1.001, written_after=1.0) == restarted
    # written within the 2 ms before it was read, 4 ms after the last one could have been: too close
    assert ctl.handle(p.toggle_off(), 1.005, written_after=1.003) == bytes([p.ReplyCode.FRAME_OVERRUN])
    assert ctl.spacing_violations == 1


def test_a_starved_emulator_simulates_a_bounded_stretch_before_it_answers(monkeypatch):
    """At --time-scale 60 a starved second used to be 6000 physics steps before the reply; the
    arm's time now waits for the emulator instead (MAX_CATCH_UP_S of it at most)."""
    emu = RtxEmulator(time_scale=60.0)  # not started: only its controller
    ctl = emu.controller
    assert ctl.max_catch_up_s == MAX_CATCH_UP_S
    steps = []
    real_step = ctl._step
    monkeypatch.setattr(ctl, "_step", lambda dt: (steps.append(dt), real_step(dt)))
    ctl.advance(100.0)
    assert ctl.handle(p.toggle_off(), 105.0) == bytes([p.RESP_IP_RESTART])  # 5 s later, answered
    assert sum(steps) == pytest.approx(MAX_CATCH_UP_S * 60.0)
    assert len(steps) <= MAX_CATCH_UP_S * 60.0 / 0.01 + 1
    # a controller driven by explicit times (the unit tests') still simulates all of a gap
    exact = RtxController(time_scale=60.0)
    assert exact.max_catch_up_s is None
    exact_steps = []
    real_exact_step = exact._step
    monkeypatch.setattr(exact, "_step", lambda dt: (exact_steps.append(dt), real_exact_step(dt)))
    exact.advance(0.0)
    exact.advance(0.5)
    assert sum(exact_steps) == pytest.approx(30.0)
