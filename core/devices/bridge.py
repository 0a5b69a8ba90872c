"""The motor bridge interface: what every arm link offers, its errors and its URLs.

A bridge sends joint commands to an arm and reports its joint state. The implementations live
beside this module — ``sim_arm`` (SimServoArm, the simulated arm), ``serial_v1`` (the seed
protocol) and ``serial_v2`` (deskarm's framed protocol) — and ``core.devices.open_bridge(url,
profile)`` chooses one from the URL:

- ``sim://`` — the simulated arm (SimServoArm);
- ``/dev/ttyACM0``, ``COM3``, ``loop://`` or any pyserial URL, or the same with ``v1:`` in
  front — the seed protocol v1 (SerialV1Bridge): no feedback, the twin shows commanded angles;
- ``v2:/dev/ttyACM0`` — our protocol v2 (SerialV2Bridge): measured joint states, heartbeat,
  watchdog, e-stop;
- ``phidget://[SERIAL][?channels=0,1,2]`` — a Phidget servo controller through the vendor's
  Phidget22 library (``phidget.PhidgetServoBridge``), as on the original assistive arm;
- ``rtx:/dev/ttyUSB0`` — a UMI-RTX's own controller over RS-232 (``rtx_bridge.RtxBridge``,
  ``--robot umi_rtx`` only); ``rtx:sim`` — the same bridge talking to an emulated RTX
  (``rtx_emulator``) over a pseudo-terminal pair. Options: ``?init=auto`` initialises the
  encoders on connect without asking (unattended runs), ``?speedup=N`` (``rtx:sim`` only) makes
  the emulated arm move N times faster.

There is deliberately no auto-detection of the protocol. Probing means sending a v2 frame
(a PING is ``F5 F5 00 05 seq crc crc F7``) to a board that may run the ORIGINAL firmware, which
knows nothing of frames: it reads every byte 0x00–0xB4 as an angle for whichever joint a
previous host left selected — the 0x00 in the PING alone would swing that joint to 0°. A
probe could move the arm, so the user says which firmware the board runs.

Every bridge clamps again before it writes: no path can command a servo outside its joint
limits or outside 0–180°. Every bridge has ``estop()`` / ``rearm()``: while e-stopped
``send`` writes nothing and returns ``()``; v2 also switches the pulses off on the board, the
simulated arm freezes, v1 can only stop sending (the servos hold their last position).
"""
from __future__ import annotations

import errno
import math
import os
import re
import stat
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Optional, Sequence
from urllib.parse import parse_qs, urlsplit

from core.clock import WallClock
from core.messages import BridgeStatus, JointCommand, JointState, SequenceCounter
from core.motion.safety import to_servo_bytes_deg

BRIDGE_CHOICES = (
    "sim:// (simulated arm) | /dev/ttyACM0, /dev/ttyUSB0, /dev/serial/by-id/…, COM3 or v1:<port> "
    "(original firmware, protocol v1: no feedback) | v2:<port>, e.g. v2:/dev/ttyACM0 (deskarm "
    "firmware, protocol v2: feedback, watchdog, e-stop) | phidget://[SERIAL][?channels=0,1,2] "
    "(Phidget servo board, needs pip install 'deskarm[phidget]') | rtx:<port>[?init=auto], e.g. "
    "rtx:/dev/ttyUSB0 (UMI-RTX controller over RS-232, --robot umi_rtx) or rtx:sim (an emulated "
    "RTX) | loop:// (pyserial loopback). "
    "No auto-detection: a v2 probe would move an arm running the original firmware"
)


class BridgeError(RuntimeError):
    """The bridge could not connect or lost its device; the message says what to do."""


