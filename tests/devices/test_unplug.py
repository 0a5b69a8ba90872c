"""A serial board that goes away: only BridgeError ever reaches the caller, and the bridge says
it is disconnected, so the reconnect path runs (v1 and v2; write, flush, read and close).

The race tests unplug a pseudo-terminal (its other end closes) while the bridge writes, many
times over and without sleeps: the failure used to depend on where in ``send`` the close landed
(between pyserial's ``write`` and its ``flush``, ``tcdrain`` raised ``termios.error``). The fake
ports then make every failing operation and error type happen on purpose, one at a time.
"""
from __future__ import annotations

import errno
import os
import select
import termios
import threading
import tty
from collections import Counter

import pytest
import serial

from core.clock import SimClock
from core.devices import protocol_v2 as p
from core.devices.bridge import BridgeError, explain_serial_error
from core.devices.serial_v1 import SerialV1Bridge
from core.devices.serial_v2 import SerialV2Bridge
from core.kinematics.profile import load_profile
from core.messages import JointCommand

TIMEOUT_S = 3.0
TRIALS = 200
GONE = "the device went away (unplugged?)"


@pytest.fixture(scope="module")
def profile():
    return load_profile("desk_rrr")


class PtyPeer:
    """The board end of a pty pair: answers v2 PINGs with STATUS (a v1 bridge ignores them);
    ``unplug()`` makes it close its end, as a board that is pulled out."""

    def __init__(self) -> None:
        self.master, self.slave = os.openpty()
        tty.setraw(self.master)
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)
        self._unplug = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        decoder = p.V2Decoder()
        try:
            while not self._unplug.is_set():
                ready, _, _ = select.select([self.master], [], [], 0.002)
                if not ready:
                    continue
                for frame in decoder.feed(os.read(self.master, 4096)):
                    if isinstance(frame, p.PingFrame):
                        os.write(self.master, p.encode_status(frame.seq, int(p.Flag.V2_MODE), (0, 0, 0)))
        finally:
            os.close(self.master)  # the only closer of the master: no fd is closed twice

    def unplug(self) -> None:
        self._unplug.set()

    def close(self) -> None:
        self._unplug.set()
        self._thread.join(TIMEOUT_S)
        os.close(self.slave)


def _unplug_mid_write(make_bridge, profile) -> tuple[Counter, int]:
    """Run TRIALS unplugs under a writing bridge; returns (what escaped each time, trials that
    ended disconnected)."""
    escaped: Counter = Counter()
    disconnected = 0
    commands = [JointCommand(k, 0.0, profile.from_servo_deg((k % 180, 90, 90))) for k in range(180)]
    for _ in range(TRIALS):
        peer = PtyPeer()
        bridge = make_bridge(peer.path)
        try:
            bridge.connect()
            peer.unplug()  # the peer closes its end while we write below
            try:
                for k in range(200_000):  # ends with the first error (the close takes ~ms)
                    bridge.send(commands[k % len(commands)])
                escaped["nothing (the unplug went unnoticed)"] += 1
            except BridgeError as exc:
                escaped["BridgeError"] += 1
                assert peer.path in str(exc), str(exc)  # the message names the port
            except Exception as exc:  # noqa: BLE001 - what this test is about
                escaped[f"{type(exc).__module__}.{type(exc).__name__}: {exc}"] += 1
            if hasattr(bridge, "wait_disconnected"):
                bridge.wait_disconnected(TIMEOUT_S)
            disconnected += not bridge.is_connected
        finally:
            try:
                bridge.disconnect()
            except Exception as exc:  # noqa: BLE001
                escaped[f"disconnect: {type(exc).__name__}: {exc}"] += 1
            peer.close()
    return escaped, disconnected


def test_unplugging_a_v1_board_mid_write_raises_only_bridge_error_and_disconnects(profile):
    escaped, disconnected = _unplug_mid_write(lambda path: SerialV1Bridge(path, profile), profile)
    assert escaped == Counter({"BridgeError": TRIALS}), escaped
    assert disconnected == TRIALS


def test_unplugging_a_v2_board_mid_write_raises_only_bridge_error_and_disconnects(profile):
    def make(path):  # no rate cap: every send writes at once, as fast as the loop goes
        return SerialV2Bridge(f"v2:{path}", profile, max_command_hz=0)

    escaped, disconnected = _unplug_mid_write(make, profile)
    assert escaped == Counter({"BridgeError": TRIALS}), escaped
    assert disconnected == TRIALS


