"""RtxBridge over a pseudo-terminal against the emulated RTX: handshake, each command's bytes,
pacing, the encoder initialisation (refused motion before it, STOP during it), every injected
fault, the emulator program killed and restarted, and random goals that never leave the limits."""
from __future__ import annotations

import math
import os
import queue
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.devices import open_bridge
from core.devices import rtx_protocol as p
from core.devices.bridge import BridgeError, parse_bridge_url, parse_rtx_url, split_bridge_url
from core.devices.rtx_bridge import InitCancelled, RtxBridge, counts_within_limits, safe_counts
from core.devices.rtx_emulator import RtxEmulator
from core.kinematics import umi_rtx as k
from core.kinematics.profile import load_profile
from core.messages import JointCommand
from core.motion.safety import is_within_limits

SPEEDUP = 60.0  # the emulated arm moves this much faster: an initialisation takes a few seconds
TIMEOUT_S = 30.0  # generous: a loaded 2-core machine must not fail these
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def profile():
    return load_profile("umi_rtx")


@pytest.fixture
def emulator():
    emu = RtxEmulator(time_scale=SPEEDUP)
    emu.start()
    yield emu
    emu.stop()


@pytest.fixture
def bridge(emulator, profile):
    b = RtxBridge("rtx:" + emulator.path, profile)
    yield b
    b.shutdown()


@pytest.fixture(scope="module")
def ready():
    """A connected, initialised bridge on its own emulator (shared: one initialisation)."""
    emu = RtxEmulator(time_scale=SPEEDUP)
    emu.start()
    b = RtxBridge("rtx:" + emu.path, load_profile("umi_rtx"))
    b.connect()
    b.initialise()
    yield b, emu.controller
    b.shutdown()
    emu.stop()


def commands(ctl, start: int = 0) -> list[bytes]:
    return [c for _, _, c in ctl.received[start:]]


def cmd(q, seq=1):
    return JointCommand(seq=seq, t=0.0, q=tuple(q))


def moved(bridge, q_goal, tol=0.01, timeout=TIMEOUT_S):
    """Wait until the read-back joints are within ``tol`` of the joint values sent."""
    target = bridge.last_sent_q
    return bridge.wait_for_state(timeout, lambda s: max(abs(a - b) for a, b in zip(s.q, target)) < tol)


# ------------------------------------------------------------------------------ URLs

def test_rtx_urls_parse_and_name_what_is_wrong(emulator):
    assert split_bridge_url("rtx:sim") == ("rtx", "sim") and parse_bridge_url("rtx:sim") == "rtx"
    assert split_bridge_url("rtx:" + emulator.path) == ("rtx", emulator.path)
    assert parse_rtx_url("rtx:sim?speedup=20&init=auto").speedup == 20.0
    assert parse_rtx_url("rtx:/dev/ttyUSB0?init=auto").auto_init
    with pytest.raises(ValueError, match="speedup= is for rtx:sim only"):
        parse_rtx_url("rtx:/dev/ttyUSB0?speedup=3")
    with pytest.raises(ValueError, match="unknown option 'baud'"):
        parse_rtx_url("rtx:sim?baud=9600")
    with pytest.raises(ValueError, match="no port"):
        parse_rtx_url("rtx:")


def test_the_bridge_drives_the_umi_rtx_only():
    with pytest.raises(BridgeError, match="use --robot umi_rtx"):
        RtxBridge("rtx:sim", load_profile("desk_rrr"))


# ------------------------------------------------------------------------------ handshake

def test_handshake_is_the_drivers_sequence_and_a_restarted_controller_needs_initialising(bridge, emulator):
    bridge.connect()
    seq = commands(emulator.controller)
    # TOGGLE_OFF, IDENTIFY → restarted, GO, IDENTIFY; TOGGLE_ONCE; the same on the other chip; VERSION
    assert seq[:10] == [b"\x28", b"\x01", b"\x00", b"\x01", b"\x29", b"\x28", b"\x01", b"\x00", b"\x01", b"\x38"]
    chips = [ip for _, ip, _ in emulator.controller.received[:10]]
    assert chips == [0, 0, 0, 0, 0, 1, 1, 1, 1, 1]
    assert not bridge.ready and "restarted" in bridge.status().message
    assert bridge.version == 0x0105


def test_a_reconnect_redoes_the_handshake_and_keeps_the_initialisation(ready):
    bridge, ctl = ready
    bridge.disconnect()
    start = len(ctl.received)
    bridge.connect()
    seq = commands(ctl, start)
    assert seq[:6] == [b"\x28", b"\x01", b"\x29", b"\x28", b"\x01", b"\x38"]  # no restart this time
    assert bridge.ready and "ready" in bridge.status().message
    bridge.send(cmd(bridge.profile.q_home))
    assert moved(bridge, bridge.profile.q_home) is not None