class MotorBridge(ABC):
    """Sends joint commands to an arm and reports its joint state.

    Lifecycle: ``connect()``, ``disconnect()``, ``is_connected``, context manager.
    ``send`` returns the servo angles actually sent after clamping.
    """

    has_feedback = False
    _estopped = False  # class default, so subclasses that skip __init__ still work
    # command rate cap (Hz) the control schedule respects: v1's 6 bytes take 6.25 ms at 9600
    # baud, so 100 Hz keeps the line at most 63 % busy; v2 sets its own (MAX_COMMAND_HZ)
    max_command_hz = 100.0

    def __init__(self, url: str, profile, clock=None):
        self.url = url
        self.profile = profile
        self.clock = clock or WallClock()
        self.commands_sent = 0
        self.bytes_written = 0
        self.last_write_t: Optional[float] = None
        self.last_source_t: Optional[float] = None
        self.message = ""
        self.request_failed = False  # set by the app when a request to switch or stop it failed
        self._state_seq = SequenceCounter()
        self._last_sent_deg: Optional[tuple[int, ...]] = None

    @abstractmethod
    def connect(self) -> None: ...

    @abstractmethod
    def disconnect(self) -> None: ...

    @property
    @abstractmethod
    def is_connected(self) -> bool: ...

    @abstractmethod
    def _write_servo_deg(self, servo_deg: tuple[int, ...]) -> int:
        """Write whole-degree servo angles; returns the number of bytes written."""

    def send(self, command: JointCommand) -> tuple[int, ...]:
        """Clamp, convert to servo degrees and write; returns the servo angles sent.

        While e-stopped nothing is written and the result is ``()``.
        """
        if self._estopped:
            return ()
        servo_deg = to_servo_bytes_deg(command.q, self.profile)
        written = self._write_servo_deg(servo_deg)
        self.commands_sent += 1
        self.bytes_written += written
        self.last_write_t = self.clock.now()
        self.last_source_t = command.source_t
        self._last_sent_deg = servo_deg
        return servo_deg

    def joint_state(self) -> Optional[JointState]:
        """The arm's joint state: measured, or the last command echoed (``measured=False``)."""
        if self._last_sent_deg is None:
            return None
        q = servo_deg_to_q(self._last_sent_deg, self.profile)
        return JointState(seq=self._state_seq.next(), t=self.clock.now(), q=q, measured=False)

    @property
    def is_estopped(self) -> bool:
        """True from ``estop()`` until ``rearm()``."""
        return self._estopped

    def estop(self) -> None:
        """Stop the arm now; nothing is sent until ``rearm()``.

        The base behaviour (v1) is to stop writing: the seed firmware has no stop command,
        so its servos hold their last position. Subclasses also act on the device
        (``_on_estop``). Works while disconnected too: the state is kept for the next connect.
        """
        self._estopped = True
        self._on_estop()

    def rearm(self) -> None:
        """End an e-stop: commands are sent again (nothing moves until the next one)."""
        self._estopped = False
        self._on_rearm()

    def _on_estop(self) -> None:
        """Device-specific part of ``estop()``; the base only stops sending."""

    def _on_rearm(self) -> None:
        """Device-specific part of ``rearm()``."""

    def _estop_text(self) -> str:
        """What an e-stop means on this bridge, for the status bar."""
        return ("E-STOP: not sending — protocol v1 cannot switch the servos off, they hold "
                "their last position; re-arm to resume")

    def status(self) -> BridgeStatus:
        message = self.message
        if self._estopped:
            message = f"{self._estop_text()} · {message}" if message else self._estop_text()
        return BridgeStatus(
            url=self.url, connected=self.is_connected, message=message,
            commands_sent=self.commands_sent, bytes_written=self.bytes_written,
            last_write_t=self.last_write_t, last_source_t=self.last_source_t,
            request_failed=self.request_failed,
        )

    def __enter__(self):
        self.connect()
        return self

    def __exit__(self, *exc):
        self.disconnect()


def servo_deg_to_q(servo_deg: Sequence[float], profile) -> tuple[float, ...]:
    """Servo angles (deg) -> kinematic joint values (rad) through each joint's offset/direction."""
    return tuple(j.from_servo_deg(d) for j, d in zip(profile.joints, servo_deg))


