"""core.motion.teleop: the mapping, the stereo hand's stillness gestures, the original's pose
gestures on synthetic landmark sequences, the state machine, the hand sources, and that no input
ever gives a non-finite or out-of-box target."""
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.clock import SimClock
from core.kinematics import build_kinematics, list_profiles, load_profile
from core.messages import MarkerObservation, PerceptionResult, TargetMode
from core.motion.targeting import Targeter
from core.motion.teleop import (
    CALIBRATING,
    COMMON_TARGET_BOX,
    ENDED,
    FOLLOWING,
    HOLDING,
    TARGET_BOX_BY_KIND,
    Box,
    HandObservation,
    MarkerHandSource,
    PoseGestureDetector,
    PoseHandSource,
    TeleopController,
    TeleopMapping,
    TeleopParams,
    default_target_box,
    map_box_to_box,
    parse_teleop_source,
    reachable_target_box,
)

HAND = Box((0.0, 0.2, 0.1), (0.2, 0.3, 0.2))
TARGET = Box((-0.05, 0.08, 0.04), (0.05, 0.15, 0.10))
FPS = 30.0


# --- the mapping -----------------------------------------------------------------------------
def test_corners_map_to_corners():
    for h, r in zip(HAND.corners(), TARGET.corners()):
        assert np.allclose(map_box_to_box(h, HAND, TARGET), r)
    assert np.allclose(map_box_to_box(HAND.centre, HAND, TARGET), TARGET.centre)


def test_the_original_formula_is_the_box_map_with_a_hand_box_of_two_arm_lengths():
    # x_R = (x_Rmax − x_Rmin)/(2L)·(x_H − x_Hmax) + x_Rmax, right shoulder at 0.1, arm length L
    L, shoulder = 0.6, 0.1
    hand = Box((shoulder - L, 0, 0), (shoulder + L, 1, 1))
    robot = Box((-0.2, 0, 0), (0.3, 1, 1))
    for x_h in np.linspace(shoulder - L, shoulder + L, 7):
        original = (0.3 - -0.2) / (2 * L) * (x_h - (shoulder + L)) + 0.3
        assert map_box_to_box((x_h, 0.5, 0.5), hand, robot)[0] == pytest.approx(original)


def test_points_outside_the_hand_volume_are_clipped_to_the_target_box():
    far = map_box_to_box((5.0, -3.0, 0.15), HAND, TARGET)
    assert np.allclose(far, (TARGET.hi[0], TARGET.lo[1], TARGET.centre[2]))
    unclipped = map_box_to_box((0.4, 0.25, 0.15), HAND, TARGET, clip=False)
    assert unclipped[0] == pytest.approx(0.15)  # one hand box further: one target box further


def shaped(params, **kw):
    return TeleopMapping(HAND, TARGET, TeleopParams(**{**dict(smoothing_s=0.0, max_speed_m_s=5.0), **kw}))


def test_dead_zone_ignores_small_motions_and_drags_on_bigger_ones():
    m = shaped(None, dead_zone_m=0.002)
    start = m.step(HAND.centre, 0.0)
    # the target box is half the hand box along x: 2 mm of hand = 1 mm mapped, inside the dead zone
    assert np.allclose(m.step(HAND.centre + (0.002, 0, 0), 0.1), start)
    assert np.allclose(m.step(HAND.centre - (0.002, 0, 0), 0.2), start)
    moved = m.step(HAND.centre + (0.010, 0, 0), 0.3)  # 5 mm mapped: the output trails it by 2 mm
    assert moved[0] - start[0] == pytest.approx(0.003, abs=1e-9)


def test_speed_limit_bounds_every_step_of_the_mapped_target():
    m = shaped(None, dead_zone_m=0.0, max_speed_m_s=0.1)
    p0 = m.step(HAND.lo, 0.0)
    p1 = m.step(HAND.hi, 1 / FPS)  # the far corner at once
    assert np.linalg.norm(p1 - p0) == pytest.approx(0.1 / FPS)
    for k in range(2, 60):
        p = m.step(HAND.hi, k / FPS)
    assert np.allclose(p, TARGET.hi)  # it gets there in the end


