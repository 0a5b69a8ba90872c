"""Switches that are not keys or mouse buttons: a gamepad button (evdev) or a Raspberry Pi GPIO pin (gpiozero).

Most switch interfaces present themselves as a keyboard (Space / Enter) and need nothing here.
The others report through a switch source: each one calls ``handler(name, pressed)`` — the same
switch name the assistive window's settings map to a role ("gamepad:BTN_SOUTH", "gpio:17") and
True on press, False on release — from its own thread; the window hands that on to the GUI thread
and into the very code the keys go through (``AssistWindow.switch_down`` / ``switch_up``).

Both libraries are imported lazily (only when such a switch is configured). A missing library,
no such device, or no permission gives a clear ``status_message`` naming the fix (``pip install
evdev`` / ``pip install gpiozero``; the user in the ``input`` / ``gpio`` group) and the source
keeps retrying every ``retry_interval_s`` — never an exception in the window. A gamepad that is
unplugged is looked for again the same way.

Switch names and CLI specs:

- ``gamepad:BTN_SOUTH`` — the first input device that has that key code (evdev's names: BTN_SOUTH
  (A / cross), BTN_EAST, BTN_TL, …, or a number);
- ``gpio:17`` — BCM pin 17, wired to ground through the switch (internal pull-up, 20 ms debounce).

``--switch gamepad:BTN_SOUTH=confirm`` is a name and a role: next, confirm or single.
"""
from __future__ import annotations

import importlib
import threading
from dataclasses import dataclass
from typing import Callable, Optional

SWITCH_ROLES = ("next", "confirm", "single")
RETRY_INTERVAL_S = 1.0  # a missing gamepad / pin is tried again this often
POLL_INTERVAL_S = 0.01  # the gamepad's events are read this often (a press lasts ≥ 50 ms)
GPIO_BOUNCE_S = 0.02  # a mechanical switch's bounce

SwitchHandler = Callable[[str, bool], None]


def is_device_switch_name(name: str) -> bool:
    """'gamepad:<evdev key name or code>' or 'gpio:<BCM pin 0…27>'."""
    if name.startswith("gamepad:"):
        key = name[8:]
        return key.isdigit() or (key.startswith(("BTN_", "KEY_")) and len(key) > 4 and key.replace("_", "").isalnum())
    if name.startswith("gpio:"):
        pin = name[5:]
        return pin.isdigit() and 0 <= int(pin) <= 27
    return False


@dataclass(frozen=True)
class SwitchSpec:
    """A switch and the role it plays (``--switch NAME=ROLE``)."""

    name: str  # "gamepad:BTN_SOUTH", "gpio:17", "key:Space", "mouse:left"
    role: str  # next, confirm or single


def parse_switch_spec(spec: str) -> SwitchSpec:
    """``gamepad:BTN_SOUTH=confirm`` → SwitchSpec; ValueError naming the accepted forms."""
    name, sep, role = (spec or "").strip().rpartition("=")
    if not sep or role not in SWITCH_ROLES or not name:
        raise ValueError(f"switch {spec!r}: use NAME=ROLE with ROLE one of {', '.join(SWITCH_ROLES)} — e.g. "
                         f"gamepad:BTN_SOUTH=confirm, gpio:17=single, key:F1=next")
    if not (is_device_switch_name(name) or name.startswith(("key:", "mouse:"))):
        raise ValueError(f"switch {spec!r}: {name!r} is not a switch — use gamepad:BTN_… (an evdev key name), "
                         f"gpio:PIN (a BCM pin 0…27), key:NAME or mouse:left|right|middle")
    return SwitchSpec(name, role)


def _import(module: str):
    """The library, or None when it is not installed (tests inject fakes into sys.modules)."""
    try:
        return importlib.import_module(module)
    except ImportError:
        return None


