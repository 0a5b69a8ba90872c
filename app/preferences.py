"""The main window's side of the remembered settings (``core.preferences`` holds the data and
the file): read them from the widgets, apply them to the widgets and the core objects.

``WindowPreferences(window)`` loads the file at once (``messages`` lists its problems for the
banner). ``restore()`` applies the saved values the way a user would: through the panels'
setters and the window's own slots (``on_mode_changed``, ``on_lissajous``, ...), so the targeter
and the workers follow. It never connects to a serial port: the bridge picker only shows the
saved port, protocol and recent ports; the session keeps the bridge the command line chose.
A saved window geometry is applied only when it fits on a screen's free area. The saved target
mode comes back only on a plain start (no scenario, replay, ``--teleop`` or ``--follow-object``:
those choose their own mode) and only when it can run there; else one plain line says why.

After a change (mode, Lissajous, follow id, camera settings, bridge choice, 3D twin, a camera
control) ``save()`` runs once a second at most (``SAVE_DELAY_MS``); the window also calls it
when it closes. A real camera's saved controls are requested again each time the camera lists
its controls (first frame, replug, refresh).
"""
from __future__ import annotations

import weakref
from pathlib import Path
from typing import Any

from PySide6 import QtCore, QtGui

from core.devices.bridge import split_bridge_url
from core.messages import TargetMode
from core.preferences import (
    Preferences,
    WindowGeometry,
    preferences_path,
    read_preferences,
    remembered_mode_refusal,
    reset_preferences,
    save_preferences,
    with_recent_port,
)
from core.settings import SettingsError, replace_field
from widgets._style import Coalescer
from widgets.bridge_picker import same_bridge
from widgets.target_panel import MODE_LABELS

SAVE_DELAY_MS = 1000  # a burst of changes (a dragged slider) is written once, a second later


def mode_label(mode: TargetMode | str) -> str:
    """The target mode as its button reads ("Follow marker")."""
    return dict(MODE_LABELS).get(TargetMode(mode), str(getattr(mode, "value", mode)))


