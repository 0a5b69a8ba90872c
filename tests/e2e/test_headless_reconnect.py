"""The headless runner keeps going when its board goes away, and drives a v1 board from the start.

The firmware test runs ``deskarm --headless`` in a child process, paced on the wall clock, with
``--bridge v2:<link>`` where the link is a symlink this test controls (as udev's by-id links):
the first host_firmware is stopped mid-run, a new one is started and the link pointed at it.
Every wait is on a line the firmware prints (a queue read with a timeout), never a sleep.
"""
from __future__ import annotations

import json
import os
import queue
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from host_board import TIMEOUT_S, Board  # tests/ is on sys.path (pytest rootdir conftest)

from app.cli import main
from app.headless import HeadlessRunner
from core.devices.bridge import BridgeError
from core.devices.reconnect import FIRST_RETRY_S, MAX_RETRY_S
from core.devices.sim_arm import SimServoArm
from core.session import DeskSession, SessionOptions

ROOT = Path(__file__).resolve().parents[2]
STARTUP_S = 60.0  # a child process importing numpy, OpenCV and Pinocchio on a loaded machine


class Lines:
    """A child process's lines (its stderr: the status lines), read by a thread into a queue."""

    def __init__(self, stream) -> None:
        self.all: list[str] = []
        self._queue: "queue.Queue[str]" = queue.Queue()
        threading.Thread(target=self._read, args=(stream,), daemon=True).start()

    def _read(self, stream) -> None:
        for line in stream:
            self._queue.put(line.rstrip("\n"))

    def wait_for(self, text: str, timeout: float) -> str:
        """The first line from now on containing ``text``; AssertionError after ``timeout`` s."""
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            try:
                line = self._queue.get(timeout=max(0.0, left))
            except queue.Empty:
                raise AssertionError(f"no line with {text!r} within {timeout} s; saw {self.all}") from None
            self.all.append(line)
            if text in line:
                return line

    def rest(self) -> list[str]:
        while True:
            try:
                self.all.append(self._queue.get(timeout=TIMEOUT_S))
            except queue.Empty:
                return self.all


def test_a_paced_headless_run_outlives_the_board_going_away_and_reconnects(host_firmware, tmp_path):
    link = tmp_path / "usb-deskarm-board-if00"
    first = Board(host_firmware)
    second = None
    proc = None
    try:
        os.symlink(first.path, link)
        proc = subprocess.Popen(
            [sys.executable, "-m", "app.cli", "--headless", "--camera", "sim", "--scenario", "static",
             "--bridge", f"v2:{link}", "--duration", "5", "--json"],
            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )
        lines = Lines(proc.stderr)  # the once-a-second status lines; the JSON alone is on stdout
        first.next_pwm(timeout=STARTUP_S)  # the run is on: its commands move the first board
        first.stop()  # unplugged mid-run: the line hangs up
        link.unlink()  # udev removes the link with the device
        # the runner says so on its next once-a-second status line, and keeps running
        lost = lines.wait_for("bridge-disconnects=1", timeout=TIMEOUT_S)
        assert "no such port — is the board plugged in?" in lost and "retrying in" in lost
        second = Board(host_firmware)  # plugged in again: a new tty behind the same name
        os.symlink(second.path, link)
        second.next_pwm(timeout=MAX_RETRY_S + TIMEOUT_S)  # commands after the reconnect reach it
        assert proc.wait(timeout=STARTUP_S) == 0, lines.rest()
        out = proc.stdout.read()
    finally:
        if proc is not None and proc.poll() is None:
            proc.kill()
            proc.wait()
        first.stop()
        if second is not None:
            second.stop()
    summary = json.loads(out)
    assert summary["bridge_disconnects"] == 1
    assert summary["disconnected_s"] >= FIRST_RETRY_S  # noticed before the new board was there
    assert summary["duration_s"] >= 5.0  # the whole duration, not cut short by the loss
    assert summary["commands_sent"] > 0 and summary["limit_violations"] == 0


class UnpluggedArm(SimServoArm):
    """A simulated arm whose device goes away at ``lose_at`` (s, session clock) and then
    refuses ``refusals`` connects, like a board being plugged back in."""

    def __init__(self, profile, clock, lose_at: float, refusals: int):
        super().__init__(profile, clock=clock)
        self.lose_at, self.refusals = lose_at, refusals
        self.lost_t = None
        self.connect_times: list[float] = []
        self.sent_after_reconnect = 0

    def connect(self):
        self.connect_times.append(self.clock.now())
        if self.lost_t is not None and len(self.connect_times) - 2 < self.refusals:
            raise BridgeError("/dev/ttyACM0: no such port — is the board plugged in?")
        super().connect()

    def send(self, command):
        if self.lost_t is None and self.clock.now() >= self.lose_at:
            self.lost_t = self.clock.now()
            self._connected = False
            raise BridgeError("/dev/ttyACM0: the device went away (unplugged?) — plug it back in; "
                              "deskarm reconnects by itself")
        sent = super().send(command)
        if self.lost_t is not None:
            self.sent_after_reconnect += 1
        return sent


def test_a_lost_bridge_is_reconnected_with_the_windows_backoff_and_counted():
    session = DeskSession.create(SessionOptions(camera="sim", scenario="static", simulated_clock=True))
    arm = session.bridge = UnpluggedArm(session.profile, session.clock, lose_at=session.clock.now() + 2.0,
                                        refusals=2)
    summary = HeadlessRunner(session, 6.0).run().summary()
    assert arm.lost_t is not None and summary["bridge_disconnects"] == 1
    # connect at the start, then: at once (refused), after 0.5 s (refused), after 1 s (back)
    assert len(arm.connect_times) == 4
    retries = arm.connect_times[1:]
    assert retries[0] - arm.lost_t < 0.05  # the next control step
    assert [round(b - a, 2) for a, b in zip(retries, retries[1:])] == pytest.approx([0.5, 1.0], abs=0.03)
    assert summary["disconnected_s"] == pytest.approx(retries[-1] - arm.lost_t, abs=0.03)
    assert arm.sent_after_reconnect > 50  # 50 Hz for the ~2.5 s left
    assert summary["duration_s"] >= 6.0 and summary["limit_violations"] == 0


def test_headless_with_a_v1_bridge_sends_commands_within_the_limits(capsys):
    code = main(["--headless", "--camera", "sim", "--scenario", "static", "--bridge", "loop://",
                 "--duration", "2", "--fast", "--json"])
    assert code == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["commands_sent"] > 50  # up to 100 Hz (v1's cap) for 2 s
    assert summary["limit_violations"] == 0
    assert summary["bridge_disconnects"] == 0 and summary["disconnected_s"] == 0


def test_a_v1_board_starts_from_home_and_gets_the_seed_bytes():
    session = DeskSession.create(SessionOptions(camera="sim", scenario="static", simulated_clock=True,
                                                bridge="loop://"))
    bridge = session.bridge
    written = []
    write = bridge._write_servo_deg

    def recording(servo_deg):
        written.append(servo_deg)
        return write(servo_deg)

    bridge._write_servo_deg = recording
    summary = HeadlessRunner(session, 1.0).run().summary()
    assert summary["commands_sent"] == len(written) > 0
    assert bridge.bytes_written == 6 * len(written)  # FB a1 FC a2 FD a3 each
    home = session.profile.to_servo_deg(session.profile.q_home)
    # the first step starts from home: one rate-limited step away from it at most
    step_deg = [j.max_speed_deg_s * session.controller.period_s + 1.0 for j in session.profile.joints]
    assert all(abs(a - h) <= s for a, h, s in zip(written[0], home, step_deg)), (written[0], home)
