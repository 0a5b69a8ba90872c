"""Stereo calibration on rendered boards of known geometry: accuracy, robustness, gating, coverage."""
import math

import cv2
import numpy as np
import pytest

from core.clock import SimClock
from core.sim.board_render import (
    CHEAP_WEBCAM,
    RenderedBoardCamera,
    default_rig,
    project,
    random_poses,
    render_pair,
    render_set,
)
from core.vision.calibration import (
    export_ros_camera_info,
    load_calibration,
    save_calibration,
)
from core.vision.stereo_calibration import (
    BoardDetection,
    BoardError,
    CalibrationFailed,
    CalibrationOptions,
    CalibrationSession,
    CharucoSpec,
    ChessboardSpec,
    GateParams,
    PairDetection,
    board_motion_px,
    calibrate_stereo,
    coverage_of,
    detect_board,
    detect_pair,
    draw_detection,
    match_views,
    parse_board,
    pose_params,
    read_session_board,
    rectified_preview,
    suggest_board,
)

BOARD = ChessboardSpec(9, 6, 0.025)
CHARUCO = CharucoSpec(7, 5, 0.04, 0.03, "DICT_4X4_50")


def assert_close_rel(value, truth, rel, what):
    """Relative comparison that prints both values."""
    err = abs(value / truth - 1.0)
    assert err <= rel, f"{what}: got {value:.6g}, truth {truth:.6g} ({err * 100:.3f} % > {rel * 100:g} %)"


@pytest.fixture(scope="module")
def rig():
    return default_rig(distortion=True)


@pytest.fixture(scope="module")
def chess_set(rig):
    pairs = render_set(BOARD, rig, 20, seed=1)
    return pairs, [detect_pair(p.left, p.right, BOARD) for p in pairs]


@pytest.fixture(scope="module")
def chess_report(chess_set):
    return calibrate_stereo(chess_set[1], board=BOARD)


@pytest.fixture(scope="module")
def charuco_set(rig):
    pairs = render_set(CHARUCO, rig, 14, seed=5, partial=3, distance_m=(0.4, 0.8))
    return pairs, [detect_pair(p.left, p.right, CHARUCO) for p in pairs]


@pytest.fixture(scope="module")
def cheap_set():
    rig = default_rig(distortion=True, size=(320, 240))
    pairs = render_set(BOARD, rig, 22, seed=3, options=CHEAP_WEBCAM, partial=3)
    return rig, pairs, [detect_pair(p.left, p.right, BOARD) for p in pairs]


# ---------------------------------------------------------------------------------------------
# boards


def test_board_forms_parse_into_specs():
    assert parse_board("chessboard:9x6", 0.025) == ChessboardSpec(9, 6, 0.025)
    ch = parse_board("charuco:5x7:0.022:dict_4x4_50", 0.03)
    assert (ch.squares_x, ch.squares_y, ch.marker_m, ch.dictionary, ch.legacy) == (5, 7, 0.022, "DICT_4X4_50", False)
    assert parse_board("charuco:5x7:0.022:DICT_4X4_50:legacy", 0.03).legacy
    assert parse_board(BOARD.text(), BOARD.square_m) == BOARD


@pytest.mark.parametrize("text, square, expected", [
    ("chess:9x6", 0.025, "unknown board 'chess:9x6'; valid: chessboard:COLSxROWS"),
    ("chessboard:9by6", 0.025, "is not COLSxROWS"),
    ("chessboard:9x6", 25, "give metres"),
    ("chessboard:2x6", 0.025, "need 3 … 40"),
    ("charuco:5x7:0.04:DICT_4X4_50", 0.03, "must be smaller than the square"),
    ("charuco:5x7:0.02:DICT_9X9_1", 0.03, "unknown ArUco dictionary 'DICT_9X9_1'"),
    ("charuco:20x20:0.02:DICT_4X4_50", 0.03, "has only 50"),
])
def test_bad_boards_are_refused_naming_the_problem(text, square, expected):
    with pytest.raises(BoardError, match=expected.replace("(", r"\(").replace(")", r"\)")):
        parse_board(text, square)


# ---------------------------------------------------------------------------------------------
# detection


