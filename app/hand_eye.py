"""The window's camera → arm calibration: the hand-eye wizard, driven by live perception results.

``HandEyeController`` opens ``widgets.hand_eye_wizard.HandEyeWizard`` and runs one of the
methods of ``core.handeye`` on the frames the window already receives:

- **sweep** — ``HandEyeSweep`` plans tool poses the cameras share; each perception result
  advances it, and its goal becomes the targeter's manual target, so the arm moves through the
  normal control step (limits, rate clamps, e-stop, pause). The tool marker's triangulated
  centre is sampled while the arm holds still.
- **touch points** / **planar** — the user jogs the tool tip onto markers lying on the desk (the
  wizard goes back to a normal window so the Target tab is usable) and taps *Record this
  point*; the marker nearest to the tool (in the current camera → arm estimate) is paired with
  the tool point. Touch points solve the rigid transform; planar maps the left image's pixels
  to the desk.

*Save and use* writes the file (``core.handeye.storage``) and hands ``base_T_camera`` to
perception at once. Everything runs in the GUI thread: perception results arrive at frame
rate and a step costs microseconds.
"""
from __future__ import annotations

from typing import Optional

import numpy as np
from PySide6 import QtCore

from core.handeye.solve import pose_error, solve_planar, solve_touch_points, tool_marker_of
from core.handeye.storage import save_hand_eye, save_planar
from core.handeye.sweep import HandEyeSweep
from core.messages import TargetMode

TOUCH_POINTS_NEEDED = 4  # markers the touch-point and planar methods need at least
LIVE_EVERY = 2  # show every 2nd frame in the wizard's live view


