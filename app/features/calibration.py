"""The calibration feature: the Camera tab (stereo calibration, the camera's image controls) and
the camera → arm (hand-eye) calibration of the Robot tab.

``CalibrationFeature`` builds the Camera tab's ``page``: "Calibrate cameras…" opens the
calibration wizard (its own worker, fed with the live frames while it is open); a saved
calibration goes to the perception worker, which switches perception, disparity and the health
monitor to it without a restart. Below it, the simulated desk's four camera settings or a real
camera's device controls as it reports them. ``open_hand_eye`` opens the hand-eye wizard.

Signals (GUI thread): ``sigNote(str)`` — a message for the banner; ``sigCalibrationChanged()`` —
a stereo or camera → arm calibration is in use now (legends, status bar, views);
``sigDialogMade(object)`` — a wizard's controller was made (it has STOP and shows the e-stop state).
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Optional

from PySide6 import QtCore, QtWidgets

from widgets._style import TOUCH_PX, touch_button
from widgets.camera_controls import CameraSettingsPanel
from widgets.device_controls import DeviceControlsPanel

if TYPE_CHECKING:  # the wizards' modules are imported when one first opens (start-up)
    from app.calibration_worker import CalibrationController
    from app.hand_eye import HandEyeController


class CalibrationFeature(QtCore.QObject):
    """Calibrations and camera controls for ``session``.

    ``host``: the window the wizards open over; the hand-eye controller reads its newest
    ``_result`` and ``_state`` and switches its ``target_panel``'s mode (app/hand_eye.py)."""

    sigNote = QtCore.Signal(str)
    sigCalibrationChanged = QtCore.Signal()
    sigDialogMade = QtCore.Signal(object)

    def __init__(self, session, perception_worker, host: QtWidgets.QWidget):
        super().__init__(host)
        self.session = session
        self.perception = perception_worker
        self.host = host
        self.calibration_controller: Optional[CalibrationController] = None
        self.hand_eye: Optional[HandEyeController] = None
        self.page = self._build_page()
        p = perception_worker
        p.sigControls.connect(self.on_controls)
        p.sigControlApplied.connect(self.on_control_applied)
        p.sigControlError.connect(self.on_control_error)
        p.sigCalibrationApplied.connect(self.on_calibration_applied)
        self.update_label()

    def _build_page(self) -> QtWidgets.QWidget:
        """Calibrate button and state, then the image controls: the simulated camera's four
        settings, or a real camera's device controls as it reports them."""
        page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(page)
        layout.setContentsMargins(0, 0, 0, 0)
        self.calibrate_button = touch_button("Calibrate cameras…")
        self.calibrate_button.setMinimumHeight(TOUCH_PX + 12)
        font = self.calibrate_button.font()
        font.setBold(True)
        self.calibrate_button.setFont(font)
        self.calibrate_button.setToolTip("Stereo calibration with a printed chessboard or ChArUco board")
        self.calibrate_button.clicked.connect(self.open_calibration)
        layout.addWidget(self.calibrate_button)
        self.calibration_label = QtWidgets.QLabel()
        self.calibration_label.setWordWrap(True)
        layout.addWidget(self.calibration_label)
        self.camera_panel: Optional[CameraSettingsPanel] = None
        self.device_panel: Optional[DeviceControlsPanel] = None
        if self.session.is_simulated_camera or self.session.camera.kind == "remote":
            # the simulated desk's four controls (sent to the serving machine's cameras when remote)
            self.camera_panel = CameraSettingsPanel()
            self.camera_panel.sigSettingsChanged.connect(self.on_camera_settings)
            layout.addWidget(self.camera_panel)
        else:
            self.device_panel = DeviceControlsPanel()
            self.device_panel.sigControlRequested.connect(self.on_control_requested)
            self.device_panel.sigAutoRequested.connect(self.on_auto_requested)
            self.device_panel.sigRefreshRequested.connect(self.on_controls_refresh)
            layout.addWidget(self.device_panel)
        layout.addStretch(1)
        return page

    # --- the camera's image controls -----------------------------------------------------------
    @QtCore.Slot(object)
    def on_camera_settings(self, settings) -> None:
        self.perception.set_camera_settings(settings)

    @QtCore.Slot(object)
    def on_controls(self, controls) -> None:
        """The camera's image controls (list of CameraControl) from the perception worker."""
        if self.device_panel is not None:
            self.device_panel.set_controls(controls)

    @QtCore.Slot(object)
    def on_control_applied(self, control) -> None:
        if self.device_panel is not None:
            self.device_panel.show_applied(control)

    @QtCore.Slot(str)
    def on_control_error(self, message: str) -> None:
        if self.device_panel is not None:
            self.device_panel.set_message(message, warn=True)

    @QtCore.Slot(str, float)
    def on_control_requested(self, name: str, value: float) -> None:
        self.perception.request_control(name, value)

    @QtCore.Slot(str, bool)
    def on_auto_requested(self, name: str, on: bool) -> None:
        self.perception.request_auto(name, on)

    @QtCore.Slot()
    def on_controls_refresh(self) -> None:
        self.perception.request_controls()

    # --- frames and camera problems --------------------------------------------------------------
    def result(self, result) -> None:
        """A perception result: the open wizards step with it."""
        if self.calibration_controller is not None:
            self.calibration_controller.feed(result.frame)  # newest only; ignored while closed
        if self.hand_eye is not None:
            self.hand_eye.on_result(result)  # the camera→arm sweep steps with each frame

    def camera_problem(self, message: str, ended: str) -> None:
        """A camera problem ("" when back; ``ended``: a finished replay's text, no fault)."""
        if self.calibration_controller is not None:
            self.calibration_controller.camera_problem(ended or message)
        if self.device_panel is not None:
            if message and not ended:
                self.device_panel.set_message("camera not delivering frames — the controls come back with it",
                                              warn=True)
            else:
                self.device_panel.set_message("")

    # --- stereo calibration --------------------------------------------------------------------
    @QtCore.Slot()
    def open_calibration(self) -> None:
        """Open the calibration wizard (fed with the live frames while it is open)."""
        if self.calibration_controller is None:
            from app.calibration_worker import CalibrationController

            ctl = self.calibration_controller = CalibrationController(self)
            ctl.sigCalibrationInstalled.connect(self.on_calibration_installed)
            ctl.sigBoardShown.connect(self.on_board_shown)
            self.sigDialogMade.emit(ctl)  # the wizard's own STOP and Esc; it shows the e-stop state
        self.calibration_controller.set_estop(not self.session.controller.armed)
        self.calibration_controller.open(self.host)

    @QtCore.Slot(object)
    def on_board_shown(self, board) -> None:
        """The wizard is capturing ``board`` (None: closed): the simulated desk holds one up."""
        show = getattr(self.session.camera, "show_board", None)
        if show is None:
            return
        try:
            show(board)
        except (RuntimeError, ValueError) as exc:
            self.sigNote.emit(f"the simulated desk cannot show this board: {exc}")

    @QtCore.Slot(object, object)
    def on_calibration_installed(self, path, calibration) -> None:
        """The wizard saved a calibration: use it now (the worker switches before its next frame)."""
        s = self.session
        s.banners = [b for b in s.banners if not b.startswith("UNCALIBRATED") and "rescaled" not in b]
        self.perception.set_calibration(calibration)
        self.sigNote.emit(f"new calibration in use (stereo RMS {calibration.rms_stereo:.2f} px, epipolar "
                          f"{calibration.epipolar_error_px:.2f} px) — saved to {path}")

    @QtCore.Slot(object)
    def on_calibration_applied(self, calibration) -> None:
        """The perception worker now uses ``calibration``."""
        self.update_label()
        self.sigCalibrationChanged.emit()

    def update_label(self) -> None:
        c = self.session.calibration
        if any(b.startswith("UNCALIBRATED") for b in self.session.banners):
            text = "Not calibrated: nominal parameters, 3D positions approximate."
        elif self.session.is_simulated_camera and c.source.endswith("sim_rig_calibration.yaml"):
            text = "Calibration: the simulated rig's exact one."
        else:
            text = (f"Calibration: {c.source or 'from the wizard'} · stereo RMS {c.rms_stereo:.2f} px · "
                    f"epipolar {c.epipolar_error_px:.2f} px · baseline {c.baseline_m * 1e3:.1f} mm")
        self.calibration_label.setText(text)

    # --- camera → arm (hand-eye) -----------------------------------------------------------------
    @QtCore.Slot()
    def open_hand_eye(self):
        """Robot tab → Calibrate camera→arm…: the hand-eye wizard (its own STOP)."""
        if self.hand_eye is None:
            from app.hand_eye import HandEyeController

            self.hand_eye = HandEyeController(self.host)
            self.hand_eye.sigCalibrationInUse.connect(self.on_hand_eye_in_use)
            self.sigDialogMade.emit(self.hand_eye)
        self.hand_eye.set_estop(not self.session.controller.armed)
        return self.hand_eye.open()

    @QtCore.Slot(object, str)
    def on_hand_eye_in_use(self, result, path: str) -> None:
        self.sigNote.emit(f"camera→arm calibration in use ({result.rms_mm:.1f} mm RMS) — saved to {path}")
        self.sigCalibrationChanged.emit()

    def close(self) -> None:
        """The window closes: the wizards' workers are stopped and joined."""
        if self.calibration_controller is not None:
            self.calibration_controller.close()
        if self.hand_eye is not None:
            self.hand_eye.close()
