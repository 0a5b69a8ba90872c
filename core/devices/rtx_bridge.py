"""The UMI-RTX over its own controller's RS-232 line: ``rtx:/dev/ttyUSB0`` (or ``rtx:sim``).

``RtxBridge`` is a ``MotorBridge`` for ``--robot umi_rtx``: the window, the headless runner, the
assistive loop, recording and the remote desk use it like any other bridge. The protocol (bytes,
codes, chips) is pure code in ``core.devices.rtx_protocol``; joint ↔ count conversions and the
differential wrist are in ``core.kinematics.umi_rtx``.

The line. pyserial, exclusive open, 9600 baud 8N1. Every command waits for its reply (100 ms
per byte, retried once, as the original driver) and the next command is written no sooner than
8 ms after that reply arrived — so the controller never sees two commands closer than the
driver's 8 ms spacing, whatever the line or the computer delays (the original counted the 8 ms
from its own previous write). The line is shared by the two chips; the bridge keeps toggling
off and hands the line over with TOGGLE_ONCE only when the next command is for the other chip.

Connect = the driver's handshake: TOGGLE_OFF (tried twice), IDENTIFY; a chip that answers
"restarted" gets GO and IDENTIFY again; TOGGLE_ONCE; the same on the other chip; both chips
must have answered with different numbers. A chip that had restarted means the encoder counts
are gone: the bridge then needs the initialisation again (it says so; it never re-initialises
without being asked — ``?init=auto`` in the URL is that consent, for unattended runs).

A wrong or garbled reply, or none, makes the bridge resynchronise (drop input until the line is
quiet, TOGGLE_OFF, IDENTIFY — which also tells which chip has the line) and retry the command (3
tries in all; the driver tried once, but a loaded host can miss a reply too); when the
controller stays silent the link is lost (BridgeError: the bridge worker and the headless runner
reconnect with backoff, and the reconnect does the handshake again).

Encoder initialisation (``initialise``), as ``umiinit.cpp`` does it: each joint is driven at low
speed into its end stop (the controller stops the motor when its following error exceeds the
error limit: that is the stop), the column first, then the gripper, the wrist (its two motors
against the roll and the pitch stops, twice), the shoulder, the elbow and yaw together; the
counts at the stops are written (``INIT_STOP_COUNTS``) and the arm goes to its post-init pose.
Progress is reported per joint; ``estop()`` (or the cancel event) stops every motor and ends it.
Until it has completed, ``send`` writes nothing and returns ``()``, and the status says why.

Motion: ``send`` clamps (profile limits, then the driver's count limits incl. the wrist's sum and
difference) and hands the target to the I/O thread, which writes NEW_POSITION for the motors whose
target changed and GO with their bits (a motor still moving answers "axis busy": GO is retried on
the next cycle), then reads every motor back (position − following error = measured) and each
chip's general status. A motor the controller stopped on its error limit (an end stop or an
obstacle) stops the whole arm (e-stop, with the motor named); re-arm to go on.

E-stop = DEAD_STOP to both chips, back to back (TOGGLE_ONCE between them): ~20 ms on the line.
"""
from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass
from typing import Callable, Mapping, Optional, Sequence

from core.devices import rtx_protocol as p
from core.devices.bridge import (
    RTX_PREFIX,
    BridgeError,
    MotorBridge,
    close_quietly,
    explain_serial_error,
    parse_rtx_url,
    serial_error_types,
)
from core.kinematics import umi_rtx as k
from core.messages import BridgeStatus, JointCommand, JointState
from core.motion.safety import clamp_to_limits

SPACING_MARGIN_S = 0.0005  # waited beyond the 8 ms, so clock granularity never makes it shorter
RESPONSE_TIMEOUT_S = p.READ_TIMEOUT_S  # per byte, tried twice (the driver's VTIME = 1, one retry)
SIM_RESPONSE_TIMEOUT_S = 0.5  # rtx:sim: the emulator shares this process (and its GIL) with the app
ATTEMPTS = 3  # a command (and a resynchronisation) is tried this often before the link counts as lost
MAX_COMMAND_HZ = 20.0  # targets are taken this often at most; the line does ~4 full cycles a second
IDLE_POLL_S = 0.3  # before initialisation: general status this often (a silent controller shows)
INIT_LEG_TIMEOUT_S = 240.0  # a joint that does not reach its end stop in this long fails the init
ARM_MOTORS = (p.ZED, p.SHOULDER, p.ELBOW, p.YAW, p.WRIST1, p.WRIST2)  # the profile's six joints
MOTOR_NAME = {m: p.MOTOR_NAMES[m] for m in range(7)}
INIT_JOINTS = ("column", "gripper", "wrist_roll", "wrist_pitch", "shoulder", "elbow", "wrist_yaw")
# counts a joint may have to travel to its stop (stop to stop), for the progress fraction
INIT_SPAN = {"column": 3550.0, "gripper": 1290.0, "wrist_roll": 8510.0, "wrist_pitch": 2802.0,
             "shoulder": 5310.0, "elbow": 4879.0, "wrist_yaw": 3894.0}
NOT_INITIALISED = ("not initialised — the encoders need the initialisation (each joint driven to its "
                   "end stops at low speed) before the arm may move")
# margins (counts) kept inside the limits, so that truncation and the wrist's two motors never
# put a count — or the joint value read back from it — outside
MARGIN_COUNTS = 2


class RtxReplyError(BridgeError):
    """The controller answered a command with an error code; the text says which and why."""

    def __init__(self, text: str, code: int):
        super().__init__(text)
        self.code = code


class InitCancelled(Exception):
    """The initialisation was stopped (STOP or cancel)."""


@dataclass(frozen=True)
class InitProgress:
    """One step of the encoder initialisation, for the window's bars and the CLI's lines."""

    joint: str  # one of INIT_JOINTS, or "" for the whole arm (start, limits, home, done)
    fraction: float  # this joint's progress, 0…1 (1 = its end stop found)
    text: str  # what is happening, in words
    fractions: tuple[tuple[str, float], ...] = ()  # every joint's progress so far
    done: bool = False  # the initialisation has finished (``ok`` says how)
    ok: bool = False


# ------------------------------------------------------------------------------ limits

