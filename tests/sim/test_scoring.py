"""Scoring against the simulated desk's truth (core.sim.scoring): following a marker that is often
out of reach (the wander scenario), and whether the cups game points at the cup hiding the ball.

Before, wander had no following metric (the reach error only counts once the arm settled on a
still goal: null on desk_rrr) and the cups game none for correctness."""
import io
import json
import math

import numpy as np
import pytest

from app.headless import run_headless
from core.messages import GroundTruth, ObjectTruth
from core.session import SessionOptions
from core.sim.scoring import FOLLOW_REACH_TOL_M, CupsScore, FollowScore

R = 0.2  # the toy arm reaches a ball of this radius about the origin


class BallArm:
    """A toy arm whose joint values are its tool point: FK is the identity, IK the nearest point
    of the ball of radius R."""

    def fk(self, q):
        return tuple(float(v) for v in q)

    def ik(self, p, q_hint=None):
        p = np.asarray(p, float)
        n = float(np.linalg.norm(p))
        reached = p if n <= R else p * (R / n)

        class Result:
            error_m = float(np.linalg.norm(p - reached))
            base_p_reached = tuple(reached)
        return Result()


def truth(*objects, target=None):
    return GroundTruth(objects=tuple(ObjectTruth(mid, tuple(p), vis, vis) for mid, p, vis in objects),
                       pointing_target_id=target)


def test_follow_error_is_to_the_reachable_projection_of_the_true_aim_and_counts_reachable_time():
    score = FollowScore(BallArm(), aim=lambda p: p, marker_id=23)
    # reachable, the command 3 mm off: 3 mm
    score.note_frame(0.0, truth((23, (0.1, 0.0, 0.0), True)))
    score.note_command(0.0, (0.1, 0.003, 0.0))
    # out of reach (0.3 m out): the command at the nearest reachable point is 0 error, not 100 mm
    score.note_frame(1.0, truth((23, (0.3, 0.0, 0.0), True)))
    score.note_command(1.0, (R, 0.0, 0.0))
    # marker hidden (or gone): not scored, the arm cannot know where it is
    score.note_frame(2.0, truth((23, (0.0, 0.1, 0.0), False)))
    score.note_command(2.0, (0.5, 0.5, 0.5))
    score.note_frame(3.0, truth())
    score.note_command(3.0, (0.5, 0.5, 0.5))
    s = score.summary()
    assert s["follow_tracking_samples"] == 2 and s["follow_reachable_ratio"] == 0.5
    assert sorted(score.errors_mm) == pytest.approx([0.0, 3.0])
    assert s["follow_tracking_mm_p95"] == pytest.approx(np.percentile([0.0, 3.0], 95), abs=1e-3)


def test_follow_truth_is_carried_to_the_command_time_with_its_velocity():
    score = FollowScore(BallArm(), aim=lambda p: p, marker_id=23)
    score.note_frame(0.0, truth((23, (0.0, 0.0, 0.0), True)))
    score.note_frame(0.1, truth((23, (0.01, 0.0, 0.0), True)))  # 0.1 m/s along x
    score.note_command(0.15, (0.015, 0.0, 0.0))  # where it truly is at 0.15 s
    assert score.errors_mm == [pytest.approx(0.0, abs=1e-9)]
    assert FOLLOW_REACH_TOL_M <= 0.005


def test_cups_counts_the_frames_whose_goal_is_on_the_cup_hiding_the_ball():
    score = CupsScore(aim=lambda p: (p[0], p[1], p[2] + 0.05), cup_ids=(23, 50))
    cups = ((23, (-0.07, 0.14, 0.05), True), (50, (0.07, 0.14, 0.05), True))
    assert score.note_decision((-0.068, 0.141, 0.10), truth(*cups, target=23)) is True
    assert score.note_decision((-0.068, 0.141, 0.10), truth(*cups, target=50)) is False  # the other cup
    assert score.note_decision((0.071, 0.139, 0.10), truth(*cups, target=50)) is True
    assert score.note_decision((0.0, 0.14, 0.1), truth(*cups, target=None)) is None  # no truth to judge by
    assert score.summary() == {"cups_correct_ratio": pytest.approx(2 / 3, abs=1e-3), "cups_decision_frames": 3}


def headless_json(scenario: str, robot: str, seconds: float) -> dict:
    out, err = io.StringIO(), io.StringIO()
    options = SessionOptions(camera="sim", scenario=scenario, robot=robot, simulated_clock=True)
    assert run_headless(options, seconds, True, out=out, err=err) == 0, err.getvalue()
    return json.loads(out.getvalue())


@pytest.mark.parametrize("robot", ["desk_rrr", "delta"])
def test_wander_reports_how_closely_the_arm_follows_over_time(robot):
    s = headless_json("wander", robot, 20.0)
    assert s["follow_tracking_samples"] > 500  # 50 Hz while the card is in view, not only when settled
    assert math.isfinite(s["follow_tracking_mm_p50"]) and s["follow_tracking_mm_p50"] <= s["follow_tracking_mm_p95"]
    assert s["follow_tracking_mm_p50"] < 5.0 and s["follow_tracking_mm_p95"] < 30.0
    assert 0.0 < s["follow_reachable_ratio"] <= 1.0
    assert "cups_correct_ratio" not in s


def test_the_cups_game_reports_how_often_it_points_at_the_cup_hiding_the_ball():
    s = headless_json("cups", "desk_rrr", 28.0)  # two rounds
    assert s["cups_decision_frames"] > 300
    assert 0.6 <= s["cups_correct_ratio"] <= 1.0
    assert "follow_tracking_mm_p50" not in s


def test_without_truth_there_is_no_truth_score():
    s = headless_json("static", "desk_rrr", 1.0)
    assert s["follow_tracking_samples"] > 0  # the simulated desk has truth
    from app.headless import RunMetrics

    assert "follow_tracking_mm_p50" not in RunMetrics(scenario="static").summary()  # a webcam run's summary
