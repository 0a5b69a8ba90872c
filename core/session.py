"""Build the whole pipeline (camera, calibration, perception, targeting, control, bridge) from options.

The window's workers and the headless runner both start from a ``DeskSession``, so what the
headless metrics measure is what the window shows.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Optional

import numpy as np

from core.clock import SimClock, WallClock
from core.cpu_budget import fit_opencv_threads
from core.detect.registry import make_detector, parse_detector_list
from core.detect.stereo import StereoObjectPerception
from core.devices import open_bridge
from core.devices.bridge import MotorBridge, is_simulated_bridge, parse_bridge_url
from core.handeye import HandEyeResult, ToolMarker, tool_marker_of
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
from core.vision.markers import MarkersConfig, load_markers, markers_for_session
from core.vision.perception import StereoMarkerPerception

SCENARIOS = ("static", "cups", "wander", "objects", "panel", "teleop")
MAX_SIM_SKEW_MS = 100.0  # --sim-skew-ms: 0…this


@dataclass
class SessionOptions:
    """What the command line chooses."""

    camera: str = "auto"  # auto | sim | IDX,IDX
    bridge: str = "sim://"  # sim:// | serial port | loop://
    robot: str = "desk_rrr"  # profile name or path
    scenario: str = "static"  # static | cups | wander | objects | panel | teleop (simulated desk)
    fps: float = 30.0  # camera frame rate
    simulated_clock: bool = False  # headless --fast: run on a simulated clock
    marker_ids: tuple[int, ...] = (23, 50)
    calibration: Optional[str] = None  # path; default: the last saved one for real cameras
    event_driven: bool = True  # control step at once on a new goal (False: only on the 50 Hz tick)
    # simulated desk only: the rig mounted off its nominal pose (dx, dy, dz m, roll, pitch, yaw rad)
    rig_offset: Optional[tuple[float, float, float, float, float, float]] = None
    hand_eye: Optional[str] = None  # camera→arm TOML; default: the saved one when it is for this pair
    markers: Optional[str] = None  # markers TOML (dictionary, ids, names, actions); default: the config folder's
    # a desk served by `deskarm serve` on another machine (Zenoh endpoint, e.g. tcp/192.168.1.20:7447):
    # its cameras and arm replace --camera and --bridge
    remote: Optional[str] = None
    remote_credentials: str = ""  # --credentials FILE for --remote ("": the config folder's remote/client.toml)
    # simulated desk only: the right view is captured this much later than the left (ms, 0…100)
    sim_skew_ms: float = 0.0
    # simulated desk only: a realism preset (core.sim.realism, e.g. "webcam") applied to every render
    sim_realism: Optional[str] = None
    # detectors of marker-less objects (registry names, e.g. ("hsv",)): run on every frame after the
    # markers, matched across the views, triangulated and tracked (``DeskSession.object_perception``)
    detectors: tuple[str, ...] = ()
    # how the object perception runs its detectors (``core.detect.stereo.StereoObjectPerception``):
    object_roi_search: bool = False  # detect only around the tracks between full-frame searches
    object_full_frame_every: int = 10  # with ROI search: a full-frame search every N frames (≥ 1)
    object_tracker: Optional[str] = None  # kcf | csrt | mil | mosse: a tracker per object and view
    object_reseed_every: int = 5  # the trackers are re-seeded from the detector every N frames (≥ 1)
    object_detect_every: int = 1  # with a tracker: the detectors run every N frames, trackers in between
    object_min_hits: int = 3  # a new object gets an id after N triangulated frames in a row (≥ 1)
    compensate_skew: bool = True  # bring the right view's object centres to the left view's instant
    # follow a marker-less object from the start (TargetMode.OBJECT): a label ("green ball"), a colour
    # or a kind; needs ``detectors``. ``object_intercept`` False aims where it is, not where it will be
    follow_object: Optional[str] = None
    object_intercept: bool = True
    # drive the arm by hand from the start (TargetMode.TELEOP): "marker:ID" (a wristband marker),
    # "hsv:COLOUR" (a glove; needs --detector hsv) or "pose:PATH.onnx" (a body pose model); the
    # teleop scenario uses "marker:<first marker id>" when this is None
    teleop_source: Optional[str] = None
    # the main window's physical STOP and RE-ARM (app.estop_switches): switch names such as "gpio:17",
    # "gamepad:BTN_SOUTH" or "key:F12"; a STOP press stops, only a different RE-ARM switch re-arms
    estop_switches: tuple[str, ...] = ()
    rearm_switches: tuple[str, ...] = ()

    def validate(self) -> None:
        """Raise ValueError naming the bad option and the valid values."""
        if self.detectors:
            items = (self.detectors,) if isinstance(self.detectors, str) else tuple(self.detectors)
            try:
                self.detectors = tuple(parse_detector_list(",".join(str(d) for d in items)))
            except ValueError as exc:
                raise ValueError(f"--detector: {exc}") from None
        if self.detectors:
            object_perception_options(self)  # ValueError naming a bad object_* option
        if self.follow_object is not None:
            if not str(self.follow_object).strip():
                raise ValueError("--follow-object needs a label, e.g. --follow-object \"green ball\"")
            if not self.detectors:
                raise ValueError(f"--follow-object {self.follow_object!r} needs a detector to see objects: "
                                 "add --detector hsv (or circles, desk, onnx:PATH)")
        if self.teleop_source is not None:
            from core.motion.teleop import parse_teleop_source

            try:
                kind, _ = parse_teleop_source(self.teleop_source)
            except ValueError as exc:
                raise ValueError(f"--teleop: {exc}") from None
            if kind == "hsv" and not self.detectors:
                raise ValueError(f"--teleop {self.teleop_source}: a glove is seen by the hsv detector — add --detector hsv")
            if self.follow_object is not None:
                raise ValueError("--teleop and --follow-object both choose what the arm follows: give one of them")
        if self.rig_offset is not None:
            check_rig_offset_option(self.rig_offset)
        parse_camera_spec(self.camera)
        parse_bridge_url(self.bridge)
        if self.scenario not in SCENARIOS:
            raise ValueError(f"unknown --scenario value {self.scenario!r}; valid: {', '.join(SCENARIOS)}")
        if not (isinstance(self.sim_skew_ms, (int, float)) and 0.0 <= self.sim_skew_ms <= MAX_SIM_SKEW_MS):
            raise ValueError(f"--sim-skew-ms {self.sim_skew_ms!r} is outside 0…{MAX_SIM_SKEW_MS:g} ms")
        if self.sim_realism is not None:
            from core.sim.realism import preset_named

            try:
                preset_named(self.sim_realism)
            except ValueError as exc:
                raise ValueError(f"--sim-realism: {exc}") from None
        load_profile(self.robot)  # raises ProfileError naming the valid profiles
        if self.markers:
            load_markers(self.markers)  # raises MarkersError naming the file and the key
        if self.remote is not None:
            from core.remote.link import check_endpoint

            check_endpoint(self.remote)  # ValueError with an example
            if self.simulated_clock:
                raise ValueError("--remote runs at the served desk's pace: it cannot run on a simulated clock (--fast)")
        if self.remote_credentials and not self.remote:
            raise ValueError("--credentials belongs to --remote ENDPOINT (the desk another machine serves)")


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
    hand_eye: Optional[HandEyeResult] = None  # the camera→arm calibration in use (None: nominal/exact)
    camera_to_robot: str = ""  # status-bar text, see camera_to_robot_state()
    tool_marker: Optional[ToolMarker] = None  # the marker the arm carries (hand-eye sweep)
    markers: Optional[MarkersConfig] = None  # the markers the user configured (names, actions)
    # marker-less objects located in 3D by ``options.detectors`` (None when none were given)
    object_perception: Optional[StereoObjectPerception] = None

    @classmethod
    def create(cls, options: SessionOptions) -> "DeskSession":
        options.validate()
        fit_opencv_threads()  # a CPU quota below the cores OpenCV sees: its pool would only spin (core.cpu_budget)
        clock = SimClock() if options.simulated_clock else WallClock()
        profile = load_profile(options.robot)
        kinematics = build_kinematics(profile)
        # the simulated desk stands in for missing cameras only when the arm is simulated too
        simulated_arm = is_simulated_bridge(options.bridge)  # sim:// or the emulated RTX (rtx:sim)
        remote_bridge = None
        if options.remote:  # another machine's cameras and arm; never the simulated desk instead
            from core.remote.desk import open_remote_desk

            credential = None
            if options.remote_credentials:
                from core.remote.security import load_credential

                credential = load_credential(options.remote_credentials)  # CredentialError names the file
            camera, remote_bridge = open_remote_desk(options.remote, profile, clock=clock, credential=credential)
            banner = f"REMOTE — {options.remote}"
        else:
            camera, banner = open_camera(options.camera, scenario=options.scenario, clock=clock, fps=options.fps,
                                         fallback_to_sim=simulated_arm)
        banners = [banner] if banner else []
        if getattr(camera, "kind", "") == "replay":
            if not simulated_arm:  # a recorded scene never drives a real arm
                camera.disconnect()
                raise ValueError(f"--camera {options.camera}: a recording drives only the simulated arm (--bridge "
                                 "sim://) — a real arm would reach for objects that are not on the desk")
            banners += list(camera.recording.compatibility_warnings(options.robot)) + list(camera.warnings)
        if options.remote and not options.calibration:  # the served camera_info pair
            calibration, note = camera.calibration(), ""
        else:
            calibration, note = load_session_calibration(camera, options.calibration)
        if note:
            banners.append(note)
        offset = tuple(options.rig_offset) if options.rig_offset is not None else None
        if offset is not None and any(offset):
            if hasattr(camera, "set_rig_offset"):
                camera.set_rig_offset(offset)
            else:
                banners.append(f"--rig-offset only moves the simulated desk's rig; {camera.name} ignores it")
        if options.sim_skew_ms:
            if getattr(camera, "kind", "") == "sim":
                camera.skew_s = options.sim_skew_ms / 1000.0
            else:
                banners.append(f"--sim-skew-ms only delays the simulated desk's right view; {camera.name} ignores it")
        if options.sim_realism is not None:
            from core.sim.realism import preset_named

            if getattr(camera, "kind", "") == "sim":
                camera.realism = preset_named(options.sim_realism)
            elif preset_named(options.sim_realism) is not None:
                banners.append(f"--sim-realism only changes the simulated desk's images; {camera.name} ignores it")
        tool_marker = tool_marker_of(profile)
        if hasattr(camera, "set_tool_marker"):
            try:  # the simulated arm carries the tool marker
                camera.set_tool_marker(tool_marker)
            except ValueError as exc:
                banners.append(f"simulated tool marker not drawn: {exc}")
        if options.remote and not options.hand_eye:  # the server's /tf_static (its own hand-eye)
            base_T_camera, hand_eye, state, note = (camera.base_T_camera(), None,
                                                    f"camera→arm: as served by {options.remote}", "")
        else:
            base_T_camera, hand_eye, state, note = resolve_base_T_camera(camera, options.hand_eye)
        if note:
            banners.append(note)
        markers, note = markers_for_session(options.markers)
        if note:
            banners.append(note)
        ids = markers.ids if (options.markers or markers.source) else tuple(options.marker_ids)
        perception = StereoMarkerPerception(calibration, base_T_camera, marker_ids=ids, dictionary=markers.dictionary)
        mode = TargetMode.CUPS if options.scenario == "cups" else TargetMode.FOLLOW
        targeter = Targeter(clock, mode=mode, follow_id=ids[0], cup_ids=ids[:2],
                            lissajous=lissajous_for(profile, kinematics))
        targeter.set_arm(kinematics, profile)  # object goals: clipped to the workspace, the arm's tool speed
        if options.follow_object is not None:
            targeter.set_object_follow_params(replace(targeter.follower.params, intercept=bool(options.object_intercept)))
            targeter.set_follow_object(str(options.follow_object).strip())
            targeter.set_mode(TargetMode.OBJECT)
        teleop_source = options.teleop_source
        if teleop_source is None and options.scenario == "teleop" and options.follow_object is None:
            teleop_source = f"marker:{ids[0]}"
        if teleop_source is not None:
            from core.motion.teleop import TeleopController, make_hand_source, reachable_target_box

            margin = float(getattr(getattr(profile, "workspace", None), "desk_margin_m", 0.0) or 0.0)
            source = make_hand_source(teleop_source, calibration, base_T_camera)
            targeter.set_teleop(TeleopController(source, reachable_target_box(kinematics, margin)))
            targeter.set_mode(TargetMode.TELEOP)
        controller = ArmController(profile, kinematics)
        object_perception = None
        if options.detectors:  # "hsv" with its default colours, every detector with its defaults
            object_perception = StereoObjectPerception(calibration, base_T_camera,
                                                       [make_detector(name) for name in options.detectors],
                                                       **object_perception_options(options))
        bridge = remote_bridge or open_bridge(options.bridge, profile, clock=clock)
        return cls(options, clock, profile, kinematics, camera, calibration, perception, targeter,
                   controller, bridge, banners, hand_eye=hand_eye, camera_to_robot=state, tool_marker=tool_marker,
                   markers=markers, object_perception=object_perception)

    def use_hand_eye(self, result: HandEyeResult, path=None) -> None:
        """A camera→arm calibration saved from the window: perception maps to robot_base with
        it from the next frame on, and the status bar says so."""
        self.perception.base_T_camera = np.asarray(result.base_T_camera, dtype=np.float64).copy()
        if self.object_perception is not None:  # the objects map to robot_base through it too
            self.object_perception.geometry.base_T_camera = self.perception.base_T_camera
            self.object_perception.base_T_camera = self.perception.base_T_camera
        self.hand_eye = result
        self.camera_to_robot = f"camera→arm: calibrated, {result.rms_mm:.1f} mm RMS"

    def camera_to_robot_state(self) -> str:
        """Status-bar text: "camera→arm: calibrated, 1.8 mm RMS", "camera→arm: NOMINAL — run
        calibration" or "camera→arm: simulated rig (exact)"."""
        return self.camera_to_robot

    @property
    def hand_eye_pair_id(self) -> str:
        """The camera pair id a hand-eye file of this session's cameras names."""
        return hand_eye_pair_id(self.camera)

    def control_schedule(self):
        """A fresh ControlSchedule for this session's controller and bridge (its rate cap)."""
        return schedule_for(self.controller.period_s, self.bridge, self.options.event_driven)

    def real_arm_refusal(self, bridge_url: str) -> str:
        """Why switching to ``bridge_url`` is refused ("" when it is not): a real arm never
        follows the simulated desk that stands in for missing cameras — only a user who asked
        for ``--camera sim`` gets a real arm on the simulated scene."""
        try:
            simulated_arm = is_simulated_bridge(bridge_url)
        except ValueError:
            return ""  # not a bridge URL at all: open_bridge says so
        if getattr(self.camera, "kind", "") == "remote":
            return (f"{bridge_url}: not connected — this window shows a desk served by another machine; its arm "
                    "is driven there. Connect an arm to the serving machine (deskarm serve --bridge …)")
        if not simulated_arm and getattr(self.camera, "kind", "") == "replay":
            return (f"{bridge_url}: not connected — the views replay a recording; a real arm would reach for "
                    "objects that are not on the desk. Restart without --camera replay:… to drive it")
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