def test_a_silent_port_is_no_answer_from_the_controller(bridge, emulator):
    emulator.controller.no_answer(None)
    with pytest.raises(BridgeError, match="no answer from the RTX controller"):
        bridge.connect()
    assert not bridge.is_connected


# ------------------------------------------------------------------------------ initialisation

def test_motion_is_refused_before_the_initialisation_with_the_reason(bridge, emulator):
    bridge.connect()
    before = len(emulator.controller.received)
    assert bridge.send(cmd(bridge.profile.q_home)) == ()
    assert bridge.last_sent_q is None and bridge.joint_state() is None
    # the I/O thread polls the status while waiting; wait for a few of those, then look
    assert bridge.wait_for_state(0.5) is None
    sent = commands(emulator.controller, before)
    assert not [c for c in sent if c[0] in (p.CMD_DEF_WRITE1, p.CMD_DIR_MAN) or c[0] & 0xE0 == p.CMD_DIR_NUM]
    assert "not initialised" in bridge.status().message or "restarted" in bridge.status().message
    with pytest.raises(BridgeError, match="re-arm before initialising"):
        bridge.estop()
        bridge.initialise()


def test_initialisation_reaches_every_end_stop_writes_the_limits_and_reports_each_joint(bridge, emulator):
    bridge.connect()
    events = []
    assert bridge.initialise(progress=events.append) is True
    joints = {e.joint for e in events if e.joint and e.fraction == 1.0}
    assert joints == {"column", "gripper", "wrist_roll", "wrist_pitch", "shoulder", "elbow", "wrist_yaw"}
    assert events[-1].done and events[-1].ok
    # the counts now mean the driver's joint angles: the arm is at the post-init pose in both frames
    readings = emulator.controller.readings()
    true = emulator.controller.true_positions()
    for m in (p.SHOULDER, p.ELBOW, p.YAW, p.WRIST1, p.WRIST2):
        assert readings[m] == pytest.approx(0, abs=2) and true[m] == pytest.approx(0, abs=2)
    assert readings[p.ZED] == pytest.approx(-18, abs=2) and true[p.ZED] == pytest.approx(-18, abs=2)
    # the limits were written as counts at the stops (IM_WRITE_CP), e.g. the elbow's −2629
    writes = [c for c in commands(emulator.controller) if c[0] & 0xF8 == p.CMD_IM_WRITE_CP]
    assert p.write_position(0, k.INIT_STOP_COUNTS["ELBOW"]) in writes
    assert bridge.ready and bridge.joint_state() is not None or bridge.wait_for_state(TIMEOUT_S) is not None


def test_stop_during_the_initialisation_stops_every_motor_and_ends_it(bridge, emulator):
    bridge.connect()
    driving = threading.Event()
    outcome: "queue.Queue[object]" = queue.Queue()

    def progress(ev):
        if ev.joint == "column" and 0 < ev.fraction < 1:
            driving.set()

    def run():
        try:
            outcome.put(bridge.initialise(progress=progress))
        except BaseException as exc:  # noqa: BLE001 - handed to the test thread
            outcome.put(exc)

    worker = threading.Thread(target=run)
    worker.start()
    assert driving.wait(TIMEOUT_S)
    bridge.estop()
    worker.join(TIMEOUT_S)
    assert isinstance(outcome.get_nowait(), InitCancelled)
    ctl = emulator.controller
    stops = [(ip, c) for _, ip, c in ctl.received if c == p.stop(p.StopMode.DEAD)]
    assert {ip for ip, _ in stops[-2:]} == {p.IP0, p.IP1}  # both chips got DEAD_STOP
    assert not any(ax.busy for ax in ctl.axes.values())
    assert not bridge.ready and "stopped before it finished" in bridge.init_reason
    assert bridge.send(cmd(bridge.profile.q_home)) == ()  # still refused (e-stopped, not initialised)


# ------------------------------------------------------------------------------ motion, bytes, pacing

