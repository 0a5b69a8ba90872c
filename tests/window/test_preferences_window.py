"""Settings remembered between runs, on the main window (pytest-qt, offscreen).

Each test has its own DESKARM_HOME: the session-wide one of conftest is shared by all tests.
"""
from __future__ import annotations

import pytest
from PySide6 import QtCore

from app.gui import MainWindow
from core.messages import TargetMode
from core.preferences import (
    Preferences,
    WindowGeometry,
    load_preferences,
    preferences_path,
    save_preferences,
)
from core.session import DeskSession, SessionOptions
from core.settings import CameraSettings, LissajousParams

TIMEOUT_MS = 5000


@pytest.fixture(autouse=True)
def home(tmp_path, monkeypatch):
    monkeypatch.setenv("DESKARM_HOME", str(tmp_path / "home"))
    return tmp_path / "home"


@pytest.fixture(autouse=True)
def sessions():
    """The sessions the test built, closed after it: a simulated camera left open keeps
    rendering in its thread, and such threads still in OpenCV when Python exits abort it."""
    opened: list[DeskSession] = []
    yield opened
    for session in opened:
        session.close()


def new_window(qtbot, sessions, show: bool = True) -> MainWindow:
    """A window on the static simulated desk, as tests/window/test_main_window.py builds it."""
    session = DeskSession.create(SessionOptions(camera="sim", scenario="static"))
    sessions.append(session)
    w = MainWindow(session)
    qtbot.addWidget(w)
    w.resize(800, 480)
    if show:
        w.show()
    return w


def stop(w: MainWindow) -> None:
    w.stop()
    for worker in (w.workers.perception, w.workers.control, w.workers.bridge):
        assert worker.isFinished() or not worker.isRunning()


def change_everything(qtbot, w: MainWindow) -> None:
    """What a user would do: Lissajous mode and curve, v1 on a typed port, camera gain, 3D."""
    tp = w.target_panel
    with qtbot.waitSignal(tp.sigModeChanged, timeout=TIMEOUT_MS):
        tp.mode_buttons["lissajous"].click()
    with qtbot.waitSignal(tp.sigLissajousChanged, timeout=TIMEOUT_MS):
        tp.lissajous_spins[1][0].setValue(4.5)  # amplitude x, cm
    with qtbot.waitSignal(tp.sigLissajousChanged, timeout=TIMEOUT_MS):
        tp.lissajous_spins[2][2].setValue(0.33)  # frequency z, Hz
    w.bridge_picker.set_protocol("v1")
    w.bridge_picker.port_combo.setEditText("/dev/pts/7")
    with qtbot.waitSignal(w.camera_panel.sigSettingsChanged, timeout=TIMEOUT_MS):
        w.camera_panel.sliders["gain"].setValue(6.5)
        w.camera_panel.flush()
    if w.view_3d_button.isEnabled():  # no OpenGL offscreen: then the field is not exercised
        w.view_3d_button.setChecked(True)


def test_settings_come_back_in_a_new_window_and_in_the_core_objects(qtbot, sessions):
    first = new_window(qtbot, sessions)
    prefs = first.preferences
    assert prefs.messages == [] and prefs.path == preferences_path()
    change_everything(qtbot, first)
    assert prefs.save() and prefs.path.is_file()
    saved, problems = load_preferences()
    assert problems == []
    assert saved.target_mode is TargetMode.LISSAJOUS and saved.bridge_protocol == "v1"
    assert saved.bridge_port == "/dev/pts/7" and saved.sim_camera == CameraSettings(gain=6.5)

    second = new_window(qtbot, sessions)
    restored = second.preferences
    restored.restore()
    assert restored.messages == []
    tp = second.target_panel
    assert tp.mode == "lissajous" and tp.stack.currentIndex() == 2
    assert second.session.targeter.mode is TargetMode.LISSAJOUS
    curve = first.target_panel.lissajous()
    assert curve.amplitude[0] == pytest.approx(0.045) and curve.frequency_hz[2] == pytest.approx(0.33)
    assert tp.lissajous() == curve and second.session.targeter.lissajous == curve
    assert second.bridge_picker.protocol() == "v1" and second.bridge_picker.port() == "/dev/pts/7"
    assert second.session.bridge.url == "sim://"  # the picker is filled in, nothing is connected
    assert second.camera_panel.settings() == CameraSettings(gain=6.5)
    assert second.view_3d_button.isChecked() == (first.view_3d_button.isChecked()
                                                  and second.view_3d_button.isEnabled())
    assert not restored._saver.pending  # restoring is not a change to save
    second.start()  # the simulated camera renders with the restored settings
    try:
        qtbot.waitUntil(lambda: second.session.camera.settings == CameraSettings(gain=6.5), timeout=TIMEOUT_MS)
    finally:
        stop(second)