class SwitchSource:
    """A switch read in a thread of its own; ``handler(name, pressed)`` on every press and release."""

    def __init__(self, name: str, handler: SwitchHandler, retry_interval_s: float = RETRY_INTERVAL_S):
        self.name = name
        self.handler = handler
        self.retry_interval_s = float(retry_interval_s)
        self.status_message = ""
        self.connected = False
        self._stop = threading.Event()
        self._thread: Optional[threading.Thread] = None
        self._state_changed = threading.Condition()

    def start(self) -> None:
        if self._thread is not None:
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, daemon=True, name=f"switch-{self.name}")
        self._thread.start()

    def stop(self) -> None:
        """End the thread (joined) and release the device."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None
        self._close()

    def wait_for(self, predicate: Callable[["SwitchSource"], bool], timeout: float = 5.0) -> bool:
        """Block until ``predicate(self)`` (a state change: connected, a message); for tests and UIs."""
        with self._state_changed:
            return self._state_changed.wait_for(lambda: predicate(self), timeout)

    def _set_state(self, connected: bool, message: str) -> None:
        with self._state_changed:
            self.connected, self.status_message = connected, message
            self._state_changed.notify_all()

    def _emit(self, pressed: bool) -> None:
        self.handler(self.name, bool(pressed))

    def _run(self) -> None:
        while not self._stop.is_set():
            if not self.connected and not self._open():
                if self._stop.wait(self.retry_interval_s):
                    break
                continue
            self._serve()

    # subclasses
    def _open(self) -> bool:  # pragma: no cover - abstract
        raise NotImplementedError

    def _serve(self) -> None:
        """While connected: wait for events (returns when stopped or disconnected)."""
        self._stop.wait(self.retry_interval_s)

    def _close(self) -> None:
        pass


class GamepadSwitch(SwitchSource):
    """A gamepad (or any evdev input device) button: ``gamepad:BTN_SOUTH``."""

    def __init__(self, name: str, handler: SwitchHandler, retry_interval_s: float = RETRY_INTERVAL_S):
        if not name.startswith("gamepad:") or not is_device_switch_name(name):
            raise ValueError(f"gamepad switch {name!r}: use gamepad:BTN_… (an evdev key name) or gamepad:CODE")
        super().__init__(name, handler, retry_interval_s)
        self.key = name[8:]
        self.device = None

    def _code(self, evdev) -> Optional[int]:
        if self.key.isdigit():
            return int(self.key)
        value = getattr(evdev.ecodes, self.key, None)
        if isinstance(value, (list, tuple)):
            value = value[0]
        return value if isinstance(value, int) else None

    def _open(self) -> bool:
        evdev = _import("evdev")
        if evdev is None:
            self._set_state(False, f"{self.name}: the evdev library is missing — pip install evdev (Linux)")
            return False
        code = self._code(evdev)
        if code is None:
            self._set_state(False, f"{self.name}: evdev knows no key {self.key!r} — use a name such as BTN_SOUTH, "
                                   f"BTN_EAST, BTN_TL (see `evtest`) or the key's number")
            return False
        try:
            paths = list(evdev.list_devices())
        except OSError as exc:
            paths, error = [], exc
        else:
            error = None
        for path in paths:
            try:
                device = evdev.InputDevice(path)
                keys = device.capabilities().get(evdev.ecodes.EV_KEY, [])
            except OSError:
                continue
            if code in keys:
                self.device, self.code = device, code
                self._set_state(True, "")
                return True
            device.close()
        why = f" ({error})" if error else ""
        self._set_state(False, f"{self.name}: no input device with {self.key} found{why} — is the gamepad plugged "
                               f"in? Your user must be in the `input` group (sudo usermod -aG input $USER, then "
                               f"log in again); retrying every {self.retry_interval_s:g} s")
        return False

    def _serve(self) -> None:
        evdev = _import("evdev")
        key_type = evdev.ecodes.EV_KEY
        while not self._stop.is_set():
            try:
                event = self.device.read_one()
            except OSError:
                self._close()
                self._set_state(False, f"{self.name}: the gamepad was unplugged — retrying every "
                                       f"{self.retry_interval_s:g} s")
                return
            if event is None:
                self._stop.wait(POLL_INTERVAL_S)
                continue
            if event.type == key_type and event.code == self.code and event.value in (0, 1):  # 2: auto-repeat
                self._emit(event.value == 1)

    def _close(self) -> None:
        device, self.device = self.device, None
        if device is not None:
            try:
                device.close()
            except OSError:
                pass


class GpioSwitch(SwitchSource):
    """A switch between a Raspberry Pi GPIO pin and ground: ``gpio:17`` (BCM numbering)."""

    def __init__(self, name: str, handler: SwitchHandler, retry_interval_s: float = RETRY_INTERVAL_S):
        if not name.startswith("gpio:") or not is_device_switch_name(name):
            raise ValueError(f"GPIO switch {name!r}: use gpio:PIN with a BCM pin number 0…27, e.g. gpio:17")
        super().__init__(name, handler, retry_interval_s)
        self.pin = int(name[5:])
        self.button = None

    def _open(self) -> bool:
        gpiozero = _import("gpiozero")
        if gpiozero is None:
            self._set_state(False, f"{self.name}: the gpiozero library is missing — pip install gpiozero "
                                   f"(on a Raspberry Pi)")
            return False
        try:
            button = gpiozero.Button(self.pin, pull_up=True, bounce_time=GPIO_BOUNCE_S)
        except Exception as exc:  # noqa: BLE001 — gpiozero raises its own errors (no pin factory, pin in use)
            self._set_state(False, f"{self.name}: GPIO pin {self.pin} did not open ({type(exc).__name__}: {exc}) "
                                   f"— on a Raspberry Pi your user must be in the `gpio` group (sudo usermod -aG "
                                   f"gpio $USER, then log in again); retrying every {self.retry_interval_s:g} s")
            return False
        button.when_pressed = lambda *_: self._emit(True)
        button.when_released = lambda *_: self._emit(False)
        self.button = button
        self._set_state(True, "")
        return True

    def _serve(self) -> None:
        self._stop.wait()  # gpiozero calls the handlers from its own thread

    def _close(self) -> None:
        button, self.button = self.button, None
        if button is not None:
            button.close()


def make_switch_source(name: str, handler: SwitchHandler, retry_interval_s: float = RETRY_INTERVAL_S) -> SwitchSource:
    """The source for a device switch name (gamepad:… or gpio:…); ValueError for others."""
    if name.startswith("gamepad:"):
        return GamepadSwitch(name, handler, retry_interval_s)
    if name.startswith("gpio:"):
        return GpioSwitch(name, handler, retry_interval_s)
    raise ValueError(f"{name!r} needs no switch source (keys and mouse buttons reach the window directly)")
