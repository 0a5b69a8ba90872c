"""The firmware built for an ATmega328P (Arduino Uno/Nano) and run in simavr, pins measured.

``make -C firmware avr`` builds the image avrdude would flash (build/avr/deskarm.hex) with
Debian's gcc-avr; ``make -C firmware avr-sim`` builds firmware/sim/avr_harness, which runs
that .hex in libsimavr with USART0 on a pseudo-terminal and prints every servo pulse it
measures on the emulated pins D9, D10, D11 (tests/avr_board.py reads them). The same
src/*.c logic as host_firmware, only the hardware layer (hal_avr.c) differs, so these tests
mirror tests/devices/test_firmware_host.py — but the pulse widths here are pin edges 1/16 µs
apart, not the firmware's own print-outs.

The tools come from apt (gcc-avr avr-libc binutils-avr simavr libsimavr-dev libelf-dev
pkg-config); when they are missing and this runs as root with apt-get, the session installs
them; otherwise the tests skip saying so.
"""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from avr_board import PINS, AvrBoard, Off, Pulse, last_widths  # tests/ is on sys.path

from core.devices import protocol_v2 as p

ROOT = Path(__file__).resolve().parents[2]
FIRMWARE = ROOT / "firmware"
HARNESS = FIRMWARE / "build" / "avr" / "avr_harness"
HEX = FIRMWARE / "build" / "avr" / "deskarm.hex"
ELF = FIRMWARE / "build" / "avr" / "deskarm.elf"
AVR_PACKAGES = ["gcc-avr", "avr-libc", "binutils-avr", "simavr", "libsimavr-dev", "libelf-dev",
                "pkg-config"]
FLASH_BYTES = 32 * 1024 - 512  # the Uno's Optiboot bootloader keeps the top 512 bytes
RAM_BYTES = 2 * 1024
STACK_RESERVE = 512  # RAM left free for the stack (main loop + a STATUS reply under way)
TOL_US = 2.0


def _tools_missing() -> list[str]:
    missing = [tool for tool in ("make", "gcc", "avr-gcc", "avr-objcopy", "avr-size", "pkg-config")
               if shutil.which(tool) is None]
    if shutil.which("pkg-config") is not None and subprocess.run(
            ["pkg-config", "--exists", "simavr"]).returncode != 0:
        missing.append("libsimavr (pkg-config simavr)")
    return missing


def _install_avr_tools() -> str:
    """apt-get install the AVR tool chain and simavr; '' on success, else why not."""
    if shutil.which("apt-get") is None:
        return "no apt-get here"
    if os.geteuid() != 0:
        return "not root, so apt-get cannot install them"
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    install = ["apt-get", "install", "-y", "--no-install-recommends", *AVR_PACKAGES]
    done = subprocess.run(install, capture_output=True, text=True, env=env, timeout=900)
    if done.returncode != 0:  # a fresh machine may not have package lists yet
        subprocess.run(["apt-get", "update"], capture_output=True, env=env, timeout=900)
        done = subprocess.run(install, capture_output=True, text=True, env=env, timeout=900)
    return "" if done.returncode == 0 else f"apt-get install failed: {done.stderr.strip()[-300:]}"


