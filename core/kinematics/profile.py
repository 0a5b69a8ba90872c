"""Robot profiles: the TOML files that describe an arm (kind, geometry, joints, servo mapping).

A profile is read once, validated, and turned into frozen dataclasses that the kinematics,
the safety clamps and the motor bridges share read-only. Every error a user can hit names the
file, the key and what was expected, e.g.::

    .../desk_rrr.toml: joints[1].servo_max_deg = 200 is outside 0…180

Built-in profiles live in ``resources/robots/<name>.toml``; ``load_profile`` also accepts a
path to any TOML file, or ``urdf:PATH``. Units inside are SI (m, rad); degrees appear only in
fields whose names end in ``_deg``.

Kinds (``kind = ...``):

- ``"rrr"``: the yaw–shoulder–elbow desk arm on three hobby servos (analytic IK);
- ``"delta3"``: a three-arm parallel (delta) robot on three servos (analytic IK and FK);
- ``"urdf"``: any serial arm described by a URDF file (``[geometry] urdf = "x.urdf"``,
  ``tip = "tool"``), solved by closed-loop IK with Pinocchio. Its joints — the ones between
  the URDF's root and the tip frame — come from the URDF (limits in rad or m, velocities);
  optional ``[[joints]]`` entries, by name, narrow the limits or set ``home``,
  ``max_velocity`` and ``max_acceleration``. URDF mimic joints are not profile joints: their
  values follow the joints they mimic (``core.kinematics.urdf``). A URDF arm on hobby servos
  gives each joint's entry the servo fields below (``servo_min_deg``, ``servo_max_deg``,
  ``offset_deg``, ``direction``, optionally ``home_servo_deg`` — or ``home`` in rad — and
  ``max_speed_deg_s``, default the URDF's velocity): its limits then follow from the servo range,
  which must map inside the URDF's limits, and every joint needs a mapping or none does (the
  servo bridges drive all joints). ``umi_rtx`` and ``assistive_5dof`` (servo-mapped) are URDF
  profiles, and ``load_profile("urdf:PATH", tip="FRAME")`` makes one from any URDF file.

A joint is either a hobby servo (``servo_min_deg``/``servo_max_deg``/``offset_deg``/
``direction``: its limits follow from the servo range) or a plain joint with ``lower``/``upper``
in joint units (rad for revolute joints, m for prismatic ones). ``q_min``/``q_max``/``q_home``
work for both; servo angles exist only for servo joints.

Every kind may add a ``[workspace]`` table — ``desk_margin_m`` (default 0.005 m: no moving part
of the arm closer to the desk plane z = 0) and ``[[workspace.keep_out]]`` boxes (``name``,
``min = [x, y, z]``, ``max = [x, y, z]`` in m, robot_base) that no arm segment may enter; the
control step enforces them (``core.motion.safety.workspace_violation``) — and a
``[tool_marker]`` table (``id``, ``offset_m = [x, y, z]`` from the tool point in robot_base
axes, ``size_m``): an ArUco marker fixed to the tool, for hand-eye calibration.

A new kind adds a geometry parser to ``_GEOMETRY_PARSERS``, its joint count to
``_JOINT_COUNTS`` (None: the geometry decides) and a solver to ``core.kinematics.SOLVERS``;
``core.kinematics.build_kinematics`` then hands out the right solver.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Optional, Sequence, Union

from core.kinematics.base import MAX_JOINTS, ProfileError
from core.settings import is_number as _is_number
from core.settings import toml_type_name as _type_name

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

SERVO_MIN_DEG = 0.0  # the hobby servos (and the v1 protocol's angle byte) span 0…180°
SERVO_MAX_DEG = 180.0
OFFSET_LIMIT_DEG = 360.0  # |offset_deg| above this is surely a typo
MAX_SPEED_LIMIT_DEG_S = 3600.0  # no hobby servo turns ten revolutions a second
LENGTH_LIMIT_M = 5.0  # a desk arm longer than this is a unit mistake (cm or mm typed as m)
REVOLUTE_LIMIT_RAD = 4.0 * math.pi  # |lower|, |upper| of a revolute joint (URDFs use up to ±2π)
MAX_VELOCITY_LIMIT = 100.0  # rad/s or m/s: above this a velocity is surely a unit mistake
MAX_ACCELERATION_LIMIT = 1000.0  # rad/s² or m/s²
DEFAULT_PRISMATIC_SPEED_M_S = 0.1  # a prismatic joint without a velocity limit
DEFAULT_ACCELERATION_RAD_S2 = 10.0  # a revolute joint without an acceleration limit
DEFAULT_ACCELERATION_M_S2 = 0.5  # a prismatic joint without an acceleration limit
JOINT_TYPES = ("revolute", "prismatic")
DEFAULT_DESK_MARGIN_M = 0.005  # no arm point closer to the desk than this by default
MAX_DESK_MARGIN_M = 0.1  # workspace.desk_margin_m: 0 … this
KEEP_OUT_LIMIT_M = 5.0  # |coordinate| of a keep-out box corner, m
TOOL_MARKER_MAX_ID = 999  # tool_marker.id: 0 … this
TOOL_MARKER_OFFSET_LIMIT_M = 0.2  # |tool_marker.offset_m| per axis, m
TOOL_MARKER_SIZE_RANGE_M = (0.005, 0.2)  # tool_marker.size_m: the marker's side, m



# --------------------------------------------------------------------------------------------
# Dataclasses


@dataclass(frozen=True)
class JointSpec:
    """One joint: a hobby servo (servo range, offset, direction) or a plain joint (limits in q).

    Servo joints give the four servo fields; their limits follow from the servo range, and q is
    in rad. Plain joints (UMI-RTX, URDF arms) give ``lower``/``upper`` in joint units instead —
    rad for ``joint_type = "revolute"``, m for ``"prismatic"`` — and have no servo angles.
    """

    name: str  # joint name, e.g. "shoulder"
    servo_min_deg: Optional[float] = None  # servo joints: lowest servo angle, deg, 0 … servo_max_deg
    servo_max_deg: Optional[float] = None  # servo joints: highest servo angle, deg, servo_min_deg … 180
    offset_deg: Optional[float] = None  # servo joints: servo angle at q = 0, deg, -360 … 360
    direction: Optional[int] = None  # servo joints: +1 or -1: servo_deg = offset_deg + direction * degrees(q)
    # fastest allowed motion of a revolute joint, deg/s, 0 (excl.) … 3600. For a plain joint
    # with max_velocity it is set to degrees(max_velocity), so radians(max_speed_deg_s) is the
    # speed in joint units per second for every joint (prismatic ones too: m/s)
    max_speed_deg_s: float = 300.0
    home_servo_deg: Optional[float] = None  # servo joints: servo angle of the home pose; None = mid-range
    joint_type: str = "revolute"  # "revolute" (q in rad) or "prismatic" (q in m); servos are revolute
    lower: Optional[float] = None  # plain joints: lower limit, rad or m
    upper: Optional[float] = None  # plain joints: upper limit, rad or m, > lower
    home: Optional[float] = None  # plain joints: home value, rad or m; None = 0 clamped into the limits
    max_velocity: Optional[float] = None  # plain joints: rad/s or m/s, 0 (excl.) … 100; None = default
    max_acceleration: Optional[float] = None  # rad/s² or m/s², 0 (excl.) … 1000; None = default

    def __post_init__(self) -> None:
        prefix = f"joint {self.name!r}: "
        if self.has_servo:
            missing = [k for k in ("servo_min_deg", "servo_max_deg", "offset_deg", "direction")
                       if getattr(self, k) is None]
            if missing:
                raise ProfileError(f"{prefix}a servo joint needs {', '.join(missing)} too")
            extra = [k for k in ("lower", "upper", "home", "max_velocity") if getattr(self, k) is not None]
            if extra or self.joint_type != "revolute":
                raise ProfileError(
                    f"{prefix}a servo joint is revolute and takes its limits from the servo range;"
                    f" remove {', '.join(extra) or 'joint_type'}"
                )
            _check_joint("", prefix, _joint_fields(self))
        else:
            _check_plain_joint("", prefix, _plain_fields(self))
            if self.max_velocity is not None:
                object.__setattr__(self, "max_speed_deg_s", math.degrees(self.max_velocity))
            elif self.joint_type == "prismatic":
                object.__setattr__(self, "max_speed_deg_s", math.degrees(DEFAULT_PRISMATIC_SPEED_M_S))
        if self.max_acceleration is not None:
            _check_range("", prefix + "max_acceleration", self.max_acceleration, 0.0,
                         MAX_ACCELERATION_LIMIT, lo_open=True, why="it must be > 0")

    @property
    def has_servo(self) -> bool:
        """True for a hobby-servo joint (servo angles exist); False for a plain joint."""
        return not (self.servo_min_deg is None and self.servo_max_deg is None
                    and self.offset_deg is None and self.direction is None)

    @property
    def unit(self) -> str:
        """Unit of q: "rad" (revolute) or "m" (prismatic)."""
        return "m" if self.joint_type == "prismatic" else "rad"

    @property
    def q_min(self) -> float:
        """Lower joint limit (rad or m); for a servo, from the servo range through offset and direction."""
        if not self.has_servo:
            return float(self.lower)  # type: ignore[arg-type]
        a = self.from_servo_deg(self.servo_min_deg)  # type: ignore[arg-type]
        b = self.from_servo_deg(self.servo_max_deg)  # type: ignore[arg-type]
        return min(a, b)

    @property
    def q_max(self) -> float:
        """Upper joint limit (rad or m); for a servo, from the servo range through offset and direction."""
        if not self.has_servo:
            return float(self.upper)  # type: ignore[arg-type]
        a = self.from_servo_deg(self.servo_min_deg)  # type: ignore[arg-type]
        b = self.from_servo_deg(self.servo_max_deg)  # type: ignore[arg-type]
        return max(a, b)

    @property
    def q_home(self) -> float:
        """Joint value (rad or m) of the home pose."""
        if not self.has_servo:
            if self.home is not None:
                return float(self.home)
            return min(max(0.0, float(self.lower)), float(self.upper))  # type: ignore[arg-type]
        home = self.home_servo_deg
        if home is None:
            home = 0.5 * (self.servo_min_deg + self.servo_max_deg)  # type: ignore[operator]
        return self.from_servo_deg(home)

    @property
    def velocity_limit(self) -> float:
        """Fastest allowed motion, rad/s (revolute, servo) or m/s (prismatic)."""
        if self.max_velocity is not None and not self.has_servo:
            return float(self.max_velocity)
        return math.radians(self.max_speed_deg_s)

    @property
    def acceleration_limit(self) -> float:
        """Largest allowed acceleration, rad/s² or m/s² (a default when the profile gives none)."""
        if self.max_acceleration is not None:
            return float(self.max_acceleration)
        return DEFAULT_ACCELERATION_M_S2 if self.joint_type == "prismatic" else DEFAULT_ACCELERATION_RAD_S2

    def _no_servo(self) -> ProfileError:
        return ProfileError(
            f"joint {self.name!r} has no servo mapping (its limits are in {self.unit}): servo "
            "angles exist only for hobby-servo profiles such as desk_rrr"
        )

    def to_servo_deg(self, q: float) -> float:
        """Servo angle (deg) for the joint value ``q`` (rad); no clamping (see core.motion.safety).

        Raises ProfileError for a plain (non-servo) joint.
        """
        if not self.has_servo:
            raise self._no_servo()
        return self.offset_deg + self.direction * math.degrees(q)  # type: ignore[operator]

    def from_servo_deg(self, servo_deg: float) -> float:
        """Joint value (rad) for the servo angle ``servo_deg``; no clamping. Servo joints only."""
        if not self.has_servo:
            raise self._no_servo()
        return self.direction * math.radians(servo_deg - self.offset_deg)  # type: ignore[operator]

    @property
    def display_unit(self) -> str:
        """Unit for people: "deg" (revolute) or "mm" (prismatic)."""
        return "mm" if self.joint_type == "prismatic" else "deg"

    def to_display(self, q: float) -> float:
        """``q`` (rad or m) in ``display_unit`` (deg or mm), for GUI fields and the command line."""
        return q * 1000.0 if self.joint_type == "prismatic" else math.degrees(q)

    def from_display(self, value: float) -> float:
        """A value in ``display_unit`` (deg or mm) as q (rad or m)."""
        return value / 1000.0 if self.joint_type == "prismatic" else math.radians(value)


@dataclass(frozen=True)
class RRRGeometry:
    """Yaw–shoulder–elbow arm: shoulder on the yaw axis, tool point at the forearm's end."""

    shoulder_height_m: float  # shoulder axis above the desk, on the yaw axis, 0 … 5 m
    upper_arm_m: float  # shoulder axis to elbow axis, 0 (excl.) … 5 m
    forearm_m: float  # elbow axis to the tool point, 0 (excl.) … 5 m

    def __post_init__(self) -> None:
        _check_rrr_geometry("", "geometry.", _rrr_fields(self))