def test_detected_chessboard_corners_land_on_the_projected_truth(rig, chess_set):
    pairs, dets = chess_set
    errors = []
    for p, d in zip(pairs, dets):
        assert d.ok, d.reason
        for side, pts in (("left", d.left_points), ("right", d.right_points)):
            errors.append(np.linalg.norm(pts - project(rig, side, p.pose, d.object_points), axis=1))
    e = np.concatenate(errors)
    assert np.median(e) < 0.1 and np.percentile(e, 99) < 0.5, (np.median(e), np.percentile(e, 99))


def test_small_images_are_upscaled_and_corners_mapped_back_to_original_pixels(cheap_set):
    rig, pairs, dets = cheap_set
    errs = [np.linalg.norm(d.left_points - project(rig, "left", p.pose, d.object_points), axis=1)
            for p, d in zip(pairs, dets) if d.ok]
    assert len(errs) >= 15
    assert np.median(np.concatenate(errs)) < 0.2  # a half-pixel slip in the mapping would show here


def test_a_half_turn_between_the_views_is_undone_when_the_colours_cannot_tell(rig):
    board = ChessboardSpec(7, 5, 0.025)  # 8x6 squares: the same pattern after a half turn
    p = render_set(board, rig, 1, seed=2)[0]
    d = detect_pair(p.left, p.right, board)
    flipped = BoardDetection(True, d.right.corners[::-1].copy(), d.right.ids, image_size=d.right.image_size)
    again = match_views(d.left, flipped, board)
    np.testing.assert_allclose(again.right_points, d.right_points)


def test_the_squares_colours_keep_the_first_corner_of_a_turned_view(chess_set):
    pairs, dets = chess_set
    turned = detect_board(cv2.rotate(pairs[0].right, cv2.ROTATE_180), BOARD)
    w, h = turned.image_size
    back = np.column_stack([w - 1 - turned.corners[:, 0], h - 1 - turned.corners[:, 1]])
    np.testing.assert_allclose(back, dets[0].right_points, atol=0.05)


def test_charuco_partial_views_pair_corners_by_id(charuco_set):
    pairs, dets = charuco_set
    partial_ok = [d for p, d in zip(pairs, dets) if p.partial and d.ok]
    assert partial_ok, "a partly visible ChArUco board should still give a usable pair"
    for d in dets:
        if d.ok:
            assert set(d.ids) <= set(d.left.ids) & set(d.right.ids)
            assert len(d.ids) < CHARUCO.n_corners or d.left.n == d.right.n == CHARUCO.n_corners
    assert any(d.ok and len(d.ids) < CHARUCO.n_corners for d in dets)


def test_no_board_says_why():
    dark = np.full((240, 320, 3), 10, np.uint8)
    d = detect_board(dark, BOARD)
    assert not d.ok and "too dark" in d.reason
    flat = np.full((240, 320, 3), 128, np.uint8)
    pair = detect_pair(flat, flat, BOARD)
    assert not pair.ok and pair.reason.startswith("left: board not found") and "right:" in pair.reason


def test_a_board_cut_by_the_image_border_is_reported_as_partly_out_of_view(cheap_set):
    _, pairs, dets = cheap_set
    partial = [d for p, d in zip(pairs, dets) if p.partial]
    assert partial and not any(d.ok for d in partial)
    assert any("partly out of the image" in d.reason for d in partial), [d.reason for d in partial]


def test_counting_squares_instead_of_corners_gets_a_hint(chess_set):
    left = chess_set[0][0].left
    wrong = ChessboardSpec(10, 7, 0.025)
    assert not detect_board(left, wrong).ok
    assert "chessboard:9x6" in suggest_board([left], wrong)


def test_aruco_markers_under_a_chessboard_description_get_a_hint(charuco_set):
    hint = suggest_board([charuco_set[0][1].left], BOARD)
    assert hint and "DICT_4X4_50" in hint and "charuco" in hint


def test_draw_detection_marks_corners_without_touching_the_input(chess_set):
    p, d = chess_set[0][0], chess_set[1][0]
    before = p.left.copy()
    out = draw_detection(p.left, d.left, BOARD)
    assert out.shape == p.left.shape and np.any(out != p.left)
    np.testing.assert_array_equal(p.left, before)


# ---------------------------------------------------------------------------------------------
# calibration accuracy


