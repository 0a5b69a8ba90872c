"""Build the whole pipeline (camera, calibration, perception, targeting, control, bridge) from options.

The window's workers and the headless runner both start from a ``DeskSession``, so what the
headless metrics measure is what the window shows.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np

from core.clock import SimClock, WallClock
from core.devices import open_bridge
from core.devices.bridge import MotorBridge, parse_bridge_url
from core.kinematics import build_kinematics, load_profile
from core.messages import TargetMode
from core.motion.control import ArmController
from core.motion.schedule import schedule_for
from core.motion.targeting import BallFinder, Targeter
from core.paths import user_dir
from core.vision.calibration import (
    CalibrationError,
    StereoCalibration,
    load_calibration,
    save_calibration,
)
from core.vision.cameras import CameraSource, open_camera, parse_camera_spec
from core.vision.perception import StereoMarkerPerception

SCENARIOS = ("static", "cups", "wander")


@dataclass
class SessionOptions:
    """What the command line chooses."""

    camera: str = "auto"  # auto | sim | IDX,IDX
    bridge: str = "sim://"  # sim:// | serial port | loop://
    robot: str = "desk_rrr"  # profile name or path
    scenario: str = "static"  # static | cups | wander (simulated desk)
    fps: float = 30.0  # camera frame rate
    simulated_clock: bool = False  # headless --fast: run on a simulated clock
    marker_ids: tuple[int, ...] = (23, 50)
    calibration: Optional[str] = None  # path; default: the last saved one for real cameras
    event_driven: bool = True  # control step at once on a new goal (False: only on the 50 Hz tick)

    def validate(self) -> None:
        """Raise ValueError naming the bad option and the valid values."""
        parse_camera_spec(self.camera)
        parse_bridge_url(self.bridge)
        if self.scenario not in SCENARIOS:
            raise ValueError(f"unknown --scenario value {self.scenario!r}; valid: {', '.join(SCENARIOS)}")
        load_profile(self.robot)  # raises ProfileError naming the valid profiles


@dataclass
class DeskSession:
    """All the core objects of one run, wired the same way for the window and the headless runner."""

    options: SessionOptions
    clock: object
    profile: object
    kinematics: object
    camera: CameraSource
    calibration: StereoCalibration
    perception: StereoMarkerPerception
    targeter: Targeter
    controller: ArmController
    bridge: MotorBridge
    banners: list[str] = field(default_factory=list)
    ball_finder: BallFinder = field(default_factory=BallFinder)

    @classmethod
    def create(cls, options: SessionOptions) -> "DeskSession":
        options.validate()
        clock = SimClock() if options.simulated_clock else WallClock()
        profile = load_profile(options.robot)
        kinematics = build_kinematics(profile)
        # the simulated desk stands in for missing cameras only when the arm is simulated too
        simulated_arm = parse_bridge_url(options.bridge) == "sim"
        camera, banner = open_camera(options.camera, scenario=options.scenario, clock=clock, fps=options.fps,
                                     fallback_to_sim=simulated_arm)
        banners = [banner] if banner else []
        calibration, note = load_session_calibration(camera, options.calibration)
        if note:
            banners.append(note)
        base_T_camera = camera.base_T_camera()
        if base_T_camera is None:
            from core.sim.rig import SimRig

            base_T_camera = SimRig().base_T_camera  # nominal mount until a hand-eye step exists
        perception = StereoMarkerPerception(calibration, base_T_camera, marker_ids=options.marker_ids)
        mode = TargetMode.CUPS if options.scenario == "cups" else TargetMode.FOLLOW
        targeter = Targeter(clock, mode=mode, follow_id=options.marker_ids[0], cup_ids=options.marker_ids[:2],
                            lissajous=lissajous_for(profile, kinematics))
        controller = ArmController(profile, kinematics)
        bridge = open_bridge(options.bridge, profile, clock=clock)
        return cls(options, clock, profile, kinematics, camera, calibration, perception, targeter,
                   controller, bridge, banners)

    def control_schedule(self):
        """A fresh ControlSchedule for this session's controller and bridge (its rate cap)."""
        return schedule_for(self.controller.period_s, self.bridge, self.options.event_driven)

    def real_arm_refusal(self, bridge_url: str) -> str:
        """Why switching to ``bridge_url`` is refused ("" when it is not): a real arm never
        follows the simulated desk that stands in for missing cameras — only a user who asked
        for ``--camera sim`` gets a real arm on the simulated scene."""
        try:
            simulated_arm = parse_bridge_url(bridge_url) == "sim"
        except ValueError:
            return ""  # not a bridge URL at all: open_bridge says so
        if simulated_arm or not self.is_simulated_camera or self.options.camera == "sim":
            return ""
        return (f"{bridge_url}: not connected — no camera was found, the views show the simulated desk, and a "
                "real arm would follow markers that do not exist. Plug in the cameras and restart deskarm, "
                "or start it with --camera sim to drive a real arm from the simulated desk on purpose")

    @property
    def is_simulated_camera(self) -> bool:
        return self.camera.kind == "sim"

    def close(self) -> None:
        try:
            self.camera.disconnect()
        finally:
            self.bridge.disconnect()


