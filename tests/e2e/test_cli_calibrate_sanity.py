"""``deskarm calibrate`` refuses what fails a sanity check (exit 1, nothing written) unless --force."""
import json
import shutil
from pathlib import Path

import pytest

from app.cli import main

REAL = Path(__file__).resolve().parents[1] / "data" / "stereo_7x5_320x240"
ARGS = ["--board", "chessboard:7x5", "--square", "0.025", "--json", "--quiet"]


def run_cli(capsys, *argv):
    code = main(["calibrate", *map(str, argv)])
    out, err = capsys.readouterr()
    return code, json.loads(out.strip().splitlines()[-1]), err


@pytest.fixture(scope="module")
def same_dir(tmp_path_factory):
    folder = tmp_path_factory.mktemp("same")
    for p in sorted(REAL.glob("left*.jpg")):
        shutil.copy(p, folder / p.name)
        shutil.copy(p, folder / p.name.replace("left", "right"))
    return folder


def test_real_photos_pass_every_check(capsys, tmp_path):
    code, s, err = run_cli(capsys, "--left", REAL / "left*.jpg", "--right", REAL / "right*.jpg",
                           "--out", tmp_path / "c.yaml", *ARGS)
    assert code == 0, err
    assert s["ok"] and s["problems"] == [] and not s["installed"] and (tmp_path / "c.yaml").exists()
    assert 360 < s["fx_left"] < 440 and s["pairs_used"] == s["pairs_total"]


def test_identical_images_exit_1_and_write_nothing(capsys, same_dir, tmp_path):
    code, s, err = run_cli(capsys, "--folder", same_dir, "--out", tmp_path / "c.yaml", *ARGS)
    assert code == 1 and not s["ok"] and not s["installed"] and s["out"] is None
    assert any("check the camera indices" in p for p in s["problems"])
    assert "--force" in err and not (tmp_path / "c.yaml").exists()


def test_force_writes_a_failed_calibration_anyway(capsys, same_dir, tmp_path):
    code, s, _ = run_cli(capsys, "--folder", same_dir, "--out", tmp_path / "c.yaml", "--force", *ARGS)
    assert code == 0 and s["forced"] and (tmp_path / "c.yaml").exists()


def test_swapped_globs_are_refused_and_swap_fixes_them(capsys):
    swapped = ["--left", REAL / "right*.jpg", "--right", REAL / "left*.jpg", "--no-save"]
    code, s, _ = run_cli(capsys, *swapped, *ARGS)
    assert code == 1 and any("--swap" in p for p in s["problems"])
    code, s, err = run_cli(capsys, *swapped, "--swap", *ARGS)
    assert code == 0 and s["ok"], err
