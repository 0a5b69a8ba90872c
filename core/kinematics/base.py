"""What every kinematics solver shares: the IK result, pose helpers and message formatting.

The solvers (``rrr``, ``delta``, ``clik`` in this package) all offer::

    fk(q) -> ndarray (3,)              tool point in robot_base (m)
    chain_points(q) -> ndarray (N, 3)  points base → tool, for drawing
    ik(base_p_target, q_current) -> IKResult   position only; never raises on "unreachable"
    jacobian(q) -> ndarray (3, n)      d(base_p_tool)/dq
    workspace_radius_range(), workspace_outline_side()

and the 6-DOF-capable URDF solver adds ``fk_pose(q) -> 4x4`` and ``ik_pose(oMdes, q_current,
weights)``. ``IKResult`` here has the fields of ``rrr.IKResult`` plus the solver's
iterations, residual and orientation error. No Qt and no Pinocchio here.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

MAX_JOINTS = 16  # more joints than this in one chain is not a desk arm
# A finite target farther than this many times the arm's reach is solved as the point in its
# direction at that distance: squared errors of targets like 1e308 m overflow to inf (and their
# differences to NaN), while the nearest reachable point moves by less than reach² / distance
FAR_TARGET_FACTOR = 1e3

class ProfileError(ValueError):
    """A robot profile cannot be used; the message names the file, the key and the fix."""


@dataclass(frozen=True)
class IKResult:
    """Answer of an IK solve; never raised as an exception, even when unreachable."""

    q: tuple[float, ...]  # rad or m; always within the joint limits
    success: bool  # the target was reached within the solver's tolerance
    reachable: bool  # the solver found the target reachable (same as success for CLIK)
    error_m: float  # |target - base_p_reached| (m); inf for a non-finite target
    base_p_reached: tuple[float, float, float]  # FK(q) in robot_base: the target or the nearest point found
    branches: tuple[tuple[float, ...], ...]  # exact solutions found, q first; () if none
    message: str = ""  # "" or what went wrong, e.g. "out of reach by 23 mm"
    iterations: int = 0  # solver iterations over all attempts (0 for closed-form solvers)
    residual: float = 0.0  # norm of the weighted error the solver minimised (m and rad mixed)
    error_rad: float = 0.0  # orientation error (rad) of a pose solve; 0 for position solves
    restarts: int = 0  # attempts after the first (seeds and random restarts)


def format_distance(error_m: float) -> str:
    """A distance for people: "0.1 mm", "23 mm", or metres when absurdly large."""
    mm = error_m * 1000.0
    if not math.isfinite(mm) or mm >= 1e6:
        return f"{error_m:.3g} m"
    if mm >= 10.0:
        return f"{mm:.0f} mm"
    return f"{mm:.2g} mm"


def all_finite(values: Sequence[float]) -> bool:
    """True when every value is a finite number (no NaN, no ±inf)."""
    return all(math.isfinite(v) for v in values)


def bring_near(p: Sequence[float], radius_m: float) -> tuple[float, float, float]:
    """``p`` (finite, m) moved towards the origin along its ray until no coordinate exceeds
    ``radius_m``; unchanged when already that near. Never overflows, whatever ``p``."""
    x, y, z = (float(v) for v in p)
    m = max(abs(x), abs(y), abs(z))
    if not m > radius_m:
        return (x, y, z)
    s = radius_m / m
    return (x * s, y * s, z * s)


def distance_m(a: Sequence[float], b: Sequence[float]) -> float:
    """|a − b| (m) without intermediate overflow; inf when it exceeds the float range or is NaN."""
    d = math.hypot(float(a[0]) - float(b[0]), float(a[1]) - float(b[1]), float(a[2]) - float(b[2]))
    return math.inf if math.isnan(d) else d


def rpy_to_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rotation matrix R = Rz(yaw) · Ry(pitch) · Rx(roll) (URDF/ROS fixed-axis convention), rad.

    A NaN or infinite angle gives a matrix of NaN (math.cos would raise for ±inf), which the
    solvers answer as a non-finite target.
    """
    if not (math.isfinite(roll) and math.isfinite(pitch) and math.isfinite(yaw)):
        return np.full((3, 3), math.nan)
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def matrix_to_rpy(R: np.ndarray) -> tuple[float, float, float]:
    """(roll, pitch, yaw) rad of a rotation matrix, inverse of ``rpy_to_matrix`` (pitch in ±π/2)."""
    R = np.asarray(R, dtype=float)
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if abs(math.cos(pitch)) < 1e-12:  # gimbal lock: put the whole turn in yaw
        return 0.0, pitch, math.atan2(-R[0, 1], R[1, 1])
    return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])


def pose_parts(base_T_target: Any) -> tuple[np.ndarray, np.ndarray]:
    """(position (3,), rotation (3, 3)) of a pose given as a pinocchio SE3 or a 4x4 matrix."""
    if hasattr(base_T_target, "rotation") and hasattr(base_T_target, "translation"):
        p = np.array(base_T_target.translation, dtype=float).reshape(3)
        R = np.array(base_T_target.rotation, dtype=float).reshape(3, 3)
        return p, R
    T = np.asarray(base_T_target, dtype=float)
    if T.shape != (4, 4):
        raise ValueError(f"a pose must be a pinocchio SE3 or a 4x4 matrix, got shape {T.shape}")
    return T[:3, 3].copy(), T[:3, :3].copy()


def pose_matrix(p: Sequence[float], R: np.ndarray) -> np.ndarray:
    """The 4x4 homogeneous matrix of position ``p`` (m) and rotation ``R``."""
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


def rotation_angle(R_a: np.ndarray, R_b: np.ndarray) -> float:
    """Angle (rad) of the rotation taking ``R_b`` to ``R_a``."""
    c = (float(np.trace(np.asarray(R_a) @ np.asarray(R_b).T)) - 1.0) * 0.5
    return math.acos(min(1.0, max(-1.0, c)))
