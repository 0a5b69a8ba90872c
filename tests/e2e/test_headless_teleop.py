"""End-to-end: the teleop scenario's hand (a wristband marker) calibrates, drives the arm, is lost
(the arm holds) and ends (the arm stops following), scored against the simulated desk's truth."""
import json
import math

import numpy as np
import pytest

from app.cli import main
from core.session import DeskSession, SessionOptions
from core.sim.scenarios import TeleopScenario, make_scenario


@pytest.fixture(scope="module")
def teleop_summary():
    import io

    out = io.StringIO()
    from app.headless import run_headless

    code = run_headless(SessionOptions(camera="sim", scenario="teleop", simulated_clock=True), 24.0, True, out=out)
    assert code == 0
    return json.loads(out.getvalue().strip().splitlines()[-1])


def test_gestures_are_detected_within_half_a_second_of_the_truth(teleop_summary):
    events = {e["event"]: e for e in teleop_summary["gesture_events"]}
    assert set(events) == {"corner", "calibrate", "end"}
    for name in ("calibrate", "end"):
        assert abs(events[name]["t_detected"] - events[name]["t_true"]) <= 0.5, events[name]
    assert all(c <= 2.0 for c in teleop_summary["teleop_corner_error_mm"])


def test_the_tool_tracks_the_mapped_true_hand_within_5_mm(teleop_summary):
    s = teleop_summary
    assert s["teleop_tracking_samples"] > 300  # ~13 s of following at 50 Hz, minus the settling
    assert math.isfinite(s["teleop_tracking_mm_p50"]) and s["teleop_tracking_mm_p50"] <= 5.0
    assert s["teleop_tracking_mm_p50"] <= s["teleop_tracking_mm_p95"]
    assert s["limit_violations"] == 0 and s["unreachable_commands"] == 0


def test_a_lost_hand_holds_and_the_end_gesture_stops_following(teleop_summary):
    s = teleop_summary
    assert s["teleop_hold_commands"] > 0
    assert s["teleop_hold_command_mm_max"] == 0.0  # no command moves the tool while lost or ended
    assert s["teleop_valid_goals_after_end"] == 0
    states = s["teleop_state_s"]
    assert states["holding"] >= 1.0  # the occlusion (~1.4 s) and the cover before the end (1 s)
    assert states["ended"] > 1.0 and states["following"] > 10.0


def test_the_scenario_truth_the_band_is_where_the_script_says():
    sc = make_scenario("teleop", (23, 50))
    assert isinstance(sc, TeleopScenario)
    st = sc.state(2.0)  # holding still at the first corner (tremor: a fraction of a mm)
    band = st.hands[0].band
    assert band.marker_id == 23 and np.allclose(band.centre, sc.CORNER_A, atol=5e-4)
    assert len(sc.state(12.5).hands) == 2  # the other hand over the band (the occlusion)
    assert sc.gesture_times()["end"] == pytest.approx(sc.cover_t + sc.END_COVER_S)
    # human speeds: a reach of < 0.4 m/s coming in, then at most 15 cm/s (median ~3 cm/s) while driving
    ts = np.arange(0.0, 24.0, 1 / 100)
    speed = np.linalg.norm(np.diff([sc.band_centre(t) for t in ts], axis=0), axis=1) * 100
    assert speed.max() < 0.4 and speed[ts[:-1] > sc.ENTER_S].max() < 0.15


def test_teleop_options_are_checked(capsys):
    assert main(["--headless", "--teleop", "glove:red", "--duration", "1"]) == 2
    assert "teleop source" in capsys.readouterr().err
    assert main(["--headless", "--teleop", "hsv:green", "--duration", "1"]) == 2
    assert "--detector hsv" in capsys.readouterr().err


def test_the_teleop_scenario_starts_in_teleop_mode_with_the_first_marker_as_the_band():
    session = DeskSession.create(SessionOptions(camera="sim", scenario="teleop", simulated_clock=True))
    try:
        assert session.targeter.mode.value == "teleop"
        assert session.targeter.teleop.source.name == "marker:23"
    finally:
        session.close()