def _limits_in_q(profile) -> list[tuple[float, float]]:
    """The profile's joint limits narrowed by the driver's count limits and a small margin."""
    out = []
    wrist_pitch_deg = tuple(v / (2.0 / k.DEG_PER_COUNT["WRIST1"]) for v in k.WRIST_SUM_LIMITS)
    wrist_roll_deg = tuple(v / (2.0 / k.DEG_PER_COUNT["WRIST1"]) for v in k.WRIST_DIFF_LIMITS)
    for name, joint in zip(k.JOINT_ORDER, profile.joints):
        lo, hi = float(joint.q_min), float(joint.q_max)
        if name == "column":
            c_lo, c_hi = k.SOFT_LIMIT_COUNTS["ZED"]
            d_lo = k.ticks_to_column_m(c_lo + MARGIN_COUNTS)
            d_hi = k.ticks_to_column_m(c_hi - MARGIN_COUNTS)
            step = MARGIN_COUNTS / k.COLUMN_TICKS_PER_M
        else:
            motor, per = {
                "shoulder": ("SHOULDER", k.DEG_PER_COUNT["SHOULDER"]),
                "elbow": ("ELBOW", k.DEG_PER_COUNT["ELBOW"]),
                "wrist_yaw": ("YAW", k.DEG_PER_COUNT["YAW"]),
                "wrist_roll": (None, k.DEG_PER_COUNT["WRIST1"]),
                "wrist_pitch": (None, k.DEG_PER_COUNT["WRIST1"]),
            }[name]
            if motor is not None:
                c_lo, c_hi = k.SOFT_LIMIT_COUNTS[motor]
                d_lo, d_hi = math.radians(c_lo * per), math.radians(c_hi * per)
            else:
                deg = wrist_roll_deg if name == "wrist_roll" else wrist_pitch_deg
                d_lo, d_hi = math.radians(deg[0]), math.radians(deg[1])
            step = math.radians(MARGIN_COUNTS * per)
        lo, hi = max(lo, d_lo) + step, min(hi, d_hi) - step
        if lo > hi:
            lo = hi = 0.5 * (lo + hi)
        out.append((lo, hi))
    return out


def counts_within_limits(counts: Mapping[str, int]) -> bool:
    """Do the six arm motors' targets respect the driver's limits (incl. the wrist's sum and
    difference)? The independent check the tests and the bridge's last guard use."""
    for motor, (lo, hi) in k.SOFT_LIMIT_COUNTS.items():
        if motor in counts and not lo <= counts[motor] <= hi:
            return False
    if "WRIST1" in counts or "WRIST2" in counts:
        w1, w2 = counts["WRIST1"], counts["WRIST2"]
        if not k.WRIST_SUM_LIMITS[0] <= w1 + w2 <= k.WRIST_SUM_LIMITS[1]:
            return False
        if not k.WRIST_DIFF_LIMITS[0] <= w1 - w2 <= k.WRIST_DIFF_LIMITS[1]:
            return False
    return all(isinstance(v, int) and p.WORD_MIN <= v <= p.WORD_MAX for v in counts.values())


def safe_counts(q: Sequence[float], profile, limits_q=None) -> tuple[dict[str, int], tuple[float, ...]]:
    """Encoder targets for ``q`` inside every limit, and the joint values they stand for.

    Clamp into the profile's limits (NaN → middle), then into the driver's (narrowed by a
    margin), convert, and check again; a target that still fails (it cannot, but this is the
    last guard before the wire) is replaced by the middle of the ranges.
    """
    limits_q = limits_q or _limits_in_q(profile)
    q_safe, _ = clamp_to_limits(q, profile)
    q_in = tuple(min(max(v, lo), hi) for v, (lo, hi) in zip(q_safe, limits_q))
    counts = k.q_to_motor_ticks(q_in)
    if not counts_within_limits(counts):  # pragma: no cover - the margins make this unreachable
        counts = k.q_to_motor_ticks(tuple(0.5 * (lo + hi) for lo, hi in limits_q))
    return counts, k.motor_ticks_to_q(counts)


# ------------------------------------------------------------------------------ the bridge

