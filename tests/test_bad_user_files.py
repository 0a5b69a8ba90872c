"""Bad user files give one clear message naming the file, the key and what is expected — never a
traceback, never a half-loaded file — and an unreadable preferences file is never saved over.

Issue 25 items 1–3: hand-eye files with nested or text residuals, a deeply nested assist.toml,
a corrupt preferences.toml overwritten with the defaults on exit."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from core.handeye import HandEyeFileError, load_hand_eye, save_hand_eye, solve_rigid
from core.paths import UserFileError, read_user_toml
from core.preferences import Preferences, load_preferences, preferences_path, read_preferences, save_preferences

DEEP = "[" * 5000 + "]" * 5000  # tomllib recurses once per level: a RecursionError before the fix


@pytest.fixture(autouse=True)
def home(tmp_path, monkeypatch) -> Path:
    monkeypatch.setenv("DESKARM_HOME", str(tmp_path / "home"))
    return tmp_path / "home"


def a_hand_eye_file(tmp_path) -> Path:
    rng = np.random.default_rng(0)
    B = rng.uniform(-0.2, 0.2, (8, 3))
    return save_hand_eye(solve_rigid(B - (0.0, 0.4, 0.45), B, camera_pair="webcam:0,1"), tmp_path / "he.toml")


def with_value(path: Path, key: str, value: str) -> Path:
    """The file with ``key = …`` (a one-line or multi-line array) replaced by ``key = value``."""
    text = path.read_text()
    new, n = re.subn(rf"^{key} = (\[.*?\]|.*?)$", f"{key} = {value}", text, count=1, flags=re.S | re.M)
    assert n == 1, f"{key} not in {text}"
    out = path.with_name(f"bad_{key}.toml")
    out.write_text(new)
    return out


# ---------------------------------------------------------------------------------------- 1
@pytest.mark.parametrize("key, value, expected", [
    ("residuals_mm", "[[1]]", "'quality.residuals_mm' = [[1]] must be a list of finite numbers ≥ 0"),
    ("residuals_mm", '["x"]', "'quality.residuals_mm' = ['x'] must be a list of finite numbers ≥ 0"),
    ("residuals_mm", "[-1.0]", "'quality.residuals_mm' = [-1.0] must be a list of finite numbers ≥ 0"),
    ("rejected", "[{a = 1}]", "'quality.rejected' = [{'a': 1}] must be a list of whole numbers ≥ 0"),
    ("rejected", '["2"]', "'quality.rejected' = ['2'] must be a list of whole numbers ≥ 0"),
    ("warnings", "[[1]]", "'quality.warnings' = [[1]] must be a list of strings"),
    ("poses_used", "true", "'quality.poses_used' = True is not a whole number"),
    ("max_mm", "nan", "'quality.max_mm' = nan is not a finite number ≥ 0"),
    ("worst_index", "[1]", "'quality.worst_index' = [1] is not a whole number"),
    ("created", "[1]", "'created' = [1] is not a string"),
    ("base_T_camera", '[["1", 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]',
     "'base_T_camera' must be a 4x4 table of finite numbers"),
    ("residuals_mm", "[" * 300 + "1" + "]" * 300, "'quality.residuals_mm' = [[[...]]] must be a list"),
])
def test_a_bad_hand_eye_value_names_the_file_the_key_and_what_is_expected(tmp_path, key, value, expected):
    bad = with_value(a_hand_eye_file(tmp_path), key, value)
    with pytest.raises(HandEyeFileError) as info:
        load_hand_eye(bad)
    message = str(info.value)
    assert message.startswith(f"{bad}: key ") and expected in message and "calibrate-hand-eye" in message
    assert "\n" not in message and len(message) < 300


def test_a_deeply_nested_hand_eye_file_names_the_file(tmp_path):
    bad = tmp_path / "deep.toml"
    bad.write_text(a_hand_eye_file(tmp_path).read_text() + f"\nextra = {DEEP}\n")
    with pytest.raises(HandEyeFileError, match=rf"^{re.escape(str(bad))}: nested too deeply .* calibrate-hand-eye"):
        load_hand_eye(bad)


def test_deskarm_refuses_a_bad_hand_eye_file_with_one_line_and_no_traceback(tmp_path):
    import subprocess
    import sys

    bad = with_value(a_hand_eye_file(tmp_path), "rejected", "[{a = 1}]")
    run = subprocess.run([sys.executable, "-m", "app.cli", "--headless", "--fast", "--duration", "0.2",
                          "--hand-eye", str(bad)], capture_output=True, text=True, timeout=300,
                         cwd=Path(__file__).resolve().parents[1])
    assert run.returncode == 1 and "Traceback" not in run.stderr, run.stderr
    assert f"--hand-eye: {bad}: key 'quality.rejected' = [{{'a': 1}}] must be a list of whole numbers" in run.stderr


# ---------------------------------------------------------------------------------------- 2
def test_a_deeply_nested_assist_file_gives_the_defaults_and_names_the_file(tmp_path):
    from app.assist_window import AssistSettings, load_assist_settings

    path = tmp_path / "assist.toml"
    path.write_text(f"mode = {DEEP}\n")
    settings, warnings = load_assist_settings(path)
    assert settings == AssistSettings()
    assert len(warnings) == 1 and warnings[0].startswith(f"{path}: nested too deeply")
    assert "using the defaults" in warnings[0]


@pytest.mark.parametrize("line, expected", [
    ('next_switch = [1, "mouse:right"]', "next_switch = [1, 'mouse:right']: expected a list of switch names"),
    ("ready_deg = [[1]]", "ready_deg = [[1]]: expected a list of finite numbers"),
    ('scan_period_s = "2"', "scan_period_s = '2': expected a number"),
    ('sound = "yes"', "sound = 'yes': expected true or false"),
    ("mode = " + "[" * 300 + "]" * 300, "mode = [[[...]]]: expected a string"),
])
def test_a_bad_assist_value_costs_only_that_setting(tmp_path, line, expected):
    from app.assist_window import AssistSettings, load_assist_settings

    path = tmp_path / "assist.toml"
    path.write_text(f"long_press_s = 2.0\n{line}\n")
    settings, warnings = load_assist_settings(path)
    assert settings.long_press_s == 2.0  # the good value is kept
    key = line.split(" = ")[0]
    assert getattr(settings, key) == getattr(AssistSettings(), key)
    assert warnings == [f"{path}: {expected} — the default is used"] or (
        len(warnings) == 1 and warnings[0].startswith(f"{path}: {expected}"))


def test_the_shared_reader_names_the_file_for_every_kind_of_unreadable_file(tmp_path):
    cases = {"deep.toml": f"a = {DEEP}\n".encode(), "broken.toml": b"[a\n", "binary.toml": b"\xff\xfe\x00"}
    for name, data in cases.items():
        (tmp_path / name).write_bytes(data)
        with pytest.raises(UserFileError, match=rf"^{re.escape(str(tmp_path / name))}: .* — do this"):
            read_user_toml(tmp_path / name, "a test file", "do this")
    with pytest.raises(FileNotFoundError):
        read_user_toml(tmp_path / "none.toml", "a test file", "do this")


# ---------------------------------------------------------------------------------------- 3
USERS_FILE = b"""[target]
mode = "follow"
[bridge]
port = "/dev/ttyACM3"
recent_ports = ["/dev/ttyACM3", "/dev/ttyUSB0"
"""  # the closing bracket lost: not TOML any more, but the user's port is in there


@pytest.mark.parametrize("data", [USERS_FILE, b"\xff\xfe binary", f"x = {DEEP}\n".encode()])
def test_an_unreadable_preferences_file_is_kept_aside_and_a_save_cannot_destroy_it(data):
    path = preferences_path()
    path.parent.mkdir(parents=True)
    path.write_bytes(data)
    prefs, messages = load_preferences()
    bad = path.with_name("preferences.toml.bad")
    assert prefs == Preferences() and len(messages) == 1
    assert messages[0].startswith(f"{path}: ") and f"kept as {bad}" in messages[0], messages
    save_preferences(prefs)  # what the window does on exit
    assert bad.read_bytes() == data and load_preferences() == (Preferences(), [])


def test_a_second_unreadable_file_does_not_replace_the_first_copy():
    path = preferences_path()
    path.parent.mkdir(parents=True)
    for n, text in enumerate(("[a\n", "[b\n")):
        path.write_text(text)
        assert f"kept as {path}.bad" + (".2" if n else "") in load_preferences()[1][0]
    assert Path(f"{path}.bad").read_text() == "[a\n" and Path(f"{path}.bad.2").read_text() == "[b\n"


def test_an_unreadable_file_that_cannot_be_moved_is_flagged_do_not_overwrite(monkeypatch):
    import core.preferences as core_preferences

    path = preferences_path()
    path.parent.mkdir(parents=True)
    path.write_bytes(USERS_FILE)

    def refuse(p):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(core_preferences, "set_aside", refuse)
    loaded = read_preferences()
    assert loaded.do_not_overwrite and loaded.kept_aside is None
    assert "could not be moved aside (permission denied)" in loaded.messages[0]
    assert path.read_bytes() == USERS_FILE
