"""Goals are checked where they enter: NaN/inf targets are refused by name, never reach a solver
as a traceback, and no command is ever non-finite or outside the joint limits."""
from __future__ import annotations

import math
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.clock import SimClock
from core.kinematics import build_kinematics, load_profile
from core.kinematics.base import pose_matrix, rpy_to_matrix
from core.kinematics.profile import parse_profile
from core.messages import Goal, MarkerObservation, PerceptionResult, TargetMode
from core.motion.control import ArmController
from core.motion.grab_task import GrabParams, GrabTask
from core.motion.safety import is_within_limits
from core.motion.targeting import Targeter
from core.motion.trajectory import PointToPoint, follow_cartesian
from core.settings import LissajousParams

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

NAN, INF = math.nan, math.inf
MAX = 1.7976931348623157e308


def _equal_radii_delta():
    """A valid but odd delta (effector as wide as the base)."""
    data = tomllib.loads(Path(load_profile("delta").source).read_text())
    data["geometry"]["effector_radius_m"] = data["geometry"]["base_radius_m"]
    data["name"] = "delta_equal_radii"
    return parse_profile(data, "delta_equal_radii")


PROFILES = {name: load_profile(name) for name in ("desk_rrr", "umi_rtx", "assistive_5dof", "delta")}
PROFILES["delta_equal_radii"] = _equal_radii_delta()
KINS = {name: build_kinematics(p) for name, p in PROFILES.items()}
NAMES = sorted(PROFILES)

# ordinary coordinates, the absurd ones, and anything hypothesis likes
value = st.one_of(
    st.floats(-1.0, 1.0),
    st.sampled_from([NAN, INF, -INF, 1e308, -1e300, MAX, -MAX, 1e150, 1e6, -1e6, 1e-300, 5e-324, -5e-324, 0.0]),
    st.floats(allow_nan=True, allow_infinity=True),
)
point = st.tuples(value, value, value)


def finite(values) -> bool:
    return all(math.isfinite(v) for v in values)


def assert_command_safe(q, profile, what=""):
    assert q is not None and finite(q), f"{what}: non-finite command {q}"
    assert is_within_limits(q, profile), f"{what}: {q} outside {profile.q_min} … {profile.q_max}"


def in_limits(profile, data):
    """A joint vector: usually within the limits, sometimes absurd."""
    return tuple(data.draw(st.one_of(st.floats(lo, hi), value)) for lo, hi in zip(profile.q_min, profile.q_max))


# --------------------------------------------------------------------------------------------
# Targeter setters


@pytest.mark.parametrize("p, axis, v", [((NAN, 0.1, 0.1), "x", "nan"), ((0.0, INF, 0.1), "y", "inf"),
                                        ((0.0, 0.1, -INF), "z", "-inf")])
def test_manual_target_setter_refuses_nan_and_inf_naming_the_axis(p, axis, v):
    t = Targeter(SimClock())
    calls = []
    t.listeners.append(lambda: calls.append(1))
    before = t.manual_target
    with pytest.raises(ValueError, match=rf"manual target {axis} = {v} must be a finite number \(m\)"):
        t.set_manual_target(p)
    assert t.manual_target == before and calls == []  # nothing changed, nobody woken
    assert finite(t.update(None).base_p_target)


