"""Implausible lens distortion is refused when a calibration file is loaded (issue 25 item 4):
``D1 = [1e6, 0, 0, 0, 0]`` was accepted and sent the arm toward phantom targets (3D error 667 mm)."""
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from core.sim.rig import SimRig
from core.vision.calibration import CalibrationError, distortion_problem, load_calibration, save_calibration
from core.vision.stereo_calibration import ChessboardSpec, calibrate_stereo, detect_pair

REAL = Path(__file__).resolve().parents[1] / "data" / "stereo_7x5_320x240"


@pytest.fixture(scope="module")
def sim():
    return SimRig().calibration()  # 640x480, fx 430 px


@pytest.mark.parametrize("key, D, reason", [
    ("D1", [1e6, 0, 0, 0, 0], "moves the image border to 0.0105×"),  # the file
    ("D2", [0, 0, 0.5, 0, 0], "moves the image border to 267×"),  # a tangential term run away
    ("D1", [-0.5, 0, 0, 0, 0], "cannot be undone at the image border"),  # folds back before the corners
    ("D2", [0.1, -0.2, 0, 0, 0], "cannot be undone at the image border"),  # folds back just inside them
])
def test_an_implausible_distortion_is_refused_naming_the_file_and_the_key(tmp_path, sim, key, D, reason):
    path = save_calibration(tmp_path / "stereo.yaml", replace(sim, **{key: np.array([D], float)}))
    with pytest.raises(CalibrationError) as info:
        load_calibration(path)
    message = str(info.value)
    assert info.value.key == key and message.startswith(f"{path}: '{key}' = [")
    assert reason in message and "not a plausible lens" in message and "deskarm calibrate" in message


@pytest.mark.parametrize("D", [[-0.3, 0.1, 0, 0, 0], [-0.05, 0, 0, 0, 0], [0.1, -0.5, 0.001, -0.002, 0.3],
                               [0.3, 0, 0, 0, 0, 0, 0, 0], [0, 0, 0, 0, 0]])
def test_real_lens_distortions_still_load(tmp_path, sim, D):
    path = save_calibration(tmp_path / "stereo.yaml", replace(sim, D1=np.array([D], float), D2=np.array([D], float)))
    back = load_calibration(path)
    np.testing.assert_allclose(back.D1.ravel(), D)


def test_the_real_webcam_calibration_is_plausible_and_loads(tmp_path):
    board = ChessboardSpec(7, 5, 0.025)
    pairs = [(cv2.imread(str(p)), cv2.imread(str(p.with_name(p.name.replace("left", "right")))))
             for p in sorted(REAL.glob("left*.jpg"))]
    assert len(pairs) >= 8, "tests/data/stereo_7x5_320x240 is missing"
    report = calibrate_stereo([detect_pair(l, r, board) for l, r in pairs], board=board)
    calib = report.calibration
    assert np.any(calib.D1) and np.any(calib.D2)  # a real lens model, not all zeros
    assert distortion_problem(calib.M1, calib.D1, calib.image_size) == ""
    assert distortion_problem(calib.M2, calib.D2, calib.image_size) == ""
    back = load_calibration(save_calibration(tmp_path / "real.yaml", calib))
    np.testing.assert_allclose(back.D1, calib.D1)


def test_a_calibration_run_with_such_a_distortion_is_not_installable(sim):
    """The wizard's and ``deskarm calibrate``'s sanity checks refuse it too, so nothing is installed
    that the next start would refuse."""
    from core.vision.stereo_calibration import CalibrationOptions, _sanity_problems

    rvecs = [np.zeros(3)] * 3
    tvecs = [np.array([0.0, 0.0, 0.5])] * 3
    bad = replace(sim, D1=np.array([[1e6, 0, 0, 0, 0]], float))
    problems, _ = _sanity_problems(bad, rvecs, tvecs, (0.01, 0.01), [], None, CalibrationOptions())
    assert any(p.startswith("the left lens distortion moves the image border") for p in problems), problems
    good, _ = _sanity_problems(sim, rvecs, tvecs, (0.01, 0.01), [], None, CalibrationOptions())
    assert not any("lens distortion" in p for p in good), good
