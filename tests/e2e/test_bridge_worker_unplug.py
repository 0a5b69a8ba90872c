"""The bridge QThread survives a v1 board going away mid-write, shows it, and reconnects.

The port is a serial-like fake whose ``flush`` fails as pyserial's ``tcdrain`` does on an
unplugged device (``termios.error``, not a SerialException): that used to end the worker's
thread while the window kept showing "connected".
"""
from __future__ import annotations

import errno
import termios
import threading

import serial

from app.workers import BridgeWorker, Latest
from core.devices.serial_v1 import SerialV1Bridge
from core.messages import JointCommand
from test_bridge_worker import StatusLog, session  # noqa: F401  (the fixture and the log)


class Port:
    """A v1 port: records writes; ``unplug()`` makes the next flush fail like a vanished device."""

    def __init__(self) -> None:
        self.is_open = True
        self.fd = 5
        self.writes: list[bytes] = []
        self.wrote = threading.Event()
        self._unplugged = threading.Event()

    def unplug(self) -> None:
        self._unplugged.set()

    def write(self, data: bytes) -> int:
        self.writes.append(bytes(data))
        self.wrote.set()
        return len(data)

    def flush(self) -> None:
        if self._unplugged.is_set():
            raise termios.error(errno.EIO, "Input/output error")

    def close(self) -> None:
        self.is_open = False


class Plug:
    """The serial factory: hands out a new Port per open; refuses ``refusals`` opens after an unplug."""

    def __init__(self, refusals: int) -> None:
        self.ports: list[Port] = []
        self.refusals = refusals
        self.refused = 0

    def __call__(self, url, **kwargs) -> Port:
        if self.ports and self.refused < self.refusals:
            self.refused += 1
            raise serial.SerialException(errno.ENOENT, f"could not open port {url}: [Errno 2] No such file or directory")
        self.ports.append(Port())
        return self.ports[-1]


def test_a_v1_board_unplugged_mid_write_is_shown_and_reconnected_and_the_worker_lives(qtbot, session):
    plug = Plug(refusals=2)  # 1.5 s away (retries at once, after 0.5 s, after 1 s): statuses show it
    session.bridge = SerialV1Bridge("/dev/ttyACM0", session.profile, serial_factory=plug)
    session.bridge.connect()
    commands = Latest()
    worker = BridgeWorker(session, commands, Latest())
    log = StatusLog()
    worker.sigStatus.connect(log.add)
    home = session.profile.q_home
    worker.start()
    try:
        commands.put(JointCommand(1, 0.0, home))
        assert plug.ports[0].wrote.wait(5.0)
        plug.ports[0].unplug()
        commands.put(JointCommand(2, 0.0, home))  # its flush fails: the board is gone
        qtbot.waitUntil(lambda: any(not st.connected and "no such port" in st.message for st in log.items),
                        timeout=5000)
        assert worker.isRunning()  # the thread lived through it
        qtbot.waitUntil(lambda: len(plug.ports) == 2, timeout=5000)  # the third retry worked
        commands.put(JointCommand(3, 0.0, home))
        assert plug.ports[1].wrote.wait(5.0)  # commands flow to the board again
        qtbot.waitUntil(lambda: log.items[-1].connected, timeout=5000)
    finally:
        worker.stop()
    assert worker.isFinished()
    assert worker.reconnector.disconnects == 1
    assert plug.ports[1].writes[0] == bytes.fromhex("FB00FC5AFD5A")  # home: FB 00 FC 5A FD 5A