def test_a_move_writes_new_positions_then_go_and_reads_every_motor_back(ready):
    bridge, ctl = ready
    q = list(bridge.profile.q_home)
    bridge.send(cmd(q))
    assert moved(bridge, q) is not None
    q[1] = 0.3  # then the shoulder only
    start = len(ctl.received)
    bridge.send(cmd(q))
    assert moved(bridge, q) is not None
    seq = commands(ctl, start)
    shoulder = bridge.last_sent_counts["SHOULDER"]
    assert shoulder == k.angle_deg_to_ticks("SHOULDER", math.degrees(0.3))
    i = seq.index(p.write_param(1, shoulder))
    assert seq[i - 1] == p.select_write(p.Param.NEW_POSITION)
    writes = [c for c in seq if c[0] & 0xF8 == p.CMD_DEF_WRITE2]
    assert writes == [p.write_param(1, shoulder)]  # only the motor whose target changed
    assert p.numeric_go([1]) in seq[i:]  # GO with the shoulder's bit on IP1
    for ctl_no in (0, 1, 2, 3):  # IP1's arm motors, and IP0's wrist: position and error read
        assert p.read_position(ctl_no) in seq and p.read_error(ctl_no) in seq
    assert p.general_status() in seq


def test_no_two_commands_reach_the_controller_closer_than_the_drivers_8_ms(ready):
    bridge, ctl = ready
    q = list(bridge.profile.q_home)
    q[2] = 2.0
    bridge.send(cmd(q))
    assert moved(bridge, q) is not None
    times = [t for t, _, _ in ctl.received]
    assert len(times) > 200
    gaps = sorted(b - a for a, b in zip(times, times[1:]))
    # the emulator judges each command by the window the host could have written it in (arrivals
    # bunch when a loaded host delays the pty, not the bridge): none was certainly closer than 8 ms
    assert ctl.spacing_violations == 0
    assert gaps[len(gaps) // 2] >= p.COMMAND_SPACING_S  # and the typical arrival gap is the driver's spacing


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.floats(-10, 10)),
                min_size=6, max_size=6))
def test_random_goals_never_put_a_count_outside_the_limits_on_the_wire(ready, goal):
    bridge, ctl = ready
    counts, q_sent = safe_counts(goal, bridge.profile)
    assert counts_within_limits(counts) and is_within_limits(q_sent, bridge.profile)
    start = len(ctl.position_writes)
    bridge.send(cmd(goal))
    assert bridge.wait_for_state(TIMEOUT_S) is not None and bridge.wait_for_state(TIMEOUT_S) is not None
    written = dict(ctl.position_writes[start:])
    by_name = {p.MOTOR_NAMES[m]: v for m, v in written.items()}
    assert counts_within_limits({**bridge.last_sent_counts, **by_name})
    assert all(by_name[n] == bridge.last_sent_counts[n] for n in by_name)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=6, max_size=6))
def test_safe_counts_are_inside_every_limit_for_any_goal(goal):
    profile = load_profile("umi_rtx")
    counts, q_sent = safe_counts(goal, profile)
    assert counts_within_limits(counts)
    assert is_within_limits(q_sent, profile)


# ------------------------------------------------------------------------------ faults

def test_an_unanswered_command_is_resynchronised_and_motion_goes_on(ready):
    bridge, ctl = ready
    resyncs = bridge.resyncs
    ctl.no_answer(1)
    q = list(bridge.profile.q_home)
    q[0] = 0.5
    bridge.send(cmd(q))
    assert moved(bridge, q) is not None
    assert bridge.resyncs > resyncs and bridge.no_answers >= 1 and bridge.is_connected


def test_a_garbage_reply_is_resynchronised_and_motion_goes_on(ready):
    bridge, ctl = ready
    resyncs = bridge.resyncs
    ctl.garbage(1)
    q = list(bridge.profile.q_home)
    q[0] = 0.4
    bridge.send(cmd(q))
    assert moved(bridge, q) is not None
    assert bridge.resyncs > resyncs and bridge.is_connected


def test_a_silent_controller_loses_the_link_and_a_reconnect_does_the_handshake(bridge, emulator):
    bridge.connect()
    emulator.controller.no_answer(None)
    assert bridge.wait_disconnected(TIMEOUT_S)
    assert "does not answer" in bridge.status().message
    emulator.controller.clear_faults()
    start = len(emulator.controller.received)
    bridge.connect()
    assert commands(emulator.controller, start)[:2] == [b"\x28", b"\x01"]


def test_a_restart_mid_session_is_noticed_and_motion_refused_until_initialised(ready):
    bridge, ctl = ready
    ctl.restart()
    q = list(bridge.profile.q_home)
    bridge.send(cmd(q))
    # the next command meets the restarted chip
    deadline = threading.Event()
    for _ in range(int(TIMEOUT_S / 0.02)):
        if not bridge.ready:
            break
        deadline.wait(0.02)
    assert not bridge.ready and "restarted" in bridge.init_reason
    assert bridge.send(cmd(q)) == () and "restarted" in bridge.status().message
    bridge.initialise()  # put the shared bridge back
    assert bridge.ready


