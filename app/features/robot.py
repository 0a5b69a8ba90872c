"""The robot feature: the Robot tab — the joints, the bridge to the arm, and the buttons for the
camera → arm calibration and the 3D twin (the window connects those two).

``RobotFeature`` builds the tab's ``page``: the joint readout (commanded and measured, as people
read them), the ``BridgePicker`` (a serial port or URL: the bridge worker switches to it and
reports back), "Camera → arm calibration…" (``hand_eye_button``) and "3D twin"
(``view_3d_button``, disabled where OpenGL is missing).
"""
from __future__ import annotations

from typing import Optional

from PySide6 import QtCore, QtWidgets

from app.window_texts import joint_display_limits, joint_display_values, list_port_choices
from widgets._style import touch_button
from widgets.arm_twin_3d import available_3d
from widgets.bridge_picker import BridgePicker
from widgets.joint_readout import JointReadout


class RobotFeature(QtCore.QObject):
    """The Robot tab of ``session``'s window; ``bridge_worker``: where a chosen bridge goes."""

    def __init__(self, session, bridge_worker, parent: Optional[QtCore.QObject] = None):
        super().__init__(parent)
        s = self.session = session
        self.bridge_worker = bridge_worker
        self.joints = JointReadout()
        self.joints.set_joints(s.profile.joint_names, *joint_display_limits(s.profile),
                               None if s.profile.has_servos else [j.display_unit for j in s.profile.joints])
        self.bridge_picker = BridgePicker(list_port_choices)
        self.bridge_picker.sigConnectRequested.connect(self.on_bridge_requested)
        self.page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(self.page)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.joints)
        self.hand_eye_button = touch_button("Camera → arm calibration…")
        self.hand_eye_button.setToolTip("Where the cameras are in the robot's frame: the arm carries its tool "
                                        "marker through a sweep (or touch markers on the desk)")
        layout.addWidget(self.hand_eye_button)
        self.view_3d_button = touch_button("3D twin", checkable=True)
        ok3d, self.why_no_3d = available_3d()
        self.view_3d_button.setEnabled(ok3d)
        if not ok3d:
            self.view_3d_button.setText("3D twin (no OpenGL here)")
        layout.addWidget(self.view_3d_button)
        layout.addWidget(self.bridge_picker)
        layout.addStretch(1)

    def add_panel(self, panel: Optional[QtWidgets.QWidget]) -> None:
        """Another feature's panel at the top of the Robot tab (None: nothing), e.g. the RTX's."""
        if panel is not None:
            self.page.layout().insertWidget(0, panel)

    @QtCore.Slot(str)
    def on_bridge_requested(self, url: str) -> None:
        self.bridge_picker.set_status(f"connecting to {url} …", None)  # neutral until it answers
        self.bridge_worker.request_bridge(url)

    def show_bridge_status(self, status) -> None:
        """The bridge worker's BridgeStatus (None: none yet)."""
        if status is not None:
            # green only for a working connection: a failed switch keeps the old bridge
            # connected but says "could not switch to … — still on …": warning colour
            self.bridge_picker.show_bridge_status(status)

    def draw(self, command, state) -> None:
        """The commanded and measured joints (None: not known yet)."""
        profile = self.session.profile
        cmd_deg = joint_display_values(profile, command.q) if command is not None else None
        meas_deg = joint_display_values(profile, state.q) if state is not None else None
        self.joints.set_values(cmd_deg, meas_deg)
