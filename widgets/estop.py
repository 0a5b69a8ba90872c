"""The emergency-stop button: large, red, always visible; a second tap re-arms."""
from __future__ import annotations

from PySide6 import QtCore, QtWidgets

from widgets._style import ERROR_COLOUR, OK_COLOUR, TOUCH_PX

_STYLE = """
QPushButton {{
    min-height: {h}px; min-width: 120px; font-size: 15pt; font-weight: bold; color: white;
    background: {stop}; border: 3px solid #7f0000; border-radius: 8px; padding: 0 14px;
}}
QPushButton:checked {{ background: {rearm}; border: 3px solid #1b5e20; }}
"""


class EStopButton(QtWidgets.QPushButton):
    """STOP when armed; RE-ARM while stopped.

    Signals:
    - sigEstopChanged(bool): True when the user stops the arm, False when they re-arm.
    ``engage()`` (e.g. from a keyboard shortcut) stops; re-arming takes a deliberate tap.
    """

    sigEstopChanged = QtCore.Signal(bool)

    def __init__(self, parent: QtWidgets.QWidget | None = None):
        super().__init__("STOP", parent)
        self.setCheckable(True)
        self.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)
        self.setStyleSheet(_STYLE.format(h=TOUCH_PX + 8, stop=ERROR_COLOUR, rearm=OK_COLOUR))
        self.setToolTip("Emergency stop (Esc). Tap again to re-arm.")
        self.toggled.connect(self._on_toggled)

    @property
    def engaged(self) -> bool:
        return self.isChecked()

    def engage(self) -> None:
        """Stop (no effect when already stopped)."""
        if not self.isChecked():
            self.setChecked(True)

    def _on_toggled(self, checked: bool) -> None:
        self.setText("RE-ARM" if checked else "STOP")
        self.sigEstopChanged.emit(checked)
