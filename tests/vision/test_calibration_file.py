"""The stereo calibration YAML: round trip, OpenCV-sample keys, clear errors for bad files."""
import cv2
import numpy as np
import pytest

from core.sim.rig import SimRig
from core.vision.calibration import CalibrationError, load_calibration, save_calibration


@pytest.fixture
def calib():
    return SimRig().calibration()


def test_round_trip_keeps_every_matrix(tmp_path, calib):
    path = save_calibration(tmp_path / "stereo.yaml", calib)
    back = load_calibration(path)
    for key in ("M1", "D1", "M2", "D2", "R", "T", "R1", "R2", "P1", "P2", "Q", "E", "F"):
        np.testing.assert_allclose(getattr(back, key), getattr(calib, key), atol=1e-9, err_msg=key)
    assert back.image_size == calib.image_size


def test_file_has_the_keys_of_opencvs_stereo_sample(tmp_path, calib):
    path = save_calibration(tmp_path / "stereo.yaml", calib)
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    for key in ("M1", "D1", "M2", "D2", "R", "T", "E", "F", "R1", "R2", "P1", "P2", "Q",
                "image_width", "image_height", "rms_stereo", "epipolar_error_px"):
        assert not fs.getNode(key).empty(), key
    fs.release()


def test_corrupt_file_names_the_file_and_the_fix(tmp_path):
    bad = tmp_path / "broken.yaml"
    bad.write_text("%YAML:1.0\nM1: [this is not, a matrix\n")
    with pytest.raises(CalibrationError, match="broken.yaml.*deskarm calibrate"):
        load_calibration(bad)


def test_missing_key_is_named(tmp_path, calib):
    path = save_calibration(tmp_path / "stereo.yaml", calib)
    text = path.read_text().replace("\nT: ", "\nT_renamed: ")
    path.write_text(text)
    with pytest.raises(CalibrationError, match="'T' is missing"):
        load_calibration(path)


def test_missing_file_is_named(tmp_path):
    with pytest.raises(CalibrationError, match="not found"):
        load_calibration(tmp_path / "nope.yaml")


def test_same_aspect_other_resolution_is_rescaled_and_says_so(tmp_path, calib):
    path = save_calibration(tmp_path / "stereo.yaml", calib)
    half = load_calibration(path, expected_size=(320, 240))
    assert half.image_size == (320, 240)
    assert half.M1[0, 0] == pytest.approx(calib.M1[0, 0] / 2)
    assert any("rescaled" in n for n in half.notes)


def test_other_aspect_ratio_is_a_clear_error(tmp_path, calib):
    path = save_calibration(tmp_path / "stereo.yaml", calib)
    with pytest.raises(CalibrationError, match="640x480.*1280x720"):
        load_calibration(path, expected_size=(1280, 720))
