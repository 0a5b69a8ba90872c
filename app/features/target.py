"""The target feature: the Target tab (mode, manual target, marker to follow, object to follow,
Lissajous), the Pose tab of a 6-DOF arm, and the Lissajous preview in the arm twin.

``TargetFeature`` owns the ``TargetPanel`` and, for 6-DOF arms, the ``PosePanel``: one target
state — the Pose tab starts at the targeter's manual target with the home orientation, the
Target tab's X/Y/Z sliders get its ranges, and each shows what the other set. The panels'
setters go straight to the session's targeter (thread-safe; the control worker reads them on
its next tick). The window hears of a new mode through its own ``on_mode_changed`` (other
features act on some modes).

Signals (GUI thread): ``sigNote(str)`` — a message for the banner; ``sigChanged()`` — something
drawn changed (the preview).
"""
from __future__ import annotations

from dataclasses import replace
from typing import Callable, Optional

from PySide6 import QtCore

from app.window_texts import cups_hint, lissajous_preview
from core.messages import TargetMode
from widgets.pose_panel import PosePanel, pose_panel_applies, pose_target_from_matrix
from widgets.target_panel import TargetPanel


class TargetFeature(QtCore.QObject):
    """The target controls of ``session``; ``twins()``: the arm twins that draw the preview."""

    sigNote = QtCore.Signal(str)
    sigChanged = QtCore.Signal()

    def __init__(self, session, twins: Callable[[], list], parent: Optional[QtCore.QObject] = None):
        super().__init__(parent)
        s = self.session = session
        self._twins = twins
        self.preview_note = ""  # how much of the Lissajous curve is out of reach ("" when none)
        self.target_panel = TargetPanel()
        self.pose_panel: Optional[PosePanel] = None
        if pose_panel_applies(s.profile):  # 6-DOF arms: X/Y/Z, yaw/pitch/roll, grip
            self.pose_panel = PosePanel()
            self.pose_panel.configure_for(s.profile, s.kinematics)
            home = pose_target_from_matrix(s.kinematics.fk_pose(s.profile.q_home))
            # one target state: the Pose tab starts at the targeter's manual target, with the
            # home orientation, and the Target tab's X/Y/Z sliders get the same ranges
            self.pose_panel.set_pose(replace(home, base_p=tuple(s.targeter.manual_target)))
            lo_hi = [self.pose_panel.spins[k] for k in "xyz"]
            self.target_panel.set_manual_ranges(*(v / 100.0 for sp in lo_hi for v in (sp.minimum(), sp.maximum())))
        tp = self.target_panel
        tp.set_marker_ids(s.options.marker_ids)
        tp.set_lissajous(s.targeter.lissajous)
        tp.set_manual_target(s.targeter.manual_target)

    def connect_panels(self, on_mode_changed: Callable[[str], None], on_pose_target: Callable) -> None:
        """The panels' signals, once the window is built: a new mode goes to ``on_mode_changed``
        (the window's, which also tells the features a mode concerns), a typed pose to ``on_pose_target``."""
        tp = self.target_panel
        tp.sigModeChanged.connect(on_mode_changed)
        tp.sigManualTargetChanged.connect(self.on_manual_target)
        tp.sigFollowIdChanged.connect(self.on_follow_id)
        tp.sigFollowObjectChanged.connect(self.on_follow_object)
        tp.sigLissajousChanged.connect(self.on_lissajous)
        tp.sigLissajousRunning.connect(self.on_lissajous_running)
        tp.set_mode(self.session.targeter.mode.value)
        if self.pose_panel is not None:
            self.pose_panel.sigPoseChanged.connect(on_pose_target)

    def set_mode(self, mode: str) -> None:
        """The targeter's mode (the panel already shows it); the cups game says what it needs."""
        self.session.targeter.set_mode(TargetMode(mode))
        self.update_preview()
        if TargetMode(mode) is TargetMode.CUPS:
            hint = cups_hint(self.session)
            self.target_panel.set_cups_hint(hint)
            if hint:
                self.sigNote.emit(hint)

    @QtCore.Slot(object)
    def on_manual_target(self, p) -> None:
        try:
            self.session.targeter.set_manual_target(p)  # keeps a manual orientation (Pose tab)
        except ValueError as exc:  # a non-finite target is refused where it enters: say so
            self.sigNote.emit(str(exc))
            return
        if self.pose_panel is not None:  # the Pose tab shows the same target
            self.pose_panel.set_pose(replace(self.pose_panel.pose(), base_p=tuple(float(v) for v in p)))

    def set_pose(self, pose) -> bool:
        """A pose (Pose tab, or a joint jog's tool pose) as the manual target, orientation
        included; the Target tab's X/Y/Z show it. False (and a note) when it is refused."""
        try:
            self.session.targeter.set_manual_pose(pose.base_p, pose.rpy, pose.grip_m)
        except ValueError as exc:
            self.sigNote.emit(str(exc))
            return False
        self.target_panel.show_manual_target(pose.base_p)
        return True

    @QtCore.Slot(int)
    def on_follow_id(self, marker_id: int) -> None:
        self.session.targeter.set_follow_id(marker_id)

    @QtCore.Slot(str, object)
    def on_follow_object(self, label: str, object_id) -> None:
        """The Target tab's object list: follow that track (or any object of that label)."""
        self.session.targeter.set_follow_object(label, object_id)

    @QtCore.Slot(object)
    def on_lissajous(self, params) -> None:
        self.session.targeter.set_lissajous(params)
        self.update_preview()

    @QtCore.Slot(bool)
    def on_lissajous_running(self, running: bool) -> None:
        self.session.targeter.set_lissajous_running(running)

    def update_preview(self) -> None:
        """Lissajous preview in the twin, with out-of-reach points moved to the nearest reachable."""
        t = self.session.targeter
        if t.mode is not TargetMode.LISSAJOUS:
            for twin in self._twins():
                twin.set_preview(None)
            self.preview_note = ""
            self.sigChanged.emit()
            return
        points, outside = lissajous_preview(t.lissajous, self.session.kinematics)
        for twin in self._twins():
            twin.set_preview(points)
        self.preview_note = (
            f"{outside:.0%} of the curve is out of reach (drawn at the nearest reachable point)" if outside else ""
        )
        self.sigChanged.emit()  # the reach status shows the note, even while the goal holds still