def test_a_v1_send_after_the_board_went_away_says_so_in_plain_words(profile):
    peer = PtyPeer()
    bridge = SerialV1Bridge(peer.path, profile)
    try:
        bridge.connect()
        peer.close()  # fully gone before the write
        with pytest.raises(BridgeError, match=r"the device went away \(unplugged\?\)"):
            bridge.send(JointCommand(1, 0.0, profile.q_home))
        assert not bridge.is_connected
        assert GONE in bridge.status().message
        with pytest.raises(BridgeError, match="not connected"):
            bridge.send(JointCommand(2, 0.0, profile.q_home))
    finally:
        bridge.disconnect()


# ------------------------------------------------------------------ every operation, every error


def _errors():
    """What pyserial lets through when the device goes away or the fd is closed under it."""
    return [
        pytest.param(lambda: termios.error(errno.EIO, "Input/output error"), id="termios.error"),
        pytest.param(lambda: OSError(errno.EIO, "Input/output error"), id="OSError-EIO"),
        pytest.param(lambda: OSError(errno.ENODEV, "No such device"), id="OSError-ENODEV"),
        pytest.param(lambda: serial.SerialException("write failed: [Errno 5] Input/output error"),
                     id="SerialException"),
        pytest.param(lambda: serial.PortNotOpenError(), id="PortNotOpenError"),
        pytest.param(lambda: ValueError("file descriptor cannot be a negative integer (-1)"), id="ValueError-fd"),
        pytest.param(lambda: TypeError("'NoneType' object cannot be interpreted as an integer"),
                     id="TypeError-closed"),
    ]


class FailingPort:
    """A serial-like port that fails ``op`` with ``make_error()`` once ``armed``.

    It answers v2 PINGs (so a v2 bridge can connect). A TypeError is raised as pyserial does
    for a port closed by another thread: the fd is then None.
    """

    def __init__(self, op: str, make_error) -> None:
        self.op, self.make_error = op, make_error
        self.armed = threading.Event()
        self.is_open = True
        self.fd = 7
        self.closed = 0
        self._rx = bytearray()
        self._decoder = p.V2Decoder()
        self._cond = threading.Condition()

    def _maybe_fail(self, op: str) -> None:
        if op == self.op and self.armed.is_set():
            exc = self.make_error()
            if isinstance(exc, TypeError):
                self.fd = None
            raise exc

    def write(self, data: bytes) -> int:
        self._maybe_fail("write")
        with self._cond:
            for frame in self._decoder.feed(data):
                if isinstance(frame, p.PingFrame):
                    self._rx += p.encode_status(frame.seq, int(p.Flag.V2_MODE), (0, 0, 0))
            self._cond.notify_all()
        return len(data)

    def flush(self) -> None:
        self._maybe_fail("flush")

    @property
    def in_waiting(self) -> int:
        self._maybe_fail("in_waiting")
        return len(self._rx)

    def read(self, size: int = 1) -> bytes:
        self._maybe_fail("read")
        with self._cond:
            if not self._rx:
                self._cond.wait(0.002)
            out = bytes(self._rx[:size])
            del self._rx[:size]
            return out

    def reset_input_buffer(self) -> None:
        pass

    def close(self) -> None:
        self.closed += 1
        self._maybe_fail("close")
        self.is_open = False


def _v1(profile, port) -> SerialV1Bridge:
    return SerialV1Bridge("/dev/ttyACM0", profile, clock=SimClock(), serial_factory=lambda url, **kw: port)


def _v2(profile, port) -> SerialV2Bridge:
    # no heartbeat, no rate cap: only ``send`` writes, so a write error is always the caller's
    return SerialV2Bridge("v2:/dev/ttyACM0", profile, clock=SimClock(), max_command_hz=0, heartbeat_hz=0,
                          serial_factory=lambda url, **kw: port)