def test_smoothing_lags_a_step_then_converges():
    m = shaped(None, dead_zone_m=0.0, smoothing_s=0.1)
    m.step(HAND.centre, 0.0)
    first = m.step(HAND.centre + (0.02, 0, 0), 0.05)
    wanted = map_box_to_box(HAND.centre + (0.02, 0, 0), HAND, TARGET)
    assert 0 < first[0] - TARGET.centre[0] < wanted[0] - TARGET.centre[0]
    for k in range(2, 40):
        last = m.step(HAND.centre + (0.02, 0, 0), 0.05 * k)
    assert last[0] == pytest.approx(wanted[0], abs=1e-5)


def test_every_profile_reaches_the_common_target_box_and_starts_from_its_own():
    box = Box(*COMMON_TARGET_BOX)
    for name in list_profiles():
        profile = load_profile(name)
        kinematics = build_kinematics(profile)
        margin = profile.workspace.desk_margin_m
        assert reachable_target_box(kinematics, margin, box=box) == box, name  # not shrunk: all reachable
        assert reachable_target_box(kinematics, margin) == default_target_box(kinematics), name
    assert default_target_box(build_kinematics(load_profile("delta"))) == Box(*TARGET_BOX_BY_KIND["delta3"])
    assert default_target_box(build_kinematics(load_profile("desk_rrr"))) == box


class _Unreachable:
    def ik(self, p, q=None):
        class R:
            reachable = False
            error_m = 1.0
        return R()


def test_a_target_box_nothing_reaches_is_refused_with_a_message():
    with pytest.raises(ValueError, match="choose a target box"):
        reachable_target_box(_Unreachable())


# --- the stereo hand's gestures, on synthetic sequences ---------------------------------------
class ScriptedSource:
    """A hand source playing a list of (t, position or None) with a small measurement noise."""

    name = "scripted"

    def __init__(self, noise_m=0.0003, seed=0):
        self.rng = np.random.default_rng(seed)
        self.noise_m = noise_m
        self.source = MarkerHandSource(7)

    def reset(self):
        self.source.reset()

    def hand(self, p, t):
        if p is None:
            result = PerceptionResult(0, t, (MarkerObservation(7, False),), {}, False)
        else:
            noisy = tuple(np.asarray(p) + self.rng.normal(0, self.noise_m, 3))
            result = PerceptionResult(0, t, (MarkerObservation(7, True, base_p_centre=noisy),), {}, False)
        return self.source.hand(result, t)


def path_segments(*segments):
    """[(duration_s, from, to or None)] → list of (t, position or None) at 30 fps; a smooth move
    from → to, a hold when to == from, lost when from is None."""
    out, t = [], 0.0
    for duration, a, b in segments:
        n = int(round(duration * FPS))
        for k in range(n):
            s = k / n
            if a is None:
                p = None
            else:
                w = 0.5 - 0.5 * math.cos(math.pi * s)
                p = np.asarray(a) + (np.asarray(b) - np.asarray(a)) * w
            out.append((t, p))
            t += 1 / FPS
    return out


A, B = np.array([0.0, 0.2, 0.1]), np.array([0.2, 0.3, 0.2])
CALIBRATION = [(0.5, A + 0.1, A), (1.3, A, A), (2.0, A, B), (1.3, B, B)]


def run(controller, script):
    """Feed the script; returns [(t, target or None, state)]."""
    out = []
    for t, p in script:
        target, _ = controller.goal(p, t)
        out.append((t, target, controller.state))
    return out


def events(controller, kind):
    return [e for e in controller.events if e.event == kind]


def test_holding_still_at_two_opposite_corners_calibrates_then_the_hand_is_followed():
    c = TeleopController(ScriptedSource(), TARGET)
    script = path_segments(*CALIBRATION, (2.0, B, (A + B) / 2))
    trace = run(c, script)
    corner, calibrate = events(c, "corner"), events(c, "calibrate")
    assert len(corner) == 1 and len(calibrate) == 1
    assert corner[0].t == pytest.approx(0.5 + 1.0, abs=0.35)  # A reached at 0.5 s, still for 1 s
    assert calibrate[0].t == pytest.approx(0.5 + 1.3 + 2.0 + 1.0, abs=0.35)
    hand_box = c.mapping.hand_box
    assert np.allclose(hand_box.lo, A, atol=0.002) and np.allclose(hand_box.hi, B, atol=0.002)
    before = [target for t, target, state in trace if t < calibrate[0].t]
    assert all(target is None for target in before)  # the arm holds while calibrating
    assert trace[-1][2] == FOLLOWING
    assert np.allclose(trace[-1][1], TARGET.centre, atol=0.004)  # the hand in the middle → the box's middle


