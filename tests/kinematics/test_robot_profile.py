"""Robot profiles: the built-in desk_rrr, the servo mapping, and errors for bad files."""
from __future__ import annotations

import copy
import math

import pytest
import tomli_w

from core.kinematics import build_kinematics
from core.kinematics.profile import (
    JointSpec,
    ProfileError,
    RobotProfile,
    RRRGeometry,
    list_profiles,
    load_profile,
    parse_profile,
)

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib


@pytest.fixture(scope="module")
def desk():
    return load_profile("desk_rrr")


@pytest.fixture()
def good_data(desk):
    """The built-in desk_rrr file as a dict, to be broken one key at a time."""
    with open(desk.source, "rb") as f:
        return tomllib.load(f)


def write(tmp_path, data, name="arm.toml"):
    path = tmp_path / name
    path.write_bytes(tomli_w.dumps(data).encode())
    return path


def test_desk_rrr_is_a_built_in_profile():
    assert "desk_rrr" in list_profiles()


def test_desk_rrr_has_the_original_arms_geometry(desk):
    assert desk.name == "desk_rrr" and desk.kind == "rrr" and desk.description
    assert desk.geometry == RRRGeometry(shoulder_height_m=0.0662, upper_arm_m=0.125, forearm_m=0.090)
    assert desk.joint_names == ("base_yaw", "shoulder", "elbow")


def test_desk_rrr_joint_limits_follow_from_the_0_180_servo_range(desk):
    assert desk.q_min == pytest.approx((0.0, 0.0, -math.pi), abs=1e-15)
    assert desk.q_max == pytest.approx((math.pi, math.pi, 0.0), abs=1e-15)


def test_home_servo_0_90_90_is_q_0_half_pi_minus_half_pi(desk):
    assert desk.from_servo_deg((0, 90, 90)) == pytest.approx((0.0, math.pi / 2, -math.pi / 2), abs=1e-15)
    assert desk.to_servo_deg((0.0, math.pi / 2, -math.pi / 2)) == pytest.approx((0.0, 90.0, 90.0), abs=1e-12)
    assert desk.q_home == pytest.approx((0.0, math.pi / 2, -math.pi / 2), abs=1e-15)


def test_servo_mapping_round_trips_with_mirrored_servos():
    j = JointSpec("elbow", servo_min_deg=10, servo_max_deg=170, offset_deg=90, direction=-1)
    assert j.q_min == pytest.approx(math.radians(-80)) and j.q_max == pytest.approx(math.radians(80))
    for deg in (10.0, 45.0, 90.0, 170.0):
        assert j.to_servo_deg(j.from_servo_deg(deg)) == pytest.approx(deg, abs=1e-12)
    assert j.to_servo_deg(math.radians(30)) == pytest.approx(60.0)
    assert j.q_home == pytest.approx(0.0)  # no home given: the middle of the servo range


def test_loading_by_path_gives_the_same_profile_as_by_name(desk, good_data, tmp_path):
    by_path = load_profile(write(tmp_path, good_data))
    assert by_path.geometry == desk.geometry and by_path.joints == desk.joints
    assert by_path.source.endswith("arm.toml")


def test_build_kinematics_uses_the_profile_geometry(desk):
    kin = build_kinematics(desk)
    assert (kin.shoulder_height_m, kin.upper_arm_m, kin.forearm_m) == (0.0662, 0.125, 0.090)


def test_unknown_profile_name_lists_the_valid_names():
    with pytest.raises(ProfileError, match=r"unknown robot profile 'nope'; valid names: .*desk_rrr"):
        load_profile("nope")


def test_missing_file_names_the_path(tmp_path):
    with pytest.raises(ProfileError, match=r"missing\.toml: no such file"):
        load_profile(tmp_path / "missing.toml")


