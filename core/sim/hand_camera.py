"""The eye-in-hand camera of the simulated desk: what a camera on the arm's hand sees.

``SimHandCamera`` takes the arm's joint values, finds the camera frame's pose by forward
kinematics (the profile's ``geometry.camera_frame``, an OpenCV optical frame: z forward along the
hand, x right, y down) and renders the desk from there with ``SimDesk.render_camera`` — the same
desk texture, panel, buttons, handle, shading, blur and noise as the stereo rig's views. The arm
itself is not drawn.

Intrinsics: robot profiles carry no camera intrinsics yet, so ``HandCameraConfig`` holds them
(640×480, f = 525 px ≈ a 63° horizontal field of view, a common webcam).

Vibration (optional): the whole hand shakes rigidly — camera and tool tip together — by a small
rotation and translation, each a sum of three sines (4–11 Hz, seeded phases), like a hobby-servo
arm's jitter. ``hand_shake(t)`` is that motion; ``base_T_camera``/``base_T_tool`` include it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from core.sim.desk import ImageBox, SimDesk

VIBRATION_HZ = (4.3, 7.1, 11.3)  # the shake's three components (Hz); amplitudes 1, 0.6, 0.35


@dataclass(frozen=True)
class HandCameraConfig:
    """The hand camera's image and lens, and the hand's shake."""

    width: int = 640  # image width (px)
    height: int = 480  # image height (px)
    fx: float = 525.0  # focal length (px)
    fy: float = 525.0
    cx: Optional[float] = None  # principal point (px); None: the image centre ((w − 1) / 2)
    cy: Optional[float] = None
    max_supersample: int = 2  # textures' supersampling (the rig's views use 4; 2 renders twice as fast up close)
    vibration: bool = False  # shake the hand
    vibration_m: float = 0.0005  # shake amplitude, translation (m, per axis, peak of the main sine)
    vibration_rad: float = math.radians(0.25)  # shake amplitude, rotation (rad, per axis)

    def __post_init__(self) -> None:
        if not (16 <= self.width <= 4096 and 16 <= self.height <= 4096):
            raise ValueError(f"hand camera size {self.width}x{self.height} px: need 16…4096 px a side")
        if not (10.0 <= self.fx <= 10000.0 and 10.0 <= self.fy <= 10000.0):
            raise ValueError(f"hand camera focal lengths {self.fx}, {self.fy} px: need 10…10000 px")
        if not 1 <= self.max_supersample <= 8:
            raise ValueError(f"hand camera max_supersample = {self.max_supersample}: need 1…8")
        if not (0.0 <= self.vibration_m <= 0.01 and 0.0 <= self.vibration_rad <= math.radians(5.0)):
            raise ValueError(f"hand shake {self.vibration_m} m / {self.vibration_rad} rad: need 0…0.01 m and 0…5°")

    @property
    def size(self) -> tuple[int, int]:
        return (self.width, self.height)

    @property
    def K(self) -> np.ndarray:
        """The 3x3 camera matrix (OpenCV's pixel-centre convention)."""
        cx = (self.width - 1) / 2 if self.cx is None else float(self.cx)
        cy = (self.height - 1) / 2 if self.cy is None else float(self.cy)
        return np.array([[self.fx, 0.0, cx], [0.0, self.fy, cy], [0.0, 0.0, 1.0]])


def _rotation(rx: float, ry: float, rz: float) -> np.ndarray:
    """Rotation matrix of a small rotation vector (Rodrigues)."""
    w = np.array([rx, ry, rz])
    a = float(np.linalg.norm(w))
    if a < 1e-12:
        return np.eye(3)
    k = w / a
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(a) * Kx + (1 - math.cos(a)) * Kx @ Kx


@dataclass
class HandFrame:
    """One hand-camera image with its pose and (optionally) the truth boxes."""

    t: float  # capture time (s)
    image: np.ndarray  # BGR uint8
    base_T_camera: np.ndarray  # 4x4, robot_base, shake included
    boxes: Optional[dict[int, ImageBox]] = None  # truth id → visible box (when asked for)


class SimHandCamera:
    """Renders the desk from the profile's eye-in-hand camera frame for joint values q."""

    def __init__(self, desk: SimDesk, kinematics, config: HandCameraConfig = HandCameraConfig(), seed: int = 0):
        if getattr(kinematics, "camera_frame", "") in ("", None):
            raise ValueError(f"robot profile {kinematics.profile.name!r} has no eye-in-hand camera: set "
                             f"geometry.camera_frame in its .toml to a frame of its URDF")
        self.desk = desk
        self.kinematics = kinematics
        self.config = config
        self.K = config.K
        rng = np.random.default_rng([int(seed) & 0x7FFFFFFF, 77])
        self._phases = rng.uniform(0.0, 2 * math.pi, size=(6, len(VIBRATION_HZ)))
        # camera_T_tool is fixed (both on the hand): the tool pose follows the shaken camera
        q0 = kinematics.q_home
        self.camera_T_tool = np.linalg.inv(kinematics.camera_pose(q0)) @ kinematics.fk_pose(q0)

    # -- geometry -------------------------------------------------------------------------

    def hand_shake(self, t: float) -> np.ndarray:
        """camera_T_shaken (4x4): the hand's rigid shake at time t (identity without vibration)."""
        c = self.config
        if not c.vibration:
            return np.eye(4)
        amps = np.array([1.0, 0.6, 0.35])
        s = (amps * np.sin(2 * math.pi * np.array(VIBRATION_HZ) * float(t) + self._phases)).sum(axis=1)
        T = np.eye(4)
        T[:3, :3] = _rotation(*(c.vibration_rad * s[3:]))
        T[:3, 3] = c.vibration_m * s[:3]
        return T

    def base_T_camera(self, q: Sequence[float], t: float = 0.0) -> np.ndarray:
        """The camera's pose (4x4, robot_base) for joints q at time t (shake included)."""
        return self.kinematics.camera_pose(q) @ self.hand_shake(t)

    def base_T_tool(self, q: Sequence[float], t: float = 0.0) -> np.ndarray:
        """The tool's pose (4x4, robot_base) at time t (the same shake as the camera's)."""
        return self.base_T_camera(q, t) @ self.camera_T_tool

    def project(self, base_T_camera: np.ndarray, base_points) -> tuple[np.ndarray, np.ndarray]:
        """Pixels (N, 2) and depths (N,) of robot_base points (N, 3) seen from ``base_T_camera``."""
        pts = np.atleast_2d(np.asarray(base_points, dtype=float))
        camera_p = (np.linalg.inv(base_T_camera) @ np.column_stack([pts, np.ones(len(pts))]).T)[:3]
        uv = (self.K @ camera_p)[:2] / camera_p[2]
        return uv.T, camera_p[2]

    # -- images ---------------------------------------------------------------------------

    def render(self, q: Sequence[float], t: float, boxes: bool = False) -> HandFrame:
        """The hand camera's image for joints q at scenario time t (s)."""
        T = self.base_T_camera(q, t)
        image, truth_boxes = self.desk.render_camera(T, self.K, self.config.size, t, boxes=boxes,
                                                     max_supersample=self.config.max_supersample)
        return HandFrame(t=float(t), image=image, base_T_camera=T, boxes=truth_boxes)
