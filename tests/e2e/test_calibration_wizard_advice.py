"""The calibration wizard says a refused calibration's root cause first (issue 25 items 9–10): a real
webcam pair with a mirrored right camera shows 'mirrored' as the problem, its consequences after it,
and Save and use stays off (pytest-qt, offscreen)."""
from __future__ import annotations

from pathlib import Path

import cv2
import pytest
from PySide6 import QtCore

import widgets  # noqa: F401  (row-major images)
from app.calibration_worker import ReportUpdate
from core.vision.calibration import installed_calibration_path
from core.vision.stereo_calibration import ChessboardSpec, calibrate_stereo, detect_pair
from tests.window.test_calibration_wizard import wizard_rig

REAL = Path(__file__).resolve().parents[1] / "data" / "stereo_7x5_320x240"
BOARD = ChessboardSpec(7, 5, 0.025)
TIMEOUT_MS = 5000
LEFT = QtCore.Qt.MouseButton.LeftButton


@pytest.fixture(scope="module")
def mirrored_report():
    lefts = sorted(REAL.glob("left*.jpg"))
    dets = [detect_pair(cv2.imread(str(p)), cv2.flip(cv2.imread(str(p.with_name(p.name.replace("left", "right")))), 1),
                        BOARD) for p in lefts]
    return calibrate_stereo(dets, names=[p.name for p in lefts], board=BOARD)


@pytest.fixture
def rig(qtbot, tmp_path, monkeypatch):
    """An open wizard for BOARD (the real 7x5 photos' board), closed and joined at the end."""
    yield from wizard_rig(qtbot, tmp_path, monkeypatch, BOARD)


def test_the_wizard_says_mirrored_first_and_its_consequences_after_it(qtbot, rig, mirrored_report):
    ctl, wizard = rig
    rep = mirrored_report
    update = ReportUpdate(wizard.session_id, rep, tuple(range(1, rep.pairs_total + 1)), None, None, "")
    ctl.worker.sigReport.emit(update)
    qtbot.waitUntil(lambda: wizard.report_update is update, timeout=TIMEOUT_MS)
    lines = wizard.summary_label.text().splitlines()
    assert lines[1].startswith("NOT INSTALLABLE — the right camera's picture is mirrored"), lines
    assert lines[2].startswith("which also explains:"), lines
    assert not any(line.startswith("NOT INSTALLABLE") and "tilt the board more" in line for line in lines)
    assert not wizard.save_button.isEnabled()
    qtbot.mouseClick(wizard.save_button, LEFT)  # a disabled button: nothing is installed
    assert not installed_calibration_path().exists()
