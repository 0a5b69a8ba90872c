"""What deskarm remembers between runs: target mode, Lissajous curve, bridge port and protocol,
recent ports, the 3D twin, window geometry and the camera controls (plain, validated data).

The file is ``preferences.toml`` in the user's config folder (``DESKARM_HOME`` overrides). A
damaged file never stops the app: :func:`load_preferences` keeps every good value, uses the
default for each bad one and returns one message per problem naming the file, the key and the
fix. Unknown keys are ignored and the next :func:`save_preferences` rewrites the file cleanly.
A file that cannot be read at all (not TOML, not text, nested too deeply) is never overwritten:
it is moved to ``preferences.toml.bad`` and the message says where.
:func:`reset_preferences` moves the file aside (``preferences.toml.bak``).

No Qt here: the window's side (reading widgets, applying values) is ``app.preferences``.
"""
from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from core.messages import TargetMode
from core.paths import os_error_reason, user_dir, write_file_atomically
from core.settings import (
    CameraSettings,
    LissajousParams,
    SettingsError,
    check_range,
    replace_field,
)

PREFERENCES_FILE = "preferences.toml"
MAX_RECENT_PORTS = 8
BRIDGE_PROTOCOLS = ("sim", "v1", "v2")
MAX_MARKER_ID = 1023  # ArUco's largest dictionary (original) has 1024 markers
FIX = "delete the file or use Reset to defaults"
_HEADER = ("# deskarm preferences, written by the app when it closes (help: F1 → Reset to defaults).\n"
           "# Units: metres, hertz, radians; window geometry in screen pixels.\n\n")


@dataclass(frozen=True)
class WindowGeometry:
    """Where the window was: its inner area in screen pixels (not Qt's opaque saveGeometry bytes)."""

    x: int = 0  # left edge on the virtual desktop (px), -100000 … 100000
    y: int = 0  # top edge (px), -100000 … 100000
    width: int = 800  # px, 100 … 20000
    height: int = 480  # px, 100 … 20000
    maximised: bool = False  # the window filled the screen's free area
    fullscreen: bool = False  # kiosk mode (F11)

    def __post_init__(self) -> None:
        for name in ("x", "y", "width", "height"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool):
                raise SettingsError(f"window.{name} = {value!r} must be a whole number of pixels")
        check_range("window", "x", self.x, -100_000, 100_000)
        check_range("window", "y", self.y, -100_000, 100_000)
        check_range("window", "width", self.width, 100, 20_000)
        check_range("window", "height", self.height, 100, 20_000)
        for name in ("maximised", "fullscreen"):
            if not isinstance(getattr(self, name), bool):
                raise SettingsError(f"window.{name} = {getattr(self, name)!r} must be true or false")


