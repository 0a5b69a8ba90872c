"""The UMI-RTX's encoder initialisation: one progress bar per joint, Start / Cancel, the state.

The panel shows; it owns no bridge. The owner connects ``sigStartRequested`` to whatever runs
``RtxBridge.initialise`` in a worker thread (``app.rtx_init_worker.RtxInitRunner``), feeds each
``InitProgress`` to ``set_progress`` and the bridge's state to ``set_state``; ``sigCancelRequested``
must stop the initialisation (which stops every motor).

Signals (all emitted in the GUI thread, from the buttons):
- sigStartRequested(): the user asked to initialise (the arm will drive to its end stops).
- sigCancelRequested(): the user asked to stop the initialisation now.
"""
from __future__ import annotations

from PySide6 import QtCore, QtWidgets

from widgets._style import ERROR_COLOUR, OK_COLOUR, TOUCH_PX

JOINT_LABELS = (  # (InitProgress joint name, label), in the order the initialisation does them
    ("column", "Column"),
    ("gripper", "Gripper"),
    ("wrist_roll", "Wrist roll"),
    ("wrist_pitch", "Wrist pitch"),
    ("shoulder", "Shoulder"),
    ("elbow", "Elbow"),
    ("wrist_yaw", "Wrist yaw"),
)
WARNING = ("Initialising drives every joint slowly into its end stops, then to the start pose. "
           "Clear the arm's reach first.")


class RtxInitPanel(QtWidgets.QWidget):
    """Per-joint progress of the RTX's initialisation, Start / Cancel (≥ 44 px) and a state line."""

    sigStartRequested = QtCore.Signal()
    sigCancelRequested = QtCore.Signal()

    def __init__(self, parent: QtWidgets.QWidget | None = None):
        super().__init__(parent)
        self.setObjectName("rtxInitPanel")
        layout = QtWidgets.QVBoxLayout(self)
        warning = QtWidgets.QLabel(WARNING)
        warning.setWordWrap(True)
        layout.addWidget(warning)
        grid = QtWidgets.QGridLayout()
        self.bars: dict[str, QtWidgets.QProgressBar] = {}
        for row, (name, label) in enumerate(JOINT_LABELS):
            grid.addWidget(QtWidgets.QLabel(label), row, 0)
            bar = QtWidgets.QProgressBar()
            bar.setRange(0, 100)
            bar.setValue(0)
            bar.setFormat("%p %")
            bar.setObjectName(f"rtxInit_{name}")
            grid.addWidget(bar, row, 1)
            self.bars[name] = bar
        layout.addLayout(grid)
        self.state_label = QtWidgets.QLabel("")
        self.state_label.setWordWrap(True)
        self.state_label.setObjectName("rtxInitState")
        layout.addWidget(self.state_label)
        buttons = QtWidgets.QHBoxLayout()
        self.start_button = QtWidgets.QPushButton("Start initialisation")
        self.cancel_button = QtWidgets.QPushButton("Cancel (stops every motor)")
        for b in (self.start_button, self.cancel_button):
            b.setMinimumHeight(TOUCH_PX)
            b.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)
            buttons.addWidget(b)
        layout.addLayout(buttons)
        layout.addStretch(1)
        self.start_button.clicked.connect(self._on_start)
        self.cancel_button.clicked.connect(self.sigCancelRequested)
        self._running = False
        self.set_state(ready=False, reason="not initialised", initialising=False)

    @property
    def running(self) -> bool:
        """True from Start until the initialisation reports it is done."""
        return self._running

    def _on_start(self) -> None:
        for bar in self.bars.values():
            bar.setValue(0)
        self._running = True
        self._update_buttons()
        self.state_label.setText("starting …")
        self.sigStartRequested.emit()

    @QtCore.Slot(object)
    def set_progress(self, event) -> None:
        """Show one ``InitProgress``: every joint's bar and the step in words."""
        for name, fraction in getattr(event, "fractions", ()):
            if name in self.bars:
                self.bars[name].setValue(int(round(100 * max(0.0, min(1.0, fraction)))))
        self.state_label.setText(event.text)
        if event.done:
            self._running = False
            self._paint_state(ok=event.ok)
        else:
            self._running = True
            self.state_label.setStyleSheet("")
        self._update_buttons()

    @QtCore.Slot(bool, str, bool)
    def set_state(self, ready: bool, reason: str, initialising: bool) -> None:
        """The bridge's state: ready, or why not (``reason``), and whether it is initialising."""
        self._running = bool(initialising)
        if not initialising:
            self.state_label.setText("ready — the arm is initialised" if ready else reason)
            self._paint_state(ok=ready)
        self._update_buttons()

    def _paint_state(self, ok: bool) -> None:
        self.state_label.setStyleSheet(f"color: {OK_COLOUR if ok else ERROR_COLOUR};")

    def _update_buttons(self) -> None:
        self.start_button.setEnabled(not self._running)
        self.cancel_button.setEnabled(self._running)
