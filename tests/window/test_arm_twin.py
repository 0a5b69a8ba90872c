"""The arm twin for every robot profile (pytest-qt, offscreen): ranges, chains, joint levels,
the delta's arms, workspace outlines with NaN rows, and the 3D factory's refusal offscreen."""
from __future__ import annotations

import math
import os

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402
import pytest  # noqa: E402
from PySide6 import QtGui, QtWidgets  # noqa: E402

import widgets  # noqa: E402,F401  (sets pyqtgraph's row-major image order)
from core.kinematics import build_kinematics, list_profiles, load_profile  # noqa: E402
from core.kinematics.profile import parse_profile  # noqa: E402
from widgets.arm_twin import (  # noqa: E402
    LEVEL_COLOURS,
    ArmTwin,
    break_lines,
    circle_outline,
    joint_levels,
    legend_entries,
    marker_entry,
    normalise_level,
    place_labels,
    profile_joint_levels,
    side_view_coords,
    workspace_outlines,
)
from widgets.arm_twin_3d import ArmTwin3D, available_3d, make_twin_3d, segment_pairs  # noqa: E402

PROFILES = ("desk_rrr", "umi_rtx", "assistive_5dof", "delta")
TWIN_W, TWIN_H = 800, 300


def close(a, b, tol=1e-9) -> bool:
    """Compare floats or sequences (NaN equal to NaN); pytest prints both sides on failure."""
    return np.allclose(np.asarray(a, dtype=float), np.asarray(b, dtype=float), atol=tol, rtol=0,
                       equal_nan=True)


@pytest.fixture(scope="module")
def solvers():
    """Each built-in profile with its solver (built once: the URDF seed banks take a moment)."""
    out = {}
    for name in PROFILES:
        profile = load_profile(name)
        out[name] = (profile, build_kinematics(profile))
    return out


@pytest.fixture
def twin(qtbot) -> ArmTwin:
    widget = ArmTwin()
    qtbot.addWidget(widget)
    widget.resize(TWIN_W, TWIN_H)
    widget.show()
    qtbot.waitExposed(widget)
    return widget


def random_in_limits(profile, n, seed=1):
    rng = np.random.default_rng(seed)
    return rng.uniform(profile.q_min, profile.q_max, (n, len(profile.joints)))


def view_ranges(twin: ArmTwin):
    """((x, y) of the top view, (s, z) of the side view) ranges in cm, as drawn."""
    return (twin.top_plot.getPlotItem().viewRange(), twin.side_plot.getPlotItem().viewRange())


def inside(values, lo_hi) -> bool:
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return bool(np.all(v >= lo_hi[0] - 1e-6) and np.all(v <= lo_hi[1] + 1e-6))


# ------------------------------------------------------------------------------- every profile
def test_the_profiles_under_test_are_the_built_in_ones():
    assert set(PROFILES) <= set(list_profiles())


@pytest.mark.parametrize("name", PROFILES)
def test_configure_for_holds_the_fk_chain_in_any_configuration_and_draws_the_workspace(
        twin, solvers, name):
    profile, kin = solvers[name]
    twin.configure_for(profile, kin)
    (x_rng, y_rng), (s_rng, z_rng) = view_ranges(twin)
    for q in [kin.q_home, *random_in_limits(profile, 25)]:
        chain = np.asarray(kin.chain_points(q))
        segments = np.asarray(kin.arm_segments(q)) if hasattr(kin, "arm_segments") else None
        twin.set_arm(chain, chain)
        twin.set_extra_segments(None if segments is None else list(segments))
        twin.set_joint_levels(profile_joint_levels(profile, q))
        x_cm, y_cm = twin._top.measured.getData()
        start = 2 if profile.kind == "delta3" else 0  # the delta's desk origin and base centre
        assert close(x_cm, chain[start:, 0] * 100) and close(y_cm, chain[start:, 1] * 100)
        s_cm, z_cm = twin._side.measured.getData()
        assert close(np.column_stack([s_cm, z_cm]),
                     side_view_coords(chain[start:], twin.azimuth) * 100, tol=1e-6)
        assert inside(x_cm, x_rng) and inside(y_cm, y_rng), (name, q)
        assert inside(s_cm, s_rng) and inside(z_cm, z_rng), (name, q)
        if segments is not None:
            ex, ey = twin._top.extra.getData()
            assert inside(ex, x_rng) and inside(ey, y_rng)
            es, ez = twin._side.extra.getData()
            assert inside(es, s_rng) and inside(ez, z_rng)
    # the workspace: a top circle and the solver's side outline, in cm
    tx, ty = twin._top.workspace.getData()
    r_max = kin.workspace_radius_range()[1]
    assert np.nanmax(np.hypot(tx, ty)) >= r_max * 100 - 1e-6
    sx, sz = twin._side.workspace.getData()
    outline = np.asarray(kin.workspace_outline_side())
    assert len(sx) >= len(outline)
    assert inside(sx, s_rng) and inside(sz[sz > 0], z_rng)
    twin.grab()


