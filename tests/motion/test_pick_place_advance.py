"""Starting and stepping a pick and place from the markers file and the measured joints
(core.motion.pick_place.start_pick_place, PickPlaceSequence.advance): what the window's markers
feature used to work out itself. No Qt."""
from __future__ import annotations

import numpy as np
import pytest

from core.kinematics import build_kinematics, load_profile
from core.messages import MarkerObservation
from core.motion.pick_place import PickPlaceSequence, start_pick_place
from core.vision.markers import MarkersConfig, MarkerSpec

CONFIG = MarkersConfig(dictionary="DICT_APRILTAG_36h11",
                       markers=(MarkerSpec(23, "cup A", "pick_place", "bin"), MarkerSpec(50, "pen", "point")),
                       places={"bin": (0.15, 0.05, 0.02)})
SEEN = MarkerObservation(23, True, base_p_centre=(0.05, 0.15, 0.0))


def test_a_seen_marker_with_a_place_starts_a_sequence_named_after_it():
    seq, why = start_pick_place(CONFIG, 23, SEEN)
    assert why == "" and isinstance(seq, PickPlaceSequence) and seq.label == "cup A"
    assert np.allclose(seq.waypoints[-1][0], (0.15, 0.05, 0.02 + 0.05))


def test_a_marker_not_seen_by_both_cameras_says_so():
    for obs in (None, MarkerObservation(23, False), MarkerObservation(23, True, base_p_centre=None)):
        seq, why = start_pick_place(CONFIG, 23, obs)
        assert seq is None and why == "pick and place cup A: it must be seen by both cameras"


def test_a_marker_without_a_place_says_so_even_when_seen():
    seq, why = start_pick_place(CONFIG, 50, MarkerObservation(50, True, base_p_centre=(0.0, 0.2, 0.0)))
    assert seq is None and why == "pen has no place in the markers file"


class PointKinematics:
    """fk(q) = q: the measured "joints" are the tool point itself."""

    def fk(self, q):
        return np.asarray(q, float)


def test_advance_steps_with_the_measured_tool_and_says_each_new_step_once():
    seq, _ = start_pick_place(CONFIG, 23, SEEN)
    first = seq.advance(0.0, PointKinematics(), None)
    assert first.target == pytest.approx((0.05, 0.15, 0.05)) and first.grip_m is None and not first.done
    assert seq.advance(0.1, PointKinematics(), None).note == ""  # nothing new to say
    there = seq.advance(0.2, PointKinematics(), first.target)
    assert there.target == pytest.approx((0.05, 0.15, 0.0)) and "down to cup A" in there.note


def test_advance_gives_the_gripper_opening_of_each_waypoint():
    gripper = load_profile("assistive_5dof").gripper
    seq, _ = start_pick_place(CONFIG, 23, SEEN)
    step = seq.advance(0.0, PointKinematics(), None, gripper)
    assert step.grip_m == gripper.max_m  # open on the way down
    step = seq.advance(0.1, PointKinematics(), step.target, gripper)  # above: arrives
    step = seq.advance(0.2, PointKinematics(), step.target, gripper)  # down: grips
    assert step.grip_m == gripper.min_m and "lifting" in step.note


def test_advance_ends_with_placed_and_no_target():
    seq, _ = start_pick_place(CONFIG, 23, SEEN)
    step, t = seq.advance(0.0, PointKinematics(), None), 0.0
    while not step.done:
        t += 0.1
        step = seq.advance(t, PointKinematics(), step.target)
    assert step.target is None and "placed" in step.note and seq.done


def test_advance_with_real_kinematics_uses_the_tool_point_of_the_joints():
    profile = load_profile("desk_rrr")
    kin = build_kinematics(profile)
    tool = tuple(float(v) for v in kin.fk(profile.q_home))
    seq = PickPlaceSequence(np.asarray(tool) - (0.0, 0.0, 0.05), (0.1, 0.1, 0.02))  # above it: the tool now
    step = seq.advance(0.0, kin, profile.q_home)
    assert "(2/6)" in step.note  # the first waypoint is where the tool is: reached at once