def test_a_change_is_saved_once_about_a_second_later(qtbot, sessions):
    w = new_window(qtbot, sessions)
    prefs = w.preferences
    path = prefs.path
    with qtbot.waitSignal(w.target_panel.sigModeChanged, timeout=TIMEOUT_MS):
        w.target_panel.mode_buttons["cups"].click()
    w.target_panel.mode_buttons["follow"].click()
    assert prefs._saver.pending and not path.exists()  # debounced, not written on every click
    qtbot.waitUntil(path.exists, timeout=TIMEOUT_MS)
    assert load_preferences()[0].target_mode is TargetMode.FOLLOW


def test_the_follow_id_is_restored_to_the_panel_and_the_targeter(qtbot, sessions):
    save_preferences(Preferences(target_mode="follow", follow_id=50))
    w = new_window(qtbot, sessions)
    w.preferences.restore()
    assert w.target_panel.follow_id == 50 and w.session.targeter.follow_id == 50
    assert w.session.targeter.mode is TargetMode.FOLLOW


def test_a_successful_connect_puts_the_port_first_in_the_recent_list(qtbot, sessions):
    save_preferences(Preferences(recent_ports=("/dev/ttyUSB0",)))
    w = new_window(qtbot, sessions)
    prefs = w.preferences
    prefs.restore()
    picker = w.bridge_picker
    assert picker.port_combo.itemText(0) == "/dev/ttyUSB0 (recent)"
    w.start()
    try:
        picker.set_protocol("v1")
        picker.set_port("loop://")  # pyserial's loopback: a v1 port that always opens
        with qtbot.waitSignal(picker.sigConnectRequested, timeout=TIMEOUT_MS):
            picker.connect_button.click()
        qtbot.waitUntil(lambda: prefs.prefs.recent_ports == ("loop://", "/dev/ttyUSB0"), timeout=TIMEOUT_MS)
        assert w.session.bridge.url == "loop://"
        assert [picker.port_combo.itemText(i) for i in range(2)] == ["loop:// (recent)", "/dev/ttyUSB0 (recent)"]
        assert picker.port() == "loop://"
        qtbot.waitUntil(lambda: load_preferences()[0].recent_ports == ("loop://", "/dev/ttyUSB0"),
                        timeout=TIMEOUT_MS)
    finally:
        stop(w)


def test_a_failed_connect_is_not_a_recent_port(qtbot, sessions):
    w = new_window(qtbot, sessions)
    prefs = w.preferences
    w.start()
    try:
        w.bridge_picker.set_port("/dev/deskarm-no-such-port")
        w.bridge_picker.connect_button.click()
        qtbot.waitUntil(lambda: w._bridge_status is not None and "could not" in w._bridge_status.message,
                        timeout=TIMEOUT_MS)
        w.bridge_picker.show_bridge_status(w._bridge_status)
        assert "#e08a00" in w.bridge_picker.status_label.text()  # the warning colour, not green
        assert prefs.prefs.recent_ports == ()
    finally:
        stop(w)


def test_reset_brings_the_defaults_back_and_keeps_a_copy(qtbot, sessions):
    w = new_window(qtbot, sessions)
    prefs = w.preferences
    change_everything(qtbot, w)
    prefs.save()
    saved_text = prefs.path.read_text()
    assert prefs.reset()
    assert not prefs.path.exists()
    assert prefs.path.with_name("preferences.toml.bak").read_text() == saved_text
    assert w.target_panel.mode == "manual" and w.session.targeter.mode is TargetMode.MANUAL
    assert w.target_panel.lissajous() == LissajousParams() == w.session.targeter.lissajous
    assert w.camera_panel.settings() == CameraSettings()
    assert w.workers.perception._pending_settings == CameraSettings()  # the camera gets them too
    assert w.bridge_picker.protocol() == "v2" and w.bridge_picker.recent_ports() == ()
    assert not w.view_3d_button.isChecked()
    assert not prefs._saver.pending


