"""The assistive view's settings (``assist.toml``) and the words for its switches.

``AssistSettings`` is what the view's features share: the input mode, the scan period, the long
press, the sound cue, the switch mapping and the real arm's ready pose. It is kept in
``assist.toml`` in the user's config folder (core.paths; ``DESKARM_HOME`` in tests) — a file of
its own so the main window's ``preferences.toml`` is untouched. The other modules of
``app.assist`` may import this one; none of them imports another.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Optional

from PySide6 import QtCore, QtGui

from core.motion.scanning import MAX_PERIOD_S, MIN_PERIOD_S

ASSIST_SETTINGS_FILE = "assist.toml"
MODES = ("touch", "scan2", "scan1")
MODE_NAMES = {"touch": "Touch", "scan2": "2 switches", "scan1": "1 switch"}


@dataclass(frozen=True)
class AssistSettings:
    """The assistive view's own settings (``assist.toml``)."""

    mode: str = "touch"
    scan_period_s: float = 1.5
    long_press_s: float = 1.5
    sound: bool = False
    next_switch: tuple[str, ...] = ("key:Space", "mouse:right")
    confirm_switch: tuple[str, ...] = ("key:Return", "key:Enter", "mouse:left")
    single_switch: tuple[str, ...] = ("key:Space", "key:Return", "key:Enter", "mouse:left")
    # the real arm's ready pose (degrees, one per joint) where its camera sees the panel; () = the
    # pose aimed at the simulated desk's panel place (``app.cli_assist.nominal_ready_pose``)
    ready_deg: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"assist mode {self.mode!r}: use one of {', '.join(MODES)}")
        if not MIN_PERIOD_S <= self.scan_period_s <= MAX_PERIOD_S:
            raise ValueError(f"scan period {self.scan_period_s} s is outside {MIN_PERIOD_S:g}…{MAX_PERIOD_S:g} s")
        if not 0.5 <= self.long_press_s <= 5.0:
            raise ValueError(f"long press {self.long_press_s} s is outside 0.5…5 s")
        for role in ("next_switch", "confirm_switch", "single_switch"):
            names = getattr(self, role)
            bad = [n for n in names if not is_switch_name(n)]
            if bad or not names:
                raise ValueError(f"{role} = {list(names)}: each switch is 'key:NAME' (a Qt key name such as "
                                 f"key:Space, key:Return, key:F1), one of mouse:left, mouse:right, mouse:middle, "
                                 f"gamepad:BTN_… (an evdev button, e.g. gamepad:BTN_SOUTH) or gpio:PIN (a "
                                 f"Raspberry Pi BCM pin, e.g. gpio:17)")
        if set(self.next_switch) & set(self.confirm_switch):
            raise ValueError(f"{sorted(set(self.next_switch) & set(self.confirm_switch))} is both 'next' and "
                             f"'confirm': give the two switches different keys or buttons")


def is_switch_name(name: str) -> bool:
    """'key:<Qt key name>', 'mouse:left|right|middle', 'gamepad:BTN_…' or 'gpio:PIN' (core.devices.switches)."""
    from core.devices.switches import is_device_switch_name

    if name in ("mouse:left", "mouse:right", "mouse:middle") or is_device_switch_name(name):
        return True
    if not name.startswith("key:") or len(name) <= 4:
        return False
    return QtGui.QKeySequence.fromString(name[4:])[0].key() != QtCore.Qt.Key.Key_unknown


def key_switch_name(event: QtGui.QKeyEvent) -> str:
    """The switch name of a key event: 'key:Space', 'key:Return', 'key:A', …"""
    return "key:" + QtGui.QKeySequence(event.key()).toString()


def switch_words(names) -> str:
    """Switch names in plain words: ("key:Space", "mouse:right") → "Space key or right mouse button".

    Enter and Return (one key on most keyboards, two Qt names) read as one "Enter key"."""
    words: list[str] = []
    for name in names:
        kind, _, what = name.partition(":")
        if kind == "key":
            text = "Enter key" if what in ("Return", "Enter") else f"{what} key"
        elif kind == "mouse":
            text = f"{what} mouse button"
        elif kind == "gamepad":
            text = f"gamepad {what}"
        elif kind == "gpio":
            text = f"switch on pin {what}"
        else:
            text = name
        if text not in words:
            words.append(text)
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " or " + words[-1]


def with_switches(settings: AssistSettings, specs) -> AssistSettings:
    """The settings with each ``SwitchSpec`` (``--switch NAME=ROLE``) added to its role's switches
    (and taken out of the other 2-switch role, so next and confirm never share a switch)."""
    roles = {"next": "next_switch", "confirm": "confirm_switch", "single": "single_switch"}
    changes = {field: tuple(getattr(settings, field)) for field in roles.values()}
    for spec in specs:
        field = roles[spec.role]
        if spec.name not in changes[field]:
            changes[field] = changes[field] + (spec.name,)
        other = {"next_switch": "confirm_switch", "confirm_switch": "next_switch"}.get(field)
        if other:
            changes[other] = tuple(n for n in changes[other] if n != spec.name)
    return replace(settings, **changes)