def test_umi_rtx_column_and_reach_are_on_scale(twin, solvers):
    """The UMI-RTX's column is ~1 m: the side view holds its whole travel (the old fixed
    32 cm cut it), drawn as a fixed structure from the desk."""
    profile, kin = solvers["umi_rtx"]
    twin.configure_for(profile, kin)
    _, (_, z_rng) = view_ranges(twin)
    assert z_rng[1] >= profile.q_max[0] * 100
    sx, sz = twin._side.structure.getData()
    assert close(sz, [0.0, kin.chain_points([profile.q_max[0], *kin.q_home[1:]])[1][2] * 100])


def test_reconfiguring_clears_the_previous_profiles_arm(twin, solvers):
    profile, kin = solvers["delta"]
    twin.configure_for(profile, kin)
    q = kin.q_home
    twin.set_arm(kin.chain_points(q), kin.chain_points(q))
    twin.set_extra_segments(list(kin.arm_segments(q)))
    twin.set_joint_levels(["ok"] * 3)
    profile, kin = solvers["desk_rrr"]
    twin.configure_for(profile, kin)
    assert len(twin._top.measured.getData()[0] or []) == 0
    assert len(twin._top.extra.getData()[0]) == 0
    assert twin.joint_levels() is None and twin.joint_dots() == []
    assert len(twin._top.structure.getData()[0]) == 0  # no base plate for a serial arm


# ------------------------------------------------------------------------------- joint levels
def test_joint_levels_warn_within_10_percent_and_limit_within_2_percent_of_the_range():
    q_min, q_max = (0.0, -1.0, 0.0, 0.0), (10.0, 1.0, 0.1, 1.0)
    q = (5.0, 0.95, 0.0015, float("nan"))  # mid, 2.5 % from the top, 1.5 % from the bottom, NaN
    assert joint_levels(q, q_min, q_max) == ["ok", "warn", "limit", "ok"]
    assert joint_levels(None, q_min, q_max) == ["ok"] * 4
    assert joint_levels((9.5, -1.0, 0.1, 0.15), q_min, q_max) == ["warn", "limit", "limit", "ok"]


def test_profile_joint_levels_use_the_profiles_limits_in_joint_units(solvers):
    profile, _ = solvers["umi_rtx"]  # column in m, the rest in rad
    lo, hi = np.array(profile.q_min), np.array(profile.q_max)
    q = 0.5 * (lo + hi)
    q[0] = hi[0] - 0.05 * (hi[0] - lo[0])  # column 5 % below its top: warn
    q[2] = lo[2] + 0.01 * (hi[2] - lo[2])  # elbow 1 % above its bottom: limit
    assert profile_joint_levels(profile, q) == ["warn", "ok", "limit", "ok", "ok", "ok"]


def test_levels_accept_the_joint_readouts_spelling_and_refuse_others():
    assert [normalise_level(v) for v in ("ok", "near", "at", "warn", "limit")] == [
        "ok", "warn", "limit", "warn", "limit"]
    with pytest.raises(ValueError, match="ok, warn, limit"):
        normalise_level("red")


def dot_colours(twin: ArmTwin, view: str = "top") -> list[tuple[int, int, int]]:
    item = (twin._top if view == "top" else twin._side).joints
    return [p.brush().color().getRgb()[:3] for p in item.points()]


