"""The assistive view's switches: keys, mouse buttons, gamepad buttons and GPIO pins as "next",
"confirm" or the single switch — a short press acts on release, a hold stops (or, begun while
stopped, re-arms), and a held key stays held through X11 auto-repeat.

``SwitchInput`` takes the window's key events (``key_press`` / ``key_release``) and any switch
by name (``down`` / ``up``: mouse buttons over the view, the ☰ button, the margins), runs one
source per gamepad / GPIO switch in the settings (``core.devices.switches``; their presses come
from their threads, queued to the GUI thread) and the timer that ends a pending key release's
wait. ``core.motion.switch_presses.SwitchPresses`` holds the press state; the window's callables
act on what a press, a release and a hold mean.
"""
from __future__ import annotations

from typing import Callable, Optional

from PySide6 import QtCore, QtGui

from app.assist.settings import device_switch_names, key_switch_name
from core.motion.switch_presses import KEY_REPEAT_GRACE_S, SwitchPresses


class SwitchInput(QtCore.QObject):
    """Switch presses by name, to the window's callables (see the module docstring).

    ``role(name)``: what switch ``name`` does in the current mode (None: not a switch now);
    ``long_press_s()``: the hold that stops; ``stopped()``: True while STOP is engaged;
    ``clock``: the time (s) the holds are measured on; ``on_press(role, now)`` and
    ``on_release(role, now, held_long)``: a switch went down / came up; ``on_hold("stop" |
    "rearm")``: a switch was held for ``long_press_s``.

    Signals: sigDeviceSwitch(str, bool) — a gamepad / GPIO switch (name, pressed), emitted from its
    source's thread, received queued in the GUI thread.
    """

    sigDeviceSwitch = QtCore.Signal(str, bool)

    def __init__(self, role: Callable[[str], Optional[str]], long_press_s: Callable[[], float],
                 stopped: Callable[[], bool], clock: Callable[[], float],
                 on_press: Callable[[str, float], None], on_release: Callable[[str, float, bool], None],
                 on_hold: Callable[[str], None], parent: Optional[QtCore.QObject] = None):
        super().__init__(parent)
        self.role = role
        self._long_press_s = long_press_s
        self._stopped = stopped
        self._clock = clock
        self._on_press = on_press
        self._on_release = on_release
        self._on_hold = on_hold
        self.presses = SwitchPresses()
        self.sources: dict = {}  # device switch name → core.devices.switches.SwitchSource (running)
        self.sigDeviceSwitch.connect(self._on_device_switch, QtCore.Qt.ConnectionType.QueuedConnection)
        self._release_timer = QtCore.QTimer(self)  # ends a pending key release's wait (wall time)
        self._release_timer.setSingleShot(True)
        self._release_timer.setInterval(int(KEY_REPEAT_GRACE_S * 1000))
        self._release_timer.timeout.connect(lambda: self._resolve_pending_release(None))

    @property
    def held(self):
        """The switch held now (``core.motion.switch_presses.HeldSwitch``) or None."""
        return self.presses.down

    def reset(self) -> None:
        """Forget the held switch and a pending release (the mode changed)."""
        self.presses.reset()

    # -- by name ----------------------------------------------------------------------------------

    def down(self, name: str) -> bool:
        """A switch went down (key or mouse button by name); True when it is mapped."""
        role = self.role(name)
        if role is None:
            return False
        now = self._clock()
        if self.presses.press(name, role, now, self._stopped()):
            self._on_press(role, now)
        return True

    def up(self, name: str, now: Optional[float] = None) -> bool:
        """The switch came up (``now``: when, on the clock; default now): a short press acts (next,
        confirm, select), a long one already did. True when it is mapped (or was the held one)."""
        held = self.presses.down
        if held is None or held.name != name:
            return self.role(name) is not None
        now = self._clock() if now is None else now
        self._check_hold(now)
        self.presses.release(name)
        self._on_release(held.role, now, held.fired)
        return True

    def tick(self, now: float) -> None:
        """A pending key release whose grace has passed acts; a switch held long enough stops."""
        self._resolve_pending_release(now)
        self._check_hold(now)

    def _check_hold(self, now: float) -> None:
        action = self.presses.hold(now, self._long_press_s())
        if action is not None:
            self._on_hold(action)

    # -- keys -------------------------------------------------------------------------------------

    def key_press(self, event: QtGui.QKeyEvent) -> bool:
        """A key went down; True when it was a switch's (the event is then the switch's)."""
        name = key_switch_name(event)
        if event.isAutoRepeat():
            return self.role(name) is not None
        if self.presses.pending is not None:
            if self.presses.is_repeat_press(name, event.timestamp()):
                self._release_timer.stop()  # the X server's auto-repeat, delivered unflagged: the key never came up
                return True
            self._resolve_pending_release(None)  # it was a real release: it acts before this press
        return self.down(name)

    def key_release(self, event: QtGui.QKeyEvent) -> bool:
        """A key switch's release acts at once — unless it may be half of an auto-repeat pair.

        With X11 auto-repeat a held key arrives as release/press pairs carrying one timestamp;
        Qt flags them ``isAutoRepeat()`` only when the press is already queued when it reads the
        release (measured under Xvfb with the window running: every pair came unflagged). So a
        release with a timestamp is kept for ``KEY_REPEAT_GRACE_S``: a press of the same key with
        the same timestamp cancels it (the hold goes on: no "next", no new press), anything else —
        the grace passing, another key — lets it act. A release without a timestamp (0: a
        synthetic event) cannot be told apart and acts at once."""
        if event.isAutoRepeat():
            return True
        name = key_switch_name(event)
        if self.presses.pending is not None:
            self._resolve_pending_release(None)
        if self.presses.keep_release(name, self._clock(), event.timestamp()):
            self._release_timer.start()
            return True
        return self.up(name)

    def _resolve_pending_release(self, now: Optional[float]) -> None:
        """A pending key release acts (``now`` None: at once; else once the grace has passed)."""
        pending = self.presses.due_release(now)
        if pending is None:
            return
        self._release_timer.stop()
        self.up(pending.name, pending.t)  # as long as the key was really held, not the wait

    # -- gamepad and GPIO switches ------------------------------------------------------------------

    def start_sources(self, settings) -> None:
        """One source per gamepad / GPIO switch in ``settings`` (others stopped); each press and
        release reaches ``down`` / ``up`` in the GUI thread, as a key's would."""
        from core.devices.switches import make_switch_source

        wanted = set(device_switch_names(settings))
        for name in [n for n in self.sources if n not in wanted]:
            self.sources.pop(name).stop()
        for name in sorted(wanted - set(self.sources)):
            source = make_switch_source(name, self.sigDeviceSwitch.emit)
            self.sources[name] = source
            source.start()

    def stop_sources(self) -> None:
        """Stop (and join) every gamepad / GPIO source."""
        for source in self.sources.values():
            source.stop()
        self.sources = {}

    def source_messages(self) -> list[str]:
        """What the gamepad / GPIO switches report (missing library, no device, …)."""
        return [s.status_message for s in self.sources.values() if s.status_message]

    def _on_device_switch(self, name: str, pressed: bool) -> None:
        if pressed:
            self.down(name)
        else:
            self.up(name)