def _errno_of(exc: Exception) -> Optional[int]:
    """The OS error number behind a pyserial/OS error (pyserial often keeps it in the text only;
    ``termios.error`` is not an OSError and carries it as its first argument)."""
    code = getattr(exc, "errno", None)
    if isinstance(code, int):
        return code
    args = getattr(exc, "args", ())
    if len(args) == 2 and isinstance(args[0], int) and not isinstance(args[0], bool):
        return args[0]  # termios.error(errno, text)
    match = re.search(r"\[errno (\d+)\]", str(exc).lower())
    return int(match.group(1)) if match else None


def explain_serial_error(url: str, exc: Exception) -> str:
    """Turn a pyserial/OS error into a sentence that says what happened and what to do."""
    text = str(exc)
    low = text.lower()
    code = _errno_of(exc)
    if code == errno.EACCES or "permission denied" in low or "access is denied" in low:
        return f"{url}: permission denied — add your user to the 'dialout' group and log in again"
    if code == errno.ENOENT or "no such file" in low or "filenotfounderror" in low:
        return (f"{url}: no such port — is the board plugged in? Valid ports look like "
                "/dev/ttyACM0, /dev/ttyUSB0, /dev/serial/by-id/… or COM3")
    if (code in (errno.EBUSY, errno.EAGAIN) or "busy" in low or "exclusively lock" in low
            or "being used by another" in low):
        return f"{url}: port busy — close the other program using it (serial monitor, another deskarm)"
    if code == errno.ENOTTY or "inappropriate ioctl" in low:
        return f"{url}: not a serial port — choose the board's port (e.g. /dev/ttyACM0)"
    if "write timeout" in low:
        return (f"{url}: write timed out — the port accepts no data (wrong port, or the board "
                "is hung: press its reset button)")
    if (code in (errno.EIO, errno.ENXIO, errno.ENODEV, errno.EBADF) or "disconnected" in low
            or "device reports" in low or "port not open" in low or "attempting to use a port" in low
            or "file descriptor" in low or "closed file" in low):
        return f"{url}: the device went away (unplugged?) — plug it back in; deskarm reconnects by itself"
    return f"{url}: {text or type(exc).__name__}"


def serial_error_types() -> tuple[type[BaseException], ...]:
    """Every exception an open serial port may raise when its device goes away or its fd is
    closed under a call; a bridge turns each into BridgeError.

    pyserial wraps only some of them in SerialException: ``flush()`` is ``termios.tcdrain``
    (``termios.error``, not an OSError), ``in_waiting`` an ioctl (OSError), and a port closed by
    another thread fails on its fd with a ValueError (fd -1) or a TypeError (fd None).
    """
    import serial

    kinds: list[type[BaseException]] = [serial.SerialException, OSError, ValueError, TypeError]
    try:
        import termios  # POSIX only
    except ImportError:
        pass
    else:
        kinds.append(termios.error)
    return tuple(kinds)


def lost_port_error(url: str, port, exc: BaseException) -> BridgeError:
    """The BridgeError for ``exc`` raised by an open ``port``: what happened and what to do.

    A port found closed after the failure (``is_open`` false or no fd) was closed under the
    call: whatever pyserial raised then (often a TypeError), the device is gone.
    """
    closed = port is not None and (not getattr(port, "is_open", True) or getattr(port, "fd", 0) is None)
    if closed and not isinstance(exc, OSError):
        import serial

        exc = serial.PortNotOpenError()
    return BridgeError(explain_serial_error(url, exc))


def close_quietly(port) -> None:
    """Close a port that may already be gone; closing it is then done, never an error."""
    try:
        port.close()
    except Exception:  # noqa: BLE001 - whatever a vanished device makes close() raise
        pass


