"""Workspace safety: the desk plane and keep-out boxes, checked on the whole arm (every moving
point and every segment), enforced in the control step for every solver and goal source."""
from __future__ import annotations

import itertools
import math
from collections import Counter
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.clock import SimClock
from core.kinematics import build_kinematics, load_profile
from core.kinematics.profile import KeepOutBox, WorkspaceSpec
from core.messages import Goal, MarkerObservation, PerceptionResult, TargetMode
from core.motion.control import ArmController
from core.motion.grab_task import GrabParams, GrabTask
from core.motion.safety import (
    arm_layout,
    clamp_to_limits,
    is_within_limits,
    limit_to_workspace,
    segment_hits_box,
    workspace_violation,
)
from core.motion.targeting import Targeter
from core.settings import LissajousParams

NAMES = ("desk_rrr", "umi_rtx", "assistive_5dof", "delta")
BASE = {name: load_profile(name) for name in NAMES}
# one box per arm, inside its reach and clear of its home pose: a mug, a monitor, a lamp, a part
BOXES = {
    "desk_rrr": KeepOutBox("mug", (0.06, 0.06, 0.0), (0.12, 0.14, 0.09)),
    "umi_rtx": KeepOutBox("monitor", (0.2, 0.2, 0.0), (0.5, 0.3, 0.5)),
    "assistive_5dof": KeepOutBox("lamp", (0.15, 0.15, 0.0), (0.35, 0.3, 0.3)),
    "delta": KeepOutBox("part", (0.05, -0.05, 0.0), (0.12, 0.05, 0.06)),
}
PROFILES = {n: replace(p, workspace=WorkspaceSpec(0.005, (BOXES[n],))) for n, p in BASE.items()}
KINS = {n: build_kinematics(p) for n, p in PROFILES.items()}
REACH_M = {"desk_rrr": 0.3, "umi_rtx": 0.9, "assistive_5dof": 0.8, "delta": 0.4}
# how many chain points (from the start) are the mount, written out here rather than derived, so
# the independent check below does not share the implementation's sampling
MOUNT_POINTS = {"desk_rrr": 2, "umi_rtx": 1, "assistive_5dof": 3, "delta": 3}
SEGMENT_SAMPLES = 41
STATS: Counter = Counter()


def independent_violation(name: str, q, ws: WorkspaceSpec) -> str:
    """A brute-force check: moving points above the margin, segments sampled against the boxes."""
    kin = KINS[name]
    chain = np.asarray(kin.chain_points(q), dtype=float)
    m = MOUNT_POINTS[name]
    polylines = [(chain[m - 1:], 1)]  # the segment from the last mount point on moves
    if hasattr(kin, "arm_segments"):
        polylines += [(arm, 1) for arm in np.asarray(kin.arm_segments(q), dtype=float)]
    t = np.linspace(0.0, 1.0, SEGMENT_SAMPLES)[:, None]
    for pts, first_moving in polylines:
        if not np.isfinite(pts).all():
            return "not finite"
        low = pts[first_moving:, 2].min()
        if low < ws.desk_margin_m - 1e-9:  # FK rounding at the margin
            return f"point at z = {low}"
        for a, b in itertools.pairwise(pts):
            samples = a + t * (b - a)
            for box in ws.keep_out:
                inside = np.all((samples > np.array(box.min_m) + 1e-9) & (samples < np.array(box.max_m) - 1e-9), axis=1)
                if inside.any():
                    return f"in {box.name}"
    return ""


def tool_z(name, q) -> float:
    return float(KINS[name].fk(q)[2])


# --------------------------------------------------------------------------------------------
# Pieces