def test_a_degenerate_box_is_refused_with_a_message_and_the_corner_starts_a_new_try():
    flat_b = np.array([0.2, 0.3, A[2] + 0.005])  # 5 mm apart along z
    c = TeleopController(ScriptedSource(), TARGET)
    run(c, path_segments((0.5, A + 0.1, A), (1.3, A, A), (2.0, A, flat_b), (1.3, flat_b, flat_b)))
    rejected = events(c, "rejected")
    assert len(rejected) == 1 and "too thin along z" in rejected[0].message
    assert c.state == CALIBRATING and "too thin" in c.message
    assert np.allclose(c.gestures.corner_a, flat_b, atol=0.002)


def test_a_hand_lost_while_moving_holds_and_is_followed_again_when_found():
    c = TeleopController(ScriptedSource(), TARGET)
    mid = (A + B) / 2
    script = path_segments(*CALIBRATION, (1.0, B, mid), (1.5, None, None), (1.0, mid, A))
    trace = run(c, script)
    t_lost = 0.5 + 1.3 + 2.0 + 1.3 + 1.0
    lost = [(t, target, state) for t, target, state in trace if t_lost + 0.05 < t < t_lost + 1.45]
    assert lost and all(target is None and state == HOLDING for _, target, state in lost)
    assert [e.message for e in events(c, "lost")] == ["moving"]
    assert not events(c, "end")  # lost while moving is an occlusion, not the end gesture
    assert trace[-1][2] == FOLLOWING


def test_still_then_covered_for_end_cover_s_ends_and_nothing_is_followed_after():
    c = TeleopController(ScriptedSource(), TARGET)
    mid = (A + B) / 2
    script = path_segments(*CALIBRATION, (1.0, B, mid), (1.0, mid, mid), (1.5, None, None), (1.0, mid, A))
    trace = run(c, script)
    t_cover = 0.5 + 1.3 + 2.0 + 1.3 + 1.0 + 1.0
    end = events(c, "end")
    assert len(end) == 1 and end[0].t == pytest.approx(t_cover + 1.0, abs=0.05)
    after = [(target, state) for t, target, state in trace if t > end[0].t]
    assert all(target is None and state == ENDED for target, state in after)  # seen again: still ended
    c.restart()
    assert c.state == CALIBRATING and c.mapping is None


def test_the_calibration_hold_itself_is_no_cover():
    # lost right after calibrating, while still at the second corner: an occlusion (hold), not the end
    c = TeleopController(ScriptedSource(), TARGET)
    trace = run(c, path_segments(*CALIBRATION, (0.3, B, B), (2.0, None, None)))
    assert not events(c, "end") and trace[-1][2] == HOLDING


def test_holding_the_hand_above_a_height_ends_when_enabled():
    c = TeleopController(ScriptedSource(), TARGET, TeleopParams(end_height_m=0.35, end_raise_s=0.5))
    high = np.array([0.1, 0.25, 0.40])
    run(c, path_segments(*CALIBRATION, (1.0, B, high), (1.0, high, high)))
    end = events(c, "end")
    assert len(end) == 1 and c.state == ENDED
    # z passes 0.35 at about 0.72 of the smooth move from B (z 0.2) to 0.4
    t_up = 0.5 + 1.3 + 2.0 + 1.3 + math.acos(1 - 2 * 0.75) / math.pi
    assert end[0].t == pytest.approx(t_up + 0.5, abs=0.1)


# --- the original's gestures on 2D landmarks ---------------------------------------------------
def skeleton(left_wrist_y, score=0.9):
    """Image y grows down: head at 100, shoulders at 200."""
    return {"nose": (320, 100, 0.9), "left_eye": (330, 95, 0.9), "right_eye": (310, 95, 0.9),
            "left_shoulder": (380, 200, 0.9), "right_shoulder": (260, 200, 0.9),
            "left_wrist": (400, left_wrist_y, score)}


def feed(detector, ys, score=0.9):
    return [detector.update(skeleton(y, score)) for y in ys]


def test_left_wrist_above_the_left_shoulder_calibrates_once_per_hold():
    got = feed(PoseGestureDetector(), [300, 300, 150, 150, 150, 150, 150, 300, 150, 150, 150])
    assert got == ["", "", "", "", "calibrate", "", "", "", "", "", "calibrate"]