@dataclass(frozen=True)
class DeltaGeometry:
    """Three-arm parallel (delta) robot hanging from a base plate above the desk.

    Arm i's shoulder axis lies in the base plate at ``base_radius_m`` from its centre, at
    azimuth ``first_arm_azimuth_deg + 120° · i``; its upper arm swings in the vertical plane
    through that azimuth (q = 0 horizontal and pointing outwards, q > 0 down); a forearm
    (parallelogram) joins the elbow to the effector at ``effector_radius_m`` from its centre.
    """

    base_height_m: float  # base plate (the shoulder axes' plane) above the desk, 0 (excl.) … 5 m
    base_radius_m: float  # base centre to each shoulder axis, 0 (excl.) … 5 m
    effector_radius_m: float  # effector centre to each forearm joint, 0 … 5 m
    upper_arm_m: float  # shoulder axis to elbow, 0 (excl.) … 5 m
    forearm_m: float  # elbow to effector joint, 0 (excl.) … 5 m
    tool_offset_m: float = 0.0  # tool point below the effector centre, 0 … 5 m
    first_arm_azimuth_deg: float = 90.0  # azimuth of arm 0 from +x towards +y, deg, -360 … 360

    def __post_init__(self) -> None:
        _check_delta_geometry("", "geometry.", _delta_fields(self))

    @property
    def arm_azimuths_rad(self) -> tuple[float, float, float]:
        """Azimuth (rad, from +x towards +y) of each arm's vertical plane."""
        a0 = math.radians(self.first_arm_azimuth_deg)
        return (a0, a0 + 2.0 * math.pi / 3.0, a0 + 4.0 * math.pi / 3.0)


