"""The profile's [workspace] (desk margin, keep-out boxes) and [tool_marker] tables: defaults,
the built-in values, and one ProfileError naming the file and the key for every bad value."""
from __future__ import annotations

import re
from dataclasses import replace

import pytest

from core.kinematics.profile import (
    JointSpec,
    KeepOutBox,
    ProfileError,
    RobotProfile,
    RRRGeometry,
    ToolMarkerSpec,
    WorkspaceSpec,
    list_profiles,
    load_profile,
)

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

BOX = '\n[[workspace.keep_out]]\nname = "monitor"\nmin = [-0.3, 0.25, 0.0]\nmax = [0.3, 0.4, 0.4]\n'


@pytest.fixture(scope="module")
def desk_text():
    with open(load_profile("desk_rrr").source, encoding="utf-8") as f:
        return f.read()


def without_tables(text: str) -> str:
    """desk_rrr.toml without its [workspace] and [tool_marker] tables (they come last)."""
    return text[: text.index("\n# Where the arm may go")] + "\n"


def write(tmp_path, text, name="arm.toml"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_desk_rrr_has_the_tool_marker_and_the_default_margin_and_no_boxes():
    p = load_profile("desk_rrr")
    assert p.tool_marker == ToolMarkerSpec(marker_id=7, offset_m=(0.0, 0.0, 0.012), size_m=0.03)
    assert p.workspace == WorkspaceSpec(desk_margin_m=0.005, keep_out=())


def test_every_built_in_profile_has_a_workspace_even_without_the_table():
    for name in list_profiles():
        ws = load_profile(name).workspace
        assert isinstance(ws, WorkspaceSpec) and 0.0 <= ws.desk_margin_m <= 0.1


def test_profiles_built_in_code_keep_working_with_the_defaults():
    joints = tuple(JointSpec(name=n, servo_min_deg=0, servo_max_deg=180, offset_deg=0, direction=1)
                   for n in ("a", "b", "c"))
    p = RobotProfile("x", "rrr", "", RRRGeometry(0.06, 0.12, 0.09), joints)
    assert p.workspace == WorkspaceSpec() and p.workspace.desk_margin_m == 0.005 and p.tool_marker is None
    boxed = replace(p, workspace=WorkspaceSpec(0.01, (KeepOutBox("lamp", (0, 0, 0), (0.1, 0.1, 0.1)),)))
    assert boxed.workspace.keep_out[0].max_m == (0.1, 0.1, 0.1)


def test_the_commented_example_box_in_desk_rrr_parses_when_uncommented(tmp_path, desk_text):
    example = "\n".join(line[2:] if line.startswith("# [[workspace.keep_out]]") or
                        (line.startswith("# ") and line[2:].split(" ")[0] in ("name", "min", "max"))
                        else line for line in desk_text.splitlines())
    p = load_profile(write(tmp_path, example))
    assert p.workspace.keep_out == (KeepOutBox("monitor", (-0.30, 0.25, 0.0), (0.30, 0.40, 0.40)),)


def test_a_workspace_table_with_boxes_loads(tmp_path, desk_text):
    text = without_tables(desk_text) + "\n[workspace]\ndesk_margin_m = 0.02\n" + BOX + BOX.replace("monitor", "lamp")
    ws = load_profile(write(tmp_path, text)).workspace
    assert ws.desk_margin_m == 0.02 and [b.name for b in ws.keep_out] == ["monitor", "lamp"]
    no_margin = load_profile(write(tmp_path, without_tables(desk_text) + BOX, "b.toml")).workspace
    assert no_margin.desk_margin_m == 0.005 and len(no_margin.keep_out) == 1  # the default margin


BAD_WORKSPACE = [
    ("[workspace]\ndesk_margin_m = 0.2\n", "workspace.desk_margin_m = 0.2 is outside 0…0.1"),
    ("[workspace]\ndesk_margin_m = -0.001\n", "workspace.desk_margin_m = -0.001 is outside 0…0.1"),
    ("[workspace]\ndesk_margin_m = nan\n", "workspace.desk_margin_m = nan is outside 0…0.1"),
    ("[workspace]\ndesk_margin_m = true\n", "workspace.desk_margin_m = True must be a number"),
    ("[workspace]\nmargin = 0.01\n", "unknown key workspace.margin; expected one of desk_margin_m, keep_out"),
    ("workspace = 3\n", "workspace must be a table ([workspace]), got a whole number"),
    (BOX.replace("max = [0.3, 0.4, 0.4]", "max = [0.3, 0.2, 0.4]"),
     "workspace.keep_out[0].max y = 0.2 must be greater than min y = 0.25"),
    (BOX.replace("max = [0.3, 0.4, 0.4]", "max = [0.3, 0.4, 6.0]"),
     "workspace.keep_out[0].max z = 6.0 is outside -5…5"),
    (BOX.replace("min = [-0.3, 0.25, 0.0]", "min = [-inf, 0.25, 0.0]"),
     "workspace.keep_out[0].min x = -inf is outside -5…5"),
    (BOX.replace("min = [-0.3, 0.25, 0.0]", "min = [-0.3, 0.25]"),
     "workspace.keep_out[0].min = [-0.3, 0.25] must be three numbers [x, y, z], got an array"),
    (BOX.replace("min = [-0.3, 0.25, 0.0]", 'min = "low"'),
     "workspace.keep_out[0].min = 'low' must be three numbers [x, y, z], got a string"),
    (BOX.replace('name = "monitor"\n', ""), "missing key workspace.keep_out[0].name (a string)"),
    (BOX.replace('name = "monitor"', 'name = " "'), "workspace.keep_out[0].name = ' ' must be a non-empty string"),
    (BOX.replace("max = [0.3, 0.4, 0.4]\n", ""), "missing key workspace.keep_out[0].max (three numbers"),
    (BOX + BOX, "workspace.keep_out[1].name = 'monitor' is used twice"),
    (BOX + "size = 1\n", "unknown key workspace.keep_out[0].size; expected one of name, min, max"),
    ("[workspace]\nkeep_out = 1\n", "workspace.keep_out must be an array of tables ([[workspace.keep_out]])"),
]


@pytest.mark.parametrize("table, message", BAD_WORKSPACE, ids=[m for _, m in BAD_WORKSPACE])
def test_a_bad_workspace_value_is_refused_naming_file_and_key(tmp_path, desk_text, table, message):
    base = without_tables(desk_text)
    # a bare key belongs to the table above it: put it first, where it is a top-level key
    text = table + base if table.startswith("workspace =") else base + "\n" + table
    path = write(tmp_path, text)
    with pytest.raises(ProfileError, match=re.escape(f"{path}: {message}")):
        load_profile(path)


MARKER = "[tool_marker]\nid = 7\noffset_m = [0.0, 0.0, 0.012]\nsize_m = 0.03\n"
BAD_MARKER = [
    (MARKER.replace("id = 7", "id = 1000"), "tool_marker.id = 1000 must be an integer 0…999"),
    (MARKER.replace("id = 7", "id = -1"), "tool_marker.id = -1 must be an integer 0…999"),
    (MARKER.replace("id = 7", "id = 7.0"), "tool_marker.id = 7.0 must be an integer 0…999"),
    (MARKER.replace("id = 7", "id = true"), "tool_marker.id = True must be an integer 0…999"),
    (MARKER.replace("id = 7\n", ""), "missing key tool_marker.id (an integer 0…999)"),
    (MARKER.replace("0.012]", "0.3]"), "tool_marker.offset_m z = 0.3 is outside -0.2…0.2"),
    (MARKER.replace("[0.0, 0.0, 0.012]", "[0.0, 0.012]"), "tool_marker.offset_m = [0.0, 0.012] must be three numbers"),
    (MARKER.replace("size_m = 0.03", "size_m = 0.001"), "tool_marker.size_m = 0.001 is outside 0.005…0.2"),
    (MARKER.replace("size_m = 0.03", "size_m = 0.5"), "tool_marker.size_m = 0.5 is outside 0.005…0.2"),
    (MARKER.replace("size_m = 0.03\n", ""), "missing key tool_marker.size_m (a number)"),
    (MARKER + "colour = 1\n", "unknown key tool_marker.colour; expected one of id, offset_m, size_m"),
]


@pytest.mark.parametrize("table, message", BAD_MARKER, ids=[m for _, m in BAD_MARKER])
def test_a_bad_tool_marker_value_is_refused_naming_file_and_key(tmp_path, desk_text, table, message):
    path = write(tmp_path, without_tables(desk_text) + "\n" + table)
    with pytest.raises(ProfileError, match=re.escape(f"{path}: {message}")):
        load_profile(path)


def test_the_dataclasses_validate_values_built_in_code_too():
    with pytest.raises(ProfileError, match=re.escape("keep-out box 'b': max x = 0.0 must be greater than min x = 0.0")):
        KeepOutBox("b", (0, 0, 0), (0, 1, 1))
    with pytest.raises(ProfileError, match=re.escape("workspace.desk_margin_m = 1.0 is outside 0…0.1")):
        WorkspaceSpec(desk_margin_m=1.0)
    with pytest.raises(ProfileError, match=re.escape("tool_marker.size_m = 0.0 is outside 0.005…0.2")):
        ToolMarkerSpec(1, (0, 0, 0), 0.0)


def test_a_tool_marker_on_a_urdf_profile_loads(tmp_path):
    with open(load_profile("umi_rtx").source, encoding="utf-8") as f:
        text = f.read()
    urdf = load_profile("umi_rtx").geometry.urdf_path
    text = text.replace('urdf = "umi_rtx.urdf"', f"urdf = {urdf!r}".replace("'", '"'))
    data = tomllib.loads(text + "\n" + MARKER.replace("id = 7", "id = 12"))
    from core.kinematics.profile import parse_profile

    p = parse_profile(data, "umi.toml")
    assert p.tool_marker.marker_id == 12 and p.tool_marker.offset_m == (0.0, 0.0, 0.012)