def object_perception_options(options: SessionOptions) -> dict:
    """The ``StereoObjectPerception`` keyword options a session's ``options`` choose (ValueError,
    naming the option, for a value out of range)."""
    kw = dict(roi_search=bool(options.object_roi_search), full_frame_every=options.object_full_frame_every,
              tracker=options.object_tracker, reseed_every=options.object_reseed_every,
              detect_every=options.object_detect_every, min_hits=options.object_min_hits,
              compensate_skew=bool(options.compensate_skew))
    for name in ("full_frame_every", "reseed_every", "detect_every", "min_hits"):
        value = kw[name]
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ValueError(f"object_{name} = {value!r} must be a whole number ≥ 1")
    return kw


def freeze_startup_objects() -> None:
    """Collect once and move everything alive so far (modules, models, the session) out of the
    garbage collector's reach (``gc.freeze``): the young-generation collections of a running
    loop then stay short — one took 8 ms, a visible hiccup in the frame → command latency.
    Called by the app's entry points (window, headless run) once the session is built."""
    import gc

    gc.collect()
    gc.freeze()


def check_rig_offset_option(offset) -> tuple[float, ...]:
    """``--rig-offset`` as 6 floats (m, rad), or ValueError naming the option and the limits."""
    try:
        values = tuple(float(v) for v in offset)
    except (TypeError, ValueError):
        values = ()
    if len(values) != 6 or not all(map(math.isfinite, values)):
        raise ValueError(f"--rig-offset {offset!r}: need 6 finite numbers DX,DY,DZ,ROLL,PITCH,YAW (m, degrees)")
    if any(abs(v) > 0.2 for v in values[:3]) or any(abs(v) > math.radians(30.0) + 1e-12 for v in values[3:]):
        raise ValueError("--rig-offset is outside the valid range: |DX|,|DY|,|DZ| ≤ 0.2 m and "
                         "|ROLL|,|PITCH|,|YAW| ≤ 30°")
    return values