@pytest.mark.parametrize("make_error", _errors())
@pytest.mark.parametrize("op", ["write", "flush"])
def test_a_v1_write_or_flush_error_is_a_bridge_error_and_the_bridge_is_disconnected(profile, op, make_error):
    port = FailingPort(op, make_error)
    bridge = _v1(profile, port)
    bridge.connect()
    assert bridge.send(JointCommand(1, 0.0, profile.q_home)) == (0, 90, 90)
    port.armed.set()
    with pytest.raises(BridgeError, match=r"^/dev/ttyACM0: the device went away \(unplugged\?\)"):
        bridge.send(JointCommand(2, 0.0, profile.q_home))
    assert not bridge.is_connected and port.closed == 1  # closed, not leaked
    assert GONE in bridge.status().message
    bridge.disconnect()  # nothing left to close: no error


@pytest.mark.parametrize("make_error", _errors())
@pytest.mark.parametrize("op", ["read", "in_waiting"])
def test_a_v1_read_error_is_a_bridge_error_and_the_bridge_is_disconnected(profile, op, make_error):
    port = FailingPort(op, make_error)
    bridge = _v1(profile, port)
    bridge.connect()
    port.armed.set()
    with pytest.raises(BridgeError, match=r"the device went away \(unplugged\?\)"):
        bridge.read_available()
    assert not bridge.is_connected


@pytest.mark.parametrize("make_error", _errors())
@pytest.mark.parametrize("make", [_v1, _v2], ids=["v1", "v2"])
def test_a_close_error_never_escapes_disconnect(profile, make, make_error):
    port = FailingPort("close", make_error)
    bridge = make(profile, port)
    bridge.connect()
    port.armed.set()
    bridge.disconnect()  # the port is gone either way: closing it is done
    assert not bridge.is_connected and port.closed == 1
    bridge.disconnect()


@pytest.mark.parametrize("make_error", _errors())
def test_a_v2_write_error_is_a_bridge_error_and_the_bridge_is_disconnected(profile, make_error):
    port = FailingPort("write", make_error)
    bridge = _v2(profile, port)
    bridge.connect()
    try:
        port.armed.set()
        with pytest.raises(BridgeError, match=r"^/dev/ttyACM0: the device went away \(unplugged\?\)"):
            bridge.send(JointCommand(1, 0.0, profile.q_home))
        assert bridge.wait_disconnected(TIMEOUT_S) and not bridge.is_connected
        assert GONE in bridge.status().message
    finally:
        bridge.disconnect()


@pytest.mark.parametrize("make_error", _errors())
@pytest.mark.parametrize("op", ["read", "in_waiting"])
def test_a_v2_read_error_disconnects_with_a_plain_message(profile, op, make_error):
    port = FailingPort(op, make_error)
    bridge = _v2(profile, port)
    bridge.connect()
    try:
        port.armed.set()
        assert bridge.wait_disconnected(TIMEOUT_S) and not bridge.is_connected
        assert GONE in bridge.status().message, bridge.status().message
        with pytest.raises(BridgeError, match="not connected"):
            bridge.send(JointCommand(1, 0.0, profile.q_home))
    finally:
        bridge.disconnect()


# ------------------------------------------------------------------ the helpers


@pytest.mark.parametrize("exc", [
    termios.error(errno.EIO, "Input/output error"),
    ValueError("file descriptor cannot be a negative integer (-1)"),
    ValueError("I/O operation on closed file"),
    OSError(errno.ENXIO, "No such device or address"),
])
def test_errors_of_a_port_that_went_away_are_explained_in_plain_words(exc):
    assert explain_serial_error("/dev/ttyACM0", exc) == (
        "/dev/ttyACM0: the device went away (unplugged?) — plug it back in; deskarm reconnects by itself")


def test_termios_errors_are_read_by_their_errno():
    assert "permission denied" in explain_serial_error("/dev/ttyACM0", termios.error(errno.EACCES, "Permission denied"))


def test_serial_error_types_cover_what_pyserial_lets_through():
    from core.devices.bridge import serial_error_types

    kinds = serial_error_types()
    for exc in (termios.error(5, "x"), OSError(5, "x"), serial.SerialException("x"), ValueError("x"), TypeError("x")):
        assert isinstance(exc, kinds), exc
    assert not isinstance(KeyboardInterrupt(), kinds)


def test_an_error_on_a_port_closed_under_the_call_counts_as_the_device_gone():
    from core.devices.bridge import lost_port_error

    class Closed:
        is_open = False
        fd = None

    err = lost_port_error("/dev/ttyACM0", Closed(), TypeError("'NoneType' object cannot be interpreted as an integer"))
    assert isinstance(err, BridgeError) and GONE in str(err)
