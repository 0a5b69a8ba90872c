"""Robot profiles: the TOML files that describe an arm (kind, geometry, joints, servo mapping).

A profile is read once, validated, and turned into frozen dataclasses that the kinematics,
the safety clamps and the motor bridges share read-only. Every error a user can hit names the
file, the key and what was expected, e.g.::

    .../desk_rrr.toml: joints[1].servo_max_deg = 200 is outside 0…180

Built-in profiles live in ``resources/robots/<name>.toml``; ``load_profile`` also accepts a
path to any TOML file. Units inside are SI (m, rad); degrees appear only in the servo fields,
whose names end in ``_deg``.

Only ``kind = "rrr"`` exists today. A new kind (delta, UMI-RTX, URDF) adds a geometry parser
to ``_GEOMETRY_PARSERS``, its joint count to ``_JOINT_COUNTS`` and a solver to
``_SOLVER_FACTORIES``; ``build_kinematics`` then hands out the right solver.
"""
from __future__ import annotations

import importlib
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping, Optional, Sequence, Union

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

SERVO_MIN_DEG = 0.0  # the hobby servos (and the v1 protocol's angle byte) span 0…180°
SERVO_MAX_DEG = 180.0
OFFSET_LIMIT_DEG = 360.0  # |offset_deg| above this is surely a typo
MAX_SPEED_LIMIT_DEG_S = 3600.0  # no hobby servo turns ten revolutions a second
LENGTH_LIMIT_M = 5.0  # a desk arm longer than this is a unit mistake (cm or mm typed as m)


class ProfileError(ValueError):
    """A robot profile cannot be used; the message names the file, the key and the fix."""


# --------------------------------------------------------------------------------------------
# Dataclasses


@dataclass(frozen=True)
class JointSpec:
    """One servo-driven joint: servo range and the mapping between q (rad) and servo degrees."""

    name: str  # joint name, e.g. "shoulder"
    servo_min_deg: float  # lowest servo angle allowed, deg, 0 … servo_max_deg
    servo_max_deg: float  # highest servo angle allowed, deg, servo_min_deg … 180
    offset_deg: float  # servo angle at q = 0, deg, -360 … 360
    direction: int  # +1 or -1: servo_deg = offset_deg + direction * degrees(q)
    max_speed_deg_s: float = 300.0  # fastest allowed servo motion, deg/s, 0 (excl.) … 3600
    home_servo_deg: Optional[float] = None  # servo angle of the home pose; None = mid-range

    def __post_init__(self) -> None:
        _check_joint("", f"joint {self.name!r}: ", _joint_fields(self))

    @property
    def q_min(self) -> float:
        """Lower joint limit (rad), from the servo range through offset and direction."""
        a = self.from_servo_deg(self.servo_min_deg)
        b = self.from_servo_deg(self.servo_max_deg)
        return min(a, b)

    @property
    def q_max(self) -> float:
        """Upper joint limit (rad), from the servo range through offset and direction."""
        a = self.from_servo_deg(self.servo_min_deg)
        b = self.from_servo_deg(self.servo_max_deg)
        return max(a, b)

    @property
    def q_home(self) -> float:
        """Joint value (rad) of the home pose."""
        home = self.home_servo_deg
        if home is None:
            home = 0.5 * (self.servo_min_deg + self.servo_max_deg)
        return self.from_servo_deg(home)

    def to_servo_deg(self, q: float) -> float:
        """Servo angle (deg) for the joint value ``q`` (rad); no clamping (see core.safety)."""
        return self.offset_deg + self.direction * math.degrees(q)

    def from_servo_deg(self, servo_deg: float) -> float:
        """Joint value (rad) for the servo angle ``servo_deg``; no clamping."""
        return self.direction * math.radians(servo_deg - self.offset_deg)


@dataclass(frozen=True)
class RRRGeometry:
    """Yaw–shoulder–elbow arm: shoulder on the yaw axis, tool point at the forearm's end."""

    shoulder_height_m: float  # shoulder axis above the desk, on the yaw axis, 0 … 5 m
    upper_arm_m: float  # shoulder axis to elbow axis, 0 (excl.) … 5 m
    forearm_m: float  # elbow axis to the tool point, 0 (excl.) … 5 m

    def __post_init__(self) -> None:
        _check_rrr_geometry("", "geometry.", _rrr_fields(self))


@dataclass(frozen=True)
class RobotProfile:
    """A validated robot description; read-only and shared by every worker."""

    name: str  # profile name, e.g. "desk_rrr"
    kind: str  # kinematic family; chooses the solver (see build_kinematics)
    description: str  # one line for the GUI
    geometry: RRRGeometry  # kind-specific geometry (RRRGeometry for "rrr")
    joints: tuple[JointSpec, ...]  # in kinematic order (q1, q2, …)
    source: str = ""  # the file it was read from ("" when built in code)

    def __post_init__(self) -> None:
        if self.kind not in _JOINT_COUNTS:
            raise ProfileError(
                f"kind = {self.kind!r} is unknown; expected one of {', '.join(_JOINT_COUNTS)}"
            )
        expected = _JOINT_COUNTS[self.kind]
        if len(self.joints) != expected:
            raise ProfileError(
                f"kind {self.kind!r} needs {expected} joints, got {len(self.joints)}"
            )

    @property
    def n_joints(self) -> int:
        return len(self.joints)

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    @property
    def q_min(self) -> tuple[float, ...]:
        """Lower joint limits (rad)."""
        return tuple(j.q_min for j in self.joints)

    @property
    def q_max(self) -> tuple[float, ...]:
        """Upper joint limits (rad)."""
        return tuple(j.q_max for j in self.joints)

    @property
    def q_home(self) -> tuple[float, ...]:
        """Joint values (rad) of the home pose."""
        return tuple(j.q_home for j in self.joints)

    def to_servo_deg(self, q: Sequence[float]) -> tuple[float, ...]:
        """Servo angles (deg) for joint values ``q`` (rad); no clamping or rounding."""
        return tuple(j.to_servo_deg(v) for j, v in zip(self.joints, q))

    def from_servo_deg(self, servo_deg: Sequence[float]) -> tuple[float, ...]:
        """Joint values (rad) for servo angles (deg); no clamping."""
        return tuple(j.from_servo_deg(v) for j, v in zip(self.joints, servo_deg))


