"""The webcam realism preset (core.sim.realism): what it does to an image, the statistics it is
compared with real photos by, and its hooks (the simulated camera, --sim-realism, assist-trials)."""
import json
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from core.clock import SimClock
from core.session import SessionOptions
from core.sim.camera import SimStereoCamera
from core.sim.realism import (WEBCAM, RealismPreset, apply_realism, compare_with_real, distort_points,
                              format_comparison, image_stats, main, preset_named)

REAL = Path(__file__).resolve().parents[1] / "data" / "stereo_7x5_320x240"  # real 320x240 webcam photos
# only the lens: every other effect off
LENS_ONLY = replace(WEBCAM, defocus_sigma_px=(0.0, 0.0), motion_blur_px=(0.0, 0.0), rolling_shutter_px=0.0,
                    flicker=0.0, exposure_jitter=0.0, read_noise=0.0, shot_noise=0.0, vignetting=0.0,
                    jpeg_quality=(100, 100), distortion_k1=-0.05)


def test_flat_area_noise_is_measured_as_the_noise_added():
    rng = np.random.default_rng(0)
    flat = np.full((240, 320, 3), 120, np.uint8)
    assert image_stats(flat).noise == pytest.approx(0.0, abs=1e-6)
    noisy = np.clip(120 + rng.normal(0, 5.0, (240, 320, 1)), 0, 255).astype(np.uint8).repeat(3, axis=2)
    assert image_stats(noisy).noise == pytest.approx(5.0, rel=0.15)


def test_saturation_histogram_puts_grey_in_the_first_bin_and_pure_red_in_the_last():
    grey = image_stats(np.full((40, 40, 3), 90, np.uint8))
    red = image_stats(np.dstack([np.zeros((40, 40)), np.zeros((40, 40)), np.full((40, 40), 200)]).astype(np.uint8))
    assert grey.saturation_hist[0] == pytest.approx(1.0) and grey.saturation_mean == 0.0
    assert red.saturation_hist[-1] == pytest.approx(1.0) and red.saturation_mean == pytest.approx(255.0)


def test_the_preset_blurs_a_sharp_image_and_adds_noise_to_a_flat_one():
    board = np.kron((np.indices((12, 16)).sum(axis=0) % 2) * 200 + 30, np.ones((40, 40))).astype(np.uint8)
    board = cv2.cvtColor(board, cv2.COLOR_GRAY2BGR)  # 640x480 chessboard, perfectly sharp
    flat = np.full((480, 640, 3), 128, np.uint8)
    out_board, out_flat = apply_realism((board, flat), np.random.default_rng(3), t=0.1)
    assert image_stats(out_board).sharpness < 0.5 * image_stats(board).sharpness
    assert image_stats(out_flat).noise > 0.3  # JPEG removes most of the fine noise, as in real webcam photos
    raw = apply_realism(flat, np.random.default_rng(3), preset=replace(WEBCAM, jpeg_quality=(100, 100)))
    assert image_stats(raw).noise > 4.0  # read + shot noise at grey 128: σ ≈ 6
    # the corners lose light (vignetting) and the frame's exposure is one gain for the whole pair
    assert out_flat[:20, :20].mean() < out_flat[220:260, 300:340].mean() - 10


def test_the_same_generator_gives_the_same_frame_and_another_one_another():
    img = np.full((120, 160, 3), 100, np.uint8)
    a = apply_realism(img, np.random.default_rng(7), t=0.5)
    b = apply_realism(img, np.random.default_rng(7), t=0.5)
    c = apply_realism(img, np.random.default_rng(8), t=0.5)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert apply_realism(img, np.random.default_rng(7), preset=None) is img


def test_distort_points_says_where_a_clean_pixel_appears_after_the_lens():
    img = np.zeros((480, 640, 3), np.uint8)
    spot = (560.0, 420.0)  # near a corner, where barrel distortion moves it most
    cv2.circle(img, (int(spot[0] * 16), int(spot[1] * 16)), 3 * 16, (255, 255, 255), -1, cv2.LINE_AA, shift=4)
    out = apply_realism(img, np.random.default_rng(0), preset=LENS_ONLY)
    m = cv2.moments(cv2.cvtColor(out, cv2.COLOR_BGR2GRAY))
    seen = np.array([m["m10"] / m["m00"], m["m01"] / m["m00"]])
    predicted = distort_points([spot], (640, 480), LENS_ONLY)[0]
    assert np.linalg.norm(predicted - spot) > 5.0  # the lens moved it …
    assert np.linalg.norm(seen - predicted) < 0.5, (seen, predicted)  # … where distort_points says


def test_a_preset_with_a_value_out_of_range_names_the_field():
    with pytest.raises(ValueError, match="vignetting"):
        RealismPreset(vignetting=1.5)
    with pytest.raises(ValueError, match="jpeg_quality"):
        RealismPreset(jpeg_quality=(90, 60))
    with pytest.raises(ValueError, match="webcam"):
        preset_named("dslr")
    assert preset_named("off") is None and preset_named("webcam") is WEBCAM


def test_the_simulated_camera_delivers_realistic_frames_only_when_asked():
    clean = SimStereoCamera("static", clock=SimClock())
    real = SimStereoCamera("static", clock=SimClock(), realism="webcam")
    again = SimStereoCamera("static", clock=SimClock(), realism="webcam")
    frames = []
    for cam in (clean, real, again):
        cam.connect()
        frames.append(cam.read())
        cam.disconnect()
    f_clean, f_real, f_again = frames
    reference = clean.desk.render(0.0)  # the desk's own render: the clean camera delivers it unchanged
    assert np.array_equal(f_clean.left, reference[0]) and np.array_equal(f_clean.right, reference[1])
    assert not np.array_equal(f_real.left, f_clean.left)
    assert np.array_equal(f_real.left, f_again.left) and np.array_equal(f_real.right, f_again.right)
    assert f_real.left.shape == f_clean.left.shape and f_real.truth == f_clean.truth


def test_sim_realism_option_is_checked_and_reaches_the_camera():
    with pytest.raises(ValueError, match="--sim-realism"):
        SessionOptions(camera="sim", sim_realism="dslr").validate()
    SessionOptions(camera="sim", sim_realism="webcam").validate()
    from app.cli import build_parser

    assert build_parser().parse_args(["--sim-realism"]).sim_realism == "webcam"
    assert build_parser().parse_args([]).sim_realism is None


def test_compare_prints_real_photos_beside_clean_and_realistic_renders(capsys):
    table = compare_with_real(REAL, n_sim=2)
    assert list(table) == ["real", "sim", "sim webcam"]
    assert all(s.size == (320, 240) for s in table.values())
    assert table["sim webcam"].noise != table["sim"].noise
    assert "sharpness" in format_comparison(table)
    assert main(["--compare", str(REAL), "--n", "2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {"real", "sim", "sim webcam"} and len(out["real"]["saturation_hist"]) == 8


def test_compare_says_when_the_folder_has_no_photos(tmp_path, capsys):
    assert main(["--compare", str(tmp_path), "--n", "1"]) == 2
    assert "no .jpg/.png photos" in capsys.readouterr().err


def test_assist_trials_realistic_runs_the_loop_on_webcam_images():
    from app.cli_assist import AssistTrials, run_trials

    runner = AssistTrials(seed=1, realistic=True)
    clean = AssistTrials(seed=1)
    q = runner.ready_q
    assert not np.array_equal(runner.camera.render(q, 0.0).image, clean.camera.render(q, 0.0).image)
    summary, results = run_trials(1, "touch", seed=2, realistic=True)
    assert summary["realistic"] is True and len(results) == 1
