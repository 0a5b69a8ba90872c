"""Bad calibration and preset files (issue 16 items 5 and 9): each gives one message naming the file,
the key and the fix, installs nothing of the bad file, and leaves the app able to run uncalibrated
or with default stereo parameters.

Permission problems are tested twice: for real with chmod (skipped where the mode bits do not bind,
i.e. as root with CAP_DAC_OVERRIDE) and simulated by an ``open`` that refuses (runs everywhere).
"""
from __future__ import annotations

import re
import stat
import tempfile
from pathlib import Path

import cv2
import numpy as np
import pytest

import core.paths
import core.vision.calibration as calibration_module
from core.settings import SgbmParams, StereoMatchParams
from core.sim.rig import SimRig
from core.vision.calibration import (
    CalibrationError,
    export_ros_camera_info,
    install_calibration,
    installed_calibration_path,
    load_calibration,
    save_calibration,
)
from core.vision.disparity import PresetError, delete_preset, list_presets, load_preset, save_preset



def _mode_bits_bind() -> bool:
    """False for root (CAP_DAC_OVERRIDE), who reads and writes whatever the mode bits say."""
    with tempfile.TemporaryDirectory() as folder:
        probe = Path(folder) / "probe"
        probe.write_bytes(b"x")
        probe.chmod(0)
        try:
            probe.read_bytes()
        except PermissionError:
            return True
        finally:
            probe.chmod(stat.S_IRUSR | stat.S_IWUSR)
    return False


needs_binding_mode_bits = pytest.mark.skipif(not _mode_bits_bind(), reason="root reads and writes through chmod 000 / 555")


@pytest.fixture
def calib():
    return SimRig().calibration()


@pytest.fixture
def own_home(tmp_path, monkeypatch):
    """A config folder of this test alone (the shared one holds other tests' calibration)."""
    monkeypatch.setenv("DESKARM_HOME", str(tmp_path / "home"))
    return tmp_path / "home"


def write_calibration(path, calib, **override):
    """A calibration YAML like save_calibration's, with some keys replaced."""
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    for key in ("M1", "D1", "M2", "D2", "R", "T"):
        fs.write(key, np.asarray(override.get(key, getattr(calib, key)), np.float64))
    w, h = calib.image_size
    for key, value in (("image_width", w), ("image_height", h), ("rms_stereo", 0.2), ("epipolar_error_px", 0.1)):
        value = override.get(key, value)
        fs.write(key, int(value) if isinstance(value, int) else float(value))
    fs.release()
    return path


def refuse(paths_under, monkeypatch, module):
    """Make ``open`` in ``module`` fail with EACCES for files under ``paths_under`` (as chmod would)."""
    real_open = open

    def fake_open(file, *args, **kwargs):
        if str(file).startswith(str(paths_under)):
            raise PermissionError(13, "Permission denied", str(file))
        return real_open(file, *args, **kwargs)

    monkeypatch.setattr(module, "open", fake_open, raising=False)


# ---------------------------------------------------------------------------------------------
# calibration values


def test_a_zero_baseline_names_the_file_and_key_T_instead_of_an_opencv_traceback(tmp_path, calib):
    path = write_calibration(tmp_path / "zero_baseline.yaml", calib, T=np.zeros((3, 1)))
    with pytest.raises(CalibrationError, match=re.escape(
            f"{path}: 'T': baseline |T| = 0 m — the two cameras cannot be the same; recalibrate")) as err:
        load_calibration(path)
    assert err.value.key == "T" and err.value.path == path and not err.value.missing


SINGULAR = {
    "all zeros": (np.zeros((3, 3)), "is all zeros"),
    "fy = 0": ([[430.0, 0, 320], [0, 0, 240], [0, 0, 1]], "fy = 0"),
    "negative fx": ([[-430.0, 0, 320], [0, 430, 240], [0, 0, 1]], "fx = -430"),
    "last row zero": ([[430.0, 0, 320], [0, 430, 240], [0, 0, 0]], "last row [0 0 0]"),
}


@pytest.mark.parametrize("key", ["M1", "M2"])
@pytest.mark.parametrize("case", SINGULAR, ids=list(SINGULAR))
def test_a_singular_camera_matrix_names_the_file_and_the_key(tmp_path, calib, key, case):
    matrix, what = SINGULAR[case]
    path = write_calibration(tmp_path / "singular.yaml", calib, **{key: matrix})
    with pytest.raises(CalibrationError) as err:
        load_calibration(path)
    message = str(err.value)
    assert message.startswith(f"{path}: '{key}' ") and what in message and "deskarm calibrate" in message, message
    assert err.value.key == key