def device_switch_names(settings: AssistSettings) -> list[str]:
    """The switches in the settings that need a source of their own (gamepad buttons, GPIO pins)."""
    from core.devices.switches import is_device_switch_name

    names = [n for role in ("next_switch", "confirm_switch", "single_switch") for n in getattr(settings, role)]
    return sorted({n for n in names if is_device_switch_name(n)})


def settings_path() -> Path:
    from core.paths import user_dir

    return user_dir("config") / ASSIST_SETTINGS_FILE


_ASSIST_FIX = "using the defaults; fix or delete the file"


def _assist_value(key: str, value):
    """``value`` from assist.toml as the type of setting ``key`` wants, or ValueError saying what is expected."""
    import math

    default = AssistSettings.__dataclass_fields__[key].default

    def number(v) -> bool:
        return isinstance(v, (int, float)) and not isinstance(v, bool)

    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ValueError("expected true or false")
        return value
    if isinstance(default, float):
        if not number(value):
            raise ValueError("expected a number")
        return float(value)
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ValueError("expected a string")
        return value
    if key == "ready_deg":
        if not (isinstance(value, list) and all(number(v) and math.isfinite(v) for v in value)):
            raise ValueError("expected a list of finite numbers (degrees, one per joint)")
        return tuple(float(v) for v in value)
    if not (isinstance(value, list) and all(isinstance(v, str) for v in value)):  # the *_switch lists
        raise ValueError("expected a list of switch names such as [\"key:Space\", \"mouse:right\"]")
    return tuple(value)


def _short_value(value) -> str:
    """``repr(value)`` cut to a line: a value nested hundreds of levels deep stays readable."""
    import reprlib

    short = reprlib.Repr()
    short.maxlevel, short.maxlist, short.maxdict, short.maxstring, short.maxother = 2, 4, 4, 40, 40
    return short.repr(value)


def load_assist_settings(path: Optional[Path] = None) -> tuple[AssistSettings, list[str]]:
    """The saved settings (defaults when there is no file) and warnings for what was not usable.

    A file that cannot be read at all (not TOML, not UTF-8, nested too deeply) gives the defaults
    and one warning naming the file; a bad value gives the default for that setting only."""
    from core.paths import UserFileError, read_user_toml

    path = Path(path) if path else settings_path()
    try:
        data = read_user_toml(path, "the assistive view's settings", _ASSIST_FIX)
    except FileNotFoundError:
        return AssistSettings(), []
    except UserFileError as exc:
        return AssistSettings(), [str(exc)]
    settings, warnings = AssistSettings(), []
    for key, value in data.items():
        if key not in AssistSettings.__dataclass_fields__:
            warnings.append(f"{path}: unknown setting {key!r} ignored")
            continue
        try:
            settings = replace(settings, **{key: _assist_value(key, value)})
        except (TypeError, ValueError) as exc:
            warnings.append(f"{path}: {key} = {_short_value(value)}: {exc} — the default is used")
    return settings, warnings


def save_assist_settings(settings: AssistSettings, path: Optional[Path] = None) -> Path:
    import tomli_w

    from core.paths import write_file_atomically

    data = {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(settings).items()}
    text = "# deskarm: the assistive view's settings (written by the window)\n" + tomli_w.dumps(data)
    return write_file_atomically(Path(path) if path else settings_path(), text.encode())


def switch_role(settings: AssistSettings, name: str) -> Optional[str]:
    """What switch ``name`` does in the settings' mode: "next", "confirm", "single" or None (not a
    switch there; never one in touch mode)."""
    if settings.mode == "scan1":
        return "single" if name in settings.single_switch else None
    if settings.mode == "scan2":
        if name in settings.next_switch:
            return "next"
        if name in settings.confirm_switch:
            return "confirm"
    return None


def hint_text(settings: AssistSettings, messages=()) -> str:
    """The side column's hint: how to choose in the settings' mode, then ``messages`` (problems)."""
    hold = f"Hold {settings.long_press_s:g} s: stop (again: re-arm)."
    text = {"touch": "Tap a numbered box.",
            "scan2": (f"Next: {switch_words(settings.next_switch)}.\nGo: {switch_words(settings.confirm_switch)}."
                      f"\n{hold}"),
            "scan1": f"Press the {switch_words(settings.single_switch)} when your box is yellow.\n{hold}"}[settings.mode]
    if messages:
        text += "\n\n" + "\n".join(messages)
    return text