def test_left_wrist_above_the_head_stops_and_a_quick_pass_through_the_shoulder_zone_does_not_calibrate():
    got = feed(PoseGestureDetector(), [300, 150, 50, 50, 50, 50])
    assert got == ["", "", "", "", "stop", ""]


def test_unsure_landmarks_make_no_gesture():
    assert feed(PoseGestureDetector(), [50] * 6, score=0.1) == [""] * 6


class PoseObservations:
    """A hand source emitting pose observations (as PoseHandSource does) from a script."""

    name = "pose-script"

    def __init__(self, script):
        self.script = dict(script)

    def reset(self):
        pass

    def hand(self, result, t):
        p, gesture, box = self.script[t]
        return HandObservation(t, True, p, (0.0, 0.0, 0.0), p, gesture=gesture, calibration_box=box)


def test_pose_gestures_drive_the_state_machine():
    box = Box((-0.6, -0.6, 0.4), (0.6, 0.6, 1.6))
    hand = (0.1, 0.2, 1.0)
    script = [(0.0, (hand, "", None)), (0.1, (hand, "calibrate", box)), (0.2, (hand, "", None)),
              (0.3, (hand, "stop", None)), (0.4, (hand, "", None))]
    c = TeleopController(PoseObservations(script), TARGET)
    states = [(c.goal(None, t)[0], c.state) for t, _ in script]
    assert states[0] == (None, CALIBRATING)
    assert states[1][1] == FOLLOWING and states[2][1] == FOLLOWING
    assert np.allclose(states[2][0], map_box_to_box(hand, box, TARGET))
    assert states[3] == (None, ENDED) and states[4] == (None, ENDED)


# --- the pose source: triangulated wrist and the shoulder ± arm-length volume ----------------------
class PlantedPoseModel:
    """The right arm's 3-D joints projected into whichever view the image is (its first pixel says
    which), plus 2-D landmarks of the left side and the head (the gestures) as given."""

    path = "planted.onnx"

    def __init__(self, rig, joints_base, left_side_px):
        self.rig = rig
        self.joints = joints_base
        self.left_side_px = left_side_px

    def landmarks(self, image):
        T = self.rig.base_T_left if image[0, 0, 0] == 0 else self.rig.base_T_right
        camera_T_base = np.linalg.inv(T)
        out = dict(self.left_side_px)
        for name, p in self.joints.items():
            c = camera_T_base[:3, :3] @ np.asarray(p) + camera_T_base[:3, 3]
            uv = self.rig.K @ (c / c[2])
            out[name] = (float(uv[0]), float(uv[1]), 0.9)
        return out


def test_pose_source_triangulates_the_right_wrist_and_calibrates_with_shoulder_plus_minus_arm_length():
    from core.messages import StereoFrame
    from core.sim.rig import SimRig

    rig = SimRig()
    shoulder, elbow, wrist = np.array([0.1, 0.3, 0.25]), np.array([0.05, 0.25, 0.2]), np.array([0.0, 0.2, 0.2])
    left_side = skeleton(300)  # left wrist down
    model = PlantedPoseModel(rig, {"right_shoulder": shoulder, "right_elbow": elbow, "right_wrist": wrist},
                             left_side)
    c = TeleopController(PoseHandSource(model, rig.calibration(), rig.base_T_camera), TARGET)
    frame = StereoFrame(0, 0.0, np.zeros((480, 640, 3), np.uint8), np.ones((480, 640, 3), np.uint8))

    def step(k):
        return c.goal(PerceptionResult(k, k / FPS, (), {}, False, frame=frame), k / FPS)

    assert step(0) == (None, c.message) and c.state == CALIBRATING
    assert np.allclose(c.source.kalman.position, wrist, atol=1e-3)  # triangulated from both views
    model.left_side_px = skeleton(150)  # left wrist above the left shoulder, below the head
    for k in range(1, 5):
        target, _ = step(k)
    assert c.state == FOLLOWING and len(events(c, "calibrate")) == 1
    L = np.linalg.norm(elbow - shoulder) + np.linalg.norm(wrist - elbow)
    assert np.allclose(c.mapping.hand_box.lo, shoulder - L, atol=2e-3)
    assert np.allclose(c.mapping.hand_box.hi, shoulder + L, atol=2e-3)
    assert np.allclose(target, map_box_to_box(wrist, c.mapping.hand_box, TARGET), atol=1e-3)
    model.left_side_px = skeleton(50)  # above the head: stop
    for k in range(5, 9):
        step(k)
    assert c.state == ENDED