@pytest.mark.parametrize("a, b, hit", [
    ((-1, 0.5, 0.5), (2, 0.5, 0.5), True),   # straight through
    ((-1, 2.0, 0.5), (2, 2.0, 0.5), False),  # parallel, outside one slab
    ((0.5, 0.5, 0.5), (0.5, 0.5, 0.5), True),  # a point inside
    ((1.5, 0.5, 0.5), (1.5, 0.5, 0.5), False),  # a point outside
    ((-1, -1, -1), (-0.1, -0.1, -0.1), False),  # stops short
    ((-1, -1, -1), (0.0, 0.0, 0.0), True),  # touches the corner (closed box)
    ((3, -0.5, 0.5), (-0.5, 3, 0.5), False),  # passes by the corner diagonally
    ((2, -1, 0.5), (-1, 2, 0.5), True),  # cuts the corner diagonally
    ((0.5, 0.5, 2), (0.5, 0.5, 0.9), True),  # ends inside
    ((0.0, 0.0, math.nan), (1, 1, 1), True),  # unknown is unsafe
])
def test_segment_box_intersection_uses_the_slab_method(a, b, hit):
    assert segment_hits_box(a, b, (0, 0, 0), (1, 1, 1)) is hit
    assert segment_hits_box(b, a, (0, 0, 0), (1, 1, 1)) is hit


def test_the_mount_is_found_and_the_points_and_segments_have_names():
    rrr = arm_layout(PROFILES["desk_rrr"], KINS["desk_rrr"])
    assert rrr.chain_fixed == (True, True, False, False)
    assert rrr.chain_names == ("base", "shoulder", "elbow", "tool")
    assert rrr.chain_segment_names == ("base column", "upper arm", "forearm")
    for name in NAMES:
        layout = arm_layout(PROFILES[name], KINS[name])
        assert sum(layout.chain_fixed) == MOUNT_POINTS[name] and not any(layout.chain_fixed[MOUNT_POINTS[name]:])
    umi = arm_layout(PROFILES["umi_rtx"], KINS["umi_rtx"])
    assert umi.chain_segment_names[2:4] == ("upper_arm", "forearm") and umi.chain_names[-1] == "tool"
    delta = arm_layout(PROFILES["delta"], KINS["delta"])
    assert [row[0] for row in delta.arms_fixed] == [True] * 3 and not any(any(r[1:]) for r in delta.arms_fixed)


def test_every_home_pose_is_clear():
    for name in NAMES:
        assert workspace_violation(KINS[name].q_home, PROFILES[name], KINS[name]) == "", name


def test_a_tool_below_the_desk_is_named_with_its_height():
    p, k = PROFILES["desk_rrr"], KINS["desk_rrr"]
    q = (math.pi / 2, 0.0, -1.5)  # upper arm level, forearm folded down through the desk
    z = tool_z("desk_rrr", q)
    assert z < 0
    assert workspace_violation(q, p, k) == f"below the desk: tool at z = {z * 1e3:.0f} mm"


def test_within_the_margin_says_so_and_a_bigger_margin_catches_more():
    p, k = PROFILES["desk_rrr"], KINS["desk_rrr"]
    q = (math.pi / 2, 0.2, -1.0)
    z = tool_z("desk_rrr", q)
    assert 0.0 < z < 0.05
    assert workspace_violation(q, p, k) == ""
    assert workspace_violation(q, p, k, WorkspaceSpec(desk_margin_m=0.05)).startswith(
        f"below the desk: tool at z = {z * 1e3:.0f} mm (margin 50 mm)")


def test_the_base_on_the_desk_is_exempt_but_the_elbow_is_not():
    """With a 0.1 m margin the assistive arm's mount (base at z = 0, turret 0.05, shoulder 0.15)
    is never a violation; its elbow, lowered to 0.09 m, is."""
    p, k = PROFILES["assistive_5dof"], KINS["assistive_5dof"]
    q = list(k.q_home)
    q[1] = -0.2  # shoulder at its lower limit: upper arm slightly below horizontal
    q[2] = 0.0
    q[3] = 0.0
    elbow_z = float(k.chain_points(q)[3][2])
    assert 0.0 < elbow_z < 0.1
    reason = workspace_violation(q, p, k, WorkspaceSpec(desk_margin_m=0.1))
    assert reason.startswith("below the desk: ") and reason != ""
    assert workspace_violation(k.q_home, p, k, WorkspaceSpec(desk_margin_m=0.1)) == ""  # home: base exempt


