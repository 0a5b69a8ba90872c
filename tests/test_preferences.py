"""Preferences remembered between runs (core, no Qt): round trip, damaged files, reset."""
from __future__ import annotations

import math
from pathlib import Path

import pytest

from core.messages import TargetMode
from core.preferences import (
    MAX_RECENT_PORTS,
    Preferences,
    WindowGeometry,
    load_preferences,
    preferences_path,
    reset_preferences,
    save_preferences,
    with_recent_port,
)
from core.settings import CameraSettings, LissajousParams, SettingsError

FIX = "delete the file or use Reset to defaults"


@pytest.fixture(autouse=True)
def home(tmp_path, monkeypatch) -> Path:
    """A config folder of this test's own (the session-wide DESKARM_HOME is shared by tests)."""
    monkeypatch.setenv("DESKARM_HOME", str(tmp_path / "home"))
    return tmp_path / "home"


def everything_changed() -> Preferences:
    return Preferences(
        target_mode=TargetMode.LISSAJOUS,
        lissajous=LissajousParams(centre=(0.01, 0.2, 0.12), amplitude=(0.05, 0.04, 0.0),
                                  frequency_hz=(0.3, 0.25, 0.0), phase_rad=(0.5, -1.0, math.pi)),
        follow_id=50,
        bridge_protocol="v1",
        bridge_port="/dev/serial/by-id/usb-TI_LaunchPad",
        recent_ports=("/dev/serial/by-id/usb-TI_LaunchPad", "/dev/ttyUSB0"),
        view_3d=True,
        window=WindowGeometry(x=-20, y=30, width=1024, height=600, maximised=True, fullscreen=False),
        sim_camera=CameraSettings(exposure=-1.5, gain=6.0, brightness=12.0, contrast=1.4),
        camera_controls={"webcam:0,2": {"gain": 35.0, "white_balance": 4000.0}, "sbs:1": {"focus": 10.0}},
        camera_auto={"webcam:0,2": {"exposure": False}},
    )


def write(text: str) -> Path:
    path = preferences_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def test_preferences_live_in_the_config_folder_of_deskarm_home(home):
    assert preferences_path() == home / "config" / "preferences.toml"
    path = save_preferences(Preferences())
    assert path == home / "config" / "preferences.toml" and path.is_file()


def test_a_first_start_gives_the_defaults_and_no_message():
    prefs, messages = load_preferences()
    assert prefs == Preferences() and messages == []
    assert prefs.target_mode is TargetMode.MANUAL and prefs.window is None and prefs.recent_ports == ()


def test_every_value_survives_a_save_and_a_load():
    prefs = everything_changed()
    save_preferences(prefs)
    loaded, messages = load_preferences()
    assert messages == []
    assert loaded == prefs
    assert loaded.lissajous.phase_rad[2] == math.pi  # floats come back exactly


def test_the_mode_may_be_given_as_its_value():
    assert Preferences(target_mode="follow").target_mode is TargetMode.FOLLOW


def test_invalid_preferences_name_the_field_and_the_allowed_values():
    with pytest.raises(SettingsError, match=r"bridge.protocol = 'v3'; allowed: sim, v1, v2"):
        Preferences(bridge_protocol="v3")
    with pytest.raises(SettingsError, match=r"target.follow_id = 5000 is outside the allowed range 0…1023"):
        Preferences(follow_id=5000)
    with pytest.raises(SettingsError, match=r"window.width = 20 is outside"):
        WindowGeometry(width=20)
    with pytest.raises(SettingsError, match=r"camera_controls.webcam:0,2.gain = nan is not a finite number"):
        Preferences(camera_controls={"webcam:0,2": {"gain": float("nan")}})


def test_recent_ports_are_most_recent_first_without_repeats_and_at_most_eight():
    prefs = Preferences(recent_ports=["/dev/a", " /dev/b ", "/dev/a", ""])
    assert prefs.recent_ports == ("/dev/a", "/dev/b")
    prefs = with_recent_port(prefs, "/dev/b")
    assert prefs.recent_ports == ("/dev/b", "/dev/a")
    for k in range(10):
        prefs = with_recent_port(prefs, f"/dev/pts/{k}")
    assert len(prefs.recent_ports) == MAX_RECENT_PORTS
    assert prefs.recent_ports[0] == "/dev/pts/9" and "/dev/a" not in prefs.recent_ports


def test_a_corrupt_file_gives_the_defaults_and_a_message_then_a_save_rewrites_it():
    path = write("[target\nmode = 'follow'\n")
    prefs, messages = load_preferences()
    assert prefs == Preferences()
    assert len(messages) == 1 and messages[0].startswith(f"{path}: not valid TOML")
    assert f"kept as {path}.bad" in messages[0]  # the unreadable file is kept, never saved over
    save_preferences(prefs)
    assert load_preferences() == (Preferences(), [])


def test_a_file_that_is_not_text_gives_the_defaults_and_a_message():
    path = preferences_path()
    path.parent.mkdir(parents=True)
    path.write_bytes(b"\xff\xfe\x00 binary")
    prefs, messages = load_preferences()
    assert prefs == Preferences() and len(messages) == 1
    assert messages[0].startswith(f"{path}: not UTF-8 text") and f"kept as {path}.bad;" in messages[0]
    assert Path(f"{path}.bad").read_bytes() == b"\xff\xfe\x00 binary"


