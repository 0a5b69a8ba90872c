"""The control step: Goal -> inverse kinematics -> safety clamps -> JointCommand.

Runs in the kinematics/control worker and in the headless runner when ``ControlSchedule``
(``core.motion.schedule``) says so: at once for a new goal, else on the 50 Hz tick (the servo
PWM frame). A lost marker holds the last command; an unreachable goal sends the arm to the
nearest reachable point and says by how much the goal is out of reach. A goal with a NaN or
infinite value is treated as invalid: the last command is held and ``ArmController.note`` says
why (the Targeter refuses such targets already; this is the last gate before the solvers).

Workspace (the profile's desk margin and keep-out boxes, ``core.motion.safety``): a goal below
the desk margin is aimed at the margin instead (the command is then not "reachable" and
``note`` says "below the desk: goal at z = …"), and after the joint clamps and the step limit
the pose is checked as a whole — every moving point of the arm above the margin, no segment in a
keep-out box. A step that would break that stops at the farthest safe fraction of the step
(``limit_to_workspace``) and ``note`` gives the reason, e.g. "below the desk: elbow at z = -12 mm".
Whatever the solver and the goal source, no commanded pose leaves the workspace from a safe start.

Joint goals (``Goal.joint_target``, joint-space jogging): no IK — the joint values go through the
same joint clamps, the same per-tick step limit and the same whole-arm workspace check as a
solved answer, so a joint target outside the limits stops at the limit and one that would put
the elbow through the desk stops at the desk (``note`` says which). A joint target that is not
one finite number per joint holds the last command. The window's joint jog reaches the
controller through :meth:`ArmController.set_joint_jog` (the targeter makes Cartesian goals only):
while set, MANUAL goals become joint goals, until the user's manual target or the mode changes.
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Optional, Sequence

import numpy as np

from core.kinematics.base import distance_m, format_distance, pose_matrix, rpy_to_matrix
from core.kinematics.profile import WorkspaceSpec
from core.messages import Goal, JointCommand, SequenceCounter, TargetMode, as_point
from core.motion.safety import clamp_to_limits, limit_step, limit_to_workspace, workspace_violation

CONTROL_RATE_HZ = 50.0


def goal_pose_matrix(base_p, rpy) -> "np.ndarray":
    """``oMdes`` the controller solves for: position (m) and roll, pitch, yaw (rad, Pinocchio's
    R = Rz(yaw) · Ry(pitch) · Rx(roll))."""
    return pose_matrix(base_p, rpy_to_matrix(*rpy))


def goal_problem(goal: Goal) -> str:
    """"" for a goal the solvers can take, else why not (a NaN or infinite target, orientation
    or grip), e.g. "goal z = nan is not a finite number (m) — holding"."""
    fields = [("goal", "xyz", goal.base_p_target, "m")]
    if goal.orientation_rpy is not None:
        fields.append(("goal orientation", ("roll", "pitch", "yaw"), goal.orientation_rpy, "rad"))
    if goal.grip_m is not None:
        fields.append(("goal", ("grip_m",), (goal.grip_m,), "m"))
    for field, axes, values, unit in fields:
        try:
            vs = [float(v) for v in values]
        except (TypeError, ValueError):
            return f"{field} {values!r} is not {len(axes)} numbers — holding"
        if len(vs) != len(axes):
            return f"{field} {values!r} is not {len(axes)} numbers — holding"
        for axis, v in zip(axes, vs):
            if not math.isfinite(v):
                return f"{field} {axis} = {v!r} is not a finite number ({unit}) — holding"
    return ""


def joint_target_problem(joint_target, profile) -> str:
    """"" for a joint target the controller can take (one finite number per joint of ``profile``),
    else why not, e.g. "joint target elbow = nan is not a finite number — holding"."""
    names = [j.name for j in profile.joints]
    try:
        values = [float(v) for v in joint_target]
    except (TypeError, ValueError):
        return f"joint target {joint_target!r} is not {len(names)} numbers ({', '.join(names)}) — holding"
    if len(values) != len(names):
        return (f"joint target has {len(values)} values but profile {profile.name!r} has {len(names)} joints"
                f" ({', '.join(names)}) — holding")
    for name, v in zip(names, values):
        if not math.isfinite(v):
            return f"joint target {name} = {v!r} is not a finite number — holding"
    return ""


def _clamped_joint_names(q_raw: Sequence[float], q_clamped: Sequence[float], profile) -> list[str]:
    return [j.name for j, a, b in zip(profile.joints, q_raw, q_clamped) if float(a) != float(b)]


class ArmController:
    """Solves IK for each goal and limits each joint's step per tick."""

    def __init__(self, profile, kinematics, rate_hz: float = CONTROL_RATE_HZ):
        self.profile = profile
        self.kinematics = kinematics
        self.period_s = 1.0 / rate_hz
        self.max_step_rad = tuple(
            math.radians(j.max_speed_deg_s) * self.period_s for j in profile.joints
        )
        self.last: Optional[JointCommand] = None
        # the goal the last step used, after the joint jog (a MANUAL goal may become a joint goal):
        # what the window and the recorder show beside the command
        self.last_goal: Optional[Goal] = None
        self.last_ik = None
        self.armed = True  # False after an e-stop: refuse new commands until re-armed
        self.paused_by: frozenset[str] = frozenset()  # why the arm holds still (e.g. "a dialog is open")
        self.note = ""  # why the last step held or stopped short ("" when it solved and moved freely)
        # desk margin and keep-out boxes enforced on every step; the profile's unless set (settings)
        self.workspace: WorkspaceSpec = getattr(profile, "workspace", None) or WorkspaceSpec()
        self.workspace_note = ""  # the workspace's reason alone, "" when the last step was clear
        self._seq = SequenceCounter()
        # the window's joint jog: (joint target, the MANUAL goal points it holds for), or None
        self._joint_jog: Optional[tuple[tuple[float, ...], tuple]] = None

    def set_joint_jog(self, q_target: Optional[Sequence[float]], manual_target=None) -> None:
        """Jog in joint space (any thread): while set, each MANUAL goal whose point is
        ``manual_target`` (None: any point) is taken as a joint goal for ``q_target``. A MANUAL goal
        with another point (the user moved the Cartesian target) or a goal of another mode ends the
        jog; None ends it at once. The window sets the targeter's manual target to the tool point of
        ``q_target`` right after this call (the twin shows where the joints go): until it has, the
        previous jog's point still counts, so no step in between ends the jog.

        The targeter only makes Cartesian goals; this is how joint goals from the window reach the
        control step without a second goal path. ValueError for a target that is not one finite
        number per joint (nothing changes then)."""
        if q_target is None:
            self._joint_jog = None
            return
        problem = joint_target_problem(q_target, self.profile)
        if problem:
            raise ValueError(problem.replace(" — holding", ""))
        anchors: tuple = ()
        if manual_target is not None:
            anchors = (as_point(manual_target),)
            prev = self._joint_jog
            if prev is not None and prev[1]:  # the point of the jog before, until the targeter catches up
                anchors += (prev[1][0],)
        self._joint_jog = (tuple(float(v) for v in q_target), anchors)  # one assignment: atomic

    @property
    def joint_jog(self) -> Optional[tuple[float, ...]]:
        """The joint jog's target while one is on, else None."""
        jog = self._joint_jog
        return None if jog is None else jog[0]

    def _with_joint_jog(self, goal: Optional[Goal]) -> Optional[Goal]:
        jog = self._joint_jog
        if jog is None or goal is None or goal.joint_target is not None:
            return goal
        q_target, anchors = jog
        if goal.mode is not TargetMode.MANUAL or (anchors and as_point(goal.base_p_target) not in anchors):
            if self._joint_jog is jog:  # the user took over: the jog ends
                self._joint_jog = None
            return goal
        return replace(goal, joint_target=q_target, orientation_rpy=None, note=goal.note or "joint jog")

    def step(self, goal: Optional[Goal], q_now: Sequence[float], t: float) -> Optional[JointCommand]:
        """One control tick. ``q_now`` is the measured (or last commanded) joint state.

        Returns None when there is nothing to send (no goal yet, or disarmed). An invalid goal
        — a lost marker, or a NaN or infinite value in it — holds the last command (None before
        the first one) and ``note`` says why.
        """
        if not self.armed:
            return None
        goal = self._with_joint_jog(goal)
        self.last_goal = goal
        paused_by = self.paused_by
        if paused_by:
            self.note = f"paused: {', '.join(sorted(paused_by))}"
            return self._hold(goal, t)
        if goal is None or not goal.valid:
            self.note = (goal.note or "goal invalid — holding") if goal is not None else "no goal yet"
            return self._hold(goal, t)
        if goal.joint_target is not None:
            return self._step_joints(goal, q_now, t)
        problem = goal_problem(goal)
        if problem:
            self.note = problem
            return self._hold(goal, t)
        self.note = ""
        self.workspace_note = ""
        q_ref = self.last.q if self.last is not None else tuple(q_now)
        target = tuple(float(v) for v in goal.base_p_target)
        margin = self.workspace.desk_margin_m
        raised = ""
        if target[2] < margin:  # never aim below the desk: aim at the margin above that point
            raised = (f"below the desk: goal at z = {target[2] * 1e3:.0f} mm — aiming"
                      f" {format_distance(margin)} above the desk")
            target = (target[0], target[1], margin)
        if goal.orientation_rpy is not None and hasattr(self.kinematics, "ik_pose"):
            ik = self.kinematics.ik_pose(goal_pose_matrix(target, goal.orientation_rpy), q_ref)
        else:
            ik = self.kinematics.ik(target, q_ref)
        self.last_ik = ik
        q_cmd, changed, why = self._safe_step(q_ref, ik.q, t)
        self.workspace_note = "; ".join(r for r in (why, raised) if r)
        self.note = self.workspace_note
        reach_error = float(ik.error_m)
        if raised:
            reach_error = distance_m(goal.base_p_target, ik.base_p_reached)
        cmd = JointCommand(
            seq=self._seq.next(), t=t, q=tuple(q_cmd), source_t=goal.source_t,
            reachable=bool(ik.reachable) and not raised, reach_error_m=reach_error,
            base_p_target=as_point(ik.base_p_reached),
            clamped=bool(changed or why),
        )
        self.last = cmd
        return cmd

    def _safe_step(self, q_ref: Sequence[float], q_wanted: Sequence[float], t: float):
        """The safety chain every command goes through, whatever made ``q_wanted`` (IK or a joint
        goal): joint clamps, the per-tick step limit, the clamps again, the whole-arm workspace
        check. Returns (q_cmd, changed by the clamps, the workspace's reason or "")."""
        q_safe, changed = clamp_to_limits(q_wanted, self.profile)
        q_limited = limit_step(q_ref, q_safe, self.step_allowance(t))
        q_final, changed_again = clamp_to_limits(q_limited, self.profile)
        # the step starts where limit_step started it: a joint with no usable history starts
        # where it is commanded to go (so the check below looks at the commanded pose alone)
        q_from, _ = clamp_to_limits(tuple(a if math.isfinite(float(a)) else b
                                          for a, b in zip(q_ref, q_final)), self.profile)
        q_cmd, why = limit_to_workspace(q_from, q_final, self.profile, self.kinematics, self.workspace)
        return tuple(q_cmd), bool(changed or changed_again), why

    def _step_joints(self, goal: Goal, q_now: Sequence[float], t: float) -> Optional[JointCommand]:
        """A joint goal: no IK; the same clamps, step limit and workspace check as a solved one."""
        problem = joint_target_problem(goal.joint_target, self.profile)
        if problem:
            self.note = problem
            return self._hold(goal, t)
        q_raw = tuple(float(v) for v in goal.joint_target)
        q_goal, _ = clamp_to_limits(q_raw, self.profile)
        q_ref = self.last.q if self.last is not None else tuple(q_now)
        q_cmd, changed, why = self._safe_step(q_ref, q_goal, t)
        self.last_ik = None
        limited = _clamped_joint_names(q_raw, q_goal, self.profile)
        limit_note = f"joint target beyond the limits of {', '.join(limited)} — stopping at the limit" if limited else ""
        target_why = why and workspace_violation(q_goal, self.profile, self.kinematics, self.workspace)
        self.workspace_note = why
        self.note = "; ".join(r for r in (why, limit_note) if r)
        base_p_goal = as_point(self.kinematics.fk(q_goal))
        reach_error = 0.0
        if target_why:  # the joint target itself breaks the workspace: say how far it is from where the arm stops
            reach_error = distance_m(base_p_goal, self.kinematics.fk(q_cmd))
        elif limited:  # beyond a limit: how far the tool would have gone past it (0 where FK is undefined)
            with np.errstate(all="ignore"):
                gap = distance_m(self.kinematics.fk(q_raw), base_p_goal)
            reach_error = gap if math.isfinite(gap) else 0.0
        cmd = JointCommand(
            seq=self._seq.next(), t=t, q=q_cmd, source_t=goal.source_t,
            reachable=not limited and not target_why, reach_error_m=float(reach_error),
            base_p_target=base_p_goal, clamped=bool(changed or why or limited),
        )
        self.last = cmd
        return cmd

    def _hold(self, goal: Optional[Goal], t: float) -> Optional[JointCommand]:
        """Repeat the last command (servos keep their pulse; the link stays alive); None before one."""
        if self.last is None:
            return None
        return JointCommand(self._seq.next(), t, self.last.q, goal.source_t if goal else None,
                            self.last.reachable, self.last.reach_error_m, self.last.base_p_target)

    def start_pose(self, state) -> tuple[float, ...]:
        """The joints a step starts from: the measured (or echoed) JointState, else the last
        command (v1 has no state before its first one), else the profile's home pose."""
        if state is not None:
            return tuple(state.q)
        if self.last is not None:
            return self.last.q
        return tuple(self.profile.q_home)

    def step_allowance(self, t: float) -> tuple[float, ...]:
        """How far each joint may move in a step at ``t``: its speed limit × the time since the
        previous step, at most one tick period (a step that comes sooner than the tick — a new
        goal — moves less, so the speed limits hold however often the step runs)."""
        if self.last is None:
            return self.max_step_rad
        dt = t - self.last.t
        if not dt < self.period_s:  # also NaN: never more than one tick's step
            return self.max_step_rad
        scale = max(dt, 0.0) / self.period_s
        return tuple(s * scale for s in self.max_step_rad)

    def estop(self) -> None:
        self.armed = False

    def rearm(self) -> None:
        self.armed = True

    def pause(self, reason: str) -> None:
        """Hold still (the last command repeats) until :meth:`resume` with the same reason;
        several reasons may hold at once. Unlike the e-stop the link stays commanded."""
        self.paused_by = self.paused_by | {str(reason)}

    def resume(self, reason: str) -> None:
        """Drop one reason to hold still (no effect if it was not holding)."""
        self.paused_by = self.paused_by - {str(reason)}

    @property
    def paused(self) -> bool:
        return bool(self.paused_by)
