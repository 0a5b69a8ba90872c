"""Jogging: move the arm by hand in small steps, in Cartesian space or one joint at a time.

A :class:`Jogger` is a pure, time-based model (no Qt, no threads, no clock of its own): the
window (keys, ± buttons) and any other input feed it presses and releases with a time, and it
answers with the new target.

- **Cartesian**: x, y or z ± the chosen step (1, 5 or 20 mm) applied to the current target,
  which is kept above the desk margin and inside the arm's reach (the nearest point the IK
  reaches, as OBJECT mode aims). The target then goes to the targeter's MANUAL mode.
- **Joint**: joint i ± the chosen step (1, 5 or 15 degrees; mm for a prismatic joint), kept
  within the joint's limits; a step that would take a clear arm into the desk or a keep-out
  box is refused. The target becomes a goal with ``joint_target`` (the controller skips the IK
  and applies its clamps, rate limits and workspace check as always).
- **Held**: a press moves one step at once (a tap); held longer than ``hold_delay_s`` the target
  then moves continuously at one step per ``repeat_period_s``, capped by a speed the arm can
  follow (so the target never runs far ahead of the arm), and stops where it is on release.
  Time steps longer than ``max_dt_s`` count as ``max_dt_s`` (a stalled timer never jumps).

Why a target and not a velocity command: the control step already limits speeds and checks the
workspace for every target; jogging a target keeps one safety path for every input.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum
from typing import Optional, Sequence

from core.messages import Goal, SequenceCounter, TargetMode, as_point
from core.motion.safety import clamp_to_limits, workspace_violation

AXES = ("x", "y", "z")
CARTESIAN_STEPS_M = (0.001, 0.005, 0.020)
JOINT_STEPS_DEG = (1.0, 5.0, 15.0)
PRISMATIC_STEPS_M = (0.001, 0.005, 0.020)  # the joint steps of a prismatic joint
REACH_TOL_M = 1e-4  # a target this close to the IK's answer counts as reached


class JogSpace(str, Enum):
    """What the ± inputs move."""

    CARTESIAN = "cartesian"  # the tool point along x, y, z of robot_base
    JOINT = "joint"  # one joint at a time


@dataclass(frozen=True)
class JogParams:
    """How jogging steps and moves while held."""

    cartesian_steps_m: tuple[float, ...] = CARTESIAN_STEPS_M  # step sizes to choose from (m), > 0
    joint_steps_deg: tuple[float, ...] = JOINT_STEPS_DEG  # revolute joints (deg), > 0
    prismatic_steps_m: tuple[float, ...] = PRISMATIC_STEPS_M  # prismatic joints (m), as many as joint_steps_deg
    hold_delay_s: float = 0.35  # a press held this long starts moving continuously, 0 … 5
    repeat_period_s: float = 0.1  # while held: one step per this period, > 0 … 5
    max_tool_speed_m_s: float = 0.10  # Cartesian hold never faster than this (also the arm's speed)
    max_dt_s: float = 0.1  # a longer time between updates counts as this much, > 0 … 1

    def __post_init__(self) -> None:
        for name in ("cartesian_steps_m", "joint_steps_deg", "prismatic_steps_m"):
            steps = getattr(self, name)
            if not steps or not all(math.isfinite(float(s)) and float(s) > 0.0 for s in steps):
                raise ValueError(f"JogParams.{name} = {steps!r} must be one or more finite numbers > 0")
        if len(self.cartesian_steps_m) != len(self.joint_steps_deg) or \
                len(self.prismatic_steps_m) != len(self.joint_steps_deg):
            raise ValueError("JogParams: cartesian_steps_m, joint_steps_deg and prismatic_steps_m must have"
                             f" as many sizes each (got {len(self.cartesian_steps_m)}, {len(self.joint_steps_deg)},"
                             f" {len(self.prismatic_steps_m)})")
        for name, lo, hi in (("hold_delay_s", 0.0, 5.0), ("repeat_period_s", 1e-3, 5.0),
                             ("max_tool_speed_m_s", 1e-3, 5.0), ("max_dt_s", 1e-3, 1.0)):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and lo <= v <= hi):
                raise ValueError(f"JogParams.{name} = {v!r} must be within {lo} … {hi}")


@dataclass
class _Held:
    direction: int  # +1 or -1
    t_pressed: float
    t_moved: float  # up to when the continuous motion has been applied


@dataclass
class Jogger:
    """Cartesian and joint jogging for one arm (see the module docstring).

    ``profile`` and ``kinematics`` are the session's; ``desk_margin_m`` defaults to the profile's
    workspace margin. Not thread-safe: one thread (the GUI's) owns it.
    """

    profile: object
    kinematics: object
    params: JogParams = field(default_factory=JogParams)
    desk_margin_m: Optional[float] = None
    space: JogSpace = JogSpace.CARTESIAN
    step_index: int = 1  # into the params' step sizes: 5 mm / 5 deg by default
    note: str = ""  # why the last step stopped short ("" when it went where asked)

    def __post_init__(self) -> None:
        if self.desk_margin_m is None:
            ws = getattr(self.profile, "workspace", None)
            self.desk_margin_m = float(getattr(ws, "desk_margin_m", 0.0) or 0.0)
        self.space = JogSpace(self.space)
        self.step_index = min(max(int(self.step_index), 0), len(self.params.cartesian_steps_m) - 1)
        self.base_p_target: Optional[tuple[float, float, float]] = None  # Cartesian target (m, robot_base)
        self.q_target: Optional[tuple[float, ...]] = None  # joint target
        self._held: dict[int, _Held] = {}
        self._q_seed = tuple(self.profile.q_home)
        self._seq = SequenceCounter()

    # --- settings ----------------------------------------------------------------------------
    @property
    def joint_count(self) -> int:
        return len(self.profile.joints)

    @property
    def channel_count(self) -> int:
        """How many ± pairs the current space has: 3 axes, or one per joint."""
        return 3 if self.space is JogSpace.CARTESIAN else self.joint_count

    def set_space(self, space) -> None:
        """Cartesian or joint; anything held is released (its target stays where it is)."""
        self.release_all()
        self.space = JogSpace(space)

    def toggle_space(self) -> JogSpace:
        self.set_space(JogSpace.JOINT if self.space is JogSpace.CARTESIAN else JogSpace.CARTESIAN)
        return self.space

    def set_step_index(self, index: int) -> None:
        self.step_index = min(max(int(index), 0), len(self.params.cartesian_steps_m) - 1)

    def change_step(self, delta: int) -> int:
        """A bigger (+1) or smaller (-1) step size; stays at the ends. Returns the new index."""
        self.set_step_index(self.step_index + int(delta))
        return self.step_index

    @property
    def cartesian_step_m(self) -> float:
        return float(self.params.cartesian_steps_m[self.step_index])

    def joint_step(self, joint: int) -> float:
        """The step of ``joint`` in joint units (rad, or m for a prismatic joint)."""
        if self.profile.joints[joint].joint_type == "prismatic":
            return float(self.params.prismatic_steps_m[self.step_index])
        return math.radians(self.params.joint_steps_deg[self.step_index])

    def step_label(self) -> str:
        """The step size for people, e.g. "5 mm / 5°"."""
        return f"{self.cartesian_step_m * 1e3:g} mm / {self.params.joint_steps_deg[self.step_index]:g}°"

    # --- where jogging starts ----------------------------------------------------------------
    def start_cartesian(self, base_p) -> tuple[float, float, float]:
        """Jog from ``base_p`` (the current target or tool point), brought into the workspace."""
        self.base_p_target, self.note = self.clip(base_p)
        return self.base_p_target

    def start_joints(self, q) -> tuple[float, ...]:
        """Jog the joints from ``q`` (the last command or the measured joints), within the limits."""
        self.q_target = clamp_to_limits(q, self.profile)[0]
        self._q_seed = self.q_target
        return self.q_target

    def begin(self, q_arm, manual_target=None, joint_jog=None):
        """Start a jog from where the arm is aimed: in MANUAL mode (``manual_target`` given) from
        the manual target, or from the joint jog's target when one is on (``joint_jog``); in any
        other mode from ``q_arm``, the joints the arm is commanded to (so jogging out of Follow
        starts at the tool, not at an old target). Returns the start (a point or joint values)."""
        joints = joint_jog if manual_target is not None and joint_jog is not None else None
        if self.space is JogSpace.CARTESIAN:
            if manual_target is not None and joints is None:
                return self.start_cartesian(manual_target)
            return self.start_cartesian(self.kinematics.fk(q_arm if joints is None else joints))
        return self.start_joints(q_arm if joints is None else joints)

    def tool_point(self, q) -> tuple[float, float, float]:
        """The tool point of joint values ``q`` (robot_base, m): where a joint jog puts the manual target."""
        return tuple(float(v) for v in self.kinematics.fk(q))

    def readout(self, q_commanded, manual_target, joint_jog=None) -> tuple[tuple[float, float, float], list[str]]:
        """What a jog panel shows: the point (the joint jog's tool point in joint space, else the
        manual target) and the joints for people (the joint jog's, else ``q_commanded``, else home)."""
        joint_space = self.space is JogSpace.JOINT
        q = joint_jog if joint_space and joint_jog is not None else (
            q_commanded if q_commanded is not None else self.profile.q_home)
        p = self.kinematics.fk(q) if joint_space else manual_target
        return p, joint_display(self.profile, q)

    # --- clipping ----------------------------------------------------------------------------
    def clip(self, base_p) -> tuple[tuple[float, float, float], str]:
        """``base_p`` above the desk margin and then at the nearest point the arm reaches; the note
        says what changed ("" when nothing did)."""
        x, y, z = (float(v) for v in base_p)
        if not all(map(math.isfinite, (x, y, z))):
            raise ValueError(f"jog target {base_p!r} must be three finite numbers (m)")
        notes = []
        if z < self.desk_margin_m:
            z = self.desk_margin_m
            notes.append(f"desk margin: z ≥ {self.desk_margin_m * 1e3:.0f} mm")
        p = (x, y, z)
        ik = self.kinematics.ik(p, self._q_seed)
        if all(map(math.isfinite, ik.q)):
            self._q_seed = tuple(ik.q)
        reached = as_point(ik.base_p_reached)
        if not ik.success and math.dist(p, reached) > REACH_TOL_M and all(map(math.isfinite, reached)):
            if reached[2] < self.desk_margin_m:  # the nearest point is under the margin: lift it
                reached = (reached[0], reached[1], self.desk_margin_m)
                lifted = self.kinematics.ik(reached, ik.q)
                reached = as_point(lifted.base_p_reached) if lifted.base_p_reached[2] >= self.desk_margin_m - 1e-9 \
                    else reached
            notes.append(f"out of reach by {math.dist(p, reached) * 1e3:.0f} mm — at the nearest point")
            p = reached
        return p, "; ".join(notes)

    # --- single steps ------------------------------------------------------------------------
    def step_cartesian(self, axis: int, direction: int, distance_m: Optional[float] = None):
        """Move the Cartesian target along ``axis`` (0 x, 1 y, 2 z) by ``direction`` × the step (or
        ``distance_m``), clipped; returns the new target. Call :meth:`start_cartesian` first."""
        if self.base_p_target is None:
            raise RuntimeError("Jogger.step_cartesian before start_cartesian: tell it where the target is first")
        d = self.cartesian_step_m if distance_m is None else float(distance_m)
        p = list(self.base_p_target)
        p[int(axis)] += _sign(direction) * d
        self.base_p_target, self.note = self.clip(p)
        return self.base_p_target

    def step_joint_target(self, joint: int, direction: int, distance: Optional[float] = None):
        """Move joint ``joint`` by ``direction`` × its step (or ``distance``, rad or m), within its
        limits; a step that would take a clear arm out of the workspace is refused (``note``
        says why). Returns the new joint target. Call :meth:`start_joints` first."""
        if self.q_target is None:
            raise RuntimeError("Jogger.step_joint_target before start_joints: tell it where the joints are first")
        j = int(joint)
        if not 0 <= j < self.joint_count:
            raise ValueError(f"joint {j} does not exist: profile {self.profile.name!r} has joints 0 … "
                             f"{self.joint_count - 1} ({', '.join(self.profile.joint_names)})")
        d = self.joint_step(j) if distance is None else float(distance)
        q = list(self.q_target)
        q[j] += _sign(direction) * d
        q_new, clamped = clamp_to_limits(q, self.profile)
        notes = [f"{self.profile.joints[j].name} at its limit"] if clamped else []
        why = workspace_violation(q_new, self.profile, self.kinematics)
        if why and not workspace_violation(self.q_target, self.profile, self.kinematics):
            notes.append(f"{why} — joint step refused")
            q_new = self.q_target
        self.q_target = tuple(q_new)
        self.note = "; ".join(notes)
        return self.q_target

    # --- held inputs -------------------------------------------------------------------------
    def press(self, channel: int, direction: int, t: float):
        """A key or button goes down: one step at once; held, :meth:`update` moves on. Returns
        the new target (a point in Cartesian space, joint values in joint space)."""
        channel = int(channel)
        if not 0 <= channel < self.channel_count:
            raise ValueError(f"jog channel {channel} does not exist in {self.space.value} space "
                             f"(0 … {self.channel_count - 1})")
        self._held[channel] = _Held(_sign(direction), float(t), float(t) + self.params.hold_delay_s)
        return self._step(channel, _sign(direction), None)

    def release(self, channel: int, t: float):
        """The key or button is up: the target stops where it is (motion up to ``t`` applied)."""
        self.update(t)
        self._held.pop(int(channel), None)
        return self.target

    def release_all(self) -> None:
        """Everything up at once (focus lost, space switched, e-stop): the target stays put."""
        self._held.clear()

    @property
    def holding(self) -> bool:
        return bool(self._held)

    def held_channels(self) -> dict[int, int]:
        """{channel: direction} of what is held now."""
        return {c: h.direction for c, h in self._held.items()}

    def update(self, t: float):
        """Continuous motion of every held channel up to ``t``; returns the target when it moved,
        else None (nothing held, or still within the hold delay)."""
        moved = False
        for channel, held in list(self._held.items()):
            if t <= held.t_moved:
                continue
            dt = min(float(t) - held.t_moved, self.params.max_dt_s)
            held.t_moved = float(t)
            if self.space is JogSpace.CARTESIAN:
                speed = min(self.cartesian_step_m / self.params.repeat_period_s, self.params.max_tool_speed_m_s)
            else:
                joint = self.profile.joints[channel]
                speed = min(self.joint_step(channel) / self.params.repeat_period_s,
                            math.radians(joint.max_speed_deg_s))
            self._step(channel, held.direction, speed * dt)
            moved = True
        return self.target if moved else None

    def _step(self, channel: int, direction: int, distance: Optional[float]):
        if self.space is JogSpace.CARTESIAN:
            return self.step_cartesian(channel, direction, distance)
        return self.step_joint_target(channel, direction, distance)

    @property
    def target(self):
        """The current target of the current space (None before it was started)."""
        return self.base_p_target if self.space is JogSpace.CARTESIAN else self.q_target

    # --- goals -------------------------------------------------------------------------------
    def goal(self, t: float, source_t: Optional[float] = None) -> Optional[Goal]:
        """The current target as a MANUAL goal: a point, or ``joint_target`` in joint space (its
        ``base_p_target`` is then the tool point of those joints). None before a start."""
        if self.space is JogSpace.CARTESIAN:
            if self.base_p_target is None:
                return None
            return Goal(self._seq.next(), t, self.base_p_target, TargetMode.MANUAL, source_t, note="jog")
        if self.q_target is None:
            return None
        return Goal(self._seq.next(), t, as_point(self.kinematics.fk(self.q_target)), TargetMode.MANUAL,
                    source_t, note="joint jog", joint_target=self.q_target)


def _sign(direction) -> int:
    d = float(direction)
    if d > 0:
        return 1
    if d < 0:
        return -1
    raise ValueError(f"jog direction {direction!r} must be +1 or -1")


def joint_display(profile, q: Sequence[float]) -> list[str]:
    """Joint values for people: "12.0°" for revolute joints, "35.0 mm" for prismatic ones."""
    out = []
    for joint, v in zip(profile.joints, q):
        if joint.joint_type == "prismatic":
            out.append(f"{float(v) * 1e3:.1f} mm")
        else:
            out.append(f"{math.degrees(float(v)):.1f}°")
    return out


class JogTeleopSource:
    """The keyboard (or any ± input) as a teleop source: what ``Targeter.set_teleop`` takes, so
    TELEOP mode can be driven by jogging like by a hand (``core.motion.teleop.TeleopController``'s
    ``goal(result, t)``, ``status()``, ``restart()``).

    Presses and releases come from the input's thread; ``goal`` runs in the control worker under
    the Targeter's lock and advances the held motion to the goal's time ``t`` (the targeter's
    clock, so the simulated desk's time works too). A lock keeps the two apart. Only Cartesian
    jogging fits this interface (a teleop goal is a point): in joint space ``goal`` holds and says
    so — joint jogging goes through MANUAL goals with ``joint_target`` instead.
    """

    name = "keyboard"

    def __init__(self, jogger: Jogger, start_base_p=None):
        import threading

        self.jogger = jogger
        self._lock = threading.Lock()
        self._start = None if start_base_p is None else as_point(start_base_p)
        self.message = "teleop: keyboard — press an arrow key to move"
        self.restart()

    def restart(self) -> None:
        """Back to the start point (or the arm's home point), nothing held."""
        with self._lock:
            self.jogger.release_all()
            start = self._start
            if start is None:
                start = self.jogger.kinematics.fk(self.jogger.profile.q_home)
            self.jogger.start_cartesian(start)

    def press(self, channel: int, direction: int, t: float):
        with self._lock:
            return self.jogger.press(channel, direction, t)

    def release(self, channel: int, t: float):
        with self._lock:
            return self.jogger.release(channel, t)

    def release_all(self) -> None:
        with self._lock:
            self.jogger.release_all()

    def goal(self, result, t: float) -> tuple[Optional[tuple[float, float, float]], str]:
        """The jog target at ``t`` (robot_base, m), or (None, why) in joint space."""
        with self._lock:
            if self.jogger.space is not JogSpace.CARTESIAN:
                return None, "teleop: keyboard in joint space — holding (joint jogging uses Manual mode)"
            self.jogger.update(t)
            held = self.jogger.held_channels()
            moving = ", ".join(f"{AXES[c]}{'+' if d > 0 else '−'}" for c, d in sorted(held.items()))
            self.message = f"teleop: keyboard — moving {moving}" if held else "teleop: keyboard — holding"
            if self.jogger.note:
                self.message += f" ({self.jogger.note})"
            return self.jogger.base_p_target, self.message

    def status(self):
        """A ``core.motion.teleop.TeleopStatus``: always "following" (no gestures, no calibration)."""
        from core.motion.teleop import FOLLOWING, Box, TeleopStatus  # lazily: the teleop core is optional here

        with self._lock:
            p = self.jogger.base_p_target
            r = float(self.jogger.kinematics.workspace_radius_range()[1])
            margin = float(self.jogger.desk_margin_m)
            return TeleopStatus(
                state=FOLLOWING, source=self.name, message=self.message, hand_seen=True,
                base_p_hand=p, base_p_mapped=p, corner_a=None, hand_box=None,
                target_box=Box((-r, -r, margin), (r, r, margin + r)), events=(), state_s={})


# Linux input event codes (linux/input-event-codes.h), as python-evdev's InputEvent carries them
EV_KEY, EV_ABS = 0x01, 0x03
ABS_HAT0X, ABS_HAT0Y = 0x10, 0x11  # the D-pad: -1, 0, +1 (Y: -1 is up)
BTN_NORTH, BTN_WEST, BTN_TL, BTN_TR, BTN_SELECT = 0x133, 0x134, 0x136, 0x137, 0x13A


class GamepadJog:
    """A gamepad's events → jog presses and releases (D-pad x/y or the joint, shoulder buttons z or
    the joint before/after, X/Y buttons step size, Select switches space).

    Takes (type, code, value, t) as python-evdev's ``InputDevice.read_loop()`` yields them
    (``event.type, event.code, event.value, event.timestamp()``) — no SDL, no root (the user in
    the ``input`` group); ``jog`` is a Jogger or a JogTeleopSource. Not wired to a device here."""

    def __init__(self, jog):
        self.jog, self.joint, self._held = jog, 0, {}  # {code: channel} of what is down

    def feed(self, ev_type: int, code: int, value: int, t: float) -> None:
        jogger = getattr(self.jog, "jogger", self.jog)
        cartesian = jogger.space is JogSpace.CARTESIAN
        if code in self._held and (ev_type == EV_ABS or value == 0):  # let go (or the D-pad turned)
            self.jog.release(self._held.pop(code), t)
        if ev_type == EV_ABS and code in (ABS_HAT0X, ABS_HAT0Y) and value:
            direction = value if code == ABS_HAT0X else -value
            self._held[code] = (0 if code == ABS_HAT0X else 1) if cartesian else self.joint
            self.jog.press(self._held[code], direction, t)
        elif ev_type == EV_KEY and value == 1 and code in (BTN_TL, BTN_TR):
            if cartesian:
                self._held[code] = 2
                self.jog.press(2, -1 if code == BTN_TL else 1, t)
            else:
                self.joint = min(max(self.joint + (-1 if code == BTN_TL else 1), 0), jogger.joint_count - 1)
        elif ev_type == EV_KEY and value == 1 and code in (BTN_WEST, BTN_NORTH):
            jogger.change_step(1 if code == BTN_NORTH else -1)
        elif ev_type == EV_KEY and value == 1 and code == BTN_SELECT:
            self._held.clear()
            jogger.toggle_space()
