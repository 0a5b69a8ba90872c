"""The recordings on disk: when, how long, how big, which robot — and how to replay one.

A replay restarts deskarm with the recording as its camera (``--camera replay:PATH``): the
window, its calibration and its ground truth all come from the recording. Like every deskarm
dialog it carries STOP and shows the e-stop state.
"""
from __future__ import annotations

from typing import Sequence

from PySide6 import QtCore, QtWidgets

from widgets._style import TOUCH_PX, touch_button
from widgets.estop import StopDialog
from widgets.help_dialog import EStopStrip


class RecordingsDialog(StopDialog):
    """A list of recordings (newest first); tapping one shows the command that replays it.

    ``set_recordings(infos)`` takes objects with ``path``, ``started`` (datetime or None),
    ``duration_s``, ``size_bytes``, ``robot`` and ``complete``.

    Signals:
    - sigStopRequested(): STOP on the dialog.
    """


    def __init__(self, folder: str = "", parent: QtWidgets.QWidget | None = None):
        super().__init__(parent)
        self.setWindowTitle("deskarm — recordings")
        layout = QtWidgets.QVBoxLayout(self)
        self.estop_strip = EStopStrip()
        self.estop_strip.sigStopRequested.connect(self.sigStopRequested)
        layout.addWidget(self.estop_strip)
        self.folder_label = QtWidgets.QLabel(f"Recordings in {folder}" if folder else "")
        self.folder_label.setWordWrap(True)
        layout.addWidget(self.folder_label)
        self.list = QtWidgets.QListWidget()
        self.list.setStyleSheet(f"QListWidget::item {{ min-height: {TOUCH_PX}px; }}")
        self.list.currentRowChanged.connect(self._on_row)
        layout.addWidget(self.list, 1)
        self.command_label = QtWidgets.QLabel("Tap a recording to see how to replay it.")
        self.command_label.setWordWrap(True)
        self.command_label.setTextInteractionFlags(QtCore.Qt.TextInteractionFlag.TextSelectableByMouse)
        layout.addWidget(self.command_label)
        self.close_button = touch_button("Close")
        self.close_button.clicked.connect(self.close)
        layout.addWidget(self.close_button, 0, QtCore.Qt.AlignmentFlag.AlignRight)
        self._infos: list = []

    def set_estop(self, engaged: bool) -> None:
        self.estop_strip.set_estop(engaged)

    def set_recordings(self, infos: Sequence) -> None:
        self._infos = list(infos)
        self.list.clear()
        for info in self._infos:
            when = info.started.strftime("%Y-%m-%d %H:%M") if info.started is not None else "?"
            state = "" if info.complete else " · cut short (readable up to its last chunk)"
            self.list.addItem(f"{info.path.name}  ·  {when}  ·  {info.duration_s:.0f} s  ·  "
                              f"{info.size_bytes / 1e6:.1f} MB  ·  {info.robot or '?'}{state}")
        if not self._infos:
            self.command_label.setText("No recordings yet: tap ● REC in the window (or run "
                                       "`deskarm --headless --record`).")

    def command_for(self, row: int) -> str:
        return f"deskarm --camera replay:{self._infos[row].path}"

    def _on_row(self, row: int) -> None:
        if 0 <= row < len(self._infos):
            self.command_label.setText(f"Replay it through the whole pipeline with:\n{self.command_for(row)}"
                                       "\n(add --headless --fast --json to score it without a window)")

