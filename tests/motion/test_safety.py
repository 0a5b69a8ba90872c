"""Safety clamps: joint limits, step limit, whole servo degrees; nothing non-finite gets out."""
from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core.kinematics.profile import JointSpec, RobotProfile, RRRGeometry, load_profile
from core.motion.safety import (
    clamp_to_limits,
    is_within_limits,
    limit_step,
    to_servo_bytes_deg,
)

PI = math.pi


@pytest.fixture(scope="module")
def desk():
    return load_profile("desk_rrr")


def mirrored_profile():
    """Servos mounted the other way round and narrowed, to exercise offset/direction."""
    return RobotProfile(
        name="mirrored",
        kind="rrr",
        description="",
        geometry=RRRGeometry(0.0662, 0.125, 0.09),
        joints=(
            JointSpec("base_yaw", 10, 170, 90, -1),
            JointSpec("shoulder", 0, 180, 180, -1),
            JointSpec("elbow", 5.5, 175.5, 0, -1),
        ),
    )


any_float = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(min_value=-10.0, max_value=10.0),
    st.sampled_from([math.nan, math.inf, -math.inf, 1e308, -1e308, 0.0, PI, -PI, PI / 2]),
)
joint_triples = st.tuples(any_float, any_float, any_float)


# --- clamp_to_limits --------------------------------------------------------------------------


def test_clamp_leaves_in_limit_values_alone(desk):
    q = (0.3, 1.2, -0.7)
    assert clamp_to_limits(q, desk) == (q, False)


def test_clamp_moves_each_joint_onto_its_nearest_limit(desk):
    q, changed = clamp_to_limits((-0.1, 4.0, 0.2), desk)
    assert changed and q == (0.0, PI, 0.0)
    q, changed = clamp_to_limits((math.inf, -math.inf, -math.inf), desk)
    assert changed and q == (PI, 0.0, -PI)


def test_clamp_replaces_nan_with_the_middle_of_the_range(desk):
    q, changed = clamp_to_limits((math.nan, 1.0, math.nan), desk)
    assert changed and q == (PI / 2, 1.0, -PI / 2)


def test_clamp_rejects_the_wrong_number_of_joints(desk):
    with pytest.raises(ValueError, match="2 values but profile 'desk_rrr' has 3 joints"):
        clamp_to_limits((0.0, 1.0), desk)


@settings(max_examples=300, deadline=None)
@given(q=joint_triples)
def test_clamp_output_is_always_finite_and_within_limits(q):
    for profile in (load_profile("desk_rrr"), mirrored_profile()):
        out, changed = clamp_to_limits(q, profile)
        assert is_within_limits(out, profile, tol=0.0), (q, out)
        assert changed == (tuple(out) != tuple(q) or any(v != v for v in q))


# --- limit_step ---------------------------------------------------------------------------------


def test_limit_step_passes_small_moves_and_caps_large_ones():
    assert limit_step((0.0, 1.0, -1.0), (0.01, 0.99, -1.0), 0.05) == (0.01, 0.99, -1.0)
    assert limit_step((0.0, 1.0, -1.0), (1.0, -1.0, -1.0), 0.05) == (0.05, 0.95, -1.0)


def test_limit_step_takes_one_step_per_joint():
    assert limit_step((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), (0.1, 0.2, 0.0)) == (0.1, 0.2, 0.0)


def test_limit_step_holds_the_previous_value_on_nan_target():
    assert limit_step((0.5, 1.0, -1.0), (math.nan, 2.0, math.nan), 0.1) == (0.5, 1.1, -1.0)


def test_limit_step_moves_one_step_towards_an_infinite_target():
    assert limit_step((0.5, 1.0, -1.0), (math.inf, -math.inf, 1e308), 0.1) == pytest.approx((0.6, 0.9, -0.9))


def test_limit_step_with_nan_or_negative_step_holds_and_inf_step_lets_go():
    assert limit_step((0.5, 1.0, -1.0), (1.0, 2.0, 0.0), (math.nan, -0.1, math.inf)) == (0.5, 1.0, 0.0)


