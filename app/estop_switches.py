"""A physical STOP and RE-ARM for the main window: a key, a gamepad or USB foot switch button
(evdev) or a Raspberry Pi GPIO pin (gpiozero) — ``deskarm --estop-switch NAME --rearm-switch NAME``.

``EStopSwitches`` wires the switches to the rules of ``core.motion.estop_switches`` (the STOP
press stops, every time; a STOP switch held down keeps the arm stopped; only a different RE-ARM
switch, pressed fresh after the stop and held ``REARM_HOLD_MS`` without a break, re-arms) and to
the window's ``on_stop_requested`` / ``on_rearm_requested``:

- ``key:NAME`` switches (Qt key names: key:F12, key:Pause, key:Escape) are taken by an
  application-wide event filter before any widget or shortcut sees them, in every window and
  dialog of the application. Key auto-repeat counts as held: events Qt flags as auto-repeat,
  and X11's release/press pairs with one timestamp that Qt left unflagged (a release therefore
  counts only ``AUTOREPEAT_GAP_MS`` later, at the time it came, and no re-arm happens meanwhile);
  a key that arrives only as auto-repeat was down before the window saw it.
  When the application loses the keyboard, a RE-ARM key counts as released (its release would
  go elsewhere); a STOP key stays down until it is seen to come up.
- gamepad and GPIO switches are read by ``core.devices.switches`` sources in threads of their
  own; each press and release reaches the GUI thread as a queued signal stamped with the time it
  happened. Each time a device (re)appears the source also says whether the switch is already
  down: a latched STOP stops, a RE-ARM switch found down never re-arms. A RE-ARM switch whose
  device went away counts as released.
- A timer (every ``HOLD_POLL_MS`` while a switch is down, else ``IDLE_POLL_MS``) checks
  the hold, notices stops and re-arms made by anything else (the arm's ``armed`` state) and
  refreshes the status: "STOP switch gpio:17: ready", "STOP switch gamepad:BTN_SOUTH: not found
  — plug it in (retrying)", … (``status_text()``, ``sigStatus``, ``make_status_label()``).

Signals (GUI thread):
    sigStatus(str): the status line changed (``status_text()``; "" when no switch is configured).
"""
from __future__ import annotations

import time
import weakref
from typing import Callable, Iterable, Optional

import shiboken6
from PySide6 import QtCore, QtGui, QtWidgets

from core.devices.switches import (RETRY_INTERVAL_S, GamepadSwitch, GpioSwitch, SwitchSource,
                                   is_device_switch_name)
from core.motion.estop_switches import REARM, STOP, EStopSwitchLogic
from widgets._style import ERROR_COLOUR, OK_COLOUR, WARN_COLOUR
from widgets.estop import REARM_HOLD_MS
from widgets.status import ElidedLabel

HOLD_POLL_MS = 20  # while a switch is down: how often the hold (and a re-arm made elsewhere) is checked
IDLE_POLL_MS = 250  # otherwise: how often the devices' states (plugged in, missing) are read
# X11 sends a held key's auto-repeat as a release and a press with the same timestamp, and Qt does not
# always flag them (seen under Xvfb with xdotool: none flagged, a pair every 40 ms after 660 ms): a key
# switch's release waits this long for such a press before it counts (at the time it came)
AUTOREPEAT_GAP_MS = 50

SWITCH_FORMS = ("gamepad:BTN_… (an evdev key name such as BTN_SOUTH, or its number), gpio:PIN (a Raspberry "
                "Pi BCM pin 0…27) or key:NAME (one key, no modifiers: key:F12, key:Pause, key:Escape)")


# -- names ------------------------------------------------------------------------------------------

def qt_key_of(name: str) -> Optional[int]:
    """The Qt key code of a ``key:NAME`` switch (one key without modifiers), else None."""
    if not name.startswith("key:") or len(name) <= 4:
        return None
    sequence = QtGui.QKeySequence.fromString(name[4:])
    if sequence.count() != 1:
        return None
    combo = sequence[0]
    if combo.keyboardModifiers() != QtCore.Qt.KeyboardModifier.NoModifier:
        return None
    key = int(combo.key())
    return None if key in (0, int(QtCore.Qt.Key.Key_unknown)) else key


def canonical_switch_name(name: str, option: str = "--estop-switch") -> str:
    """The one spelling of a switch name ("key:escape" → "key:Esc", "gpio:017" → "gpio:17");
    ValueError naming ``option``, the name and the accepted forms."""
    name = (name or "").strip()
    if name.startswith("gpio:") and is_device_switch_name(name):
        return f"gpio:{int(name[5:])}"
    if name.startswith("gamepad:") and is_device_switch_name(name):
        return name
    key = qt_key_of(name)
    if key is not None:
        return "key:" + QtGui.QKeySequence(key).toString()
    raise ValueError(f"{option} {name!r}: not a switch — use {SWITCH_FORMS}")


