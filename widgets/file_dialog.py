"""A file dialog that leaves STOP alive: Qt's own (not the desktop's), not modal, with a STOP of its own.

A native or modal file dialog blocks every other window of the application — a tap on the main
window's STOP does nothing while it is open — and takes Esc as Cancel. This one:

- is a :class:`widgets.estop.StopDialog`: STOP at its top and Esc = STOP (Esc never cancels; the
  Cancel button does); its STOP stops every guarded window (``StopGuard.stop_all``);
- is not modal, so the window's own STOP stays live beside it (and the window's ``StopGuard``
  keeps it off STOP's rectangle);
- answers through a callback instead of a nested event loop: ``on_chosen(path, name_filter)``
  once a file is chosen, nothing when it is cancelled or closed.
"""
from __future__ import annotations

from typing import Callable, Optional

from PySide6 import QtCore, QtWidgets

from widgets._style import TOUCH_PX
from widgets.estop import EStopButton, StopDialog, StopGuard

ChosenHandler = Callable[[str, str], None]


class FileDialogWithStop(StopDialog):
    """Qt's file dialog inside a dialog that carries STOP (see the module docstring).

    Signals:
    - sigChosen(str path, str name_filter): the user chose a file (Save / Open).
    - sigStopRequested(): STOP or Esc (also sent to every window's guard).
    """

    sigChosen = QtCore.Signal(str, str)

    def __init__(self, parent: Optional[QtWidgets.QWidget], title: str, directory: str = "",
                 name_filter: str = "", save: bool = False, selected_filter: str = ""):
        super().__init__(parent)
        self.setWindowTitle(title)
        self.setModal(False)
        self.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(6, 6, 6, 6)
        top = QtWidgets.QHBoxLayout()
        note = QtWidgets.QLabel("Esc or STOP stops the arm; Cancel closes this.")
        note.setWordWrap(True)
        top.addWidget(note, 1)
        self.stop_button = EStopButton()
        self.stop_button.sigStopRequested.connect(self.request_stop)
        top.addWidget(self.stop_button)
        layout.addLayout(top)
        files = QtWidgets.QFileDialog(self, title, directory, name_filter)
        files.setWindowFlags(QtCore.Qt.WindowType.Widget)  # a page of this dialog, not a window
        files.setOption(QtWidgets.QFileDialog.Option.DontUseNativeDialog, True)
        files.setAcceptMode(QtWidgets.QFileDialog.AcceptMode.AcceptSave if save
                            else QtWidgets.QFileDialog.AcceptMode.AcceptOpen)
        files.setFileMode(QtWidgets.QFileDialog.FileMode.AnyFile if save
                          else QtWidgets.QFileDialog.FileMode.ExistingFile)
        if selected_filter:
            files.selectNameFilter(selected_filter)
        if save and directory and not QtCore.QFileInfo(directory).isDir():
            files.selectFile(directory)  # a suggested name: its folder opens, the name is typed in
        for button in files.findChildren(QtWidgets.QPushButton):
            button.setMinimumHeight(TOUCH_PX)
        files.accepted.connect(self._on_accepted)
        files.rejected.connect(self.close)
        layout.addWidget(files, 1)
        self.files = files
        self.sigStopRequested.connect(StopGuard.stop_all)

    def _on_accepted(self) -> None:
        chosen = self.files.selectedFiles()
        name_filter = self.files.selectedNameFilter()
        self.close()
        if chosen:
            self.sigChosen.emit(chosen[0], name_filter)


def open_file_dialog(parent: Optional[QtWidgets.QWidget], title: str, on_chosen: ChosenHandler,
                     directory: str = "", name_filter: str = "", save: bool = False,
                     selected_filter: str = "") -> FileDialogWithStop:
    """Show a :class:`FileDialogWithStop` and call ``on_chosen(path, name_filter)`` when a file is
    chosen; returns the dialog (already shown) at once."""
    dialog = FileDialogWithStop(parent, title, directory, name_filter, save, selected_filter)
    dialog.sigChosen.connect(on_chosen)
    dialog.resize(720, 460)
    dialog.show()
    dialog.raise_()
    dialog.activateWindow()
    return dialog
