"""A pick-and-place "grab" task that waits for the arm instead of trusting fixed durations.

Phases, in order: approach (above the pick point), open (the gripper), descend (to the pick
point), close, lift (back above it), carry (above the drop point, then down to it), release
(open), retreat (back above the drop point). Each phase plans a joint-space move within the
profile's velocity and acceleration limits (``core.motion.trajectory.joint_move``) to the IK solution
of its waypoint, streams it, and moves on only when the *measured* tool point is within
``tolerance_m`` of the waypoint (and the gripper within its tolerance). A phase that has not
arrived ``timeout_s`` after its move should have ended fails the task with a message saying
where and by how much; the original system used fixed durations and never checked.

Every waypoint is solved before the arm moves: an unreachable pick or drop point fails the
task at once, cleanly (the command holds the start pose), with the distance out of reach.
Commands are always within the joint limits and finite: NaN or infinite points, grips and
start joints are refused with a ValueError naming the field when the task is made, a tick
with a non-finite time holds the command, and non-finite measured joints never arrive (on the
timeout that follows, such a joint keeps its last command). No Qt here; the caller steps the
task at the control rate with the clock's time and the bridge's joint state.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import Optional, Sequence

import numpy as np

from core.kinematics.base import format_distance
from core.motion.safety import limit_to_workspace, require_finite, require_finite_number
from core.motion.trajectory import PointToPoint, joint_move


class GrabPhase(str, Enum):
    """Where the task is."""

    APPROACH = "approach"
    OPEN = "open"
    DESCEND = "descend"
    CLOSE = "close"
    LIFT = "lift"
    CARRY = "carry"
    RELEASE = "release"
    RETREAT = "retreat"
    DONE = "done"
    FAILED = "failed"


PHASES = (
    GrabPhase.APPROACH, GrabPhase.OPEN, GrabPhase.DESCEND, GrabPhase.CLOSE, GrabPhase.LIFT,
    GrabPhase.CARRY, GrabPhase.RELEASE, GrabPhase.RETREAT,
)
DEFAULT_GRIPPER_OPEN_M = 0.05  # a profile without a gripper: a virtual one, commanded open-loop
DEFAULT_GRIPPER_SPEED_M_S = 0.05


@dataclass(frozen=True)
class GrabParams:
    """What to pick, where to drop it, and how strictly to check arrival."""

    base_p_pick: tuple[float, float, float]  # tool point when grasping the object (m, robot_base)
    base_p_drop: tuple[float, float, float]  # tool point when releasing it (m, robot_base)
    hover_m: float = 0.05  # approach/lift/retreat height above pick and drop, m, 0 … 0.5
    tolerance_m: float = 0.005  # arrived: measured tool point this close to the waypoint, m, (0, 0.1]
    gripper_tolerance_m: float = 0.001  # … and a measured gripper this close to its command, m
    timeout_s: float = 5.0  # a phase fails this long after its planned move has ended, s, (0, 600]
    gripper_open_m: Optional[float] = None  # opening when open (per finger), m; None: the gripper's max
    gripper_closed_m: Optional[float] = None  # opening when closed on the object, m; None: its min
    shape: str = "cubic"  # joint moves: "cubic" or "quintic"
    speed_scale: float = 1.0  # fraction of the joints' speed limits, (0, 1]

    def __post_init__(self) -> None:
        for name in ("base_p_pick", "base_p_drop"):
            object.__setattr__(self, name, require_finite(f"grab.{name}", getattr(self, name), "m"))
        for name in ("gripper_open_m", "gripper_closed_m"):
            v = getattr(self, name)
            if v is not None and not require_finite_number(f"grab.{name}", v, "m") >= 0.0:
                raise ValueError(f"grab.{name} = {v!r} must be ≥ 0 m (an opening per finger)")
        for name, lo, hi, open_lo in (("hover_m", 0.0, 0.5, False), ("tolerance_m", 0.0, 0.1, True),
                                      ("gripper_tolerance_m", 0.0, 0.05, True), ("timeout_s", 0.0, 600.0, True),
                                      ("speed_scale", 0.0, 1.0, True)):
            v = getattr(self, name)
            if not (math.isfinite(v) and (lo < v if open_lo else lo <= v) and v <= hi):
                raise ValueError(f"grab.{name} = {v!r} is outside {lo:g}…{hi:g}")


@dataclass(frozen=True)
class GrabCommand:
    """What to send this tick."""

    t: float  # s (the caller's clock)
    phase: GrabPhase
    q: tuple[float, ...]  # joint command (rad or m), within the limits
    gripper_m: float  # gripper opening command per finger (m)
    done: bool  # the task finished successfully
    failed: bool  # the task gave up (unreachable waypoint, timeout); ``message`` says why
    message: str = ""


@dataclass(frozen=True)
class _Waypoint:
    phase: GrabPhase
    base_p: tuple[float, float, float]  # tool target (m)
    q: tuple[float, ...]  # its IK solution
    gripper_m: float  # gripper command during and after this waypoint


class GrabTask:
    """Steps a pick-and-place through its phases; ``step(t, q_measured)`` → GrabCommand."""

    def __init__(self, kin, profile, params: GrabParams, q_start: Sequence[float], t_start: float = 0.0,
                 gripper_start_m: Optional[float] = None) -> None:
        self.kin = kin
        self.profile = profile
        self.params = params
        g = profile.gripper
        self.gripper_speed_m_s = g.max_speed_m_s if g is not None else DEFAULT_GRIPPER_SPEED_M_S
        self.open_m = params.gripper_open_m if params.gripper_open_m is not None else (g.max_m if g else DEFAULT_GRIPPER_OPEN_M)
        self.closed_m = params.gripper_closed_m if params.gripper_closed_m is not None else (g.min_m if g else 0.0)
        lo, hi = profile.q_min, profile.q_max
        # the moves are planned from here: a made-up start (NaN → mid-range) could jump the arm
        q_start = require_finite("q_start", q_start, "rad or m", tuple(profile.joint_names))
        self.q_start = tuple(min(max(v, a), b) for v, a, b in zip(q_start, lo, hi))
        self.gripper_cmd = (require_finite_number("gripper_start_m", gripper_start_m, "m")
                            if gripper_start_m is not None else self.closed_m)
        self.phase = GrabPhase.APPROACH
        self.message = ""
        self.history: list[tuple[float, GrabPhase]] = []  # (time entered, phase)
        self._q_cmd = self.q_start
        self.workspace_note = ""  # why the last step stopped short (below the desk, a keep-out box)
        self._index = 0
        self._move: Optional[PointToPoint] = None
        self._grip_from = self.gripper_cmd
        self._grip_time = 0.0
        self._t_phase = float(t_start)
        self._waypoints = self._plan()
        if self.phase is not GrabPhase.FAILED:
            self._enter(0, float(t_start))

    # ---------------------------------------------------------------------------------------

    def _plan(self) -> list:
        """IK of every waypoint, warm-started along the sequence; fails the task on the first miss."""
        p = self.params
        up = np.array((0.0, 0.0, p.hover_m))
        pick, drop = np.asarray(p.base_p_pick, float), np.asarray(p.base_p_drop, float)
        spec = [
            (GrabPhase.APPROACH, pick + up, self.gripper_cmd, "point above the pick point"),
            (GrabPhase.OPEN, pick + up, self.open_m, "point above the pick point"),
            (GrabPhase.DESCEND, pick, self.open_m, "pick point"),
            (GrabPhase.CLOSE, pick, self.closed_m, "pick point"),
            (GrabPhase.LIFT, pick + up, self.closed_m, "point above the pick point"),
            (GrabPhase.CARRY, drop + up, self.closed_m, "point above the drop point"),
            (GrabPhase.CARRY, drop, self.closed_m, "drop point"),
            (GrabPhase.RELEASE, drop, self.open_m, "drop point"),
            (GrabPhase.RETREAT, drop + up, self.open_m, "point above the drop point"),
        ]
        out = []
        q = self.q_start
        for phase, target, grip, what in spec:
            target_t = (float(target[0]), float(target[1]), float(target[2]))
            res = self.kin.ik(target_t, q)
            if not res.success or not all(map(math.isfinite, res.q)):
                coords = ", ".join(f"{c:.3f}" for c in target_t)
                self._fail(f"the {what} ({coords}) m is out of reach by {format_distance(res.error_m)}"
                           " — nothing was moved")
                return []
            q = tuple(res.q)
            out.append(_Waypoint(phase, target_t, q, float(grip)))
        return out

    def _fail(self, message: str) -> None:
        self.phase = GrabPhase.FAILED
        self.message = message

    def _enter(self, index: int, t: float) -> None:
        wp = self._waypoints[index]
        if not self.history or self.history[-1][1] is not wp.phase:
            self.history.append((t, wp.phase))
        self._index = index
        self.phase = wp.phase
        self._t_phase = t
        self._move = joint_move(self.profile, self._q_cmd, wp.q, shape=self.params.shape,
                                speed_scale=self.params.speed_scale)
        self._grip_from = self.gripper_cmd
        self._grip_time = abs(wp.gripper_m - self.gripper_cmd) / self.gripper_speed_m_s

    # ---------------------------------------------------------------------------------------

    @property
    def done(self) -> bool:
        return self.phase is GrabPhase.DONE

    @property
    def failed(self) -> bool:
        return self.phase is GrabPhase.FAILED

    def _command(self, t: float) -> GrabCommand:
        return GrabCommand(t, self.phase, self._q_cmd, self.gripper_cmd, self.done, self.failed, self.message)

    def step(self, t: float, q_measured: Sequence[float], gripper_measured_m: Optional[float] = None) -> GrabCommand:
        """One control tick at time ``t`` (s) with the arm's measured joints (and gripper, if known).

        Without a measured gripper, the gripper counts as arrived once its move's time at the
        gripper's speed has passed (open loop). A non-finite ``t`` holds the command; measured
        joints that are not finite never count as arrived.
        """
        if self.phase in (GrabPhase.DONE, GrabPhase.FAILED) or not math.isfinite(t):
            return self._command(t)
        wp = self._waypoints[self._index]
        move = self._move
        elapsed = t - self._t_phase
        sp = move.sample(elapsed)
        # the desk and the keep-out boxes hold here too: the task streams joints itself
        self._q_cmd, self.workspace_note = limit_to_workspace(self._q_cmd, sp.q, self.profile, self.kin)
        frac = 1.0 if self._grip_time <= 0 else min(1.0, max(0.0, elapsed / self._grip_time))
        self.gripper_cmd = self._grip_from + (wp.gripper_m - self._grip_from) * frac
        planned = max(move.duration, self._grip_time)
        if elapsed >= planned:
            measured = all(map(math.isfinite, (float(v) for v in q_measured)))
            if measured:
                tool = np.asarray(self.kin.fk(q_measured), dtype=float)
                dist = float(np.linalg.norm(tool - np.asarray(wp.base_p)))
            else:
                dist = math.inf
            if math.isnan(dist):  # FK undefined there (a delta that does not assemble)
                dist = math.inf
            if gripper_measured_m is None:
                grip_ok = True
            else:
                grip_ok = abs(float(gripper_measured_m) - wp.gripper_m) <= self.params.gripper_tolerance_m
            if dist <= self.params.tolerance_m and grip_ok:
                if self._index + 1 < len(self._waypoints):
                    self._enter(self._index + 1, t)
                else:
                    self.phase = GrabPhase.DONE
                    self.history.append((t, GrabPhase.DONE))
                    self.message = "done"
                return self._command(t)
            if elapsed > planned + self.params.timeout_s:
                why = f"tool {format_distance(dist)} from its target" if measured else "measured joints not finite"
                if not grip_ok:
                    why += f", gripper at {gripper_measured_m * 1000:.1f} mm instead of {wp.gripper_m * 1000:.1f} mm"
                self._fail(f"timeout in phase {wp.phase.value!r} after {elapsed:.1f} s: {why}")
                # stop where the arm is; a joint measured as NaN/inf keeps its last command
                lo, hi = self.profile.q_min, self.profile.q_max
                self._q_cmd = tuple(
                    min(max(float(v), a), b) if math.isfinite(float(v)) else c
                    for v, c, a, b in zip(q_measured, self._q_cmd, lo, hi)
                )
                self.history.append((t, GrabPhase.FAILED))
        return self._command(t)
