"""UMI-RTX link figures: the RTX bridge against the emulated controller over a pseudo-terminal.

- one command's round trip (IM_READ_CP: 1 byte out, 3 back) as the bridge sees it, beside the
  9600-baud physical minimum for the same 4 bytes (10 bits per byte);
- the I/O cycle (new targets written, GO, every motor read back, both chips' status) on the
  emulated line, beside the same commands on a real line: their bytes at 9600 baud plus the 8 ms
  the bridge waits after each reply;
- how far the read-back joints lag the commanded ones while the shoulder follows a sine (the
  emulated arm at real speed): the shift that best aligns the two.

A pty has no baud rate: the emulated rows are software figures; the 9600-baud rows are what a
real controller line cannot beat.
"""
from __future__ import annotations

import math
import time

import numpy as np

from core.devices import rtx_protocol as p
from core.devices.rtx_bridge import RtxBridge
from core.devices.rtx_emulator import RtxEmulator
from core.kinematics.profile import load_profile
from core.messages import JointCommand

LINE_BYTES_PER_S = p.BAUDRATE / p.BITS_PER_BYTE
INIT_SPEEDUP = 60.0  # the initialisation runs this much faster; the measurements at real speed


def _row(name, unit, samples, baseline=None, extra=""):
    return {"name": name, "unit": unit, "samples": list(samples), "baseline": baseline, "extra": extra}


def _round_trips(bridge: RtxBridge, n: int) -> list[float]:
    """``n`` IM_READ_CP round trips (ms), each started after the spacing (the I/O thread paused)."""
    out = []
    bridge._io_pause.set()
    try:
        with bridge._line:
            bridge._select(p.IP1)
            for _ in range(n):
                wait = bridge._next_write_t - time.monotonic()
                if wait > 0:
                    time.sleep(wait)
                t0 = time.perf_counter()
                bridge._raw(p.IP1, p.read_position(1))
                out.append((time.perf_counter() - t0) * 1e3)
    finally:
        bridge._io_pause.clear()
    return out


def _lag_ms(t_cmd, q_cmd, t_meas, q_meas) -> float:
    """The delay (ms) that best aligns the measured signal with the commanded one."""
    t_cmd, q_cmd, t_meas, q_meas = map(np.asarray, (t_cmd, q_cmd, t_meas, q_meas))
    best, best_err = 0.0, math.inf
    for lag in np.arange(0.0, 1.5, 0.005):
        ref = np.interp(t_meas - lag, t_cmd, q_cmd)
        ok = t_meas - lag >= t_cmd[0]
        if ok.sum() < 10:
            continue
        err = float(np.sqrt(np.mean((q_meas[ok] - ref[ok]) ** 2)))
        if err < best_err:
            best, best_err = float(lag), err
    return best * 1e3


def rows(quick: bool) -> list[dict]:
    profile = load_profile("umi_rtx")
    emu = RtxEmulator(time_scale=INIT_SPEEDUP)
    emu.start()
    bridge = RtxBridge("rtx:" + emu.path, profile)
    try:
        bridge.connect()
        bridge.initialise()
        ctl = emu.controller
        ctl.time_scale = 1.0  # from here on the emulated arm moves at a real RTX's speed
        rtt = _round_trips(bridge, 100 if quick else 500)
        # a sine on the shoulder, sent at 20 Hz; read back as fast as the line allows
        duration = 6.0 if quick else 20.0
        q0 = list(profile.q_home)
        start_cmds, start_rx = len(ctl.received), len(ctl.replies)
        bridge.cycle_s.clear()
        t_cmd, q_cmd, t_meas, q_meas = [], [], [], []
        t0 = time.monotonic()
        seen = None
        while (now := time.monotonic()) - t0 < duration:
            q = list(q0)
            q[1] = -1.2 + 0.3 * math.sin(2 * math.pi * (now - t0) / 4.0)
            bridge.send(JointCommand(seq=0, t=now, q=tuple(q)))
            t_cmd.append(now)
            q_cmd.append(bridge.last_sent_q[1])
            st = bridge.joint_state()
            if st is not None and st.seq != seen:
                seen = st.seq
                t_meas.append(now)
                q_meas.append(st.q[1])
            time.sleep(0.05)
        cycles = list(bridge.cycle_s)
        sent = [c for _, _, c in ctl.received[start_cmds:]]
        replies = ctl.replies[start_rx:]
        n_cycles = max(1, len(cycles))
        line_bytes = sum(len(c) for c in sent) + sum(len(r) for r in replies)
        phys_cycle_ms = (line_bytes / LINE_BYTES_PER_S + len(sent) * bridge.spacing_s) / n_cycles * 1e3
        lag = _lag_ms(t_cmd, q_cmd, t_meas, q_meas)
    finally:
        bridge.shutdown()
        emu.stop()
    rt_min_ms = 4 / LINE_BYTES_PER_S * 1e3
    per_cycle = len(sent) / n_cycles
    return [
        _row("rtx: 9600-baud minimum, 1 B command + 3 B reply", "ms", [rt_min_ms],
             extra="4 bytes × 10 bits / 9600 baud"),
        _row("rtx: command round trip, emulated line", "ms", rtt, baseline="rtx: 9600-baud minimum, 1 B command + 3 B reply",
             extra="IM_READ_CP, bridge write → whole reply (pty)"),
        _row("rtx: same cycle's commands at 9600 baud + 8 ms spacing", "ms", [phys_cycle_ms],
             extra=f"{per_cycle:.0f} commands a cycle"),
        _row("rtx: I/O cycle (targets, GO, read back), emulated", "ms", [c * 1e3 for c in cycles],
             baseline="rtx: same cycle's commands at 9600 baud + 8 ms spacing",
             extra=f"{per_cycle:.0f} commands a cycle, {n_cycles} cycles"),
        _row("rtx: read-back lag behind the command (sine)", "ms", [lag],
             extra="shoulder ±0.3 rad, 4 s period, emulated arm at real speed"),
    ]


if __name__ == "__main__":
    for r in rows(quick=True):
        s = np.asarray(r["samples"], dtype=float)
        print(f"{r['name']:56s} {np.median(s):9.2f} {np.percentile(s, 95):9.2f} {r['unit']}  {r['extra']}")