def test_a_segment_through_a_box_names_the_box_and_the_link():
    p, k = PROFILES["desk_rrr"], KINS["desk_rrr"]
    home = k.q_home  # forearm horizontal along +x at z = 0.19
    box = KeepOutBox("monitor", (0.03, -0.02, 0.17), (0.05, 0.02, 0.21))
    assert workspace_violation(home, p, k, WorkspaceSpec(0.005, (box,))) == "in keep-out box 'monitor': forearm"
    # a box around the mount alone (the base column) is no violation: nothing can move it
    post = KeepOutBox("cable", (-0.01, -0.01, 0.01), (0.01, 0.01, 0.03))
    assert workspace_violation(home, p, k, WorkspaceSpec(0.005, (post,))) == ""


def test_limit_to_workspace_stops_at_the_farthest_safe_fraction():
    p, k = PROFILES["desk_rrr"], KINS["desk_rrr"]
    q_from = (math.pi / 2, 0.0, -0.5)
    q_to = (math.pi / 2, 0.0, -1.5)
    q, why = limit_to_workspace(q_from, q_to, p, k)
    assert why.startswith("below the desk: tool")
    assert workspace_violation(q, p, k) == "" and 0.005 <= tool_z("desk_rrr", q) < 0.006  # at the margin
    assert limit_to_workspace(q_from, q_from, p, k) == (q_from, "")


def test_from_an_unsafe_start_a_step_out_is_allowed_and_a_step_deeper_is_not():
    p, k = PROFILES["desk_rrr"], KINS["desk_rrr"]
    below = (math.pi / 2, 0.0, -1.2)
    up = (math.pi / 2, 0.0, -1.0)
    deeper = (math.pi / 2, 0.0, -1.5)
    q, why = limit_to_workspace(below, up, p, k)
    assert q == up and why.startswith("below the desk")
    q, _ = limit_to_workspace(below, deeper, p, k)
    assert tool_z("desk_rrr", q) >= tool_z("desk_rrr", below) - 1e-12


# --------------------------------------------------------------------------------------------
# The control step


def run_goal(c: ArmController, goal_p, q0, ticks: int):
    q, out = tuple(q0), []
    for i in range(ticks):
        cmd = c.step(Goal(i, 0.02 * i, goal_p, TargetMode.MANUAL), q, 0.02 * i)
        out.append(cmd)
        q = cmd.q
    return out


def test_a_goal_below_the_desk_is_aimed_at_the_margin_and_never_commanded():
    p = BASE["desk_rrr"]  # no box in the way
    k = build_kinematics(p)
    c = ArmController(p, k)
    cmds = run_goal(c, (0.0, 0.15, -0.05), p.q_home, 150)
    assert all(tool_z("desk_rrr", cmd.q) >= 0.005 - 1e-9 for cmd in cmds)
    last = cmds[-1]
    assert c.note == "below the desk: goal at z = -50 mm — aiming 5 mm above the desk"
    assert not last.reachable and last.reach_error_m == pytest.approx(0.055, abs=1e-4)
    assert np.allclose(k.fk(last.q), (0.0, 0.15, 0.005), atol=1e-4)  # arrived at the margin


def test_a_box_between_home_and_goal_stops_the_arm_at_its_edge_and_says_so():
    p, k = PROFILES["desk_rrr"], KINS["desk_rrr"]
    c = ArmController(p, k)
    cmds = run_goal(c, (0.09, 0.10, 0.05), p.q_home, 150)  # the goal is inside the mug box
    assert all(independent_violation("desk_rrr", cmd.q, p.workspace) == "" for cmd in cmds)
    assert c.note.startswith("in keep-out box 'mug': ") and cmds[-1].clamped
    assert workspace_violation(cmds[-1].q, p, k) == ""


def test_the_controllers_workspace_can_come_from_settings():
    p, k = BASE["desk_rrr"], build_kinematics(BASE["desk_rrr"])
    c = ArmController(p, k)
    assert c.workspace == p.workspace
    c.workspace = WorkspaceSpec(0.05, ())
    cmds = run_goal(c, (0.0, 0.15, 0.02), p.q_home, 150)
    assert min(tool_z("desk_rrr", cmd.q) for cmd in cmds) >= 0.05 - 1e-9
    assert c.note.startswith("below the desk: goal at z = 20 mm")


