"""Image-based visual servoing (IBVS) of an eye-in-hand camera on a URDF arm.

A point feature at normalised image coordinates (x, y) = ((u − cx)/fx, (v − cy)/fy) of a point at
depth Z moves, for a camera twist (v, ω) in the camera frame, as ṡ = L(x, y, Z) · (v, ω) with the
classic interaction matrix

    L = [[−1/Z,    0, x/Z,     x·y, −(1 + x²),  y],
         [   0, −1/Z, y/Z, 1 + y²,      −x·y, −x]]

(``interaction_matrix``; ``interaction_matrix_px`` scales it to pixels). Z comes from a range
sensor along the camera axis or from the object's known size (``depth_from_size``).

``IbvsController`` turns an image error into joint motion:

- ``mode="full"``: the textbook law v_c = −λ L⁺ (s − s*), all six twist components;
- ``mode="translate"`` (default, for pressing things): the camera's optical axis is held on a
  direction in robot_base (straight down for a panel lying on a desk) by a proportional
  rotation, the spin about the axis is left alone, the forward speed is commanded by the caller
  (the approach), and the two lateral translations cancel the image error: ṡ = ṡ* − λ (s − s*),
  solved exactly from L's translational columns (a point needs no more). One point fixes two
  DOF, so with the full law a single point is reached mostly by rotating the camera — which
  swings a tool 12 cm ahead of it sideways; holding the axis keeps the press perpendicular.

The twist becomes joint velocities through the camera frame's Jacobian (Pinocchio,
``LOCAL`` frame: camera axes at the camera) by damped least squares, scaled down as a whole
until every joint is inside its velocity limit, integrated one tick, and then clamped as
everywhere (``core.motion.safety.limit_step`` and ``clamp_to_limits``).

The desired feature point s* is configurable: a fixed pixel, or (default) where the tool's axis
crosses depth Z in the image — the tool tip and the camera both sit on the hand, the tool's axis
parallel to the optical axis but offset (assistive_5dof: 5 cm below it in the image, 12 cm ahead),
so a target on that point's ray is straight ahead of the tool whatever the distance.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np
import pinocchio as pin

from core.motion.safety import clamp_to_limits, limit_step

DAMPING = 1e-4  # damped least squares: (JᵀJ + DAMPING·I)⁻¹ Jᵀ


def interaction_matrix(x: float, y: float, Z: float) -> np.ndarray:
    """The 2x6 interaction matrix of a point at normalised coordinates (x, y) and depth Z (m)."""
    if not Z > 0:
        raise ValueError(f"depth Z = {Z} m: a point in front of the camera has Z > 0")
    return np.array([
        [-1.0 / Z, 0.0, x / Z, x * y, -(1.0 + x * x), y],
        [0.0, -1.0 / Z, y / Z, 1.0 + y * y, -x * y, -x],
    ])


def interaction_matrix_px(u: float, v: float, Z: float, K: np.ndarray) -> np.ndarray:
    """The interaction matrix in pixels: d(u, v)/dt = L_px · (v, ω) for pixel (u, v) at depth Z."""
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    L = interaction_matrix((u - cx) / fx, (v - cy) / fy, Z)
    return np.diag([fx, fy]) @ L


def depth_from_size(size_px: float, size_m: float, focal_px: float) -> Optional[float]:
    """Depth (m) of an object of known size ``size_m`` that spans ``size_px`` pixels (pinhole)."""
    if not (size_px > 0 and size_m > 0):
        return None
    return float(focal_px * size_m / size_px)


@dataclass(frozen=True)
class IbvsConfig:
    """Gains, limits and the desired feature point of ``IbvsController``."""

    gain: float = 2.0  # λ (1/s): the image error decays as e^(−λ t)
    mode: str = "translate"  # "translate" (axis held, lateral translations) or "full" (−λ L⁺ e)
    feature_px: Optional[tuple[float, float]] = None  # fixed s* (px); None: the tool axis at depth Z
    axis_direction: tuple[float, float, float] = (0.0, 0.0, -1.0)  # translate: optical axis held on this (robot_base) …
    axis_tilt_rad: float = 0.0  # … tilted this much towards the base's z axis, in the arm's vertical plane
    axis_gain: float = 3.0  # translate: 1/s on the axis error (rad)
    max_linear_speed_m_s: float = 0.08  # the camera's lateral + forward speed is clamped to this
    max_angular_speed_rad_s: float = 0.6
    speed_scale: float = 1.0  # fraction of each joint's velocity limit that may be used (0…1]

    def __post_init__(self) -> None:
        if self.mode not in ("translate", "full"):
            raise ValueError(f"IBVS mode {self.mode!r}: use 'translate' or 'full'")
        if not 0.0 < self.gain <= 50.0:
            raise ValueError(f"IBVS gain = {self.gain}: need 0 < gain ≤ 50 (1/s)")
        if not (0.0 < self.max_linear_speed_m_s <= 1.0 and 0.0 < self.max_angular_speed_rad_s <= 5.0):
            raise ValueError("IBVS speed limits: need 0 < linear ≤ 1 m/s and 0 < angular ≤ 5 rad/s")
        if not 0.0 < self.speed_scale <= 1.0:
            raise ValueError(f"IBVS speed_scale = {self.speed_scale}: need 0 < scale ≤ 1")
        if not 0.0 <= self.axis_tilt_rad <= 1.4:
            raise ValueError(f"IBVS axis_tilt_rad = {self.axis_tilt_rad}: need 0…1.4 rad")
        if np.linalg.norm(self.axis_direction) < 1e-9:
            raise ValueError("IBVS axis_direction must be a non-zero vector")


@dataclass(frozen=True)
class IbvsStep:
    """What one servo tick did."""

    q: tuple[float, ...]  # joint values after the tick (clamped)
    qdot: np.ndarray  # joint velocities applied (rad/s)
    twist: np.ndarray  # camera twist asked for (v, ω) in the camera frame
    error_px: np.ndarray  # s − s* (px)
    feature_px: tuple[float, float]  # s* used
    clamped: bool  # a joint limit or rate clamp changed the step


class IbvsController:
    """Point-feature IBVS for an eye-in-hand camera on a ``ClikKinematics`` arm."""

    def __init__(self, kinematics, K: np.ndarray, config: IbvsConfig = IbvsConfig()):
        if not kinematics.camera_frame or not kinematics.model.existFrame(kinematics.camera_frame):
            raise ValueError(f"robot profile {kinematics.profile.name!r} has no eye-in-hand camera frame: "
                             f"set geometry.camera_frame in its .toml")
        self.kinematics = kinematics
        self.profile = kinematics.profile
        self.K = np.asarray(K, dtype=float)
        self.config = config
        self._model = kinematics.model
        self._data = kinematics.new_data()  # this controller's own
        self._camera_fid = self._model.getFrameId(kinematics.camera_frame)
        q0 = kinematics.q_home
        camera_T_tool = np.linalg.inv(kinematics.camera_pose(q0)) @ kinematics.fk_pose(q0)
        self.camera_p_tool = camera_T_tool[:3, 3].copy()  # tool tip in the camera frame (m)
        self.camera_axis_tool = camera_T_tool[:3, 0].copy()  # the tool's pointing axis (its x) in the camera frame
        self._vlim = np.array(self.profile.velocity_limits, dtype=float) * config.speed_scale

    # -- geometry ---------------------------------------------------------------------------

    def camera_jacobian(self, q: Sequence[float]) -> np.ndarray:
        """Camera twist Jacobian (6, n) in the camera frame: (v, ω) = J · q̇."""
        J = pin.computeFrameJacobian(self._model, self._data, np.asarray(q, dtype=float), self._camera_fid,
                                     pin.ReferenceFrame.LOCAL)
        return np.array(J, dtype=float)

    def base_T_camera(self, q: Sequence[float]) -> np.ndarray:
        return self.kinematics.camera_pose(q)

    def feature_point(self, Z: float) -> tuple[float, float]:
        """s* (px): the configured pixel, or where a point at depth Z on the tool's axis appears."""
        if self.config.feature_px is not None:
            return (float(self.config.feature_px[0]), float(self.config.feature_px[1]))
        p = self.tool_axis_point(Z)
        uvw = self.K @ p
        return (float(uvw[0] / uvw[2]), float(uvw[1] / uvw[2]))

    def tool_axis_point(self, Z: float) -> np.ndarray:
        """The point of the tool's axis at camera depth Z (camera frame, m)."""
        a = self.camera_axis_tool
        s = (Z - self.camera_p_tool[2]) / a[2] if abs(a[2]) > 1e-9 else 0.0
        return self.camera_p_tool + s * a

    def tool_distance(self, Z: float) -> float:
        """How far (m) the tool tip still is from a surface point at camera depth Z, along its axis."""
        a = self.camera_axis_tool
        return float((Z - self.camera_p_tool[2]) / a[2]) if abs(a[2]) > 1e-9 else float("nan")

    # -- control ----------------------------------------------------------------------------

    def desired_axis(self, base_T_camera: np.ndarray) -> np.ndarray:
        """The direction (robot_base, unit) the optical axis is held on: ``axis_direction``, tilted
        by ``axis_tilt_rad`` towards the base's z axis in the vertical plane through the camera
        (a 5-DOF arm's hand axis always lies in that plane; tilting the hand back towards the base
        lets a folded arm reach low targets near its foot)."""
        c = self.config
        d = np.asarray(c.axis_direction, dtype=float)
        d = d / np.linalg.norm(d)
        if c.axis_tilt_rad == 0.0:
            return d
        horizontal = np.array([base_T_camera[0, 3], base_T_camera[1, 3], 0.0])
        n = np.linalg.norm(horizontal)
        if n < 1e-6:
            return d
        tilted = np.cos(c.axis_tilt_rad) * d - np.sin(c.axis_tilt_rad) * horizontal / n
        return tilted / np.linalg.norm(tilted)

    def _axis_hold(self, base_T_camera: np.ndarray) -> np.ndarray:
        """Angular velocity (camera frame) turning the optical axis onto ``desired_axis``; no spin."""
        R = base_T_camera[:3, :3]
        w = R.T @ (self.config.axis_gain * np.cross(R[:, 2], self.desired_axis(base_T_camera)))
        w[2] = 0.0  # leave the spin about the axis alone
        return w

    def camera_twist(self, s_px: Sequence[float], Z: float, base_T_camera: np.ndarray,
                     forward_speed_m_s: float = 0.0, Z_rate_m_s: Optional[float] = None) -> tuple[np.ndarray, np.ndarray, tuple]:
        """(twist (6,), error (2,), s*) for the image point ``s_px`` at depth Z (m).

        ``forward_speed_m_s``: the approach along the optical axis (translate mode); the feature
        point's own motion as Z shrinks is fed forward.
        """
        c = self.config
        s = np.asarray(s_px, dtype=float).reshape(2)
        target = self.feature_point(Z)
        e = s - np.asarray(target)
        L = interaction_matrix_px(s[0], s[1], Z, self.K)
        if c.mode == "full":
            twist = -c.gain * np.linalg.pinv(L) @ e
        else:
            w = self._axis_hold(base_T_camera)
            vz = float(forward_speed_m_s)
            # s* moves as Z shrinks (the tool axis's image slides): feed that forward
            s_dot_target = np.zeros(2)
            if c.feature_px is None and vz != 0.0:
                dZ = -vz if Z_rate_m_s is None else Z_rate_m_s
                eps = 1e-4
                hi = np.asarray(self.feature_point(Z + eps))
                s_dot_target = (hi - np.asarray(target)) / eps * dZ
            rhs = s_dot_target - c.gain * e - L[:, 2] * vz - L[:, 3:] @ w
            vxy = np.linalg.solve(L[:, :2], rhs)
            twist = np.array([vxy[0], vxy[1], vz, w[0], w[1], w[2]])
        lin = np.linalg.norm(twist[:3])
        if lin > c.max_linear_speed_m_s:
            twist[:3] *= c.max_linear_speed_m_s / lin
        ang = np.linalg.norm(twist[3:])
        if ang > c.max_angular_speed_rad_s:
            twist[3:] *= c.max_angular_speed_rad_s / ang
        return twist, e, target

    def joint_velocity(self, q: Sequence[float], twist: np.ndarray) -> np.ndarray:
        """q̇ (rad/s) for a camera twist (camera frame), by damped least squares, scaled as a
        whole so no joint exceeds its velocity limit (the direction of motion is kept)."""
        J = self.camera_jacobian(q)
        n = J.shape[1]
        qdot = np.linalg.solve(J.T @ J + DAMPING * np.eye(n), J.T @ np.asarray(twist, dtype=float))
        ratio = np.max(np.abs(qdot) / self._vlim) if np.all(self._vlim > 0) else 0.0
        if ratio > 1.0:
            qdot = qdot / ratio
        return qdot

    def joint_velocity_axis_held(self, q: Sequence[float], base_T_camera: np.ndarray, v_camera: np.ndarray) -> np.ndarray:
        """q̇ (rad/s) for the camera's linear velocity ``v_camera`` (camera frame) while its optical
        axis is steered onto ``desired_axis`` and its spin is left free (translate mode).

        Five equations for five joints: the three linear velocities and the axis's two sideways
        rates (ż = ω × z). The wanted ż is ``axis_gain``·(d − z) plus the change of d itself as the
        camera moves (with a tilt, d turns with the arm's vertical plane: a base yaw tilts the
        camera out of its old plane, which is right, and must not be fought).
        """
        R = base_T_camera[:3, :3]
        z = R[:, 2]
        d = self.desired_axis(base_T_camera)
        p_dot = R @ np.asarray(v_camera, dtype=float)
        speed = float(np.linalg.norm(p_dot))
        d_dot = np.zeros(3)
        if speed > 1e-9 and self.config.axis_tilt_rad != 0.0:
            eps = 1e-4
            moved = base_T_camera.copy()
            moved[:3, 3] += eps * p_dot / speed
            d_dot = (self.desired_axis(moved) - d) / eps * speed
        z_dot = self.config.axis_gain * (d - z) + d_dot
        z_dot_camera = R.T @ (z_dot - (z_dot @ z) * z)
        J = self.camera_jacobian(q)
        A = np.vstack([J[:3], J[4], -J[3]])  # ż (camera frame) = (ω_y, −ω_x)
        b = np.concatenate([np.asarray(v_camera, dtype=float), z_dot_camera[:2]])
        n = A.shape[1]
        qdot = np.linalg.solve(A.T @ A + DAMPING * np.eye(n), A.T @ b)
        ratio = np.max(np.abs(qdot) / self._vlim) if np.all(self._vlim > 0) else 0.0
        if ratio > 1.0:
            qdot = qdot / ratio
        return qdot

    def integrate(self, q: Sequence[float], qdot: np.ndarray, dt: float) -> tuple[tuple[float, ...], bool]:
        """q + q̇·dt, rate-limited (``limit_step``) and clamped into the joint limits."""
        q = tuple(float(v) for v in q)
        wanted = tuple(float(a + b * dt) for a, b in zip(q, qdot))
        stepped = limit_step(q, wanted, tuple(float(v * dt) for v in self._vlim))
        clamped_q, changed = clamp_to_limits(stepped, self.profile)
        return clamped_q, bool(changed or any(abs(a - b) > 1e-12 for a, b in zip(stepped, wanted)))

    def step(self, q: Sequence[float], s_px: Sequence[float], Z: float, dt: float,
             forward_speed_m_s: float = 0.0) -> IbvsStep:
        """One servo tick: image point s at depth Z → the next joint values."""
        T = self.base_T_camera(q)
        twist, e, target = self.camera_twist(s_px, Z, T, forward_speed_m_s)
        if self.config.mode == "full":
            qdot = self.joint_velocity(q, twist)
        else:
            qdot = self.joint_velocity_axis_held(q, T, twist[:3])
        q_next, clamped = self.integrate(q, qdot, dt)
        return IbvsStep(q=q_next, qdot=qdot, twist=twist, error_px=e, feature_px=target, clamped=clamped)

    def move_along_axis(self, q: Sequence[float], speed_m_s: float, dt: float) -> IbvsStep:
        """One tick moving the camera (and the tool) along the optical axis at ``speed_m_s``
        (negative: back), the axis held on ``axis_direction`` — the blind press of the ACT phase."""
        T = self.base_T_camera(q)
        w = self._axis_hold(T)
        twist = np.array([0.0, 0.0, float(speed_m_s), w[0], w[1], w[2]])
        qdot = self.joint_velocity_axis_held(q, T, twist[:3])
        q_next, clamped = self.integrate(q, qdot, dt)
        return IbvsStep(q=q_next, qdot=qdot, twist=twist, error_px=np.zeros(2), feature_px=(np.nan, np.nan),
                        clamped=clamped)


def aimed_pose(kinematics, K: np.ndarray, point_base: Sequence[float], q_start: Sequence[float],
               axis_tilt_rad: float = 0.0, frame_dt_s: float = 1.0 / 30.0, steps: int = 600) -> tuple[float, ...]:
    """Joint values that centre ``point_base`` (robot_base, m) in the eye-in-hand camera, the optical
    axis held as ``IbvsController`` holds it (tilted by ``axis_tilt_rad``): IBVS run from ``q_start``
    for ``steps`` ticks on the exact projection — a pose taught by aiming, not by a camera image
    (the assistive arm's ready pose: the camera on where its panel usually is)."""
    servo = IbvsController(kinematics, K, IbvsConfig(axis_tilt_rad=axis_tilt_rad, feature_px=(K[0, 2], K[1, 2])))
    point = np.append(np.asarray(point_base, dtype=float).reshape(3), 1.0)
    q = tuple(float(v) for v in q_start)
    for _ in range(int(steps)):
        camera_p = np.linalg.inv(kinematics.camera_pose(q)) @ point
        uv = (servo.K @ camera_p[:3])[:2] / camera_p[2]
        q = servo.step(q, uv, float(camera_p[2]), frame_dt_s).q
    return q
