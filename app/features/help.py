"""The help feature: ☰ → Help & about (F1) — the version, the shortcuts, and Reset settings.

``HelpFeature`` makes the ``HelpDialog`` on first use (it carries its own STOP and shows the
e-stop state) and resets the remembered settings when its Reset is held: defaults in every
control, the old file kept as .bak.

Signals (GUI thread): ``sigNote(str)`` — a message for the banner; ``sigDialogMade(object)`` —
the dialog was made (it has STOP and shows the e-stop state).
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Optional

from PySide6 import QtCore, QtWidgets

from app.window_frame import deskarm_version

if TYPE_CHECKING:  # imported when the dialog is first made (start-up)
    from widgets.help_dialog import HelpDialog


class HelpFeature(QtCore.QObject):
    """Help for ``session``'s window; ``preferences``: the window's WindowPreferences (its file,
    its reset); ``parent``: the window the dialog opens over."""

    sigNote = QtCore.Signal(str)
    sigDialogMade = QtCore.Signal(object)

    def __init__(self, session, preferences, parent: Optional[QtWidgets.QWidget] = None):
        super().__init__(parent)
        self.session = session
        self.preferences = preferences
        self._parent = parent
        self.help_dialog: Optional[HelpDialog] = None

    @QtCore.Slot()
    def show_help(self) -> HelpDialog:
        """F1: version, shortcuts, reset settings — with its own STOP."""
        if self.help_dialog is None:
            from widgets.help_dialog import HelpDialog

            self.help_dialog = HelpDialog(deskarm_version(), str(self.preferences.path), parent=self._parent)
            self.help_dialog.sigResetRequested.connect(self.on_reset_settings)
            self.sigDialogMade.emit(self.help_dialog)
        self.help_dialog.set_estop(not self.session.controller.armed)
        self.help_dialog.show()
        self.help_dialog.raise_()
        return self.help_dialog

    @QtCore.Slot()
    def on_reset_settings(self) -> None:
        """Help → Reset settings (held): defaults in every control, the old file kept as .bak."""
        if self.preferences.reset():
            text = "settings reset to defaults (the old file is kept as preferences.toml.bak)"
            self.sigNote.emit(text)
            if self.help_dialog is not None:
                self.help_dialog.set_reset_message(text)