def test_toml_syntax_error_names_the_file_and_line(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text('name = "x"\nkind = "rrr\n')
    with pytest.raises(ProfileError) as err:
        load_profile(path)
    msg = str(err.value)
    assert str(path) in msg and "invalid TOML" in msg and "line 2" in msg, msg


def test_non_utf8_file_is_reported(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes(b'name = "bra\xe7o"\n')
    with pytest.raises(ProfileError, match=r"latin1\.toml: not UTF-8"):
        load_profile(path)


def _set(data, key_path, value):
    """Set (or delete, with value ...) ``geometry.upper_arm_m`` / ``joints.1.servo_max_deg``."""
    *parents, last = key_path.split(".")
    node = data
    for p in parents:
        node = node[int(p)] if p.isdigit() else node[p]
    if value is ...:
        del node[int(last) if last.isdigit() else last]
    else:
        node[int(last) if last.isdigit() else last] = value


BAD_FILES = [
    # (key path, value (... deletes), expected message after "<file>: ")
    ("joints.1.servo_max_deg", 200, "joints[1].servo_max_deg = 200 is outside 0…180"),
    ("joints.0.servo_min_deg", -5, "joints[0].servo_min_deg = -5 is outside 0…180"),
    ("joints.2.servo_min_deg", 120, "joints[2].home_servo_deg = 90 is outside 120…180"),
    ("joints.0.direction", 2, "joints[0].direction = 2 must be 1 or -1"),
    ("joints.0.direction", 0, "joints[0].direction = 0 must be 1 or -1"),
    ("joints.1.offset_deg", 720, "joints[1].offset_deg = 720 is outside -360…360"),
    ("joints.1.offset_deg", ..., "missing key joints[1].offset_deg (a number)"),
    ("joints.2.max_speed_deg_s", 0, "joints[2].max_speed_deg_s = 0 is outside 0…3600 (it must be > 0)"),
    ("joints.0.home_servo_deg", 181, "joints[0].home_servo_deg = 181 is outside 0…180"),
    ("joints.0.servo_max_dge", 170, "unknown key joints[0].servo_max_dge; expected one of name,"),
    ("joints.0.name", 3, "joints[0].name = 3 must be a string, got a whole number"),
    ("joints.2", ..., "joints has 2 entries; kind 'rrr' needs exactly 3"),
    ("geometry.upper_arm_m", 0, "geometry.upper_arm_m = 0 is outside 0…5 (a length must be > 0)"),
    ("geometry.forearm_m", -0.09, "geometry.forearm_m = -0.09 is outside 0…5 (a length must be > 0)"),
    ("geometry.forearm_m", 9.0, "geometry.forearm_m = 9.0 is outside 0…5"),
    ("geometry.upper_arm_m", math.nan, "geometry.upper_arm_m = nan is outside 0…5"),
    ("geometry.upper_arm_m", "12.5", "geometry.upper_arm_m = '12.5' must be a number, got a string"),
    ("geometry.shoulder_height_m", True, "geometry.shoulder_height_m = True must be a number, got a boolean"),
    ("geometry.forearm_m", ..., "missing key geometry.forearm_m (a number)"),
    ("geometry", ..., "missing table [geometry]"),
    ("geometry", 3, "geometry must be a table ([geometry]), got a whole number"),
    ("kind", "scara", "kind = 'scara' is unknown; expected one of rrr"),
    ("kind", ..., "missing key kind (a string)"),
    ("name", "", "name = '' must not be empty"),
    ("joints", ..., "missing array of tables [[joints]]"),
    ("color", "red", "unknown key color; expected one of name, kind, description, geometry, joints"),
]


@pytest.mark.parametrize("key_path, value, expected", BAD_FILES, ids=[f"{k}={v!r}" for k, v, _ in BAD_FILES])
def test_bad_profile_file_error_names_file_key_and_range(good_data, tmp_path, key_path, value, expected):
    data = copy.deepcopy(good_data)
    _set(data, key_path, value)
    path = write(tmp_path, data, "bad_arm.toml")
    with pytest.raises(ProfileError) as err:
        load_profile(path)
    assert str(err.value).startswith(f"{path}: "), str(err.value)
    assert expected in str(err.value), f"\n  got      {err.value}\n  expected {expected}"


def test_servo_max_below_servo_min_says_it_must_be_greater(good_data, tmp_path):
    data = copy.deepcopy(good_data)
    _set(data, "joints.2.servo_min_deg", 100)
    _set(data, "joints.2.servo_max_deg", 50)
    path = write(tmp_path, data)
    with pytest.raises(ProfileError, match=r"joints\[2\]\.servo_max_deg = 50 is outside 100…180 "
                                           r"\(it must be greater than servo_min_deg\)"):
        load_profile(path)


def test_duplicate_joint_names_are_rejected(good_data, tmp_path):
    data = copy.deepcopy(good_data)
    _set(data, "joints.2.name", "shoulder")
    with pytest.raises(ProfileError, match=r"joints\[2\]\.name = 'shoulder' is used twice"):
        load_profile(write(tmp_path, data))


def test_a_narrowed_servo_range_narrows_the_joint_limits(good_data, tmp_path):
    data = copy.deepcopy(good_data)
    _set(data, "joints.1.servo_min_deg", 10)
    _set(data, "joints.1.servo_max_deg", 170)
    prof = load_profile(write(tmp_path, data))
    assert prof.q_min[1] == pytest.approx(math.radians(10)) and prof.q_max[1] == pytest.approx(math.radians(170))


def test_optional_keys_take_their_defaults(good_data, tmp_path):
    data = copy.deepcopy(good_data)
    for key in ("servo_min_deg", "servo_max_deg", "max_speed_deg_s", "home_servo_deg"):
        del data["joints"][1][key]
    del data["description"]
    prof = load_profile(write(tmp_path, data))
    j = prof.joints[1]
    assert (j.servo_min_deg, j.servo_max_deg, j.home_servo_deg) == (0.0, 180.0, None)
    assert prof.description == "" and j.max_speed_deg_s > 0


def test_dataclasses_validate_when_built_in_code():
    with pytest.raises(ProfileError, match=r"joint 'elbow': servo_max_deg = 190 is outside 0…180"):
        JointSpec("elbow", 0, 190, 180, 1)
    with pytest.raises(ProfileError, match=r"geometry\.forearm_m = 0 is outside 0…5"):
        RRRGeometry(0.0662, 0.125, 0)
    j = JointSpec("j", 0, 180, 0, 1)
    with pytest.raises(ProfileError, match="needs 3 joints, got 2"):
        RobotProfile("x", "rrr", "", RRRGeometry(0.0662, 0.125, 0.09), (j, j))


def test_parse_profile_names_the_given_source(good_data):
    data = copy.deepcopy(good_data)
    data["kind"] = "delta"
    with pytest.raises(ProfileError, match=r"^<settings dialog>: kind = 'delta' is unknown"):
        parse_profile(data, "<settings dialog>")
