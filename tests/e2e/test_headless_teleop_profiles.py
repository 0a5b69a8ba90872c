"""Teleop works on every robot profile the project ships: `deskarm --headless --scenario teleop
--robot NAME` calibrates, follows the hand, holds while it is covered and ends on the end gesture.

Before, on the delta the arm reaching for the common target box stood between the cameras and the
hand: after calibrating it said "hand lost — holding" for the rest of the run (0 tracking samples
in 24 s) and never saw the end gesture."""
import io
import json
import math

import pytest

from app.headless import run_headless
from core.kinematics.profile import list_profiles
from core.session import SessionOptions


@pytest.mark.parametrize("robot", list_profiles())
def test_teleop_calibrates_follows_and_ends_on_every_profile(robot):
    out, err = io.StringIO(), io.StringIO()
    options = SessionOptions(camera="sim", scenario="teleop", robot=robot, simulated_clock=True)
    assert run_headless(options, 24.0, True, out=out, err=err) == 0, err.getvalue()
    s = json.loads(out.getvalue())
    events = {e["event"]: e for e in s["gesture_events"]}
    assert {"calibrate", "end"} <= set(events), (robot, s["gesture_events"], s["teleop_state_s"])
    for name in ("calibrate", "end"):
        assert abs(events[name]["t_detected"] - events[name]["t_true"]) <= 0.5, (robot, events[name])
    assert s["teleop_tracking_samples"] > 300, (robot, s["teleop_state_s"])  # ~13 s of following at 50 Hz
    assert math.isfinite(s["teleop_tracking_mm_p50"]) and s["teleop_tracking_mm_p50"] <= 5.0, robot
    assert s["teleop_state_s"]["following"] > 10.0 and s["teleop_state_s"]["ended"] > 1.0, robot
    assert s["teleop_hold_command_mm_max"] == 0.0 and s["teleop_valid_goals_after_end"] == 0, robot
    assert s["limit_violations"] == 0 and s["unreachable_commands"] == 0, robot