# --- the Targeter's TELEOP mode ------------------------------------------------------------------
def marker_result(t, p):
    obs = MarkerObservation(23, p is not None, base_p_centre=None if p is None else tuple(p))
    return PerceptionResult(0, t, (obs,), {}, False)


def test_targeter_teleop_mode_turns_the_controller_into_goals():
    clock = SimClock()
    targeter = Targeter(clock, mode=TargetMode.TELEOP)
    assert not targeter.update(marker_result(0.0, A)).valid  # no controller yet: hold
    targeter.set_teleop(TeleopController(MarkerHandSource(23), TARGET))
    goals = []
    for t, p in path_segments(*CALIBRATION, (1.0, B, (A + B) / 2), (0.5, None, None)):
        clock.advance(t - clock.now())
        goals.append(targeter.update(marker_result(t, p)))
    assert not goals[0].valid and "calibrating" in goals[0].note
    following = [g for g in goals if g.valid]
    assert following and all(TARGET.contains(g.base_p_target) for g in following)
    assert not goals[-1].valid and "lost" in goals[-1].note
    assert targeter.teleop_status().state == HOLDING


def test_teleop_source_specs():
    assert parse_teleop_source("marker:23") == ("marker", "23")
    assert parse_teleop_source(" hsv:green ") == ("hsv", "green")
    assert parse_teleop_source("pose:/tmp/m.onnx") == ("pose", "/tmp/m.onnx")
    for bad in ("", "marker", "marker:x", "glove:red", "pose:"):
        with pytest.raises(ValueError, match="teleop source"):
            parse_teleop_source(bad)


# --- never a non-finite or out-of-box target ------------------------------------------------------
finite = st.floats(-2.0, 2.0, allow_nan=False)
anything = st.one_of(finite, st.just(math.nan), st.just(math.inf), st.just(-math.inf), st.floats(-1e9, 1e9))
point = st.tuples(anything, anything, anything)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.tuples(finite, finite, finite), st.tuples(st.floats(0.0, 1.0), st.floats(0.0, 1.0), st.floats(0.0, 1.0)),
       st.lists(st.tuples(point, st.floats(0.0, 0.2)), min_size=1, max_size=30))
def test_the_mapping_never_gives_a_non_finite_or_out_of_box_target(corner, extent, steps):
    hand = Box(corner, tuple(np.add(corner, extent)))
    m = TeleopMapping(hand, TARGET)
    t = 0.0
    for p, dt in steps:
        t += dt
        out = m.step(p, t)
        assert np.all(np.isfinite(out)) and TARGET.contains(out, tol=1e-12)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.one_of(st.none(), point), min_size=1, max_size=120), st.integers(0, 1000))
def test_the_state_machine_never_hands_out_a_non_finite_or_out_of_box_target(points, seed):
    c = TeleopController(MarkerHandSource(23), TARGET)
    c.set_hand_box(HAND)  # calibrated, so random input is mapped
    for k, p in enumerate(points):
        target, note = c.goal(marker_result(k / FPS, p), k / FPS)
        assert isinstance(note, str) and note
        if target is not None:
            assert all(map(math.isfinite, target)) and TARGET.contains(target, tol=1e-12)


def test_the_glove_source_follows_the_triangulated_object_of_its_colour_nearest_first():
    from types import SimpleNamespace

    from core.motion.teleop import ObjectHandSource

    def result(t, *objects):
        return PerceptionResult(0, t, (), {}, False, objects=tuple(
            SimpleNamespace(label=label, kind="colour", triangulated=tri, base_p=p) for label, p, tri in objects))

    source = ObjectHandSource("Green")
    first = source.hand(result(0.0, ("red", (0.0, 0.2, 0.1), True), ("green", (0.1, 0.2, 0.1), True)), 0.0)
    assert first.seen and np.allclose(first.measured_p, (0.1, 0.2, 0.1))
    # two green blobs: the one near the hand; an untriangulated one is no measurement
    near = source.hand(result(0.1, ("green", (0.3, 0.2, 0.1), True), ("green", (0.105, 0.2, 0.1), True)), 0.1)
    assert np.allclose(near.measured_p, (0.105, 0.2, 0.1))
    lost = source.hand(result(0.2, ("green", (0.1, 0.2, 0.1), False)), 0.2)
    assert not lost.seen and lost.base_p is not None  # the filter's prediction, flagged unseen
