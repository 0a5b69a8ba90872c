"""The recording feature on its own (app/features/recording.py): ● REC records the session as a
rosbag2 folder (MCAP), and a second tap closes it and says where it is; the recordings dialog lists it. A real session and recorder, no MainWindow."""
from pathlib import Path

import pytest
from PySide6 import QtCore

from app.features.recording import RecordingFeature
from feature_rig import show_page

LEFT = QtCore.Qt.MouseButton.LeftButton


@pytest.fixture
def recording(qtbot, session, tmp_path):
    feature = RecordingFeature(session)
    feature.notes = []
    feature.sigNote.connect(feature.notes.append)
    feature.host = show_page(qtbot, feature.record_button, size=(200, 80))  # kept: qtbot holds it weakly
    yield feature
    feature.stop()  # joins the recorder's thread if a test left it recording
    if feature.recordings_dialog is not None:
        feature.recordings_dialog.close()


def test_rec_records_what_it_is_fed_and_a_second_tap_saves_it(qtbot, recording, session, tmp_path):
    recording.record_path = str(tmp_path / "take1")
    qtbot.mouseClick(recording.record_button, LEFT)
    recorder = recording.recorder
    assert recorder is not None and recording.record_button.isChecked()
    recording.refresh()
    assert recording.record_button.text().startswith("■ 0:")
    qtbot.mouseClick(recording.record_button, LEFT)
    assert recording.recorder is None and recording.record_button.text() == "● REC"
    assert recording.notes and str(tmp_path / "take1") in recording.notes[-1]
    assert "replay it with `deskarm --camera replay:" in recording.notes[-1]
    assert any(Path(recorder.path).glob("*.mcap")), list(Path(recorder.path).iterdir())


def test_a_recording_that_cannot_start_unpresses_rec_and_says_why(qtbot, recording, tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    recording.record_path = str(blocker / "take")  # a folder inside a file: OSError
    qtbot.mouseClick(recording.record_button, LEFT)
    assert recording.recorder is None and not recording.record_button.isChecked()
    assert recording.notes[-1].startswith("cannot record:")


def test_the_recordings_dialog_is_made_once_and_announced(qtbot, recording):
    made = []
    recording.sigDialogMade.connect(made.append)
    dialog = recording.show_recordings()
    assert recording.show_recordings() is dialog and made == [dialog] and dialog.isVisible()


def test_a_live_camera_has_no_replay_bar(recording):
    assert recording.replay_bar is None and recording.camera_problem("camera gone") == ""
