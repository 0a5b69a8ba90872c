"""UMI-RTX driver conversions: the differential wrist and the encoder ticks of the original driver."""
from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core.kinematics.profile import load_profile
from core.kinematics.umi_rtx import (
    DEG_PER_COUNT,
    angle_deg_to_ticks,
    column_m_to_ticks,
    gripper_mm_to_ticks,
    motor_ticks_to_q,
    q_to_motor_ticks,
    ticks_to_angle_deg,
    ticks_to_column_m,
    ticks_to_gripper_mm,
    wrist_differential,
    wrist_from_motors,
)


def test_elbow_45_degrees_is_657_ticks_and_shoulder_45_is_1315():
    assert angle_deg_to_ticks("ELBOW", 45.0) == 657
    assert angle_deg_to_ticks("SHOULDER", 45.0) == 1315


def test_ticks_truncate_towards_zero_like_the_drivers_cast():
    assert angle_deg_to_ticks("ELBOW", -45.0) == -657
    assert angle_deg_to_ticks("YAW", 0.10267 * 10.999) == 10
    assert angle_deg_to_ticks("WRIST1", 7.4) == 99  # 99.8 counts: truncated, not rounded to 100
    assert angle_deg_to_ticks("WRIST2", -7.4) == -99


def test_degrees_per_count_are_the_original_drivers():
    assert DEG_PER_COUNT == {"SHOULDER": 0.03422, "ELBOW": 0.06844, "YAW": 0.10267, "WRIST1": 0.07415, "WRIST2": 0.07415}
    assert ticks_to_angle_deg("ELBOW", 657) == pytest.approx(44.96508)


def test_wrist_differential_is_roll_plus_pitch_and_pitch_minus_roll():
    assert wrist_differential(10.0, 30.0) == (40.0, 20.0)
    assert wrist_differential(-20.0, 5.0) == (-15.0, 25.0)
    assert wrist_differential(0.0, -90.0) == (-90.0, -90.0)  # pure pitch turns both motors alike
    assert wrist_differential(45.0, 0.0) == (45.0, -45.0)  # pure roll turns them against each other


@given(roll=st.floats(-200, 200), pitch=st.floats(-120, 10))
def test_wrist_from_motors_inverts_the_differential(roll, pitch):
    r, p = wrist_from_motors(*wrist_differential(roll, pitch))
    assert r == pytest.approx(roll, abs=1e-9) and p == pytest.approx(pitch, abs=1e-9)


def test_column_and_gripper_ticks_follow_the_drivers_linear_maps():
    assert column_m_to_ticks(0.0) == -3554
    assert column_m_to_ticks(0.948) == int(-3554 + 3749.5 * 0.948)  # 0 at the top: -3554 + 3554.526
    assert column_m_to_ticks(0.5) == -1679
    assert ticks_to_column_m(-3554) == 0.0
    assert gripper_mm_to_ticks(0.0) == -30
    assert gripper_mm_to_ticks(90.0) == 1200
    assert gripper_mm_to_ticks(30.0) == 380
    assert ticks_to_gripper_mm(1200) == pytest.approx(90.0)


def test_non_finite_angles_are_refused():
    with pytest.raises(ValueError, match="cannot convert nan"):
        angle_deg_to_ticks("ELBOW", math.nan)
    with pytest.raises(ValueError, match="unknown UMI-RTX motor 'KNEE'"):
        angle_deg_to_ticks("KNEE", 1.0)


@settings(max_examples=200, deadline=None)
@given(st.data())
def test_joint_vector_round_trips_through_motor_ticks_within_one_count(data):
    p = load_profile("umi_rtx")
    q = tuple(data.draw(st.floats(lo, hi)) for lo, hi in zip(p.q_min, p.q_max))
    ticks = q_to_motor_ticks(q)
    assert set(ticks) == {"ZED", "SHOULDER", "ELBOW", "YAW", "WRIST1", "WRIST2"}
    back = motor_ticks_to_q(ticks)
    assert abs(back[0] - q[0]) <= 1.0 / 3749.5  # one column count
    for i, motor in ((1, "SHOULDER"), (2, "ELBOW"), (3, "YAW")):
        assert abs(back[i] - q[i]) <= math.radians(DEG_PER_COUNT[motor])
    # roll and pitch each come from two motors: within one wrist count
    for i in (4, 5):
        assert abs(back[i] - q[i]) <= math.radians(DEG_PER_COUNT["WRIST1"])
