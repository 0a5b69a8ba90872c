"""Dense disparity on the simulated desk: metric depth through Q, matchers, display, presets."""
import math

import numpy as np
import pytest

from core.paths import user_dir
from core.settings import SettingsError, SgbmParams, StereoMatchParams
from core.sim.desk import SimDesk
from core.sim.rig import SimRig, SimRigConfig
from core.vision.disparity import (
    DisparityComputer,
    PresetError,
    colorize_disparity,
    delete_preset,
    half_resolution_params,
    list_presets,
    load_preset,
    presets_path,
    save_preset,
)

DESK_DISTANCE_M = 0.50


@pytest.fixture(scope="module")
def desk():
    """The rig straight above the desk at 50 cm, one rendered pair and the true depth per pixel."""
    rig = SimRig(SimRigConfig(position=(0.0, 0.15, DESK_DISTANCE_M), look_at=(0.0, 0.15, 0.0)))
    left, right, _ = SimDesk(rig, scenario="static").render(0.0)
    calib = rig.calibration()
    h, w = left.shape[:2]
    uu, vv = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    rays_rect = np.linalg.inv(calib.P1[:3, :3]) @ np.stack([uu.ravel(), vv.ravel(), np.ones(uu.size)])
    rays_base = rig.base_T_left[:3, :3] @ calib.R1.T @ rays_rect
    z_true = (-rig.base_T_left[2, 3] / rays_base[2]).reshape(h, w)  # rectified Z where the ray meets z = 0
    return rig, calib, left, right, z_true


def depth_errors(computer, desk):
    _, _, left, right, z_true = desk
    z = computer.depth_map_m(computer.compute(left, right))
    ok = np.isfinite(z)
    ok[:, : computer.params.num_disparities] = False  # no match possible left of the search range
    return np.abs(z[ok] / z_true[ok] - 1.0), ok.mean()


@pytest.mark.parametrize("mode", ["SGBM", "HH", "SGBM_3WAY", "HH4"])
def test_sgbm_depth_is_metric_within_1_percent_at_50_cm(desk, mode):
    rel, valid = depth_errors(DisparityComputer(desk[1], SgbmParams(mode=mode)), desk)
    assert valid > 0.6
    assert np.median(rel) <= 0.01, f"{mode}: median depth error {np.median(rel) * 100:.2f} %"


@pytest.mark.parametrize("match, limit", [
    (StereoMatchParams(matcher="BM"), 0.01),
    (StereoMatchParams(wls=True, wls_lambda=1000, wls_sigma=0.9), 0.01),
    (StereoMatchParams(matcher="BM", wls=True), 0.01),
    (StereoMatchParams(half_resolution=True), 0.02),  # half the pixels, twice the disparity step
])
def test_bm_wls_and_half_resolution_are_metric_too(desk, match, limit):
    rel, valid = depth_errors(DisparityComputer(desk[1], SgbmParams(), match), desk)
    assert valid > 0.4
    assert np.median(rel) <= limit, f"{match}: median depth error {np.median(rel) * 100:.2f} %"


def test_disparity_is_float_pixels_not_fixed_point(desk):
    d = DisparityComputer(desk[1]).compute(desk[2], desk[3])
    good = d[d > 0]
    expected = desk[1].P1[0, 0] * desk[1].baseline_m / DESK_DISTANCE_M
    assert d.dtype == np.float32 and np.median(good) == pytest.approx(expected, rel=0.02)
    assert np.any(np.abs(good - np.round(good)) > 0.05)  # sub-pixel values survive


def test_half_resolution_output_keeps_the_full_size_and_scale(desk):
    full = DisparityComputer(desk[1]).compute(desk[2], desk[3])
    half = DisparityComputer(desk[1], match=StereoMatchParams(half_resolution=True)).compute(desk[2], desk[3])
    assert half.shape == full.shape
    assert np.median(half[half > 0]) == pytest.approx(np.median(full[full > 0]), rel=0.02)
    assert half_resolution_params(SgbmParams(num_disparities=64, min_disparity=-3)).num_disparities == 32
    assert half_resolution_params(SgbmParams(num_disparities=16)).num_disparities == 16


