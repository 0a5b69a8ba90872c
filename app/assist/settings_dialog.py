"""The assistive view's "Switches…": which key or button is "next", "confirm" and the single switch,
the hold that stops, the sound cue — a dialog that is not modal (the window's STOP stays live beside
it, kept uncovered) and carries its own STOP; Esc is STOP there too."""
from __future__ import annotations

from dataclasses import replace
from typing import Callable, Optional

from PySide6 import QtCore, QtGui, QtWidgets

from app.assist.settings import AssistSettings
from widgets._style import BUTTON_STYLE, SPIN_STYLE, TOUCH_PX
from widgets.estop import EStopButton, StopDialog


class SwitchSettingsDialog(StopDialog):
    """Which key or mouse button is "next", "confirm" and the single switch; the long press; sound."""

    def __init__(self, settings: AssistSettings, parent=None):
        super().__init__(parent)
        self.setWindowTitle("Switches")
        self.setModal(False)  # the window's STOP stays live beside it
        self.settings = settings
        form = QtWidgets.QFormLayout(self)
        self.stop_button = EStopButton()  # its own STOP, as every dialog of deskarm; Esc is STOP too
        self.stop_button.sigStopRequested.connect(self.request_stop)
        form.addRow("Esc or STOP stops the arm", self.stop_button)
        self.edits = {}
        for role, label in (("next_switch", "2 switches: next"), ("confirm_switch", "2 switches: confirm"),
                            ("single_switch", "1 switch")):
            edit = QtWidgets.QLineEdit(", ".join(getattr(settings, role)))
            edit.setMinimumHeight(TOUCH_PX)
            edit.setToolTip("Comma-separated: key:Space, key:Return, key:F1 … or mouse:left, mouse:right, "
                            "mouse:middle. Switch interfaces usually send Space or Enter.")
            self.edits[role] = edit
            form.addRow(label, edit)
        self.long_press = QtWidgets.QDoubleSpinBox()
        self.long_press.setRange(0.5, 5.0)
        self.long_press.setSingleStep(0.5)
        self.long_press.setSuffix(" s")
        self.long_press.setValue(settings.long_press_s)
        self.long_press.setStyleSheet(SPIN_STYLE)
        form.addRow("Hold to stop / re-arm", self.long_press)
        self.sound = QtWidgets.QCheckBox("Sound when the highlight moves")
        self.sound.setChecked(settings.sound)
        form.addRow(self.sound)
        self.error = QtWidgets.QLabel("")
        self.error.setWordWrap(True)
        self.error.setStyleSheet("color: #d32f2f;")
        form.addRow(self.error)
        buttons = QtWidgets.QDialogButtonBox(QtWidgets.QDialogButtonBox.StandardButton.Ok
                                             | QtWidgets.QDialogButtonBox.StandardButton.Cancel)
        buttons.setStyleSheet(BUTTON_STYLE)
        buttons.accepted.connect(self._accept)
        buttons.rejected.connect(self.reject)
        form.addRow(buttons)

    def result_settings(self) -> AssistSettings:
        """The settings as edited (ValueError naming the problem when they are not valid)."""
        switches = {role: tuple(n.strip() for n in edit.text().split(",") if n.strip())
                    for role, edit in self.edits.items()}
        return replace(self.settings, long_press_s=float(self.long_press.value()), sound=self.sound.isChecked(),
                       **switches)

    def _accept(self) -> None:
        try:
            self.settings = self.result_settings()
        except ValueError as exc:
            self.error.setText(str(exc))
            return
        self.accept()


class SwitchSettingsEditor(QtCore.QObject):
    """The "Switches…" button and the dialog it opens (one at a time).

    Signals (GUI thread):
    - sigApplied(AssistSettings): OK was pressed on valid settings
    - sigStopRequested(): the dialog's STOP (or Esc in it)

    ``settings()``: the settings the dialog starts from; ``window``: the dialog's parent."""

    sigApplied = QtCore.Signal(object)
    sigStopRequested = QtCore.Signal()

    def __init__(self, settings: Callable[[], AssistSettings], window: QtWidgets.QWidget, font: QtGui.QFont):
        super().__init__(window)
        self._settings = settings
        self._window = window
        self.dialog: Optional[SwitchSettingsDialog] = None  # while open
        self.button = QtWidgets.QPushButton("Switches…")
        self.button.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)
        self.button.setStyleSheet(BUTTON_STYLE)
        self.button.setFont(font)
        self.button.clicked.connect(lambda: self.open())

    def open(self) -> SwitchSettingsDialog:
        """Show the dialog (raise it when already open); OK applies the settings."""
        dialog = self.dialog
        if dialog is not None and dialog.isVisible():
            dialog.raise_()
            return dialog
        dialog = self.dialog = SwitchSettingsDialog(self._settings(), self._window)
        dialog.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
        dialog.sigStopRequested.connect(lambda: self.sigStopRequested.emit())
        dialog.accepted.connect(lambda: self.sigApplied.emit(dialog.settings))
        dialog.show()
        dialog.raise_()
        dialog.activateWindow()
        return dialog