# the pyserial URLs deskarm documents: the loopback and network serial servers (ser2net,
# ESP-Link). The others are refused: spy://…?file=PATH truncates PATH when the bridge opens
# (even if the port then fails); hwgrep://, alt://, cp2110:// pick devices nobody named
SERIAL_URL_SCHEMES = ("loop", "socket", "rfc2217")
_SERIAL_URL_PREFIXES = ("/dev/", "COM", "\\\\.\\COM") + tuple(f"{s}://" for s in SERIAL_URL_SCHEMES)
V1_PREFIX = "v1:"  # explicit protocol v1 (the default for a plain port)
V2_PREFIX = "v2:"  # protocol v2: deskarm firmware only (see the module docstring)
PHIDGET_SCHEME = "phidget://"  # a Phidget servo board (core.devices.phidget)
RTX_PREFIX = "rtx:"  # a UMI-RTX controller (core.devices.rtx_bridge)
PHIDGET_MAX_CHANNEL = 15  # the largest Phidget servo controller (RCC1000) has 16 channels


def _is_serial_port_url(port: str) -> bool:
    if port.startswith(_SERIAL_URL_PREFIXES) or (port.startswith("/") and "tty" in port):
        return True
    # any other typed path to a character device, e.g. a symlink a test or udev made to a pty
    try:
        return port.startswith("/") and stat.S_ISCHR(os.stat(port).st_mode)
    except OSError:
        return False


def split_bridge_url(url: str) -> tuple[str, str]:
    """``(protocol, port)``: ('sim', 'sim://'), ('v1', '/dev/ttyACM0'), ('v2', '/dev/ttyACM0'),
    ('phidget', 'phidget://123456?channels=0,1,2') (the whole URL: it is the "port"),
    ('rtx', '/dev/ttyUSB0') or ('rtx', 'sim') (any ``?options`` stay on the port).

    A plain port means v1, as it always did; ``v1:`` says so explicitly, ``v2:`` chooses v2.
    ValueError names the value and the valid forms.
    """
    url = (url or "sim://").strip()
    if url in ("sim", "sim://"):
        return "sim", "sim://"
    if url.lower().startswith(PHIDGET_SCHEME):
        parse_phidget_url(url)  # ValueError naming what is wrong
        return "phidget", url
    if url.lower().startswith(RTX_PREFIX):
        rtx = parse_rtx_url(url)  # ValueError naming what is wrong
        return "rtx", url[len(RTX_PREFIX):].strip() if rtx.port else "sim"
    protocol = "v1"
    port = url
    low = url.lower()
    if low.startswith((V1_PREFIX, V2_PREFIX)):
        protocol, port = low[:2], url[3:].strip()
    if port and _is_serial_port_url(port):
        return protocol, port
    raise ValueError(f"unknown --bridge value {url!r}; valid: {BRIDGE_CHOICES}")


@dataclass(frozen=True)
class PhidgetUrl:
    """What a ``phidget://`` URL names."""

    serial_number: Optional[int]  # None = any board
    channels: Optional[tuple[int, ...]]  # channel per joint; None = 0, 1, 2 …

def parse_phidget_url(url: str) -> PhidgetUrl:
    """``phidget://[SERIAL][?channels=a,b,c]`` → PhidgetUrl; ValueError naming the part that is wrong."""
    text = (url or "").strip()
    if not text.lower().startswith(PHIDGET_SCHEME):
        raise ValueError(f"{url!r} is not a Phidget URL: expected phidget://[SERIAL][?channels=0,1,2]")
    parts = urlsplit(text)
    where = f"{url!r}: "
    if parts.path not in ("", "/") or parts.fragment:
        raise ValueError(where + "expected phidget://[SERIAL][?channels=0,1,2], e.g. phidget://123456?channels=0,1,2")
    serial_number: Optional[int] = None
    if parts.netloc:
        if not parts.netloc.isdigit() or int(parts.netloc) <= 0:
            raise ValueError(where + f"serial number {parts.netloc!r} must be a positive whole number "
                             "(it is printed on the board and shown by the Phidget Control Panel)")
        serial_number = int(parts.netloc)
    query = parse_qs(parts.query, keep_blank_values=True) if parts.query else {}
    unknown = sorted(set(query) - {"channels"})
    if unknown:
        raise ValueError(where + f"unknown option {unknown[0]!r}; the only option is channels=0,1,2")
    channels: Optional[tuple[int, ...]] = None
    if "channels" in query:
        raw = query["channels"][-1]
        try:
            channels = tuple(int(c) for c in raw.split(","))
        except ValueError:
            raise ValueError(where + f"channels={raw!r}: expected channel numbers separated by commas, "
                             "e.g. channels=0,1,2") from None
        bad = [c for c in channels if not 0 <= c <= PHIDGET_MAX_CHANNEL]
        if bad:
            raise ValueError(where + f"channel {bad[0]} is outside 0…{PHIDGET_MAX_CHANNEL}")
        if len(set(channels)) != len(channels):
            raise ValueError(where + f"channels={raw}: a channel is used twice")
    return PhidgetUrl(serial_number=serial_number, channels=channels)