def hand_eye_pair_id(camera) -> str:
    """The pair id a hand-eye file must name for ``camera`` (a moved simulated rig is another pair)."""
    return str(getattr(camera, "hand_eye_pair_id", None) or camera.pair_id)


def resolve_base_T_camera(camera, hand_eye_path: Optional[str]):
    """(base_T_camera, HandEyeResult or None, status text, banner) for the session's perception.

    A given ``hand_eye_path`` must load (ValueError naming the file otherwise); without one the
    saved default is used when it is for this camera pair. A file for another pair is ignored
    with a banner. The simulated desk's exact rig needs no file.
    """
    from core.handeye import HandEyeFileError, default_hand_eye_path, load_hand_eye

    nominal = camera.base_T_camera()
    if getattr(camera, "kind", "") == "replay" and not hand_eye_path:
        return nominal, None, "camera→arm: as recorded", ""  # the recording's own pose
    if nominal is None:
        from core.sim.rig import SimRig

        nominal = SimRig().base_T_camera  # nominal mount until a hand-eye calibration exists
    true_T = getattr(camera, "true_base_T_camera", None)
    exact_sim = camera.kind == "sim" and true_T is not None and np.allclose(true_T(), nominal)
    nominal_state = ("camera→arm: simulated rig (exact)" if exact_sim
                     else "camera→arm: NOMINAL — run calibration")
    pair = hand_eye_pair_id(camera)
    if hand_eye_path:
        try:
            result, warning = load_hand_eye(hand_eye_path, expected_pair=pair)
        except HandEyeFileError as exc:
            raise ValueError(f"--hand-eye: {exc}") from None
    else:
        path = default_hand_eye_path()
        if exact_sim or not path.is_file():
            return nominal, None, nominal_state, ""
        try:
            result, warning = load_hand_eye(path, expected_pair=pair)
        except HandEyeFileError as exc:
            return nominal, None, nominal_state, f"camera→arm NOMINAL: {exc}"
    if warning:
        return nominal, None, nominal_state, f"camera→arm NOMINAL: {warning}"
    return (np.asarray(result.base_T_camera, float), result,
            f"camera→arm: calibrated, {result.rms_mm:.1f} mm RMS", "")


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
