"""Serial link figures: the Python bridges against the firmware's C core over a pseudo-terminal.

- PING → STATUS round trip as the caller sees it (write, the I/O thread reads and decodes the
  reply, the caller wakes), and SET_JOINTS + PING → STATUS;
- bytes per command, v1 vs v2, counted from what the bridges wrote;
- the sustained SET_JOINTS rate the bridge + host_firmware keep up with the 50 Hz cap off.

A pty has no baud rate: these are software figures. The real line runs at 9600 baud, 960 bytes/s,
which the rows' extra text turns into the ceiling a real board sees.
"""
from __future__ import annotations

import math
import queue
import random
import shutil
import subprocess
import threading
import time
from pathlib import Path

from core.clock import SimClock
from core.devices.serial_v1 import SerialV1Bridge
from core.devices.serial_v2 import SerialV2Bridge
from core.kinematics.profile import load_profile
from core.messages import JointCommand

ROOT = Path(__file__).resolve().parents[1]
FIRMWARE = ROOT / "firmware"
LINE_BYTES_PER_S = 9600 / 10  # 8N1: 10 bits per byte
TIMEOUT_S = 3.0


def _row(name, unit, samples, baseline=None, extra=""):
    return {"name": name, "unit": unit, "samples": list(samples), "baseline": baseline, "extra": extra}


def _build() -> tuple[Path | None, str]:
    """(path to host_firmware, "") or (None, why it could not be built)."""
    if shutil.which("make") is None or shutil.which("gcc") is None:
        return None, "make and gcc are needed to build firmware/host_firmware"
    try:
        done = subprocess.run(["make", "-s", "-C", str(FIRMWARE), "host"], capture_output=True, text=True,
                              timeout=120)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return None, f"make -C firmware host failed: {exc}"
    if done.returncode != 0:
        tail = (done.stderr or done.stdout).strip().splitlines()[-1:] or ["(no output)"]
        return None, f"make -C firmware host failed: {tail[0]}"
    return FIRMWARE / "host_firmware", ""


