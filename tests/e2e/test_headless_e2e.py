"""End-to-end: the headless runner drives the whole loop on the simulated desk."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

from app.cli import main
from app.headless import HeadlessRunner
from core.session import DeskSession, SessionOptions

ROOT = Path(__file__).resolve().parents[2]


def run(scenario, duration=6.0, robot="desk_rrr"):
    session = DeskSession.create(SessionOptions(camera="sim", scenario=scenario, simulated_clock=True,
                                                robot=robot))
    return HeadlessRunner(session, duration).run().summary()


def test_static_scene_is_located_in_3d_and_reached():
    s = run("static")
    assert s["frames"] >= 170  # 6 s at 30 fps on the simulated clock
    assert s["markers_seen_ratio"] > 0.98
    assert s["error_3d_mm_p95"] <= 3.0
    assert s["error_3d_mm_p50"] <= 1.0
    assert s["limit_violations"] == 0
    assert s["commands_sent"] >= 250  # 50 Hz control
    assert s["reach_error_mm_p50"] is not None and s["reach_error_mm_p50"] < 3.0


@pytest.mark.parametrize("robot", ["umi_rtx", "assistive_5dof", "delta"])
def test_every_arm_reaches_the_followed_marker_on_the_default_desk(robot):
    # the first thing a user with another arm sees: its home keeps it out of the cameras' way,
    # and its workspace covers the marker it is told to follow
    s = run("static", duration=8.0, robot=robot)
    assert s["markers_seen_ratio"] > 0.98
    assert s["limit_violations"] == 0
    assert s["unreachable_commands"] == 0
    assert s["reach_error_mm_p50"] is not None and s["reach_error_mm_p50"] < 3.0


@pytest.mark.parametrize("scenario", ["cups", "wander"])
def test_moving_scenes_keep_error_small_and_limits_safe(scenario):
    s = run(scenario, duration=8.0)
    assert s["error_3d_mm_p95"] <= 3.0
    assert s["limit_violations"] == 0
    assert s["markers_seen_ratio"] > 0.9


def test_cli_json_line_has_every_metric(capsys):
    code = main(["--headless", "--camera", "sim", "--scenario", "static", "--duration", "2", "--fast", "--json"])
    assert code == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)  # stdout is the JSON object alone
    for key in ("scenario", "frames", "fps", "perception_ms_p50", "perception_ms_p95", "latency_ms_p50",
                "latency_ms_p95", "error_3d_mm_p50", "error_3d_mm_p95", "markers_seen_ratio",
                "commands_sent", "limit_violations", "reach_error_mm_p50"):
        assert key in summary, key
    assert any(line.startswith("t=") for line in captured.err.splitlines()), "one status line per second (stderr)"


@pytest.mark.parametrize("argv, expected", [
    (["--camera", "usb-left"], "unknown --camera value 'usb-left'; valid: auto"),
    (["--bridge", "bluetooth"], "unknown --bridge value 'bluetooth'; valid: sim://"),
    (["--robot", "hal9000"], "hal9000"),
    (["--scenario", "mars"], "unknown --scenario value 'mars'; valid: static, cups, wander"),
])
def test_unknown_values_give_one_line_naming_them(argv, expected, capsys):
    assert main(argv + ["--headless", "--fast", "--duration", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert expected in err and "\n" not in err


def test_invalid_robot_profile_names_file_key_and_range(tmp_path, capsys):
    src = (ROOT / "resources" / "robots" / "desk_rrr.toml").read_text()
    bad = tmp_path / "bad_arm.toml"
    bad.write_text(src.replace("servo_max_deg = 180", "servo_max_deg = 200", 1))
    assert main(["--robot", str(bad), "--headless", "--fast", "--duration", "1"]) == 2
    err = capsys.readouterr().err
    assert "bad_arm.toml" in err and "servo_max_deg" in err and "180" in err


def test_paced_run_from_a_fresh_process_keeps_the_camera_rate():
    """The installed entry point, paced at 30 fps on the wall clock (1.5 s). How many frames a
    loaded machine perceives in that time is its speed, not the pacing: the run's own figures
    must show the wall clock's whole duration passed and no frame came faster than the camera's."""
    duration, camera_fps = 1.5, 30.0
    out = subprocess.run(
        [sys.executable, "-m", "app.cli", "--headless", "--camera", "sim", "--duration", str(duration), "--json"],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    )
    assert out.returncode == 0, out.stderr
    assert f"{duration:g} s paced at {camera_fps:g} fps" in out.stderr  # the mode it chose, said
    summary = json.loads(out.stdout.strip().splitlines()[-1])
    frames, fps = summary["frames"], summary["fps"]  # fps: frames per wall-clock second of the run
    assert frames >= 1 and summary["duration_s"] >= duration
    wall_s = frames / fps
    assert wall_s >= duration * 0.99, summary  # it waited for the camera's clock, not simulated it
    # never ahead of the camera: its frames keep a grid one period apart, so the run gets at most
    # one per period of its duration, plus one at its start, one already waiting when it began and
    # one that its last read waited for (the loop checks the duration before a read, and the read
    # may wait up to a period past it)
    assert frames <= summary["duration_s"] * camera_fps + 3, summary
    assert fps <= camera_fps + 2.0 / wall_s + 0.1, summary
    assert summary["limit_violations"] == 0


def run_with(scenario, event_driven, duration=4.0):
    session = DeskSession.create(SessionOptions(camera="sim", scenario=scenario, simulated_clock=True,
                                                event_driven=event_driven))
    runner = HeadlessRunner(session, duration)
    return runner.run().summary(), runner


@pytest.mark.parametrize("scenario", ["cups", "wander"])
def test_each_new_perception_result_is_acted_on_at_once_unless_tick_driven(scenario):
    """On the simulated clock a frame's command leaves at the frame's own instant when the
    step is event-driven; tick-driven, it waits for the next 50 Hz tick (up to 20 ms)."""
    event, _ = run_with(scenario, True)
    tick, _ = run_with(scenario, False)
    assert event["control_steps_event"] >= 0.8 * event["frames"]
    assert tick["control_steps_event"] == 0
    # the simulated clock makes the waiting exact: it is all of the tick-driven latency
    assert tick["latency_ms_p50"] > event["latency_ms_p50"] + 3.0
    for s in (event, tick):
        assert s["limit_violations"] == 0 and s["markers_seen_ratio"] > 0.9


def test_a_still_scene_is_rendered_and_perceived_once_then_reused():
    s, runner = run_with("static", True, duration=6.0)
    assert s["frames_reused"] > 0.5 * s["frames"]  # the arm settles on the marker, the desk is still
    assert s["error_3d_mm_p95"] <= 3.0 and s["reach_error_mm_p50"] is not None
    assert runner.s.camera.frames_rendered + runner.s.camera.frames_repeated == s["frames"]
