"""``deskarm assist-trials`` end to end: a few trials of the whole loop on the simulated desk."""
import json

from app.cli_assist import run, run_trials


def test_a_few_trials_run_the_whole_loop_and_report_every_metric():
    summary, results = run_trials(2, "scan1", seed=3)
    assert summary["trials"] == 2
    for key in ("success_rate", "final_distance_mm_mean", "time_to_target_s_mean", "time_to_target_s_p95",
                "selections_wrong"):
        assert key in summary
    assert all(r.events and r.events[0]["to"] == "ALIGN" for r in results if r.selected_ok)
    assert summary["detector"] == "circles"


def test_cli_json_output(capsys):
    assert run("assist-trials", ["--n", "1", "--mode", "touch", "--json", "--seed", "5"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["mode"] == "touch" and out["trials"] == 1


def test_cli_rejects_a_bad_scan_period(capsys):
    assert run("assist-trials", ["--n", "1", "--scan-period", "9"]) == 2
    assert "scan-period" in capsys.readouterr().err


def test_depth_from_the_range_sensor_runs_the_loop_too():
    summary, results = run_trials(1, "touch", seed=2, depth_source="range")
    assert summary["depth"] == "range" and len(results) == 1 and results[0].events


def test_the_learned_desk_detector_runs_the_trials_and_presses_the_wanted_button(capsys):
    assert run("assist-trials", ["--n", "2", "--detector", "desk", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["detector"] == "desk" and out["trials"] == 2
    # success = the chosen button itself went down, the tool tip within 3 mm of its centre
    assert out["success_rate"] == 1.0 and out["wrong_button_pressed"] == 0 and out["selections_wrong"] == 0, out
    assert out["detect_ms_per_call"] > 0 and out["depth_error_pct_median"] is not None


def test_cli_rejects_an_unknown_detector(capsys):
    try:
        code = run("assist-trials", ["--n", "1", "--detector", "yolo"])
    except SystemExit as exc:  # argparse's own error
        code = exc.code
    assert code == 2 and "--detector" in capsys.readouterr().err