@dataclass(frozen=True)
class UrdfGeometry:
    """A serial arm described by a URDF file; robot_base is the URDF's root link."""

    urdf_path: str  # absolute path of the URDF file
    tip_frame: str  # URDF frame (link or joint) whose origin is the tool point
    camera_frame: str = ""  # optional frame of an eye-in-hand camera ("" = none)

    def __post_init__(self) -> None:
        if not self.urdf_path:
            raise ProfileError("geometry.urdf must name a URDF file")
        if not self.tip_frame:
            raise ProfileError("geometry.tip must name a frame of the URDF")


@dataclass(frozen=True)
class GripperSpec:
    """A parallel gripper: opening per finger, commanded beside the arm's joints (not in q)."""

    name: str = "gripper"  # e.g. the URDF finger joint it drives
    min_m: float = 0.0  # closed opening per finger, m, 0 … max_m
    max_m: float = 0.05  # fully open opening per finger, m, min_m (excl.) … 1
    max_speed_m_s: float = 0.05  # finger speed, m/s, 0 (excl.) … 10

    def __post_init__(self) -> None:
        _check_gripper("", "gripper.", _gripper_fields(self))


@dataclass(frozen=True)
class KeepOutBox:
    """An axis-aligned box in robot_base that no part of the arm may enter (a monitor, a lamp)."""

    name: str  # shown in the reason, e.g. "monitor"
    min_m: tuple[float, float, float]  # lowest corner (x, y, z), m, robot_base, each in ±5 m
    max_m: tuple[float, float, float]  # highest corner, m, > min_m on every axis, each in ±5 m

    def __post_init__(self) -> None:
        object.__setattr__(self, "min_m", tuple(float(v) for v in self.min_m))
        object.__setattr__(self, "max_m", tuple(float(v) for v in self.max_m))
        _check_box("", f"keep-out box {self.name!r}: ", self.name, self.min_m, self.max_m)


@dataclass(frozen=True)
class WorkspaceSpec:
    """Where the arm may be: above the desk plane by a margin, and outside keep-out boxes."""

    desk_margin_m: float = DEFAULT_DESK_MARGIN_M  # no moving arm point below z = this, m, 0 … 0.1
    keep_out: tuple[KeepOutBox, ...] = ()  # boxes no arm segment may enter

    def __post_init__(self) -> None:
        object.__setattr__(self, "keep_out", tuple(self.keep_out))
        _check_range("", "workspace.desk_margin_m", self.desk_margin_m, 0.0, MAX_DESK_MARGIN_M)
        for i, box in enumerate(self.keep_out):
            if not isinstance(box, KeepOutBox):
                raise ProfileError(f"workspace.keep_out[{i}] must be a KeepOutBox, got {type(box).__name__}")


@dataclass(frozen=True)
class ToolMarkerSpec:
    """An ArUco marker fixed to the tool, for hand-eye calibration."""

    marker_id: int  # ArUco id, 0 … 999
    offset_m: tuple[float, float, float]  # marker centre from the tool point, robot_base axes, m, each in ±0.2
    size_m: float  # marker side, m, 0.005 … 0.2

    def __post_init__(self) -> None:
        object.__setattr__(self, "offset_m", tuple(float(v) for v in self.offset_m))
        _check_tool_marker("", "tool_marker.", self.marker_id, self.offset_m, self.size_m)


@dataclass(frozen=True)
class RobotProfile:
    """A validated robot description; read-only and shared by every worker."""

    name: str  # profile name, e.g. "desk_rrr"
    kind: str  # kinematic family; chooses the solver (see build_kinematics)
    description: str  # one line for the GUI
    geometry: Any  # kind-specific: RRRGeometry ("rrr"), DeltaGeometry ("delta3"), UrdfGeometry ("urdf")
    joints: tuple[JointSpec, ...]  # in kinematic order (q1, q2, …)
    source: str = ""  # the file it was read from ("" when built in code)
    gripper: Optional[GripperSpec] = None  # a gripper commanded beside the joints, if any
    workspace: WorkspaceSpec = field(default_factory=WorkspaceSpec)  # desk margin and keep-out boxes (core.motion.safety)
    tool_marker: Optional[ToolMarkerSpec] = None  # a marker on the tool for hand-eye calibration

    def __post_init__(self) -> None:
        if not isinstance(self.workspace, WorkspaceSpec):
            raise ProfileError(f"workspace must be a WorkspaceSpec, got {type(self.workspace).__name__}")
        if self.kind not in _JOINT_COUNTS:
            raise ProfileError(
                f"kind = {self.kind!r} is unknown; expected one of {', '.join(_JOINT_COUNTS)}"
            )
        expected = _JOINT_COUNTS[self.kind]
        if expected is not None and len(self.joints) != expected:
            raise ProfileError(
                f"kind {self.kind!r} needs {expected} joints, got {len(self.joints)}"
            )
        if not 1 <= len(self.joints) <= MAX_JOINTS:
            raise ProfileError(f"kind {self.kind!r} needs 1…{MAX_JOINTS} joints, got {len(self.joints)}")
        geometry_type = _GEOMETRY_TYPES[self.kind]
        if not isinstance(self.geometry, geometry_type):
            raise ProfileError(
                f"kind {self.kind!r} needs a {geometry_type.__name__}, got {type(self.geometry).__name__}"
            )
        if self.kind in _SERVO_KINDS and not self.has_servos:
            raise ProfileError(f"kind {self.kind!r} needs servo joints (servo_min_deg, offset_deg, …)")

    @property
    def n_joints(self) -> int:
        return len(self.joints)

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    @property
    def has_servos(self) -> bool:
        """True when every joint is a hobby servo (servo angles and the v1 protocol apply)."""
        return all(j.has_servo for j in self.joints)

    @property
    def joint_types(self) -> tuple[str, ...]:
        """"revolute" or "prismatic" per joint."""
        return tuple(j.joint_type for j in self.joints)

    @property
    def q_min(self) -> tuple[float, ...]:
        """Lower joint limits (rad or m)."""
        return tuple(j.q_min for j in self.joints)

    @property
    def q_max(self) -> tuple[float, ...]:
        """Upper joint limits (rad or m)."""
        return tuple(j.q_max for j in self.joints)

    @property
    def q_home(self) -> tuple[float, ...]:
        """Joint values (rad or m) of the home pose."""
        return tuple(j.q_home for j in self.joints)

    @property
    def velocity_limits(self) -> tuple[float, ...]:
        """Fastest allowed motion per joint (rad/s or m/s)."""
        return tuple(j.velocity_limit for j in self.joints)

    @property
    def acceleration_limits(self) -> tuple[float, ...]:
        """Largest allowed acceleration per joint (rad/s² or m/s²)."""
        return tuple(j.acceleration_limit for j in self.joints)

    def to_servo_deg(self, q: Sequence[float]) -> tuple[float, ...]:
        """Servo angles (deg) for joint values ``q`` (rad); no clamping or rounding.

        Raises ProfileError naming the profile for a profile without servos.
        """
        self._require_servos()
        return tuple(j.to_servo_deg(v) for j, v in zip(self.joints, q))

    def from_servo_deg(self, servo_deg: Sequence[float]) -> tuple[float, ...]:
        """Joint values (rad) for servo angles (deg); no clamping. Servo profiles only."""
        self._require_servos()
        return tuple(j.from_servo_deg(v) for j, v in zip(self.joints, servo_deg))

    def _require_servos(self) -> None:
        if not self.has_servos:
            plain = [j.name for j in self.joints if not j.has_servo]
            raise ProfileError(
                f"profile {self.name!r} has no servo mapping (joints {', '.join(plain)} are in"
                " joint units): servo angles exist only for hobby-servo profiles such as desk_rrr"
            )

    def to_display(self, q: Sequence[float]) -> tuple[float, ...]:
        """Joint values in each joint's display unit (deg or mm)."""
        return tuple(j.to_display(float(v)) for j, v in zip(self.joints, q))