@pytest.fixture(scope="session")
def avr_size_report() -> str:
    """Build the ATmega328P image and the simavr harness once; avr-size's report."""
    missing = _tools_missing()
    if missing:
        why = _install_avr_tools()
        missing = _tools_missing()
        if missing:
            pytest.skip(f"{', '.join(missing)} missing and not installable ({why}): "
                        f"apt-get install {' '.join(AVR_PACKAGES)}")
    done = subprocess.run(["make", "-s", "-C", str(FIRMWARE), "avr", "avr-sim"],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, f"make -C firmware avr avr-sim failed:\n{done.stdout}\n{done.stderr}"
    return done.stdout


@pytest.fixture
def avr(avr_size_report):
    """The .hex running in simavr (tests/avr_board.AvrBoard), stopped after the test."""
    b = AvrBoard(HARNESS, HEX)
    try:
        yield b
    finally:
        assert b.stop() == 0, "avr_harness should exit 0 on SIGTERM"


def _assert_pulses(pulses: list[Pulse], width_us: float) -> None:
    widths = [q.width_us for q in pulses]
    periods = [q.period_us for q in pulses if q.period_us > 0]
    assert all(abs(w - width_us) <= TOL_US for w in widths), f"{pulses[0].pin}: {widths}"
    assert periods and all(abs(t - 20000.0) <= TOL_US for t in periods), f"{pulses[0].pin}: {periods}"


def test_avr_build_fits_the_atmega328p_and_makes_a_flashable_hex(avr_size_report):
    program = int(re.search(r"Program:\s+(\d+) bytes", avr_size_report).group(1))
    data = int(re.search(r"Data:\s+(\d+) bytes", avr_size_report).group(1))
    print(f"\nATmega328P: flash {program} bytes of {FLASH_BYTES}, RAM {data} bytes of {RAM_BYTES}")
    assert 0 < program <= FLASH_BYTES
    assert 0 < data <= RAM_BYTES - STACK_RESERVE
    lines = HEX.read_text().split()
    assert lines[0].startswith(":") and lines[-1] == ":00000001FF"  # Intel HEX, ends with EOF
    assert "avrdude -p m328p" in avr_size_report


@pytest.mark.parametrize("image", [HEX, ELF], ids=["hex", "elf"])
def test_v1_home_command_gives_900_1800_1800_us_at_50_hz_on_the_pins(avr_size_report, image):
    b = AvrBoard(HARNESS, image)
    try:
        # a board nobody has commanded keeps its servos limp: no pulse for a whole emulated second
        before = b.read_until(lambda seen: len(b.clocks) >= 1, what="the first CLOCK line")
        assert not [ev for ev in before if isinstance(ev, Pulse)]
        port = b.open()
        port.write(bytes.fromhex("FB 00 FC 5A FD 5A"))  # PROTOCOL.md v1: joint 1 0°, 2 and 3 90°
        b.wait_widths(900, 1800, 1800)
        pulses = b.collect(20)
        for pin, width in zip(PINS, (900, 1800, 1800)):
            _assert_pulses(pulses[pin], width)
        print(f"\nmeasured: " + ", ".join(
            f"{pin} {min(q.width_us for q in v):.4f}–{max(q.width_us for q in v):.4f} µs, period "
            f"{min(q.period_us for q in v):.4f}–{max(q.period_us for q in v):.4f} µs"
            for pin, v in pulses.items()))
    finally:
        assert b.stop() == 0


def test_v2_set_joints_jumps_then_ramps_36_us_per_pulse_on_the_pins(avr):
    port = avr.open()
    port.write(p.encode_set_joints(avr.next_seq(), [90, 90, 90]))
    avr.wait_widths(1800, 1800, 1800)
    port.write(p.encode_set_joints(avr.next_seq(), [120, 90, 60]))
    seen = avr.wait_widths(2100, 1800, 1500)
    # default 180°/s at 50 Hz: 3.6° = 36 µs per 20 ms pulse, up on D9, down on D11
    d9 = [q.width_us for q in seen if isinstance(q, Pulse) and q.pin == "D9"]
    d11 = [q.width_us for q in seen if isinstance(q, Pulse) and q.pin == "D11"]
    ramp9 = [w for w in d9 if w > 1800 + TOL_US]
    ramp11 = [w for w in d11 if w < 1800 - TOL_US]
    assert ramp9 == pytest.approx([min(1800 + 36 * k, 2100) for k in range(1, 10)], abs=TOL_US)
    assert ramp11 == pytest.approx([max(1800 - 36 * k, 1500) for k in range(1, 10)], abs=TOL_US)
    assert all(abs(q.width_us - 1800) <= TOL_US for q in seen if isinstance(q, Pulse) and q.pin == "D10")
    reply = avr.status(port)
    assert reply.flags == p.Flag.V2_MODE  # arrived: no longer MOVING
    assert reply.pulses_us == (2100, 1800, 1500)


def test_v2_watchdog_holds_the_pulses_500_ms_after_the_host_goes_silent(avr):
    port = avr.open()
    port.write(p.encode_config(avr.next_seq(), p.CONFIG_ALL_JOINTS, 900, 2700, 20))
    port.write(p.encode_set_joints(avr.next_seq(), [0, 0, 0]))
    avr.wait_widths(900, 900, 900)
    port.write(p.encode_set_joints(avr.next_seq(), [180, None, None]))  # 9 s away at 20°/s
    # then silence: read 1.5 s of emulated D9 pulses
    d9: list[Pulse] = []

    def enough(seen):
        if seen and isinstance(seen[-1], Pulse) and seen[-1].pin == "D9":
            d9.append(seen[-1])
        return bool(d9) and any(q.width_us > 900 + TOL_US for q in d9) and \
            d9[-1].t_us - next(q for q in d9 if q.width_us > 900 + TOL_US).t_us > 1_500_000
    seen = avr.read_until(enough, what="1.5 s of D9 pulses after the ramp started")
    assert not [ev for ev in seen if isinstance(ev, Off)], "the watchdog holds: pulses go on"
    ramp = [q for q in d9 if q.width_us > 900 + TOL_US]
    changes = [q for a, q in zip(ramp, ramp[1:]) if abs(q.width_us - a.width_us) > TOL_US]
    steps = [round(b.width_us - a.width_us) for a, b in zip(ramp, ramp[1:]) if b in changes]
    assert set(steps) == {4}, f"0.4° = 4 µs per pulse while ramping, got {steps}"
    moving_for_us = changes[-1].t_us - ramp[0].t_us
    held = ramp[-1].width_us
    print(f"\nramp moved for {moving_for_us / 1000:.0f} ms ({len(changes) + 1} pulses), "
          f"then held {held:.4f} µs")
    # 500 ms watchdog = 25 ticks after the last frame: the width changes on 24-26 pulses
    assert 23 <= len(changes) + 1 <= 26
    assert 900 < held < 2700
    assert all(abs(q.width_us - held) <= TOL_US for q in ramp if q.t_us > changes[-1].t_us)
    assert all(abs(q.period_us - 20000) <= TOL_US for q in ramp)
    reply = avr.status(port)
    assert p.Flag.WATCHDOG in reply.flags and p.Flag.MOVING not in reply.flags
    assert reply.pulses_us[0] == pytest.approx(held, abs=TOL_US)
    # a new SET_JOINTS clears the flag and the pulse moves on from where it held
    port.write(p.encode_set_joints(avr.next_seq(), [180, None, None]))
    avr.wait_widths(held + 4, 900, 900)
    assert p.Flag.WATCHDOG not in avr.status(port).flags


def test_v2_estop_stops_the_pulses_on_the_pins_until_arm(avr):
    port = avr.open()
    port.write(p.encode_set_joints(avr.next_seq(), [90, 45, 0]))
    avr.wait_widths(1800, 1350, 900)
    port.write(p.encode_estop(avr.next_seq()))
    stopped = avr.read_until(lambda seen: {e.pin for e in seen if isinstance(e, Off)} == set(PINS),
                             what="OFF on every pin")
    off_at = max(e.t_us for e in stopped if isinstance(e, Off))
    # a SET_JOINTS while e-stopped moves nothing, and the pins stay low
    port.write(p.encode_set_joints(avr.next_seq(), [10, 10, 10]))
    reply = avr.status(port)
    assert reply.pulses_us == (0, 0, 0) and p.Flag.ESTOP in reply.flags
    port.write(p.encode_arm(avr.next_seq()))
    resumed = avr.wait_widths(1800, 1350, 900)
    pulses = [e for e in resumed if isinstance(e, Pulse)]
    first = pulses[0]
    assert first.t_us - off_at > 20000, "the pins stayed low for at least a frame"
    assert all(abs(q.width_us - w) <= TOL_US for q in pulses
               for pin, w in zip(PINS, (1800, 1350, 900)) if q.pin == pin), \
        f"after ARM the pulses come back where they were held, never at the ignored 10°: {pulses}"
    assert p.Flag.ESTOP not in avr.status(port).flags


def _headless(bridge: str, seconds: int) -> dict:
    done = subprocess.run(
        [sys.executable, "-m", "app.cli", "--headless", "--camera", "sim", "--scenario", "wander",
         "--bridge", bridge, "--duration", str(seconds), "--json"],
        capture_output=True, text=True, timeout=seconds + 120, cwd=ROOT,
    )
    assert done.returncode == 0, f"deskarm --headless failed:\n{done.stderr[-2000:]}"
    return json.loads(done.stdout)


@pytest.mark.parametrize("protocol,seconds", [("v2", 10), ("v1", 5)])
def test_deskarm_bridge_drives_the_emulated_board(avr, avr_size_report, protocol, seconds):
    result = _headless(f"{protocol}:{avr.path}", seconds)
    moved = []  # what was measured on the pins during the run
    while not avr.events.empty():
        moved.append(avr.next_event())
    pulses = [e for e in moved if isinstance(e, Pulse)]
    print(f"\n{protocol}: {json.dumps({k: result[k] for k in ('commands_sent', 'limit_violations', 'bridge_disconnects', 'latency_ms_p50', 'latency_ms_p95')})}; "
          f"emulated/wall time {avr.speed_ratio() or 0:.3f}; {len(pulses)} pulses measured")
    assert result["limit_violations"] == 0
    assert result["bridge_disconnects"] == 0
    assert result["commands_sent"] > 0
    for pin in PINS:
        widths = {round(q.width_us) for q in pulses if q.pin == pin}
        assert len(widths) > 5, f"{pin} should follow the arm's moves, saw widths {sorted(widths)}"
        assert all(400 - TOL_US <= w <= 3000 + TOL_US for w in widths)
        odd = [q for q in pulses if q.pin == pin and q.period_us > 0 and abs(q.period_us - 20000) > TOL_US]
        assert not odd, f"{pin}: periods off 20 ms: {odd[:5]}"
    if protocol == "v2":
        assert p.Flag.V2_MODE in avr.status(avr.open()).flags
    assert last_widths(moved), "the pins were still pulsing at the end"
    # RAM: the static data plus the deepest the stack went during the run, measured in simavr
    assert avr.stop() == 0
    static = int(re.search(r"Data:\s+(\d+) bytes", avr_size_report).group(1))
    print(f"RAM: {static} bytes static + {avr.stack_bytes} bytes of stack at most, of {RAM_BYTES}")
    assert avr.stack_bytes is not None and static + avr.stack_bytes <= RAM_BYTES - 256


def test_msp430_build_without_a_compiler_fails_saying_what_to_install():
    if shutil.which("make") is None:
        pytest.skip("make is needed")
    done = subprocess.run(["make", "-C", str(FIRMWARE), "msp430", "MSP430_CC="],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode != 0
    assert "no MSP430 cross compiler found" in done.stderr
    assert "No firmware image was built" in done.stderr
    assert "MSP430-GCC" in done.stderr