def test_limit_step_without_history_passes_the_new_value_or_the_fallback():
    out = limit_step((math.nan, math.inf, math.nan), (0.3, 1.0, math.nan), 0.1, q_fallback=(0, 0, -1.5))
    assert out == (0.3, 1.0, -1.5)
    assert limit_step((math.nan,), (math.nan,), 0.1) == (0.0,)


def test_limit_step_rejects_mismatched_lengths():
    with pytest.raises(ValueError):
        limit_step((0.0, 0.0), (0.0, 0.0, 0.0), 0.1)
    with pytest.raises(ValueError):
        limit_step((0.0, 0.0), (0.0, 0.0), (0.1, 0.1, 0.1))


@settings(max_examples=300, deadline=None)
@given(prev=joint_triples, new=joint_triples, step=st.one_of(any_float, st.tuples(any_float, any_float, any_float)))
def test_limit_step_output_is_always_finite_and_never_exceeds_the_step(prev, new, step):
    out = limit_step(prev, new, step)
    assert all(math.isfinite(v) for v in out), (prev, new, step, out)
    steps = step if isinstance(step, tuple) else (step,) * 3
    for p, n, s, o in zip(prev, new, steps, out):
        if math.isfinite(p) and s >= 0:
            rounding = 2 * math.ulp(max(abs(p), abs(o)))
            assert abs(o - p) <= s + rounding, (p, n, s, o)


# --- to_servo_bytes_deg -------------------------------------------------------------------------


def test_home_pose_is_servo_0_90_90(desk):
    assert to_servo_bytes_deg((0.0, PI / 2, -PI / 2), desk) == (0, 90, 90)


def test_servo_degrees_round_to_the_nearest_whole_degree(desk):
    q = (math.radians(44.4), math.radians(44.6), math.radians(-0.4))
    assert to_servo_bytes_deg(q, desk) == (44, 45, 180)
    assert to_servo_bytes_deg((math.radians(12.5),) + (1.0, -1.0), desk)[0] == 13  # half up


def test_servo_degrees_clamp_to_the_joint_and_servo_ranges(desk):
    assert to_servo_bytes_deg((-1.0, 9.0, 3.0), desk) == (0, 180, 180)
    assert to_servo_bytes_deg((math.nan, math.inf, -math.inf), desk) == (90, 180, 0)


def test_servo_degrees_follow_offset_and_direction_and_stay_inside_a_fractional_range():
    prof = mirrored_profile()
    # base: servo = 90 - deg(q); shoulder: 180 - deg(q); elbow: -deg(q) within 5.5…175.5
    assert to_servo_bytes_deg((0.0, PI / 2, -PI / 2), prof) == (90, 90, 90)
    assert to_servo_bytes_deg((PI, -PI, 1.0), prof) == (10, 180, 6)
    assert to_servo_bytes_deg((-PI, PI, -PI), prof) == (170, 0, 175)


@settings(max_examples=300, deadline=None)
@given(q=joint_triples)
def test_servo_degrees_are_always_whole_and_inside_0_180(q):
    for profile in (load_profile("desk_rrr"), mirrored_profile()):
        out = to_servo_bytes_deg(q, profile)
        assert all(type(v) is int for v in out)
        for v, j in zip(out, profile.joints):
            assert 0 <= v <= 180 and j.servo_min_deg <= v <= j.servo_max_deg, (q, out)


# --- is_within_limits ---------------------------------------------------------------------------


def test_is_within_limits(desk):
    assert is_within_limits((0.0, PI, -PI), desk)
    assert is_within_limits((PI + 1e-12, 0.0, 0.0), desk)  # rounding tolerance
    assert not is_within_limits((0.0, PI + 1e-6, 0.0), desk)
    assert not is_within_limits((math.nan, 1.0, -1.0), desk)
    assert not is_within_limits((0.0, 1.0), desk)