# --------------------------------------------------------------------------------------------
# Validation helpers (shared by the loader and the dataclasses' __post_init__)




def _fmt(value: float) -> str:
    return f"{value:g}"


def _check_range(
    where: str, key: str, value: float, lo: float, hi: float, *, lo_open: bool = False, why: str = ""
) -> None:
    ok = math.isfinite(value) and (lo < value if lo_open else lo <= value) and value <= hi
    if not ok:
        extra = f" ({why})" if why else ""
        raise ProfileError(f"{where}{key} = {value!r} is outside {_fmt(lo)}…{_fmt(hi)}{extra}")


def _joint_fields(j: JointSpec) -> dict[str, Any]:
    return {
        "servo_min_deg": j.servo_min_deg,
        "servo_max_deg": j.servo_max_deg,
        "offset_deg": j.offset_deg,
        "direction": j.direction,
        "max_speed_deg_s": j.max_speed_deg_s,
        "home_servo_deg": j.home_servo_deg,
    }


def _check_joint(where: str, prefix: str, f: Mapping[str, Any]) -> None:
    """Raise ProfileError naming ``where`` + ``prefix`` + key for the first bad joint value."""
    _check_range(where, prefix + "servo_min_deg", f["servo_min_deg"], SERVO_MIN_DEG, SERVO_MAX_DEG)
    _check_range(
        where,
        prefix + "servo_max_deg",
        f["servo_max_deg"],
        max(SERVO_MIN_DEG, f["servo_min_deg"]),
        SERVO_MAX_DEG,
        lo_open=True,
        why="it must be greater than servo_min_deg" if f["servo_max_deg"] <= f["servo_min_deg"] else "",
    )
    _check_range(where, prefix + "offset_deg", f["offset_deg"], -OFFSET_LIMIT_DEG, OFFSET_LIMIT_DEG)
    direction = f["direction"]
    # integers only: 1.0 == 1 slips through `in (1, -1)`; one spelling for one meaning
    if not isinstance(direction, int) or isinstance(direction, bool) or direction not in (1, -1):
        raise ProfileError(f"{where}{prefix}direction = {direction!r} must be 1 or -1 (an integer: "
                           f"write `direction = 1` or `direction = -1`)")
    _check_range(
        where,
        prefix + "max_speed_deg_s",
        f["max_speed_deg_s"],
        0.0,
        MAX_SPEED_LIMIT_DEG_S,
        lo_open=True,
        why="it must be > 0",
    )
    home = f.get("home_servo_deg")
    if home is not None:
        _check_range(
            where,
            prefix + "home_servo_deg",
            home,
            f["servo_min_deg"],
            f["servo_max_deg"],
            why="the home pose must lie inside the servo range",
        )


def _plain_fields(j: JointSpec) -> dict[str, Any]:
    return {
        "joint_type": j.joint_type,
        "lower": j.lower,
        "upper": j.upper,
        "home": j.home,
        "max_velocity": j.max_velocity,
        "max_speed_deg_s": j.max_speed_deg_s,
    }


def _check_plain_joint(where: str, prefix: str, f: Mapping[str, Any]) -> None:
    """Raise ProfileError for the first bad value of a joint whose limits are in joint units."""
    jtype = f["joint_type"]
    if jtype not in JOINT_TYPES:
        raise ProfileError(f"{where}{prefix}type = {jtype!r} must be one of {', '.join(JOINT_TYPES)}")
    for key in ("lower", "upper"):
        if f[key] is None:
            raise ProfileError(
                f"{where}{prefix}missing {key} (joint limit in {'m' if jtype == 'prismatic' else 'rad'});"
                " a joint needs either lower/upper or the servo fields (servo_min_deg, offset_deg, …)"
            )
    bound = LENGTH_LIMIT_M if jtype == "prismatic" else REVOLUTE_LIMIT_RAD
    _check_range(where, prefix + "lower", f["lower"], -bound, bound)
    _check_range(
        where, prefix + "upper", f["upper"], f["lower"], bound, lo_open=True,
        why="it must be greater than lower" if f["upper"] <= f["lower"] else "",
    )
    if f.get("home") is not None:
        _check_range(where, prefix + "home", f["home"], f["lower"], f["upper"],
                     why="the home pose must lie inside the joint limits")
    if f.get("max_velocity") is not None:
        _check_range(where, prefix + "max_velocity", f["max_velocity"], 0.0, MAX_VELOCITY_LIMIT,
                     lo_open=True, why="it must be > 0")
    else:
        _check_range(where, prefix + "max_speed_deg_s", f["max_speed_deg_s"], 0.0,
                     MAX_SPEED_LIMIT_DEG_S, lo_open=True, why="it must be > 0")


def _rrr_fields(g: RRRGeometry) -> dict[str, Any]:
    return {
        "shoulder_height_m": g.shoulder_height_m,
        "upper_arm_m": g.upper_arm_m,
        "forearm_m": g.forearm_m,
    }


def _check_rrr_geometry(where: str, prefix: str, f: Mapping[str, Any]) -> None:
    _check_range(where, prefix + "shoulder_height_m", f["shoulder_height_m"], 0.0, LENGTH_LIMIT_M)
    for key in ("upper_arm_m", "forearm_m"):
        _check_range(
            where, prefix + key, f[key], 0.0, LENGTH_LIMIT_M, lo_open=True, why="a length must be > 0"
        )


_DELTA_LENGTHS = ("base_height_m", "base_radius_m", "upper_arm_m", "forearm_m")


def _delta_fields(g: DeltaGeometry) -> dict[str, Any]:
    return {
        "base_height_m": g.base_height_m,
        "base_radius_m": g.base_radius_m,
        "effector_radius_m": g.effector_radius_m,
        "upper_arm_m": g.upper_arm_m,
        "forearm_m": g.forearm_m,
        "tool_offset_m": g.tool_offset_m,
        "first_arm_azimuth_deg": g.first_arm_azimuth_deg,
    }


def _check_delta_geometry(where: str, prefix: str, f: Mapping[str, Any]) -> None:
    for key in _DELTA_LENGTHS:
        _check_range(
            where, prefix + key, f[key], 0.0, LENGTH_LIMIT_M, lo_open=True, why="a length must be > 0"
        )
    for key in ("effector_radius_m", "tool_offset_m"):
        _check_range(where, prefix + key, f[key], 0.0, LENGTH_LIMIT_M)
    _check_range(where, prefix + "first_arm_azimuth_deg", f["first_arm_azimuth_deg"], -360.0, 360.0)


def _gripper_fields(g: GripperSpec) -> dict[str, Any]:
    return {"min_m": g.min_m, "max_m": g.max_m, "max_speed_m_s": g.max_speed_m_s}


def _check_gripper(where: str, prefix: str, f: Mapping[str, Any]) -> None:
    _check_range(where, prefix + "min_m", f["min_m"], 0.0, 1.0)
    _check_range(where, prefix + "max_m", f["max_m"], f["min_m"], 1.0, lo_open=True,
                 why="it must be greater than min_m" if f["max_m"] <= f["min_m"] else "")
    _check_range(where, prefix + "max_speed_m_s", f["max_speed_m_s"], 0.0, 10.0, lo_open=True,
                 why="it must be > 0")