class HandEyeController(QtCore.QObject):
    """Opens the hand-eye wizard for a MainWindow and runs the chosen method.

    Signals:
    - sigStopRequested(): the wizard's STOP (or Esc).
    - sigCalibrationInUse(object result, str path): a saved calibration is now in use.
    """

    sigStopRequested = QtCore.Signal()
    sigCalibrationInUse = QtCore.Signal(object, str)

    def __init__(self, window) -> None:
        super().__init__(window)
        self.window = window
        self.session = window.session
        self.wizard = None
        self.method: Optional[str] = None
        self.sweep: Optional[HandEyeSweep] = None
        self.result = None
        self.raw_result = None  # the solver's own result (self.result may wrap it with the truth)
        self.records: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []  # (camera_p, pixel, tool_p)
        self._restore_mode: Optional[TargetMode] = None
        self._frames = 0
        self._estop = False
        self.marker = tool_marker_of(self.session.profile)

    # --- opening / closing -------------------------------------------------------------------
    def open(self):
        from widgets.hand_eye_wizard import HandEyeWizard

        if self.wizard is not None:
            self.wizard.raise_()
            return self.wizard
        w = self.wizard = HandEyeWizard(self.window)
        w.set_tool_marker(f"id {self.marker.marker_id}, {self.marker.size_m * 1e3:g} mm, "
                          f"{_offset_text(self.marker.offset_m)} from the tool point")
        w.set_estop(self._estop)
        w.sigStartRequested.connect(self.on_start)
        w.sigCancelRequested.connect(self.on_cancel)
        w.sigRecordPointRequested.connect(self.on_record_point)
        w.sigSaveRequested.connect(self.on_save)
        w.sigStopRequested.connect(self.sigStopRequested)
        w.finished.connect(self.on_closed)
        w.show_adaptive()
        return w

    def close(self) -> None:
        if self.wizard is not None:
            self.wizard.close()
        self.on_closed()

    @property
    def running(self) -> bool:
        return self.method is not None

    def set_estop(self, engaged: bool) -> None:
        self._estop = bool(engaged)
        if self.wizard is not None:
            self.wizard.set_estop(engaged)

    # --- wizard slots ------------------------------------------------------------------------
    @QtCore.Slot(str, int)
    def on_start(self, method: str, n_poses: int) -> None:
        self.result, self.raw_result, self.records, self._frames = None, None, [], 0
        targeter = self.session.targeter
        if self._restore_mode is None:
            self._restore_mode = targeter.mode
        if method == "sweep":
            try:
                self.sweep = HandEyeSweep(self.session.profile, self.session.kinematics, n_poses=n_poses,
                                          tool_marker=self.marker)
            except ValueError as exc:
                self.wizard.on_failed(str(exc))
                return
            targeter.set_mode(TargetMode.MANUAL)  # the sweep's goals become the manual target
            self.window.target_panel.set_mode(TargetMode.MANUAL.value)
        else:
            self.sweep = None
            self.wizard.set_points_recorded(0, TOUCH_POINTS_NEEDED)  # the phase line says what to do
            self.wizard.showNormal()  # the Target tab must be reachable to jog
        self.method = method

    @QtCore.Slot()
    def on_cancel(self) -> None:
        self._finish()

    @QtCore.Slot()
    def on_closed(self, *_args) -> None:
        self._finish()
        wizard, self.wizard = self.wizard, None
        if wizard is not None:
            wizard.deleteLater()

    def _finish(self) -> None:
        """Stop the procedure; the target mode the user had comes back."""
        self.method, self.sweep = None, None
        if self._restore_mode is not None:
            mode, self._restore_mode = self._restore_mode, None
            self.session.targeter.set_mode(mode)
            self.window.target_panel.set_mode(mode.value)

    # --- frames ------------------------------------------------------------------------------
    def on_result(self, result) -> None:
        """A perception result (GUI thread): advance the sweep, refresh the live view."""
        if self.wizard is None or self.method is None or result is None:
            return
        obs = result.marker(self.marker.marker_id)
        self._frames += 1
        if result.frame is not None and self._frames % LIVE_EVERY == 0:
            seen = obs is not None and len(obs.left_corners) == 4
            self.wizard.show_live(result.frame.left, [np.asarray(obs.left_corners)] if seen else None,
                                  [obs.marker_id] if seen else None)
        if self.sweep is None:
            return
        camera_p = obs.camera_p_centre if obs is not None and obs.found else None
        q = self._q_now()
        step = self.sweep.step(self.session.clock.now(), camera_p, q)
        if step.goal_base_p is not None:
            self.session.targeter.set_manual_target(step.goal_base_p)
        self.wizard.set_progress(step.progress, step.message)  # which pose: "settling at pose 3 of 12"
        if step.phase != "done":
            self.wizard.set_phase(step.phase)  # what that means, in the phase's own words
            return
        res = self.sweep.result(self.session.camera.pair_id)
        self._finish()
        self._show(res)

    def _q_now(self):
        state = self.window._state
        if state is not None:
            return tuple(state.q)
        return self.session.controller.start_pose(None)

    @QtCore.Slot()
    def on_record_point(self) -> None:
        """Touch points / planar: pair the tool point with the marker nearest to it."""
        r = self.window._result
        if self.method not in ("touch_points", "planar") or r is None:
            return
        tool = np.asarray(self.session.kinematics.fk(self._q_now()), float)[:3]
        seen = [m for m in r.markers if m.found and m.camera_p_centre is not None and m.base_p_centre is not None
                and m.marker_id != self.marker.marker_id]
        if not seen:
            self.wizard.on_failed("no marker is seen by both cameras — put one on the desk in view")
            return
        nearest = min(seen, key=lambda m: float(np.linalg.norm(np.asarray(m.base_p_centre) - tool)))
        pixel = np.asarray(nearest.left_corners, float).mean(axis=0)
        self.records.append((np.asarray(nearest.camera_p_centre, float), pixel, tool))
        n = len(self.records)
        self.wizard.set_points_recorded(n, TOUCH_POINTS_NEEDED)
        # the count is on the points line, what to do next on the phase line
        self.wizard.set_progress(min(1.0, n / TOUCH_POINTS_NEEDED), f"marker {nearest.marker_id} recorded")
        if n < TOUCH_POINTS_NEEDED:
            return
        cam, px, tools = (np.array([rec[k] for rec in self.records]) for k in range(3))
        pair = self.session.camera.pair_id
        if self.method == "touch_points":
            res = solve_touch_points(cam, tools, camera_pair=pair)
        else:
            res = solve_planar(px, tools[:, :2], tools[:, 2], camera_pair=pair)
        self._finish()
        self._show(res)

    def _show(self, res) -> None:
        self.result = self.raw_result = res
        truth = getattr(self.session.camera, "true_base_T_camera", None)
        if callable(truth) and getattr(res, "base_T_camera", None) is not None:
            t_mm, r_deg = pose_error(res.base_T_camera, truth())
            res = _TruthView(res, t_mm, r_deg)
            self.result = res
        self.wizard.show_result(res)

    @QtCore.Slot()
    def on_save(self) -> None:
        """Save and use: write the file, hand base_T_camera to perception now."""
        res = self.raw_result
        if res is None or not getattr(res, "ok", False):
            return
        try:
            if getattr(res, "base_T_camera", None) is not None:
                path = save_hand_eye(res)
                self.session.use_hand_eye(res, path)
            else:
                path = save_planar(res, _planar_path())
        except (OSError, ValueError) as exc:
            self.wizard.on_failed(f"could not save: {exc}")
            return
        self.wizard.on_saved(str(path))
        self.sigCalibrationInUse.emit(res, str(path))


class _TruthView:
    """A result plus its error against the simulated desk's true mount (for the wizard)."""

    def __init__(self, res, t_mm: float, r_deg: float) -> None:
        self._res = res
        self.translation_error_mm = t_mm
        self.rotation_error_deg = r_deg

    def __getattr__(self, name):
        return getattr(self._res, name)


def _offset_text(offset_m) -> str:
    return "(" + ", ".join(f"{v * 1e3:+.0f}" for v in offset_m) + ") mm"


def _planar_path():
    from core.handeye.storage import default_hand_eye_path

    return default_hand_eye_path().with_name("planar_map.toml")