@pytest.mark.parametrize("key, value", [("image_width", 40000), ("image_height", 30000), ("image_width", 8193)])
def test_an_absurd_image_size_is_refused_before_any_rectify_map_is_allocated(tmp_path, calib, key, value):
    path = write_calibration(tmp_path / "huge.yaml", calib, **{key: value})
    with pytest.raises(CalibrationError, match=re.escape(f"{path}: '{key}' = {value} px is missing or invalid")):
        load_calibration(path)


def test_the_largest_sane_image_size_still_loads(tmp_path, calib):
    path = write_calibration(tmp_path / "big.yaml", calib, image_width=8192, image_height=6144)
    assert load_calibration(path).image_size == (8192, 6144)


ABSURD = [
    ("D2", np.array([[0.1, np.inf, 0, 0, 0]]), "'D2' contains NaN or infinity"),
    ("M1", [[430.0, 0, np.nan], [0, 430, 240], [0, 0, 1]], "'M1' contains NaN or infinity"),
    ("R", np.diag([2.0, 0.5, 1.0]), "'R' is not a rotation matrix (R·Rᵀ ≠ I)"),
    ("rms_stereo", float("nan"), "'rms_stereo' = nan px must be a finite value ≥ 0"),
    ("epipolar_error_px", -1.0, "'epipolar_error_px' = -1 px must be a finite value ≥ 0"),
    ("image_height", 480.5, "'image_height' = 480.5 px is missing or invalid"),
]


@pytest.mark.parametrize("key, value, expected", ABSURD, ids=[f"{k}" for k, _, _ in ABSURD])
def test_non_finite_or_absurd_values_name_the_key(tmp_path, calib, key, value, expected):
    path = write_calibration(tmp_path / "absurd.yaml", calib, **{key: value})
    with pytest.raises(CalibrationError, match=re.escape(f"{path}: {expected}")):
        load_calibration(path)


def test_a_missing_file_is_told_apart_from_a_broken_one(tmp_path, calib):
    with pytest.raises(CalibrationError) as missing:
        load_calibration(tmp_path / "none.yaml")
    broken = write_calibration(tmp_path / "broken.yaml", calib, T=np.zeros((3, 1)))
    with pytest.raises(CalibrationError) as bad:
        load_calibration(broken)
    assert missing.value.missing and not bad.value.missing
    (tmp_path / "folder.yaml").mkdir()
    with pytest.raises(CalibrationError, match="folder.yaml: is a folder, expected a calibration YAML") as folder:
        load_calibration(tmp_path / "folder.yaml")
    assert not folder.value.missing


def test_a_corrupt_installed_calibration_names_its_path_and_reason(own_home, calib):
    """What core.session's banner needs: the installed file exists, so not "no calibration yet"."""
    installed = installed_calibration_path()
    installed.parent.mkdir(parents=True)
    write_calibration(installed, calib, M2=np.zeros((3, 3)))
    with pytest.raises(CalibrationError) as err:
        load_calibration(installed)
    assert str(err.value).startswith(f"{installed}: 'M2' is all zeros")
    assert err.value.path == installed and not err.value.missing


# ---------------------------------------------------------------------------------------------
# permissions (read)


def test_an_unreadable_calibration_says_permission_denied_simulated(tmp_path, calib, monkeypatch):
    path = save_calibration(tmp_path / "locked.yaml", calib)
    refuse(path, monkeypatch, calibration_module)
    with pytest.raises(CalibrationError, match=re.escape(f"{path}: cannot read: permission denied — ")):
        load_calibration(path)


@needs_binding_mode_bits
def test_an_unreadable_calibration_says_permission_denied(tmp_path, calib):
    path = save_calibration(tmp_path / "locked.yaml", calib)
    path.chmod(0)
    try:
        with pytest.raises(CalibrationError, match=re.escape(f"{path}: cannot read: permission denied — ")):
            load_calibration(path)
    finally:
        path.chmod(stat.S_IRUSR | stat.S_IWUSR)


# ---------------------------------------------------------------------------------------------
# permissions (write: item 9)


def test_saving_into_a_read_only_folder_names_the_path_simulated(tmp_path, calib, own_home, monkeypatch):
    locked = tmp_path / "locked"
    locked.mkdir()
    refuse(locked, monkeypatch, core.paths)
    with pytest.raises(PermissionError, match=re.escape(f"{locked / 'c.yaml'}: cannot write: permission denied — make {locked} writable")) as err:
        save_calibration(locked / "c.yaml", calib)
    assert "[Errno" not in str(err.value) and err.value.errno == 13
    with pytest.raises(PermissionError, match=re.escape(f"{locked / 'left.yaml'}: cannot write: permission denied")):
        export_ros_camera_info(calib, locked)
    assert list(locked.iterdir()) == []  # no temporary file left behind


