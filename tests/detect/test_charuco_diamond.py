"""``deskarm detect`` finds ChArUco boards and diamonds (detector kinds ``charuco`` and ``diamond``).

The photos are real (``tests/data/stereo_7x5_320x240``, two cheap webcams) with a ChArUco
pattern laid on the real chessboard's plane (``tests/data/charuco/make_composites.py``); the
plain chessboard photos are the negatives.
"""
from __future__ import annotations

import json
from pathlib import Path

import cv2
import pytest

from app.cli import main
from core.detect.registry import make_detector
from core.settings import SettingsError

DATA = Path(__file__).resolve().parents[1] / "data"
BOARD_PHOTOS = ("charuco_8x6_legacy_left01.jpg", "charuco_8x6_legacy_left05.jpg")
DIAMOND_PHOTO = DATA / "charuco" / "diamond_5_6_7_8_left03.jpg"


def _detect_json(capsys, argv) -> dict:
    assert main(["detect", *argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


@pytest.mark.parametrize("photo", BOARD_PHOTOS)
def test_detect_finds_the_charuco_board_on_a_real_photo(photo, capsys):
    out = _detect_json(capsys, [str(DATA / "charuco" / photo), "--detector", "charuco", "--board", "8x6",
                                "--legacy", "--dictionary", "DICT_4X4_50"])
    boards = out["images"][0]["detections"]
    assert len(boards) == 1, boards
    board = boards[0]
    assert board["kind"] == "board" and board["label"] == "8x6"
    assert len(board["points"]) == len(board["point_ids"]) >= 28  # of 7x5 = 35 inner corners
    assert board["score"] == pytest.approx(len(board["points"]) / 35, abs=1e-3)
    assert set(board["point_ids"]) <= set(range(35))


def test_the_charuco_corners_lie_on_the_real_chessboard_corners():
    photo = cv2.imread(str(DATA / "charuco" / BOARD_PHOTOS[0]))
    original = cv2.imread(str(DATA / "stereo_7x5_320x240" / "left01.jpg"), cv2.IMREAD_GRAYSCALE)
    found, chess = cv2.findChessboardCorners(original, (7, 5))
    assert found
    chess = chess.reshape(-1, 2)
    [board] = make_detector("charuco", squares_x=8, squares_y=6, legacy=True).detect(photo)
    # every ChArUco corner is one of the real board's inner corners (sub-pixel refined on the pattern)
    for x, y in board.points:
        assert min(((chess[:, 0] - x) ** 2 + (chess[:, 1] - y) ** 2) ** 0.5) < 1.5


def test_the_legacy_option_matters_and_a_plain_chessboard_is_no_charuco_board(capsys):
    photo = str(DATA / "charuco" / BOARD_PHOTOS[0])
    out = _detect_json(capsys, [photo, "--detector", "charuco", "--board", "8x6", "--dictionary", "DICT_4X4_50"])
    assert out["images"][0]["detections"] == []  # the pattern was drawn as OpenCV < 4.6 drew it
    plain = sorted((DATA / "stereo_7x5_320x240").glob("*.jpg"))
    assert len(plain) >= 10
    out = _detect_json(capsys, [*map(str, plain), "--detector", "charuco,diamond", "--board", "8x6"])
    assert all(image["detections"] == [] for image in out["images"])


def test_detect_finds_the_diamond_and_its_four_marker_ids(capsys):
    out = _detect_json(capsys, [str(DIAMOND_PHOTO), "--detector", "diamond", "--dictionary", "DICT_4X4_50"])
    [diamond] = out["images"][0]["detections"]
    assert diamond["kind"] == "diamond" and diamond["label"] == "5,6,7,8"
    assert len(diamond["corners"]) == 4
    x, y, w, h = diamond["box"]
    assert 15 < w < 40 and 15 < h < 40  # one chessboard square of this 320x240 photo is ~25 px
    assert main(["detect", str(DIAMOND_PHOTO), "--detector", "diamond", "--dictionary", "DICT_4X4_50"]) == 0
    assert "diamond 5,6,7,8" in capsys.readouterr().out


@pytest.mark.parametrize("argv, message", [
    (["--board", "2x5"], "charuco.squares_x = 2"),
    (["--board", "7by5"], "--board '7by5' is not COLSxROWS"),
    (["--marker", "0.04"], "must be smaller than square_m"),
    (["--board", "12x12", "--dictionary", "DICT_4X4_50"], "needs 72 markers but DICT_4X4_50 has only 50"),
])
def test_a_bad_board_option_is_one_line_and_exit_2(argv, message, capsys):
    assert main(["detect", str(DIAMOND_PHOTO), "--detector", "charuco", *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_board_settings_are_checked():
    with pytest.raises(SettingsError, match="min_corners"):
        make_detector("charuco", min_corners=0)
    with pytest.raises(SettingsError, match="square_m"):
        make_detector("diamond", square_m=float("nan"))
