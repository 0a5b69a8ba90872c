"""Servo mappings on URDF profiles: a URDF arm whose [[joints]] give servo_min_deg/servo_max_deg/
offset_deg/direction becomes a hobby-servo profile (limits from the servo range, inside the URDF's),
so the Phidget and v2 bridges can drive it; assistive_5dof ships with one."""
from __future__ import annotations

import math

import pytest

from core.devices.phidget import PhidgetServoBridge
from core.devices.serial_v2 import SerialV2Bridge, to_servo_cdeg
from core.kinematics import ProfileError, load_profile
from core.kinematics.profile import parse_profile, profile_from_urdf
from core.messages import JointCommand
from core.motion.safety import to_servo_bytes_deg

# the fake Phidget22 the bridge's own tests inject into sys.modules (tests/devices)
from tests.devices.test_phidget_bridge import FakeBoard, make_fake_library

JOINTS = ("base_yaw", "shoulder", "elbow", "wrist_pitch", "wrist_roll")
# URDF limits (rad) of assistive_5dof.urdf: base_yaw ±2.96, shoulder -0.2…2.9, elbow ±2.6,
# wrist_pitch ±1.9, wrist_roll ±2.9
SERVO_JOINTS = [
    {"name": "base_yaw", "servo_min_deg": 0, "servo_max_deg": 180, "offset_deg": 90, "direction": 1},
    {"name": "shoulder", "servo_min_deg": 20, "servo_max_deg": 150, "offset_deg": 10, "direction": 1,
     "home_servo_deg": 100},
    {"name": "elbow", "servo_min_deg": 0, "servo_max_deg": 180, "offset_deg": 90, "direction": -1,
     "home": -0.5},
    {"name": "wrist_pitch", "servo_min_deg": 0, "servo_max_deg": 180, "offset_deg": 90, "direction": 1,
     "max_speed_deg_s": 120},
    {"name": "wrist_roll", "servo_min_deg": 0, "servo_max_deg": 180, "offset_deg": 90, "direction": 1},
]


@pytest.fixture(scope="module")
def urdf_path() -> str:
    return load_profile("assistive_5dof").geometry.urdf_path


def urdf_profile(urdf_path: str, joints: list[dict]):
    """A URDF profile on assistive_5dof.urdf with the given [[joints]] entries."""
    data = {"name": "test_arm", "kind": "urdf", "geometry": {"urdf": urdf_path, "tip": "tool"},
            "joints": [dict(j) for j in joints]}
    return parse_profile(data, "test_arm.toml")


def with_changes(name: str, **changes) -> list[dict]:
    return [dict(j, **changes) if j["name"] == name else dict(j) for j in SERVO_JOINTS]


# ---- loading and limits ------------------------------------------------------------------


def test_a_urdf_profile_with_servo_fields_loads_as_a_servo_profile(urdf_path):
    profile = urdf_profile(urdf_path, SERVO_JOINTS)
    assert profile.kind == "urdf" and profile.joint_names == JOINTS
    assert profile.has_servos and all(j.has_servo for j in profile.joints)
    yaw, shoulder, elbow, pitch, roll = profile.joints
    assert (shoulder.servo_min_deg, shoulder.servo_max_deg, shoulder.offset_deg, shoulder.direction) == (20, 150, 10, 1)
    assert shoulder.q_home == pytest.approx(math.radians(90.0))  # home_servo_deg 100 = 10 + 90
    assert elbow.home_servo_deg == pytest.approx(90.0 - math.degrees(-0.5))  # home (rad) through direction -1
    assert elbow.q_home == pytest.approx(-0.5)
    assert yaw.q_home == pytest.approx(0.0)  # no home: mid-range, as desk_rrr's servos
    assert pitch.max_speed_deg_s == 120  # given
    assert yaw.max_speed_deg_s == pytest.approx(math.degrees(0.8))  # the URDF's velocity
    assert roll.velocity_limit == pytest.approx(1.5)


def test_the_limits_follow_from_the_servo_range_through_offset_and_direction(urdf_path):
    profile = urdf_profile(urdf_path, SERVO_JOINTS)
    expected_deg = {"base_yaw": (-90, 90), "shoulder": (10, 140), "elbow": (-90, 90),
                    "wrist_pitch": (-90, 90), "wrist_roll": (-90, 90)}
    for joint in profile.joints:
        lo, hi = expected_deg[joint.name]
        assert (math.degrees(joint.q_min), math.degrees(joint.q_max)) == pytest.approx((lo, hi)), joint.name
        assert joint.to_servo_deg(joint.q_min) == pytest.approx(
            joint.servo_min_deg if joint.direction == 1 else joint.servo_max_deg)
    # direction -1: the servo's 0° is the joint's upper limit
    narrow = urdf_profile(urdf_path, with_changes("elbow", servo_min_deg=30, servo_max_deg=170))
    elbow = narrow.joints[2]
    assert (math.degrees(elbow.q_min), math.degrees(elbow.q_max)) == pytest.approx((-80, 60))


def test_a_servo_range_outside_the_urdf_limits_is_refused_naming_both_ranges_and_the_fix(urdf_path):
    # shoulder: URDF -0.2…2.9 rad (-11.46…166.16°); offset 0 and 0…180° would reach q = 180°
    joints = with_changes("shoulder", servo_min_deg=0, servo_max_deg=180, offset_deg=0)
    joints[1].pop("home_servo_deg")
    with pytest.raises(ProfileError) as err:
        urdf_profile(urdf_path, joints)
    text = str(err.value)
    assert text.startswith("test_arm.toml: joints[1].")
    assert "'shoulder'" in text
    assert "servo range 0…180°" in text and "q = 0.00…180.00°" in text
    assert "URDF's limits -11.46…166.16°" in text and "-0.2…2.9 rad" in text
    assert "servo_min_deg = 0, servo_max_deg = 166.1" in text  # the fix for this offset and direction


