"""The Phidget servo board the original assistive arm used, through the vendor's ``Phidget22``.

``PhidgetServoBridge("phidget://", profile)`` drives one RC servo channel per joint of a servo
profile (desk_rrr, delta …) on a Phidget servo controller (the 1061 PhidgetAdvancedServo 8-Motor,
the RCC1000 16x RC Servo Phidget, …) through the ``Phidget22`` package from PyPI
(``pip install 'deskarm[phidget]'``). The library is imported only when such a bridge connects,
so nothing else in deskarm needs it.

URLs::

    phidget://                       the first board found, joints on channels 0, 1, 2 …
    phidget://123456                 the board with serial number 123456
    phidget://123456?channels=4,5,6  joint i on channel channels[i]

Mapping. As on the v2 board: the profile's servo mapping gives servo degrees (0–180, 0.01°),
clamped to the joint's servo range; each channel is configured with MinPosition 0 and
MaxPosition 180 over the same pulse widths the v2 firmware uses (900–2700 µs unless the
profile says otherwise) and a VelocityLimit of the joint's ``max_speed_deg_s``, so one command
produces the same pulse on either board.

Safety. A channel is engaged (pulses on) only by the first command after connect, re-arm or a
replug: an RC servo reports no position, so there is nothing safe to hold before someone asks
for one. ``estop()`` disengages every channel (servos limp, as v2's ESTOP) and is idempotent;
nothing is sent until ``rearm()`` and the next command. A board unplugged mid-run makes the
bridge disconnected with a message that says so; ``connect()`` (the reconnector calls it)
opens it again, and the library also re-attaches a replugged board by itself. RC servos have
no feedback: ``joint_state()`` is the controller's own ramped position, ``measured=False``.

Threads. The Phidget library calls the attach/detach handlers on its own thread; every piece
of channel state is kept under one lock.
"""
from __future__ import annotations

import importlib
import math
import threading
from typing import Any, Optional, Sequence

from core.devices.bridge import BridgeError, MotorBridge, PhidgetUrl, parse_phidget_url  # noqa: F401 - re-exported
from core.devices.serial_v2 import JointPulseConfig, pulse_configs, to_servo_cdeg
from core.kinematics.profile import SERVO_MAX_DEG, SERVO_MIN_DEG
from core.messages import JointCommand, JointState

ATTACH_TIMEOUT_S = 2.0  # openWaitForAttachment: a plugged-in board attaches in ~0.1–0.5 s
INSTALL_HINT = "pip install 'deskarm[phidget]'"
EPHIDGET_TIMEOUT = 3  # Phidget22.ErrorCode.EPHIDGET_TIMEOUT: nothing attached in time


def _load_library() -> tuple[Any, type]:
    """(RCServo class, PhidgetException class) from Phidget22; BridgeError with the install command."""
    try:
        rcservo = importlib.import_module("Phidget22.Devices.RCServo")
        exception = importlib.import_module("Phidget22.PhidgetException")
    except ImportError:
        raise BridgeError(f"Phidget22 is not installed: {INSTALL_HINT}") from None
    except OSError as exc:
        raise _native_library_error(exc) from None
    # load the native part now: an RCServo whose construction fails to load it complains again
    # from its __del__ (a traceback on stderr); the loader is the package's own, so tolerate its absence
    try:
        support = importlib.import_module("Phidget22._phidget_support")
        support.PhidgetSupport.getDll()
    except OSError as exc:
        raise _native_library_error(exc) from None
    except (ImportError, AttributeError):
        pass
    return rcservo.RCServo, exception.PhidgetException


def _native_library_error(exc: BaseException) -> BridgeError:
    """The Phidget22 package loads libphidget22 (bundled) which needs libusb-1.0 (not bundled)."""
    return BridgeError(
        f"Phidget22 is installed but its native library did not load ({exc}) — install libusb-1.0 "
        "(Debian/Ubuntu: sudo apt install libusb-1.0-0; Fedora: sudo dnf install libusb1) and, to use "
        "the board without root, Phidgets' udev rules (https://www.phidgets.com/docs/OS_-_Linux)"
    )


