"""Stereo calibration that is honest: symmetric boards, turned cameras, and the sanity checks
that refuse physically impossible results (real webcam photos in tests/data, rendered boards)."""
import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from core.sim.board_render import BoardPose, _rot, default_rig, render_pair, render_set
from core.vision.stereo_calibration import (
    ChessboardSpec,
    PairDetection,
    calibrate_stereo,
    detect_pair,
    parse_board,
    suggest_board,
)

REAL = Path(__file__).resolve().parents[1] / "data" / "stereo_7x5_320x240"
BOARD_7x5 = ChessboardSpec(7, 5, 0.025)


def assert_close_rel(value, truth, rel, what):
    """Relative comparison that prints both values."""
    err = abs(value / truth - 1.0)
    assert err <= rel, f"{what}: got {value:.6g}, expected {truth:.6g} ({err * 100:.2f} % > {rel * 100:g} %)"


@pytest.fixture(scope="module")
def real_images():
    lefts = sorted(REAL.glob("left*.jpg"))
    assert len(lefts) >= 8, "tests/data/stereo_7x5_320x240 is missing"
    return [(cv2.imread(str(p)), cv2.imread(str(p.with_name(p.name.replace("left", "right"))))) for p in lefts]


@pytest.fixture(scope="module")
def real_report(real_images):
    return calibrate_stereo([detect_pair(l, r, BOARD_7x5) for l, r in real_images], board=BOARD_7x5)


def test_real_webcam_photos_calibrate_with_plausible_numbers(real_report):
    r = real_report
    assert r.ok, r.problems
    assert r.pairs_used == r.pairs_total and r.rms_stereo < 0.4 and r.epipolar_error_px < 0.3
    assert 360 < r.calibration.M1[0, 0] < 440 and 360 < r.calibration.M2[0, 0] < 440  # plain OpenCV: 397/399
    assert 1.5 < r.calibration.baseline_m / BOARD_7x5.square_m < 2.0  # plain OpenCV: 1.74 squares
    assert 30 < r.checks["fov_left_deg"] < 60 and r.checks["tilt_spread_deg"] > 30


def test_an_upside_down_right_camera_is_calibrated_right_and_refused_with_the_reason(real_images, real_report):
    dets = [detect_pair(l, cv2.rotate(r, cv2.ROTATE_180), BOARD_7x5) for l, r in real_images]
    r = calibrate_stereo(dets, board=BOARD_7x5)
    assert_close_rel(r.calibration.M1[0, 0], real_report.calibration.M1[0, 0], 0.01, "fx left")
    assert_close_rel(r.calibration.baseline_m, real_report.calibration.baseline_m, 0.01, "baseline")
    assert r.rms_stereo < 0.4
    assert not r.ok and any("upside down" in p and "same way up" in p for p in r.problems), r.problems


def test_identical_left_and_right_images_are_refused(real_images):
    r = calibrate_stereo([detect_pair(l, l, BOARD_7x5) for l, _ in real_images], board=BOARD_7x5)
    assert not r.ok and any("the left and right images are the same — check the camera indices" in p
                            for p in r.problems), r.problems


def test_swapped_views_are_refused_offering_swap(real_images):
    r = calibrate_stereo([detect_pair(r, l, BOARD_7x5) for l, r in real_images], board=BOARD_7x5)
    assert not r.ok and any("swapped" in p and "--swap" in p for p in r.problems), r.problems


def test_an_implausible_focal_length_is_refused(real_images):
    # the same corners shrunk tenfold towards the image centre: a camera with fx ≈ 40 px at 320 px
    def shrink(pts):
        return ((pts - (160, 120)) * 0.1 + (160, 120)).astype(np.float32)

    dets = [detect_pair(l, r, BOARD_7x5) for l, r in real_images]
    dets = [PairDetection(d.left, d.right, d.object_points, shrink(d.left_points), shrink(d.right_points), d.ids)
            for d in dets]
    r = calibrate_stereo(dets, board=BOARD_7x5)
    assert r.calibration.M1[0, 0] < 80
    text = " | ".join(r.problems)
    assert not r.ok and "field of view" in text and "--wide" in text, text


def test_poses_that_all_tilt_the_board_alike_are_refused():
    rig = default_rig(size=(320, 240))
    board = ChessboardSpec(9, 6, 0.025)
    rng = np.random.default_rng(4)
    dets = []
    for k in range(8):
        R = _rot(math.radians(10), 0.0, math.radians(rng.uniform(-20, 20)))  # same tilt, only the roll varies
        t = np.array([rng.uniform(-0.12, 0.0), rng.uniform(-0.08, -0.02), rng.uniform(0.45, 0.6)])
        left, right = render_pair(board, rig, BoardPose(R, t), seed=k)
        dets.append(detect_pair(left, right, board))
    assert sum(d.ok for d in dets) >= 6
    r = calibrate_stereo(dets, board=board)
    assert not r.ok and any("tilt the board more, fx cannot be pinned down" in p for p in r.problems), r.problems


def test_a_symmetric_7x7_board_is_accepted_and_calibrates_to_the_truth():
    board = parse_board("chessboard:7x7", 0.025)
    rig = default_rig(size=(320, 240))
    pairs = render_set(board, rig, 10, seed=7)
    dets = [detect_pair(p.left, p.right, board) for p in pairs]
    assert sum(d.ok for d in dets) >= 9
    r = calibrate_stereo(dets, board=board)
    assert r.ok, r.problems
    assert_close_rel(r.calibration.M1[0, 0], rig.K1[0, 0], 0.02, "fx left")
    assert_close_rel(r.calibration.baseline_m, rig.baseline_m, 0.02, "baseline")
    # the right camera upside down: the quarter/half turn is settled over the pairs, then refused
    turned = [detect_pair(p.left, cv2.rotate(p.right, cv2.ROTATE_180), board) for p in pairs]
    t = calibrate_stereo(turned, board=board)
    assert_close_rel(t.calibration.baseline_m, rig.baseline_m, 0.02, "baseline, right camera upside down")
    assert any("upside down" in p for p in t.problems), t.problems


def test_a_board_size_is_suggested_only_when_it_calibrates(real_images):
    lefts = [l for l, _ in real_images]
    hint = suggest_board(lefts, ChessboardSpec(8, 6, 0.025), pairs=real_images)
    assert hint and "use --board chessboard:7x5" in hint
    # 8x5 cannot be the board either way: a 7x5 board has no 8-corner rows to calibrate from
    assert suggest_board(lefts, ChessboardSpec(9, 5, 0.025), pairs=real_images) is None or \
        "8x5" not in suggest_board(lefts, ChessboardSpec(9, 5, 0.025), pairs=real_images)


def test_left_and_right_of_different_sizes_are_refused_naming_both(real_images):
    from core.vision.stereo_calibration import CalibrationFailed

    dets = [detect_pair(l, cv2.resize(r, (640, 480)), BOARD_7x5) for l, r in real_images]
    with pytest.raises(CalibrationFailed, match="the left images are 320x240 but the right ones are 640x480"):
        calibrate_stereo(dets, board=BOARD_7x5)