def test_manual_pose_setter_refuses_non_finite_position_orientation_and_grip():
    t = Targeter(SimClock())
    t.set_manual_pose((0.1, 0.2, 0.3), (0.0, 0.5, 1.0), 0.02)
    with pytest.raises(ValueError, match=r"manual target z = nan must be a finite number \(m\)"):
        t.set_manual_pose((0.1, 0.2, NAN), (0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match=r"manual orientation pitch = inf must be a finite number \(rad\)"):
        t.set_manual_pose((0.1, 0.2, 0.3), (0.0, INF, 0.0))
    with pytest.raises(ValueError, match=r"manual grip_m = nan must be a finite number \(m\)"):
        t.set_manual_pose((0.1, 0.2, 0.3), (0.0, 0.0, 0.0), NAN)
    with pytest.raises(ValueError, match=r"manual grip_m = -0.01 must be ≥ 0 m"):
        t.set_manual_pose((0.1, 0.2, 0.3), None, -0.01)
    g = t.update(None)  # the last accepted pose stands
    assert g.base_p_target == (0.1, 0.2, 0.3) and g.orientation_rpy == (0.0, 0.5, 1.0) and g.grip_m == 0.02


def test_targeter_refuses_a_non_finite_initial_target():
    with pytest.raises(ValueError, match=r"manual target y = inf must be a finite number \(m\)"):
        Targeter(SimClock(), manual_target=(0.0, INF, 0.1))


def test_lissajous_setter_refuses_parameters_with_a_nan():
    params = LissajousParams()
    object.__setattr__(params, "centre", (0.0, NAN, 0.1))  # past its range checks
    t = Targeter(SimClock(), mode=TargetMode.LISSAJOUS)
    with pytest.raises(ValueError, match=r"lissajous\.centre y = nan must be a finite number \(m\)"):
        t.set_lissajous(params)
    assert finite(t.update(None).base_p_target)


class JumpClock(SimClock):
    """A clock whose time can be set to anything (a broken clock source)."""

    def set(self, t: float) -> None:
        self._now = t


@pytest.mark.parametrize("bad_t", [INF, NAN])
def test_a_lissajous_point_at_a_non_finite_time_is_an_invalid_goal_not_a_traceback(bad_t):
    clock = JumpClock()
    t = Targeter(clock, mode=TargetMode.LISSAJOUS)
    t.set_lissajous_running(True)
    clock.set(bad_t)
    g = t.update(None)
    assert not g.valid and "Lissajous point" in g.note and "not finite" in g.note
    c = ArmController(PROFILES["desk_rrr"], KINS["desk_rrr"])
    assert c.step(g, PROFILES["desk_rrr"].q_home, 0.0) is None  # nothing to hold yet


@pytest.mark.parametrize("centre", [(NAN, 0.1, 0.0), (0.0, INF, 0.0), (0.0, 0.1, -INF)])
def test_a_marker_triangulated_at_a_non_finite_position_holds(centre):
    t = Targeter(SimClock(), mode=TargetMode.FOLLOW, follow_id=23)
    obs = MarkerObservation(23, True, base_p_centre=centre)
    g = t.update(PerceptionResult(1, 0.0, (obs,), {}, False))
    assert not g.valid and g.note == "marker 23 position is not finite — holding"


# --------------------------------------------------------------------------------------------
# The control step: the last gate


def test_a_non_finite_goal_holds_the_last_command_and_the_controller_says_why():
    profile, kin = PROFILES["desk_rrr"], KINS["desk_rrr"]
    c = ArmController(profile, kin)
    assert c.step(Goal(1, 0.0, (NAN, 0.1, 0.1), TargetMode.MANUAL), profile.q_home, 0.0) is None
    assert c.note == "goal x = nan is not a finite number (m) — holding"
    first = c.step(Goal(2, 0.02, (0.05, 0.15, 0.08), TargetMode.MANUAL), profile.q_home, 0.02)
    assert first is not None and c.note == ""
    held = c.step(Goal(3, 0.04, (0.05, -INF, 0.08), TargetMode.MANUAL), profile.q_home, 0.04)
    assert held.q == first.q and held.base_p_target == first.base_p_target
    assert c.note == "goal y = -inf is not a finite number (m) — holding"


@pytest.mark.parametrize("rpy, grip, note", [
    ((0.0, INF, 0.0), None, "goal orientation pitch = inf is not a finite number (rad) — holding"),
    ((NAN, 0.0, 0.0), None, "goal orientation roll = nan is not a finite number (rad) — holding"),
    ((0.0, 0.0, 0.0), NAN, "goal grip_m = nan is not a finite number (m) — holding"),
])
def test_a_pose_goal_with_a_non_finite_orientation_or_grip_holds(rpy, grip, note):
    profile, kin = PROFILES["umi_rtx"], KINS["umi_rtx"]
    c = ArmController(profile, kin)
    goal = Goal(1, 0.0, (0.2, 0.3, 0.3), TargetMode.MANUAL, orientation_rpy=(0.0, 1.5, 0.0))
    first = c.step(goal, profile.q_home, 0.0)
    held = c.step(Goal(2, 0.02, (0.2, 0.3, 0.3), TargetMode.MANUAL, orientation_rpy=rpy, grip_m=grip),
                  profile.q_home, 0.02)
    assert held.q == first.q and c.note == note


# --------------------------------------------------------------------------------------------
# The grab task and trajectories


def test_grab_refuses_non_finite_points_grips_and_start_joints_naming_the_field():
    profile, kin = PROFILES["desk_rrr"], KINS["desk_rrr"]
    with pytest.raises(ValueError, match=r"grab\.base_p_drop z = inf must be a finite number \(m\)"):
        GrabParams((0.0, 0.15, 0.05), (0.1, 0.15, INF))
    with pytest.raises(ValueError, match=r"grab\.gripper_open_m = nan must be a finite number \(m\)"):
        GrabParams((0.0, 0.15, 0.05), (0.1, 0.15, 0.05), gripper_open_m=NAN)
    params = GrabParams((0.0, 0.15, 0.05), (0.1, 0.15, 0.05))
    with pytest.raises(ValueError, match=r"q_start shoulder = nan must be a finite number"):
        GrabTask(kin, profile, params, (0.0, NAN, 0.0))


def test_grab_never_commands_non_finite_joints_from_non_finite_measurements_or_times():
    profile, kin = PROFILES["desk_rrr"], KINS["desk_rrr"]
    task = GrabTask(kin, profile, GrabParams((0.0, 0.15, 0.05), (0.1, 0.15, 0.05), timeout_s=1.0), profile.q_home)
    cmd = task.step(NAN, profile.q_home)  # a NaN time holds the command
    assert_command_safe(cmd.q, profile, "NaN time")
    for t in (0.5, 5.0, 50.0):  # the arm reports NaN joints: never arrives, times out
        cmd = task.step(t, (NAN, 0.3, INF))
        assert_command_safe(cmd.q, profile, f"t = {t}")
    assert cmd.failed and "measured joints not finite" in cmd.message


def test_a_trajectory_is_never_sampled_at_a_nan_time():
    with pytest.raises(ValueError, match=r"t = nan s"):
        PointToPoint((0.0,), (1.0,), 1.0).sample(NAN)


def test_follow_cartesian_refuses_a_non_finite_start_and_holds_on_non_finite_points():
    profile, kin = PROFILES["desk_rrr"], KINS["desk_rrr"]
    with pytest.raises(ValueError, match=r"q_start base_yaw = nan must be a finite number"):
        list(follow_cartesian(kin, profile, lambda t: (0.0, 0.15, 0.1), 0.1, (NAN, 0.0, 0.0)))
    sps = list(follow_cartesian(kin, profile, lambda t: (NAN, 0.15, 0.1), 0.1, profile.q_home))
    assert all(sp.q == pytest.approx(profile.q_home) and not sp.reachable for sp in sps)


# --------------------------------------------------------------------------------------------
# Property: every profile × every goal source × absurd values


COMMON = {"deadline": None, "suppress_health_check": [HealthCheck.too_slow]}


@settings(max_examples=80, **COMMON)
@given(name=st.sampled_from(NAMES), p=point, rpy=st.one_of(st.none(), point), data=st.data())
def test_direct_ik_never_raises_and_never_leaves_the_limits(name, p, rpy, data):
    profile, kin = PROFILES[name], KINS[name]
    which = data.draw(st.sampled_from(["none", "home", "drawn"]))
    q_cur = None if which == "none" else profile.q_home if which == "home" else in_limits(profile, data)
    if rpy is not None and hasattr(kin, "ik_pose"):
        res = kin.ik_pose(pose_matrix(p, rpy_to_matrix(*rpy)), q_cur)
    else:
        res = kin.ik(p, q_cur)
    assert_command_safe(res.q, profile, f"{name} ik {p} {rpy}")
    if not finite(p):
        assert not res.success and res.error_m == math.inf
    assert res.success or res.message


@settings(max_examples=60, **COMMON)
@given(name=st.sampled_from(NAMES), goals=st.lists(st.tuples(point, st.one_of(st.none(), point),
                                                             st.one_of(st.none(), value)), min_size=1, max_size=4),
       data=st.data())
def test_control_step_commands_stay_finite_and_within_limits(name, goals, data):
    profile, kin = PROFILES[name], KINS[name]
    c = ArmController(profile, kin)
    for k, (p, rpy, grip) in enumerate(goals):
        before = c.last
        cmd = c.step(Goal(k, 0.02 * k, p, TargetMode.MANUAL, orientation_rpy=rpy, grip_m=grip),
                     in_limits(profile, data), 0.02 * k)
        if not (finite(p) and (rpy is None or finite(rpy)) and (grip is None or math.isfinite(grip))):
            assert "not a finite number" in c.note  # held, and says why
            assert (cmd is None and before is None) or cmd.q == before.q
            continue
        assert_command_safe(cmd.q, profile, f"{name} goal {p} {rpy}")


@settings(max_examples=60, **COMMON)
@given(name=st.sampled_from(NAMES), p=point, rpy=st.one_of(st.none(), point), grip=st.one_of(st.none(), value),
       data=st.data())
def test_targeter_setters_refuse_or_pass_a_goal_the_controller_can_take(name, p, rpy, grip, data):
    profile, kin = PROFILES[name], KINS[name]
    t = Targeter(SimClock())
    c = ArmController(profile, kin)
    try:
        if rpy is None and grip is None:
            t.set_manual_target(p)
        else:
            t.set_manual_pose(p, rpy, grip)
    except ValueError as exc:  # the documented refusal, and only for a value that deserves it
        assert "must be a finite number" in str(exc) or "must be ≥ 0" in str(exc)
        grip_ok = grip is None or (math.isfinite(grip) and grip >= 0)
        assert not (finite(p) and (rpy is None or finite(rpy)) and grip_ok)
    goal = t.update(None)
    assert finite(goal.base_p_target)
    cmd = c.step(goal, in_limits(profile, data), 0.0)
    assert_command_safe(cmd.q, profile, f"{name} manual {p} {rpy} {grip}")


@settings(max_examples=40, **COMMON)
@given(name=st.sampled_from(NAMES), pick=point, drop=point, data=st.data())
def test_grab_task_commands_stay_finite_and_within_limits(name, pick, drop, data):
    profile, kin = PROFILES[name], KINS[name]
    try:
        params = GrabParams(pick, drop, timeout_s=0.5)
    except ValueError as exc:
        assert "must be a finite number" in str(exc) and not (finite(pick) and finite(drop))
        return
    q_start = in_limits(profile, data)
    try:
        task = GrabTask(kin, profile, params, q_start)
    except ValueError as exc:
        assert "q_start" in str(exc) and not finite(q_start)
        return
    q_meas, t = task.q_start, 0.0
    for _ in range(6):
        # the tick's time: on the grid, long after (timeouts), or NaN from a broken clock
        t_tick = data.draw(st.sampled_from([t, NAN]))
        cmd = task.step(t_tick, q_meas)
        assert_command_safe(cmd.q, profile, f"{name} grab {pick} → {drop} at t = {t_tick}")
        assert math.isfinite(cmd.gripper_m)
        if cmd.done or cmd.failed:
            break
        q_meas = cmd.q if data.draw(st.booleans()) else in_limits(profile, data)  # tracking, or garbage
        t += data.draw(st.sampled_from([0.02, 100.0]))