def _describe(exc: BaseException) -> str:
    """A PhidgetException's own words (description and details), else str(exc)."""
    words = [w for w in (getattr(exc, "description", ""), getattr(exc, "details", "")) if w]
    return " — ".join(words) or str(exc) or type(exc).__name__


class PhidgetServoBridge(MotorBridge):
    """One Phidget RCServo channel per joint; see the module docstring for mapping and safety."""

    has_feedback = False  # RC servos report nothing; joint_state is the controller's estimate
    max_command_hz = 50.0  # the servos' frame rate; the board updates targets no faster

    def __init__(self, url: str, profile, clock=None, *, attach_timeout_s: float = ATTACH_TIMEOUT_S):
        spec = parse_phidget_url(url)
        super().__init__(url.strip(), profile, clock)
        n = len(profile.joints)
        if not getattr(profile, "has_servos", True):
            raise BridgeError(
                f"a Phidget servo board drives hobby servos; profile {profile.name!r} has joints without "
                "a servo mapping (servo_min_deg, servo_max_deg, offset_deg, direction) — use sim:// for it"
            )
        channels = spec.channels if spec.channels is not None else tuple(range(n))
        if len(channels) != n:
            raise BridgeError(
                f"{url}: {len(channels)} channels for the {n} joints of profile {profile.name!r} — give one "
                f"channel per joint, e.g. ?channels={','.join(str(i) for i in range(n))}"
            )
        if not attach_timeout_s > 0:
            raise ValueError(f"attach_timeout_s = {attach_timeout_s}: expected > 0")
        self.serial_number = spec.serial_number
        self.channels = channels
        self.attach_timeout_s = float(attach_timeout_s)
        self.configs: tuple[JointPulseConfig, ...] = pulse_configs(profile)
        self._servo_range_deg = tuple(
            (max(SERVO_MIN_DEG, j.servo_min_deg), min(SERVO_MAX_DEG, j.servo_max_deg)) for j in profile.joints
        )
        self._lock = threading.RLock()  # channel state; the library's handler thread takes it too
        self._servos: list[Any] = []  # RCServo objects, one per joint, while open
        self._attached: list[bool] = [False] * n
        self._configured: list[bool] = [False] * n  # pulse widths and speed set since attach
        self._engaged: list[bool] = [False] * n
        self._open = False  # connect() succeeded and disconnect() not called
        self._phidget_exception: type = Exception
        self.detaches = 0  # boards unplugged while open
        self.last_sent_deg: Optional[tuple[float, ...]] = None

    # ---------------------------------------------------------------- lifecycle

    @property
    def is_connected(self) -> bool:
        """True while open and every channel is attached (a detach makes it False at once)."""
        with self._lock:
            return self._open and all(self._attached)

    def _where(self, joint: int) -> str:
        board = f"serial {self.serial_number}" if self.serial_number is not None else "any board"
        return f"Phidget servo board ({board}), channel {self.channels[joint]} (joint {self.profile.joints[joint].name!r})"

    def connect(self) -> None:
        """Open a channel per joint, wait for the board, configure pulse widths and speed limits.

        Raises BridgeError: library missing (with the pip command), native library missing (with
        the package to install), no board attached in time (check the cable), or a channel the
        board refused. Calling it again after a detach closes everything and opens it afresh.
        """
        if self.is_connected:
            return
        self._close_all()
        rcservo_cls, self._phidget_exception = _load_library()
        servos: list[Any] = []
        try:
            for j, channel in enumerate(self.channels):
                try:
                    ch = rcservo_cls()
                except OSError as exc:
                    raise _native_library_error(exc) from None
                servos.append(ch)
                if self.serial_number is not None:
                    ch.setDeviceSerialNumber(self.serial_number)
                ch.setChannel(channel)
                ch.setOnAttachHandler(lambda _ch, j=j: self._on_attach(j))
                ch.setOnDetachHandler(lambda _ch, j=j: self._on_detach(j))
            with self._lock:
                self._servos = servos
                self._open = True
            for j, ch in enumerate(servos):
                self._call(j, ch.openWaitForAttachment, int(round(self.attach_timeout_s * 1000)))
                with self._lock:
                    self._attached[j] = True
                    if not self._configured[j]:
                        self._configure(j)
        except BridgeError:
            self._close_all()
            raise
        except Exception as exc:  # noqa: BLE001 - whatever the library raises: never a crash
            self._close_all()
            raise BridgeError(f"Phidget servo board: {_describe(exc)}") from None
        self.message = f"Phidget servo board, {len(servos)} channels ({', '.join(map(str, self.channels))})"

    def disconnect(self) -> None:
        """Close every channel (the library stops its pulses); safe to call twice."""
        with self._lock:
            was = self._open
        self._close_all()
        if was:
            self.message = "disconnected"

    def _close_all(self) -> None:
        with self._lock:
            servos, self._servos = self._servos, []
            self._open = False
            n = len(self.channels)
            self._attached, self._configured, self._engaged = [False] * n, [False] * n, [False] * n
        for ch in servos:
            try:
                ch.setOnAttachHandler(None)
                ch.setOnDetachHandler(None)
                ch.close()
            except Exception:  # noqa: BLE001 - closing a channel that is gone is done, not an error
                pass

    def _call(self, joint: int, fn, *args):
        """Call a library method; a PhidgetException becomes a BridgeError naming the channel."""
        try:
            return fn(*args)
        except self._phidget_exception as exc:
            if getattr(exc, "code", None) == EPHIDGET_TIMEOUT:
                raise BridgeError(
                    f"no Phidget servo board attached ({self._where(joint)}, waited {self.attach_timeout_s:g} s) "
                    "— check the USB cable and the board's power supply, and close other programs using it "
                    "(Phidget Control Panel)"
                ) from None
            raise BridgeError(f"{self._where(joint)}: {_describe(exc)}") from None

    def _configure(self, joint: int) -> None:
        """Pulse widths, position range and speed limit of one channel (caller holds the lock).

        Called on every attach: a replugged board has forgotten them. Pulses stay off.
        """
        ch = self._servos[joint]
        cfg = self.configs[joint]
        # widen before narrowing, so min < max holds after every single call
        if cfg.min_pulse_us >= ch.getMaxPulseWidth():
            self._call(joint, ch.setMaxPulseWidth, float(cfg.max_pulse_us))
            self._call(joint, ch.setMinPulseWidth, float(cfg.min_pulse_us))
        else:
            self._call(joint, ch.setMinPulseWidth, float(cfg.min_pulse_us))
            self._call(joint, ch.setMaxPulseWidth, float(cfg.max_pulse_us))
        self._call(joint, ch.setMinPosition, SERVO_MIN_DEG)
        self._call(joint, ch.setMaxPosition, SERVO_MAX_DEG)
        self._call(joint, ch.setVelocityLimit, float(cfg.max_speed_dps))
        self._configured[joint] = True

    def _on_attach(self, joint: int) -> None:
        """Library thread: a channel (re)attached. Configure it; it stays disengaged."""
        with self._lock:
            if not self._open or joint >= len(self._servos):
                return
            self._attached[joint] = True
            self._engaged[joint] = False
            try:
                self._configure(joint)
            except BridgeError as exc:
                self.message = str(exc)
                return
            if all(self._attached):
                self.message = "Phidget servo board attached again: servos off until the next command"

    def _on_detach(self, joint: int) -> None:
        """Library thread: a channel went away (board unplugged or lost power)."""
        with self._lock:
            if not self._open:
                return
            if all(self._attached):
                self.detaches += 1
            self._attached[joint] = False
            self._configured[joint] = False
            self._engaged[joint] = False
            self.message = (f"{self._where(joint)} detached (unplugged?) — plug it back in; "
                            "deskarm reconnects by itself")

    # ---------------------------------------------------------------- commands

    def servo_deg_for(self, q: Sequence[float]) -> tuple[float, ...]:
        """Servo degrees (0.01° steps) for ``q``: clamped to the joint limits, then checked
        again against each joint's servo range, so nothing outside it can reach a channel."""
        out = []
        for j, c in enumerate(to_servo_cdeg(q, self.profile)):
            lo, hi = self._servo_range_deg[j]
            deg = c / 100.0
            if not (math.isfinite(deg) and lo - 1e-9 <= deg <= hi + 1e-9):
                raise BridgeError(f"internal error: joint {j} at {deg}° is outside its servo range {lo}…{hi}°")
            out.append(min(max(deg, lo), hi))
        return tuple(out)

    def send(self, command: JointCommand) -> tuple[float, ...]:
        """Set every channel's target (servo degrees) and engage it; returns the degrees sent.

        ``()`` while e-stopped (nothing is written). BridgeError when not connected or detached.
        """
        if self._estopped:
            return ()
        servo_deg = self.servo_deg_for(command.q)
        self._write_targets(servo_deg)
        self.commands_sent += 1
        self.last_write_t = self.clock.now()
        self.last_source_t = command.source_t
        return servo_deg

    def _write_servo_deg(self, servo_deg: tuple[int, ...]) -> int:
        """Whole-degree targets (the base interface; ``send`` is the way in). Returns 0 bytes."""
        self._write_targets(tuple(float(d) for d in servo_deg))
        return 0

    def _write_targets(self, servo_deg: Sequence[float]) -> None:
        with self._lock:
            if self._estopped:
                return
            if not self._open:
                raise BridgeError(f"{self.url}: not connected")
            missing = [j for j, a in enumerate(self._attached) if not a]
            if missing:
                raise BridgeError(f"{self._where(missing[0])} is detached (unplugged?) — plug it back in; "
                                  "deskarm reconnects by itself")
            for j, (ch, deg) in enumerate(zip(self._servos, servo_deg)):
                # the target first: engaging starts the pulses at it, not at a stale one
                self._call(j, ch.setTargetPosition, float(deg))
                if not self._engaged[j]:
                    self._call(j, ch.setEngaged, True)
                    self._engaged[j] = True
            self.last_sent_deg = tuple(float(d) for d in servo_deg)
            self._last_sent_deg = self.last_sent_deg  # the base class's echo for joint_state

    def _on_estop(self) -> None:
        """Disengage every channel (servos limp). Never raises: a detached channel is off anyway."""
        with self._lock:
            for j, ch in enumerate(self._servos):
                try:
                    ch.setEngaged(False)
                except Exception:  # noqa: BLE001 - an unplugged board has no pulses to stop
                    pass
                self._engaged[j] = False

    def _on_rearm(self) -> None:
        """Nothing to send: each channel engages again with the next command."""

    def _estop_text(self) -> str:
        return "E-STOP: Phidget servo channels disengaged (servos limp); re-arm to resume"

    # ---------------------------------------------------------------- state

    def engaged(self) -> tuple[bool, ...]:
        """Which channels are engaged (producing pulses) now."""
        with self._lock:
            return tuple(self._engaged)

    def joint_state(self) -> Optional[JointState]:
        """Where the controller drives each servo (its ramped position), ``measured=False``.

        A channel not engaged or not attached shows the last commanded angle; None before the
        first command.
        """
        with self._lock:
            if self.last_sent_deg is None:
                return None
            deg = list(self.last_sent_deg)
            for j, ch in enumerate(self._servos):
                if self._attached[j] and self._engaged[j]:
                    try:
                        deg[j] = float(ch.getPosition())
                    except Exception:  # noqa: BLE001 - unknown while ramping up: keep the target
                        pass
        q = tuple(jt.from_servo_deg(d) for jt, d in zip(self.profile.joints, deg))
        return JointState(seq=self._state_seq.next(), t=self.clock.now(), q=q, measured=False)