@dataclass(frozen=True)
class RtxUrl:
    """What an ``rtx:`` URL names."""

    port: Optional[str]  # the serial port; None = the emulated RTX (rtx:sim)
    auto_init: bool  # initialise the encoders on connect without asking
    speedup: float  # rtx:sim only: the emulated arm moves this many times faster than a real one


RTX_SIM_SPEEDUP = 5.0  # rtx:sim's default: the emulated initialisation takes ~11 s instead of ~55 s


def parse_rtx_url(url: str) -> RtxUrl:
    """``rtx:PORT[?init=auto]`` or ``rtx:sim[?speedup=N][&init=auto]`` → RtxUrl; ValueError naming
    the part that is wrong."""
    text = (url or "").strip()
    form = "expected rtx:<port>[?init=auto] (e.g. rtx:/dev/ttyUSB0) or rtx:sim[?speedup=5]"
    if not text.lower().startswith(RTX_PREFIX):
        raise ValueError(f"{url!r} is not an RTX URL: {form}")
    rest = text[len(RTX_PREFIX):].strip()
    port, _, query = rest.partition("?")
    port = port.strip()
    if not port:
        raise ValueError(f"{url!r}: no port — {form}")
    options = parse_qs(query, keep_blank_values=True) if query else {}
    unknown = sorted(set(options) - {"init", "speedup"})
    if unknown:
        raise ValueError(f"{url!r}: unknown option {unknown[0]!r}; the options are init=auto and speedup=N (rtx:sim)")
    init = options.get("init", ["ask"])[-1]
    if init not in ("auto", "ask"):
        raise ValueError(f"{url!r}: init={init!r}: expected init=auto (initialise on connect) or init=ask")
    sim = port.lower() in ("sim", "sim://")
    speedup = RTX_SIM_SPEEDUP if sim else 1.0
    if "speedup" in options:
        if not sim:
            raise ValueError(f"{url!r}: speedup= is for rtx:sim only (a real arm moves at its own speed)")
        try:
            speedup = float(options["speedup"][-1])
        except ValueError:
            speedup = float("nan")
        if not 0.1 <= speedup <= 1000.0:
            raise ValueError(f"{url!r}: speedup={options['speedup'][-1]!r}: expected a number from 0.1 to 1000")
    if not sim and not _is_serial_port_url(port):
        raise ValueError(f"{url!r}: {port!r} is not a serial port; {form}")
    return RtxUrl(port=None if sim else port, auto_init=init == "auto", speedup=speedup)


def is_simulated_bridge(url: str) -> bool:
    """True for an arm that is not on the desk: ``sim://`` and the emulated RTX ``rtx:sim[?…]``
    (the simulated desk may stand in for missing cameras; a real arm never follows it)."""
    protocol, port = split_bridge_url(url)
    return protocol == "sim" or (protocol == "rtx" and port.split("?", 1)[0] == "sim")


def parse_bridge_url(url: str) -> str:
    """'sim', 'serial' (protocol v1), 'serial-v2', 'phidget' or 'rtx'; ValueError naming the value and
    the valid forms."""
    protocol, _ = split_bridge_url(url)
    return {"sim": "sim", "v1": "serial", "v2": "serial-v2", "phidget": "phidget", "rtx": "rtx"}[protocol]


def is_finite_q(q: Sequence[float]) -> bool:
    return all(math.isfinite(v) for v in q)
