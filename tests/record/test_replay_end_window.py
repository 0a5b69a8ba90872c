"""The end of a replay in the main window (issue 22 items 14 and 15): it says the recording
finished — no "camera lost … retrying" — and ▶ Play again (or the seek bar) plays it again; a
replay starts in its own mode, not in the mode the last run left in the preferences."""
from __future__ import annotations

import pytest
from PySide6 import QtCore, QtWidgets

from app.gui import MainWindow, replay_end_text
from core.messages import TargetMode
from core.preferences import Preferences, load_preferences, save_preferences
from core.session import DeskSession, SessionOptions
from make_recording import make_recording
from widgets._style import TOUCH_PX

SECONDS = 1.0  # a short recording: the window plays it to its end twice in a test
FPS = 15.0
TIMEOUT_MS = 15000
LEFT = QtCore.Qt.MouseButton.LeftButton


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    return make_recording(tmp_path_factory.mktemp("rec") / "short", seconds=SECONDS, fps=FPS).path


@pytest.fixture
def home(tmp_path, monkeypatch):
    monkeypatch.setenv("DESKARM_HOME", str(tmp_path / "home"))
    return tmp_path / "home"


@pytest.fixture
def replay_window(qtbot, recording, home):
    """A started window replaying the short recording; stopped (workers joined, camera closed) after."""
    made = []

    def make():
        session = DeskSession.create(SessionOptions(camera=f"replay:{recording}", scenario="static"))
        w = MainWindow(session)
        qtbot.addWidget(w)
        w.resize(800, 480)
        w.show()
        qtbot.waitExposed(w)
        made.append(w)
        return w

    yield make
    for w in made:
        w.stop()
        w.session.close()


def play_again_button(w):
    return w.replay_bar.findChild(QtWidgets.QPushButton, "play_again")


def ended(w) -> bool:
    return "replay finished" in w.banner.text() and w.banner.isVisible()


def test_the_end_of_a_replay_says_finished_and_play_again_plays_it_from_the_start(qtbot, replay_window):
    w = replay_window()
    w.start()
    qtbot.waitUntil(lambda: ended(w), timeout=TIMEOUT_MS)
    text = w.banner.text()
    assert "camera lost" not in text and "retrying" not in text and w.banner.level == "info"
    assert "(0:01)" in text  # the recording's length
    assert w._camera_error is None
    assert w.view_left.placeholder_text() == "" and w.view_right.placeholder_text() == ""  # the last frame stays
    button = play_again_button(w)
    assert button is not None and button.isVisible() and button.height() >= TOUCH_PX
    delivered = w.session.camera.frames_delivered
    qtbot.mouseClick(button, LEFT)  # a real tap on ▶ Play again
    qtbot.waitUntil(lambda: w.session.camera.frames_delivered > delivered and not ended(w), timeout=TIMEOUT_MS)
    assert not button.isVisible() and w._camera_error is None
    # it plays through to the end again, and says so again
    qtbot.waitUntil(lambda: ended(w) and button.isVisible(), timeout=TIMEOUT_MS)
    assert w.session.camera.frames_delivered >= delivered + int(SECONDS * FPS) // 2


def test_dragging_the_seek_bar_back_after_the_end_plays_again(qtbot, replay_window):
    w = replay_window()
    w.start()
    qtbot.waitUntil(lambda: ended(w), timeout=TIMEOUT_MS)
    slider = w.replay_slider
    w._refresh_replay_bar()
    assert slider.value() == slider.maximum()
    opt = QtWidgets.QStyleOptionSlider()
    slider.initStyleOption(opt)
    handle = slider.style().subControlRect(QtWidgets.QStyle.ComplexControl.CC_Slider, opt,
                                           QtWidgets.QStyle.SubControl.SC_SliderHandle, slider)
    start = handle.center()
    end = QtCore.QPoint(slider.rect().left() + 2, start.y())
    delivered = w.session.camera.frames_delivered
    with qtbot.waitSignal(slider.sliderReleased, timeout=TIMEOUT_MS):
        qtbot.mousePress(slider, LEFT, pos=start)
        for k in range(1, 6):  # a drag, in steps, as a finger moves
            qtbot.mouseMove(slider, QtCore.QPoint(start.x() + (end.x() - start.x()) * k // 5, start.y()))
        qtbot.mouseRelease(slider, LEFT, pos=end)
    assert slider.value() < slider.maximum() // 4
    qtbot.waitUntil(lambda: w.session.camera.frames_delivered > delivered and not ended(w), timeout=TIMEOUT_MS)
    assert not play_again_button(w).isVisible()


def test_replay_end_text_is_empty_until_a_replay_has_finished(recording):
    from core.record.replay import open_replay

    cam = open_replay(recording, fast=True)
    try:
        assert replay_end_text(cam) == ""
        while cam.read() is not None or not cam.finished:
            pass
        assert replay_end_text(cam).startswith("replay finished (0:01)")
        cam.seek(0.0)
        assert cam.read() is not None and replay_end_text(cam) == ""
    finally:
        cam.disconnect()
    assert replay_end_text(object()) == ""  # not a replay: nothing to say


@pytest.mark.parametrize("saved", [TargetMode.TELEOP, TargetMode.CUPS, TargetMode.LISSAJOUS])
def test_a_replay_starts_in_its_own_mode_whatever_mode_was_saved(qtbot, replay_window, saved):
    save_preferences(Preferences(target_mode=saved))
    w = replay_window()
    assert w.session.targeter.mode is TargetMode.FOLLOW and w.target_panel.mode == "follow"
    assert w.session.targeter.teleop is None  # no hand source was built for a teleop nobody chose
    assert w.preferences.messages == [] and "too thin" not in w.target_status.text()
    w.preferences.save()
    assert load_preferences()[0].target_mode is saved  # the replay's mode does not replace the user's
