"""Targeting and the control step: pointing, holding on loss, nearest reachable point, limits."""
import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from core.clock import SimClock
from core.kinematics import build_kinematics, load_profile
from core.messages import Goal, MarkerObservation, PerceptionResult, TargetMode
from core.motion.control import ArmController
from core.motion.safety import is_within_limits
from core.motion.targeting import BallFinder, PointingOffset, Targeter
from core.settings import LissajousParams

PROFILE = load_profile("desk_rrr")
KIN = build_kinematics(PROFILE)


def result(markers, ball=None, t=0.0):
    return PerceptionResult(seq=1, t=t, markers=tuple(markers), timings_ms={}, full_frame_search=False,
                            ball_left_px=ball)


def seen(marker_id, p, corners=((0, 0), (10, 0), (10, 10), (0, 10))):
    return MarkerObservation(marker_id, True, left_corners=corners, right_corners=corners, base_p_centre=p)


def test_pointing_offset_stands_back_towards_the_base_and_above():
    x, y, z = PointingOffset(standoff_m=0.05, hover_m=0.04).apply((0.0, 0.15, 0.0))
    assert (x, y, z) == (0.0, 0.10000000000000002, 0.04) or np.allclose((x, y, z), (0, 0.10, 0.04))


def test_follow_mode_goes_to_the_marker_and_holds_when_lost():
    t = Targeter(SimClock(), mode=TargetMode.FOLLOW, follow_id=23)
    g = t.update(result([seen(23, (0.05, 0.15, 0.0))]))
    assert g.valid and np.allclose(g.base_p_target[2], 0.04)
    lost = t.update(result([MarkerObservation(23, False)]))
    assert not lost.valid and "lost" in lost.note


def test_cups_mode_follows_the_cup_the_ball_was_seen_near():
    t = Targeter(SimClock(), mode=TargetMode.CUPS, cup_ids=(23, 50))
    near_50 = ((100, 100), (110, 100), (110, 110), (100, 110))
    near_23 = ((300, 300), (310, 300), (310, 310), (300, 310))
    g = t.update(result([seen(23, (0.0, 0.1, 0.08), near_23), seen(50, (0.1, 0.1, 0.08), near_50)], ball=(104, 130)))
    assert t.ball_cup_id == 50 and g.valid
    # the ball is hidden now; the cups swap: keep pointing at cup 50 wherever it goes
    g = t.update(result([seen(23, (0.1, 0.1, 0.08), near_50), seen(50, (0.0, 0.1, 0.08), near_23)]))
    assert t.ball_cup_id == 50 and np.allclose(g.base_p_target[0], 0.0)


def test_cups_mode_takes_the_lifted_cup_when_the_ball_shows_under_it():
    """The ball is shown by lifting its cup: that cup's marker rises ~15 cm above the ball in the
    image while the other cup, on the desk, sits nearer the ball in the image — nearest was wrong
    for most of each show (the headless cups score found it: 0.79 right, now 0.92)."""
    t = Targeter(SimClock(), mode=TargetMode.CUPS, cup_ids=(23, 50))
    lifted = seen(50, (0.0, 0.20, 0.16), corners=((260, 100), (280, 100), (280, 120), (260, 120)))  # far in the image
    resting = seen(23, (0.08, 0.18, 0.03), corners=((400, 215), (420, 215), (420, 235), (400, 235)))  # near it
    goal = t.update(result([lifted, resting], ball=(286.0, 260.0)))
    assert t.ball_cup_id == 50 and goal.valid, goal.note
    # with no cup lifted, the nearest cup in the image, as before
    t2 = Targeter(SimClock(), mode=TargetMode.CUPS, cup_ids=(23, 50))
    down = seen(50, (0.0, 0.20, 0.03), corners=((260, 100), (280, 100), (280, 120), (260, 120)))
    t2.update(result([down, resting], ball=(286.0, 260.0)))
    assert t2.ball_cup_id == 23


def test_ball_finder_finds_a_red_disc():
    import cv2

    img = np.full((480, 640, 3), (60, 120, 170), np.uint8)
    cv2.circle(img, (400, 200), 12, (38, 38, 205), -1)
    x, y = BallFinder().find(img)
    assert abs(x - 400) < 3 and abs(y - 200) < 3
    assert BallFinder().find(np.full((480, 640, 3), (60, 120, 170), np.uint8)) is None