def _check_box(where: str, prefix: str, name: Any, lo: Sequence[float], hi: Sequence[float]) -> None:
    """Raise ProfileError unless ``lo``/``hi`` are 3 finite numbers in ±5 m with lo < hi per axis."""
    if not isinstance(name, str) or not name.strip():
        raise ProfileError(f"{where}{prefix}name = {name!r} must be a non-empty string")
    for key, v in (("min", lo), ("max", hi)):
        if len(v) != 3:
            raise ProfileError(f"{where}{prefix}{key} = {list(v)!r} must be [x, y, z] (m, robot_base)")
        for axis, c in zip("xyz", v):
            _check_range(where, f"{prefix}{key} {axis}", c, -KEEP_OUT_LIMIT_M, KEEP_OUT_LIMIT_M)
    for axis, a, b in zip("xyz", lo, hi):
        if not a < b:
            raise ProfileError(f"{where}{prefix}max {axis} = {b!r} must be greater than min {axis} = {a!r}")


def _check_tool_marker(where: str, prefix: str, marker_id: Any, offset: Sequence[float], size: float) -> None:
    if not isinstance(marker_id, int) or isinstance(marker_id, bool) or not 0 <= marker_id <= TOOL_MARKER_MAX_ID:
        raise ProfileError(f"{where}{prefix}id = {marker_id!r} must be an integer 0…{TOOL_MARKER_MAX_ID}")
    if len(offset) != 3:
        raise ProfileError(f"{where}{prefix}offset_m = {list(offset)!r} must be [x, y, z] (m)")
    for axis, c in zip("xyz", offset):
        _check_range(where, f"{prefix}offset_m {axis}", c, -TOOL_MARKER_OFFSET_LIMIT_M, TOOL_MARKER_OFFSET_LIMIT_M)
    _check_range(where, prefix + "size_m", size, *TOOL_MARKER_SIZE_RANGE_M)


# --------------------------------------------------------------------------------------------
# Reading TOML


class _Reader:
    """Typed access to a parsed TOML table; every error names the file and the key path."""

    def __init__(self, where: str) -> None:
        self.where = where  # "path/to/file.toml: "

    def fail(self, message: str) -> ProfileError:
        return ProfileError(f"{self.where}{message}")

    def table(self, data: Mapping[str, Any], key: str, path: str) -> Mapping[str, Any]:
        if key not in data:
            raise self.fail(f"missing table [{path}{key}]")
        value = data[key]
        if not isinstance(value, dict):
            raise self.fail(f"{path}{key} must be a table ([{path}{key}]), got {_type_name(value)}")
        return value

    def number(
        self, data: Mapping[str, Any], key: str, path: str, default: Any = ...
    ) -> Optional[float]:
        if key not in data:
            if default is ...:
                raise self.fail(f"missing key {path}{key} (a number)")
            return default
        value = data[key]
        if not _is_number(value):
            raise self.fail(f"{path}{key} = {value!r} must be a number, got {_type_name(value)}")
        return value

    def string(self, data: Mapping[str, Any], key: str, path: str, default: Any = ...) -> str:
        if key not in data:
            if default is ...:
                raise self.fail(f"missing key {path}{key} (a string)")
            return default
        value = data[key]
        if not isinstance(value, str):
            raise self.fail(f"{path}{key} = {value!r} must be a string, got {_type_name(value)}")
        return value

    def vector3(self, data: Mapping[str, Any], key: str, path: str) -> tuple[float, float, float]:
        """``data[key]`` as three numbers ``[x, y, z]``; the key is required."""
        if key not in data:
            raise self.fail(f"missing key {path}{key} (three numbers [x, y, z])")
        value = data[key]
        if not isinstance(value, list) or len(value) != 3 or not all(_is_number(v) for v in value):
            raise self.fail(f"{path}{key} = {value!r} must be three numbers [x, y, z], got {_type_name(value)}")
        return (float(value[0]), float(value[1]), float(value[2]))

    def no_unknown_keys(self, data: Mapping[str, Any], allowed: Sequence[str], path: str) -> None:
        for key in data:
            if key not in allowed:
                raise self.fail(
                    f"unknown key {path}{key}; expected one of {', '.join(allowed)}"
                )




_TOP_KEYS = ("name", "kind", "description", "geometry", "joints", "gripper", "workspace", "tool_marker")
_WORKSPACE_KEYS = ("desk_margin_m", "keep_out")
_KEEP_OUT_KEYS = ("name", "min", "max")
_TOOL_MARKER_KEYS = ("id", "offset_m", "size_m")
_JOINT_KEYS = (
    "name",
    "servo_min_deg",
    "servo_max_deg",
    "offset_deg",
    "direction",
    "max_speed_deg_s",
    "home_servo_deg",
    "max_acceleration",
)
_URDF_SERVO_KEYS = ("servo_min_deg", "servo_max_deg", "offset_deg", "direction", "home_servo_deg",
                    "max_speed_deg_s")
_URDF_JOINT_KEYS = ("name", "lower", "upper", "home", "max_velocity", "max_acceleration") + _URDF_SERVO_KEYS
_URDF_LIMIT_TOLERANCE_RAD = 1e-9  # a servo range ending exactly on a URDF limit is inside it
_URDF_GEOMETRY_KEYS = ("urdf", "tip", "camera_frame")
_GRIPPER_KEYS = ("name", "min_m", "max_m", "max_speed_m_s")
_DELTA_KEYS = _DELTA_LENGTHS + ("effector_radius_m", "tool_offset_m", "first_arm_azimuth_deg")
_DELTA_DEFAULTS = {"tool_offset_m": 0.0, "first_arm_azimuth_deg": 90.0}


def _parse_rrr_geometry(rd: _Reader, table: Mapping[str, Any]) -> RRRGeometry:
    keys = ("shoulder_height_m", "upper_arm_m", "forearm_m")
    rd.no_unknown_keys(table, keys, "geometry.")
    fields = {k: rd.number(table, k, "geometry.") for k in keys}
    _check_rrr_geometry(rd.where, "geometry.", fields)
    return RRRGeometry(**{k: float(v) for k, v in fields.items()})


def _parse_delta_geometry(rd: _Reader, table: Mapping[str, Any]) -> DeltaGeometry:
    rd.no_unknown_keys(table, _DELTA_KEYS, "geometry.")
    fields = {k: rd.number(table, k, "geometry.", _DELTA_DEFAULTS.get(k, ...)) for k in _DELTA_KEYS}
    _check_delta_geometry(rd.where, "geometry.", fields)
    return DeltaGeometry(**{k: float(v) for k, v in fields.items()})


# kind -> geometry parser, geometry type, joint count (None: from the geometry), solver
# (module relative to this package, class name). "urdf" reads its joints from the URDF file.
_GEOMETRY_PARSERS: dict[str, Optional[Callable[[_Reader, Mapping[str, Any]], Any]]] = {
    "rrr": _parse_rrr_geometry,
    "delta3": _parse_delta_geometry,
    "urdf": None,
}
_GEOMETRY_TYPES: dict[str, type] = {"rrr": RRRGeometry, "delta3": DeltaGeometry, "urdf": UrdfGeometry}
_JOINT_COUNTS: dict[str, Optional[int]] = {"rrr": 3, "delta3": 3, "urdf": None}
_SERVO_KINDS = ("rrr", "delta3")
KINDS: tuple[str, ...] = tuple(_GEOMETRY_PARSERS)
URDF_PREFIX = "urdf:"  # load_profile("urdf:PATH") builds a profile from any URDF file