def check_estop_switch_names(stop_switches: Iterable[str],
                             rearm_switches: Iterable[str] = ()) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The STOP and RE-ARM switch names, canonical and without repeats; ValueError when one is not
    a switch or when a switch is in both roles (a held STOP must never be the way to re-arm)."""
    stop = tuple(dict.fromkeys(canonical_switch_name(n, "--estop-switch") for n in stop_switches))
    rearm = tuple(dict.fromkeys(canonical_switch_name(n, "--rearm-switch") for n in rearm_switches))
    both = [n for n in rearm if n in stop]
    if both:
        raise ValueError(f"--rearm-switch {both[0]}: it is also a STOP switch (--estop-switch) — re-arming "
                         f"must take a different key, button or pin, so a held or bouncing STOP never re-arms")
    return stop, rearm


# -- device sources that also say whether the switch is down when the device appears ---------------

class _GamepadEStopSwitch(GamepadSwitch):
    """A gamepad button that, each time its device (re)appears, also reports whether it is down
    (read in the source's own thread, so it comes before any later press or release)."""

    def __init__(self, name, handler, found: Callable[[str], None], retry_interval_s: float):
        super().__init__(name, handler, retry_interval_s)
        self._found = found

    def _open(self) -> bool:
        if not super()._open():
            return False
        try:
            down = self.code in self.device.active_keys()
        except (OSError, AttributeError, TypeError):
            down = False
        if down:
            self._found(self.name)
        else:
            self._emit(False)  # up now: a press held while it was unplugged has ended
        return True


class _GpioEStopSwitch(GpioSwitch):
    """A GPIO switch that also reports, when its pin opens, whether it is down already (a latched
    STOP). Only "down" is reported: gpiozero calls the edge handlers from a thread of its own,
    and a stale "up" could arrive after a real press."""

    def __init__(self, name, handler, found: Callable[[str], None], retry_interval_s: float):
        super().__init__(name, handler, retry_interval_s)
        self._found = found

    def _open(self) -> bool:
        if not super()._open():
            return False
        if bool(getattr(self.button, "is_pressed", False)):
            self._found(self.name)
        return True


def _make_source(name: str, handler, found, retry_interval_s: float) -> SwitchSource:
    cls = _GamepadEStopSwitch if name.startswith("gamepad:") else _GpioEStopSwitch
    return cls(name, handler, found, retry_interval_s)


class _KeySwitchFilter(QtCore.QObject):
    """The application-wide filter behind the key switches: a small object holding its owner
    weakly and passing on only key events (as app.gui.JogKeyFilter does, for the same reason)."""

    _KINDS = (QtCore.QEvent.Type.KeyPress, QtCore.QEvent.Type.KeyRelease, QtCore.QEvent.Type.ShortcutOverride)

    def __init__(self, owner: "EStopSwitches"):
        super().__init__()
        self._owner = weakref.ref(owner)

    def eventFilter(self, obj, event) -> bool:  # noqa: N802 (Qt override)
        kind = event.type()
        if kind not in self._KINDS:
            return False
        owner = self._owner()
        if owner is None or not shiboken6.isValid(owner):
            return False
        return owner.key_event(event, kind)


class EStopSwitchLabel(ElidedLabel):
    """The switches' status line in a status bar (``EStopSwitches.make_status_label``)."""

    def __init__(self, switches: "EStopSwitches"):
        super().__init__("")
        self._switches = weakref.ref(switches)
        self.setContentsMargins(6, 0, 6, 0)
        self.setMinimumHeight(24)
        self.show_status(switches.status_text())

    @QtCore.Slot(str)
    def show_status(self, text: str) -> None:
        """Show ``text`` in the colour of the switches' level, their devices' messages as tooltip."""
        switches = self._switches()
        level = switches.status_level() if switches is not None else "ok"
        details = switches.status_details() if switches is not None else ""
        colour = {"ok": OK_COLOUR, "warn": WARN_COLOUR, "error": ERROR_COLOUR}[level]
        self.setText(text)
        self.setStyleSheet(f"QLabel {{ color: {colour}; font-weight: bold; }}")
        self.setToolTip("\n".join(filter(None, (text.replace(" · ", "\n"), details))))
        self.setVisible(bool(text))


# -- the controller ---------------------------------------------------------------------------------

class EStopSwitches(QtCore.QObject):
    """The physical STOP / RE-ARM switches of a window (see the module docstring).

    Args:
        parent: the window (owns this object).
        stop_switches, rearm_switches: switch names (``check_estop_switch_names``).
        stop: called (GUI thread) to stop the arm; ``rearm``: to re-arm it.
        armed: the arm's state now (e.g. ``lambda: session.controller.armed``); None: this object
            knows only the stops and re-arms it made itself and those told by ``note_stop()``.
        clock: monotonic seconds (a test passes its own); also read in the device threads.
        hold_ms: the RE-ARM hold (the on-screen RE-ARM's, ``REARM_HOLD_MS``).
        retry_interval_s: how often a missing device is looked for again.

    ``start()`` installs the key filter and starts the device threads; ``stop()`` removes the
    filter and stops and joins the threads.
    """

    sigStatus = QtCore.Signal(str)
    _sigDevice = QtCore.Signal(str, str, float)  # (name, "press" | "release" | "found", t), device threads

    def __init__(self, parent: Optional[QtCore.QObject], stop_switches: Iterable[str] = (),
                 rearm_switches: Iterable[str] = (), *, stop: Callable[[], None], rearm: Callable[[], None],
                 armed: Optional[Callable[[], bool]] = None, clock: Callable[[], float] = time.monotonic,
                 hold_ms: int = REARM_HOLD_MS, retry_interval_s: float = RETRY_INTERVAL_S):
        super().__init__(parent)
        stop_names, rearm_names = check_estop_switch_names(stop_switches, rearm_switches)
        self._stop, self._rearm, self._armed = stop, rearm, armed
        self._clock = clock
        self._retry_interval_s = float(retry_interval_s)
        self.logic = EStopSwitchLogic(stop_names, rearm_names, hold_ms / 1000.0,
                                      armed=True if armed is None else bool(armed()))
        if not self.logic.armed:
            self.logic.stopped(clock())  # stopped before we were made: a held RE-ARM switch is not fresh
        self._keys = {qt_key_of(n): n for n in stop_names + rearm_names if n.startswith("key:")}
        self.sources: dict[str, SwitchSource] = {}  # device switch name → its source (while started)
        self._filter: Optional[_KeySwitchFilter] = None
        self._running = False
        self._status = ""
        self._details = ""
        self._level = "ok"
        self.poll_timer = QtCore.QTimer(self)  # the hold and the devices (HOLD_POLL_MS / IDLE_POLL_MS)
        self.poll_timer.timeout.connect(self.tick)
        # a key switch's release that may be the first half of an X11 auto-repeat pair → (timestamp, t)
        self._pending_release: dict[str, tuple[int, float]] = {}
        self._release_timer = QtCore.QTimer(self)
        self._release_timer.setSingleShot(True)
        self._release_timer.setInterval(AUTOREPEAT_GAP_MS)
        self._release_timer.timeout.connect(self._apply_pending_releases)
        self._sigDevice.connect(self._on_device, QtCore.Qt.ConnectionType.QueuedConnection)

    @classmethod
    def for_window(cls, window, clock: Callable[[], float] = time.monotonic) -> "EStopSwitches":
        """The switches of ``window.session.options`` (``--estop-switch`` / ``--rearm-switch``)
        wired to the window's STOP, RE-ARM and its arm's state (the window held weakly)."""
        options = window.session.options
        ref = weakref.ref(window)

        def stop() -> None:
            w = ref()
            if w is not None:
                w.on_stop_requested()

        def rearm() -> None:
            w = ref()
            if w is not None:
                w.on_rearm_requested()

        def armed() -> bool:
            w = ref()
            return True if w is None else bool(w.session.controller.armed)

        return cls(window, options.estop_switches, options.rearm_switches, stop=stop, rearm=rearm, armed=armed,
                   clock=clock)

    # -- lifecycle -------------------------------------------------------------------------------
    @property
    def enabled(self) -> bool:
        """Whether any switch is configured (else start() does nothing and the status is "")."""
        return bool(self.logic.stop_switches or self.logic.rearm_switches)

    @property
    def running(self) -> bool:
        return self._running

    def start(self) -> None:
        """Take the key switches (ahead of every other application filter: call it after the
        window installed its own) and start a thread per gamepad / GPIO switch."""
        if self._running or not self.enabled:
            return
        self._running = True
        app = QtWidgets.QApplication.instance()
        if self._keys and app is not None:
            self._filter = _KeySwitchFilter(self)
            app.installEventFilter(self._filter)  # the last installed filter sees events first
            app.applicationStateChanged.connect(self._on_application_state)
        for name in self.logic.stop_switches + self.logic.rearm_switches:
            if is_device_switch_name(name):
                source = _make_source(name, self._device_switch, self._device_found, self._retry_interval_s)
                self.sources[name] = source
                source.start()
        self.poll_timer.start(IDLE_POLL_MS)
        self.tick()

    def stop(self) -> None:
        """Remove the key filter; stop and join the device threads."""
        self.poll_timer.stop()
        app = QtWidgets.QApplication.instance()
        if self._filter is not None and app is not None:
            app.removeEventFilter(self._filter)
            try:
                app.applicationStateChanged.disconnect(self._on_application_state)
            except (RuntimeError, TypeError):
                pass
        self._filter = None
        self._release_timer.stop()
        self._pending_release = {}
        for source in self.sources.values():
            source.stop()
        self.sources = {}
        self._running = False

    # -- what the window asks ---------------------------------------------------------------------
    def rearm_blocked(self) -> str:
        """Why the arm must not be re-armed now ("" when it may): a STOP switch is down."""
        down = self.logic.stop_switches_down()
        return f"STOP switch {down[0]} is down — release it to re-arm" if down else ""

    @QtCore.Slot()
    def note_stop(self) -> None:
        """The arm was stopped by something else (the STOP button, Esc): a RE-ARM hold under way
        ends, and only a press that begins after this re-arms."""
        self.logic.stopped(self._clock())
        self._update_status(self._clock())

    def status_text(self) -> str:
        """One line per switch, joined with " · " ("" when no switch is configured)."""
        return self._status

    def status_details(self) -> str:
        """The devices' own messages (what is missing and how to fix it), one per line."""
        return self._details

    def status_level(self) -> str:
        """"ok", "warn" (a switch is held) or "error" (a device is missing)."""
        return self._level

    def make_status_label(self) -> "EStopSwitchLabel":
        """A status-bar label that follows ``sigStatus``: green ready, orange held, red missing
        (the devices' messages in its tooltip); hidden when no switch is configured."""
        label = EStopSwitchLabel(self)
        self.sigStatus.connect(label.show_status)
        return label

    # -- inputs ------------------------------------------------------------------------------------
    def key_event(self, event: QtGui.QKeyEvent, kind) -> bool:
        """A key event seen by the filter: True (taken) when the key is a switch."""
        name = self._keys.get(event.key())
        if name is None:
            return False
        event.accept()
        if kind == QtCore.QEvent.Type.ShortcutOverride:
            return True  # accepted: no shortcut fires on a switch key (Esc's STOP included), it comes as a KeyPress
        t = self._clock()
        self._sync_armed(t)
        pending = self._pending_release.pop(name, None)
        if kind == QtCore.QEvent.Type.KeyRelease:
            if pending is not None:
                self._act(self.logic.feed(name, False, pending[1]), t)
            if not event.isAutoRepeat():  # auto-repeat's releases are the key still held
                # X11 may not flag its auto-repeat: the press that follows carries this timestamp
                self._pending_release[name] = (event.timestamp(), t)
                self._release_timer.start()
        elif event.isAutoRepeat() or (pending is not None and pending[0] == event.timestamp()):
            if not self.logic.is_down(name):  # down before the window saw it
                self._act(self.logic.found_down(name, t), t)
        else:
            if pending is not None:  # released (a bounce), then pressed again
                self._act(self.logic.feed(name, False, pending[1]), t)
            self._act(self.logic.feed(name, True, t), t)
        self._after_input(t)
        return True

    @QtCore.Slot()
    def _apply_pending_releases(self) -> None:
        """The key releases no auto-repeat press followed: real releases, at the time they came."""
        pending, self._pending_release = self._pending_release, {}
        t = self._clock()
        for name, (_, released_at) in pending.items():
            self._act(self.logic.feed(name, False, released_at), t)
        self._after_input(t)

    def _device_switch(self, name: str, pressed: bool) -> None:  # a device thread
        self._sigDevice.emit(name, "press" if pressed else "release", self._clock())

    def _device_found(self, name: str) -> None:  # a device thread
        self._sigDevice.emit(name, "found", self._clock())

    @QtCore.Slot(str, str, float)
    def _on_device(self, name: str, kind: str, t: float) -> None:
        if not self._running:
            return
        self._sync_armed(self._clock())
        if kind == "found":
            action = self.logic.found_down(name, t)
        else:
            action = self.logic.feed(name, kind == "press", t)
        self._act(action, self._clock())
        self._after_input(self._clock())

    @QtCore.Slot(QtCore.Qt.ApplicationState)
    def _on_application_state(self, state) -> None:
        if state == QtCore.Qt.ApplicationState.ApplicationActive:
            return
        self._apply_pending_releases()
        t = self._clock()
        for name in self.logic.rearm_switches:  # its release would go to another application
            if name.startswith("key:") and self.logic.is_down(name):
                self.logic.feed(name, False, t)
        self._update_status(t)

    # -- the timer ---------------------------------------------------------------------------------
    @QtCore.Slot()
    def tick(self) -> None:
        """Check the RE-ARM hold and the devices; refresh the status."""
        t = self._clock()
        self._sync_armed(t)
        for name, source in self.sources.items():
            if not source.connected and name in self.logic.rearm_switches and self.logic.is_down(name):
                self.logic.feed(name, False, t)  # its device went away: nobody is holding it
        if not self._pending_release:  # a key released just now may have ended the hold: wait for it
            self._act(self.logic.poll(t), t)
        self._after_input(t)

    def _after_input(self, t: float) -> None:
        # a RE-ARM hold under way, or a STOP switch down (a re-arm from the screen is undone at once)
        down = any(self.logic.is_down(n) for n in self.logic.stop_switches + self.logic.rearm_switches)
        interval = HOLD_POLL_MS if down else IDLE_POLL_MS
        if self._running and (self.poll_timer.interval() != interval or not self.poll_timer.isActive()):
            self.poll_timer.start(interval)
        self._update_status(t)

    def _sync_armed(self, t: float) -> None:
        """Follow stops and re-arms made by anything else; a latched STOP stops a re-arm at once."""
        if self._armed is None:
            return
        armed = bool(self._armed())
        if armed == self.logic.armed:
            return
        if armed:
            self._act(self.logic.rearmed(t), t)
        else:
            self.logic.stopped(t)

    def _act(self, action: Optional[str], t: float) -> None:
        if action == STOP:
            self._stop()
        elif action == REARM:
            self._rearm()
            if self._armed is not None and not self._armed():  # the window did not re-arm
                self.logic.stopped(t)

    # -- the status ----------------------------------------------------------------------------------
    def _update_status(self, t: float) -> None:
        parts, details, levels = [], [], []
        for name in self.logic.stop_switches + self.logic.rearm_switches:
            text, level, detail = self._switch_status(name, t)
            parts.append(text)
            levels.append(level)
            if detail:
                details.append(detail)
        shown = (" · ".join(parts), "\n".join(details),
                 "error" if "error" in levels else "warn" if "warn" in levels else "ok")
        if shown != (self._status, self._details, self._level):  # the label's colour and tooltip too
            self._status, self._details, self._level = shown
            self.sigStatus.emit(self._status)

    def _switch_status(self, name: str, t: float) -> tuple[str, str, str]:
        """(text, level, the device's own message) for one switch."""
        is_stop = name in self.logic.stop_switches
        head = f"{'STOP' if is_stop else 'RE-ARM'} switch {name}"
        hold_s = self.logic.hold_s
        source = self.sources.get(name)
        if source is not None and not source.connected:
            message = source.status_message
            if not message:
                state, level = "opening…", "warn"
            elif "library is missing" in message:
                fix = message.split("—", 1)[-1].strip()
                state, level = f"its library is missing — {fix}", "error"
            elif "did not open" in message:
                state, level = "the pin did not open (retrying)", "error"
            else:
                state, level = "not found — plug it in (retrying)", "error"
            if is_stop and self.logic.is_down(name):
                state += "; it was down when it went away, so the arm stays stopped"
            return f"{head}: {state}", level, message
        if not self._running and is_device_switch_name(name):
            return f"{head}: off", "warn", ""
        if is_stop:
            if self.logic.is_down(name):
                return f"{head}: held down — the arm stays stopped until it is released", "warn", ""
            return f"{head}: ready", "ok", ""
        hold = self.logic.hold(name, t)
        if hold is None or hold.why_not == "armed":
            return f"{head}: ready", "ok", ""
        if hold.fresh:
            return f"{head}: re-arming — keep holding ({min(hold.held_s, hold_s):.1f} of {hold_s:g} s)", "warn", ""
        if hold.why_not == "stop_down":
            return f"{head}: a STOP switch is down — release it first", "warn", ""
        return (f"{head}: held since before the stop — release it, then press and hold {hold_s:g} s",
                "warn", "")


__all__ = ["AUTOREPEAT_GAP_MS", "EStopSwitchLabel", "EStopSwitches", "HOLD_POLL_MS", "IDLE_POLL_MS",
           "canonical_switch_name", "check_estop_switch_names", "qt_key_of"]