@pytest.mark.parametrize("name", PROFILES)
def test_joint_dots_sit_on_their_joints_and_take_the_level_colours(twin, solvers, name):
    profile, kin = solvers[name]
    twin.configure_for(profile, kin)
    n = len(profile.joints)
    q = np.array(kin.q_home, dtype=float)
    chain = np.asarray(kin.chain_points(q))
    segments = np.asarray(kin.arm_segments(q)) if hasattr(kin, "arm_segments") else None
    twin.set_arm(chain, chain)
    twin.set_extra_segments(None if segments is None else list(segments))
    levels = (["limit", "warn", "ok"] * n)[:n]
    twin.set_joint_levels(levels)
    dots = twin.joint_dots("top")
    assert len(dots) == n
    # worst last: no red dot is drawn under another joint's
    order = [("ok", "warn", "limit").index(level) for _, _, level in dots]
    assert order == sorted(order)
    # each joint's dot is on its joint: the RRR's base, shoulder and elbow; a URDF joint's
    # origin (from Pinocchio); the delta arm's shoulder
    if profile.kind == "rrr":
        joints_at = [(0.0, 0.0, 0.0), (0.0, 0.0, profile.geometry.shoulder_height_m), chain[2]]
    elif profile.kind == "urdf":
        data = kin.model.createData()
        pin.forwardKinematics(kin.model, data, q)
        joints_at = [data.oMi[i + 1].translation for i in range(n)]
    else:
        joints_at = [segments[i][0] for i in range(n)]
    side = twin.joint_dots("side")
    key = lambda d: (*np.round(d[:4], 6), d[4])  # noqa: E731 (wrist joints share a point)
    got = sorted(((x, y, s_, z, level) for (x, y, level), (s_, z, _) in zip(dots, side)), key=key)
    sz = side_view_coords(np.array(joints_at, dtype=float), twin.azimuth) * 100
    want = sorted(((p[0] * 100, p[1] * 100, s_, z, level)
                   for p, (s_, z), level in zip(joints_at, sz, levels)), key=key)
    assert [g[4] for g in got] == [w[4] for w in want], name
    assert close([g[:4] for g in got], [w[:4] for w in want], tol=1e-6), name
    colours = dot_colours(twin)
    assert colours == [LEVEL_COLOURS[level][:3] for _, _, level in dots]
    assert len(twin.joint_dots("side")) == n
    twin.set_joint_levels(None)
    assert twin.joint_dots() == []


def test_joint_dots_follow_the_measured_arm_and_hide_without_it(twin, solvers):
    profile, kin = solvers["desk_rrr"]
    twin.configure_for(profile, kin)
    twin.set_joint_levels(["ok", "warn", "limit"])
    assert twin.joint_dots() == []  # no measured arm yet
    q = (1.0, 0.5, -0.5)
    chain = kin.chain_points(q)
    twin.set_arm(None, chain)
    elbow = [d for d in twin.joint_dots() if d[2] == "limit"][0]
    assert close(elbow[:2], chain[2][:2] * 100)
    twin.set_arm(chain, None)
    assert twin.joint_dots() == []


def test_joint_levels_from_the_joint_readout_colour_the_twin(twin, solvers):
    profile, kin = solvers["desk_rrr"]
    twin.configure_for(profile, kin)
    twin.set_arm(None, kin.chain_points(kin.q_home))
    twin.set_joint_levels(["at", "near", "ok"])  # JointReadout.levels()
    assert sorted(d[2] for d in twin.joint_dots()) == ["limit", "ok", "warn"]


# ------------------------------------------------------------------------------- delta
def test_delta_draws_its_three_arms_in_a_fixed_side_plane(twin, solvers):
    profile, kin = solvers["delta"]
    twin.configure_for(profile, kin)
    arm0 = profile.geometry.arm_azimuths_rad[0]
    assert close(twin.azimuth, arm0)
    q = (1.2, 0.2, -0.3)  # effector off the axis: a tool-following plane would turn
    segments = np.asarray(kin.arm_segments(q))
    twin.set_arm(kin.chain_points(q), kin.chain_points(q))
    twin.set_extra_segments(list(segments))
    assert close(twin.azimuth, arm0)
    x, y = twin._top.extra.getData()
    assert len(x) == 3 * 4 + 2 and np.isnan(x).sum() == 2  # three chains, NaN between them
    finite = np.isfinite(x)
    assert close(np.column_stack([x[finite], y[finite]]), segments.reshape(-1, 3)[:, :2] * 100)
    assert twin._top.extra.opts["connect"] == "finite"
    s, z = twin._side.extra.getData()
    assert close(np.column_stack([s[finite], z[finite]]),
                 side_view_coords(segments.reshape(-1, 3), arm0) * 100)
    # the base plate: a closed triangle through the shoulders
    px, py = twin._top.structure.getData()
    assert close(np.column_stack([px, py])[:3], segments[:, 0, :2] * 100)
    twin.set_extra_segments(None)
    assert len(twin._top.extra.getData()[0]) == 0
    twin.grab()