def _parse_joint(rd: _Reader, table: Any, i: int) -> JointSpec:
    path = f"joints[{i}]."
    if not isinstance(table, dict):
        raise rd.fail(f"joints[{i}] must be a table ([[joints]]), got {_type_name(table)}")
    rd.no_unknown_keys(table, _JOINT_KEYS, path)
    name = rd.string(table, "name", path)
    fields: dict[str, Any] = {
        "servo_min_deg": rd.number(table, "servo_min_deg", path, SERVO_MIN_DEG),
        "servo_max_deg": rd.number(table, "servo_max_deg", path, SERVO_MAX_DEG),
        "offset_deg": rd.number(table, "offset_deg", path),
        "direction": rd.number(table, "direction", path),
        "max_speed_deg_s": rd.number(table, "max_speed_deg_s", path, 300.0),
        "home_servo_deg": rd.number(table, "home_servo_deg", path, None),
    }
    _check_joint(rd.where, path, fields)
    return _servo_joint(rd, table, path, name, fields)


def _servo_joint(rd: _Reader, table: Mapping[str, Any], path: str, name: str, fields: Mapping[str, Any]) -> JointSpec:
    """A servo JointSpec from checked servo ``fields`` and the table's optional max_acceleration
    (servo profiles and servo-mapped URDF joints alike)."""
    accel = rd.number(table, "max_acceleration", path, None)
    if accel is not None:
        _check_range(rd.where, path + "max_acceleration", accel, 0.0, MAX_ACCELERATION_LIMIT,
                     lo_open=True, why="it must be > 0")
    return JointSpec(
        name=name,
        servo_min_deg=float(fields["servo_min_deg"]),
        servo_max_deg=float(fields["servo_max_deg"]),
        offset_deg=float(fields["offset_deg"]),
        direction=int(fields["direction"]),
        max_speed_deg_s=float(fields["max_speed_deg_s"]),
        home_servo_deg=None if fields["home_servo_deg"] is None else float(fields["home_servo_deg"]),
        max_acceleration=None if accel is None else float(accel),
    )


def _parse_servo_joints(rd: _Reader, data: Mapping[str, Any], kind: str) -> tuple[JointSpec, ...]:
    if "joints" not in data:
        raise rd.fail("missing array of tables [[joints]]")
    joints_raw = data["joints"]
    if not isinstance(joints_raw, list):
        raise rd.fail(f"joints must be an array of tables ([[joints]]), got {_type_name(joints_raw)}")
    expected = _JOINT_COUNTS[kind]
    if len(joints_raw) != expected:
        raise rd.fail(
            f"joints has {len(joints_raw)} {'entry' if len(joints_raw) == 1 else 'entries'};"
            f" kind {kind!r} needs exactly {expected}"
        )
    return tuple(_parse_joint(rd, t, i) for i, t in enumerate(joints_raw))


def _urdf_joints(rd: _Reader, chain, overrides: Any) -> tuple[JointSpec, ...]:
    """The URDF chain's joints, with the TOML's optional per-joint overrides applied."""
    if overrides is None:
        overrides = []
    if not isinstance(overrides, list):
        raise rd.fail(f"joints must be an array of tables ([[joints]]), got {_type_name(overrides)}")
    names = [j.name for j in chain.joints]
    by_name: dict[str, tuple[int, Mapping[str, Any]]] = {}
    for i, table in enumerate(overrides):
        path = f"joints[{i}]."
        if not isinstance(table, dict):
            raise rd.fail(f"joints[{i}] must be a table ([[joints]]), got {_type_name(table)}")
        rd.no_unknown_keys(table, _URDF_JOINT_KEYS, path)
        name = rd.string(table, "name", path)
        mimic = next((m for m in chain.mimics if m.name == name), None)
        if mimic is not None:
            raise rd.fail(
                f"joints[{i}].name = {name!r} is a mimic joint (q = {mimic.multiplier:g}·{mimic.primary} +"
                f" {mimic.offset:g}), not a variable; set {mimic.primary!r} instead"
            )
        if name not in names:
            raise rd.fail(
                f"joints[{i}].name = {name!r} is not a joint between the URDF's root and tip"
                f" {chain.tip!r}; those joints are: {', '.join(names)}"
            )
        if name in by_name:
            raise rd.fail(f"joints[{i}].name = {name!r} is used twice; joint names must be unique")
        by_name[name] = (i, table)
    mapped = [cj.name for cj in chain.joints
              if any(k in by_name.get(cj.name, (-1, {}))[1] for k in _URDF_SERVO_KEYS)]
    if mapped and len(mapped) != len(chain.joints):
        unmapped = [n for n in names if n not in mapped]
        raise rd.fail(
            f"joints {', '.join(mapped)} have a servo mapping but {', '.join(unmapped)}"
            f" {'has' if len(unmapped) == 1 else 'have'} none; a servo board drives every joint or"
            f" none — give each of {', '.join(unmapped)} a [[joints]] entry with servo_min_deg,"
            " servo_max_deg, offset_deg and direction, or remove the servo fields everywhere"
        )
    out = []
    for cj in chain.joints:
        i, table = by_name.get(cj.name, (-1, {}))
        path = f"joints[{i}]." if i >= 0 else f"URDF joint {cj.name!r}: "
        if cj.name in mapped:
            out.append(_urdf_servo_joint(rd, cj, table, path))
            continue
        fields: dict[str, Any] = {
            "joint_type": cj.joint_type,
            "lower": rd.number(table, "lower", path, cj.lower),
            "upper": rd.number(table, "upper", path, cj.upper),
            "home": rd.number(table, "home", path, None),
            "max_velocity": rd.number(table, "max_velocity", path, cj.max_velocity),
            "max_speed_deg_s": 300.0,
        }
        for key in ("lower", "upper"):  # the TOML may narrow the URDF's limits, never widen them
            if key in table:
                _check_range(rd.where, path + key, fields[key], cj.lower, cj.upper,
                             why="it must stay inside the URDF's limits")
        _check_plain_joint(rd.where, path, fields)
        accel = rd.number(table, "max_acceleration", path, None)
        if accel is not None:
            _check_range(rd.where, path + "max_acceleration", accel, 0.0, MAX_ACCELERATION_LIMIT,
                         lo_open=True, why="it must be > 0")
        out.append(JointSpec(
            name=cj.name, joint_type=cj.joint_type, lower=float(fields["lower"]),
            upper=float(fields["upper"]),
            home=None if fields["home"] is None else float(fields["home"]),
            max_velocity=float(fields["max_velocity"]),
            max_acceleration=None if accel is None else float(accel),
        ))
    return tuple(out)


