"""The recording feature: ● REC, the recordings dialog, and a replay's seek bar and ▶ Play again.

``RecordingFeature`` owns the ● REC button (the window puts it in the STOP strip): pressed, a
``core.record.Recorder`` records the session as a rosbag2 folder (MCAP) in the recordings folder,
fed by the window with each result, command and joint state (queue puts: the recorder's own
thread encodes and writes). For ``--camera replay:PATH`` it also owns the replay bar (progress,
a seek slider, ▶ Play again at the end) the window puts under the camera views.

Signals (GUI thread): ``sigNote(str)`` — a message for the banner; ``sigDialogMade(object)`` —
the recordings dialog was made (it has STOP and shows the e-stop state).
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Optional

from PySide6 import QtCore, QtWidgets

from app.window_texts import replay_end_text
from widgets._style import TOUCH_PX, touch_button, touch_slider

if TYPE_CHECKING:  # imported when the dialog is first made (start-up)
    from widgets.recordings_dialog import RecordingsDialog


class RecordingFeature(QtCore.QObject):
    """● REC and the replay bar for ``session``; ``parent``: the window (the dialog's parent)."""

    sigNote = QtCore.Signal(str)
    sigDialogMade = QtCore.Signal(object)

    def __init__(self, session, parent: Optional[QtWidgets.QWidget] = None):
        super().__init__(parent)
        self.session = session
        self._parent = parent
        self.recorder = None  # core.record.Recorder while the Record button is on
        self.record_path: Optional[str] = None  # where the next recording goes (None: a new dated folder)
        self.recordings_dialog: Optional[RecordingsDialog] = None
        self.record_button = touch_button("● REC", checkable=True)  # record the session (rosbag2/MCAP)
        self.record_button.setToolTip("Record cameras, markers, goals and joints as a rosbag2 folder (MCAP) "
                                      "in the recordings folder; tap again to stop")
        self.record_button.setMinimumHeight(TOUCH_PX + 8)
        self.record_button.toggled.connect(self.on_record_toggled)
        self.replay_bar = self._build_replay_bar()  # only for --camera replay:PATH

    # --- recording ----------------------------------------------------------------------------
    @QtCore.Slot(bool)
    def on_record_toggled(self, on: bool) -> None:
        """● REC: record this session as a rosbag2 folder (MCAP) in the recordings folder."""
        if not on:
            path = self.stop()
            if path:
                self.sigNote.emit(f"recording saved: {path} — replay it with `deskarm --camera replay:{path}`")
            return
        from core.record.recorder import Recorder

        s = self.session
        path, self.record_path = self.record_path, None  # --record PATH: the first recording goes there
        try:
            self.recorder = Recorder.for_session(s, path or None).start(
                calibration=s.calibration, base_T_camera=s.perception.base_T_camera,
                estopped=not s.controller.armed)
        except (OSError, ValueError) as exc:
            self.recorder = None
            self.sigNote.emit(f"cannot record: {exc}")
            blocked = self.record_button.blockSignals(True)
            self.record_button.setChecked(False)
            self.record_button.blockSignals(blocked)
        self.refresh()

    def stop(self) -> str:
        """Close the recorder (joins its thread); the folder's path, "" when none was recording."""
        recorder, self.recorder = self.recorder, None
        if recorder is None:
            return ""
        recorder.close()
        if recorder.error:
            self.sigNote.emit(f"recording stopped: {recorder.error}")
        self.refresh()
        return str(recorder.path)

    def refresh(self) -> None:
        """● REC's time and size on disk (2 Hz), and the replay bar."""
        self.refresh_replay_bar()
        r = self.recorder
        if r is None:
            text = "● REC"
        elif r.error:  # disk full: the recording ends, the loop goes on
            self.sigNote.emit(f"recording stopped: {r.error}")
            self.record_button.setChecked(False)
            return
        else:
            m, sec = divmod(int(r.elapsed_s), 60)
            text = f"■ {m}:{sec:02d}\n{r.file_bytes / 1e6:.0f} MB"  # on disk, not before compression
            if r.frames_dropped:
                text += f" · {r.frames_dropped} lost"
        if self.record_button.text() != text:
            self.record_button.setText(text)

    def result(self, result) -> None:
        if self.recorder is not None:
            if result.frame is not None:
                self.recorder.frame(result.frame)
            self.recorder.result(result)

    def command(self, command, goal) -> None:
        if self.recorder is not None:
            self.recorder.command(command, goal)

    def state(self, state) -> None:
        if self.recorder is not None:
            self.recorder.state(state)

    def estop(self, engaged: bool) -> None:
        if self.recorder is not None:
            self.recorder.estop(engaged)

    @QtCore.Slot()
    def show_recordings(self) -> RecordingsDialog:
        """☰ → Recordings…: what was recorded, and the command that replays it."""
        from core.record.recorder import list_recordings, recordings_dir
        from widgets.recordings_dialog import RecordingsDialog

        dialog = self.recordings_dialog
        if dialog is None:
            dialog = self.recordings_dialog = RecordingsDialog(str(recordings_dir()), parent=self._parent)
            self.sigDialogMade.emit(dialog)
        dialog.set_recordings(list_recordings())
        dialog.set_estop(not self.session.controller.armed)
        if self._parent is not None:
            dialog.resize(min(760, self._parent.width()), min(440, self._parent.height()))
        dialog.show()
        dialog.raise_()
        return dialog

    # --- replay -------------------------------------------------------------------------------
    def _build_replay_bar(self) -> Optional[QtWidgets.QWidget]:
        """A replay's progress and a seek slider (None for live cameras)."""
        if getattr(self.session.camera, "kind", "") != "replay":
            return None
        bar = QtWidgets.QWidget()
        row = QtWidgets.QHBoxLayout(bar)
        row.setContentsMargins(0, 0, 0, 0)
        self.replay_label = QtWidgets.QLabel("replay 0:00")
        row.addWidget(self.replay_label)
        self.replay_slider = touch_slider(QtWidgets.QSlider(QtCore.Qt.Orientation.Horizontal))
        self.replay_slider.setRange(0, 1000)
        self.replay_slider.sliderReleased.connect(self.on_replay_seek)
        row.addWidget(self.replay_slider, 1)
        return bar

    @QtCore.Slot()
    def on_replay_seek(self) -> None:
        """The seek slider was let go: the replay continues from there."""
        camera = self.session.camera
        camera.seek(self.replay_slider.value() / 1000.0 * camera.duration_s)

    def refresh_replay_bar(self) -> None:
        """The replay's progress on the seek bar and its label (not while the slider is held)."""
        camera = self.session.camera
        if self.replay_bar is None or self.replay_slider.isSliderDown():
            return
        blocked = self.replay_slider.blockSignals(True)
        self.replay_slider.setValue(round(camera.progress * 1000))
        self.replay_slider.blockSignals(blocked)
        done = camera.progress * camera.duration_s
        text = f"replay {int(done) // 60}:{int(done) % 60:02d} / {int(camera.duration_s) // 60}:" \
               f"{int(camera.duration_s) % 60:02d}"
        if self.replay_label.text() != text:
            self.replay_label.setText(text)

    def camera_problem(self, message: str) -> str:
        """The camera's problem ("" when back): at a replay's end ▶ Play again shows. Returns the
        replay's end text ("" when this is no finished replay)."""
        ended = replay_end_text(self.session.camera) if message else ""
        if self.replay_bar is not None:
            show_play_again(self.replay_bar, self.session.camera, bool(ended))
        return ended


def show_play_again(replay_bar: QtWidgets.QWidget, camera, shown: bool) -> Optional[QtWidgets.QPushButton]:
    """Show (``shown``) or hide the replay bar's ▶ Play again button, made on first use: a tap
    plays ``camera`` (a replay) from its start. Returns the button (None before it was needed)."""
    button = replay_bar.findChild(QtWidgets.QPushButton, "play_again")
    if button is None:
        if not shown:
            return None
        button = touch_button("▶ Play again")
        button.setObjectName("play_again")
        button.setToolTip("Play the recording again from its start")
        # the camera, not the window, in the slot: a window held by its own button's slot is a cycle
        button.clicked.connect(lambda *_: camera.seek(0.0))
        replay_bar.layout().addWidget(button)
    button.setVisible(shown)
    return button