def test_chessboard_calibration_matches_the_true_rig(rig, chess_report):
    r = chess_report
    c = r.calibration
    assert r.pairs_used >= 18
    assert_close_rel(c.M1[0, 0], rig.K1[0, 0], 0.01, "fx left")
    assert_close_rel(c.M2[1, 1], rig.K2[1, 1], 0.01, "fy right")
    assert_close_rel(c.baseline_m, rig.baseline_m, 0.01, "baseline")
    assert r.rms_stereo <= 0.3 and r.rms_left <= 0.3 and r.rms_right <= 0.3
    assert r.epipolar_error_px <= 0.3
    assert c.D1[0, 0] == pytest.approx(rig.D1[0], abs=0.01)  # k1 of the barrel distortion
    R_err = cv2.Rodrigues(c.R @ rig.R.T)[0]
    assert np.degrees(np.linalg.norm(R_err)) < 0.1


def test_charuco_calibration_with_partial_boards_matches_the_true_rig(rig, charuco_set):
    r = calibrate_stereo(charuco_set[1], board=CHARUCO)
    assert_close_rel(r.calibration.M1[0, 0], rig.K1[0, 0], 0.01, "fx left")
    assert_close_rel(r.calibration.baseline_m, rig.baseline_m, 0.01, "baseline")
    assert r.rms_stereo <= 0.3


def test_cheap_webcam_pictures_calibrate_and_bad_pairs_are_rejected_with_reasons(cheap_set):
    rig, pairs, dets = cheap_set
    r = calibrate_stereo(dets, board=BOARD)
    assert_close_rel(r.calibration.M1[0, 0], rig.K1[0, 0], 0.01, "fx left (320x240)")
    assert_close_rel(r.calibration.baseline_m, rig.baseline_m, 0.01, "baseline (320x240)")
    assert r.rms_stereo <= 0.3
    rejected = {p.index: p.reason for p in r.rejected}
    partial = [k for k, p in enumerate(pairs) if p.partial]
    assert set(partial) <= set(rejected)
    assert all(rejected[k] for k in rejected)


def test_an_outlier_pair_is_rejected_and_the_rest_recalibrated(chess_set):
    dets = list(chess_set[1])
    d = dets[3]
    rng = np.random.default_rng(0)
    noisy = d.right_points + rng.normal(0, 2.0, d.right_points.shape).astype(np.float32)
    dets[3] = PairDetection(d.left, d.right, d.object_points, d.left_points, noisy, d.ids)
    r = calibrate_stereo(dets, board=BOARD)
    bad = r.pairs[3]
    assert not bad.used and bad.reason.startswith("outlier: reprojection error")
    assert r.rms_stereo <= 0.3 and any("recalibrated" in n for n in r.notes)
    assert r.worst(1) != [3]


def test_few_pairs_limit_the_distortion_terms(chess_set):
    r = calibrate_stereo(chess_set[1][:5], board=BOARD)
    assert r.distortion_model == "k1"
    assert np.allclose(r.calibration.D1[0, 1:], 0)
    assert any("distortion limited" in n for n in r.notes)


def test_too_few_usable_pairs_fail_with_the_reasons(chess_set):
    flat = np.full((480, 640, 3), 128, np.uint8)
    dets = list(chess_set[1][:2]) + [detect_pair(flat, flat, BOARD)] * 3
    with pytest.raises(CalibrationFailed, match="only 2 of 5 pairs show the board") as info:
        calibrate_stereo(dets)
    assert [p.used for p in info.value.pairs] == [False] * 5
    assert info.value.pairs[2].reason.startswith("left: board not found")


def test_swapped_cameras_are_noticed(chess_set):
    swapped = [PairDetection(d.right, d.left, d.object_points, d.right_points, d.left_points, d.ids)
               for d in chess_set[1][:10]]
    r = calibrate_stereo(swapped, board=BOARD)
    assert not r.ok and any("--swap" in p for p in r.problems), r.problems


def test_progress_is_reported_up_to_done(chess_set):
    seen = []
    calibrate_stereo(chess_set[1][:8], progress=lambda f, m: seen.append((f, m)))
    fractions = [f for f, _ in seen]
    assert fractions == sorted(fractions) and fractions[-1] == 1.0 and seen[-1][1] == "done"


