"""Geometry of the simulated stereo rig: two pinhole cameras above the desk.

Defaults follow the published low-cost desk setup: 640x480 images, ~430 px focal length,
~6 cm baseline, mounted ~50 cm above the desk looking down at the arm's workspace.
The right camera is slightly rotated against the left one so rectification has real work.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from core.vision.calibration import StereoCalibration


def look_at(position, target, right_hint=(1.0, 0.0, 0.0)) -> np.ndarray:
    """``base_T_camera`` (4x4) for an OpenCV camera (x right, y down, z forward) at ``position``
    looking at ``target``, its x axis as close to ``right_hint`` as possible. Points in robot_base."""
    position = np.asarray(position, dtype=float)
    z = np.asarray(target, dtype=float) - position
    z /= np.linalg.norm(z)
    x = np.asarray(right_hint, dtype=float)
    x = x - z * float(x @ z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    base_T_camera = np.eye(4)
    base_T_camera[:3, 0], base_T_camera[:3, 1], base_T_camera[:3, 2] = x, y, z
    base_T_camera[:3, 3] = position
    return base_T_camera


def rot_xyz(rx: float, ry: float, rz: float) -> np.ndarray:
    """Rotation matrix from small angles (rad) about x, y, z (Rodrigues of the vector)."""
    R, _ = cv2.Rodrigues(np.array([[rx], [ry], [rz]], dtype=float))
    return R


@dataclass(frozen=True)
class SimRigConfig:
    """Where the virtual cameras are and what they look like."""

    width: int = 640  # px
    height: int = 480  # px
    focal_px: float = 430.0  # px, both axes
    baseline_m: float = 0.06  # distance between the optical centres
    # The rig faces the arm from across the desk: the arm reaches towards the cameras, so it
    # points at objects without covering their markers (seen from behind the arm, the elbow
    # hides what the tool points at).
    position: tuple[float, float, float] = (0.0, 0.42, 0.45)  # midpoint of the rig, robot_base (m)
    look_at: tuple[float, float, float] = (0.0, 0.10, 0.0)  # point both cameras aim at (m)
    right_hint: tuple[float, float, float] = (-1.0, 0.0, 0.0)  # image x axis, roughly (robot_base)
    right_rotation_rad: tuple[float, float, float] = (0.004, -0.012, 0.006)  # right vs left, small
    # where the rig really is against where it was meant to be (a bumped or hand-mounted rig):
    # dx, dy, dz (m, robot_base) and roll, pitch, yaw (rad, about robot_base x, y, z through the
    # rig's midpoint). Renders use the true (offset) mount; ``nominal_base_T_camera`` ignores it.
    mount_offset: tuple[float, float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if not (64 <= self.width <= 4096 and 48 <= self.height <= 4096):
            raise ValueError(f"sim rig size {self.width}x{self.height} is outside 64x48…4096x4096")
        if not (50 <= self.focal_px <= 5000):
            raise ValueError(f"sim rig focal_px = {self.focal_px} is outside 50…5000")
        if not (0.01 <= self.baseline_m <= 0.5):
            raise ValueError(f"sim rig baseline_m = {self.baseline_m} is outside 0.01…0.5")
        check_rig_offset(self.mount_offset)


MAX_OFFSET_M = 0.2
MAX_OFFSET_RAD = np.radians(30.0)


def check_rig_offset(offset) -> tuple[float, ...]:
    """``offset`` (dx, dy, dz m, roll, pitch, yaw rad) as floats, or ValueError naming the limits."""
    try:
        values = tuple(float(v) for v in offset)
    except (TypeError, ValueError):
        raise ValueError(f"rig offset {offset!r} is not 6 numbers (DX,DY,DZ in m, ROLL,PITCH,YAW)") from None
    if len(values) != 6 or not all(np.isfinite(values)):
        raise ValueError(f"rig offset {offset!r} must be 6 finite numbers (DX,DY,DZ in m, ROLL,PITCH,YAW)")
    if any(abs(v) > MAX_OFFSET_M for v in values[:3]) or any(abs(v) > MAX_OFFSET_RAD + 1e-12 for v in values[3:]):
        raise ValueError(f"rig offset {offset!r} is outside |d| ≤ {MAX_OFFSET_M} m and angles ≤ 30°")
    return values


def offset_transform(offset, pivot) -> np.ndarray:
    """4x4 transform (robot_base) that moves a rig by ``offset`` (rotation about ``pivot``)."""
    dx, dy, dz, rx, ry, rz = check_rig_offset(offset)
    R = rot_xyz(rx, ry, rz)
    pivot = np.asarray(pivot, float)
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = pivot - R @ pivot + np.array([dx, dy, dz])
    return T


class SimRig:
    """The simulated stereo camera: poses, intrinsics and its exact calibration."""

    def __init__(self, config: SimRigConfig | None = None):
        self.config = c = config or SimRigConfig()
        self.size = (c.width, c.height)
        self.K = np.array(
            [[c.focal_px, 0.0, (c.width - 1) / 2.0], [0.0, c.focal_px, (c.height - 1) / 2.0], [0, 0, 1.0]]
        )
        mid_T_camera = look_at(c.position, c.look_at, c.right_hint)
        x_axis = mid_T_camera[:3, 0]
        self.base_T_left = mid_T_camera.copy()
        self.base_T_left[:3, 3] = np.asarray(c.position) - x_axis * c.baseline_m / 2
        # right camera: shifted along the left camera's x axis, then slightly rotated
        self.base_T_right = mid_T_camera.copy()
        self.base_T_right[:3, :3] = mid_T_camera[:3, :3] @ rot_xyz(*c.right_rotation_rad).T
        self.base_T_right[:3, 3] = np.asarray(c.position) + x_axis * c.baseline_m / 2
        self.nominal_base_T_left = self.base_T_left.copy()
        if any(c.mount_offset):
            moved = offset_transform(c.mount_offset, c.position)
            self.base_T_left = moved @ self.base_T_left
            self.base_T_right = moved @ self.base_T_right

    @property
    def base_T_camera(self) -> np.ndarray:
        """True pose of camera_left in robot_base (where the renders come from)."""
        return self.base_T_left.copy()

    @property
    def nominal_base_T_camera(self) -> np.ndarray:
        """Where camera_left was meant to be mounted (without ``mount_offset``)."""
        return self.nominal_base_T_left.copy()

    @property
    def is_offset(self) -> bool:
        return any(self.config.mount_offset)

    def camera_T_base(self, side: str) -> np.ndarray:
        """Inverse pose for ``side`` in {"left", "right"}."""
        return np.linalg.inv(self.base_T_left if side == "left" else self.base_T_right)

    def projection(self, side: str) -> np.ndarray:
        """3x4 projection matrix K [R|t] mapping robot_base points to pixels."""
        return self.K @ self.camera_T_base(side)[:3, :]

    def project(self, side: str, base_points: np.ndarray) -> np.ndarray:
        """Pixel coordinates (N,2) of robot_base points (N,3) (no distortion)."""
        pts = np.asarray(base_points, dtype=float).reshape(-1, 3)
        P = self.projection(side)
        h = pts @ P[:, :3].T + P[:, 3]
        return h[:, :2] / h[:, 2:3]

    def depth(self, side: str, base_points: np.ndarray) -> np.ndarray:
        """Depth (camera z, m) of robot_base points in the given camera."""
        T = self.camera_T_base(side)
        pts = np.asarray(base_points, dtype=float).reshape(-1, 3)
        return pts @ T[2, :3] + T[2, 3]

    def calibration(self) -> StereoCalibration:
        """The rig's exact stereo calibration (no distortion)."""
        right_T_left = self.camera_T_base("right") @ self.base_T_left
        return StereoCalibration(
            M1=self.K.copy(), D1=np.zeros((1, 5)), M2=self.K.copy(), D2=np.zeros((1, 5)),
            R=right_T_left[:3, :3].copy(), T=right_T_left[:3, 3].reshape(3, 1).copy(),
            image_size=self.size, source="simulated rig",
        )
