"""`deskarm ik` and `deskarm bench-ik`: joint values, success and residual; one JSON object;
clear one-line errors for bad robots, frames, URDFs and targets."""
from __future__ import annotations

import io
import json
import math
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from app.cli_kinematics import run_bench, run_ik
from core.kinematics import build_kinematics, load_profile

DATA = Path(__file__).resolve().parents[1] / "data"


def call(fn, argv):
    out, err = io.StringIO(), io.StringIO()
    try:
        code = fn(argv, out=out, err=err)
    except SystemExit as exc:  # argparse errors
        code = exc.code
    return code, out.getvalue(), err.getvalue()


def test_ik_prints_the_joints_success_and_residual_as_json():
    code, out, _ = call(run_ik, ["--robot", "desk_rrr", "--target", "0,0.15,0.1", "--json"])
    assert code == 0
    r = json.loads(out)
    assert r["success"] is True and r["robot"] == "desk_rrr" and len(r["q"]) == 3
    assert [j["name"] for j in r["joints"]] == ["base_yaw", "shoulder", "elbow"]
    kin = build_kinematics(load_profile("desk_rrr"))
    assert np.allclose(kin.fk(r["q"]), (0, 0.15, 0.1), atol=1e-9)
    assert r["residual"] <= 1e-9 and r["error_m"] <= 1e-9


def test_ik_solves_a_full_pose_on_the_umi_rtx_with_angles_in_degrees():
    code, out, _ = call(run_ik, ["--robot", "umi_rtx", "--target", "0.1,0.4,0.2,0,80,30", "--degrees", "--json"])
    r = json.loads(out)
    assert code == 0 and r["success"] and r["mode"] == "pose" and r["error_rad"] < 1e-5
    kin = build_kinematics(load_profile("umi_rtx"))
    assert np.allclose(kin.fk(r["q"]), (0.1, 0.4, 0.2), atol=1e-6)
    assert r["joints"][0]["unit"] == "m" and r["joints"][0]["display_unit"] == "mm"


def test_ik_text_output_names_every_joint_and_says_success():
    code, out, _ = call(run_ik, ["--robot", f"urdf:{DATA / 'ur5_like.urdf'}", "--target", "0.3,0.2,0.3"])
    assert code == 0 and "solved" in out and "success = true" in out and "residual" in out
    for name in ("shoulder_pan_joint", "wrist_3_joint"):
        assert name in out


def test_ik_of_an_unreachable_target_exits_1_with_the_distance():
    code, out, _ = call(run_ik, ["--robot", "umi_rtx", "--target", "0,0.3,3", "--json"])
    r = json.loads(out)
    assert code == 1 and r["success"] is False and r["message"].startswith("out of reach by")
    assert r["error_m"] == pytest.approx(3.0 - 0.948 - 0.15, abs=1e-6)


@pytest.mark.parametrize("argv, expected", [
    (["--robot", "nope", "--target", "0,0,0"], "unknown robot profile 'nope'"),
    (["--robot", f"urdf:{DATA / 'ur5_like.urdf'}", "--tip", "hand", "--target", "0,0,0"], "no frame 'hand' for --tip; valid frames:"),
    (["--robot", "desk_rrr", "--tip", "tool", "--target", "0,0,0"], "applies only to URDF profiles"),
    (["--robot", "desk_rrr", "--target", "0,0.1,0.1,0,0,0"], "solves position only"),
    (["--robot", "desk_rrr", "--target", "0,0.1"], "needs 3 values"),
    (["--robot", "desk_rrr", "--target", "a,b,c"], "must be comma-separated numbers"),
    (["--robot", "umi_rtx", "--target", "0,0.3,0.3", "--from", "0,0"], "--from has 2 values; 'umi_rtx' has 6 joints"),
])
def test_ik_errors_are_one_line_with_exit_code_2(argv, expected):
    code, out, err = call(run_ik, argv)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and expected in err, err


def test_a_malformed_urdf_is_named_in_the_error(tmp_path):
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'/>")
    code, _, err = call(run_ik, ["--robot", f"urdf:{bad}", "--target", "0,0,0"])
    assert code == 2 and str(bad) in err and "not valid XML" in err


def test_bench_ik_ends_with_one_json_object_with_every_field():
    code, out, _ = call(run_bench, ["--robot", "umi_rtx", "--mode", "pose", "--n", "30", "--seed", "2"])
    assert code == 0
    last = json.loads(out.strip().splitlines()[-1])
    assert set(last) == {"robot", "mode", "n", "success_rate", "p50_ms", "p95_ms", "p99_ms", "iterations_p50",
                         "limit_violations", "max_residual_m"}
    assert last["robot"] == "umi_rtx" and last["mode"] == "pose" and last["n"] == 30
    assert last["limit_violations"] == 0 and last["success_rate"] == 1.0 and last["max_residual_m"] <= 1e-6
    assert 0 < last["p50_ms"] <= last["p95_ms"] <= last["p99_ms"]


def test_bench_ik_json_mode_prints_only_the_object_and_defaults_to_position_for_small_arms():
    code, out, _ = call(run_bench, ["--robot", "delta", "--n", "20", "--json"])
    r = json.loads(out)
    assert code == 0 and r["mode"] == "position" and r["success_rate"] == 1.0 and r["iterations_p50"] == 0
    code, _, err = call(run_bench, ["--robot", "delta", "--mode", "pose", "--n", "5"])
    assert code == 2 and "solves position only" in err


def test_the_deskarm_entry_point_dispatches_both_commands(capsys):
    assert main(["ik", "--robot", "delta", "--target", "0,0,0.05", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["success"] is True
    assert main(["bench-ik", "--robot", "assistive_5dof", "--n", "10", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["mode"] == "position" and r["n"] == 10 and not math.isnan(r["p50_ms"])
