"""The simulated desk as a stereo camera source: the rig's two views rendered on a clock."""
from __future__ import annotations

import threading
from dataclasses import replace
from typing import Optional

import numpy as np

from core.messages import SequenceCounter, StereoFrame
from core.settings import CameraSettings, replace_field
from core.sim.desk import SimDesk
from core.sim.rig import SimRig
from core.vision.calibration import StereoCalibration
from core.vision.cameras import CameraControl, ClockPacedSource, check_side

_SIM_CONTROLS = (  # name, label, min, max, step (CameraSettings fields)
    ("exposure", "Exposure (EV)", -4.0, 4.0, 0.1),
    ("gain", "Gain (dB)", 0.0, 24.0, 0.5),
    ("brightness", "Brightness", -100.0, 100.0, 1.0),
    ("contrast", "Contrast", 0.2, 3.0, 0.05),
)



class SimStereoCamera(ClockPacedSource):
    """The simulated desk seen by the simulated rig, at ``fps`` on the given clock.

    ``set_arm_points`` tells the renderer where the arm is (chain points in robot_base), so the
    arm appears in both views as it moves.
    """

    kind = "sim"

    def __init__(self, scenario: str = "static", fps: float = 30.0, clock=None, seed: int = 0,
                 marker_ids=(23, 50), rig=None, **desk_options):
        super().__init__(clock)
        if not (1.0 <= fps <= 240.0):
            raise ValueError(f"camera fps = {fps} is outside 1…240")
        self.rig = rig or SimRig()
        self.desk = SimDesk(self.rig, scenario=scenario, marker_ids=marker_ids, seed=seed, **desk_options)
        self.scenario = scenario
        self.fps = float(fps)
        self._seq = SequenceCounter()
        self._t0 = 0.0
        self._next = 0.0
        self._arm_points: Optional[np.ndarray] = None
        self._lock = threading.Lock()

    @property
    def name(self) -> str:
        return f"simulated desk ({self.scenario})"

    @property
    def pair_id(self) -> str:
        return "sim"

    def connect(self) -> None:
        self._connected = True
        self._t0 = self.clock.now()
        self._next = self._t0


    def set_settings(self, settings: CameraSettings) -> None:
        super().set_settings(settings)
        self.desk.set_camera_settings(settings)

    def controls(self, side: str = "left") -> list[CameraControl]:
        check_side(side, ("left", "right"))
        default = CameraSettings()
        return [CameraControl(name, label, lo, hi, step, float(getattr(default, name)),
                              float(getattr(self.settings, name)))
                for name, label, lo, hi, step in _SIM_CONTROLS]

    def set_control(self, name: str, value: float, side: str = "both") -> CameraControl:
        check_side(side)
        by_name = {c.name: c for c in self.controls()}
        if name not in by_name:
            raise KeyError(f"{self.name} has no control {name!r}; available: {', '.join(by_name)}")
        applied = by_name[name].clamp(value)
        self.set_settings(replace_field(self.settings, **{name: applied}))
        return replace(by_name[name], value=applied)

    def set_arm_points(self, points: Optional[np.ndarray]) -> None:
        with self._lock:
            self._arm_points = None if points is None else np.array(points, dtype=float)

    def read(self) -> Optional[StereoFrame]:
        if not self._connected:
            return None
        if not self.clock.wait_until(self._next) or not self._connected:
            return None
        t = self.clock.now()
        # keep the frame grid; after a stall skip ahead instead of bursting
        self._next = max(self._next + 1.0 / self.fps, t)
        with self._lock:
            arm = self._arm_points
        left, right, truth = self.desk.render(t - self._t0, arm)
        return StereoFrame(seq=self._seq.next(), t=t, left=left, right=right, truth=truth)

    def calibration(self) -> StereoCalibration:
        return self.rig.calibration()

    def base_T_camera(self) -> np.ndarray:
        return self.rig.base_T_camera