@dataclass(frozen=True)
class Preferences:
    """Everything remembered between runs; every default is what a first start shows."""

    target_mode: TargetMode = TargetMode.MANUAL  # how the goal is chosen (a TargetMode or its value)
    lissajous: LissajousParams = field(default_factory=LissajousParams)  # the curve (validated there)
    follow_id: int | None = None  # marker id to follow, 0 … 1023; None: the first one seen
    bridge_protocol: str = "v2"  # protocol chosen in the bridge picker: sim, v1 or v2
    bridge_port: str = ""  # serial port path chosen in the picker; "" = the first listed port
    recent_ports: tuple[str, ...] = ()  # ports connected successfully, most recent first, ≤ 8, no repeats
    view_3d: bool = False  # the 3D twin instead of the top and side views
    window: WindowGeometry | None = None  # last window geometry; None: the app fits one to the screen
    sim_camera: CameraSettings = field(default_factory=CameraSettings)  # simulated camera's image controls
    # real cameras: pair id ("webcam:0,2") -> control name -> value in the device's units
    camera_controls: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    # real cameras: pair id -> control name -> automatic mode on (only controls that have one)
    camera_auto: Mapping[str, Mapping[str, bool]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        try:
            mode = TargetMode(self.target_mode)
        except ValueError:
            raise SettingsError(f"target.mode = {self.target_mode!r}; allowed: "
                                f"{', '.join(m.value for m in TargetMode)}") from None
        object.__setattr__(self, "target_mode", mode)
        if not isinstance(self.lissajous, LissajousParams):
            raise SettingsError(f"lissajous = {self.lissajous!r} must be LissajousParams")
        if self.follow_id is not None:
            if not isinstance(self.follow_id, int) or isinstance(self.follow_id, bool):
                raise SettingsError(f"target.follow_id = {self.follow_id!r} must be a whole number")
            check_range("target", "follow_id", self.follow_id, 0, MAX_MARKER_ID)
        if self.bridge_protocol not in BRIDGE_PROTOCOLS:
            raise SettingsError(f"bridge.protocol = {self.bridge_protocol!r}; allowed: {', '.join(BRIDGE_PROTOCOLS)}")
        if not isinstance(self.bridge_port, str) or "\n" in self.bridge_port:
            raise SettingsError(f"bridge.port = {self.bridge_port!r} must be a port path on one line")
        object.__setattr__(self, "bridge_port", self.bridge_port.strip())
        object.__setattr__(self, "recent_ports", recent_ports_list(self.recent_ports))
        if not isinstance(self.view_3d, bool):
            raise SettingsError(f"view.twin_3d = {self.view_3d!r} must be true or false")
        if self.window is not None and not isinstance(self.window, WindowGeometry):
            raise SettingsError(f"window = {self.window!r} must be WindowGeometry")
        if not isinstance(self.sim_camera, CameraSettings):
            raise SettingsError(f"sim_camera = {self.sim_camera!r} must be CameraSettings")
        # copies: a caller's dict changed later must not change these frozen preferences
        object.__setattr__(self, "camera_controls",
                           _checked_per_pair("camera_controls", self.camera_controls, _finite_number))
        object.__setattr__(self, "camera_auto", _checked_per_pair("camera_auto", self.camera_auto, _boolean))


def _finite_number(value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SettingsError("is not a finite number")
    return float(value)


def _boolean(value: Any) -> bool:
    if not isinstance(value, bool):
        raise SettingsError("is not true or false")
    return value


def _checked_per_pair(owner: str, data: Mapping, check: Callable[[Any], Any]) -> dict[str, dict[str, Any]]:
    out: dict[str, dict[str, Any]] = {}
    if not isinstance(data, Mapping):
        raise SettingsError(f"{owner} = {data!r} must map camera pair ids to control values")
    for pair, controls in data.items():
        if not isinstance(pair, str) or not isinstance(controls, Mapping):
            raise SettingsError(f"{owner}.{pair!r} must map control names to values")
        checked = {}
        for name, value in controls.items():
            try:
                checked[str(name)] = check(value)
            except SettingsError as exc:
                raise SettingsError(f"{owner}.{pair}.{name} = {value!r} {exc}") from None
        out[pair] = checked
    return out


def recent_ports_list(ports: Sequence[str]) -> tuple[str, ...]:
    """Port paths as a recent list: stripped, empty and repeated ones dropped (the first, i.e.
    most recent, kept), at most MAX_RECENT_PORTS."""
    if isinstance(ports, str):
        raise SettingsError(f"bridge.recent_ports = {ports!r} must be a list of port paths")
    out: list[str] = []
    for port in ports:
        if not isinstance(port, str) or "\n" in port:
            raise SettingsError(f"bridge.recent_ports: {port!r} is not a port path")
        port = port.strip()
        if port and port not in out:
            out.append(port)
    return tuple(out[:MAX_RECENT_PORTS])


def with_recent_port(prefs: Preferences, port: str) -> Preferences:
    """``prefs`` with ``port`` first in the recent list (moved up if it was there already)."""
    return replace_field(prefs, recent_ports=(port, *prefs.recent_ports))


# why the plain simulated desk cannot run a mode, and the scenario that plays it
_SIM_DESK_CANNOT = {
    TargetMode.TELEOP: "Teleop, your last mode, needs a hand in the camera views and this simulated desk has "
                       "none (deskarm --scenario teleop has one)",
    TargetMode.CUPS: "the cups game, your last mode, needs a ball and cups on the desk and this simulated desk "
                     "has none (deskarm --scenario cups has them)",
}


def remembered_mode_refusal(mode: TargetMode | str, *, scenario: str = "static", camera_kind: str = "",
                            teleop_source: str | None = None, follow_object: str | None = None) -> str | None:
    """Whether the target mode saved by the last run comes back at this start: None when it does,
    else why not — "" when the command line chose the mode itself, or one line in plain words
    when the mode cannot run here.

    The rule: only a plain start gets the remembered mode back. A ``--scenario`` other than
    ``static`` (the default scene), a replay (``camera_kind`` "replay"), ``--teleop`` or
    ``--follow-object`` choose their own mode. On the plain simulated desk (``camera_kind``
    "sim") Teleop and the cups game cannot run — no hand, no ball — so they stay off and the
    line says which scenario plays them. Real cameras get every mode back: the hand, ball or
    object may well be on the desk.
    """
    mode = TargetMode(mode)
    if camera_kind == "replay" or scenario != "static" or teleop_source or follow_object:
        return ""
    if camera_kind == "sim" and mode in _SIM_DESK_CANNOT:
        return _SIM_DESK_CANNOT[mode]
    return None


# --------------------------------------------------------------------------------- the file
def preferences_path() -> Path:
    """``preferences.toml`` in the user's config folder (``DESKARM_HOME/config`` in tests)."""
    return user_dir("config") / PREFERENCES_FILE


def preferences_to_toml(prefs: Preferences) -> str:
    """The TOML text :func:`save_preferences` writes (tables target, lissajous, bridge, view,
    sim_camera, camera_controls, camera_auto and window)."""
    import tomli_w

    target: dict[str, Any] = {"mode": prefs.target_mode.value}
    if prefs.follow_id is not None:
        target["follow_id"] = prefs.follow_id
    liss = prefs.lissajous
    data: dict[str, Any] = {
        "target": target,
        "lissajous": {"centre": list(liss.centre), "amplitude": list(liss.amplitude),
                      "frequency_hz": list(liss.frequency_hz), "phase_rad": list(liss.phase_rad)},
        "bridge": {"protocol": prefs.bridge_protocol, "port": prefs.bridge_port,
                   "recent_ports": list(prefs.recent_ports)},
        "view": {"twin_3d": prefs.view_3d},
        "sim_camera": asdict(prefs.sim_camera),
    }
    if prefs.camera_controls:
        data["camera_controls"] = {pair: dict(values) for pair, values in prefs.camera_controls.items()}
    if prefs.camera_auto:
        data["camera_auto"] = {pair: dict(values) for pair, values in prefs.camera_auto.items()}
    if prefs.window is not None:
        data["window"] = asdict(prefs.window)
    return _HEADER + tomli_w.dumps(data)


def save_preferences(prefs: Preferences, path: os.PathLike | str | None = None) -> Path:
    """Write ``prefs`` (whole or not at all); returns the file. An OSError names the file, the
    reason and the fix ("…: cannot write: permission denied — make … writable …")."""
    return write_file_atomically(Path(path) if path else preferences_path(),
                                 preferences_to_toml(prefs).encode())


@dataclass(frozen=True)
class LoadedPreferences:
    """What :func:`read_preferences` found: the preferences, one message per problem, and
    whether the file must be left alone (unreadable and it could not be moved aside)."""

    prefs: Preferences  # the values to use (the defaults for anything unreadable)
    messages: list[str]  # one per problem, naming the file, the key and the fix
    kept_aside: Path | None = None  # where an unreadable file was moved (``preferences.toml.bad``)
    do_not_overwrite: bool = False  # unreadable and still at its place: a save would destroy it


def set_aside(path: Path) -> Path:
    """Move an unreadable ``path`` to ``<name>.bad`` (``.bad.2``, ``.bad.3`` … when taken) so
    the next save cannot destroy what the user had; returns the new place, OSError if it failed."""
    for n in range(1, 100):
        bad = path.with_name(f"{path.name}.bad" + (f".{n}" if n > 1 else ""))
        if not bad.exists():
            break
    os.replace(path, bad)
    return bad


def read_preferences(path: os.PathLike | str | None = None) -> LoadedPreferences:
    """The saved preferences and one message per problem found (never raises).

    A missing file gives the defaults and no message. An unreadable or invalid file gives the
    defaults and is moved aside (:func:`set_aside`, the message says where) — never overwritten
    by the next save; when it cannot be moved, ``do_not_overwrite`` is set. A bad value gives the
    default for that value only. Unknown keys are ignored.
    """
    from core.paths import UserFileError, read_user_toml

    path = Path(path) if path else preferences_path()
    try:
        data = read_user_toml(path, "a preferences file", FIX)
    except FileNotFoundError:
        return LoadedPreferences(Preferences(), [])
    except UserFileError as exc:
        problem = str(exc).rsplit(f" — {FIX}", 1)[0]
        if not path.is_file():  # e.g. the config folder is a file: nothing of the user's to keep
            return LoadedPreferences(Preferences(), [f"{problem} — using the defaults; {FIX}"])
        try:
            bad = set_aside(path)
        except OSError as move_error:
            return LoadedPreferences(Preferences(), [
                f"{problem} — using the defaults; it could not be moved aside ({os_error_reason(move_error)}), "
                f"so nothing is saved over it this run; {FIX}"], do_not_overwrite=True)
        return LoadedPreferences(Preferences(), [
            f"{problem} — kept as {bad}; using the defaults (copy back what you need from it)"], kept_aside=bad)
    reader = _Reader(path)
    prefs = reader.preferences(data)
    return LoadedPreferences(prefs, reader.messages)


def load_preferences(path: os.PathLike | str | None = None) -> tuple[Preferences, list[str]]:
    """(preferences, messages) of :func:`read_preferences` (never raises; an unreadable file is
    moved aside to ``preferences.toml.bad`` and the message says so)."""
    loaded = read_preferences(path)
    return loaded.prefs, loaded.messages


def reset_preferences(path: os.PathLike | str | None = None) -> Path | None:
    """Forget the saved preferences: the file becomes ``preferences.toml.bak`` (replacing an
    older copy). Returns the copy, or None when there was no file; an OSError names the file."""
    path = Path(path) if path else preferences_path()
    if not path.exists():
        return None
    backup = path.with_name(path.name + ".bak")
    try:
        os.replace(path, backup)
    except OSError as exc:
        error = type(exc)(f"{path}: cannot reset: {os_error_reason(exc)} — delete the file by hand")
        error.errno = exc.errno
        raise error from None
    return backup


# --------------------------------------------------------------------------------- reading
class _Bad(ValueError):
    """A stored value of the wrong type; the message completes "key = value …"."""


def _as_str(value: Any) -> str:
    if not isinstance(value, str):
        raise _Bad("is not text")
    return value


def _as_bool(value: Any) -> bool:
    if not isinstance(value, bool):
        raise _Bad("is not true or false")
    return value


def _as_int(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise _Bad("is not a whole number")
    return value


def _as_float(value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise _Bad("is not a number")
    return float(value)


def _as_vec3(value: Any) -> tuple[float, float, float]:
    if not isinstance(value, list) or len(value) != 3:
        raise _Bad("is not a list of 3 numbers")
    try:
        return tuple(_as_float(v) for v in value)  # type: ignore[return-value]
    except _Bad:
        raise _Bad("is not a list of 3 numbers") from None


def _as_str_list(value: Any) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise _Bad("is not a list of port paths")
    return value


def _what_is_wrong(error: str, value: Any) -> str:
    """The end of "key = value …" from a SettingsError about ``value`` ("is outside the allowed
    range 0.0…24.0"), without repeating the key and the value it names."""
    _, found, rest = error.partition(f" = {value!r}")
    if found and rest.startswith(" "):
        return rest.strip()
    if found and rest.startswith(";"):
        return f"is not allowed ({rest[1:].strip()})"
    return f"is not allowed ({error})"


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "…"


class _Reader:
    """Reads the TOML tables value by value, collecting a message per bad value."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.messages: list[str] = []

    def problem(self, key: str, value: Any, what: str) -> None:
        self.messages.append(f"{self.path}: {key} = {_short(value)} {what} — using the default; {FIX}")

    def table(self, data: Mapping, key: str) -> dict:
        value = data.get(key, {})
        if not isinstance(value, dict):
            self.problem(key, value, "is not a table")
            return {}
        return value

    def value(self, table: Mapping, section: str, key: str, parse: Callable[[Any], Any],
              check: Callable[[Any], Any] | None = None) -> Any:
        """The parsed value of ``table[key]``, or _MISSING (absent or bad: a message says which)."""
        if key not in table:
            return _MISSING
        raw = table[key]
        try:
            value = parse(raw)
            if check is not None:
                check(value)
        except _Bad as exc:
            self.problem(f"{section}.{key}", raw, str(exc))
            return _MISSING
        except SettingsError as exc:
            self.problem(f"{section}.{key}", raw, _what_is_wrong(str(exc), value))
            return _MISSING
        return value

    def fields_of(self, defaults, table: Mapping, section: str,
                  parsers: Mapping[str, Callable[[Any], Any]]) -> dict:
        """The good values of ``table`` for the fields of dataclass instance ``defaults``, each
        checked on its own (with the defaults for the others)."""
        out = {}
        for name, parse in parsers.items():
            value = self.value(table, section, name, parse, lambda v, n=name: replace_field(defaults, **{n: v}))
            if value is not _MISSING:
                out[name] = value
        return out

    def preferences(self, data: Mapping) -> Preferences:
        defaults = Preferences()
        values: dict[str, Any] = {}

        def check(name):
            return lambda v: replace_field(defaults, **{name: v})

        target = self.table(data, "target")
        for name, key, parse in (("target_mode", "mode", _as_str), ("follow_id", "follow_id", _as_int)):
            value = self.value(target, "target", key, parse, check(name))
            if value is not _MISSING:
                values[name] = value

        liss = self.fields_of(defaults.lissajous, self.table(data, "lissajous"), "lissajous",
                              {f.name: _as_vec3 for f in fields(LissajousParams)})
        values["lissajous"] = LissajousParams(**liss)

        bridge = self.table(data, "bridge")
        for name, key, parse in (("bridge_protocol", "protocol", _as_str), ("bridge_port", "port", _as_str),
                                 ("recent_ports", "recent_ports", _as_str_list)):
            value = self.value(bridge, "bridge", key, parse, check(name))
            if value is not _MISSING:
                values[name] = value

        value = self.value(self.table(data, "view"), "view", "twin_3d", _as_bool, check("view_3d"))
        if value is not _MISSING:
            values["view_3d"] = value

        if "window" in data:
            geometry = self.fields_of(WindowGeometry(), self.table(data, "window"), "window",
                                      {"x": _as_int, "y": _as_int, "width": _as_int, "height": _as_int,
                                       "maximised": _as_bool, "fullscreen": _as_bool})
            values["window"] = WindowGeometry(**geometry)

        camera = self.fields_of(defaults.sim_camera, self.table(data, "sim_camera"), "sim_camera",
                                {f.name: _as_float for f in fields(CameraSettings)})
        values["sim_camera"] = CameraSettings(**camera)

        values["camera_controls"] = self.per_pair(data, "camera_controls", _as_float)
        values["camera_auto"] = self.per_pair(data, "camera_auto", _as_bool)
        try:
            return Preferences(**values)
        except SettingsError as exc:  # each value was checked alone: only a surprise lands here
            self.messages.append(f"{self.path}: {exc} — using the defaults; {FIX}")
            return Preferences()

    def per_pair(self, data: Mapping, section: str, parse: Callable[[Any], Any]) -> dict:
        out: dict[str, dict[str, Any]] = {}
        for pair, controls in self.table(data, section).items():
            if not isinstance(controls, dict):
                self.problem(f"{section}.{pair}", controls, "is not a table of control values")
                continue
            good = {}
            for name in controls:
                value = self.value(controls, f"{section}.{pair}", name, parse)
                if value is not _MISSING:
                    good[name] = value
            out[pair] = good
        return out


_MISSING = object()

__all__ = [
    "BRIDGE_PROTOCOLS",
    "MAX_RECENT_PORTS",
    "PREFERENCES_FILE",
    "Preferences",
    "WindowGeometry",
    "load_preferences",
    "read_preferences",
    "LoadedPreferences",
    "set_aside",
    "preferences_path",
    "preferences_to_toml",
    "recent_ports_list",
    "remembered_mode_refusal",
    "reset_preferences",
    "save_preferences",
    "with_recent_port",
]
