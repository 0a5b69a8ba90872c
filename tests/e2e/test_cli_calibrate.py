"""`deskarm calibrate` on rendered picture sets: JSON summary, files written, clear errors."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

from app.cli import main
from core.paths import user_dir
from core.session import load_session_calibration
from core.sim.board_render import CHEAP_WEBCAM, default_rig, render_set, write_pairs
from core.vision.calibration import load_calibration
from core.vision.stereo_calibration import (
    CalibrationSession,
    CharucoSpec,
    ChessboardSpec,
)

ROOT = Path(__file__).resolve().parents[2]
BOARD = ChessboardSpec(9, 6, 0.025)
JSON_KEYS = ("pairs_total", "pairs_used", "pairs_rejected", "rms_left", "rms_right", "rms_stereo",
             "epipolar_error_px", "baseline_m", "fx_left", "fy_left", "out")


@pytest.fixture(scope="module")
def good_dir(tmp_path_factory):
    folder = tmp_path_factory.mktemp("good")
    write_pairs(folder, render_set(BOARD, default_rig(distortion=True), 14, seed=21))
    return folder


@pytest.fixture(scope="module")
def cheap_dir(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cheap")
    pairs = render_set(BOARD, default_rig(distortion=True, size=(320, 240)), 18, seed=3, options=CHEAP_WEBCAM, partial=3)
    write_pairs(folder, pairs, fmt="jpg", layout="split")
    return folder


def run_cli(capsys, *argv):
    code = main(["calibrate", *map(str, argv)])
    out, err = capsys.readouterr()
    return code, out, err


def last_json(out: str) -> dict:
    return json.loads(out.strip().splitlines()[-1])


def test_rendered_pairs_calibrate_and_end_with_the_json_summary(capsys, good_dir, tmp_path):
    rig = default_rig(distortion=True)
    installed = user_dir("config") / "calibration.yaml"
    before = installed.stat().st_mtime_ns if installed.exists() else None
    code, out, err = run_cli(capsys, "--left", f"{good_dir}/left_*.png", "--right", f"{good_dir}/right_*.png",
                             "--board", "chessboard:9x6", "--square", "0.025", "--out", tmp_path / "c.yaml",
                             "--export-ros", tmp_path / "ros", "--json")
    assert code == 0, err
    s = last_json(out)
    for key in JSON_KEYS:
        assert key in s, key
    assert s["pairs_total"] == 14 and s["pairs_used"] >= 13
    assert s["rms_stereo"] <= 0.3
    assert abs(s["fx_left"] / rig.K1[0, 0] - 1) < 0.01
    assert abs(s["baseline_m"] / rig.baseline_m - 1) < 0.01
    assert s["out"] == str(tmp_path / "c.yaml")
    calib = load_calibration(tmp_path / "c.yaml", expected_size=(640, 480))
    assert calib.rms_stereo == pytest.approx(s["rms_stereo"], abs=1e-3)
    assert (tmp_path / "ros" / "left.yaml").is_file() and (tmp_path / "ros" / "right.yaml").is_file()
    assert "[  1/14] left_001.png + right_001.png: ok" in out
    after = installed.stat().st_mtime_ns if installed.exists() else None
    assert after == before  # --out alone leaves the app's calibration alone


def test_without_out_the_result_is_installed_where_the_app_loads_it(capsys, good_dir):
    installed = user_dir("config") / "calibration.yaml"
    installed.unlink(missing_ok=True)
    argv = ["--folder", good_dir, "--board", "chessboard:9x6", "--square", "0.025", "--quiet", "--json"]
    code, out, _ = run_cli(capsys, *argv)
    assert code == 0 and last_json(out)["out"] == str(installed)
    code, out, _ = run_cli(capsys, *argv)  # again: the previous one is kept
    assert code == 0 and (installed.parent / "calibration.previous.yaml").is_file()

    class RealCameras:  # a source without its own calibration, like webcams
        def calibration(self):
            return None

    calib, banner = load_session_calibration(RealCameras(), None)
    assert banner == "" and calib.source == str(installed)


def test_cheap_webcam_pictures_calibrate_and_say_why_pairs_were_rejected(capsys, cheap_dir, tmp_path):
    code, out, err = run_cli(capsys, "--left", f"{cheap_dir}/left/*.jpg", "--right", f"{cheap_dir}/right/*.jpg",
                             "--board", "chessboard:9x6", "--square", "0.025", "--out", tmp_path / "c.yaml", "--json")
    assert code == 0, err
    s = last_json(out)
    assert s["image_width"] == 320 and s["pairs_total"] == 18
    assert s["pairs_rejected"] >= 3 and s["pairs_used"] >= 12
    assert s["rms_stereo"] <= 0.3
    reasons = [r["reason"] for r in s["rejected"]]
    assert sum("partly out of the image" in r for r in reasons) >= 2, reasons
    assert "rejected 016.jpg:" in out or "rejected 018.jpg:" in out  # the human summary names them too


def test_charuco_board_via_the_cli(capsys, tmp_path):
    board = CharucoSpec(7, 5, 0.04, 0.03, "DICT_4X4_50")
    write_pairs(tmp_path / "ch", render_set(board, default_rig(), 10, seed=8, distance_m=(0.4, 0.7)))
    code, out, err = run_cli(capsys, "--folder", tmp_path / "ch", "--board", "charuco:7x5:0.03:DICT_4X4_50",
                             "--square", "0.04", "--no-save", "--json", "--quiet")
    assert code == 0, err
    s = last_json(out)
    assert s["pairs_used"] >= 8 and s["out"] is None and abs(s["baseline_m"] - 0.06) < 0.0006


def test_a_wizard_session_folder_names_its_own_board(capsys, good_dir, tmp_path):
    import cv2

    session = CalibrationSession(BOARD, folder=tmp_path / "session")
    for k in range(1, 9):
        session.add(cv2.imread(str(good_dir / f"left_{k:03d}.png")), cv2.imread(str(good_dir / f"right_{k:03d}.png")))
    code, out, err = run_cli(capsys, "--folder", tmp_path / "session", "--no-save", "--json", "--quiet")
    assert code == 0, err
    assert last_json(out)["pairs_used"] == 8 and last_json(out)["board"] == "chessboard:9x6"


def test_too_few_usable_pairs_exit_1_with_a_hint(capsys, good_dir):
    code, out, err = run_cli(capsys, "--folder", good_dir, "--board", "chessboard:10x7", "--square", "0.025",
                             "--no-save", "--json", "--quiet")
    assert code == 1
    assert "the first 4 pairs show no chessboard 10x7" in err and "use --board chessboard:9x6" in err
    s = last_json(out)
    assert s["error"] and s["pairs_used"] == 0 and len(s["rejected"]) == 4
    assert "has 9x6 inner corners, not 10x7" in s["rejected"][0]["reason"]


def test_too_few_usable_pairs_exit_1_naming_the_reasons(capsys, good_dir, tmp_path):
    import shutil

    for k in (1, 2, 3):
        for side in ("left", "right"):
            shutil.copy(good_dir / f"{side}_{k:03d}.png", tmp_path / f"{side}_{k:03d}.png")
    code, out, err = run_cli(capsys, "--folder", tmp_path, "--board", "chessboard:9x6", "--square", "0.025",
                             "--no-save", "--json", "--quiet")
    assert code == 1 and "only 3 of 3 pairs show the board in both views (need at least 4)" in err
    assert last_json(out)["pairs_used"] == 0


@pytest.mark.parametrize("argv, expected", [
    (["--left", "nope/*.png", "--right", "nope/*.png", "--board", "chessboard:9x6", "--square", "0.025"],
     "--left 'nope/*.png' matches no image files"),
    (["--left", "a", "--right", "b", "--board", "chessboard:9", "--square", "0.025"], "is not COLSxROWS"),
    (["--left", "a", "--right", "b", "--board", "chessboard:9x6", "--square", "25"], "give metres"),
    (["--left", "a", "--right", "b", "--board", "chessboard:9x6"], "give --square METRES"),
    (["--board", "chessboard:9x6", "--square", "0.025"], "give --left GLOB and --right GLOB"),
    (["--folder", "x", "--install", "--board", "chessboard:9x6", "--square", "0.025"], "--install goes with --out"),
])
def test_bad_arguments_give_one_clear_line_and_exit_2(capsys, argv, expected):
    code, _, err = run_cli(capsys, *argv)
    assert code == 2
    assert expected in err and err.count("\n") == 1, err


def test_help_runs_from_a_fresh_process():
    r = subprocess.run([sys.executable, "-m", "app.cli", "calibrate", "--help"], cwd=ROOT,
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and "--export-ros" in r.stdout and "charuco:" in r.stdout