def test_installing_into_a_read_only_config_folder_keeps_the_installed_one(calib, own_home, monkeypatch):
    installed = install_calibration(calib)
    before = installed.read_bytes()
    refuse(installed.parent, monkeypatch, core.paths)
    with pytest.raises(PermissionError, match=r"cannot write: permission denied — make .* writable for your user "
                                              r"or set DESKARM_HOME to a writable folder"):
        install_calibration(SimRig().calibration())
    assert installed.read_bytes() == before


def test_saving_a_preset_into_a_read_only_folder_names_the_path_simulated(tmp_path, monkeypatch):
    path = tmp_path / "locked" / "presets.toml"
    save_preset("sim", SgbmParams(), path=path)
    refuse(path.parent, monkeypatch, core.paths)
    with pytest.raises(PermissionError, match=re.escape(f"{path}: cannot write: permission denied — ")):
        save_preset("sim", SgbmParams(block_size=7), name="fine", path=path)
    with pytest.raises(PermissionError, match=re.escape(f"{path}: cannot write: permission denied — ")):
        delete_preset("sim", "default", path=path)
    assert list_presets("sim", path=path) == ["default"]


@needs_binding_mode_bits
def test_saving_into_a_read_only_folder_names_the_path(tmp_path, calib):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(stat.S_IRUSR | stat.S_IXUSR)
    try:
        with pytest.raises(PermissionError, match=re.escape(f"{locked / 'c.yaml'}: cannot write: permission denied — ")):
            save_calibration(locked / "c.yaml", calib)
        with pytest.raises(PermissionError, match=re.escape(f"{locked / 'p.toml'}: cannot write: permission denied — ")):
            save_preset("sim", SgbmParams(), path=locked / "p.toml")
    finally:
        locked.chmod(stat.S_IRWXU)


@needs_binding_mode_bits
def test_an_unreadable_preset_file_is_a_preset_error(tmp_path):
    path = save_preset("sim", SgbmParams(), path=tmp_path / "p.toml")
    path.chmod(0)
    try:
        with pytest.raises(PresetError, match=re.escape(f"{path}: cannot read: permission denied — ")):
            list_presets("sim", path=path)
    finally:
        path.chmod(stat.S_IRUSR | stat.S_IWUSR)


# ---------------------------------------------------------------------------------------------
# stereo presets of the wrong structure


WRONG_STRUCTURE = [
    ("pairs = 3", "pairs = 3 must be a table of camera pairs"),
    ("[pairs]\nsim = 3", 'pairs."sim" = 3 must be a table'),
    ('[pairs.sim]\npresets = "x"', "pairs.\"sim\".presets = 'x' must be a table of presets"),
    ("[pairs.sim]\nactive = 3", 'pairs."sim".active = 3 must be a preset name (a string)'),
    ('[pairs.sim.presets]\ndefault = "x"', "pairs.\"sim\".presets.default = 'x' must be a table"),
]


@pytest.mark.parametrize("text, expected", WRONG_STRUCTURE, ids=[t for t, _ in WRONG_STRUCTURE])
def test_a_preset_file_of_the_wrong_structure_names_the_file_and_key(tmp_path, text, expected):
    path = tmp_path / "stereo_presets.toml"
    path.write_text(text + "\n")
    for call in (lambda: list_presets("sim", path=path), lambda: load_preset("sim", path=path),
                 lambda: save_preset("sim", SgbmParams(), path=path),
                 lambda: delete_preset("sim", "default", path=path)):
        with pytest.raises(PresetError, match=re.escape(f"{path}: {expected}")):
            call()
    assert path.read_text() == text + "\n"  # not overwritten: the user may want to repair it


def test_a_broken_pair_leaves_the_other_pairs_usable(tmp_path):
    path = tmp_path / "stereo_presets.toml"
    path.write_text('[pairs]\n"webcam:0,2" = 3\n')
    assert list_presets("sim", path=path) == [] and load_preset("sim", path=path) is None
    save_preset("sim", SgbmParams(block_size=7), StereoMatchParams(wls=True), "fine", path=path)
    assert load_preset("sim", path=path) == (SgbmParams(block_size=7), StereoMatchParams(wls=True))
    with pytest.raises(PresetError, match=r'pairs."webcam:0,2" = 3'):
        list_presets("webcam:0,2", path=path)


def test_a_preset_file_nested_too_deeply_is_a_preset_error(tmp_path):
    path = tmp_path / "stereo_presets.toml"
    path.write_text("x = " + "[" * 600 + "]" * 600 + "\n")
    with pytest.raises(PresetError, match=re.escape(f"{path}: nested too deeply")):
        list_presets("sim", path=path)
    path.write_text("[pairs.sim.presets.default.sgbm]\nblock_size" + ".a" * 3000 + " = 1\n")
    with pytest.raises(PresetError, match=re.escape(f'{path}: [pairs."sim".presets.default.sgbm] ')):
        load_preset("sim", path=path)
