"""Help & About: the version, the shortcuts, reset-to-defaults — with STOP on the dialog itself.

A dialog may cover the window's STOP button on a 800×480 screen, so it carries its own STOP
and shows the e-stop state (``set_estop``), like every deskarm dialog.
"""
from __future__ import annotations

from typing import Sequence

from PySide6 import QtCore, QtWidgets

from widgets._style import ERROR_COLOUR, WARN_COLOUR, touch_button
from widgets.estop import EStopButton, HoldButton, StopDialog

SHORTCUTS = (
    ("Esc", "STOP the arm (works in every dialog)"),
    ("F11", "full screen on / off"),
    ("F1", "this help"),
    ("Ctrl+Q", "quit (the arm stops first)"),
    ("← → ↑ ↓", "jog x / y (joint space: the selected joint −/+); hold to keep moving"),
    ("PgUp / PgDn", "jog z up / down"),
    ("[ ]", "smaller / bigger jog step (also − and +)"),
    ("J", "jog in x/y/z or joint space"),
    ("1–9", "joint space: pick the joint to jog"),
)


class EStopStrip(QtWidgets.QWidget):
    """A dialog's e-stop row: a STOP button and the arm's state in words.

    Signals:
    - sigStopRequested(): STOP tapped (the owner stops the arm; this strip never re-arms).
    """

    sigStopRequested = QtCore.Signal()

    def __init__(self, parent: QtWidgets.QWidget | None = None):
        super().__init__(parent)
        row = QtWidgets.QHBoxLayout(self)
        row.setContentsMargins(0, 0, 0, 0)
        self.state_label = QtWidgets.QLabel()
        self.state_label.setWordWrap(True)
        row.addWidget(self.state_label, 1)
        self.stop_button = EStopButton()
        self.stop_button.sigStopRequested.connect(self.sigStopRequested)
        row.addWidget(self.stop_button)
        self.set_estop(False)

    def set_estop(self, engaged: bool) -> None:
        """Show whether the arm is stopped."""
        self.stop_button.set_engaged(engaged)
        if engaged:
            self.state_label.setText("ARM STOPPED (e-stop) — re-arm in the main window")
            self.state_label.setStyleSheet(f"QLabel {{ color: {ERROR_COLOUR}; font-weight: bold; }}")
        else:
            self.state_label.setText("The arm keeps moving while this is open — STOP stops it")
            self.state_label.setStyleSheet("")


class HelpDialog(StopDialog):
    """Version, shortcuts and "reset settings to defaults" (hold 1 s), with an e-stop strip.

    Signals:
    - sigStopRequested(): STOP on the dialog (or Esc) was tapped.
    - sigResetRequested(): "Reset settings to defaults" was held.
    """

    sigResetRequested = QtCore.Signal()

    def __init__(self, version: str, settings_file: str = "",
                 shortcuts: Sequence[tuple[str, str]] = SHORTCUTS,
                 parent: QtWidgets.QWidget | None = None):
        super().__init__(parent)
        self.setWindowTitle("deskarm — help")
        self.setModal(False)
        layout = QtWidgets.QVBoxLayout(self)
        self.estop_strip = EStopStrip()
        self.estop_strip.sigStopRequested.connect(self.sigStopRequested)
        layout.addWidget(self.estop_strip)
        about = QtWidgets.QLabel(
            f"<b>deskarm {version}</b> — see objects on the desk in 3D with two webcams and have a "
            "servo arm reach them. With nothing plugged in it runs on a simulated desk.")
        about.setWordWrap(True)
        layout.addWidget(about)
        rows = "".join(f"<tr><td><b>{key}</b>&nbsp;&nbsp;</td><td>{what}</td></tr>" for key, what in shortcuts)
        keys = QtWidgets.QLabel(f"<table>{rows}</table>")
        layout.addWidget(keys)
        self.reset_button = HoldButton("Reset settings to defaults (hold 1 s)", colour=WARN_COLOUR)
        self.reset_button.setToolTip(f"Forget the saved settings{' in ' + settings_file if settings_file else ''}")
        self.reset_button.sigHeld.connect(self.sigResetRequested)
        layout.addWidget(self.reset_button)
        self.reset_label = QtWidgets.QLabel(f"Settings are kept in {settings_file}" if settings_file else "")
        self.reset_label.setWordWrap(True)
        layout.addWidget(self.reset_label)
        self.close_button = touch_button("Close")
        self.close_button.clicked.connect(self.close)
        layout.addWidget(self.close_button, 0, QtCore.Qt.AlignmentFlag.AlignRight)

    def set_estop(self, engaged: bool) -> None:
        """Show the e-stop state on the dialog."""
        self.estop_strip.set_estop(engaged)

    def set_reset_message(self, text: str) -> None:
        self.reset_label.setText(text)

