"""The hand-eye TOML file: round trip, stale pairs, errors that name the file and the key."""
import numpy as np
import pytest

from core.handeye import HandEyeFileError, default_hand_eye_path, load_hand_eye, save_hand_eye, solve_rigid


def a_result(pair="webcam:0,1"):
    rng = np.random.default_rng(0)
    B = rng.uniform(-0.2, 0.2, (8, 3))
    T = np.eye(4)
    T[:3, 3] = (0.0, 0.4, 0.45)
    return solve_rigid(B - T[:3, 3], B, camera_pair=pair)


def test_round_trip_keeps_everything(tmp_path):
    res = a_result()
    path = save_hand_eye(res, tmp_path / "he.toml")
    again, warning = load_hand_eye(path, expected_pair="webcam:0,1")
    assert warning == ""
    assert np.allclose(again.base_T_camera, res.base_T_camera)
    assert (again.method, again.poses_used, again.camera_pair, again.created) == (
        res.method, res.poses_used, res.camera_pair, res.created)
    assert np.allclose(again.residuals_mm, res.residuals_mm) and again.rms_mm == pytest.approx(res.rms_mm)


def test_default_path_is_in_the_config_folder(tmp_path, monkeypatch):
    monkeypatch.setenv("DESKARM_HOME", str(tmp_path))
    assert default_hand_eye_path() == tmp_path / "config" / "hand_eye.toml"
    assert save_hand_eye(a_result()) == default_hand_eye_path()


def test_a_file_for_another_pair_is_flagged_stale(tmp_path):
    path = save_hand_eye(a_result("webcam:0,1"), tmp_path / "he.toml")
    _, warning = load_hand_eye(path, expected_pair="webcam:2,3")
    assert "another camera pair" in warning and "webcam:0,1" in warning and "calibrate-hand-eye" in warning


def test_errors_name_the_file_and_the_key(tmp_path):
    path = save_hand_eye(a_result(), tmp_path / "he.toml")
    text = path.read_text().replace("method = ", "methodx = ")
    path.write_text(text)
    with pytest.raises(HandEyeFileError, match=r"he\.toml: key 'method' is missing"):
        load_hand_eye(path)
    with pytest.raises(HandEyeFileError, match="no such hand-eye file"):
        load_hand_eye(tmp_path / "none.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("method = 'sweep'\nbase_T_camera = [[1, 2], [3, 4]]\n")
    with pytest.raises(HandEyeFileError, match=r"bad\.toml: key 'base_T_camera' must be a 4x4"):
        load_hand_eye(bad)
