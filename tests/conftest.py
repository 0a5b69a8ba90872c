"""Shared test set-up: user folders in a temp dir, Qt offscreen."""
import os
import shutil
import subprocess
from pathlib import Path

import pytest

# Without PySide6 (a system with no wheel for its glibc, e.g. Raspberry Pi OS Bookworm: deskarm
# installs there without the window) the Qt tests cannot run: a test file that imports Qt, the
# widgets or the window's modules, or asks for qtbot, is not collected. The Makefile then runs
# pytest with -p no:pytest-qt.
import importlib.util as _importlib_util
import re as _re

_HAS_QT = _importlib_util.find_spec("PySide6") is not None
_NEEDS_QT = _re.compile(r"^\s*(from|import) (PySide6|pyqtgraph|superqt|widgets|app\.(gui|features|assist|workers|"
                        r"assist_window|rtx_init_worker|calibration_worker|startup|hand_eye|preferences|estop_switches))\b|"
                        r"\bqtbot\b|^\s*import bench\b|^\s*from bench\b", _re.MULTILINE)


def pytest_ignore_collect(collection_path, config):
    if _HAS_QT:
        return None
    if collection_path.is_dir():
        return True if collection_path.name == "window" else None  # the widget and window tests
    if collection_path.suffix != ".py" or not collection_path.name.startswith("test_"):
        return None
    try:
        return bool(_NEEDS_QT.search(collection_path.read_text(encoding="utf-8", errors="replace"))) or None
    except OSError:
        return None


os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
os.environ.setdefault("OPENCV_LOG_LEVEL", "ERROR")


@pytest.fixture(autouse=True)
def _deskarm_home(tmp_path_factory, monkeypatch):
    """Config and cache folders of a throw-away user, so tests never touch the real ones."""
    home = tmp_path_factory.getbasetemp() / "deskarm_home"
    monkeypatch.setenv("DESKARM_HOME", str(home))
    # the window saves its settings on close: each test starts from the defaults
    (home / "config" / "preferences.toml").unlink(missing_ok=True)


@pytest.fixture(scope="session")
def host_firmware() -> Path:
    """Build firmware/host_firmware (the firmware logic on a pseudo-terminal) once per session."""
    firmware = Path(__file__).resolve().parents[1] / "firmware"
    if shutil.which("make") is None or shutil.which("gcc") is None:
        pytest.skip("make and gcc are needed to build firmware/host_firmware")
    done = subprocess.run(["make", "-s", "-C", str(firmware), "host"], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, f"make -C firmware host failed:\n{done.stdout}\n{done.stderr}"
    return firmware / "host_firmware"


@pytest.fixture
def board(host_firmware):
    """A running host_firmware (tests/host_board.Board), stopped after the test."""
    from host_board import Board

    b = Board(host_firmware)
    try:
        yield b
    finally:
        b.stop()


_FROZE_IMPORTS = []  # set once the first Qt test has frozen the start-up objects


@pytest.fixture(autouse=True)
def _qt_garbage_in_the_gui_thread(request):
    """Qt tests (those using qtbot) run with Python's automatic garbage collection off and end
    with a collection here, in the GUI thread, after the widgets pytest-qt closed
    (``deleteLater``) are deleted. Left automatic, a collection can start in any thread that
    allocates — a simulated camera's render thread — and delete a Qt object (a window of an
    earlier test, in a reference cycle) there while the GUI thread delivers events to it: Python
    aborted that way in CI, "pure virtual method called" inside ``processEvents`` with no Python
    frame. The app does the same (app/startup.py GuiThreadGarbage). Objects alive before the
    first Qt test (imports, models) are frozen so these collections stay short."""
    if "qtbot" not in request.fixturenames:
        yield
        return
    import gc

    if not _FROZE_IMPORTS:
        gc.collect()
        gc.freeze()
        _FROZE_IMPORTS.append(True)
    gc.disable()
    try:
        yield
    finally:
        from PySide6 import QtCore

        app = QtCore.QCoreApplication.instance()
        if app is not None:
            QtCore.QCoreApplication.sendPostedEvents(None, QtCore.QEvent.Type.DeferredDelete)
        gc.collect()
        if app is not None:
            QtCore.QCoreApplication.sendPostedEvents(None, QtCore.QEvent.Type.DeferredDelete)
        gc.enable()