def _urdf_servo_joint(rd: _Reader, cj, table: Mapping[str, Any], path: str) -> JointSpec:
    """A URDF joint driven by a hobby servo: the servo fields of its [[joints]] entry.

    As for desk_rrr's joints, the limits follow from the servo range (servo_min_deg …
    servo_max_deg through offset_deg and direction); that range must map inside the URDF's
    limits. The home pose is ``home_servo_deg`` (servo degrees) or ``home`` (rad, converted);
    the speed is ``max_speed_deg_s``, else ``max_velocity`` (rad/s), else the URDF's velocity.
    """
    if cj.joint_type != "revolute":
        raise rd.fail(f"{path}a servo mapping needs a revolute joint; {cj.name!r} is {cj.joint_type} —"
                      " remove its servo fields")
    limits = [k for k in ("lower", "upper") if k in table]
    if limits:
        raise rd.fail(f"{path}{' and '.join(limits)} cannot be combined with a servo mapping: the limits"
                      " follow from the servo range — narrow servo_min_deg/servo_max_deg instead")
    for key in ("offset_deg", "direction"):
        if key not in table:
            raise rd.fail(f"{path}missing key {key} for the servo mapping of joint {cj.name!r}"
                          " (servo_deg = offset_deg + direction * degrees(q))")
    fields: dict[str, Any] = {
        "servo_min_deg": rd.number(table, "servo_min_deg", path, SERVO_MIN_DEG),
        "servo_max_deg": rd.number(table, "servo_max_deg", path, SERVO_MAX_DEG),
        "offset_deg": rd.number(table, "offset_deg", path),
        "direction": rd.number(table, "direction", path),
        "max_speed_deg_s": 300.0,
        "home_servo_deg": rd.number(table, "home_servo_deg", path, None),
    }
    speed = rd.number(table, "max_speed_deg_s", path, None)
    velocity = rd.number(table, "max_velocity", path, None)
    if speed is not None and velocity is not None:
        raise rd.fail(f"{path}give max_speed_deg_s (deg/s) or max_velocity (rad/s), not both")
    if speed is not None:
        fields["max_speed_deg_s"] = speed
    elif velocity is not None:
        _check_range(rd.where, path + "max_velocity", velocity, 0.0, MAX_VELOCITY_LIMIT,
                     lo_open=True, why="it must be > 0")
        fields["max_speed_deg_s"] = math.degrees(velocity)
    elif cj.max_velocity is not None:
        fields["max_speed_deg_s"] = math.degrees(cj.max_velocity)
    home = rd.number(table, "home", path, None)
    if home is not None and fields["home_servo_deg"] is not None:
        raise rd.fail(f"{path}give home (rad) or home_servo_deg (servo degrees), not both")
    _check_joint(rd.where, path, fields)  # servo range, offset, direction, speed, home_servo_deg
    if home is not None:
        _check_range(rd.where, path + "home", home, -REVOLUTE_LIMIT_RAD, REVOLUTE_LIMIT_RAD)
        fields["home_servo_deg"] = fields["offset_deg"] + fields["direction"] * math.degrees(home)
        lo_deg, hi_deg = fields["servo_min_deg"], fields["servo_max_deg"]
        if not lo_deg - 1e-9 <= fields["home_servo_deg"] <= hi_deg + 1e-9:
            raise rd.fail(
                f"{path}home = {home!r} rad is servo angle {fields['home_servo_deg']:.2f}°, outside the servo"
                f" range {_fmt(lo_deg)}…{_fmt(hi_deg)}° — the home pose must lie inside the servo range"
            )
        fields["home_servo_deg"] = min(max(fields["home_servo_deg"], lo_deg), hi_deg)
    joint = _servo_joint(rd, table, path, cj.name, fields)
    tol = _URDF_LIMIT_TOLERANCE_RAD
    if joint.q_min < cj.lower - tol or joint.q_max > cj.upper + tol:
        fit = sorted(joint.to_servo_deg(v) for v in (cj.lower, cj.upper))
        fit_lo, fit_hi = max(SERVO_MIN_DEG, fit[0]), min(SERVO_MAX_DEG, fit[1])
        hint = (f"e.g. servo_min_deg = {math.ceil(fit_lo * 10) / 10:g}, servo_max_deg ="
                f" {math.floor(fit_hi * 10) / 10:g} with this offset_deg and direction"
                if fit_lo < fit_hi else "change offset_deg so the servo range maps inside them")
        raise rd.fail(
            f"{path}the servo range {_fmt(joint.servo_min_deg)}…{_fmt(joint.servo_max_deg)}° of joint"
            f" {cj.name!r} maps to q = {math.degrees(joint.q_min):.2f}…{math.degrees(joint.q_max):.2f}°"
            f" ({joint.q_min:.4f}…{joint.q_max:.4f} rad), outside the URDF's limits"
            f" {math.degrees(cj.lower):.2f}…{math.degrees(cj.upper):.2f}° ({cj.lower:g}…{cj.upper:g} rad);"
            f" narrow the servo range or move offset_deg so it maps inside them ({hint})"
        )
    return joint


def _parse_urdf_profile(
    rd: _Reader, data: Mapping[str, Any], base_dir: Path, tip: Optional[str]
) -> tuple[UrdfGeometry, tuple[JointSpec, ...]]:
    table = rd.table(data, "geometry", "")
    rd.no_unknown_keys(table, _URDF_GEOMETRY_KEYS, "geometry.")
    urdf = rd.string(table, "urdf", "geometry.")
    if not urdf.strip():
        raise rd.fail("geometry.urdf = '' must name a URDF file (relative to the profile's folder)")
    path = Path(urdf).expanduser()
    if not path.is_absolute():
        path = base_dir / path
    tip_name = tip if tip is not None else rd.string(table, "tip", "geometry.", None)
    camera = rd.string(table, "camera_frame", "geometry.", "")
    from core.kinematics.urdf import (
        read_urdf_chain,  # Pinocchio is imported only for URDF profiles
    )

    chain = read_urdf_chain(path, tip_name)
    if camera and camera not in chain.frames:
        raise rd.fail(
            f"geometry.camera_frame = {camera!r} is not a frame of {path}; valid frames:"
            f" {', '.join(chain.frames)}"
        )
    joints = _urdf_joints(rd, chain, data.get("joints"))
    return UrdfGeometry(urdf_path=str(path), tip_frame=chain.tip, camera_frame=camera), joints


def _parse_gripper(rd: _Reader, data: Mapping[str, Any]) -> Optional[GripperSpec]:
    if "gripper" not in data:
        return None
    table = rd.table(data, "gripper", "")
    rd.no_unknown_keys(table, _GRIPPER_KEYS, "gripper.")
    fields = {
        "min_m": rd.number(table, "min_m", "gripper.", 0.0),
        "max_m": rd.number(table, "max_m", "gripper.", 0.05),
        "max_speed_m_s": rd.number(table, "max_speed_m_s", "gripper.", 0.05),
    }
    _check_gripper(rd.where, "gripper.", fields)
    return GripperSpec(name=rd.string(table, "name", "gripper.", "gripper"),
                       **{k: float(v) for k, v in fields.items()})


def _parse_workspace(rd: _Reader, data: Mapping[str, Any]) -> WorkspaceSpec:
    if "workspace" not in data:
        return WorkspaceSpec()
    table = rd.table(data, "workspace", "")
    rd.no_unknown_keys(table, _WORKSPACE_KEYS, "workspace.")
    margin = rd.number(table, "desk_margin_m", "workspace.", DEFAULT_DESK_MARGIN_M)
    _check_range(rd.where, "workspace.desk_margin_m", margin, 0.0, MAX_DESK_MARGIN_M)
    raw = table.get("keep_out", [])
    if not isinstance(raw, list):
        raise rd.fail(f"workspace.keep_out must be an array of tables ([[workspace.keep_out]]), got {_type_name(raw)}")
    boxes = []
    for i, box in enumerate(raw):
        path = f"workspace.keep_out[{i}]."
        if not isinstance(box, dict):
            raise rd.fail(f"workspace.keep_out[{i}] must be a table ([[workspace.keep_out]]), got {_type_name(box)}")
        rd.no_unknown_keys(box, _KEEP_OUT_KEYS, path)
        name = rd.string(box, "name", path)
        lo, hi = rd.vector3(box, "min", path), rd.vector3(box, "max", path)
        _check_box(rd.where, path, name, lo, hi)
        if any(b.name == name for b in boxes):
            raise rd.fail(f"{path}name = {name!r} is used twice; keep-out box names must be unique")
        boxes.append(KeepOutBox(name=name, min_m=lo, max_m=hi))
    return WorkspaceSpec(desk_margin_m=float(margin), keep_out=tuple(boxes))


