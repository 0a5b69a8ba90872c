"""The jog feature (issue 13): the Jog tab's ± buttons and the jog keys, anywhere in the window.

``JogFeature`` owns the ``JogPanel`` (its ``page``), a ``core.motion.jog.Jogger`` (``jogger``:
the stepping, holding and clipping) and a 50 Hz timer that moves the target while something is
held. A Cartesian jog moves the MANUAL target; a joint jog gives the controller a joint goal and
the manual target follows the tool. When the keyboard is TELEOP's hand source the keys move
its target instead. The keys come through an application-wide event filter (``JogKeyFilter``)
installed by ``install``; nothing jogs while the arm is stopped.

Signals (GUI thread): ``sigNote(str)`` — a message for the banner; ``sigChanged()`` — the
target moved (something drawn changed).
"""
from __future__ import annotations

import time
import weakref
from dataclasses import replace
from typing import Callable, Optional

import shiboken6
from PySide6 import QtCore, QtGui, QtWidgets

from core.messages import TargetMode
from core.motion.jog import JogSpace, Jogger
from widgets.jog_panel import JogPanel, is_text_field, jog_key_action
from widgets.pose_panel import pose_target_from_matrix

JOG_TICK_MS = 20  # a held jog key or button moves the target at 50 Hz (the control rate)


class JogKeyFilter(QtCore.QObject):
    """The application-wide event filter behind the jog keys: a small object of its own (not the
    window), holding the jog feature weakly and passing on only key and deactivation events. The
    window itself as the filter made every event of the application a Python call on it, and one
    arriving while the window was being destroyed ("pure virtual method called") aborted Python."""

    _KINDS = (QtCore.QEvent.Type.KeyPress, QtCore.QEvent.Type.KeyRelease, QtCore.QEvent.Type.WindowDeactivate)

    def __init__(self, jog: "JogFeature"):
        super().__init__()
        self._jog = weakref.ref(jog)

    def eventFilter(self, obj, event) -> bool:  # noqa: N802 (Qt override)
        kind = event.type()
        if kind not in self._KINDS:
            return False
        jog = self._jog()
        if jog is None or not shiboken6.isValid(jog) or not shiboken6.isValid(obj):
            return False
        window = jog.window
        if window is None or not shiboken6.isValid(window):
            return False
        return jog.jog_event(obj, event, kind)