def test_lissajous_pauses_and_resumes_where_it_stopped():
    clock = SimClock()
    t = Targeter(clock, mode=TargetMode.LISSAJOUS, lissajous=LissajousParams())
    t.set_lissajous_running(True)
    clock.advance(1.0)
    t.set_lissajous_running(False)
    p1 = t.update(None).base_p_target
    clock.advance(5.0)
    assert t.update(None).base_p_target == p1
    t.set_lissajous_running(True)
    clock.advance(0.5)
    assert np.allclose(t.update(None).base_p_target, LissajousParams().point(1.5))


def test_default_lissajous_fits_the_workspace():
    p = LissajousParams()
    for time_s in np.linspace(0, p.period_s(), 500):
        assert KIN.ik(p.point(time_s), PROFILE.q_home).reachable


def test_unreachable_goal_goes_to_the_nearest_point_and_says_how_far():
    c = ArmController(PROFILE, KIN)
    cmd = c.step(Goal(1, 0.0, (0.0, 0.5, 0.05), TargetMode.MANUAL), PROFILE.q_home, 0.0)
    assert not cmd.reachable and 0.25 < cmd.reach_error_m < 0.35
    assert is_within_limits(cmd.q, PROFILE)


def test_invalid_goal_holds_the_last_command():
    c = ArmController(PROFILE, KIN)
    first = c.step(Goal(1, 0.0, (0.05, 0.15, 0.08), TargetMode.FOLLOW), PROFILE.q_home, 0.0)
    held = c.step(Goal(2, 0.02, (0.0, 0.0, 0.0), TargetMode.FOLLOW, valid=False), PROFILE.q_home, 0.02)
    assert held.q == first.q


def test_steps_are_rate_limited_per_tick():
    c = ArmController(PROFILE, KIN)
    q0 = PROFILE.q_home
    cmd = c.step(Goal(1, 0.0, (-0.15, 0.05, 0.07), TargetMode.MANUAL), q0, 0.0)
    for a, b, step in zip(cmd.q, q0, c.max_step_rad):
        assert abs(a - b) <= step + 1e-12


finite = st.floats(allow_nan=True, allow_infinity=True, width=64)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(finite, finite, finite), min_size=1, max_size=8),
       st.tuples(finite, finite, finite))
def test_no_goal_sequence_commands_a_joint_outside_its_limits(targets, q_start):
    c = ArmController(PROFILE, KIN)
    for k, p in enumerate(targets):
        cmd = c.step(Goal(k, k * 0.02, p, TargetMode.MANUAL), q_start, k * 0.02)
        if cmd is None:  # a NaN/inf goal before any command is invalid: there is nothing to hold yet
            assert c.last is None and not all(math.isfinite(v) for v in p)
            continue
        assert all(math.isfinite(v) for v in cmd.q)
        assert is_within_limits(cmd.q, PROFILE)


def test_pose_goal_uses_the_pose_solver_for_6dof_arms():
    from core.motion.control import goal_pose_matrix

    profile = load_profile("umi_rtx")
    kin = build_kinematics(profile)
    q_true = tuple((lo + hi) / 2 + 0.1 for lo, hi in zip(profile.q_min, profile.q_max))
    T = np.asarray(kin.fk_pose(q_true))
    import pinocchio as pin

    rpy = pin.rpy.matrixToRpy(T[:3, :3])
    np.testing.assert_allclose(goal_pose_matrix(T[:3, 3], rpy), T, atol=1e-12)
    c = ArmController(profile, kin)
    c.max_step_rad = tuple(10.0 for _ in c.max_step_rad)  # one tick, no rate limit, for the check
    cmd = c.step(Goal(1, 0.0, tuple(T[:3, 3]), TargetMode.MANUAL, orientation_rpy=tuple(rpy)), profile.q_home, 0.0)
    np.testing.assert_allclose(np.asarray(kin.fk_pose(cmd.q)), T, atol=1e-5)
    assert is_within_limits(cmd.q, profile)


def test_manual_pose_reaches_the_goal():
    t = Targeter(SimClock())
    t.set_manual_pose((0.1, 0.2, 0.3), (0.0, 0.5, 1.0), 0.02)
    g = t.update(None)
    assert g.orientation_rpy == (0.0, 0.5, 1.0) and g.grip_m == 0.02
