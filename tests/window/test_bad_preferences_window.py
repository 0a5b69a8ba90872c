"""The window never saves over a preferences file it could not read (issue 25 item 3): the file
is kept as preferences.toml.bad, the banner says where, and closing the window writes a new file."""
from __future__ import annotations

import pytest

from app.gui import MainWindow
from core.preferences import Preferences, load_preferences, preferences_path
from core.session import DeskSession, SessionOptions

USERS_FILE = b"""[target]
mode = "follow"
[bridge]
port = "/dev/ttyACM3"
recent_ports = ["/dev/ttyACM3", "/dev/ttyUSB0"
"""  # one bracket lost: not TOML, but the user's port and recent ports are in there


@pytest.fixture(autouse=True)
def home(tmp_path, monkeypatch):
    monkeypatch.setenv("DESKARM_HOME", str(tmp_path / "home"))
    return tmp_path / "home"


@pytest.fixture
def window(qtbot):
    session = DeskSession.create(SessionOptions(camera="sim", scenario="static"))
    w = MainWindow(session)
    qtbot.addWidget(w)
    w.resize(800, 480)
    w.show()
    qtbot.waitExposed(w)
    yield w
    w.stop()
    session.close()


def corrupt_file():
    path = preferences_path()
    path.parent.mkdir(parents=True)
    path.write_bytes(USERS_FILE)
    return path


@pytest.fixture
def corrupt():
    return corrupt_file()


def test_closing_the_window_keeps_the_unreadable_file_and_the_banner_says_where(corrupt, window, qtbot):
    bad = corrupt.with_name("preferences.toml.bad")
    assert len(window.preferences.messages) == 1 and f"kept as {bad}" in window.preferences.messages[0]
    assert f"kept as {bad}" in window._note  # the banner shows it
    window.close()  # closeEvent saves the preferences
    assert bad.read_bytes() == USERS_FILE  # the user's port and recent ports are still there
    assert load_preferences(corrupt)[1] == []  # and a clean file took its place


def test_a_file_that_could_not_be_moved_aside_is_not_saved_over(monkeypatch, qtbot):
    import core.preferences as core_preferences

    path = corrupt_file()

    def refuse(p):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(core_preferences, "set_aside", refuse)
    session = DeskSession.create(SessionOptions(camera="sim", scenario="static"))
    try:
        w = MainWindow(session)
        qtbot.addWidget(w)
        prefs = w.preferences
        assert prefs.prefs == Preferences() and "could not be moved aside" in prefs.messages[0]
        with qtbot.waitSignal(prefs.sigMessage, timeout=5000, check_params_cb=lambda m: "not saved" in m):
            assert not prefs.save()
        w.close()
        assert path.read_bytes() == USERS_FILE
        monkeypatch.undo()
        assert prefs.reset() and prefs.save()  # Reset to defaults moves it aside: saving starts again
        assert path.with_name("preferences.toml.bak").read_bytes() == USERS_FILE
    finally:
        w.stop()
        session.close()
