"""A calibration made on the simulated desk never replaces the real cameras' one (issue 22 item
18): the README invites trying the calibration wizard on the simulated desk, and "Save and use"
there wrote the very file real webcams load at start."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PySide6 import QtCore

from core.session import DeskSession, SessionOptions
from core.sim.rig import SimRig, SimRigConfig
from core.vision.calibration import (
    PREVIOUS_NAME,
    install_calibration,
    installed_calibration_path,
    is_simulated_pair,
    load_calibration,
    save_calibration,
)

DATA = Path(__file__).resolve().parents[1] / "data" / "stereo_7x5_320x240"  # a real webcam pair's pictures
LEFT = QtCore.Qt.MouseButton.LeftButton
TIMEOUT_MS = 10_000


@pytest.fixture
def home(tmp_path, monkeypatch):
    monkeypatch.setenv("DESKARM_HOME", str(tmp_path / "home"))
    return tmp_path / "home"


def real_pair_calibration():
    """A calibration of a real 320x240 webcam pair, as `deskarm calibrate` would have installed it."""
    return SimRig(SimRigConfig(width=320, height=240, focal_px=260.0)).calibration()


def webcam_session_calibration():
    """The calibration a session on real cameras loads at start (the saved pictures of a webcam pair)."""
    session = DeskSession.create(SessionOptions(camera=f"folder:{DATA}", scenario="static"))
    try:
        assert not is_simulated_pair(session.camera.pair_id)
        return session.calibration
    finally:
        session.close()


def test_the_simulated_desks_calibration_has_its_own_file_and_keeps_its_own_previous_one(home):
    real = installed_calibration_path()
    sim = installed_calibration_path(simulated=True)
    assert real == home / "config" / "calibration.yaml" and sim != real and sim.parent != real.parent
    install_calibration(real_pair_calibration())
    before = real.read_bytes()
    for _ in range(2):  # twice: the second keeps the first as the simulated desk's previous one
        assert install_calibration(SimRig().calibration(), simulated=True) == sim
    assert real.read_bytes() == before and not real.with_name(PREVIOUS_NAME).exists()
    assert sim.with_name(PREVIOUS_NAME).is_file()
    loaded = webcam_session_calibration()
    assert Path(loaded.source) == real and loaded.image_size == (320, 240)
    assert is_simulated_pair("sim") and not is_simulated_pair("webcam:0,2")


def test_saving_the_wizards_calibration_on_the_simulated_desk_leaves_the_webcams_file_alone(qtbot, home):
    from app.gui import MainWindow

    real = installed_calibration_path()
    save_calibration(real, real_pair_calibration())
    before = real.read_bytes()
    session = DeskSession.create(SessionOptions(camera="sim", scenario="static"))
    window = MainWindow(session)
    qtbot.addWidget(window)
    window.resize(800, 480)
    window.show()
    window.start()
    try:
        qtbot.mouseClick(window.calibrate_button, LEFT)
        ctl = window.calibration_controller
        wizard, worker = ctl.wizard, ctl.worker
        with qtbot.waitSignal(worker.sigSession, timeout=TIMEOUT_MS):
            qtbot.mouseClick(wizard.start_button, LEFT)  # the simulated desk holds the board up
        qtbot.waitUntil(lambda: len(wizard.numbers) >= 6, timeout=40_000)
        with qtbot.waitSignal(worker.sigReport, timeout=20_000):
            qtbot.mouseClick(wizard.calibrate_button, LEFT)
        qtbot.waitUntil(lambda: wizard.save_button.isEnabled(), timeout=TIMEOUT_MS)
        with qtbot.waitSignal(window.workers.perception.sigCalibrationApplied, timeout=TIMEOUT_MS) as applied:
            qtbot.mouseClick(wizard.save_button, LEFT)
        sim = installed_calibration_path(simulated=True)
        assert ctl.installed_path == sim and sim.is_file()
        assert np.allclose(load_calibration(sim).M1, applied.args[0].M1)  # in use in this window
        assert real.read_bytes() == before  # the webcams' file did not change
        qtbot.waitUntil(lambda: str(sim) in window.banner.text(), timeout=TIMEOUT_MS)
    finally:
        window.stop()
    loaded = webcam_session_calibration()  # and the next start on real cameras loads theirs
    assert Path(loaded.source) == real and np.allclose(loaded.M1, load_calibration(real).M1)