class WindowPreferences(QtCore.QObject):
    """Remembers a MainWindow's settings between runs (see the module docstring).

    Attributes:
        path: the preferences file (``core.preferences.preferences_path()`` by default).
        prefs: the Preferences as last loaded, restored, collected or saved.
        messages: problems found so far (load, save, reset) and a remembered mode that could not
            come back (why, in plain words), oldest first, for the banner.
        geometry_restored: True when ``restore()`` placed the window (or maximised it): the
            caller then skips its own default size and position.
        read_only: False by default; True keeps ``save()`` from writing the file (a screenshot
            run renders the window at a size the user never chose).

    Signals (GUI thread):
        sigMessage(str): a problem found after construction (a save or a reset that failed);
            the same message is not sent twice in a row.
    """

    sigMessage = QtCore.Signal(str)

    def __init__(self, window, path: Path | str | None = None) -> None:
        super().__init__(window)
        # weak: a strong reference back to its parent window would make a reference cycle, and a
        # window freed by Python's cycle collector after Qt deleted it crashes later, in a paint
        # (seen as segfaults in QPainter::restore in the next test's window)
        self._window = weakref.ref(window)
        self.path = Path(path) if path else preferences_path()
        self._file_existed = self.path.is_file()
        loaded = read_preferences(self.path)  # an unreadable file is moved aside, never saved over
        self.prefs, self.messages = loaded.prefs, loaded.messages
        # unreadable and it could not be moved aside: saving would destroy the user's file
        self._keep_unreadable_file = loaded.do_not_overwrite
        self.geometry_restored = False
        self.read_only = False  # True: save() writes nothing (``deskarm --screenshot`` leaves the file alone)
        self._applying = False  # restore/reset at work: their own signals are not user changes
        self._asked_bridge: str | None = None  # a bridge URL requested and not yet connected
        # the mode a scenario, replay, --teleop or --follow-object started in: while it is on, the
        # saved mode is kept (a cups run must not make the next plain start a cups game)
        self._command_line_mode: TargetMode | None = None
        self._saver = Coalescer(SAVE_DELAY_MS, self.save, self)
        self._connect_signals()

    @property
    def window(self):
        """The MainWindow whose settings these are."""
        return self._window()

    # ------------------------------------------------------------------ public API
    def restore(self, geometry: bool = True) -> None:
        """Apply the loaded preferences to the widgets and, through the window's slots, to the
        targeter and the workers; ``geometry`` also places the window (if it fits a screen)."""
        self._apply(self.prefs, geometry)

    @QtCore.Slot()
    def save(self) -> bool:
        """Collect the settings from the widgets and write the file now (nothing is written while
        ``read_only``). False (and a message) when it cannot be written; the app carries on either way."""
        self._saver.cancel()
        self.prefs = self.collect()
        if self.read_only:
            return True
        if self._keep_unreadable_file:
            self._problem(f"{self.path}: not saved — the file could not be read at start and is kept as it "
                          "is; move it away (or use Reset to defaults) to save the settings again")
            return False
        try:
            save_preferences(self.prefs, self.path)
        except OSError as exc:
            self._problem(str(exc))
            return False
        return True

    @QtCore.Slot()
    def reset(self) -> bool:
        """Reset to defaults: the file is moved aside (``preferences.toml.bak``) and the widgets,
        the targeter and the simulated camera get the default values. The window keeps its place
        and the bridge its connection; a real camera keeps its current control values (nothing
        saved is requested again). False (and a message) when the file cannot be moved."""
        self._saver.cancel()
        try:
            reset_preferences(self.path)
        except OSError as exc:
            self._problem(str(exc))
            return False
        self._keep_unreadable_file = False  # the file was moved aside: saving may start again
        self.prefs = Preferences()
        self._file_existed = True  # the defaults are what the user asked for: the mode too
        self._apply(self.prefs, geometry=False)
        return True

    def schedule_save(self) -> None:
        """Save in SAVE_DELAY_MS (a change happened); bursts are written once."""
        if not self._applying:
            self._saver.poke()

    def collect(self) -> Preferences:
        """The Preferences the widgets show now (what ``save()`` writes). Values the widgets do
        not have here (a disabled 3D button, no simulated camera, a hidden window) keep their
        loaded value, and so does the target mode while it is the one the command line chose."""
        w, p = self.window, self.prefs
        tp, picker = w.target_panel, w.bridge_picker
        mode = TargetMode(tp.mode)
        if mode is self._command_line_mode:
            mode = p.target_mode
        changes: dict[str, Any] = {
            "target_mode": mode,
            "lissajous": tp.lissajous(),
            "bridge_protocol": picker.protocol(),
            "bridge_port": picker.port(),
        }
        if tp.follow_id is not None:
            changes["follow_id"] = tp.follow_id
        if w.view_3d_button.isEnabled():
            changes["view_3d"] = w.view_3d_button.isChecked()
        if w.camera_panel is not None:
            changes["sim_camera"] = w.camera_panel.settings()
        geometry = self._window_geometry()
        if geometry is not None:
            changes["window"] = geometry
        for name, value in changes.items():  # one by one: an odd value costs only itself
            try:
                p = replace_field(p, **{name: value})
            except SettingsError:
                pass
        return p

    # ------------------------------------------------------------------ applying
    def _saved_mode_applies(self, mode: TargetMode) -> bool:
        """The saved target mode comes back only from a saved file and only on a plain start
        (``core.preferences.remembered_mode_refusal``: a scenario, a replay, ``--teleop`` or
        ``--follow-object`` choose their own mode). With no file the session's default mode
        (Follow marker on the simulated desk) stays. A mode that cannot run here stays off and
        ``messages`` gets one line saying why (the window shows it once, as a note)."""
        if not self._file_existed:
            return False
        session = self.window.session
        options = session.options
        why = remembered_mode_refusal(mode, scenario=getattr(options, "scenario", "static"),
                                      camera_kind=getattr(session.camera, "kind", ""),
                                      teleop_source=getattr(options, "teleop_source", None),
                                      follow_object=getattr(options, "follow_object", None))
        if why is None:
            return True
        if not why:  # the command line's mode: not the user's preference unless they change it
            self._command_line_mode = session.targeter.mode
        else:
            line = f"Started in {mode_label(session.targeter.mode)}: {why}"
            if line not in self.messages:
                self.messages.append(line)
        return False

    def _apply(self, prefs: Preferences, geometry: bool) -> None:
        w = self.window
        was, self._applying = self._applying, True
        try:
            tp = w.target_panel
            # the curve as the spin boxes show it (their decimals) is what the targeter gets
            tp.set_lissajous(prefs.lissajous)
            w.on_lissajous(tp.lissajous())
            if prefs.follow_id is not None:
                tp.set_follow_id(prefs.follow_id)  # emits (-> on_follow_id) only when it changed
                w.on_follow_id(prefs.follow_id)
            if self._saved_mode_applies(prefs.target_mode):
                tp.set_mode(prefs.target_mode.value)
                w.on_mode_changed(prefs.target_mode.value)
            picker = w.bridge_picker
            picker.set_recent_ports(prefs.recent_ports)
            picker.set_protocol(prefs.bridge_protocol)
            picker.set_port(prefs.bridge_port)
            if w.camera_panel is not None:
                w.camera_panel.set_settings(prefs.sim_camera)
                w.on_camera_settings(prefs.sim_camera)
            if w.view_3d_button.isEnabled():
                w.view_3d_button.setChecked(prefs.view_3d)  # toggled -> on_view_3d, as a tap would
            if w.device_panel is not None and w.device_panel.rows:
                self._request_saved_controls()
            if geometry:
                self.geometry_restored = self._apply_geometry(prefs.window)
        finally:
            self._applying = was

    def _apply_geometry(self, g: WindowGeometry | None) -> bool:
        """Place the window as saved; a rectangle that is on no screen's free area is ignored
        (a monitor unplugged since), maximised and full screen still apply. True if anything was."""
        if g is None:
            return False
        w = self.window
        rect = QtCore.QRect(g.x, g.y, g.width, g.height)
        fits = any(screen.availableGeometry().contains(rect) for screen in QtGui.QGuiApplication.screens())
        if fits:
            w.setGeometry(rect)
        states = QtCore.Qt.WindowState
        state = w.windowState() & ~(states.WindowMaximized | states.WindowFullScreen)
        if g.fullscreen:
            state |= states.WindowFullScreen
        elif g.maximised:
            state |= states.WindowMaximized
        w.setWindowState(state)  # a hidden window shows in this state
        action = getattr(w, "fullscreen_action", None)
        if action is not None:
            action.setChecked(g.fullscreen)
        return fits or g.fullscreen or g.maximised

    def _window_geometry(self) -> WindowGeometry | None:
        w = self.window
        if not w.isVisible():
            return None
        maximised, fullscreen = w.isMaximized(), w.isFullScreen()
        r = w.normalGeometry()  # the size to come back to, also while maximised or full screen
        if not r.isValid():  # maximised or full screen before it was ever shown: Qt has no normal size
            saved = self.prefs.window
            return None if saved is None else replace_field(saved, maximised=maximised, fullscreen=fullscreen)
        try:
            return WindowGeometry(r.x(), r.y(), r.width(), r.height(), maximised, fullscreen)
        except SettingsError:  # a window squeezed below 100 px: not worth remembering
            return None

    def _request_saved_controls(self) -> None:
        """Ask the camera for this pair's saved controls, as the panel's user would."""
        pair = self.window.session.camera.pair_id
        values = self.prefs.camera_controls.get(pair, {})
        auto = self.prefs.camera_auto.get(pair, {})
        if not (values or auto):
            return
        was, self._applying = self._applying, True
        try:
            self.window.device_panel.request_values(values, auto)  # -> the window's on_control_requested
        finally:
            self._applying = was

    # ------------------------------------------------------------------ signals
    def _connect_signals(self) -> None:
        w = self.window
        tp = w.target_panel
        for signal in (tp.sigModeChanged, tp.sigLissajousChanged, tp.sigFollowIdChanged):
            signal.connect(self._on_changed)
        if w.camera_panel is not None:
            w.camera_panel.sigSettingsChanged.connect(self._on_changed)
        if w.device_panel is not None:
            w.device_panel.sigControlRequested.connect(self._on_control_requested)
            w.device_panel.sigAutoRequested.connect(self._on_auto_requested)
            w.device_panel.sigControlsRebuilt.connect(self._request_saved_controls)
        w.view_3d_button.toggled.connect(self._on_changed)
        w.bridge_picker.sigConnectRequested.connect(self._on_connect_requested)
        w.bridge_picker.protocol_combo.currentIndexChanged.connect(self._on_changed)
        # a worker-thread signal: a slot method of this GUI-thread object runs in the GUI thread
        w.workers.bridge.sigStatus.connect(self._on_bridge_status)

    def _on_changed(self, *_args) -> None:
        self.schedule_save()

    @QtCore.Slot(str)
    def _on_connect_requested(self, url: str) -> None:
        self._asked_bridge = url
        self.schedule_save()

    @QtCore.Slot(object)
    def _on_bridge_status(self, status) -> None:
        """The requested bridge connected: its port goes first in the recent list."""
        asked = self._asked_bridge
        if asked is None or not status.connected or not same_bridge(asked, status.url):
            return
        self._asked_bridge = None
        try:
            protocol, port = split_bridge_url(asked)
        except ValueError:
            return
        if protocol == "sim":
            return
        self.prefs = with_recent_port(self.prefs, port)
        self.window.bridge_picker.set_recent_ports(self.prefs.recent_ports)
        self.schedule_save()

    @QtCore.Slot(str, float)
    def _on_control_requested(self, name: str, value: float) -> None:
        if self._applying:
            return
        self._remember("camera_controls", name, float(value))

    @QtCore.Slot(str, bool)
    def _on_auto_requested(self, name: str, on: bool) -> None:
        if self._applying:
            return
        self._remember("camera_auto", name, bool(on))

    def _remember(self, field_name: str, name: str, value) -> None:
        pair = self.window.session.camera.pair_id
        per_pair = {p: dict(v) for p, v in getattr(self.prefs, field_name).items()}
        per_pair.setdefault(pair, {})[name] = value
        try:
            self.prefs = replace_field(self.prefs, **{field_name: per_pair})
        except SettingsError:  # a non-finite value never reaches the file
            return
        self.schedule_save()

    def _problem(self, message: str) -> None:
        if self.messages and self.messages[-1] == message:
            return
        self.messages.append(message)
        self.sigMessage.emit(message)


__all__ = ["SAVE_DELAY_MS", "WindowPreferences"]