def test_a_corrupt_file_still_builds_the_window_and_says_what_to_do(qtbot, sessions):
    path = preferences_path()
    path.parent.mkdir(parents=True)
    path.write_text("[target]\nmode = \n")
    w = new_window(qtbot, sessions)
    prefs = w.preferences
    prefs.restore()
    assert len(prefs.messages) == 1
    assert str(path) in prefs.messages[0] and f"kept as {path}.bad" in prefs.messages[0]
    assert w.target_panel.mode == "manual" and not prefs.geometry_restored
    assert prefs.save() and load_preferences() == (prefs.collect(), [])  # rewritten cleanly


def test_an_unwritable_config_folder_gives_messages_and_the_window_works(qtbot, sessions, home):
    home.mkdir(parents=True)
    (home / "config").write_text("a file where the folder should be")
    w = new_window(qtbot, sessions)
    prefs = w.preferences
    prefs.restore()
    assert len(prefs.messages) == 1 and "cannot read" in prefs.messages[0]
    with qtbot.waitSignal(prefs.sigMessage, timeout=TIMEOUT_MS,
                          check_params_cb=lambda m: "cannot write" in m) as blocker:
        assert not prefs.save()
    assert prefs.messages[-1] == blocker.args[0]
    with qtbot.assertNotEmitted(prefs.sigMessage):
        prefs.save()  # the same problem is not repeated


def test_the_window_goes_back_where_it_was_if_that_fits_the_screen(qtbot, sessions):
    first = new_window(qtbot, sessions)
    first.setGeometry(40, 50, 760, 420)
    qtbot.waitUntil(lambda: first.geometry().topLeft() == QtCore.QPoint(40, 50), timeout=TIMEOUT_MS)
    prefs = first.preferences
    prefs.save()
    geometry = load_preferences()[0].window
    assert geometry == WindowGeometry(40, 50, first.width(), first.height(), False, False)

    second = new_window(qtbot, sessions, show=False)
    restored = second.preferences
    restored.restore()
    assert restored.geometry_restored
    assert second.geometry() == QtCore.QRect(40, 50, first.width(), first.height())


def test_a_geometry_off_every_screen_is_ignored(qtbot, sessions):
    save_preferences(Preferences(window=WindowGeometry(x=5000, y=0, width=800, height=480)))
    w = new_window(qtbot, sessions, show=False)
    before = w.geometry()
    prefs = w.preferences
    prefs.restore()
    assert not prefs.geometry_restored and w.geometry() == before
    assert not w.windowState() & QtCore.Qt.WindowState.WindowMaximized


def test_a_maximised_window_comes_back_maximised_and_keeps_its_normal_size(qtbot, sessions):
    saved = WindowGeometry(x=40, y=50, width=760, height=420, maximised=True)
    save_preferences(Preferences(window=saved))
    w = new_window(qtbot, sessions, show=False)
    prefs = w.preferences
    prefs.restore()
    assert prefs.geometry_restored and w.windowState() & QtCore.Qt.WindowState.WindowMaximized
    w.show()
    qtbot.waitUntil(w.isMaximized, timeout=TIMEOUT_MS)
    assert prefs.collect().window == saved  # the size to come back to when un-maximised
    # off every screen, the rectangle is ignored but maximised still applies
    save_preferences(Preferences(window=WindowGeometry(x=5000, y=0, width=800, height=480, maximised=True)))
    other = new_window(qtbot, sessions, show=False)
    prefs = other.preferences
    prefs.restore()
    assert prefs.geometry_restored and other.windowState() & QtCore.Qt.WindowState.WindowMaximized


def test_restore_never_connects_a_saved_serial_port(qtbot, sessions):
    save_preferences(Preferences(bridge_protocol="v2", bridge_port="loop://", recent_ports=("loop://",)))
    w = new_window(qtbot, sessions)
    prefs = w.preferences
    prefs.restore()
    with qtbot.assertNotEmitted(w.bridge_picker.sigConnectRequested):
        prefs.restore()
    assert w.bridge_picker.port() == "loop://" and w.session.bridge.url == "sim://"


def test_without_a_saved_file_the_sessions_own_mode_stays(qtbot, sessions):
    """A first start (no preferences file) keeps the session's mode: Follow marker on the
    simulated desk, the cups game with --scenario cups — the saved default 'manual' is not forced."""
    session = DeskSession.create(SessionOptions(camera="sim", scenario="cups"))
    sessions.append(session)
    w = MainWindow(session)
    qtbot.addWidget(w)
    assert w.session.targeter.mode is TargetMode.CUPS and w.target_panel.mode == "cups"