def test_a_pinned_side_plane_can_be_released(twin):
    twin.set_side_azimuth(0.3)
    tool_on_y = np.array([[0, 0, 0], [0.0, 0.2, 0.1]])
    twin.set_arm(None, tool_on_y)
    assert close(twin.azimuth, 0.3)
    twin.set_side_azimuth(None)
    assert close(twin.azimuth, math.pi / 2)


# ------------------------------------------------------------------------------- outlines
def folded_elbow_rrr():
    """desk_rrr with an elbow range of ±90°: the outline gains an arc after a NaN row."""
    with open(load_profile("desk_rrr").source, "rb") as f:
        data = tomllib.load(f)
    data["joints"][2]["offset_deg"] = 90
    data["joints"][2]["home_servo_deg"] = 90
    profile = parse_profile(data, "folded_elbow.toml")
    return profile, build_kinematics(profile)


def test_an_outline_with_nan_rows_is_drawn_in_pieces_and_not_closed_across_them(twin):
    profile, kin = folded_elbow_rrr()
    outline = np.asarray(kin.workspace_outline_side())
    assert np.isnan(outline).any(axis=1).sum() == 1
    twin.configure_for(profile, kin)
    s, z = twin._side.workspace.getData()
    assert len(s) == len(outline)  # nothing appended: the arc is not joined back to the start
    assert close(np.column_stack([s, z]), outline * 100)
    assert twin._side.workspace.opts["connect"] == "finite"
    twin.grab()


def test_an_outline_without_nan_rows_is_closed(twin):
    square = np.array([[0.0, 0.0], [0.1, 0.0], [0.1, 0.1], [0.0, 0.1]])
    twin.set_workspace(square, square)
    x, y = twin._side.workspace.getData()
    assert len(x) == 5 and close((x[-1], y[-1]), (0.0, 0.0))


def test_top_outline_has_an_inner_circle_only_when_the_tool_cannot_reach_the_axis(solvers):
    class Ring:  # a solver whose tool stays 10…30 cm from the axis
        def workspace_radius_range(self):
            return (0.10, 0.30)

        def workspace_outline_side(self):
            return np.array([[0.10, 0.0], [0.30, 0.0], [0.30, 0.2], [0.10, 0.2], [0.10, 0.0]])

    top, _ = workspace_outlines(Ring())
    radii = np.hypot(top[:, 0], top[:, 1])
    assert np.isnan(radii).sum() == 1
    assert close(np.nanmax(radii), 0.30) and close(np.nanmin(radii), 0.10)
    profile, kin = solvers["desk_rrr"]  # its radius range starts at the shoulder, not the axis
    top, side = workspace_outlines(kin, profile)
    assert not np.isnan(top).any() and close(np.hypot(*top[0]), kin.workspace_radius_range()[1])
    assert close(circle_outline([1.0])[0], circle_outline([1.0])[-1])


# ------------------------------------------------------------------------------- 3D fallback
def test_make_twin_3d_returns_none_offscreen_without_touching_opengl(qapp):
    assert QtGui.QGuiApplication.platformName() == "offscreen"
    ok, reason = available_3d()
    assert not ok and "offscreen" in reason
    assert make_twin_3d() is None
    with pytest.raises(RuntimeError, match="offscreen"):
        ArmTwin3D()


def test_available_3d_can_be_switched_off(qapp, monkeypatch):
    monkeypatch.setenv("DESKARM_NO_3D", "1")
    ok, reason = available_3d()
    assert not ok and "DESKARM_NO_3D" in reason


def test_segment_pairs_split_polylines_at_nan_rows():
    pts = np.array([[0, 0, 0], [1, 0, 0], [np.nan] * 3, [2, 0, 0], [3, 0, 0], [4, 0, 0]], float)
    pairs = segment_pairs(pts)
    assert close(pairs[:, 0], [0, 1, 2, 3, 3, 4])
    assert segment_pairs(None).shape == (0, 3)


def test_joint_readout_names_each_rows_unit_for_mixed_arms(qtbot, solvers):
    from widgets.joint_readout import JointReadout

    profile, _ = solvers["umi_rtx"]
    readout = JointReadout()
    qtbot.addWidget(readout)
    lo = [j.to_display(j.q_min) for j in profile.joints]
    hi = [j.to_display(j.q_max) for j in profile.joints]
    readout.set_joints(profile.joint_names, lo, hi, [j.display_unit for j in profile.joints])
    texts = [w.text() for w in readout.findChildren(QtWidgets.QLabel)]
    assert "cmd" in texts and "cmd °" not in texts
    assert f"{lo[0]:.0f}…{hi[0]:.0f} mm" in texts and f"{lo[1]:.0f}…{hi[1]:.0f} °" in texts
    readout.set_joints(["a", "b"], [0, 0], [180, 180], ["deg", "deg"])  # all degrees: as before
    texts = [w.text() for w in readout.findChildren(QtWidgets.QLabel)]
    assert "cmd °" in texts
    with pytest.raises(ValueError, match="one unit per joint"):
        readout.set_joints(["a"], [0], [1], ["mm", "deg"])


