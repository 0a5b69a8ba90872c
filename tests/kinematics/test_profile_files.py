"""Robot profile files that parse as TOML but are wrong (issue 16 item 5): one ProfileError naming
the file, the key and the allowed values — never a traceback, never a silently accepted value."""
from __future__ import annotations

import re

import pytest

from core.kinematics.profile import ProfileError, list_profiles, load_profile


@pytest.fixture(scope="module")
def desk_text():
    with open(load_profile("desk_rrr").source, encoding="utf-8") as f:
        return f.read()


def write(tmp_path, text, name="arm.toml"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize("value", ["1.0", "-1.0", "1e0"])
def test_a_float_direction_is_refused_naming_file_key_and_allowed_values(tmp_path, desk_text, value):
    assert desk_text.count("\ndirection = 1\n") == 3
    path = write(tmp_path, desk_text.replace("\ndirection = 1\n", f"\ndirection = {value}\n", 1))
    with pytest.raises(ProfileError, match=re.escape(
            f"{path}: joints[0].direction = {float(value)!r} must be 1 or -1 (an integer: write `direction = 1`")):
        load_profile(path)


def test_integer_directions_both_ways_load(tmp_path, desk_text):
    path = write(tmp_path, desk_text.replace("\ndirection = 1\n", "\ndirection = -1\n", 1))
    profile = load_profile(path)
    assert [j.direction for j in profile.joints] == [-1, 1, 1]
    assert all(type(j.direction) is int for j in profile.joints)


def test_every_built_in_profile_still_loads():
    names = list_profiles()
    assert {"desk_rrr", "delta"} <= set(names)
    for name in names:
        assert load_profile(name).name


NESTED = {
    "array 600 deep": "links = " + "[" * 600 + "]" * 600,
    "inline table 600 deep": "links = " + "{a = " * 600 + "1" + "}" * 600,
}


@pytest.mark.parametrize("case", NESTED, ids=list(NESTED))
def test_a_profile_nested_too_deeply_is_a_profile_error_naming_the_file(tmp_path, desk_text, case):
    path = write(tmp_path, NESTED[case] + "\n" + desk_text)
    with pytest.raises(ProfileError, match=re.escape(f"{path}: nested too deeply")):
        load_profile(path)


def test_a_deep_value_under_a_known_key_is_a_profile_error_too(tmp_path, desk_text):
    """Dotted keys parse without recursion; the deep value then breaks the error message's repr."""
    path = write(tmp_path, desk_text.replace("\ndirection = 1\n", "\ndirection" + ".a" * 3000 + " = 1\n", 1))
    with pytest.raises(ProfileError, match=re.escape(f"{path}: ")):
        load_profile(path)