class JogFeature(QtCore.QObject):
    """Jogging ``session``'s arm.

    ``target``: the window's target controls — ``set_mode(mode)`` (panel and targeter),
    ``set_manual_target(base_p)`` (targeter, Pose tab), ``show_manual_target(base_p)`` (Target
    tab) and ``set_pose(pose)`` (6-DOF arms: the Pose tab's pose as the manual target, or None);
    ``user_input()``: step the control at once; ``state()``: the newest JointState (or None);
    ``teleop_keys()``: the keyboard teleop source while it is TELEOP's (or None); ``pose_panel``:
    the Pose tab of a 6-DOF arm (None otherwise)."""

    sigNote = QtCore.Signal(str)
    sigChanged = QtCore.Signal()

    def __init__(self, session, target, user_input: Callable[[], None], state: Callable[[], object],
                 teleop_keys: Callable[[], object], pose_panel=None,
                 window: Optional[QtWidgets.QWidget] = None):
        super().__init__(window)
        s = self.session = session
        self.target = target
        self._user_input = user_input
        self._state = state
        self._teleop_keys = teleop_keys
        self.pose_panel = pose_panel
        self.window = window  # the keys jog while the focus is in this window
        self.jogger = Jogger(s.profile, s.kinematics, desk_margin_m=s.controller.workspace.desk_margin_m)
        self.key_filter = JogKeyFilter(self)
        self.page = self.jog_panel = JogPanel()
        self.jog_panel.set_joints(s.profile.joint_names)
        prm = self.jogger.params
        self.jog_panel.set_step_labels([f"{v * 1e3:g} mm" for v in prm.cartesian_steps_m],
                                       [f"{v:g}°" for v in prm.joint_steps_deg])
        self.jog_panel.set_step_index(self.jogger.step_index)
        self.jog_panel.sigPressed.connect(self.press)
        self.jog_panel.sigReleased.connect(self.release)
        self.jog_panel.sigSpaceChanged.connect(self.set_space)
        self.jog_panel.sigStepChanged.connect(self.set_step)
        self.timer = QtCore.QTimer(self)
        self.timer.setInterval(JOG_TICK_MS)
        self.timer.timeout.connect(self.tick)
        self._keys: dict[int, int] = {}  # a held jog key → its channel (released by the same key)
        self._note = ""
        self.show()

    def page_with_pose(self) -> QtWidgets.QWidget:
        """The Pose tab's page for 6-DOF arms: the pose controls, then jogging."""
        page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(page)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.pose_panel)
        layout.addWidget(QtWidgets.QLabel("<b>Jog</b>"))
        layout.addWidget(self.jog_panel)
        return page

    def install(self) -> None:
        """Jog keys wherever the focus is in the window (an application-wide event filter)."""
        app = QtWidgets.QApplication.instance()
        if app is not None:
            app.installEventFilter(self.key_filter)

    def uninstall(self) -> None:
        app = QtWidgets.QApplication.instance()
        if app is not None:
            app.removeEventFilter(self.key_filter)

    @QtCore.Slot(str)
    def set_space(self, space: str) -> None:
        """Cartesian or joint jogging (J, or the tab's switch). Back in x/y/z after a joint jog the
        Cartesian target continues from where the joints put the tool."""
        c = self.session.controller
        self.jogger.set_space(space)
        self._keys.clear()
        self.timer.stop()
        self.jog_panel.set_space(self.jogger.space.value)
        if self.jogger.space is JogSpace.CARTESIAN and c.joint_jog is not None:
            q = c.joint_jog
            c.set_joint_jog(None)
            if self.pose_panel is not None:  # 6-DOF: keep the orientation the joints gave the tool too
                pose = pose_target_from_matrix(self.session.kinematics.fk_pose(q))
                pose = replace(pose, grip_m=self.session.targeter.manual_grip_m)
                self.pose_panel.set_pose(pose)
                self.target.set_pose(pose)
                self.jogger.start_cartesian(pose.base_p)
            else:
                self._apply_cartesian(self.jogger.start_cartesian(self.session.kinematics.fk(q)))
        self.show()

    @QtCore.Slot(int)
    def set_step(self, index: int) -> None:
        self.jogger.set_step_index(index)
        self.jog_panel.set_step_index(self.jogger.step_index)
        self.show()

    @QtCore.Slot(int, int)
    def press(self, channel: int, direction: int) -> None:
        """A ± button or a jog key went down: one step now, more while it is held (not while stopped)."""
        if not self.session.controller.armed:
            self._note = "stopped — hold RE-ARM before jogging"
            self.show()
            return
        if self._keys_drive_teleop():  # the keyboard is TELEOP's hand source: the keys move its target
            self._teleop_keys().press(channel, direction, self.session.clock.now())
            return
        if not self.jogger.holding:
            self._begin()
        try:
            target = self.jogger.press(channel, direction, time.monotonic())
        except ValueError as exc:
            self.sigNote.emit(str(exc))
            return
        self._apply(target)
        self.timer.start()

    @QtCore.Slot(int)
    def release(self, channel: int) -> None:
        """The button or key came up: the target stops where it is."""
        keyboard = self._teleop_keys()
        if keyboard is not None:
            keyboard.release(channel, self.session.clock.now())
        if self.jogger.holding and self.session.controller.armed:
            self._apply(self.jogger.release(channel, time.monotonic()))
        if not self.jogger.holding:
            self.timer.stop()

    def _keys_drive_teleop(self) -> bool:
        """The jog keys move TELEOP's keyboard source (Cartesian jogging only: it gives a point)."""
        keyboard, t = self._teleop_keys(), self.session.targeter
        return (keyboard is not None and t.teleop is keyboard and t.mode is TargetMode.TELEOP
                and self.jogger.space is JogSpace.CARTESIAN)

    def _begin(self) -> None:
        """Where a jog starts (``Jogger.begin``): in MANUAL mode the manual target or the joint
        jog's target, else where the arm is commanded."""
        s, c = self.session, self.session.controller
        manual = s.targeter.mode is TargetMode.MANUAL
        q_arm = c.last.q if c.last is not None else c.start_pose(self._state())
        self.jogger.begin(q_arm, s.targeter.manual_target if manual else None, c.joint_jog)

    def _apply(self, target) -> None:
        """The jog's new target to the arm: the MANUAL target (Cartesian) or a joint goal."""
        s = self.session
        if self.jogger.space is JogSpace.CARTESIAN:
            self._apply_cartesian(target)
        else:
            # the manual target follows the joints' tool point (the twin and the Target tab show it)
            base_p = self.jogger.tool_point(target)
            if s.targeter.mode is not TargetMode.MANUAL:  # Manual at that point first: no jump
                self._apply_cartesian(base_p)
                s.controller.set_joint_jog(target, base_p)
                self._user_input()  # step at once, not at the next tick
            else:
                s.controller.set_joint_jog(target, base_p)  # before the target: see set_joint_jog
                self.target.set_manual_target(base_p)  # the targeter's listener steps the control at once
                self.target.show_manual_target(base_p)
        self._note = self.jogger.note
        self.show()
        self.sigChanged.emit()

    def _apply_cartesian(self, base_p) -> None:
        s = self.session
        s.controller.set_joint_jog(None)
        self.target.set_manual_target(base_p)  # the target first, then the mode: no step towards an old target
        self.target.show_manual_target(base_p)
        if s.targeter.mode is not TargetMode.MANUAL:
            self.target.set_mode(TargetMode.MANUAL.value)

    def tick(self) -> None:
        """50 Hz while something is held: the continuous part of the jog."""
        if not self.session.controller.armed:
            self.stop()
            return
        target = self.jogger.update(time.monotonic())
        if target is not None:
            self._apply(target)
        if not self.jogger.holding:
            self.timer.stop()

    def stop(self) -> None:
        """Let go of every jog key and button (STOP, focus lost, closing): targets stay put."""
        self.jogger.release_all()
        keyboard = self._teleop_keys()
        if keyboard is not None:
            keyboard.release_all()
        self._keys.clear()
        self.timer.stop()

    def show(self) -> None:
        """The jog panel's readout: where the target is, the joints, why the last step stopped short."""
        s, c = self.session, self.session.controller
        p, joints = self.jogger.readout(c.last.q if c.last is not None else None, s.targeter.manual_target,
                                        c.joint_jog)
        self.jog_panel.show_state(p, joints, self._note)

    def jog_event(self, obj, event, kind) -> bool:
        """A key or deactivation event seen by the application-wide ``JogKeyFilter``: jog keys
        anywhere in this window unless the focus is in a text field (a focused slider or tab bar
        would otherwise eat the arrows). True when the event is used up."""
        if kind in (QtCore.QEvent.Type.KeyPress, QtCore.QEvent.Type.KeyRelease):
            return (isinstance(obj, QtWidgets.QWidget) and obj.window() is self.window
                    and self._key(event, kind == QtCore.QEvent.Type.KeyPress))
        if obj is self.window:  # WindowDeactivate: a key released in another window never comes here
            self.stop()
        return False

    def _key(self, event: QtGui.QKeyEvent, pressed: bool) -> bool:
        """Handle one key event as a jog key; True when it was one (and is used up)."""
        mods = QtCore.Qt.KeyboardModifier
        if event.modifiers() & (mods.ControlModifier | mods.AltModifier | mods.MetaModifier):
            return False
        if is_text_field(QtWidgets.QApplication.focusWidget()):
            return False
        key = int(event.key())
        if not pressed:
            if key in self._keys:
                if not event.isAutoRepeat():
                    self.release(self._keys.pop(key))
                return True
            return False
        action = jog_key_action(key, self.jogger.space.value, self.jog_panel.selected_joint, self.jogger.joint_count)
        if action is None:
            return False
        if event.isAutoRepeat():
            return True  # held: the timer moves it
        if action.kind == "jog":
            self._keys[key] = action.channel
            self.press(action.channel, action.direction)
        elif action.kind == "step":
            self.set_step(self.jogger.step_index + action.direction)
        elif action.kind == "space":
            self.set_space((JogSpace.JOINT if self.jogger.space is JogSpace.CARTESIAN else JogSpace.CARTESIAN).value)
        elif action.kind == "joint":
            self.jog_panel.set_selected_joint(action.channel)
        return True
