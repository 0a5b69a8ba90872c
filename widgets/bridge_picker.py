"""Choose the motor bridge: simulated arm, or a serial port with protocol v1 or v2."""
from __future__ import annotations

import html
from collections.abc import Callable, Sequence

from PySide6 import QtCore, QtWidgets

from core.devices.bridge import split_bridge_url
from widgets._style import (
    INFO_COLOUR,
    OK_COLOUR,
    TOUCH_PX,
    WARN_COLOUR,
    touch_button,
    touch_combo,
)

PROTOCOLS = (
    ("v2", "deskarm firmware (v2, checked) — recommended"),
    ("v1", "original firmware (v1: no checksum)"),
    ("rtx", "UMI-RTX controller (RS-232, --robot umi_rtx)"),
)
RECENT_MARK = " (recent)"


def bridge_url(protocol: str, port: str) -> str:
    """The --bridge URL for a protocol and a port path ("sim" ignores the port)."""
    port = port.strip()
    if protocol == "sim":
        return "sim://"
    if protocol == "phidget" or port.startswith("phidget://"):  # a Phidget servo board: its own URL
        return port if port.startswith("phidget://") else f"phidget://{port}"
    if protocol == "rtx":
        return port if port.startswith("rtx:") else f"rtx:{port}"
    if protocol == "v1":
        return port if port.startswith(("loop://", "v1:")) else f"v1:{port}"
    return port if port.startswith("v2:") else f"v2:{port}"


def same_bridge(a: str, b: str) -> bool:
    """True when two bridge URLs name the same protocol and port ("v1:/dev/x" is "/dev/x")."""
    try:
        return split_bridge_url(a) == split_bridge_url(b)
    except ValueError:  # not a bridge URL at all: only the very same text is the same
        return a.strip() == b.strip()