def test_the_report_summary_has_every_cli_field(chess_report):
    s = chess_report.summary("x.yaml")
    for key in ("pairs_total", "pairs_used", "pairs_rejected", "rms_left", "rms_right", "rms_stereo",
                "epipolar_error_px", "baseline_m", "fx_left", "fy_left", "out"):
        assert key in s, key
    assert s["out"] == "x.yaml" and s["pairs_total"] == 20


def test_a_calibrated_result_survives_the_file_round_trip(tmp_path, chess_report):
    c = chess_report.calibration
    path = save_calibration(tmp_path / "c.yaml", c, extra={"rms_left": chess_report.rms_left, "board": "chessboard:9x6"})
    back = load_calibration(path, expected_size=c.image_size)
    for key in ("M1", "D1", "M2", "D2", "R", "T", "Q"):
        np.testing.assert_allclose(getattr(back, key), getattr(c, key), rtol=1e-9, atol=1e-12, err_msg=key)
    assert back.rms_stereo == pytest.approx(c.rms_stereo)
    assert back.epipolar_error_px == pytest.approx(c.epipolar_error_px)


def test_ros_camera_info_export_holds_k_d_r_p(tmp_path, chess_report):
    c = chess_report.calibration
    left, right = export_ros_camera_info(c, tmp_path / "ros")
    text = right.read_text()
    assert "camera_name: right" in text and "distortion_model: plumb_bob" in text
    blocks = {}
    for line in text.splitlines():
        if line.endswith(":") and not line.startswith(" "):
            current = line[:-1]
        elif line.strip().startswith("data:"):
            blocks[current] = np.array([float(v) for v in line.split("[")[1].rstrip("]").split(",")])
    np.testing.assert_allclose(blocks["camera_matrix"], c.M2.ravel(), rtol=1e-8)
    np.testing.assert_allclose(blocks["projection_matrix"], c.P2.ravel(), rtol=1e-8, atol=1e-8)
    tx = blocks["projection_matrix"][3]
    assert tx == pytest.approx(-c.P2[0, 0] * c.baseline_m, rel=0.01)  # ROS: Tx = -fx' * B
    assert "camera_name: left" in left.read_text()


def test_rectified_preview_puts_corners_on_the_same_rows(chess_set, chess_report):
    p = chess_set[0][2]
    out = rectified_preview(p.left, p.right, chess_report.calibration)
    h, w = p.left.shape[:2]
    assert out.shape == (h, 2 * w, 3)
    plain = rectified_preview(p.left, p.right, chess_report.calibration, line_every_px=10_000)
    dl = detect_board(plain[:, :w], BOARD)
    dr = detect_board(plain[:, w:], BOARD)
    assert dl.ok and dr.ok
    dy = np.abs(dl.corners[:, 1] - dr.corners[:, 1])
    assert np.median(dy) < 0.3


# ---------------------------------------------------------------------------------------------
# wizard core: pose parameters, gating, coverage, session


def _det(p, board=BOARD):
    return detect_pair(p.left, p.right, board)


def test_pose_params_follow_the_board(rig):
    poses = random_poses(BOARD, rig, 1, seed=2)
    base = poses[0]
    shifted = type(base)(base.R, base.t + np.array([0.05, 0.0, 0.0]))
    a = pose_params(_det(_render(rig, base)).left, BOARD)
    b = pose_params(_det(_render(rig, shifted)).left, BOARD)
    for v in a.as_tuple() + b.as_tuple():
        assert 0.0 <= v <= 1.0
    assert b.x > a.x + 0.05 and b.y == pytest.approx(a.y, abs=0.05)


def _render(rig, pose):
    from core.sim.board_render import RenderedPair

    left, right = render_pair(BOARD, rig, pose)
    return RenderedPair(left, right, pose, False)


