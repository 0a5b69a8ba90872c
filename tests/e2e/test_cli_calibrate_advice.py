"""``deskarm calibrate`` on real webcam photos says the mistake, not its symptoms (issue 25 items 7–11):
the board size in view (and stops early), a tray edge is no row, a mirrored camera, pictures paired
off by one, and too few pairs to install."""
import json
import shutil
from pathlib import Path

import cv2
import pytest

from app.cli import main

REAL = Path(__file__).resolve().parents[1] / "data" / "stereo_7x5_320x240"
SQUARE = ["--square", "0.025"]


def run_cli(capsys, *argv):
    code = main(["calibrate", *map(str, argv)])
    out, err = capsys.readouterr()
    return code, json.loads(out.strip().splitlines()[-1]), out, err


def pairs_folder(folder: Path, lefts, rights, transform=None) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for k, (lp, rp) in enumerate(zip(lefts, rights), start=1):
        shutil.copy(lp, folder / f"left_{k:02d}.jpg")
        if transform is None:
            shutil.copy(rp, folder / f"right_{k:02d}.jpg")
        else:
            cv2.imwrite(str(folder / f"right_{k:02d}.png"), transform(cv2.imread(str(rp))))
    return folder


LEFTS = sorted(REAL.glob("left*.jpg"))
RIGHTS = sorted(REAL.glob("right*.jpg"))


@pytest.mark.parametrize("given", ["9x6", "8x5"])
def test_a_wrong_board_size_names_the_board_in_view_and_stops_early(capsys, given):
    code, s, out, err = run_cli(capsys, "--left", REAL / "left*.jpg", "--right", REAL / "right*.jpg",
                                "--board", f"chessboard:{given}", *SQUARE, "--json", "--no-save")
    assert code == 1 and s["pairs_used"] == 0
    assert s["pairs_rejected"] < s["pairs_total"], "no early stop"  # it went through every pair before
    assert "stopped early" in err and "--board chessboard:7x5" in s["hint"], err
    assert "bring it closer" not in out


def test_a_mirrored_right_camera_is_named_as_such(capsys, tmp_path):
    folder = pairs_folder(tmp_path / "mirrored", LEFTS, RIGHTS, lambda im: cv2.flip(im, 1))
    code, s, out, err = run_cli(capsys, "--folder", folder, "--board", "chessboard:7x5", *SQUARE, "--json",
                                "--out", tmp_path / "c.yaml")
    assert code == 1 and not (tmp_path / "c.yaml").exists()
    assert len(s["problems"]) == 1 and "right camera's picture is mirrored" in s["problems"][0], s["problems"]
    assert "horizontal_flip" in s["problems"][0]
    problem_lines = [line for line in out.splitlines() if line.startswith("problem:")]
    assert len(problem_lines) == 1 and "tilt the board more" not in out.split("which also explains")[0]


def test_pictures_paired_off_by_one_are_said_before_their_consequences(capsys, tmp_path):
    folder = pairs_folder(tmp_path / "shifted", LEFTS[1:], RIGHTS[:-1])
    code, s, out, _ = run_cli(capsys, "--folder", folder, "--board", "chessboard:7x5", *SQUARE, "--json",
                              "--no-save")
    assert code == 1 and len(s["problems"]) == 1 and "paired off by one" in s["problems"][0], s["problems"]
    assert "one above the other" not in out
    lines = out.splitlines()
    problem = next(k for k, line in enumerate(lines) if line.startswith("problem:"))
    assert lines[problem + 1].startswith("  which also explains:")  # the consequences come after the cause


def test_four_pairs_are_not_installed(capsys, tmp_path):
    folder = pairs_folder(tmp_path / "four", LEFTS[:4], RIGHTS[:4])
    code, s, _, err = run_cli(capsys, "--folder", folder, "--board", "chessboard:7x5", *SQUARE, "--json",
                              "--out", tmp_path / "c.yaml")
    assert code == 1 and not s["ok"] and not (tmp_path / "c.yaml").exists()
    assert s["checks"]["fx_sigma_rel"] > 0.04, s["checks"]  # fx is 438 px against 401 px with all pairs
    assert any("only 4 pairs used" in p for p in s["problems"]) and "--force" in err
