"""Help & About: the version, the shortcuts, reset-to-defaults — with STOP on the dialog itself.

A dialog may cover the window's STOP button on a 800×480 screen, so it carries its own STOP
and shows the e-stop state (``set_estop``), like every deskarm dialog.
"""
from __future__ import annotations

from typing import Sequence

from PySide6 import QtCore, QtGui, QtWidgets

from widgets._style import ERROR_COLOUR, WARN_COLOUR, touch_button, touch_scroll_area
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

    The strip (STOP) stays at the top and Close at the bottom; what is between scrolls — drag it
    with a finger — so every shortcut is reachable on a 800×480 screen. The dialog is never
    larger than the screen, nor than the window it belongs to.

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
        self._sized = False  # sized to fit once, before it first shows
        layout = QtWidgets.QVBoxLayout(self)
        self.estop_strip = EStopStrip()
        self.estop_strip.sigStopRequested.connect(self.sigStopRequested)
        layout.addWidget(self.estop_strip)

        content = QtWidgets.QWidget()
        column = QtWidgets.QVBoxLayout(content)
        column.setContentsMargins(0, 0, 0, 0)
        about = QtWidgets.QLabel(
            f"<b>deskarm {version}</b> — see objects on the desk in 3D with two webcams and have a "
            "servo arm reach them. With nothing plugged in it runs on a simulated desk.")
        about.setWordWrap(True)
        column.addWidget(about)
        keys = QtWidgets.QGridLayout()
        keys.setHorizontalSpacing(12)
        keys.setColumnStretch(1, 1)
        self.shortcut_rows: list[tuple[QtWidgets.QLabel, QtWidgets.QLabel]] = []
        for row, (key, what) in enumerate(shortcuts):
            key_label = QtWidgets.QLabel(key)
            key_label.setTextFormat(QtCore.Qt.TextFormat.PlainText)
            bold = key_label.font()
            bold.setBold(True)
            key_label.setFont(bold)
            what_label = QtWidgets.QLabel(what)
            what_label.setTextFormat(QtCore.Qt.TextFormat.PlainText)
            what_label.setWordWrap(True)  # a long line wraps in the row instead of being cut
            keys.addWidget(key_label, row, 0, QtCore.Qt.AlignmentFlag.AlignTop)
            keys.addWidget(what_label, row, 1)
            self.shortcut_rows.append((key_label, what_label))
        column.addLayout(keys)
        self.reset_button = HoldButton("Reset settings to defaults (hold 1 s)", colour=WARN_COLOUR)
        self.reset_button.setToolTip(f"Forget the saved settings{' in ' + settings_file if settings_file else ''}")
        self.reset_button.sigHeld.connect(self.sigResetRequested)
        column.addWidget(self.reset_button)
        self.reset_label = QtWidgets.QLabel(f"Settings are kept in {settings_file}" if settings_file else "")
        self.reset_label.setWordWrap(True)
        column.addWidget(self.reset_label)
        column.addStretch(1)
        self.scroll_area = touch_scroll_area(content)
        layout.addWidget(self.scroll_area, 1)

        self.close_button = touch_button("Close")
        self.close_button.clicked.connect(self.close)
        layout.addWidget(self.close_button, 0, QtCore.Qt.AlignmentFlag.AlignRight)

    def room(self) -> QtCore.QSize:
        """The largest size the dialog takes: its screen's free area, and no more than the
        window it belongs to (on a 7" panel that window is the screen)."""
        screen = self.screen() or QtGui.QGuiApplication.primaryScreen()
        room = screen.availableGeometry().size() if screen is not None else QtCore.QSize(800, 480)
        parent = self.parentWidget()
        if parent is not None and parent.window().isVisible():
            room = room.boundedTo(parent.window().size())
        # a window manager's title bar and borders, once known, come out of it too
        frame = self.frameGeometry().size() - self.size() if self.isVisible() else QtCore.QSize(0, 0)
        return (room - frame).expandedTo(self.minimumSizeHint())

    def setVisible(self, visible: bool) -> None:  # noqa: N802 (Qt override)
        """Before the first show: as large as the content asks, within :meth:`room` (Qt would
        cap a new dialog at 2/3 of the screen: 320 px of a 480 px panel)."""
        if visible and not self._sized:
            self._sized = True
            self.resize(self.sizeHint().boundedTo(self.room()))
        super().setVisible(visible)

    def set_estop(self, engaged: bool) -> None:
        """Show the e-stop state on the dialog."""
        self.estop_strip.set_estop(engaged)

    def set_reset_message(self, text: str) -> None:
        self.reset_label.setText(text)
