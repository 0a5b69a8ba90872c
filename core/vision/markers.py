"""The markers a user configures: which dictionary, which ids, their names and what the arm does
with each (``markers.toml`` in the user's config folder, or a path given on the command line).

A file looks like ``resources/markers.example.toml``::

    dictionary = "DICT_APRILTAG_36h11"   # any predefined OpenCV ArUco or AprilTag dictionary, or the
                                         # path of a dictionary file (cv2.aruco writeDictionary's YAML;
                                         # a relative path is taken from this file's folder)
    side_m = 0.03                        # printed side of the black square, metres

    [places]                             # named spots in robot_base, metres
    bin = [0.15, 0.05, 0.02]

    [[marker]]
    id = 23
    name = "cup A"
    action = "pick_place"                # "follow" | "point" | "pick_place"
    place = "bin"                        # pick_place: where to put it (a key of [places])

It is read once, validated, and turned into frozen dataclasses. Every error a user can hit names
the file, the key and what was expected, e.g.::

    .../markers.toml: marker[2].id = 23 is used twice (marker[0])

Without a file deskarm keeps its built-in markers (:func:`default_markers`: ids 23 and 50 of
DICT_6X6_250, the simulated desk's markers). No Qt here: the table is ``widgets.markers_table``.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Optional, Union

from core.settings import is_number as _is_number
from core.settings import toml_type_name as _type_name

from core.paths import os_error_reason, user_dir
from core.vision.perception import (
    ARUCO_DICTIONARIES,
    ARUCO_DICTIONARY_ALIASES,
    DEFAULT_DICTIONARY,
    dictionary_name,
    dictionary_size,
    is_dictionary_file,
)

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

MARKERS_FILE = "markers.toml"
ACTIONS = ("follow", "point", "pick_place")  # what the arm does with a marker
DEFAULT_SIDE_M = 0.03  # the simulated desk's markers are 3 cm squares
SIDE_MIN_M = 0.005  # smaller than 5 mm no webcam resolves the cells
SIDE_MAX_M = 0.5  # larger than 50 cm is a unit mistake (cm or mm typed as m)
PLACE_LIMIT_M = 2.0  # |x|, |y|, |z| of a place: a desk arm reaches far less; more is a unit mistake
NAME_MAX_CHARS = 40  # a name must fit a table cell on a 7" screen
DEFAULT_MARKER_IDS = (23, 50)  # the simulated desk's markers

_TOP_KEYS = ("dictionary", "side_m", "places", "marker")
_MARKER_KEYS = ("id", "name", "action", "place")

Point3 = tuple[float, float, float]


class MarkersError(ValueError):
    """A markers file or configuration is not usable; the message names the file and the key."""


# --------------------------------------------------------------------------------------------
# Dataclasses


@dataclass(frozen=True)
class MarkerSpec:
    """One configured marker: its id, a name for people and what the arm does with it."""

    marker_id: int  # id in the dictionary, 0 … dictionary size - 1 (``id`` in the file)
    name: str = ""  # shown in the table, e.g. "cup A", 1 … 40 characters; "" = "marker <id>"
    action: str = "follow"  # "follow" (tool above it), "point" (tool towards it) or "pick_place"
    place: Optional[str] = None  # a key of MarkersConfig.places; needed by "pick_place"

    def __post_init__(self) -> None:
        _check_marker("", f"marker {self.marker_id!r}: ", self.marker_id, self.name, self.action,
                      self.place)
        if not self.name:
            object.__setattr__(self, "name", f"marker {self.marker_id}")


@dataclass(frozen=True)
class MarkersConfig:
    """The validated markers of a session; read-only and shared by perception, targets and GUI."""

    dictionary: str = DEFAULT_DICTIONARY  # a name of core.vision.perception.ARUCO_DICTIONARIES, or a dictionary file's path
    side_m: float = DEFAULT_SIDE_M  # printed side of the marker's black square, m, 0.005 … 0.5
    markers: tuple[MarkerSpec, ...] = ()  # in file order, ids unique, at least one
    places: Mapping[str, Point3] = field(default_factory=dict)  # name -> point in robot_base, m
    source: str = field(default="", compare=False)  # the file it was read from ("" when built in code)

    def __post_init__(self) -> None:
        where = f"{self.source}: " if self.source else ""
        object.__setattr__(self, "dictionary", _check_dictionary(where, self.dictionary))
        _check_side(where, self.side_m)
        object.__setattr__(self, "side_m", float(self.side_m))
        object.__setattr__(self, "markers", tuple(self.markers))
        object.__setattr__(self, "places", {str(k): _check_place(where, k, v) for k, v in dict(self.places).items()})
        if not self.markers:
            raise MarkersError(f"{where}no [[marker]] entries — add at least one (id = 23, name = \"cup A\")")
        size = dictionary_size(self.dictionary)
        first: dict[int, int] = {}
        for i, m in enumerate(self.markers):
            if not isinstance(m, MarkerSpec):
                raise MarkersError(f"{where}marker[{i}] must be a MarkerSpec, got {type(m).__name__}")
            if not 0 <= m.marker_id < size:
                raise MarkersError(f"{where}marker[{i}].id = {m.marker_id} is outside 0…{size - 1} "
                                   f"({self.dictionary} has {size} markers)")
            if m.marker_id in first:
                raise MarkersError(f"{where}marker[{i}].id = {m.marker_id} is used twice "
                                   f"(marker[{first[m.marker_id]}])")
            first[m.marker_id] = i
            if m.place is not None and m.place not in self.places:
                known = ", ".join(self.places) or "none: add a [places] table"
                raise MarkersError(f"{where}marker[{i}].place = {m.place!r} is not a place; "
                                   f"expected one of [places]: {known}")

    @property
    def ids(self) -> tuple[int, ...]:
        """The configured ids, in file order (perception's ``marker_ids``)."""
        return tuple(m.marker_id for m in self.markers)

    def marker(self, marker_id: int) -> Optional[MarkerSpec]:
        """The marker with this id, or None when it is not configured."""
        for m in self.markers:
            if m.marker_id == marker_id:
                return m
        return None

    def name_of(self, marker_id: int) -> str:
        """The configured name, or ``"marker <id>"`` for an id not in the file."""
        m = self.marker(marker_id)
        return m.name if m is not None else f"marker {marker_id}"

    def place_of(self, marker_id: int) -> Optional[Point3]:
        """Where a pick_place marker goes (robot_base, m), or None."""
        m = self.marker(marker_id)
        if m is None or m.place is None:
            return None
        return self.places[m.place]

    def summary(self) -> str:
        """One line for a status bar or the command line: "2 markers (23, 50), DICT_6X6_250, 30 mm"."""
        ids = ", ".join(str(i) for i in self.ids)
        n = len(self.markers)
        return f"{n} marker{'s' if n != 1 else ''} ({ids}), {self.dictionary}, {self.side_m * 1e3:g} mm"


# --------------------------------------------------------------------------------------------
# Checks shared by the dataclasses (code-built configs) and the file reader (file + key in errors)


def _check_dictionary(where: str, value: Any, folder: Optional[Path] = None) -> str:
    """The canonical dictionary name, or a dictionary file's path (a relative one is taken from
    ``folder``, the markers file's own, so the pair can move together)."""
    if isinstance(value, str):
        if value in ARUCO_DICTIONARIES:
            return value
        if value in ARUCO_DICTIONARY_ALIASES:
            return ARUCO_DICTIONARY_ALIASES[value]
        if is_dictionary_file(value):
            path = Path(value).expanduser()
            if folder is not None and not path.is_absolute():
                path = Path(os.path.abspath(folder / path))  # absolute: the config may be re-checked elsewhere
            try:
                return dictionary_name(str(path))
            except ValueError as exc:
                raise MarkersError(f"{where}dictionary = {value!r}: {exc}") from None
    raise MarkersError(f"{where}dictionary = {value!r} is unknown; expected one of "
                       f"{', '.join(ARUCO_DICTIONARIES)}, or the path of a dictionary file "
                       "(.yml/.yaml/.json/.xml, as cv2.aruco Dictionary.writeDictionary writes)")


def _check_side(where: str, value: Any) -> None:
    if not _is_number(value) or not math.isfinite(value):
        raise MarkersError(f"{where}side_m = {value!r} must be a number of metres, got {_type_name(value)}")
    if not SIDE_MIN_M <= value <= SIDE_MAX_M:
        raise MarkersError(f"{where}side_m = {value!r} is outside {SIDE_MIN_M:g}…{SIDE_MAX_M:g} m — "
                           f"the side is in metres (3 cm = 0.03)")


def _check_place(where: str, name: Any, value: Any) -> Point3:
    key = f"places.{name}"
    if (not isinstance(value, (list, tuple)) or len(value) != 3
            or not all(_is_number(v) and math.isfinite(v) for v in value)):
        raise MarkersError(f"{where}{key} = {value!r} must be [x, y, z] in metres (robot_base)")
    for axis, v in zip("xyz", value):
        if abs(v) > PLACE_LIMIT_M:
            raise MarkersError(f"{where}{key} {axis} = {v!r} is outside ±{PLACE_LIMIT_M:g} m — "
                               "places are in metres (15 cm = 0.15)")
    return (float(value[0]), float(value[1]), float(value[2]))


def _check_marker(where: str, path: str, marker_id: Any, name: Any, action: Any, place: Any) -> None:
    if not isinstance(marker_id, int) or isinstance(marker_id, bool):
        raise MarkersError(f"{where}{path}id = {marker_id!r} must be a whole number, got {_type_name(marker_id)}")
    if marker_id < 0:
        raise MarkersError(f"{where}{path}id = {marker_id} must be 0 or more")
    if not isinstance(name, str):
        raise MarkersError(f"{where}{path}name = {name!r} must be a string, got {_type_name(name)}")
    if len(name) > NAME_MAX_CHARS:
        raise MarkersError(f"{where}{path}name = {name!r} is longer than {NAME_MAX_CHARS} characters")
    if action not in ACTIONS:
        raise MarkersError(f"{where}{path}action = {action!r} is unknown; expected one of "
                           f"{', '.join(ACTIONS)}")
    if place is not None and not isinstance(place, str):
        raise MarkersError(f"{where}{path}place = {place!r} must be the name of a place (a string), "
                           f"got {_type_name(place)}")
    if action == "pick_place" and place is None:
        raise MarkersError(f"{where}{path}action = \"pick_place\" needs place = \"NAME\", "
                           "one of the [places] table's names")






# --------------------------------------------------------------------------------------------
# Reading and writing


def parse_markers(data: Mapping[str, Any], source: str = "") -> MarkersConfig:
    """Validate parsed TOML (a dict) and build a MarkersConfig; errors name ``source`` and the key."""
    where = f"{source}: " if source else ""
    for key in data:
        if key not in _TOP_KEYS:
            hint = " (the array of tables is [[marker]], singular)" if key == "markers" else ""
            raise MarkersError(f"{where}unknown key {key}{hint}; expected one of {', '.join(_TOP_KEYS)}")
    folder = Path(source).expanduser().parent if source else None
    dictionary = _check_dictionary(where, data.get("dictionary", DEFAULT_DICTIONARY), folder)
    side_m = data.get("side_m", DEFAULT_SIDE_M)
    _check_side(where, side_m)
    places_table = data.get("places", {})
    if not isinstance(places_table, dict):
        raise MarkersError(f"{where}places must be a table ([places] name = [x, y, z]), got {_type_name(places_table)}")
    places = {name: _check_place(where, name, value) for name, value in places_table.items()}
    entries = data.get("marker", [])
    if not isinstance(entries, list):
        raise MarkersError(f"{where}marker must be an array of tables ([[marker]]), got {_type_name(entries)}")
    markers = []
    for i, table in enumerate(entries):
        path = f"marker[{i}]."
        if not isinstance(table, dict):
            raise MarkersError(f"{where}marker[{i}] must be a table ([[marker]]), got {_type_name(table)}")
        for key in table:
            if key not in _MARKER_KEYS:
                raise MarkersError(f"{where}unknown key {path}{key}; expected one of {', '.join(_MARKER_KEYS)}")
        if "id" not in table:
            raise MarkersError(f"{where}missing key {path}id (the marker's number in {dictionary})")
        fields = (table["id"], table.get("name", ""), table.get("action", "follow"), table.get("place"))
        _check_marker(where, path, *fields)
        markers.append(MarkerSpec(*fields))
    return MarkersConfig(dictionary=dictionary, side_m=side_m, markers=tuple(markers), places=places,
                         source=source)


def load_markers(path: Union[str, os.PathLike]) -> MarkersConfig:
    """Read and validate a markers file.

    Raises MarkersError naming the file, the key and the allowed values.
    """
    source = str(path)
    try:
        raw = Path(path).read_bytes()
    except FileNotFoundError:
        raise MarkersError(f"{source}: no such file — check the path "
                           "(resources/markers.example.toml is a template)") from None
    except IsADirectoryError:
        raise MarkersError(f"{source}: is a folder, expected a .toml file") from None
    except OSError as exc:
        raise MarkersError(f"{source}: cannot read: {os_error_reason(exc)}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise MarkersError(f"{source}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise MarkersError(f"{source}: invalid TOML: {exc}") from None
    except RecursionError:  # tomllib recurses per nested array or inline table
        raise MarkersError(f"{source}: nested too deeply — a markers file needs two levels; fix the file") from None
    return parse_markers(data, source)


def markers_to_toml(config: MarkersConfig) -> str:
    """The TOML text of ``config`` (``load_markers`` of it gives an equal config)."""
    lines = [f"dictionary = {_toml_str(config.dictionary)}", f"side_m = {config.side_m!r}", ""]
    if config.places:
        lines.append("[places]")
        for name, (x, y, z) in config.places.items():
            lines.append(f"{_toml_str(name)} = [{x!r}, {y!r}, {z!r}]")
        lines.append("")
    for m in config.markers:
        lines += ["[[marker]]", f"id = {m.marker_id}", f"name = {_toml_str(m.name)}",
                  f"action = {_toml_str(m.action)}"]
        if m.place is not None:
            lines.append(f"place = {_toml_str(m.place)}")
        lines.append("")
    return "\n".join(lines)


def _toml_str(s: str) -> str:
    """A TOML basic string (JSON's escapes are valid TOML)."""
    return json.dumps(s, ensure_ascii=False)


def default_markers() -> MarkersConfig:
    """deskarm's markers without a file: ids 23 and 50 of DICT_6X6_250 (3 cm), followed."""
    return MarkersConfig(
        dictionary=DEFAULT_DICTIONARY,
        side_m=DEFAULT_SIDE_M,
        markers=tuple(MarkerSpec(i, f"marker {i}", "follow") for i in DEFAULT_MARKER_IDS),
    )


def default_markers_path() -> Path:
    """``markers.toml`` in the user's config folder (``DESKARM_HOME`` overrides)."""
    return user_dir("config") / MARKERS_FILE


def markers_for_session(path: Optional[str]) -> tuple[MarkersConfig, Optional[str]]:
    """The markers a session uses and a note for the user (None when there is nothing to say).

    An explicit ``path`` (``--markers``) must load: its errors raise MarkersError. Without one,
    ``markers.toml`` in the config folder is used when it exists; when it is missing the defaults
    are used silently, when it is broken the defaults are used and the note says why.
    """
    if path:
        return load_markers(path), None
    default = default_markers_path()
    if not default.exists():
        return default_markers(), None
    try:
        return load_markers(default), None
    except MarkersError as exc:
        fallback = default_markers()
        return fallback, (f"{exc} — using the built-in markers ({', '.join(map(str, fallback.ids))}, "
                          f"{fallback.dictionary}) until the file is fixed")


__all__ = [
    "ACTIONS", "MARKERS_FILE", "MarkerSpec", "MarkersConfig", "MarkersError", "default_markers",
    "default_markers_path", "load_markers", "markers_for_session", "markers_to_toml", "parse_markers",
]
