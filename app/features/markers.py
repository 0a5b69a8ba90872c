"""The markers feature: the Markers tab's table, taps on markers, and pick-and-place.

``MarkersFeature`` owns the ``MarkersTable`` (its ``page``, filled from the markers file): a row
chosen does what the file says for that marker (follow it, point at it, or pick it up and put it
at its place); a marker tapped in a camera view is followed (Follow mode) or becomes the manual
target. A running pick and place (``core.motion.pick_place``) steps with each perception result.

Signals (GUI thread): ``sigNote(str)`` — a message for the banner.
"""
from __future__ import annotations

import math
from typing import Callable, Optional

import numpy as np
from PySide6 import QtCore

from core.messages import TargetMode
from core.motion.pick_place import PickPlaceSequence, start_pick_place
from core.vision.markers import default_markers
from widgets.markers_table import MarkersTable


class MarkersFeature(QtCore.QObject):
    """Markers and pick-and-place for ``session``.

    ``target_panel``: the Target tab (its follow id and manual target show what happens);
    ``set_mode(mode)``: the window's way to switch the target mode (panel and targeter);
    ``result()`` / ``state()``: the newest PerceptionResult and JointState (or None)."""

    sigNote = QtCore.Signal(str)

    def __init__(self, session, target_panel, set_mode: Callable[[str], None], result: Callable[[], object],
                 state: Callable[[], object], parent: Optional[QtCore.QObject] = None):
        super().__init__(parent)
        self.session = session
        self.target_panel = target_panel
        self._set_mode = set_mode
        self._result = result
        self._state = state
        self.pick_place: Optional[PickPlaceSequence] = None  # a marker's pick_place action, running
        self.page = self.markers_table = MarkersTable()
        self.markers_table.set_config(session.markers or default_markers())
        self.markers_table.sigMarkerChosen.connect(self.on_marker_chosen)

    @QtCore.Slot(int)
    def on_marker_chosen(self, marker_id: int) -> None:
        """A row of the Markers table: do what the markers file says for that id (follow it, or
        point at it)."""
        spec = self.markers_table.config.marker(marker_id)
        action = spec.action if spec is not None else "follow"
        self.pick_place = None
        if action == "pick_place":
            self.start_pick_place(marker_id)
        elif action == "follow":
            self._set_mode(TargetMode.FOLLOW.value)
        elif self.session.targeter.mode is TargetMode.FOLLOW:
            self._set_mode(TargetMode.MANUAL.value)
        self.on_marker_clicked(marker_id)
        self.markers_table.set_chosen(marker_id)

    def start_pick_place(self, marker_id: int) -> Optional[PickPlaceSequence]:
        """Pick the marked object up and put it at the place the markers file names for it."""
        r = self._result()
        obs = r.marker(marker_id) if r is not None else None
        sequence, why = start_pick_place(self.markers_table.config, marker_id, obs)
        if sequence is None:
            self.sigNote.emit(why)
            return None
        self._set_mode(TargetMode.MANUAL.value)
        self.pick_place = sequence
        self.step_pick_place()
        return self.pick_place

    def step_pick_place(self) -> None:
        """Advance a running pick and place with the measured tool (each perception result)."""
        seq = self.pick_place
        if seq is None or self.session.targeter.mode is not TargetMode.MANUAL:
            self.pick_place = None  # the user chose another mode: the sequence ends
            return
        s, state = self.session, self._state()
        step = seq.advance(s.clock.now(), s.kinematics, None if state is None else state.q, s.profile.gripper)
        if step.target is not None:
            try:
                s.targeter.set_manual_pose(step.target, s.targeter.manual_rpy, step.grip_m)
            except ValueError as exc:
                self.sigNote.emit(str(exc))
            self.target_panel.show_manual_target(step.target)
        if step.note:
            self.sigNote.emit(step.note)
        if step.done:
            self.pick_place = None

    @QtCore.Slot(int)
    def on_marker_clicked(self, marker_id: int) -> None:
        """Tapping a marker: in Follow mode the arm follows that marker; in any other mode it
        becomes the manual target (pointing position above it)."""
        if self.session.targeter.mode is TargetMode.FOLLOW:
            self.target_panel.set_follow_id(marker_id)  # the Marker id box shows it
            self.session.targeter.set_follow_id(marker_id)
            self.sigNote.emit(f"following marker {marker_id}")
            return
        r = self._result()
        if r is None:
            return
        obs = r.marker(marker_id)
        if obs is None or obs.base_p_centre is None:
            return
        if not all(math.isfinite(v) for v in obs.base_p_centre):
            self.sigNote.emit(f"marker {marker_id} has no 3D position yet — it must be seen by both cameras")
            return
        self._set_mode(TargetMode.MANUAL.value)
        self.target_panel.set_manual_target(self.session.targeter.pointing.apply(obs.base_p_centre))

    def draw(self, result, state) -> None:
        """The table's distances and states (call only while the table is shown)."""
        tool = (None if state is None
                else tuple(float(v) for v in np.asarray(self.session.kinematics.fk(state.q), float)[:3]))
        self.markers_table.update(result.markers, tool)
