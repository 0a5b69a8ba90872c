"""`deskarm --screenshot` writes exactly the size it says, whatever the saved preferences hold,
and needs no display (issue 22 item 19: 796x480 for --size 800x480, 796x796 after a saved
maximised window; Qt aborted with exit 134 where no display was set)."""
from __future__ import annotations

import os
import struct
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("PySide6", reason="the window (--screenshot) needs PySide6, which this system has no wheel of")

from core.preferences import Preferences, WindowGeometry, preferences_path, save_preferences

ROOT = Path(__file__).resolve().parents[2]
NO_DISPLAY = ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM")


def deskarm(args, home: Path, **env_changes) -> subprocess.CompletedProcess:
    """``python -m app.cli ARGS`` with DESKARM_HOME=home and no display (unless env_changes set one)."""
    env = {k: v for k, v in os.environ.items() if k not in NO_DISPLAY}
    env.update(DESKARM_HOME=str(home), **env_changes)
    return subprocess.run([sys.executable, "-m", "app.cli", *args], cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=120)


def png_size(path: Path) -> tuple[int, int]:
    """(width, height) from a PNG's IHDR chunk."""
    data = path.read_bytes()[:24]
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR", f"{path} is no PNG"
    return struct.unpack(">II", data[16:24])


@pytest.mark.parametrize("size", [(800, 480), (1280, 800)])
@pytest.mark.parametrize("saved", [None, WindowGeometry(0, 0, 640, 400, maximised=True),
                                   WindowGeometry(10, 20, 700, 420)], ids=["no-file", "maximised", "smaller"])
def test_the_screenshot_is_exactly_the_size_asked_for_whatever_geometry_was_saved(tmp_path, monkeypatch,
                                                                                 size, saved):
    home = tmp_path / "home"
    monkeypatch.setenv("DESKARM_HOME", str(home))
    if saved is not None:
        save_preferences(Preferences(window=saved))
    before = preferences_path().read_bytes() if saved is not None else None
    out = tmp_path / "shot.png"
    done = deskarm(["--screenshot", str(out), "--size", f"{size[0]}x{size[1]}", "--after", "0.3"], home)
    assert done.returncode == 0, done.stderr
    assert png_size(out) == size
    # the window is taken down before the interpreter exits: no event filter runs on a freed wrapper
    assert "Traceback" not in done.stderr and "Error calling Python override" not in done.stderr, done.stderr[-800:]
    assert f"{size[0]}x{size[1]}" in done.stdout
    # a screenshot is no window the user placed: the saved preferences stay as they were
    assert (preferences_path().read_bytes() if preferences_path().exists() else None) == before


def test_a_screenshot_renders_offscreen_even_when_qt_is_told_to_use_a_missing_x_server(tmp_path):
    out = tmp_path / "shot.png"
    done = deskarm(["--screenshot", str(out), "--size", "800x480", "--after", "0.2"], tmp_path / "home",
                   QT_QPA_PLATFORM="xcb")
    assert done.returncode == 0, done.stderr
    assert png_size(out) == (800, 480)


def test_a_screenshot_into_a_missing_folder_says_so_in_one_line(tmp_path):
    out = tmp_path / "gone" / "shot.png"
    done = deskarm(["--screenshot", str(out), "--size", "800x480", "--after", "0.2"], tmp_path / "home")
    assert done.returncode == 1 and not out.exists()
    assert "could not write the screenshot" in done.stderr and str(out) in done.stderr
    assert "saved" not in done.stdout


def test_the_window_without_a_display_says_so_in_one_line_instead_of_aborting(tmp_path):
    done = deskarm([], tmp_path / "home")
    assert done.returncode == 2, (done.returncode, done.stderr[-500:])
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "no display" in lines[0] and "--screenshot" in lines[0]