def test_an_end_stop_hit_stops_every_motor_and_names_the_motor(ready):
    bridge, ctl = ready
    q = list(bridge.profile.q_home)
    bridge.send(cmd(q))
    assert moved(bridge, q) is not None
    ctl.obstacle(p.ELBOW)
    q2 = list(q)
    q2[2] = q[2] - 0.8
    bridge.send(cmd(q2))
    for _ in range(int(TIMEOUT_S / 0.02)):
        if bridge.is_estopped:
            break
        threading.Event().wait(0.02)
    assert bridge.is_estopped and "ELBOW" in bridge.fault
    last = [(ip, c) for _, ip, c in ctl.received if c == p.stop(p.StopMode.DEAD)][-2:]
    assert {ip for ip, _ in last} == {p.IP0, p.IP1}
    assert "ELBOW" in bridge.status().message
    ctl.clear_faults()
    bridge.rearm()
    bridge.send(cmd(q))
    assert moved(bridge, q) is not None and bridge.fault == ""


# ------------------------------------------------------------------------------ rtx:sim and the program

def test_rtx_sim_is_an_emulated_rtx_over_a_pty_pair(profile):
    bridge = open_bridge("rtx:sim?speedup=60", profile)
    try:
        assert isinstance(bridge, RtxBridge)
        bridge.connect()
        assert bridge.emulator is not None and os.path.exists(bridge.emulator.path)
        assert bridge.initialise()
        bridge.send(cmd(profile.q_home))
        assert moved(bridge, profile.q_home) is not None
        assert bridge.set_gripper_mm(30.0) == k.gripper_mm_to_ticks(30.0)
    finally:
        bridge.shutdown()


class EmulatorProgram:
    """``python -m core.devices.rtx_emulator --pty`` as a child process."""

    def __init__(self, *args: str):
        self.proc = subprocess.Popen([sys.executable, "-m", "core.devices.rtx_emulator", "--pty", *args],
                                     cwd=ROOT, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        self.lines: "queue.Queue[str]" = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()
        first = self.lines.get(timeout=TIMEOUT_S)
        assert first.startswith("PORT "), first
        self.path = first.split(" ", 1)[1]

    def _read(self):
        for line in self.proc.stdout:
            self.lines.put(line.rstrip("\n"))

    def say(self, line: str) -> str:
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        return self.lines.get(timeout=TIMEOUT_S)

    def kill(self):
        self.proc.kill()
        self.proc.wait(TIMEOUT_S)

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(TIMEOUT_S)


def test_the_emulator_program_killed_and_restarted_is_the_same_arm_behind_a_replugged_cable(tmp_path, profile):
    link, state = str(tmp_path / "rtx"), str(tmp_path / "state.json")
    args = ("--link", link, "--state", state, "--time-scale", str(SPEEDUP))
    prog = EmulatorProgram(*args)
    bridge = RtxBridge("rtx:" + link, profile)
    try:
        assert os.path.realpath(link) == prog.path
        bridge.connect()
        bridge.initialise()
        q = list(profile.q_home)
        q[1] = -1.0
        bridge.send(cmd(q))
        assert moved(bridge, q) is not None
        assert prog.say("garbage 1") == "OK garbage 1"
        prog.kill()  # kill -9: no goodbye
        assert bridge.wait_disconnected(TIMEOUT_S)
        prog = EmulatorProgram(*args)
        bridge.connect()  # the handshake again, on the new pty behind the same link
        assert bridge.ready  # no restart seen: the encoders are still valid
        state_now = bridge.wait_for_state(TIMEOUT_S)
        assert state_now is not None and abs(state_now.q[1] - (-1.0)) < 0.01
        q[1] = -0.5
        bridge.send(cmd(q))
        assert moved(bridge, q) is not None
    finally:
        bridge.shutdown()
        prog.stop()


def test_init_auto_reinitialises_a_power_cycled_controller_after_a_reconnect_without_blocking(emulator, profile):
    bridge = RtxBridge(f"rtx:{emulator.path}?init=auto", profile)
    try:
        bridge.connect()  # the first connect initialises before it returns
        assert bridge.ready
        bridge.disconnect()
        emulator.controller.restart()  # power cycle while unplugged
        bridge.connect()  # sees the restart; returns at once, the I/O thread initialises
        assert not bridge.ready and bridge.restarts_seen == 2  # (the I/O thread may have begun)
        assert bridge.wait_for_state(TIMEOUT_S * 2) is not None and bridge.ready
        bridge.send(cmd(profile.q_home))
        assert moved(bridge, profile.q_home) is not None
    finally:
        bridge.shutdown()
