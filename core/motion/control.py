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
"""
from __future__ import annotations

import math
from typing import Optional, Sequence

import numpy as np

from core.kinematics.base import distance_m, format_distance, pose_matrix, rpy_to_matrix
from core.kinematics.profile import WorkspaceSpec
from core.messages import Goal, JointCommand, SequenceCounter, as_point
from core.motion.safety import clamp_to_limits, limit_step, limit_to_workspace

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
        self.last_ik = None
        self.armed = True  # False after an e-stop: refuse new commands until re-armed
        self.paused_by: frozenset[str] = frozenset()  # why the arm holds still (e.g. "a dialog is open")
        self.note = ""  # why the last step held or stopped short ("" when it solved and moved freely)
        # desk margin and keep-out boxes enforced on every step; the profile's unless set (settings)
        self.workspace: WorkspaceSpec = getattr(profile, "workspace", None) or WorkspaceSpec()
        self.workspace_note = ""  # the workspace's reason alone, "" when the last step was clear
        self._seq = SequenceCounter()

    def step(self, goal: Optional[Goal], q_now: Sequence[float], t: float) -> Optional[JointCommand]:
        """One control tick. ``q_now`` is the measured (or last commanded) joint state.

        Returns None when there is nothing to send (no goal yet, or disarmed). An invalid goal
        — a lost marker, or a NaN or infinite value in it — holds the last command (None before
        the first one) and ``note`` says why.
        """
        if not self.armed:
            return None
        paused_by = self.paused_by
        if paused_by:
            self.note = f"paused: {', '.join(sorted(paused_by))}"
            return self._hold(goal, t)
        if goal is None or not goal.valid:
            self.note = (goal.note or "goal invalid — holding") if goal is not None else "no goal yet"
            return self._hold(goal, t)
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
        q_safe, changed = clamp_to_limits(ik.q, self.profile)
        q_limited = limit_step(q_ref, q_safe, self.step_allowance(t))
        q_final, changed_again = clamp_to_limits(q_limited, self.profile)
        # the step starts where limit_step started it: a joint with no usable history starts
        # where it is commanded to go (so the check below looks at the commanded pose alone)
        q_from, _ = clamp_to_limits(tuple(a if math.isfinite(float(a)) else b
                                          for a, b in zip(q_ref, q_final)), self.profile)
        q_cmd, why = limit_to_workspace(q_from, q_final, self.profile, self.kinematics, self.workspace)
        self.workspace_note = "; ".join(r for r in (why, raised) if r)
        self.note = self.workspace_note
        reach_error = float(ik.error_m)
        if raised:
            reach_error = distance_m(goal.base_p_target, ik.base_p_reached)
        cmd = JointCommand(
            seq=self._seq.next(), t=t, q=tuple(q_cmd), source_t=goal.source_t,
            reachable=bool(ik.reachable) and not raised, reach_error_m=reach_error,
            base_p_target=as_point(ik.base_p_reached),
            clamped=bool(changed or changed_again or why),
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