# ------------------------------------------------------------------------------- text layout (pure)
def rects_of(corners, sizes):
    return [(x, y, x + w, y + h) for (x, y), (w, h) in zip(corners, sizes)]


def overlap(a, b) -> bool:
    return min(a[2], b[2]) > max(a[0], b[0]) and min(a[3], b[3]) > max(a[1], b[1])


def test_break_lines_fills_lines_between_entries_and_breaks_an_entry_only_when_wider_than_a_line():
    entries = [[30.0], [30.0, 10.0], [50.0], [200.0], [20.0, 20.0, 20.0, 20.0]]  # words (px)
    # word gap 2, entry gap 6: 30 | 30+2+10 = 42 → 30+6+42 = 78 ≤ 100; +6+50 > 100
    lines = break_lines(entries, 100.0, 6.0, 2.0)
    assert lines[0] == [(0, 0, 1), (1, 0, 2)]
    assert lines[1] == [(2, 0, 1)]
    assert lines[2] == [(3, 0, 1)]  # a single word wider than the line: alone, not dropped
    assert [span for line in lines[3:] for span in line] == [(4, 0, 4)]  # 86 px fits a line
    narrow = break_lines([[20.0, 20.0, 20.0, 20.0]], 50.0, 6.0, 2.0)
    assert narrow == [[(0, 0, 2)], [(0, 2, 4)]]  # broken between its words, every word kept
    assert break_lines([], 100.0, 6.0, 2.0) == []


def test_marker_entries_carry_the_id_and_position_in_cm_and_replace_the_plain_markers_entry():
    words = marker_entry(23, (0.031, 0.152, -0.0001))
    plain = QtGui.QTextDocumentFragment.fromHtml(" ".join(words)).toPlainText().replace("\u00a0", " ")
    assert plain == "■ 23: x 3.1 y 15.2 z 0.0 cm"
    assert len(words) == 4  # "■ 23:", "x 3.1", "y 15.2", "z 0.0 cm": a break never splits a pair
    plain_entries = legend_entries("measured")
    with_markers = legend_entries("measured", [words])
    assert plain_entries[:-1] == with_markers[:-1] and with_markers[-1] == words


def test_place_labels_prefers_the_upper_right_and_flips_inside_at_the_edges():
    size = (20.0, 10.0)
    bounds = (0.0, 0.0, 200.0, 100.0)
    (x, y), = place_labels([(100.0, 50.0)], [size], bounds, gap=2.0)
    assert (x, y) == (102.0, 38.0)  # upper right of the dot
    for anchor in [(199.0, 50.0), (100.0, 1.0), (1.0, 99.0), (199.0, 1.0), (0.0, 0.0)]:
        (x, y), = place_labels([anchor], [size], bounds, gap=2.0)
        assert bounds[0] <= x and x + size[0] <= bounds[2], anchor
        assert bounds[1] <= y and y + size[1] <= bounds[3], anchor
    (x, _), = place_labels([(199.0, 50.0)], [size], bounds, gap=2.0)
    assert x + size[0] <= 199.0  # flipped to the left of a dot at the right edge
    (_, y), = place_labels([(100.0, 1.0)], [size], bounds, gap=2.0)
    assert y >= 1.0  # below a dot at the top edge


def test_place_labels_keeps_close_labels_apart():
    """Ids 50 and 23 at almost the same place were drawn over each other ("5023")."""
    anchors = [(100.0, 60.0), (103.0, 61.0), (101.0, 58.0), (140.0, 60.0)]
    sizes = [(17.0, 16.0), (17.0, 16.0), (10.0, 16.0), (24.0, 16.0)]
    bounds = (0.0, 0.0, 200.0, 120.0)
    rects = rects_of(place_labels(anchors, sizes, bounds), sizes)
    for i, a in enumerate(rects):
        assert bounds[0] <= a[0] and a[2] <= bounds[2] and bounds[1] <= a[1] and a[3] <= bounds[3]
        for b in rects[i + 1:]:
            assert not overlap(a, b), (a, b)