def test_a_click_gives_depth_in_mm_and_a_point_on_the_desk(desk):
    rig, calib = desk[0], desk[1]
    dc = DisparityComputer(calib)
    d = dc.compute(desk[2], desk[3])
    s = dc.depth_at(d, 400, 250, base_T_camera=rig.base_T_camera)
    assert s is not None
    assert s.depth_mm == pytest.approx(desk[4][250, 400] * 1e3, rel=0.01)
    assert abs(s.base_p[2]) < 0.005  # on the desk plane (z = 0 in robot_base)
    # camera_p is in camera_left (not the rectified frame): seen by the raw left camera and then
    # rectified, it lands back on the clicked pixel
    raw = calib.M1 @ np.asarray(s.camera_p)
    import cv2

    back = cv2.undistortPoints((raw[:2] / raw[2]).reshape(1, 1, 2), calib.M1, calib.D1, R=calib.R1, P=calib.P1)
    np.testing.assert_allclose(back.reshape(2), (400, 250), atol=0.01)
    d[:, :] = -1.0
    assert dc.depth_at(d, 400, 250) is None and dc.depth_at(d, -5, 9999) is None


def test_colours_span_the_fixed_search_range_not_the_image_min_max(desk):
    d = np.full((4, 4), 20.0, np.float32)
    d2 = d.copy()
    d2[0, 0] = 60.0
    a = colorize_disparity(d, 0, 64)
    b = colorize_disparity(d2, 0, 64)
    np.testing.assert_array_equal(a[1:, 1:], b[1:, 1:])
    d2[1, 1] = -1
    assert np.all(colorize_disparity(d2, 0, 64)[1, 1] == 0)  # no match: black


def test_the_legend_labels_each_colour_with_its_depth(desk):
    dc = DisparityComputer(desk[1], SgbmParams(num_disparities=64))
    ticks = dc.legend(5)
    assert [t.disparity_px for t in ticks] == [0, 16, 32, 48, 64]
    assert math.isinf(ticks[0].depth_m)
    f_b = desk[1].P1[0, 0] * desk[1].baseline_m
    assert ticks[2].depth_m == pytest.approx(f_b / 32, rel=1e-6)
    assert ticks[1].depth_m > ticks[2].depth_m > ticks[3].depth_m


def test_matcher_settings_are_validated_naming_field_and_range():
    with pytest.raises(SettingsError, match="stereo.matcher = 'SAD'"):
        StereoMatchParams(matcher="SAD")
    with pytest.raises(SettingsError, match="stereo.wls_lambda = 50 is outside"):
        StereoMatchParams(wls_lambda=50)
    with pytest.raises(SettingsError, match="bm_prefilter_size = 8 must be odd"):
        StereoMatchParams(bm_prefilter_size=8)


def test_parameters_can_change_between_computes(desk):
    dc = DisparityComputer(desk[1])
    dc.set_params(SgbmParams(num_disparities=96, block_size=7))
    dc.set_match_params(StereoMatchParams(matcher="BM"))
    d = dc.compute(desk[2], desk[3])
    assert d.shape == desk[2].shape[:2] and set(dc.last_timings_ms) >= {"match", "total"}


# ---------------------------------------------------------------------------------------------
# presets


def test_presets_are_kept_per_camera_pair(tmp_path):
    path = tmp_path / "presets.toml"
    fine = (SgbmParams(block_size=7, mode="HH"), StereoMatchParams(wls=True, wls_lambda=800.0))
    fast = (SgbmParams(num_disparities=32), StereoMatchParams(matcher="BM", half_resolution=True))
    save_preset("webcam:0,2", *fine, name="fine", path=path)
    save_preset("sim", *fast, path=path)
    assert load_preset("webcam:0,2", path=path) == fine  # the pair's last saved one
    assert load_preset("sim", "default", path=path) == fast
    assert load_preset("webcam:9,9", path=path) is None
    assert list_presets("webcam:0,2", path=path) == ["fine"]
    assert delete_preset("webcam:0,2", "fine", path=path) and list_presets("webcam:0,2", path=path) == []


def test_presets_live_in_the_user_config_folder():
    save_preset("sim", SgbmParams(), StereoMatchParams())
    assert presets_path() == user_dir("config") / "stereo_presets.toml" and presets_path().is_file()
    assert load_preset("sim") == (SgbmParams(), StereoMatchParams())


def test_a_bad_preset_file_names_the_file_the_table_and_the_key(tmp_path):
    path = tmp_path / "presets.toml"
    save_preset("sim", SgbmParams(), path=path)
    path.write_text(path.read_text().replace("block_size = 5", "block_size = 4"))
    with pytest.raises(PresetError, match=r'presets.toml: \[pairs."sim".presets.default.sgbm\] sgbm.block_size = 4 must be odd'):
        load_preset("sim", path=path)
    path.write_text(path.read_text().replace("block_size = 4", "blocksize = 5"))
    with pytest.raises(PresetError, match="unknown key 'blocksize'; valid: block_size"):
        load_preset("sim", path=path)
    path.write_text("[pairs\n")
    with pytest.raises(PresetError, match="not valid TOML"):
        load_preset("sim", path=path)
