"""Choose the motor bridge: simulated arm, or a serial port with protocol v1 or v2."""
from __future__ import annotations

from typing import Callable, Optional, Sequence

from PySide6 import QtCore, QtWidgets

from widgets._style import TOUCH_PX, touch_button

PROTOCOLS = (
    ("v2", "deskarm firmware (v2, checked) — recommended"),
    ("v1", "original firmware (v1: no checksum)"),
)


def bridge_url(protocol: str, port: str) -> str:
    """The --bridge URL for a protocol and a port path ("sim" ignores the port)."""
    port = port.strip()
    if protocol == "sim":
        return "sim://"
    if protocol == "v1":
        return port if port.startswith(("loop://", "v1:")) else f"v1:{port}"
    return port if port.startswith("v2:") else f"v2:{port}"


class BridgePicker(QtWidgets.QWidget):
    """A port list (editable: a typed path such as /dev/pts/5 is accepted), a protocol
    choice, Connect and Use-simulated-arm buttons, and a status line.

    ``list_ports`` is a callable returning (label, path) pairs — core.devices.ports in the app.

    Signals:
    - sigConnectRequested(str): the bridge URL the user asked for.
    """

    sigConnectRequested = QtCore.Signal(str)

    def __init__(self, list_ports: Optional[Callable[[], Sequence[tuple[str, str]]]] = None,
                 parent: QtWidgets.QWidget | None = None):
        super().__init__(parent)
        self._list_ports = list_ports or (lambda: [])
        layout = QtWidgets.QGridLayout(self)
        layout.setContentsMargins(6, 6, 6, 6)
        layout.addWidget(QtWidgets.QLabel("Serial port"), 0, 0, 1, 2)
        self.port_combo = QtWidgets.QComboBox()
        self.port_combo.setEditable(True)
        self.port_combo.setMinimumHeight(TOUCH_PX)
        self.port_combo.lineEdit().setPlaceholderText("/dev/ttyACM0 or a typed path")
        layout.addWidget(self.port_combo, 1, 0)
        self.refresh_button = touch_button("Refresh")
        self.refresh_button.clicked.connect(self.refresh)
        layout.addWidget(self.refresh_button, 1, 1)
        self.protocol_combo = QtWidgets.QComboBox()
        self.protocol_combo.setMinimumHeight(TOUCH_PX)
        for key, label in PROTOCOLS:
            self.protocol_combo.addItem(label, key)
        layout.addWidget(self.protocol_combo, 2, 0, 1, 2)
        self.connect_button = touch_button("Connect")
        self.connect_button.clicked.connect(self._on_connect)
        layout.addWidget(self.connect_button, 3, 0)
        self.sim_button = touch_button("Simulated arm")
        self.sim_button.clicked.connect(lambda: self.sigConnectRequested.emit("sim://"))
        layout.addWidget(self.sim_button, 3, 1)
        self.status_label = QtWidgets.QLabel("")
        self.status_label.setWordWrap(True)
        layout.addWidget(self.status_label, 4, 0, 1, 2)
        self.refresh()

    def refresh(self) -> None:
        """Re-list the ports, keeping a typed path."""
        typed = self.port_combo.currentText()
        self.port_combo.clear()
        for label, path in self._list_ports():
            self.port_combo.addItem(label, path)
        if typed:
            self.port_combo.setEditText(typed)

    def port(self) -> str:
        """The chosen port path: the listed item's stable path, or the typed text."""
        text = self.port_combo.currentText().strip()
        index = self.port_combo.findText(text)
        if index >= 0 and self.port_combo.itemData(index):
            return str(self.port_combo.itemData(index))
        return text

    def set_status(self, text: str, ok: bool) -> None:
        colour = "#2e9d44" if ok else "#d32f2f"
        html = f"<span style='color:{colour}'>{text}</span>"
        if html != self.status_label.text():  # the window repeats it twice a second
            self.status_label.setText(html)

    def _on_connect(self) -> None:
        port = self.port()
        if not port:
            self.set_status("type or pick a serial port first", False)
            return
        self.sigConnectRequested.emit(bridge_url(self.protocol_combo.currentData(), port))