def test_gate_needs_both_views_a_still_board_sync_and_a_new_pose(chess_set):
    pairs, dets = chess_set
    session = CalibrationSession(BOARD)
    d0 = dets[0]
    assert session.gate(d0, previous=d0).accepted
    assert "hold the board still" in session.gate(d0).reason  # no previous frame to compare with
    assert "out of sync" in session.gate(d0, skew_s=0.05, previous=d0).reason
    no_right = PairDetection(d0.left, BoardDetection(False, reason="board not found"), reasons=("right: x",))
    assert "right camera does not see" in session.gate(no_right, previous=d0).reason
    moved = BoardDetection(True, d0.left.corners + 6.0, d0.left.ids, image_size=d0.left.image_size)
    moving = PairDetection(moved, d0.right, d0.object_points, moved.corners, d0.right_points, d0.ids)
    g = session.gate(moving, previous=d0)
    assert not g.accepted and "board moving" in g.reason and g.motion_px == pytest.approx(6 * math.sqrt(2), rel=1e-3)
    session.add(pairs[0].left, pairs[0].right)
    g = session.gate(d0, previous=d0)
    assert not g.accepted and "too close to capture #1" in g.reason
    assert session.gate(d0, previous=None, manual=True).accepted  # the snapshot button


def test_coverage_grows_with_varied_poses_and_not_with_repeats(chess_set):
    dets = chess_set[1]
    params = [pose_params(d.left, BOARD) for d in dets]
    one = coverage_of(params[:1])
    same = coverage_of(params[:1] * 5)
    many = coverage_of(params)
    assert same.as_dict() == one.as_dict()
    for k in ("x", "y", "size", "skew"):
        assert many.as_dict()[k] >= one.as_dict()[k]
        assert 0.0 <= many.as_dict()[k] <= 1.0
    assert many.x > 0.5 and many.y > 0.5 and many.count == 20


def test_the_gate_reports_how_much_each_meter_would_grow(chess_set):
    dets = chess_set[1]
    session = CalibrationSession(BOARD)
    session.add(chess_set[0][0].left, chess_set[0][0].right)
    g = session.gate(dets[5], previous=dets[5])
    assert set(g.coverage_gain) == {"x", "y", "size", "skew"} and sum(g.coverage_gain.values()) > 0


def test_session_saves_pairs_calibrates_and_drops_the_worst(tmp_path, chess_set):
    pairs = chess_set[0][:12]
    session = CalibrationSession(BOARD, folder=tmp_path / "s")
    for p in pairs:
        session.add(p.left, p.right)
    assert sorted(f.name for f in (tmp_path / "s").glob("left_*.png"))[0] == "left_0001.png"
    assert read_session_board(tmp_path / "s") == BOARD
    report = session.calibrate()
    assert report.pairs_used == 12 and session.last_report is report
    worst = report.worst(2)
    session.remove(worst)
    assert len(session.pairs) == 10
    assert len(list((tmp_path / "s" / "removed").glob("*.png"))) == 4
    again = session.calibrate()
    assert again.pairs_total == 10 and again.rms_stereo <= report.rms_stereo + 1e-9
    resumed = CalibrationSession.from_folder(tmp_path / "s")
    assert len(resumed.pairs) == 10 and resumed.board == BOARD
    left, right = resumed.pairs[0].images()
    assert left.shape == pairs[0].left.shape
    with pytest.raises(ValueError, match="not captured"):
        session.add(np.full_like(left, 128), np.full_like(right, 128))


def test_a_wizard_loop_on_a_rendered_camera_captures_each_pose_once(rig):
    cam = RenderedBoardCamera(BOARD, rig, n_poses=6, hold_frames=3, clock=SimClock(), seed=11, loop=False)
    session = CalibrationSession(BOARD, gate_params=GateParams(min_novelty=0.05))
    previous = None
    with cam:
        while (frame := cam.read()) is not None:
            det = session.detect(frame.left, frame.right, fast=True)
            if session.gate(det, frame.skew_s, previous).accepted:
                session.add(frame.left, frame.right)
            previous = det
    assert len(session.pairs) == 6
    cov = session.coverage()
    assert cov.count == 6 and cov.x > 0 and cov.size > 0
    assert board_motion_px(session.pairs[0].detection.left, session.pairs[0].detection.left) == 0.0


def test_the_calibration_options_are_validated():
    with pytest.raises(ValueError, match="distortion model 'k9'"):
        CalibrationOptions(distortion="k9")
    with pytest.raises(ValueError, match="min_pairs"):
        CalibrationOptions(min_pairs=1)
    with pytest.raises(ValueError, match="max_skew_s"):
        GateParams(max_skew_s=-1)
