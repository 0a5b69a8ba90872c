"""The teleop feature (issue 13): the Target tab's Teleop page, its line under STOP, the twin's boxes.

``TeleopFeature`` owns the ``TeleopPanel`` (the Target tab's teleop page): a hand source chosen
there becomes a controller for the targeter's TELEOP mode (``core.motion.teleop_choice``: a
``TeleopController`` around the hand source, or the keyboard's ``JogTeleopSource``, whose target
the jog keys then move); the target box is checked against the arm's reach before it is taken.
``draw`` shows the teleop state on the page and in the 2D twin.

Signals (GUI thread): ``sigNote(str)`` — a message for the banner; ``sigChanged()`` — something
drawn changed.
"""
from __future__ import annotations

from typing import Callable, Optional

from PySide6 import QtCore

from core.messages import TargetMode
from core.motion.jog import JogTeleopSource
from core.motion.teleop import Box, make_hand_source
from core.motion.teleop_choice import (
    KEYBOARD_SOURCE,
    default_source,
    target_box_presets,
    teleop_controller_for,
)
from core.detect.colour import DEFAULT_COLOURS
from widgets.teleop_panel import target_box_problem


class TeleopFeature(QtCore.QObject):
    """Teleoperation for ``session``; ``teleop_panel``: the Target tab's teleop page.

    ``set_mode(mode)``: the window's way to switch the target mode; ``command()``: the newest
    JointCommand (or None: the keyboard starts at home); ``detectors_running()``: the names of
    the object detectors that run (the hsv glove needs one)."""

    sigNote = QtCore.Signal(str)
    sigChanged = QtCore.Signal()

    def __init__(self, session, teleop_panel, set_mode: Callable[[str], None], command: Callable[[], object],
                 detectors_running: Callable[[], list], parent: Optional[QtCore.QObject] = None):
        super().__init__(parent)
        s = self.session = session
        self.page = self.teleop_panel = teleop_panel
        self._set_mode = set_mode
        self._command = command
        self._detectors_running = detectors_running
        # TeleopParams for the controllers this feature builds (None: the defaults); tests shorten the gestures
        self.params = None
        # spec → HandSource ("marker:23", "hsv:green", "pose:PATH"); a test may put a scripted source here
        self.source_factory = self.make_hand_source
        self.keyboard: Optional[JogTeleopSource] = None  # while the keyboard is TELEOP's source
        self.margin_m = float(s.controller.workspace.desk_margin_m)
        current = s.targeter.teleop  # the session's (--teleop, the teleop scenario), or None
        presets, problem = target_box_presets(s.kinematics, self.margin_m)
        if problem:  # an arm that reaches no box around the common one: say so on the page
            teleop_panel.refuse_target_box(problem)
        box = getattr(current, "target_box", None) or (presets[0][1] if presets else None)
        teleop_panel.set_presets(presets)
        if box is not None:
            teleop_panel.show_target_box(box)
        ids = tuple(getattr(s.perception, "marker_ids", s.options.marker_ids))
        teleop_panel.set_sources(ids, [c.name for c in DEFAULT_COLOURS])
        if current is not None:
            teleop_panel.set_source(getattr(current, "source", current).name)
        teleop_panel.sigSourceChanged.connect(self.on_source)
        teleop_panel.sigRestart.connect(self.on_restart)
        teleop_panel.sigTargetBoxChanged.connect(self.on_target_box)

    def make_hand_source(self, spec: str):
        s = self.session
        return make_hand_source(spec, s.calibration, s.perception.base_T_camera)

    def controller_for(self, spec: str):
        """A new teleop controller for ``spec`` (ValueError, OSError, or the pose model's error)."""
        s, command = self.session, self._command()
        return teleop_controller_for(spec, s.profile, s.kinematics, self.margin_m,
                                     None if command is None else command.q, self.teleop_panel.accepted_box,
                                     self.source_factory, self.params)

    @QtCore.Slot(str)
    def on_source(self, spec: str) -> None:
        """A hand source was chosen: TELEOP mode with a new controller (it calibrates afresh)."""
        s = self.session
        previous = s.targeter.teleop
        try:
            controller = self.controller_for(spec)
        except Exception as exc:  # noqa: BLE001 — a bad spec, a missing file, a model cv2.dnn cannot read
            self.sigNote.emit(f"teleop source {spec}: {exc}")
            if previous is not None:
                self.teleop_panel.set_source(getattr(previous, "source", previous).name)
            return
        self.keyboard = controller if isinstance(controller, JogTeleopSource) else None
        s.targeter.set_teleop(controller)
        if spec.startswith("hsv:") and not self._detectors_running():
            self.sigNote.emit(f"teleop source {spec}: the glove is seen by the hsv detector — "
                              "turn it on in the Objects tab")
        if s.targeter.mode is not TargetMode.TELEOP:  # choosing a hand means driving by hand
            self._set_mode(TargetMode.TELEOP.value)
        self.sigChanged.emit()

    def ensure_controller(self) -> None:
        """Into TELEOP mode without a hand source: the panel's choice (else the first marker)."""
        if self.session.targeter.teleop is not None:
            return
        spec = default_source(self.teleop_panel.source, self.session.options.marker_ids)
        self.teleop_panel.set_source(spec)
        self.on_source(spec)

    @QtCore.Slot()
    def on_restart(self) -> None:
        """Restart: calibrate again (the keyboard source goes back to where it started)."""
        if self.session.targeter.teleop is None:
            self.ensure_controller()
            return
        if self.keyboard is not None:
            self.keyboard.restart()
        else:
            self.session.targeter.restart_teleop()
        self.sigChanged.emit()

    @QtCore.Slot(object, object)
    def on_target_box(self, lo, hi) -> None:
        """The target box was edited (or a preset chosen): taken when the arm reaches all of it,
        else refused with the reason (the controls go back to the box in use)."""
        if not all(a < b for a, b in zip(lo, hi)):
            axes = ", ".join(axis for axis, a, b in zip("xyz", lo, hi) if not a < b)
            self.teleop_panel.refuse_target_box(f"target box: min must be below max along {axes}")
            return
        box = Box(tuple(lo), tuple(hi))
        problem = target_box_problem(self.session.kinematics, box, self.margin_m)
        if problem:
            self.teleop_panel.refuse_target_box(problem)
            return
        self.teleop_panel.show_target_box(box)
        self.session.targeter.set_teleop_target_box(box)
        self.sigChanged.emit()

    def draw(self, twin):
        """The teleop state on the Teleop page and in the twin (hand volume, target box, hand,
        mapped point); the TeleopStatus in TELEOP mode, else None (and the twin's items cleared)."""
        s = self.session
        status = s.targeter.teleop_status() if s.targeter.mode is TargetMode.TELEOP else None
        set_teleop = getattr(twin, "set_teleop", None)  # the 2D twin; the 3D one does not draw it
        if status is None:
            if set_teleop is not None:
                set_teleop()
            if s.targeter.mode is TargetMode.TELEOP:
                self.teleop_panel.set_status(None)
            return None
        self.teleop_panel.set_status(status)
        if set_teleop is not None:
            keyboard = status.source == KEYBOARD_SOURCE  # its "target box" is only the reach sphere's
            set_teleop(status.hand_box, None if keyboard else status.target_box,
                       None if keyboard else status.base_p_hand, status.base_p_mapped)
        return status
