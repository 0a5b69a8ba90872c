"""PickPlaceSequence: waypoints in order, advancing only on the measured tool, a timeout that says why."""
import numpy as np
import pytest

from core.motion.pick_place import PickPlaceSequence


def test_the_sequence_visits_six_waypoints_in_order_on_the_measured_tool():
    seq = PickPlaceSequence((0.05, 0.15, 0.0), (-0.10, 0.12, 0.02), hover_m=0.05, label="cup A")
    visited, t = [], 0.0
    step = seq.step(t, None)
    while not step.done:
        visited.append(step.target)
        assert seq.step(t, np.asarray(step.target) + 0.05).target == step.target  # not there: stays
        t += 0.1
        step = seq.step(t, step.target)  # arrives
    assert np.allclose(visited, [(0.05, 0.15, 0.05), (0.05, 0.15, 0.0), (0.05, 0.15, 0.05),
                                 (-0.10, 0.12, 0.07), (-0.10, 0.12, 0.02), (-0.10, 0.12, 0.07)])
    assert not step.failed and "placed" in step.message and not step.grip_closed


def test_a_waypoint_not_reached_ends_the_sequence_with_the_reason():
    seq = PickPlaceSequence((0.05, 0.15, 0.0), (0.0, 0.2, 0.0), timeout_s=2.0)
    seq.step(0.0, (0.0, 0.0, 0.3))
    step = seq.step(2.5, (0.0, 0.0, 0.3))
    assert step.done and step.failed and step.target is None and "not reached" in step.message


def test_non_finite_points_are_refused():
    with pytest.raises(ValueError, match="pick point"):
        PickPlaceSequence((float("nan"), 0.1, 0.0), (0.0, 0.2, 0.0))