def freeze_startup_objects() -> None:
    """Collect once and move everything alive so far (modules, models, the session) out of the
    garbage collector's reach (``gc.freeze``): the young-generation collections of a running
    loop then stay short — one took 8 ms, a visible hiccup in the frame → command latency.
    Called by the app's entry points (window, headless run) once the session is built."""
    import gc

    gc.collect()
    gc.freeze()


def lissajous_for(profile, kinematics):
    """The Lissajous defaults of an arm: ours for the desk arm, the original's (scaled) for others."""
    from core.settings import LissajousParams

    if profile.name == "desk_rrr":
        return LissajousParams()
    from core.motion.trajectory import default_lissajous

    try:
        return default_lissajous(kinematics, profile.name)
    except ValueError:  # no scaled curve fits this arm: the desk defaults, flagged when out of reach
        return LissajousParams()


def load_session_calibration(camera: CameraSource, path: Optional[str]) -> tuple[StereoCalibration, str]:
    """The calibration the session uses, and a banner line when it is not a real one.

    The simulated rig's exact calibration is written to the cache folder and read back through
    the same loader real calibrations use.
    """
    own = camera.calibration()
    if own is not None and path is None:
        cache = user_dir("cache") / "sim_rig_calibration.yaml"
        try:
            save_calibration(cache, own)
        except OSError as exc:  # a read-only cache folder: the rig's own calibration, unsaved
            return own, f"{exc} (the simulated rig's calibration is used without its file)"
        return load_calibration(cache, expected_size=own.image_size), ""
    candidate = Path(path) if path else user_dir("config") / "calibration.yaml"
    size = camera_image_size(camera)
    try:
        calib = load_calibration(candidate, expected_size=size)
        return calib, "; ".join(calib.notes)
    except CalibrationError as exc:
        from core.sim.rig import SimRig, SimRigConfig

        w, h = size or (640, 480)
        nominal = SimRig(SimRigConfig(width=w, height=h, focal_px=430.0 * w / 640.0)).calibration()
        if path is None and exc.missing:  # nothing installed yet: the usual first start
            return nominal, ("UNCALIBRATED: nominal parameters, 3D positions approximate "
                             "(no stereo calibration yet — run `deskarm calibrate`)")
        # a file that is there but unusable (installed or given) says which file and why
        return nominal, f"UNCALIBRATED: {exc} (nominal parameters meanwhile, 3D positions approximate)"


def camera_image_size(camera: CameraSource) -> Optional[tuple[int, int]]:
    """(width, height) the camera delivers, when it can tell (webcams after connect)."""
    mode = getattr(camera, "actual_mode", None)
    try:
        mode = mode() if callable(mode) else mode
    except Exception:  # a device that cannot report its mode is simply unknown
        return None
    if mode:
        w, h = int(mode[0][0]), int(mode[0][1])
        if w > 0 and h > 0:
            return (w, h)
    return None


def chain_points(session: DeskSession, q) -> np.ndarray:
    return np.asarray(session.kinematics.chain_points(q))