class RtxBridge(MotorBridge):
    """A UMI-RTX over RS-232 (see the module docstring)."""

    has_feedback = True
    max_command_hz = MAX_COMMAND_HZ

    def __init__(self, url: str, profile, clock=None, serial_factory: Optional[Callable[..., object]] = None, *,
                 spacing_s: float = p.COMMAND_SPACING_S + SPACING_MARGIN_S,
                 reply_timeout_s: float = RESPONSE_TIMEOUT_S, emulator_factory=None):
        text = url.strip()
        if not text.lower().startswith(RTX_PREFIX):
            text = RTX_PREFIX + text
        self.rtx_url = parse_rtx_url(text)  # ValueError naming what is wrong
        super().__init__(text, profile, clock)
        names = tuple(j.name for j in profile.joints)
        if names != k.JOINT_ORDER:
            raise BridgeError(f"rtx: drives the UMI-RTX only; profile {profile.name!r} has joints "
                              f"{', '.join(names)} — use --robot umi_rtx (or sim:// for this arm)")
        if spacing_s < p.COMMAND_SPACING_S:
            raise ValueError(f"spacing_s = {spacing_s}: the controller needs ≥ {p.COMMAND_SPACING_S} s between commands")
        self.spacing_s = float(spacing_s)
        if self.rtx_url.port is None and reply_timeout_s == RESPONSE_TIMEOUT_S:
            reply_timeout_s = SIM_RESPONSE_TIMEOUT_S
        self.reply_timeout_s = float(reply_timeout_s)
        self._factory = serial_factory
        self._emulator_factory = emulator_factory
        self.emulator = None  # rtx:sim: the RtxEmulator serving the pty (kept across reconnects)
        # where an initialisation that nobody called explicitly (?init=auto) reports its progress,
        # and where connect() says that motion waits for one (the headless runner's stderr)
        self.progress_sink: Optional[Callable[[InitProgress], None]] = None
        self.port_url = self.rtx_url.port
        self.limits_q = _limits_in_q(profile)

        self._line = threading.RLock()  # one transaction (command + reply) at a time
        self._lock = threading.Lock()  # the state below
        self._port = None
        self._connected = False
        self._current_ip: Optional[int] = None
        self._next_write_t = 0.0
        self.version: Optional[int] = None
        self.ready = False  # the encoders are initialised on this controller
        self.init_reason = NOT_INITIALISED  # why motion is refused ("" when ready)
        self.initialising = False
        self.init_progress: Optional[InitProgress] = None
        self.fault = ""  # a motor the controller stopped, or another reason the arm was stopped
        self.restarts_seen = 0
        self.resyncs = 0
        self.no_answers = 0
        self.reply_errors = 0
        self.line_commands = 0  # commands written on the line (all kinds)
        self._pending: Optional[dict[str, int]] = None  # newest target (counts) not yet written
        self._pending_source_t: Optional[float] = None
        self._written: dict[str, int] = {}  # NEW_POSITION the controller holds per motor
        self._to_go: set[str] = set()  # motors written but whose GO has not been accepted yet
        self._readback: Optional[dict[str, int]] = None
        self._readback_t: Optional[float] = None
        self._state: Optional[JointState] = None
        self.last_sent_q: Optional[tuple[float, ...]] = None
        self.last_sent_counts: Optional[dict[str, int]] = None
        self.cycle_s: list[float] = []  # duration of each I/O cycle (write + read back), for the bench
        self._thread: Optional[threading.Thread] = None
        self._stop = threading.Event()
        self._io_pause = threading.Event()  # set while the initialisation owns the line
        self._cancel_init = threading.Event()
        self._new_target = threading.Event()
        self._link_down = threading.Event()
        self._link_down.set()
        self._auto_init_due = False  # ?init=auto and the controller restarted: initialise again
        self._connected_before = False  # a later connect is a reconnect (?init=auto: not blocking)

    # ---------------------------------------------------------------- lifecycle

    @property
    def is_connected(self) -> bool:
        return self._connected

    def connect(self) -> None:
        """Open the port (rtx:sim: start the emulator first) and do the handshake.

        BridgeError with a plain message: permission denied, port busy, no such port, no answer
        (controller off, wrong cable, wrong baud rate), or answers that are not the RTX's.
        With ``?init=auto`` an arm that needs it is initialised before the first connect returns;
        on a reconnect to a restarted controller the I/O thread does it (motion waits, the caller
        does not).
        """
        if self._connected:
            return
        self._teardown()
        import serial

        port_url = self.port_url
        if self.rtx_url.port is None:
            if self.emulator is None:
                if self._emulator_factory is not None:
                    self.emulator = self._emulator_factory()
                else:
                    from core.devices.rtx_emulator import RtxEmulator

                    self.emulator = RtxEmulator(time_scale=self.rtx_url.speedup)
                self.emulator.start()
            port_url = self.emulator.path
        factory = self._factory or serial.serial_for_url
        try:
            port = factory(port_url, baudrate=p.BAUDRATE, bytesize=8, parity="N", stopbits=1,
                           timeout=self.reply_timeout_s, write_timeout=1.0, exclusive=True)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise BridgeError(explain_serial_error(self.url, exc)) from None
        with self._line:
            self._port = port
            try:
                restarted = self._handshake()
            except BridgeError:
                self._port = None
                close_quietly(port)
                raise
            except serial_error_types() as exc:
                self._port = None
                close_quietly(port)
                raise BridgeError(explain_serial_error(self.url, exc)) from None
        if restarted:
            self._lose_init("the controller restarted (power cycle or reset): its encoder positions are lost "
                            "— initialise again")
        first_connect, self._connected_before = not self._connected_before, True
        self._stop = threading.Event()
        self._connected = True
        self._link_down.clear()
        self.message = f"UMI-RTX controller, version {self.version:#06x}" if self.version is not None else "UMI-RTX"
        self._auto_init_due = False
        if not self.ready and not self.rtx_url.auto_init and self.progress_sink is not None:
            self.progress_sink(InitProgress(
                "", 0.0, f"{self.init_reason} — motion waits for it: add ?init=auto to the bridge URL or run "
                "deskarm rtx-init first", done=True))
        if self.rtx_url.auto_init and not self.ready and not self._estopped and not first_connect:
            self._auto_init_due = True  # a reconnect to a restarted controller: the I/O thread initialises
        elif self.rtx_url.auto_init and not self.ready and not self._estopped:
            try:
                self.initialise(progress=self.progress_sink)  # before the I/O thread: the line is ours
            except InitCancelled:
                pass
            except BridgeError:
                self._teardown()
                raise
        self._thread = threading.Thread(target=self._run, args=(self._stop,), daemon=True,
                                        name=f"deskarm RTX I/O {self.url}")
        self._thread.start()

    def disconnect(self) -> None:
        """Stop the I/O thread and close the port; safe twice. rtx:sim keeps its emulator (the same
        arm on the next connect) until ``shutdown()``."""
        was = self._connected
        self._cancel_init.set()
        self._teardown()
        if was:
            self.message = "disconnected"

    def shutdown(self) -> None:
        """Disconnect and, for rtx:sim, stop the emulated controller."""
        self.disconnect()
        if self.emulator is not None:
            self.emulator.stop()
            self.emulator = None

    def _teardown(self) -> None:
        self._stop.set()
        self._new_target.set()
        thread, self._thread = self._thread, None
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=5.0)
        with self._line:
            port, self._port = self._port, None
            self._connected = False
            self._link_down.set()
        if port is not None:
            close_quietly(port)

    def wait_disconnected(self, timeout: float) -> bool:
        """Block until the link is down (lost or closed); False after ``timeout`` s."""
        return self._link_down.wait(timeout)

    # ---------------------------------------------------------------- the line

    def _write_cmd(self, cmd: bytes) -> p.Reply:
        """Write one command (after the spacing) and read its whole reply.

        Raises _LineTrouble (no reply, garbage, short reply) and serial errors as they come.
        """
        port = self._port
        if port is None:
            raise BridgeError(f"{self.url}: not connected")
        wait = self._next_write_t - time.monotonic()
        if wait > 0:
            time.sleep(wait)  # the controller's 8 ms (the driver's usleep)
        port.write(cmd)
        self.line_commands += 1
        self.bytes_written += len(cmd)
        self.last_write_t = self.clock.now()
        try:
            first = port.read(1)
            if not first:
                first = port.read(1)  # the driver's one retry
            if not first:
                self.no_answers += 1
                raise _LineTrouble("no answer")
            b0 = first[0]
            if not p.is_known_reply_type(b0):
                raise _LineTrouble(f"reply 0x{b0:02X} is no RTX reply")
            need = p.reply_length(b0, cmd[0])
            data = bytearray(first)
            while len(data) < need:
                more = port.read(need - len(data))
                if not more:
                    more = port.read(need - len(data))
                    if not more:
                        raise _LineTrouble(f"reply {bytes(data).hex()} incomplete ({len(data)} of {need} bytes)")
                data += more
            return p.Reply(bytes(data))
        finally:
            self._next_write_t = time.monotonic() + self.spacing_s

    def _select(self, ip: int) -> None:
        if self._current_ip is None and not self._resync():
            raise _LineTrouble("the line's chip is unknown and IDENTIFY failed")
        if self._current_ip == ip:
            return
        reply = self._write_cmd(p.toggle_once())
        if reply.first != p.RESP_ACK:
            raise _LineTrouble(f"TOGGLE_ONCE answered 0x{reply.first:02X}")
        self._current_ip = ip

    def _raw(self, ip: int, cmd: bytes) -> p.Reply:
        """One command to chip ``ip``; on line trouble resynchronise and retry (``ATTEMPTS`` in all);
        link errors become BridgeError. Error replies are returned, not raised."""
        with self._line:
            try:
                for attempt in range(ATTEMPTS):
                    try:
                        self._select(ip)
                        return self._write_cmd(cmd)
                    except _LineTrouble as trouble:
                        if attempt == ATTEMPTS - 1 or not self._resync():
                            raise BridgeError(f"{self.url}: the RTX controller does not answer ({trouble}) — is it "
                                              "switched on and the cable in? deskarm reconnects by itself") from None
            except serial_error_types() as exc:
                raise BridgeError(explain_serial_error(self.url, exc)) from None
        raise AssertionError("unreachable")  # pragma: no cover

    def _resync(self) -> bool:
        """Drop input, TOGGLE_OFF, IDENTIFY (GO first to a restarted chip): the line is in a known
        state again and we know which chip has it (True)."""
        self.resyncs += 1
        try:
            for _ in range(ATTEMPTS):
                self._drain()
                try:
                    chip, restarted = self._identify_line()
                except _LineTrouble:
                    continue
                if restarted:
                    self._on_restart_reply()
                if chip is not None:
                    self._current_ip = chip
                    return True
        except serial_error_types():
            return False
        return False

    def _drain(self) -> None:
        """Drop every byte until the line has been quiet for one reply timeout (a late reply must
        not be taken for the answer to the next command); at most about a second."""
        port = self._port
        port.reset_input_buffer()
        end = time.monotonic() + 1.0
        while time.monotonic() < end and port.read(64):
            pass
        self._next_write_t = max(self._next_write_t, time.monotonic() + self.spacing_s)

    def _identify_line(self) -> tuple[Optional[int], bool]:
        """TOGGLE_OFF and IDENTIFY to whichever chip has the line; a restarted chip gets GO first.
        (chip or None for a wrong answer, whether it had restarted)."""
        restarted = False
        reply = self._write_cmd(p.toggle_off())
        if reply.first not in (p.RESP_ACK, p.RESP_IP_RESTART, p.RESP_IP_RESTART1):
            return None, False
        reply = self._write_cmd(p.identify())
        if reply.is_restart:
            restarted = True
            if self._write_cmd(p.go_restart()).first != p.RESP_ACK:
                return None, True
            reply = self._write_cmd(p.identify())
        return reply.identified_chip(), restarted

    def _cmd(self, ip: int, cmd: bytes, expect: Optional[int] = None, what: str = "") -> p.Reply:
        """A command that must succeed: an error reply raises RtxReplyError (a restart reply also
        marks the encoders lost)."""
        reply = self._raw(ip, cmd)
        if reply.is_restart:
            self._on_restart_reply()
            raise RtxReplyError(f"{self.url}: {p.describe_reply(reply.first)} — initialise again", reply.first)
        if reply.is_error:
            self.reply_errors += 1
            raise RtxReplyError(f"{self.url}: chip IP{ip} refused {what or cmd.hex()}: "
                                f"{p.describe_reply(reply.first)} (reply 0x{reply.first:02X})", reply.first)
        mask = 0xF0 if expect in (p.RESP_TYPE_IM_READ, p.RESP_TYPE_DEF_R2) else 0xFF
        if expect is not None and (reply.first & mask) != expect:
            raise RtxReplyError(f"{self.url}: chip IP{ip}: unexpected reply {reply.data.hex()} to {what or cmd.hex()}",
                                reply.first)
        return reply

    def _on_restart_reply(self) -> None:
        """A chip answered "restarted": the encoders are lost, and which chip has the line is
        unknown — the next command resynchronises first (GO to each restarted chip)."""
        self.restarts_seen += 1
        self._current_ip = None
        self._auto_init_due = self.rtx_url.auto_init and not self.initialising
        self._lose_init("the controller restarted (power cycle or reset): its encoder positions are lost "
                        "— initialise again")

    def _lose_init(self, reason: str) -> None:
        with self._lock:
            self.ready = False
            self.init_reason = reason
            self._pending = None
            self._written = {}
            self._to_go = set()
            self._readback = None
            self._state = None

    # ---------------------------------------------------------------- handshake

    def _handshake(self) -> bool:
        """The driver's start-up sequence; True when a chip had restarted. BridgeError when the
        controller does not answer or answers something else."""
        port = self._port
        self._current_ip = None
        restarted = False
        try:
            port.reset_input_buffer()
        except Exception:  # noqa: BLE001 - optional on some URL handlers
            pass

        def fail(why: str) -> BridgeError:
            return BridgeError(f"{self.url}: {why}")

        def first_chip() -> tuple[int, bool]:
            try:
                chip, was_restarted = self._identify_line()
            except _LineTrouble:
                self._drain()
                chip, was_restarted = self._identify_line()  # the driver tries TOGGLE_OFF twice
            if chip is None:
                raise fail("the controller's answers to TOGGLE_OFF / IDENTIFY are not the RTX's — wrong device?")
            return chip, was_restarted

        try:
            ip_a, r_a = first_chip()
            if self._write_cmd(p.toggle_once()).first != p.RESP_ACK:
                raise fail("TOGGLE_ONCE was not acknowledged")
            ip_b, r_b = first_chip()
        except _LineTrouble as trouble:
            raise fail(f"no answer from the RTX controller ({trouble}) — is it switched on, the cable in its "
                       "RS-232 port, the line at 9600 baud 8N1?") from None
        if ip_a == ip_b:
            raise fail(f"both chips answered as IP{ip_a}: the line is not the RTX's two-chip controller")
        self._current_ip = ip_b
        restarted = r_a or r_b
        if restarted:
            self.restarts_seen += 1
        try:
            reply = self._write_cmd(p.version())
            if len(reply.data) == 3:
                self.version = reply.data[1] | (reply.data[2] << 8)
        except _LineTrouble:
            self.version = None
        return restarted

    # ---------------------------------------------------------------- motion

    def send(self, command: JointCommand) -> tuple:
        """Clamp into every limit and hand the target to the I/O thread; returns ``()`` (no servo
        angles: ``last_sent_q`` holds the joint values sent). Before the initialisation, and while
        e-stopped, nothing is written. BridgeError when not connected."""
        if self._estopped:
            return ()
        if not self._connected:
            raise BridgeError(f"{self.url}: not connected")
        if not self.ready:
            self.message = self.init_reason or NOT_INITIALISED
            return ()
        counts, q_sent = safe_counts(command.q, self.profile, self.limits_q)
        with self._lock:
            if not self.ready:
                return ()
            self._pending = counts
            self._pending_source_t = command.source_t
        self.last_sent_q = q_sent
        self.last_sent_counts = counts
        self.last_source_t = command.source_t
        self.commands_sent += 1
        self._new_target.set()
        return ()

    def _write_servo_deg(self, servo_deg) -> int:  # pragma: no cover - no servos on the RTX
        raise BridgeError("the UMI-RTX has no servos; send joint values (JointCommand) instead")

    def set_gripper_mm(self, grip_mm: float) -> int:
        """Open the gripper to ``grip_mm`` (clamped to its range); returns the counts written.
        Refused (BridgeError) before the initialisation or while e-stopped."""
        if self._estopped:
            raise BridgeError("e-stopped: re-arm before moving the gripper")
        if not self.ready:
            raise BridgeError(self.init_reason or NOT_INITIALISED)
        lo, hi = k.SOFT_LIMIT_COUNTS["GRIPPER"]
        mm = grip_mm if math.isfinite(grip_mm) else 0.0
        counts = min(max(k.gripper_mm_to_ticks(mm), lo), hi)
        self._write_param(p.GRIPPER, p.Param.NEW_POSITION, counts)
        self._go(p.IP1, [p.MOTOR_CTL[p.GRIPPER]])
        return counts

    def _write_param(self, motor: int, code: p.Param, value: int) -> None:
        ip, ctl = p.MOTOR_IP[motor], p.MOTOR_CTL[motor]
        what = f"{MOTOR_NAME[motor]} {code.name} = {value}"
        with self._line:
            for attempt in range(2):
                self._cmd(ip, p.select_write(code), expect=p.RESP_TYPE_DEF_W1, what=what)
                try:
                    reply = self._cmd(ip, p.write_param(ctl, value), what=what)
                    break
                except RtxReplyError as exc:
                    # a resynchronisation between the two halves used up the selection: both again
                    if exc.code != p.ReplyCode.CMD_OOR or attempt == 1:
                        raise
        lo, hi = int(value) & 0xFF, (int(value) >> 8) & 0xFF
        if reply.first != (p.RESP_TYPE_DEF_W2 | p.checksum(lo, hi)):
            raise RtxReplyError(f"{self.url}: {what}: reply {reply.data.hex()} has the wrong checksum", reply.first)

    def _read_param(self, motor: int, code: p.Param) -> int:
        ip, ctl = p.MOTOR_IP[motor], p.MOTOR_CTL[motor]
        what = f"read {MOTOR_NAME[motor]} {code.name}"
        with self._line:
            for attempt in range(2):
                self._cmd(ip, p.select_read(code), expect=p.RESP_TYPE_DEF_R1, what=what)
                try:
                    reply = self._cmd(ip, p.read_param(ctl), what=what)
                    break
                except RtxReplyError as exc:
                    if exc.code != p.ReplyCode.CMD_OOR or attempt == 1:
                        raise
        return self._word(reply, what)

    def _word(self, reply: p.Reply, what: str) -> int:
        try:
            return reply.word()
        except p.RtxProtocolError as exc:
            raise RtxReplyError(f"{self.url}: {what}: {exc}", reply.first) from None

    def _go(self, ip: int, ctls, busy_ok: bool = False) -> bool:
        """Numeric GO for controllers ``ctls`` of chip ``ip``; False when a motor is still busy."""
        reply = self._raw(ip, p.numeric_go(ctls))
        if reply.first == p.ReplyCode.AXIS_BUSY and busy_ok:
            return False
        if reply.first != p.RESP_ACK:
            self._cmd_error(ip, reply, "GO")
        return True

    def _cmd_error(self, ip: int, reply: p.Reply, what: str) -> None:
        if reply.is_restart:
            self._on_restart_reply()
        self.reply_errors += 1
        raise RtxReplyError(f"{self.url}: chip IP{ip} refused {what}: {p.describe_reply(reply.first)} "
                            f"(reply 0x{reply.first:02X})", reply.first)

    def _stop_all(self, mode: p.StopMode = p.StopMode.DEAD) -> None:
        """Stop every motor: the stop to the chip that has the line, then to the other."""
        with self._line:
            first = self._current_ip if self._current_ip is not None else p.IP1
            for ip in (first, 1 - first):
                reply = self._raw(ip, p.stop(mode))
                if reply.first != p.RESP_ACK and not reply.is_restart:
                    self._cmd_error(ip, reply, f"STOP ({mode.name})")

    def _read_actual(self, motor: int) -> int:
        """Measured position = the controller's position − its following error (counts)."""
        ip, ctl = p.MOTOR_IP[motor], p.MOTOR_CTL[motor]
        name = MOTOR_NAME[motor]
        with self._line:
            cp = self._word(self._cmd(ip, p.read_position(ctl), expect=p.RESP_TYPE_IM_READ, what=f"read {name}"),
                            f"read {name}")
            err = self._word(self._cmd(ip, p.read_error(ctl), expect=p.RESP_TYPE_IM_READ, what=f"read {name} error"),
                             f"read {name} error")
        return cp - err

    def _motor_status(self, motor: int) -> int:
        ip, ctl = p.MOTOR_IP[motor], p.MOTOR_CTL[motor]
        reply = self._cmd(ip, p.motor_status(ctl), what=f"status of {MOTOR_NAME[motor]}")
        if len(reply.data) != 3 or reply.first != p.CMD_STAT_CTL | ctl:
            raise RtxReplyError(f"{self.url}: status of {MOTOR_NAME[motor]}: reply {reply.data.hex()}", reply.first)
        return reply.data[1]

    def _general_status(self, ip: int) -> int:
        reply = self._cmd(ip, p.general_status(), what="general status")
        if len(reply.data) != 3 or reply.first != p.CMD_STAT_GENERAL:
            raise RtxReplyError(f"{self.url}: general status: reply {reply.data.hex()}", reply.first)
        return reply.data[1]

    def _chips_in_order(self) -> list[int]:
        first = self._current_ip if self._current_ip is not None else p.IP1
        return [first, 1 - first]

    # ---------------------------------------------------------------- the I/O thread

    def _run(self, stop: threading.Event) -> None:
        next_idle = 0.0
        while not stop.is_set():
            try:
                if self._io_pause.is_set():
                    stop.wait(0.02)
                    continue
                if self.ready and not self._estopped:
                    self._cycle()
                    continue
                if self._auto_init_due and not self._estopped:
                    self._auto_init_due = False  # once per restart: a failing init is not repeated
                    try:
                        self.initialise(progress=self.progress_sink)
                    except InitCancelled:
                        pass
                    continue
                now = time.monotonic()
                if now >= next_idle:
                    next_idle = now + IDLE_POLL_S
                    with self._line:
                        if self._io_pause.is_set() or stop.is_set():
                            continue
                        for ip in self._chips_in_order():
                            self._general_status(ip)
                self._new_target.wait(0.05)
                self._new_target.clear()
            except RtxReplyError as exc:
                self.message = str(exc)
                if exc.code in (p.RESP_IP_RESTART, p.RESP_IP_RESTART1):
                    continue
                stop.wait(0.05)
            except BridgeError as exc:
                self._link_lost(str(exc), stop)
                return

    def _link_lost(self, why: str, stop: threading.Event) -> None:
        if stop.is_set():
            return
        self.message = why
        with self._line:
            port, self._port = self._port, None
            self._connected = False
            self._link_down.set()
        if port is not None:
            close_quietly(port)

    def _cycle(self) -> None:
        t0 = time.monotonic()
        with self._lock:
            target = self._pending
            self._pending = None
        if target is not None:
            if not counts_within_limits(target):  # the last guard before the wire
                raise BridgeError(f"{self.url}: refused a target outside the limits: {target}")
            changed = {m: c for m, c in target.items() if self._written.get(m) != c}
            # the chip that has the line first: fewer TOGGLE_ONCEs
            order = self._chips_in_order()
            for name in sorted(changed, key=lambda n: order.index(p.MOTOR_IP[p.MOTOR_BY_NAME[n]])):
                if self._estopped or not self.ready:
                    return
                self._write_param(p.MOTOR_BY_NAME[name], p.Param.NEW_POSITION, changed[name])
                self._written[name] = changed[name]
                self._to_go.add(name)
        if self._to_go and not self._estopped:
            for ip in self._chips_in_order():
                motors = [m for m in self._to_go if p.MOTOR_IP[p.MOTOR_BY_NAME[m]] == ip]
                if motors and self._go(ip, [p.MOTOR_CTL[p.MOTOR_BY_NAME[m]] for m in motors], busy_ok=True):
                    self._to_go -= set(motors)
        readings: dict[str, int] = {}
        for ip in self._chips_in_order():
            for m in ARM_MOTORS:
                if p.MOTOR_IP[m] == ip:
                    readings[MOTOR_NAME[m]] = self._read_actual(m)
            bits = self._general_status(ip)
            if bits & (p.GEN_ERROR_LIMITS | p.GEN_AXIS_RESET) and not self._estopped:
                self._motor_stopped(ip)
        q = k.motor_ticks_to_q(readings)
        with self._lock:
            if self.ready:
                self._readback = readings
                self._readback_t = time.monotonic()
                self._state = JointState(seq=self._state_seq.next(), t=self.clock.now(), q=q, measured=True)
        self.cycle_s.append(time.monotonic() - t0)
        if len(self.cycle_s) > 1000:
            del self.cycle_s[:500]

    def _motor_stopped(self, ip: int) -> None:
        """A motor on chip ``ip`` hit its error limit: name it and stop the arm."""
        names = []
        for m in p.MOTOR_IP:
            if p.MOTOR_IP[m] == ip and self._motor_status(m) & (p.STAT_ERROR_LIMIT | p.STAT_RESET):
                names.append(MOTOR_NAME[m])
        which = ", ".join(names) or f"a motor on IP{ip}"
        self.fault = (f"{which} stopped by the controller: its following error passed the limit — an end stop "
                      "or an obstacle. The arm is stopped; clear the way and re-arm")
        self.estop()

    # ---------------------------------------------------------------- state

    def joint_state(self) -> Optional[JointState]:
        """The joints measured by the controller (position − following error), newest cycle;
        None before the initialisation (the counts mean nothing yet)."""
        with self._lock:
            return self._state

    def readback_counts(self) -> Optional[dict[str, int]]:
        """The newest measured counts per motor (None before the initialisation)."""
        with self._lock:
            return None if self._readback is None else dict(self._readback)

    def wait_for_state(self, timeout: float, predicate: Optional[Callable[[JointState], bool]] = None,
                       ) -> Optional[JointState]:
        """Block until a read-back newer than this call satisfies ``predicate``; None after ``timeout``."""
        deadline = time.monotonic() + timeout
        with self._lock:
            seen = self._state.seq if self._state is not None else -1
        while time.monotonic() < deadline:
            with self._lock:
                st = self._state
            if st is not None and st.seq != seen and (predicate is None or predicate(st)):
                return st
            if not self._connected:
                return None
            self._stop.wait(0.01)
        return None

    # ---------------------------------------------------------------- e-stop

    def _on_estop(self) -> None:
        """Stop every motor (DEAD_STOP to both chips back to back) and end an initialisation."""
        self._cancel_init.set()
        with self._lock:
            self._pending = None
            self._to_go = set()
        if self._port is None:
            return  # nothing is moving that we could reach; the state is kept for the next connect
        try:
            self._stop_all(p.StopMode.DEAD)
        except BridgeError as exc:
            self.message = f"STOP could not be sent: {exc}"

    def _on_rearm(self) -> None:
        """Nothing to send: the motors hold where they stopped; the next target moves them."""
        self.fault = ""
        with self._lock:
            self._written = {}  # write every target again: a stop changed what the controller holds

    def _estop_text(self) -> str:
        return "E-STOP: every RTX motor stopped (DEAD_STOP on both chips); re-arm to resume"

    # ---------------------------------------------------------------- initialisation

    def initialise(self, progress: Optional[Callable[[InitProgress], None]] = None,
                   cancel: Optional[threading.Event] = None) -> bool:
        """Initialise the encoders: each joint to its end stops, limits written, to the post-init
        pose. Blocks (seconds on the emulator, about a minute on a real arm); ``progress`` gets
        each step. True when done; raises InitCancelled when STOP or ``cancel`` ended it (every
        motor stopped), BridgeError when the controller refused something or went away."""
        if not self._connected:
            raise BridgeError(f"{self.url}: not connected")
        if self._estopped:
            raise BridgeError("e-stopped: re-arm before initialising (the initialisation moves every joint)")
        self._cancel_init.clear()
        fractions = {j: 0.0 for j in INIT_JOINTS}
        say = progress or (lambda _ev: None)

        def report(joint: str, fraction: float, text: str, done: bool = False, ok: bool = False) -> None:
            if joint:
                fractions[joint] = max(fractions[joint], min(1.0, fraction))
            ev = InitProgress(joint=joint, fraction=fractions.get(joint, 1.0 if ok else 0.0), text=text,
                              fractions=tuple(fractions.items()), done=done, ok=ok)
            self.init_progress = ev
            self.message = f"initialising: {text}" if not done else text
            say(ev)

        def check() -> None:
            if self._cancel_init.is_set() or (cancel is not None and cancel.is_set()) or self._estopped:
                raise InitCancelled()

        self._lose_init("initialising")
        self.initialising = True
        self.fault = ""
        self._io_pause.set()
        try:
            with self._line:
                pass  # the I/O thread finishes its transaction and waits
            report("", 0.0, "starting: motors powered (FREE_OFF)")
            self._stop_all(p.StopMode.FREE_OFF)
            check()
            self._init_column(report, check)
            self._init_gripper(report, check)
            self._init_wrist(report, check)
            self._init_manual("shoulder", {p.SHOULDER: p.Drive.FWD}, report, check)
            self._define_origin()
            self._init_elbow_yaw(report, check)
            report("", 1.0, "writing the end stops' counts (limits)")
            for m in (p.ELBOW, p.SHOULDER, p.ZED, p.WRIST1, p.WRIST2, p.YAW, p.GRIPPER):
                check()
                value = k.INIT_STOP_COUNTS[MOTOR_NAME[m]]
                reply = self._raw(p.MOTOR_IP[m], p.write_position(p.MOTOR_CTL[m], value))
                lo, hi = value & 0xFF, (value >> 8) & 0xFF
                if reply.first != (p.RESP_TYPE_IM_WRITE | p.checksum(lo, hi)):
                    self._cmd_error(p.MOTOR_IP[m], reply, f"IM_WRITE_CP {MOTOR_NAME[m]} = {value}")
            report("", 1.0, "going to the initial pose")
            for m in (p.ELBOW, p.SHOULDER, p.ZED, p.WRIST1, p.WRIST2, p.YAW, p.GRIPPER):
                self._write_param(m, p.Param.NEW_POSITION, k.POST_INIT_COUNTS[MOTOR_NAME[m]])
            for ip in self._chips_in_order():
                ctls = sorted(p.MOTOR_CTL[m] for m in p.MOTOR_IP if p.MOTOR_IP[m] == ip)
                self._go(ip, ctls)
            self._wait_idle(check)
            with self._lock:
                self._written = {MOTOR_NAME[m]: k.POST_INIT_COUNTS[MOTOR_NAME[m]] for m in ARM_MOTORS}
                self._to_go = set()
                self.ready = True
                self.init_reason = ""
            report("", 1.0, "initialised: the arm is ready", done=True, ok=True)
            return True
        except InitCancelled:
            try:
                self._stop_all(p.StopMode.DEAD)
            except BridgeError:
                pass
            self._lose_init("the initialisation was stopped before it finished — initialise again")
            report("", 0.0, "initialisation stopped: every motor stopped; initialise again", done=True)
            raise
        except BridgeError as exc:
            try:
                self._stop_all(p.StopMode.DEAD)
            except BridgeError:
                pass
            self._lose_init(f"the initialisation failed: {exc}")
            report("", 0.0, f"initialisation failed: {exc}", done=True)
            raise
        finally:
            self.initialising = False
            self._io_pause.clear()
            self._new_target.set()

    def _define_origin(self) -> None:
        with self._line:
            for ip in self._chips_in_order():
                self._cmd(ip, p.define_home(), expect=p.RESP_ACK, what="DEF_HOME")
            for ip in self._chips_in_order():
                self._cmd(ip, p.reload_pids(), expect=p.RESP_ACK, what="IP_DEFAULT")

    def _drive_manual(self, drives: Mapping[int, p.Drive]) -> None:
        self._stop_all(p.StopMode.DEAD)
        for ip, ctls in p.split_by_chip(drives).items():
            by_ctl = {p.MOTOR_CTL[m]: d for m, d in drives.items() if p.MOTOR_IP[m] == ip}
            reply = self._raw(ip, p.manual_go(by_ctl))
            if reply.first != p.RESP_ACK:
                self._cmd_error(ip, reply, "manual GO")

    def _until_stopped(self, motors, check, on_poll) -> None:
        """Poll until every motor in ``motors`` was stopped on its error limit (its end stop)."""
        deadline = time.monotonic() + INIT_LEG_TIMEOUT_S
        hit = set()
        while len(hit) < len(motors):
            check()
            for m in motors:
                if m not in hit and self._motor_status(m) & p.STAT_RESET:
                    hit.add(m)
            on_poll()
            if time.monotonic() > deadline:
                missing = ", ".join(MOTOR_NAME[m] for m in motors if m not in hit)
                raise BridgeError(f"{self.url}: {missing} did not reach its end stop in {INIT_LEG_TIMEOUT_S:.0f} s")

    def _wait_idle(self, check) -> None:
        deadline = time.monotonic() + INIT_LEG_TIMEOUT_S
        while True:
            check()
            if not any(self._general_status(ip) & p.GEN_TASKS for ip in self._chips_in_order()):
                return
            if time.monotonic() > deadline:
                raise BridgeError(f"{self.url}: the arm did not finish its move in {INIT_LEG_TIMEOUT_S:.0f} s")

    def _init_manual(self, joint: str, drives: Mapping[int, p.Drive], report, check,
                     measure: Optional[Callable[[], float]] = None) -> None:
        motors = list(drives)
        measure = measure or (lambda: float(self._read_actual(motors[0])))
        start = measure()
        report(joint, 0.0, f"{joint}: driving to its end stop")
        self._drive_manual(drives)

        def on_poll() -> None:
            report(joint, min(0.95, abs(measure() - start) / INIT_SPAN[joint]), f"{joint}: driving to its end stop")

        self._until_stopped(motors, check, on_poll)
        report(joint, 1.0, f"{joint}: end stop found")

    def _init_column(self, report, check) -> None:
        self._init_manual("column", {p.ZED: p.Drive.FWD}, report, check)
        self._define_origin()

    def _numeric_move(self, motor: int, counts: int, check) -> None:
        self._write_param(motor, p.Param.NEW_POSITION, counts)
        self._stop_all(p.StopMode.DEAD)
        self._go(p.MOTOR_IP[motor], [p.MOTOR_CTL[motor]])
        deadline = time.monotonic() + INIT_LEG_TIMEOUT_S
        while self._motor_status(motor) & p.STAT_IN_PROGRESS:
            check()
            if time.monotonic() > deadline:
                raise BridgeError(f"{self.url}: {MOTOR_NAME[motor]} did not finish its move")

    def _init_gripper(self, report, check) -> None:
        force = self._read_param(p.GRIPPER, p.Param.MAX_FORCE)
        self._write_param(p.GRIPPER, p.Param.MAX_FORCE, force // 2)  # close gently
        self._init_manual("gripper", {p.GRIPPER: p.Drive.RVS}, report, check)
        self._define_origin()
        self._numeric_move(p.GRIPPER, 30, check)  # 30 counts off the closed stop
        self._define_origin()

    def _init_wrist(self, report, check) -> None:
        report("wrist_roll", 0.0, "elbow: out a little, so the wrist can turn")
        self._write_param(p.YAW, p.Param.MAX_FORCE, 0)
        self._numeric_move(p.ELBOW, 440, check)
        self._define_origin()
        w_sum = lambda: float(self._read_actual(p.WRIST1) + self._read_actual(p.WRIST2))  # noqa: E731
        w_diff = lambda: float(self._read_actual(p.WRIST1) - self._read_actual(p.WRIST2))  # noqa: E731
        legs = (("wrist_roll", p.Drive.RVS, p.Drive.FWD, w_diff), ("wrist_pitch", p.Drive.RVS, p.Drive.RVS, w_sum)) * 2
        for i, (joint, d1, d2, measure) in enumerate(legs):
            start = measure()
            scale = 0.5 if i < 2 else 1.0
            report(joint, 0.0, f"{joint}: driving to its end stop")
            self._drive_manual({p.WRIST1: d1, p.WRIST2: d2})

            def on_poll(joint=joint, start=start, measure=measure, scale=scale) -> None:
                frac = min(0.95, abs(measure() - start) / INIT_SPAN[joint])
                report(joint, (0.5 if scale == 1.0 else 0.0) + 0.5 * frac, f"{joint}: driving to its end stop")

            self._until_stopped((p.WRIST1, p.WRIST2), check, on_poll)
            report(joint, scale, f"{joint}: end stop found" if scale == 1.0 else f"{joint}: end stop found once")
        self._define_origin()

    def _init_elbow_yaw(self, report, check) -> None:
        self._write_param(p.ELBOW, p.Param.SPEED, 80)  # the driver's slow approach
        self._write_param(p.ELBOW, p.Param.MAX_FORCE, 30)
        self._write_param(p.YAW, p.Param.SPEED, 100)
        self._write_param(p.YAW, p.Param.MAX_FORCE, 60)
        self._write_param(p.YAW, p.Param.ERROR_LIMIT, 1500)
        e0, y0 = float(self._read_actual(p.ELBOW)), float(self._read_actual(p.YAW))
        report("elbow", 0.0, "elbow and yaw: driving to their end stops")
        report("wrist_yaw", 0.0, "elbow and yaw: driving to their end stops")
        self._drive_manual({p.ELBOW: p.Drive.RVS, p.YAW: p.Drive.RVS})

        def on_poll() -> None:
            report("elbow", min(0.95, abs(self._read_actual(p.ELBOW) - e0) / INIT_SPAN["elbow"]),
                   "elbow and yaw: driving to their end stops")
            report("wrist_yaw", min(0.95, abs(self._read_actual(p.YAW) - y0) / INIT_SPAN["wrist_yaw"]),
                   "elbow and yaw: driving to their end stops")

        self._until_stopped((p.ELBOW, p.YAW), check, on_poll)
        report("elbow", 1.0, "elbow: end stop found")
        report("wrist_yaw", 1.0, "yaw: end stop found")
        self._define_origin()

    # ---------------------------------------------------------------- status

    def status(self) -> BridgeStatus:
        """Connection, initialisation and fault state in one line."""
        if self._connected:
            parts = ["UMI-RTX" + (f" v{self.version:#06x}" if self.version is not None else "")]
            if self.initialising and self.init_progress is not None:
                parts.append(f"initialising: {self.init_progress.text}")
            elif not self.ready:
                parts.append(self.init_reason or NOT_INITIALISED)
            else:
                parts.append("ready")
                with self._lock:
                    t = self._readback_t
                if t is not None and time.monotonic() - t > 1.0:
                    parts.append(f"no read-back for {time.monotonic() - t:.1f} s — controller not answering?")
            if self.fault:
                parts.append(self.fault)
            if self.resyncs or self.no_answers:
                parts.append(f"resyncs {self.resyncs}, unanswered {self.no_answers}")
            if self.message and self.message not in parts[0] and not self.message.startswith(("UMI-RTX", "initialis")):
                parts.append(self.message)
            message = " · ".join(parts)
        else:
            message = self.message or "not connected"
        if self._estopped:
            message = f"{self._estop_text()} · {message}"
        return BridgeStatus(url=self.url, connected=self._connected, message=message,
                            commands_sent=self.commands_sent, bytes_written=self.bytes_written,
                            last_write_t=self.last_write_t, last_source_t=self.last_source_t,
                            request_failed=self.request_failed)


class _LineTrouble(Exception):
    """No reply, a reply that is no RTX reply, or a short one: resynchronise."""
