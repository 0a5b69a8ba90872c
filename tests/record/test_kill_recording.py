"""A recording cut short by ``kill -9`` stays readable up to about its last half second (issue 25
item 6: one kill in four lost 1.19 s while the README promised "up to its last second").

The writer flushes its pending chunk every FLUSH_S of wall time and of recorded time; a real-time
``deskarm --headless --record`` child killed at random moments is read back and the recorded time
lost is measured against the moment of the kill (both on CLOCK_MONOTONIC: the headless run's
WallClock is ``time.monotonic()``, shared by every process on the machine)."""
from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from core.record import topics as tp
from core.record.writer import FLUSH_S, BagWriter, read_truncated

ROOT = Path(__file__).resolve().parents[2]
NS = 1_000_000_000
STATED_BOUND_S = 1.0  # README: "stays readable up to its last second"
HALF_S = 0.5  # the flush period that keeps a kill well inside that bound (queue latency on top)
NAMES = ("base", "shoulder", "elbow")


class FakeWall:
    """``time`` for core.record.writer: a wall clock the test moves (or keeps still)."""

    def __init__(self) -> None:
        self.now = 1000.0

    def monotonic(self) -> float:
        return self.now


def readable_until_ns(mcap: Path) -> int:
    """The last log time a reader finds in the file as it is on disk now (what a kill would leave)."""
    return max((log for _, _, log, _ in read_truncated(mcap)), default=-1)


@pytest.mark.parametrize("wall_speed, rate_hz", [
    (1.0, 10.0),  # real time at a low message rate: the wall-clock flush is the one that counts
    (0.0, 30.0),  # a --fast run whose wall clock hardly moves: only the recorded time can flush
])
def test_what_a_kill_would_leave_is_never_more_than_a_flush_behind(tmp_path, monkeypatch, wall_speed, rate_hz):
    import core.record.writer as writer_module

    wall = FakeWall()
    monkeypatch.setattr(writer_module, "time", wall)
    bag = BagWriter(tmp_path / "bag")
    bag.open()
    try:
        lost = []
        for i in range(int(3 * rate_hz)):
            t = 5.0 + i / rate_hz
            wall.now = 1000.0 + wall_speed * i / rate_hz
            bag.write(tp.JOINTS_MEASURED, tp.time_ns(t), tp.joint_state((0.1, 0.2, 0.3), t, NAMES))
            # a kill right after this write loses what came after the last readable message (the
            # whole recording so far when nothing is readable yet)
            readable_ns = readable_until_ns(bag.mcap_path)
            lost.append(t - (readable_ns / NS if readable_ns >= 0 else 5.0 - 1.0 / rate_hz))
    finally:
        bag.close()
    # the pending chunk holds half a second of recording, and a message interval more at the most
    assert max(lost) <= HALF_S + 1.0 / rate_hz + 1e-6, (max(lost), lost)
    assert FLUSH_S <= HALF_S


def kill_a_recording_run(bag: Path, wait_s: float) -> float:
    """Seconds of recording lost when a real-time headless run is killed ``wait_s`` after its file appears."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), QT_QPA_PLATFORM="offscreen")
    proc = subprocess.Popen([sys.executable, "-m", "app.cli", "--headless", "--fps", "10", "--duration", "120",
                             "--record", str(bag)], cwd=ROOT, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    mcap = bag / f"{bag.name}.mcap"
    try:
        deadline = time.monotonic() + 120
        # poll the file (no event crosses processes): first messages on disk, then a random wait
        while readable_until_ns(mcap) < 0 if mcap.is_file() else True:
            assert proc.poll() is None, proc.stderr.read().decode()
            assert time.monotonic() < deadline, "the recording never reached the disk"
            time.sleep(0.05)
        time.sleep(wait_s)
        assert proc.poll() is None, proc.stderr.read().decode()
        killed_at = time.time()  # the bag's log times are ROS time: wall-clock since the epoch
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(30)
    assert proc.returncode == -signal.SIGKILL
    return killed_at - readable_until_ns(mcap) / NS


def test_a_recording_killed_at_random_moments_is_readable_up_to_its_last_second(tmp_path):
    rng = random.Random()  # a random moment each run: the bound must hold wherever the kill falls
    waits = [rng.uniform(1.5, 3.5) for _ in range(3)]
    lost = [kill_a_recording_run(tmp_path / f"killed{i}", w) for i, w in enumerate(waits)]
    assert all(0 <= s < STATED_BOUND_S for s in lost), [f"{s:.3f} s after {w:.2f} s" for s, w in zip(lost, waits)]
