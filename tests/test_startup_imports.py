"""Start-up imports only what the first frame needs (issue 28 item 3: first frame ≤ 5 s on a Pi 4).

Each check runs a fresh interpreter (what a module imports is only visible in a process that has
not imported it yet) and reads ``sys.modules`` there; nothing is timed. ``deskarm --help`` still
names every camera, bridge and scenario (the help fills them in when it is shown).
"""
from __future__ import annotations

import gc
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from app import cli

REPO = Path(__file__).resolve().parents[1]
# made on first use (a wizard, a dialog, the RTX panel, the 3D twin's OpenGL): never at start-up
NOT_AT_WINDOW_START = ("app.calibration_worker", "app.hand_eye", "core.vision.stereo_calibration",
                       "widgets.help_dialog", "widgets.recordings_dialog", "app.rtx_init_worker",
                       "widgets.rtx_init_panel", "OpenGL")
# the assistive view's window needs none of these
NOT_AT_ASSIST_START = ("pyqtgraph", "core.session", "core.detect.registry", "core.vision.perception")


def _loaded_after(code: str, names) -> dict:
    """Run ``code`` in a fresh interpreter (offscreen); which of ``names`` it imported, and what
    it printed last (one JSON line, or None)."""
    script = (code + "\nimport json, sys\n"
              f"print(json.dumps({{n: n in sys.modules for n in {list(names)!r}}}))\n")
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", PYTHONPATH=str(REPO))
    out = subprocess.run([sys.executable, "-c", script], cwd=REPO, env=env, capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    lines = [ln for ln in out.stdout.splitlines() if ln.startswith("{")]
    return json.loads(lines[-1])


def test_the_assistive_view_imports_no_pyqtgraph_and_no_desk_session():
    loaded = _loaded_after("import app.cli, app.assist_window, app.startup", NOT_AT_ASSIST_START)
    assert not any(loaded.values()), f"the assistive view's start-up imports {[n for n, v in loaded.items() if v]}"


def test_camera_views_still_take_opencv_arrays_row_major_with_a_light_widgets_package():
    """The widgets package no longer configures pyqtgraph on import; the camera view (and every
    module making pyqtgraph items) gets it configured from widgets._pyqtgraph."""
    code = ("import sys, widgets, widgets.estop, widgets.assist_view\n"
            "assert 'pyqtgraph' not in sys.modules, 'the widgets package imports pyqtgraph'\n"
            "import widgets.camera_view, pyqtgraph as pg\n"
            "print(json.dumps({'order': pg.getConfigOption('imageAxisOrder')}))\n")
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", PYTHONPATH=str(REPO))
    out = subprocess.run([sys.executable, "-c", "import json\n" + code], cwd=REPO, env=env, capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert json.loads(out.stdout.splitlines()[-1]) == {"order": "row-major"}


def test_the_main_window_imports_its_wizards_and_dialogs_only_when_first_used():
    loaded = _loaded_after("import app.cli, app.gui", NOT_AT_WINDOW_START)
    assert not any(loaded.values()), f"the window's start-up imports {[n for n, v in loaded.items() if v]}"


def test_the_help_still_names_the_cameras_bridges_and_scenarios(capsys):
    from core.devices.bridge import BRIDGE_CHOICES
    from core.session import SCENARIOS
    from core.vision.cameras import CAMERA_CHOICES

    with pytest.raises(SystemExit):
        cli.main(["--help"])
    text = " ".join(capsys.readouterr().out.split())
    for listed in (CAMERA_CHOICES, BRIDGE_CHOICES, ", ".join(SCENARIOS)):
        assert " ".join(listed.split()) in text
    left = [token for token in cli._LISTED if token in text]
    assert not left, f"placeholders left in the help: {left}"


def test_start_up_runs_with_the_collector_paused_and_a_headless_run_with_it_on(monkeypatch, capsys):
    """The window's start-up allocates without automatic collections (its GUI-thread timer
    collects once it runs); a headless run collects as usual; the collector is back on after
    either, and after a start-up that ends in an error."""
    import app.gui
    import app.headless

    seen = {}

    def run(name):
        def record(*_args, **_kwargs) -> int:
            seen[name] = gc.isenabled()
            return 0
        return record

    monkeypatch.setattr(app.headless, "run_headless", run("headless"))
    monkeypatch.setattr(app.gui, "take_screenshot", run("window"))
    assert gc.isenabled()
    assert cli.main(["--headless", "--camera", "sim", "--duration", "1"]) == 0
    assert gc.isenabled()
    assert cli.main(["--camera", "sim", "--screenshot", "/tmp/unused.png"]) == 0
    assert gc.isenabled()
    assert seen == {"headless": True, "window": False}
    assert cli.main(["--camera", "sim", "--size", "1x1"]) == 2
    assert gc.isenabled()
    with pytest.raises(SystemExit):
        cli.main(["--no-such-option"])
    assert gc.isenabled()
    assert "--size" in capsys.readouterr().err