def test_an_arm_started_below_the_desk_can_be_brought_up():
    p, k = PROFILES["desk_rrr"], KINS["desk_rrr"]
    below = (math.pi / 2, 0.0, -1.5)
    assert tool_z("desk_rrr", below) < 0
    c = ArmController(p, k)
    cmds = run_goal(c, (0.0, 0.15, 0.1), below, 100)
    zs = [tool_z("desk_rrr", cmd.q) for cmd in cmds]
    assert zs[0] >= tool_z("desk_rrr", below) - 1e-12 and zs[-1] > 0.09
    assert c.note == "" and workspace_violation(cmds[-1].q, p, k) == ""


def test_a_pose_goal_below_the_desk_is_aimed_at_the_margin_too():
    p, k = PROFILES["umi_rtx"], KINS["umi_rtx"]
    c = ArmController(p, k)
    q = p.q_home
    for i in range(300):
        cmd = c.step(Goal(i, 0.02 * i, (0.3, 0.3, -0.1), TargetMode.MANUAL, orientation_rpy=(0.0, math.pi / 2, 0.0)),
                     q, 0.02 * i)
        assert independent_violation("umi_rtx", cmd.q, p.workspace) == ""
        q = cmd.q
    assert c.note.startswith("below the desk") or c.note.startswith("in keep-out box")


# --------------------------------------------------------------------------------------------
# Property: random goals from every source, every solver, random starts


COMMON = {"deadline": None, "suppress_health_check": [HealthCheck.too_slow, HealthCheck.data_too_large]}


def goal_point(name: str):
    r, box = REACH_M[name], BOXES[name]
    near = st.tuples(st.floats(-r, r), st.floats(-r, r), st.floats(-0.3 * r, 1.2 * r))
    below = st.tuples(st.floats(-r, r), st.floats(-r, r), st.floats(-0.5 * r, 0.005, exclude_max=True))
    inside = st.tuples(*(st.floats(lo, hi) for lo, hi in zip(box.min_m, box.max_m)))
    far = st.tuples(st.floats(-1e6, 1e6), st.floats(-1e6, 1e6), st.floats(-1e6, 1e6))
    return st.one_of(st.tuples(st.just("near"), near), st.tuples(st.just("below"), below),
                     st.tuples(st.just("box"), inside), st.tuples(st.just("far"), far))


def start_state(name, data):
    p = PROFILES[name]
    q = data.draw(st.one_of(
        st.just(tuple(p.q_home)),
        st.tuples(*(st.floats(lo, hi) for lo, hi in zip(p.q_min, p.q_max))),
        st.tuples(*(st.floats(-10.0, 10.0) for _ in p.joints)),  # outside the limits: clamped
    ))
    return q


def check_command(name, cmd, c, start_safe, what):
    p = PROFILES[name]
    assert cmd is not None and all(math.isfinite(v) for v in cmd.q), what
    assert is_within_limits(cmd.q, p), f"{what}: {cmd.q} outside the limits"
    note = c.workspace_note
    assert note == "" or note.startswith(("below the desk: ", "in keep-out box ")), note
    STATS["commands"] += 1
    if "below the desk: goal" in note:
        STATS["aimed at the margin (goal below the desk)"] += 1
    if note.startswith("below the desk") and not note.startswith("below the desk: goal"):
        STATS["step stopped: below the desk"] += 1
    elif note.startswith("in keep-out box"):
        STATS["step stopped: in keep-out box"] += 1
    if start_safe:
        bad = independent_violation(name, cmd.q, p.workspace)
        assert bad == "", f"{what}: commanded {cmd.q} breaks the workspace: {bad} (note {note!r})"
        assert workspace_violation(cmd.q, p, KINS[name]) == ""
    else:
        STATS["commands from an unsafe start"] += 1