class _Board:
    """host_firmware running; its stdout is drained so PWM lines never block it."""

    def __init__(self, exe: Path) -> None:
        self.proc = subprocess.Popen([str(exe)], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        self._first: "queue.Queue[str]" = queue.Queue()
        threading.Thread(target=self._drain, daemon=True, name="bench host_firmware stdout").start()
        first = self._first.get(timeout=TIMEOUT_S)
        if not first.startswith("PORT "):
            raise RuntimeError(f"host_firmware printed {first!r} instead of 'PORT <path>'")
        self.path = first.split(" ", 1)[1].strip()

    def _drain(self) -> None:
        for k, line in enumerate(self.proc.stdout):
            if k == 0:
                self._first.put(line)

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def _poses(profile, n: int, seed: int = 1) -> list[JointCommand]:
    rng = random.Random(seed)
    out = []
    for k in range(n):
        q = tuple(rng.uniform(j.q_min, j.q_max) for j in profile.joints)
        out.append(JointCommand(k + 1, 0.0, q))
    return out


def _round_trips(bridge: SerialV2Bridge, profile, n: int) -> tuple[list[float], list[float]]:
    """(PING → STATUS ms, SET_JOINTS + PING → STATUS ms), as the caller sees them."""
    ping_ms, cmd_ms = [], []
    for cmd in _poses(profile, n):
        t0 = time.perf_counter()
        reply = bridge.wait_for_status(TIMEOUT_S, seq=bridge.ping())
        t1 = time.perf_counter()
        bridge.send(cmd)
        reply2 = bridge.wait_for_status(TIMEOUT_S, seq=bridge.ping())
        t2 = time.perf_counter()
        if reply is None or reply2 is None:
            raise RuntimeError("host_firmware stopped answering PINGs")
        ping_ms.append((t1 - t0) * 1e3)
        cmd_ms.append((t2 - t1) * 1e3)
    return ping_ms, cmd_ms


def _sustained(bridge: SerialV2Bridge, profile, duration_s: float) -> tuple[list[float], list[int], str]:
    """(commands per second in 100 ms windows, bytes of each command, how many the board took)."""
    poses = _poses(profile, 500, seed=2)
    before = bridge.wait_for_status(TIMEOUT_S, seq=bridge.ping())
    window_s, rates, sizes = 0.1, [], []
    sent = 0
    t_end = time.perf_counter() + duration_s
    w0, n_w = time.perf_counter(), 0
    while True:
        now = time.perf_counter()
        if now >= w0 + window_s:
            rates.append(n_w / (now - w0))
            w0, n_w = now, 0
            if now >= t_end:
                break
        b0 = bridge.bytes_written
        bridge.send(poses[sent % len(poses)])
        sizes.append(bridge.bytes_written - b0)
        sent += 1
        n_w += 1
    after = bridge.wait_for_status(TIMEOUT_S, seq=bridge.ping())
    if before is None or after is None:
        raise RuntimeError("host_firmware stopped answering PINGs")
    accepted = (after.good_frames - before.good_frames - 1) & 0xFFFF  # minus the second PING
    bad = (after.bad_frames - before.bad_frames) & 0xFFFF
    # the board's counters are 16-bit: compare modulo 65536
    verdict = "all accepted" if accepted == sent & 0xFFFF else f"{accepted} (mod 65536) accepted"
    return rates, sizes, f"{sent} SET_JOINTS sent, {verdict} by the board, {bad} bad frames"


def _v1_sizes(profile, n: int) -> list[int]:
    """Bytes per command of the v1 bridge, measured on pyserial's loop://."""
    sizes = []
    bridge = SerialV1Bridge("loop://", profile, clock=SimClock())
    with bridge:
        for cmd in _poses(profile, n):
            b0 = bridge.bytes_written
            bridge.send(cmd)
            bridge.read_available()
            sizes.append(bridge.bytes_written - b0)
    return sizes


def rows(quick: bool = False) -> list[dict]:
    """Bench rows (``bench/__main__.py`` format); one row saying why when there is no host_firmware."""
    exe, why = _build()
    if exe is None:
        return [_row("serial link: skipped", "ms", [0.0], extra=f"SKIPPED — {why}")]
    profile = load_profile("desk_rrr")
    board = _Board(exe)
    bridge = SerialV2Bridge(f"v2:{board.path}", profile, heartbeat_hz=0, max_command_hz=0)
    try:
        bridge.connect()
        ping_ms, cmd_ms = _round_trips(bridge, profile, 40 if quick else 400)
        thread_rtt = sorted(bridge.rtt_samples_s())
        rates, sizes_v2, accepted = _sustained(bridge, profile, 0.5 if quick else 3.0)
    except Exception as exc:  # noqa: BLE001 - a bench reports, it does not crash the table
        return [_row("serial link: failed", "ms", [0.0], extra=f"FAILED — {exc}")]
    finally:
        bridge.disconnect()
        board.stop()
    sizes_v1 = _v1_sizes(profile, 200)
    v1_b = sum(sizes_v1) / len(sizes_v1)
    v2_b = sum(sizes_v2) / len(sizes_v2)
    med_thread = thread_rtt[len(thread_rtt) // 2] * 1e3 if thread_rtt else math.nan
    line_v1, line_v2 = LINE_BYTES_PER_S / v1_b, LINE_BYTES_PER_S / v2_b
    return [
        _row("serial v2 PING -> STATUS round trip (pty)", "ms", ping_ms,
             extra=f"caller to caller; {med_thread:.3f} ms median inside the I/O thread; a real 9600 baud "
                   f"line adds 8 + 22 bytes = 31 ms"),
        _row("serial v2 SET_JOINTS+PING -> STATUS (pty)", "ms", cmd_ms),
        _row("serial bytes per command, v1 (3 joints)", "B", sizes_v1,
             extra=f"line limit at 9600 baud: {LINE_BYTES_PER_S:.0f} B/s / {v1_b:.0f} B = {line_v1:.0f} commands/s"),
        _row("serial bytes per command, v2 (3 joints)", "B", sizes_v2,
             extra=f"{v2_b:.2f} B average (escapes included) = {v2_b / v1_b:.2f}x v1; line limit "
                   f"{line_v2:.1f} commands/s; the 50 Hz cap + 10 Hz PING use "
                   f"{(50 * v2_b + 10 * 8) / LINE_BYTES_PER_S:.0%} of the line to the board "
                   f"(STATUS replies {10 * 22 / LINE_BYTES_PER_S:.0%} of the way back)"),
        _row("serial v2 sustained SET_JOINTS rate (pty, no cap)", "/s", rates,
             extra=f"{accepted}; the pty has no baud rate — a real line caps it at {line_v2:.1f}/s"),
    ]


if __name__ == "__main__":
    from bench.__main__ import format_table

    print(format_table(rows("--quick" in __import__("sys").argv)))