def _parse_tool_marker(rd: _Reader, data: Mapping[str, Any]) -> Optional[ToolMarkerSpec]:
    if "tool_marker" not in data:
        return None
    table = rd.table(data, "tool_marker", "")
    rd.no_unknown_keys(table, _TOOL_MARKER_KEYS, "tool_marker.")
    if "id" not in table:
        raise rd.fail("missing key tool_marker.id (an integer 0…999)")
    marker_id = table["id"]
    offset = rd.vector3(table, "offset_m", "tool_marker.")
    size = rd.number(table, "size_m", "tool_marker.")
    _check_tool_marker(rd.where, "tool_marker.", marker_id, offset, size)
    return ToolMarkerSpec(marker_id=int(marker_id), offset_m=offset, size_m=float(size))


def parse_profile(
    data: Mapping[str, Any],
    source: str = "<profile>",
    *,
    tip: Optional[str] = None,
    base_dir: Union[str, os.PathLike, None] = None,
) -> RobotProfile:
    """Validate an already parsed TOML document and build the RobotProfile.

    ``source`` names the file in error messages. ``tip`` overrides a URDF profile's tip frame
    (``--tip``); ``base_dir`` is where a relative ``geometry.urdf`` is looked up (default: the
    folder of ``source`` when it is a file, else the current folder).
    """
    rd = _Reader(f"{source}: ")
    rd.no_unknown_keys(data, _TOP_KEYS, "")
    name = rd.string(data, "name", "")
    if not name.strip():
        raise rd.fail("name = '' must not be empty")
    kind = rd.string(data, "kind", "")
    if kind not in _GEOMETRY_PARSERS:
        raise rd.fail(f"kind = {kind!r} is unknown; expected one of {', '.join(KINDS)}")
    description = rd.string(data, "description", "", "")
    if tip is not None and kind != "urdf":
        raise rd.fail(f"--tip {tip!r} applies only to URDF profiles; {name!r} is kind {kind!r}")
    if kind == "urdf":
        if base_dir is None:
            src_path = Path(source)
            base_dir = src_path.parent if src_path.is_file() else Path.cwd()
        geometry, joints = _parse_urdf_profile(rd, data, Path(base_dir), tip)
    else:
        parser = _GEOMETRY_PARSERS[kind]
        geometry = parser(rd, rd.table(data, "geometry", ""))  # type: ignore[misc]
        joints = _parse_servo_joints(rd, data, kind)
    names = [j.name for j in joints]
    for i, n in enumerate(names):
        if names.index(n) != i:
            raise rd.fail(f"joints[{i}].name = {n!r} is used twice; joint names must be unique")
    if kind == "delta3":
        from core.kinematics.delta import assembly_problem

        problem = assembly_problem(geometry, [j.q_min for j in joints], [j.q_max for j in joints])
        if problem:
            raise rd.fail(problem)
    gripper = _parse_gripper(rd, data)
    workspace = _parse_workspace(rd, data)
    tool_marker = _parse_tool_marker(rd, data)
    return RobotProfile(
        name=name, kind=kind, description=description, geometry=geometry, joints=joints,
        source=source, gripper=gripper, workspace=workspace, tool_marker=tool_marker,
    )


# --------------------------------------------------------------------------------------------
# Finding and loading profiles


def _robots_dir():
    """The built-in profiles folder (a Traversable; a plain Path for normal installs)."""
    try:
        from importlib.resources import files

        return files("resources") / "robots"
    except (ModuleNotFoundError, TypeError):  # resources not importable: use the source tree
        return Path(__file__).resolve().parent.parent / "resources" / "robots"


def list_profiles() -> list[str]:
    """Names of the built-in robot profiles (``resources/robots/*.toml``), sorted."""
    folder = _robots_dir()
    try:
        entries = list(folder.iterdir())
    except (FileNotFoundError, NotADirectoryError):
        return []
    return sorted(e.name[: -len(".toml")] for e in entries if e.name.endswith(".toml"))


def _looks_like_path(name_or_path: Union[str, os.PathLike]) -> bool:
    if isinstance(name_or_path, os.PathLike):
        return True
    s = str(name_or_path)
    return s.endswith(".toml") or "/" in s or os.sep in s or (os.altsep or "/") in s


def profile_from_urdf(urdf_path: Union[str, os.PathLike], tip: Optional[str] = None) -> RobotProfile:
    """A profile for any URDF file: its joints between the root and ``tip`` (default: the tip
    frame of the longest chain), limits and velocities from the file.

    Raises ProfileError naming the file (missing, malformed) or the frame (listing valid ones).
    """
    from core.kinematics.urdf import read_urdf_chain

    path = Path(urdf_path).expanduser()
    if not str(urdf_path).strip():
        raise ProfileError("urdf: needs a path, e.g. urdf:/path/to/arm.urdf")
    path = path.resolve()
    chain = read_urdf_chain(path, tip)
    rd = _Reader(f"{path}: ")
    joints = _urdf_joints(rd, chain, None)
    return RobotProfile(
        name=chain.robot_name or path.stem, kind="urdf", description=f"URDF {path.name}, tip {chain.tip}",
        geometry=UrdfGeometry(urdf_path=str(path), tip_frame=chain.tip), joints=joints,
        source=str(path),
    )


def load_profile(name_or_path: Union[str, os.PathLike], tip: Optional[str] = None) -> RobotProfile:
    """Read and validate a robot profile: a built-in name (``"desk_rrr"``), a TOML path, or
    ``"urdf:PATH"`` for any URDF file. ``tip`` picks a URDF profile's tip frame (``--tip``).

    Raises ProfileError naming the file, the key and the allowed values.
    """
    if isinstance(name_or_path, str) and name_or_path.startswith(URDF_PREFIX):
        return profile_from_urdf(name_or_path[len(URDF_PREFIX):], tip)
    if _looks_like_path(name_or_path):
        path = Path(name_or_path)
        source = str(path)
        try:
            raw = path.read_bytes()
        except FileNotFoundError:
            raise ProfileError(f"{source}: no such file — check the path") from None
        except IsADirectoryError:
            raise ProfileError(f"{source}: is a folder, expected a .toml file") from None
        except OSError as exc:
            raise ProfileError(f"{source}: cannot read ({exc.strerror or exc})") from None
        base_dir = path.resolve().parent
    else:
        name = str(name_or_path)
        entry = _robots_dir() / f"{name}.toml"
        source = str(entry)
        valid = list_profiles()
        if name not in valid:
            raise ProfileError(
                f"unknown robot profile {name!r}; valid names: {', '.join(valid) or '(none found)'}"
                " — or give the path of a .toml file, or urdf:PATH for a URDF"
            )
        raw = entry.read_bytes()
        base_dir = Path(str(entry)).parent
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ProfileError(f"{source}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    try:
        data = tomllib.loads(text)
        return parse_profile(data, source, tip=tip, base_dir=base_dir)
    except tomllib.TOMLDecodeError as exc:
        raise ProfileError(f"{source}: invalid TOML: {exc}") from None
    except RecursionError:  # tomllib recurses per nested array/inline table; messages repr values
        raise ProfileError(f"{source}: nested too deeply (arrays or tables hundreds of levels inside "
                           f"each other) — a robot profile needs a few levels; fix the file") from None