@settings(max_examples=160, **COMMON)
@given(name=st.sampled_from(NAMES), source=st.sampled_from(["manual", "pose", "follow", "lissajous"]),
       data=st.data())
def test_no_goal_from_any_source_ever_commands_a_pose_outside_the_workspace(name, source, data):
    p, k = PROFILES[name], KINS[name]
    q0 = start_state(name, data)
    start = clamp_to_limits(q0, p)[0]
    start_safe = workspace_violation(start, p, k) == ""
    STATS["runs"] += 1
    STATS["runs with a safe start"] += start_safe
    c = ArmController(p, k)
    clock = SimClock()
    targeter = Targeter(clock)
    q, t = q0, 0.0
    for g in range(data.draw(st.integers(1, 3))):
        kind, point = data.draw(goal_point(name))
        STATS[f"goals: {kind}"] += 1
        STATS["goals"] += 1
        if source == "lissajous":
            centre = tuple(min(1.0, max(-1.0, v)) for v in point)
            amp = data.draw(st.tuples(*(st.floats(0.0, 0.2) for _ in range(3))))
            targeter.set_mode(TargetMode.LISSAJOUS)
            targeter.set_lissajous(LissajousParams(centre=centre, amplitude=amp))
            targeter.set_lissajous_running(True)
        elif source == "follow":
            targeter.set_mode(TargetMode.FOLLOW)
            targeter.set_follow_id(5)
        elif source == "pose" and hasattr(k, "ik_pose"):
            rpy = data.draw(st.tuples(*(st.floats(-math.pi, math.pi) for _ in range(3))))
            targeter.set_manual_pose(point, rpy)
        else:
            targeter.set_manual_target(point)
        refused = False
        for _ in range(12):
            result = None
            if source == "follow":
                obs = MarkerObservation(5, True, base_p_centre=point)
                result = PerceptionResult(g, t, (obs,), {}, False)
            goal = targeter.update(result)
            cmd = c.step(goal, q, t)
            check_command(name, cmd, c, start_safe, f"{name} {source} {kind} {point} from {q0}")
            if goal.base_p_target[2] < p.workspace.desk_margin_m:
                assert "below the desk" in c.note
            refused = refused or bool(c.workspace_note)
            q = cmd.q
            t += 0.02
            clock.advance(0.02)
        STATS[f"goals refused or limited: {kind}"] += refused


@settings(max_examples=40, **COMMON)
@given(name=st.sampled_from(NAMES), data=st.data())
def test_grab_task_commands_through_limit_to_workspace_stay_in_the_workspace(name, data):
    """The grab task plans its own joint moves; passed through ``limit_to_workspace`` (as the
    control step does) its commands never leave the workspace either."""
    p, k = PROFILES[name], KINS[name]
    pick = data.draw(goal_point(name))[1]
    drop = data.draw(goal_point(name))[1]
    task = GrabTask(k, p, GrabParams(pick, drop, timeout_s=0.2), p.q_home)
    q, t = tuple(p.q_home), 0.0
    for _ in range(60):
        cmd = task.step(t, q)
        q_safe, why = limit_to_workspace(q, cmd.q, p, k)
        assert is_within_limits(q_safe, p)
        assert independent_violation(name, q_safe, p.workspace) == "", f"{name} grab {pick} → {drop}: {why}"
        STATS["grab commands"] += 1
        STATS["grab commands limited"] += bool(why)
        if cmd.done or cmd.failed:
            break
        q, t = q_safe, t + 0.02


def test_zz_the_random_runs_exercised_every_refusal(capsys):
    """The property runs above refused goals for each reason (otherwise they proved nothing)."""
    if STATS["goals"] == 0:
        pytest.skip("the property tests did not run in this session")
    with capsys.disabled():
        print("\nworkspace safety, random runs:")
        for key in sorted(STATS):
            print(f"  {key}: {STATS[key]}")
    assert STATS["aimed at the margin (goal below the desk)"] > 0
    assert STATS["step stopped: in keep-out box"] > 0
    assert STATS["runs with a safe start"] > 0
