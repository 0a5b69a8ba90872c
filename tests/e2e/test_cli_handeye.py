"""`deskarm calibrate-hand-eye` end to end on the simulated desk (simulated clock)."""
import json

from app.cli import main


def test_calibrates_an_offset_rig_saves_and_reports_errors_vs_the_truth(tmp_path, capsys):
    out = tmp_path / "he.toml"
    code = main(["calibrate-hand-eye", "--camera", "sim", "--fast", "--json", "--rig-offset",
                 "0.03,-0.02,0.01,3,-2,4", "--out", str(out)])
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert code == 0 and report["ok"] and report["out"] == str(out) and out.is_file()
    assert report["poses_used"] >= 8 and report["residual_mm_rms"] < 2.0 and report["residual_mm_max"] < 5.0
    assert report["translation_error_mm"] < 2.0 and report["rotation_error_deg"] < 0.3
    assert isinstance(report["warnings"], list)


def test_too_few_poses_exit_1_and_save_nothing(tmp_path, capsys):
    out = tmp_path / "he.toml"
    code = main(["calibrate-hand-eye", "--camera", "sim", "--fast", "--poses", "3", "--out", str(out)])
    text = capsys.readouterr().out
    assert code == 1 and not out.exists()
    assert "NOT calibrated" in text and "need at least 4" in text and "nothing saved" in text


def test_bad_arguments_exit_2(capsys):
    assert main(["calibrate-hand-eye", "--camera", "sim", "--rig-offset", "1,2,3"]) == 2
    assert "--rig-offset" in capsys.readouterr().err
    assert main(["calibrate-hand-eye", "--camera", "sim", "--rig-offset", "0.5,0,0,0,0,0"]) == 2
    assert main(["calibrate-hand-eye", "--poses", "0"]) == 2
    assert main(["calibrate-hand-eye", "--nonsense"]) == 2


def test_headless_uses_the_nominal_mount_until_given_the_file(tmp_path, capsys):
    offset = "-0.03,0.02,0.01,-2,3,3"  # the perceived targets stay within reach
    out = tmp_path / "he.toml"
    # a value starting with "-" needs the --rig-offset=… form (argparse)
    assert main(["calibrate-hand-eye", "--camera", "sim", "--fast", "--json", f"--rig-offset={offset}",
                 "--out", str(out)]) == 0
    capsys.readouterr()
    runs = {}
    for name, extra in (("before", []), ("after", ["--hand-eye", str(out)])):
        assert main(["--headless", "--fast", "--json", "--camera", "sim", "--scenario", "static", "--duration", "6",
                     f"--rig-offset={offset}", *extra]) == 0
        runs[name] = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert runs["before"]["error_3d_mm_p50"] > 20 and runs["after"]["error_3d_mm_p50"] < 2.0
    assert runs["before"]["reach_error_true_mm_p50"] > 20 and runs["after"]["reach_error_true_mm_p50"] < 3.0