class BridgePicker(QtWidgets.QWidget):
    """A port list (editable: a typed path such as /dev/pts/5 is accepted; recently connected
    ports first, marked "recent"), a protocol choice, Connect and Use-simulated-arm buttons,
    and a status line.

    ``list_ports`` is a callable returning (label, path) pairs — core.devices.ports in the app.

    Signals (GUI thread):
    - sigConnectRequested(str): the bridge URL the user asked for (Connect or Simulated arm).
    """

    sigConnectRequested = QtCore.Signal(str)

    def __init__(self, list_ports: Callable[[], Sequence[tuple[str, str]]] | None = None,
                 parent: QtWidgets.QWidget | None = None):
        super().__init__(parent)
        self._list_ports = list_ports or (list)
        self._recent: tuple[str, ...] = ()
        self._listed: list[tuple[str, str]] = []  # (label, path) as the last refresh listed them
        self._requested: str | None = None  # the last URL asked for, until another one is
        layout = QtWidgets.QGridLayout(self)
        layout.setContentsMargins(6, 6, 6, 6)
        layout.addWidget(QtWidgets.QLabel("Serial port"), 0, 0, 1, 2)
        self.port_combo = touch_combo(QtWidgets.QComboBox())
        self.port_combo.setEditable(True)
        # a typed path stays typed: Enter must not add it to the list as a port of its own
        self.port_combo.setInsertPolicy(QtWidgets.QComboBox.InsertPolicy.NoInsert)
        self.port_combo.setMinimumHeight(TOUCH_PX)
        self.port_combo.lineEdit().setPlaceholderText("/dev/ttyACM0 or a typed path")
        layout.addWidget(self.port_combo, 1, 0)
        self.refresh_button = touch_button("Refresh")
        self.refresh_button.clicked.connect(self.refresh)
        layout.addWidget(self.refresh_button, 1, 1)
        self.protocol_combo = touch_combo(QtWidgets.QComboBox())
        self.protocol_combo.setMinimumHeight(TOUCH_PX)
        for key, label in PROTOCOLS:
            self.protocol_combo.addItem(label, key)
        layout.addWidget(self.protocol_combo, 2, 0, 1, 2)
        self.connect_button = touch_button("Connect")
        self.connect_button.clicked.connect(self._on_connect)
        layout.addWidget(self.connect_button, 3, 0)
        self.sim_button = touch_button("Simulated arm")
        self.sim_button.clicked.connect(lambda: self._request("sim://"))
        layout.addWidget(self.sim_button, 3, 1)
        self.status_label = QtWidgets.QLabel("")
        self.status_label.setWordWrap(True)
        layout.addWidget(self.status_label, 4, 0, 1, 2)
        self.refresh()

    # ------------------------------------------------------------------ ports
    def refresh(self) -> None:
        """Re-list the ports (recent ones first), keeping the chosen or typed one."""
        self._listed = list(self._list_ports())
        self._fill(self.port())

    def set_recent_ports(self, paths: Sequence[str]) -> None:
        """Ports connected before, most recent first: listed before the others, marked "recent"
        (also when nothing lists them now, e.g. a pseudo-terminal). Keeps the current choice; the
        other ports are the last refresh's (listing them again is a scan of the system's devices)."""
        self._recent = tuple(dict.fromkeys(p.strip() for p in paths if p.strip()))
        self._fill(self.port())

    def recent_ports(self) -> tuple[str, ...]:
        """The recent ports as set by :meth:`set_recent_ports`."""
        return self._recent

    def port(self) -> str:
        """The chosen port path: the listed item's stable path, or the typed text."""
        text = self.port_combo.currentText().strip()
        index = self.port_combo.findText(text)
        if index >= 0 and self.port_combo.itemData(index):
            return str(self.port_combo.itemData(index))
        return text

    def set_port(self, path: str) -> None:
        """Choose ``path``: its item when listed, else as typed text ("" chooses the first item)."""
        path = path.strip()
        index = self.port_combo.findData(path) if path else (0 if self.port_combo.count() else -1)
        if index >= 0:
            self.port_combo.setCurrentIndex(index)
        else:
            self.port_combo.setEditText(path)

    def _fill(self, keep: str) -> None:
        listed = self._listed
        labels = {path: label for label, path in listed}
        blocked = self.port_combo.blockSignals(True)
        self.port_combo.clear()
        for path in self._recent:
            self.port_combo.addItem(labels.get(path, path) + RECENT_MARK, path)
        for label, path in listed:
            if path not in self._recent:
                self.port_combo.addItem(label, path)
        self.port_combo.blockSignals(blocked)
        if keep:
            self.set_port(keep)

    # ------------------------------------------------------------------ protocol
    def protocol(self) -> str:
        """The chosen protocol key: "v2" or "v1"."""
        return str(self.protocol_combo.currentData())

    def set_protocol(self, key: str) -> bool:
        """Choose protocol "v2" or "v1"; "sim" (the Simulated arm button) leaves the choice
        alone. True when ``key`` is one of the list's; ValueError for an unknown key."""
        index = self.protocol_combo.findData(key)
        if index >= 0:
            self.protocol_combo.setCurrentIndex(index)
            return True
        if key == "sim":
            return False
        raise ValueError(f"bridge protocol {key!r}; allowed: sim, {', '.join(k for k, _ in PROTOCOLS)}")

    # ------------------------------------------------------------------ status
    def set_status(self, text: str, ok: bool | None) -> None:
        """The status line: ``ok`` True in the OK colour (connected), None in the neutral info
        colour ("connecting to …"), False in the warning colour (failed or not connected)."""
        colour = OK_COLOUR if ok else INFO_COLOUR if ok is None else WARN_COLOUR
        markup = f"<span style='color:{colour}'>{html.escape(text)}</span>"
        if markup != self.status_label.text():  # the window repeats it twice a second
            self.status_label.setText(markup)

    def show_bridge_status(self, status) -> None:
        """Show a BridgeStatus (``url``, ``connected``, ``message``) in the right colour.

        Green only for the bridge that was asked for (or, before any request, the one the
        command line chose) while it is connected. After a request for another bridge, the
        old bridge still connected is a failed switch (warning colour) once its message names
        the request ("could not switch to …"), and neutral ("connecting …") until then.
        """
        text = (f"{status.url}: {'connected' if status.connected else 'not connected'}"
                f"{' — ' + status.message if status.message else ''}")
        asked = self._requested
        if not status.connected or getattr(status, "request_failed", False):
            ok: bool | None = False
        elif asked is None or same_bridge(asked, status.url):
            ok = True
        else:
            ok = False if asked in (status.message or "") else None
        self.set_status(text, ok)

    @property
    def requested_url(self) -> str | None:
        """The bridge URL last asked for through this picker (None before any request)."""
        return self._requested

    def _on_connect(self) -> None:
        port = self.port()
        if not port:
            self.set_status("type or pick a serial port first", False)
            return
        self._request(bridge_url(self.protocol(), port))

    def _request(self, url: str) -> None:
        self._requested = url
        self.set_status(f"connecting to {url} …", None)
        self.sigConnectRequested.emit(url)