# ------------------------------------------------------------------------- workspace drawing
def boxed_desk_rrr(solvers, margin=0.02):
    """desk_rrr with two keep-out boxes: a mug in front right, a monitor straight ahead."""
    from dataclasses import replace

    from core.kinematics.profile import KeepOutBox, WorkspaceSpec

    profile, kin = solvers["desk_rrr"]
    boxes = (KeepOutBox("mug", (0.06, 0.06, 0.0), (0.12, 0.14, 0.09)),
             KeepOutBox("monitor", (-0.05, 0.18, 0.0), (0.05, 0.22, 0.3)))
    return replace(profile, workspace=WorkspaceSpec(margin, boxes)), kin


def test_keep_out_boxes_are_drawn_in_the_top_view_and_cut_by_the_arm_plane_in_the_side_view(twin, solvers):
    profile, kin = boxed_desk_rrr(solvers)
    twin.configure_for(profile, kin)
    top = twin.keep_out_outlines("top")
    rows = [r for r in top if np.isfinite(r).all()]
    assert close(rows[:5], [(6, 6), (12, 6), (12, 14), (6, 14), (6, 6)])  # the mug's footprint, cm
    assert close(rows[5:], [(-5, 18), (5, 18), (5, 22), (-5, 22), (-5, 18)])
    assert twin.desk_margin_line_cm() == pytest.approx(2.0)
    twin.set_side_azimuth(math.pi / 2)  # straight ahead: the plane cuts the monitor only
    side = twin.keep_out_outlines("side")
    assert close(side, [(18, 0), (22, 0), (22, 30), (18, 30), (18, 0)])
    a = math.atan2(0.1, 0.09)
    twin.set_side_azimuth(a)  # through the mug (and not the monitor)
    c, sn = math.cos(a), math.sin(a)
    s0, s1 = 100 * max(0.06 / c, 0.06 / sn), 100 * min(0.12 / c, 0.14 / sn)  # where the plane enters, leaves
    assert close(twin.keep_out_outlines("side"), [(s0, 0), (s1, 0), (s1, 9), (s0, 9), (s0, 0)], 1e-6)


def test_a_profile_without_boxes_draws_none_and_reconfiguring_clears_them(twin, solvers):
    profile, kin = boxed_desk_rrr(solvers)
    twin.configure_for(profile, kin)
    assert len(twin.keep_out_outlines("top")) > 0
    plain, plain_kin = solvers["desk_rrr"]
    twin.configure_for(plain, plain_kin)
    assert len(twin.keep_out_outlines("top")) == 0 and len(twin.keep_out_outlines("side")) == 0
    assert twin.desk_margin_line_cm() == pytest.approx(0.5)  # the default 5 mm margin


def test_the_side_sections_are_recomputed_only_when_the_arm_plane_turns(twin, solvers, monkeypatch):
    profile, kin = boxed_desk_rrr(solvers)
    twin.configure_for(profile, kin)
    q = np.array(kin.q_home)
    twin.set_arm(kin.chain_points(q), kin.chain_points(q))
    calls = []
    original = twin._side.keep_out.setData
    monkeypatch.setattr(twin._side.keep_out, "setData", lambda *a, **k: (calls.append(1), original(*a, **k)))
    q2 = q + (0.0, 0.05, 0.0)  # same azimuth, arm lifted
    twin.set_arm(kin.chain_points(q2), kin.chain_points(q2))
    assert calls == []
    q3 = q + (0.8, 0.0, 0.0)  # turned towards the mug
    twin.set_arm(kin.chain_points(q3), kin.chain_points(q3))
    assert calls == [1]


def test_box_side_section_is_none_when_the_plane_misses_the_box():
    from widgets.arm_twin import box_side_section

    assert box_side_section((0.1, 0.1, 0.0), (0.2, 0.2, 0.1), -math.pi / 2) is None  # looking back
    assert box_side_section((0.1, -0.1, 0.0), (0.2, 0.1, 0.1), 0.0) is not None
    assert box_side_section((0.1, 0.1, 0.0), (0.2, 0.2, 0.1), 0.0) is None  # beside the +x plane


def test_box_edges_are_the_twelve_edges_of_the_box():
    from widgets.arm_twin_3d import box_edges

    e = box_edges((0, 0, 0), (1, 2, 3))
    lengths = sorted(float(np.linalg.norm(e[i] - e[i + 1])) for i in range(0, 24, 2))
    assert e.shape == (24, 3) and lengths == [1.0] * 4 + [2.0] * 4 + [3.0] * 4