def test_a_partial_servo_mapping_is_refused_naming_the_joints_without_one(urdf_path):
    joints = [j for j in SERVO_JOINTS if j["name"] not in ("elbow", "wrist_roll")]
    with pytest.raises(ProfileError, match=r"but elbow, wrist_roll have none; a servo board drives every "
                                           r"joint or none"):
        urdf_profile(urdf_path, joints)
    # an entry with only non-servo keys is no mapping either
    joints = [j if j["name"] != "wrist_pitch" else {"name": "wrist_pitch", "home": -1.0} for j in SERVO_JOINTS]
    with pytest.raises(ProfileError, match="but wrist_pitch has none"):
        urdf_profile(urdf_path, joints)


@pytest.mark.parametrize("changes, words", [
    ({"lower": -1.0}, "lower cannot be combined with a servo mapping"),
    ({"offset_deg": None}, "missing key offset_deg for the servo mapping of joint 'base_yaw'"),
    ({"direction": 2}, "direction = 2 must be 1 or -1"),
    ({"servo_max_deg": 200}, r"servo_max_deg = 200 is outside 0…180"),
    ({"home": 0.1, "home_servo_deg": 95}, "home \\(rad\\) or home_servo_deg"),
    ({"home": 2.0}, "is servo angle 204.59°, outside the servo range 0…180°"),
])
def test_bad_servo_fields_on_a_urdf_joint_say_what_is_wrong(urdf_path, changes, words):
    joints = with_changes("base_yaw", **changes)
    joints[0] = {k: v for k, v in joints[0].items() if v is not None}
    with pytest.raises(ProfileError, match=words):
        urdf_profile(urdf_path, joints)


def test_urdf_profiles_without_servo_fields_stay_plain(urdf_path):
    plain = profile_from_urdf(urdf_path)
    assert not plain.has_servos
    assert not load_profile("umi_rtx").has_servos
    narrowed = urdf_profile(urdf_path, [{"name": "elbow", "lower": -1.0, "upper": 1.0}])
    assert not narrowed.has_servos and narrowed.q_min[2] == -1.0


# ---- assistive_5dof's shipped mapping ------------------------------------------------------


@pytest.fixture(scope="module")
def assistive():
    return load_profile("assistive_5dof")


def test_assistive_5dof_maps_every_joint_inside_the_urdf_limits(assistive, urdf_path):
    urdf = profile_from_urdf(urdf_path, "tool")
    assert assistive.has_servos
    for joint, plain in zip(assistive.joints, urdf.joints):
        assert plain.q_min <= joint.q_min < joint.q_max <= plain.q_max, joint.name
        assert 0 <= joint.servo_min_deg < joint.servo_max_deg <= 180
        assert joint.velocity_limit == pytest.approx(plain.velocity_limit)  # the URDF's speeds kept
    # the park pose is unchanged (rad): yaw ahead, shoulder back, elbow folded, hand to the desk
    assert assistive.q_home == pytest.approx((0.0, 2.2, -2.5, -1.2, 0.0))


def test_assistive_5dof_covers_its_ready_pose_and_the_measured_pressing_range(assistive):
    from app.cli_assist import AssistTrials

    ready = AssistTrials().ready_q
    # joint range of `deskarm assist-trials --n 30` (home, ready pose, approaches and presses), deg
    used_deg = {"base_yaw": (-9.5, 32.0), "shoulder": (52.0, 126.1), "elbow": (-148.7, -109.3),
                "wrist_pitch": (-78.1, -28.4), "wrist_roll": (-0.1, 0.1)}
    for joint, q in zip(assistive.joints, ready):
        lo, hi = used_deg[joint.name]
        assert joint.q_min <= math.radians(lo) <= q <= math.radians(hi) <= joint.q_max, joint.name


def test_to_servo_cdeg_and_the_v2_bridge_accept_assistive_5dof(assistive):
    cdeg = to_servo_cdeg(assistive.q_home, assistive)
    assert len(cdeg) == 5 and all(0 <= c <= 18000 for c in cdeg)
    assert cdeg == tuple(round(d * 100) for d in assistive.to_servo_deg(assistive.q_home))
    assert to_servo_bytes_deg(assistive.q_home, assistive) == tuple(round(d) for d in assistive.to_servo_deg(assistive.q_home))
    # far outside the limits: clamped into each servo's range
    assert to_servo_cdeg((9.0, 9.0, -9.0, -9.0, 9.0), assistive) == (18000, 17600, 0, 0, 18000)
    SerialV2Bridge("v2://loop://", assistive)  # refused before: "joints without a servo mapping"


def test_the_phidget_bridge_drives_assistive_5dof(assistive, monkeypatch):
    import sys

    board = FakeBoard()
    modules, _ = make_fake_library(board)
    for name, module in modules.items():
        monkeypatch.setitem(sys.modules, name, module)
    bridge = PhidgetServoBridge("phidget://", assistive)
    assert bridge.channels == (0, 1, 2, 3, 4)
    bridge.connect()
    try:
        sent = bridge.send(JointCommand(seq=1, t=0.0, q=assistive.q_home))
        expected = assistive.to_servo_deg(assistive.q_home)
        assert sent == pytest.approx(expected, abs=0.006)
        assert tuple(board.channel(c).target for c in range(5)) == pytest.approx(expected, abs=0.006)
        assert all(board.channel(c).engaged for c in range(5))
        state = bridge.joint_state()
        assert state is not None and state.q == pytest.approx(assistive.q_home, abs=1e-3)
    finally:
        bridge.disconnect()