def test_a_wrong_type_costs_only_that_value():
    path = write("""
[target]
mode = "follow"
follow_id = "fifty"

[lissajous]
frequency_hz = 'x'
amplitude = [0.05, 0.04, 0.0]

[bridge]
port = 7
recent_ports = ["/dev/ttyACM0", 3]
protocol = "v1"

[view]
twin_3d = "yes"

[sim_camera]
gain = "high"
contrast = 2

[window]
x = 1.5
width = 1000
""")
    prefs, messages = load_preferences()
    expected = [
        f"{path}: target.follow_id = 'fifty' is not a whole number — using the default; {FIX}",
        f"{path}: lissajous.frequency_hz = 'x' is not a list of 3 numbers — using the default; {FIX}",
        f"{path}: bridge.port = 7 is not text — using the default; {FIX}",
        f"{path}: bridge.recent_ports = ['/dev/ttyACM0', 3] is not a list of port paths — using the default; {FIX}",
        f"{path}: view.twin_3d = 'yes' is not true or false — using the default; {FIX}",
        f"{path}: window.x = 1.5 is not a whole number — using the default; {FIX}",
        f"{path}: sim_camera.gain = 'high' is not a number — using the default; {FIX}",
    ]
    assert messages == expected
    # the good values stay
    assert prefs.target_mode is TargetMode.FOLLOW and prefs.follow_id is None
    assert prefs.lissajous == LissajousParams(amplitude=(0.05, 0.04, 0.0))
    assert prefs.bridge_protocol == "v1" and prefs.bridge_port == "" and prefs.recent_ports == ()
    assert prefs.view_3d is False
    assert prefs.sim_camera == CameraSettings(contrast=2.0)
    assert prefs.window == WindowGeometry(width=1000)


def test_out_of_range_values_fall_back_to_their_defaults_with_the_allowed_range():
    path = write("""
[target]
mode = "dance"
follow_id = 5000

[lissajous]
amplitude = [0.9, 0.03, 0.03]
centre = [0.02, 0.2, 0.1]

[bridge]
protocol = "v3"

[sim_camera]
gain = 99.0
exposure = 1.0

[window]
width = 5
height = 700
""")
    prefs, messages = load_preferences()
    assert messages == [
        f"{path}: target.mode = 'dance' is not allowed (allowed: manual, follow, lissajous, cups, object, teleop) — using the default; {FIX}",
        f"{path}: target.follow_id = 5000 is outside the allowed range 0…1023 — using the default; {FIX}",
        (f"{path}: lissajous.amplitude = [0.9, 0.03, 0.03] is not allowed (lissajous.amplitude_x = 0.9 is outside "
         f"the allowed range 0.0…0.5) — using the default; {FIX}"),
        f"{path}: bridge.protocol = 'v3' is not allowed (allowed: sim, v1, v2) — using the default; {FIX}",
        f"{path}: window.width = 5 is outside the allowed range 100…20000 — using the default; {FIX}",
        f"{path}: sim_camera.gain = 99.0 is outside the allowed range 0.0…24.0 — using the default; {FIX}",
    ]
    assert prefs.target_mode is TargetMode.MANUAL and prefs.follow_id is None
    assert prefs.lissajous == LissajousParams(centre=(0.02, 0.2, 0.1))
    assert prefs.sim_camera == CameraSettings(exposure=1.0)
    assert prefs.window == WindowGeometry(width=800, height=700)


def test_bad_camera_control_values_are_dropped_one_by_one():
    path = write("""
camera_controls = 3

[camera_auto]
"webcam:0,2" = { exposure = "on", focus = true }
"sbs:1" = 4
""")
    prefs, messages = load_preferences()
    assert messages == [
        f"{path}: camera_controls = 3 is not a table — using the default; {FIX}",
        f"{path}: camera_auto.webcam:0,2.exposure = 'on' is not true or false — using the default; {FIX}",
        f"{path}: camera_auto.sbs:1 = 4 is not a table of control values — using the default; {FIX}",
    ]
    assert prefs.camera_controls == {} and prefs.camera_auto == {"webcam:0,2": {"focus": True}}


def test_unknown_keys_and_tables_are_ignored_and_dropped_by_the_next_save():
    write("""
colour_scheme = "dark"

[target]
mode = "cups"
speed = 3

[plugins]
x = 1
""")
    prefs, messages = load_preferences()
    assert messages == [] and prefs == Preferences(target_mode="cups")
    text = save_preferences(prefs).read_text()
    assert "plugins" not in text and "speed" not in text and "colour_scheme" not in text


def test_an_unwritable_config_folder_gives_messages_not_crashes(home):
    home.mkdir(parents=True)
    (home / "config").write_text("a file where the folder should be")
    prefs, messages = load_preferences()
    assert prefs == Preferences()
    assert len(messages) == 1 and str(preferences_path()) in messages[0] and "cannot read" in messages[0]
    with pytest.raises(OSError) as info:
        save_preferences(everything_changed())
    assert str(info.value).startswith(f"{preferences_path()}: cannot write:")
    assert "DESKARM_HOME" in str(info.value)  # the fix for the user's own folders


def test_reset_moves_the_file_aside_and_the_defaults_come_back():
    assert reset_preferences() is None  # nothing saved yet: nothing to do
    path = save_preferences(everything_changed())
    saved = path.read_text()
    backup = reset_preferences()
    assert backup == path.with_name("preferences.toml.bak")
    assert not path.exists() and backup.read_text() == saved
    assert load_preferences() == (Preferences(), [])
    save_preferences(Preferences(view_3d=True))
    assert reset_preferences() == backup and "twin_3d = true" in backup.read_text()  # the newest copy