# --------------------------------------------------------------------------------------------
# Validation helpers (shared by the loader and the dataclasses' __post_init__)


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


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
    if f["direction"] not in (1, -1) or isinstance(f["direction"], bool):
        raise ProfileError(f"{where}{prefix}direction = {f['direction']!r} must be 1 or -1")
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

    def no_unknown_keys(self, data: Mapping[str, Any], allowed: Sequence[str], path: str) -> None:
        for key in data:
            if key not in allowed:
                raise self.fail(
                    f"unknown key {path}{key}; expected one of {', '.join(allowed)}"
                )


def _type_name(value: Any) -> str:
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, str):
        return "a string"
    if _is_number(value):
        return "a number"
    return type(value).__name__


_TOP_KEYS = ("name", "kind", "description", "geometry", "joints")
_JOINT_KEYS = (
    "name",
    "servo_min_deg",
    "servo_max_deg",
    "offset_deg",
    "direction",
    "max_speed_deg_s",
    "home_servo_deg",
)


def _parse_rrr_geometry(rd: _Reader, table: Mapping[str, Any]) -> RRRGeometry:
    keys = ("shoulder_height_m", "upper_arm_m", "forearm_m")
    rd.no_unknown_keys(table, keys, "geometry.")
    fields = {k: rd.number(table, k, "geometry.") for k in keys}
    _check_rrr_geometry(rd.where, "geometry.", fields)
    return RRRGeometry(**{k: float(v) for k, v in fields.items()})


# kind -> geometry parser, joint count, solver (module relative to this package, class name)
_GEOMETRY_PARSERS: dict[str, Callable[[_Reader, Mapping[str, Any]], Any]] = {
    "rrr": _parse_rrr_geometry,
}
_JOINT_COUNTS: dict[str, int] = {"rrr": 3}
_SOLVER_FACTORIES: dict[str, tuple[str, str]] = {"rrr": (".kinematics_rrr", "RRRKinematics")}
KINDS: tuple[str, ...] = tuple(_GEOMETRY_PARSERS)


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
    return JointSpec(
        name=name,
        servo_min_deg=float(fields["servo_min_deg"]),
        servo_max_deg=float(fields["servo_max_deg"]),
        offset_deg=float(fields["offset_deg"]),
        direction=int(fields["direction"]),
        max_speed_deg_s=float(fields["max_speed_deg_s"]),
        home_servo_deg=None if fields["home_servo_deg"] is None else float(fields["home_servo_deg"]),
    )


def parse_profile(data: Mapping[str, Any], source: str = "<profile>") -> RobotProfile:
    """Validate an already parsed TOML document and build the RobotProfile.

    ``source`` names the file in error messages.
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
    geometry = _GEOMETRY_PARSERS[kind](rd, rd.table(data, "geometry", ""))
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
    joints = tuple(_parse_joint(rd, t, i) for i, t in enumerate(joints_raw))
    names = [j.name for j in joints]
    for i, n in enumerate(names):
        if names.index(n) != i:
            raise rd.fail(f"joints[{i}].name = {n!r} is used twice; joint names must be unique")
    return RobotProfile(
        name=name, kind=kind, description=description, geometry=geometry, joints=joints,
        source=source,
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


def load_profile(name_or_path: Union[str, os.PathLike]) -> RobotProfile:
    """Read and validate a robot profile: a built-in name (``"desk_rrr"``) or a TOML path.

    Raises ProfileError naming the file, the key and the allowed values.
    """
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
    else:
        name = str(name_or_path)
        entry = _robots_dir() / f"{name}.toml"
        source = str(entry)
        valid = list_profiles()
        if name not in valid:
            raise ProfileError(
                f"unknown robot profile {name!r}; valid names: {', '.join(valid) or '(none found)'}"
                " — or give the path of a .toml file"
            )
        raw = entry.read_bytes()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ProfileError(f"{source}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ProfileError(f"{source}: invalid TOML: {exc}") from None
    return parse_profile(data, source)


def build_kinematics(profile: RobotProfile):
    """The kinematics solver for ``profile`` (e.g. RRRKinematics for kind "rrr")."""
    try:
        module_name, class_name = _SOLVER_FACTORIES[profile.kind]
    except KeyError:
        raise ProfileError(
            f"{profile.source or profile.name}: no kinematics solver for kind {profile.kind!r}"
        ) from None
    module = importlib.import_module(module_name, __package__)
    return getattr(module, class_name)(profile)
