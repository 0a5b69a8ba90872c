"""Analytic kinematics of a three-arm delta (parallel) robot, as in the delta-robot system.

Frame robot_base: origin on the desk below the base plate's centre, x right, y forward, z up.
The base plate (the three shoulder axes) is ``base_height_m`` above the desk. Arm i lies in the
vertical plane at azimuth φ_i (unit vector u_i); with R the base radius, r the effector radius,
L the upper arm, l the forearm and θ_i the joint angle (0 horizontal and outwards, > 0 down)::

    shoulder  S_i = (0, 0, H) + R u_i
    elbow     E_i = S_i + L (cos θ_i u_i − sin θ_i z)
    effector  |E_i − (P + r u_i)| = l          (P the effector centre; tool = P − tool_offset z)

IK is closed form per arm: with D = P + r u_i − S_i, ρ = D·u_i, h = D_z, the constraint is
ρ cos θ − h sin θ = (L² + |D|² − l²) / 2L. Of its two roots the solver always takes the
"knee out" one (θ = θ_D − α, the upper arm above the shoulder→effector line), the assembly mode
of a working delta, so the answer never jumps between branches. FK intersects the three
spheres of radius l around C_i = E_i − r u_i and keeps the lower point. A target out of reach
(or needing a joint beyond its limits) gives the nearest reachable point found by a damped
least-squares descent in joint space, clamped to the limits on every step.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Optional, Sequence

import numpy as np

from core.kinematics.base import (
    FAR_TARGET_FACTOR,
    IKResult,
    ProfileError,
    all_finite,
    bring_near,
    distance_m,
    format_distance,
)

if TYPE_CHECKING:  # the profile module imports this one (assembly_problem): types only
    from core.kinematics.profile import DeltaGeometry, RobotProfile

EXACT_TOL_M = 1e-9  # an FK point this close to the target counts as reached
LIMIT_TOL_RAD = 1e-9  # a closed-form angle this far outside a limit is snapped onto it
NEAREST_IT_MAX = 60  # iterations of the nearest-point descent per start
NEAREST_EPS_STEP = 1e-7  # the descent stops when the joints move less than this (rad) …
NEAREST_REL_DECREASE = 1e-12  # … or the squared error drops by less than this fraction
DAMP_MIN = 1e-9  # damping floor of the nearest-point descent
ASSEMBLY_GRID = 9  # joint values per axis checked by ``assembly_problem``
WORKSPACE_SAMPLES = 3000  # random in-limit configurations for the approximate workspace


def _unit(phi: float) -> tuple[float, float, float]:
    return (math.cos(phi), math.sin(phi), 0.0)


_NO_CENTRE = ((math.nan, math.nan, math.nan), math.nan)


def _fk_centre(g: DeltaGeometry, u, theta: Sequence[float]):
    """Effector centre P (tuple) and the squared half-chord z² (< 0: the arms cannot meet).

    NaN for both when the effector is undetermined: two forearm spheres share their centre or
    the three centres lie on one line (odd geometries can get there), or a joint is not finite.
    """
    H, R, r, L, l = g.base_height_m, g.base_radius_m, g.effector_radius_m, g.upper_arm_m, g.forearm_m
    C = []
    for (ux, uy, _), th in zip(u, theta):
        rho = R - r + L * math.cos(th)
        C.append((rho * ux, rho * uy, H - L * math.sin(th)))
    (x1, y1, z1), (x2, y2, z2), (x3, y3, z3) = C
    ax, ay, az = x2 - x1, y2 - y1, z2 - z1
    d = math.sqrt(ax * ax + ay * ay + az * az)
    if not d > 0.0:  # also NaN
        return _NO_CENTRE
    ex = (ax / d, ay / d, az / d)
    bx, by, bz = x3 - x1, y3 - y1, z3 - z1
    i = ex[0] * bx + ex[1] * by + ex[2] * bz
    vx, vy, vz = bx - i * ex[0], by - i * ex[1], bz - i * ex[2]
    j = math.sqrt(vx * vx + vy * vy + vz * vz)
    if not j > 0.0:
        return _NO_CENTRE
    ey = (vx / j, vy / j, vz / j)
    ez = (ex[1] * ey[2] - ex[2] * ey[1], ex[2] * ey[0] - ex[0] * ey[2], ex[0] * ey[1] - ex[1] * ey[0])
    x = 0.5 * d
    y = (i * i + j * j - 2.0 * i * x) / (2.0 * j)
    z2s = l * l - x * x - y * y
    z = math.sqrt(max(z2s, 0.0))
    if ez[2] > 0.0:  # keep the lower of the two intersections
        z = -z
    return (
        (x1 + x * ex[0] + y * ey[0] + z * ez[0],
         y1 + x * ex[1] + y * ey[1] + z * ez[1],
         z1 + x * ex[2] + y * ey[2] + z * ez[2]),
        z2s,
    )


def assembly_problem(g: DeltaGeometry, q_min: Sequence[float], q_max: Sequence[float]) -> str:
    """"" when the three arms can meet everywhere in the joint box, else what is wrong.

    Checked on a grid of ``ASSEMBLY_GRID``³ joint values (corners included); the profile loader
    uses it so an impossible geometry is refused when the file is read.
    """
    u = [_unit(a) for a in g.arm_azimuths_rad]
    axes = [np.linspace(lo, hi, ASSEMBLY_GRID) for lo, hi in zip(q_min, q_max)]
    for t1 in axes[0]:
        for t2 in axes[1]:
            for t3 in axes[2]:
                P, z2s = _fk_centre(g, u, (t1, t2, t3))
                if math.isnan(z2s):
                    deg = ", ".join(f"{math.degrees(t):.0f}°" for t in (t1, t2, t3))
                    return (f"at joints ({deg}) the effector's position is undetermined (the forearm ends"
                            " coincide or line up); change base_radius_m, effector_radius_m or the joint range")
                if z2s < 0.0:
                    deg = ", ".join(f"{math.degrees(t):.0f}°" for t in (t1, t2, t3))
                    return (f"geometry.forearm_m = {g.forearm_m:g} is too short for this geometry and"
                            f" joint range: at joints ({deg}) the three forearms cannot meet")
                if P[2] >= g.base_height_m:
                    deg = ", ".join(f"{math.degrees(t):.0f}°" for t in (t1, t2, t3))
                    return f"at joints ({deg}) the effector would rise above the base plate; narrow the joint range"
    return ""


class DeltaKinematics:
    """Closed-form IK and FK, Jacobian and workspace of a delta profile (read-only, shared)."""

    def __init__(self, profile: RobotProfile) -> None:
        if profile.kind != "delta3" or not hasattr(profile.geometry, "forearm_m"):
            raise ProfileError(
                f"{profile.source or profile.name}: DeltaKinematics needs kind 'delta3', got {profile.kind!r}"
            )
        self.profile = profile
        self.geometry: DeltaGeometry = profile.geometry
        g = self.geometry
        self.n_joints = 3
        self.base_height_m = g.base_height_m
        self.base_radius_m = g.base_radius_m
        self.effector_radius_m = g.effector_radius_m
        self.upper_arm_m = g.upper_arm_m
        self.forearm_m = g.forearm_m
        self.tool_offset_m = g.tool_offset_m
        self._u = tuple(_unit(a) for a in g.arm_azimuths_rad)
        self.q_min: tuple[float, ...] = tuple(profile.q_min)
        self.q_max: tuple[float, ...] = tuple(profile.q_max)
        self._mid = tuple(0.5 * (a + b) for a, b in zip(self.q_min, self.q_max))
        self.q_home: tuple[float, ...] = self._clamp(profile.q_home)
        self._samples: Optional[np.ndarray] = None
        # no tool point is farther from robot_base's origin than this (m)
        self.reach_bound_m: float = (g.base_height_m + g.base_radius_m + g.effector_radius_m + g.upper_arm_m
                                     + g.forearm_m + g.tool_offset_m)
        self._far_m = FAR_TARGET_FACTOR * self.reach_bound_m

    # ---------------------------------------------------------------------------------------
    # Forward kinematics

    def fk_tuple(self, q: Sequence[float]) -> tuple[float, float, float]:
        """Tool point in robot_base (m) as a tuple."""
        (x, y, z), _ = _fk_centre(self.geometry, self._u, [float(v) for v in q])
        return (x, y, z - self.tool_offset_m)

    def fk(self, q: Sequence[float]) -> np.ndarray:
        """Tool point ``base_p_tool`` in robot_base (m), shape (3,)."""
        return np.array(self.fk_tuple(q))

    def assembles(self, q: Sequence[float]) -> bool:
        """True when the three forearms can meet at these joint values."""
        return _fk_centre(self.geometry, self._u, [float(v) for v in q])[1] >= 0.0

    def arm_segments(self, q: Sequence[float]) -> np.ndarray:
        """Each arm's shoulder, elbow, effector joint and the effector centre, shape (3, 4, 3)."""
        g = self.geometry
        (px, py, pz), _ = _fk_centre(g, self._u, [float(v) for v in q])
        out = np.empty((3, 4, 3))
        for i, ((ux, uy, _), th) in enumerate(zip(self._u, q)):
            th = float(th)
            sx, sy, sz = g.base_radius_m * ux, g.base_radius_m * uy, g.base_height_m
            c = g.upper_arm_m * math.cos(th)
            out[i, 0] = (sx, sy, sz)
            out[i, 1] = (sx + c * ux, sy + c * uy, sz - g.upper_arm_m * math.sin(th))
            out[i, 2] = (px + g.effector_radius_m * ux, py + g.effector_radius_m * uy, pz)
            out[i, 3] = (px, py, pz)
        return out

    def chain_points(self, q: Sequence[float]) -> np.ndarray:
        """Drawable polyline (m, robot_base): desk origin, base centre, arm 0's shoulder, elbow
        and effector joint, effector centre, tool — shape (7, 3). ``arm_segments`` gives all arms."""
        seg = self.arm_segments(q)
        P = seg[0, 3]
        return np.array([
            (0.0, 0.0, 0.0), (0.0, 0.0, self.base_height_m), seg[0, 0], seg[0, 1], seg[0, 2], P,
            (P[0], P[1], P[2] - self.tool_offset_m),
        ])

    def jacobian(self, q: Sequence[float]) -> np.ndarray:
        """d(base_p_tool)/dq, shape (3, 3), from the three closure constraints (implicit function)."""
        g = self.geometry
        th = [float(v) for v in q]
        P, _ = _fk_centre(g, self._u, th)
        M = np.empty((3, 3))
        b = np.empty(3)
        for i, ((ux, uy, _), t) in enumerate(zip(self._u, th)):
            rho = g.base_radius_m - g.effector_radius_m + g.upper_arm_m * math.cos(t)
            C = np.array((rho * ux, rho * uy, g.base_height_m - g.upper_arm_m * math.sin(t)))
            dC = g.upper_arm_m * np.array((-math.sin(t) * ux, -math.sin(t) * uy, -math.cos(t)))
            M[i] = C - P
            b[i] = (C - P) @ dC
        # (C_i - P)·dP = (C_i - P)·dC_i dθ_i  →  dP/dθ = M⁻¹ diag(b)
        return np.linalg.solve(M, np.diag(b))

    # ---------------------------------------------------------------------------------------
    # Limits

    def _clamp(self, q: Sequence[float]) -> tuple[float, ...]:
        out = []
        for v, lo, hi, mid in zip(q, self.q_min, self.q_max, self._mid):
            v = float(v)
            if v != v:
                v = mid
            out.append(min(max(v, lo), hi))
        return tuple(out)

    def within_limits(self, q: Sequence[float], tol: float = 0.0) -> bool:
        """True when every joint is finite and inside its limits (± ``tol`` rad)."""
        return len(q) == 3 and all(
            math.isfinite(v) and lo - tol <= v <= hi + tol for v, lo, hi in zip(q, self.q_min, self.q_max)
        )

    # ---------------------------------------------------------------------------------------
    # Inverse kinematics

    def _arm_angle(self, i: int, px: float, py: float, pz: float) -> Optional[float]:
        """Knee-out joint angle of arm i for effector centre P, or None when it cannot reach."""
        g = self.geometry
        ux, uy, _ = self._u[i]
        dx = px + (g.effector_radius_m - g.base_radius_m) * ux
        dy = py + (g.effector_radius_m - g.base_radius_m) * uy
        dz = pz - g.base_height_m
        rho = dx * ux + dy * uy
        L = g.upper_arm_m
        k = math.hypot(rho, dz)
        if k == 0.0:
            return None
        c = (L * L + dx * dx + dy * dy + dz * dz - g.forearm_m ** 2) / (2.0 * L * k)
        if not -1.0 <= c <= 1.0:  # also NaN
            if not abs(c) <= 1.0 + 1e-12:
                return None
            c = max(-1.0, min(1.0, c))
        theta_d = math.atan2(-dz, rho)  # direction of shoulder → effector joint, below horizontal
        th = theta_d - math.acos(c)
        return (th + math.pi) % (2.0 * math.pi) - math.pi

    def ik(self, base_p_target: Sequence[float], q_current: Optional[Sequence[float]] = None) -> IKResult:
        """Joint angles putting the tool on ``base_p_target`` (robot_base, m); never raises.

        The closed form gives the single knee-out solution; when it does not exist or leaves the
        joint limits, ``q`` is the nearest reachable configuration found (from ``q_current``,
        home and the clamped closed form) and ``error_m`` its distance. A non-finite target
        gives the clamped current joints and ``error_m`` inf; an absurdly far one (1e308 m) is
        solved like a point ``FAR_TARGET_FACTOR`` reaches away in its direction.
        """
        x, y, z = (float(v) for v in base_p_target)
        cur = self.q_home if q_current is None else self._clamp(q_current)
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
            return IKResult(cur, False, False, math.inf, self.fk_tuple(cur), (), "target is not finite")
        near = bring_near((x, y, z), self._far_m)
        if near != (x, y, z):
            return self._nearest((x, y, z), cur, (), near)
        pz = z + self.tool_offset_m
        q = []
        for i in range(3):
            th = self._arm_angle(i, x, y, pz)
            if th is None:
                break
            lo, hi = self.q_min[i], self.q_max[i]
            if th < lo - LIMIT_TOL_RAD or th > hi + LIMIT_TOL_RAD:
                break
            q.append(min(max(th, lo), hi))
        else:
            qt = tuple(q)
            reached = self.fk_tuple(qt)
            err = math.dist(reached, (x, y, z))
            if err <= EXACT_TOL_M:
                return IKResult(qt, True, True, err, reached, (qt,), "")
        return self._nearest((x, y, z), cur, q)

    def _nearest(self, target, cur, partial, aim=None) -> IKResult:
        """Nearest reachable point: damped Gauss–Newton in joint space from a few starts.

        Joints held at a limit by the step (an active set) are dropped from the next solve, so
        the descent converges quickly along the workspace's boundary; every iterate is clamped.
        ``aim`` (default ``target``) is the point the descent approaches: the target brought
        near for an absurdly far one; distances are always measured to ``target``.
        """
        t = np.array(target if aim is None else aim)
        starts = [cur, self.q_home, self._mid]
        if len(partial) == 3:
            starts.insert(0, tuple(partial))
        best_q, best_e = None, math.inf
        tried: list = []
        for q0 in starts:
            q0 = self._clamp(q0)
            if any(max(abs(a - b) for a, b in zip(q0, s)) < 1e-9 for s in tried):
                continue
            tried.append(q0)
            q, E = self._descend(t, np.array(q0))
            if E < best_e:
                best_q, best_e = q, E
            if best_e <= EXACT_TOL_M * EXACT_TOL_M:
                break
        # no start gave a finite error (odd geometries: no pose there assembles): hold the current
        qt = self._clamp(cur if best_q is None else best_q)
        reached = self.fk_tuple(qt)
        err = distance_m(reached, target)
        if err <= EXACT_TOL_M:
            return IKResult(qt, True, True, err, reached, (qt,), "")
        return IKResult(qt, False, False, err, reached, (), f"out of reach by {format_distance(err)}")

    def _descend(self, t: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, float]:
        """Descent from ``q`` towards ``t``: (q, squared error), inf when ``q`` does not assemble."""
        lo, hi = np.array(self.q_min), np.array(self.q_max)
        e = t - self.fk(q)
        E = float(e @ e)
        if not math.isfinite(E):
            return q, math.inf
        lam = 1e-6
        for _ in range(NEAREST_IT_MAX):
            try:
                J = self.jacobian(q)
            except np.linalg.LinAlgError:  # a singular pose (the arms' closure has no unique dP/dθ)
                break
            if not all_finite(J.ravel().tolist()):
                break
            g = J.T @ e  # minus the gradient of |e|²/2: the joints want to move along g
            free = ~(((q <= lo) & (g < 0.0)) | ((q >= hi) & (g > 0.0)))  # held at a limit
            dq = np.zeros(3)
            if free.any():
                Jf = J[:, free]
                A = Jf.T @ Jf
                A.flat[:: A.shape[0] + 1] += lam + DAMP_MIN
                try:
                    dq[free] = np.linalg.solve(A, g[free])
                except np.linalg.LinAlgError:  # numerically singular near a singular pose: stop here
                    break
            if not free.any() or float(np.max(np.abs(dq))) < NEAREST_EPS_STEP:
                break  # every useful direction is blocked by a limit, or no step left
            qn = np.minimum(np.maximum(q + dq, lo), hi)
            (px, py, pz), z2s = _fk_centre(self.geometry, self._u, qn.tolist())
            if not z2s >= 0.0:  # the forearms cannot meet there (NaN: undetermined)
                lam *= 10.0
                continue
            en = t - (px, py, pz - self.tool_offset_m)
            En = float(en @ en)
            if En < E:
                done = E - En <= NEAREST_REL_DECREASE * E
                q, e, E = qn, en, En
                lam = max(lam * 0.1, 1e-12)
                if done or E <= EXACT_TOL_M * EXACT_TOL_M * 1e-2:
                    break
            else:
                lam *= 10.0
                if lam > 1e8 or float(np.max(np.abs(dq))) < 10.0 * NEAREST_EPS_STEP:
                    break
        return q, E

    # ---------------------------------------------------------------------------------------
    # Workspace (approximate, from sampled FK)

    def _sample(self) -> np.ndarray:
        if self._samples is None:
            rng = np.random.default_rng(0)
            qs = rng.uniform(self.q_min, self.q_max, (WORKSPACE_SAMPLES, 3))
            pts = np.array([self.fk_tuple(q) for q in qs])
            self._samples = pts[np.isfinite(pts).all(axis=1)]  # poses that assemble
        return self._samples

    def workspace_radius_range(self) -> tuple[float, float]:
        """(min, max) horizontal distance (m) of the tool from the base's axis (sampled)."""
        p = self._sample()
        r = np.hypot(p[:, 0], p[:, 1])
        return (0.0, float(r.max()))

    def workspace_outline_side(self, n_bins: int = 30) -> np.ndarray:
        """Approximate outline (s, z) of the reachable set: s horizontal distance from the base
        axis, z height above the desk; closed polyline from sampled FK (see ClikKinematics)."""
        p = self._sample()
        r = np.hypot(p[:, 0], p[:, 1])
        z = p[:, 2]
        edges = np.linspace(z.min(), z.max(), max(2, int(n_bins)) + 1)
        idx = np.clip(np.digitize(z, edges) - 1, 0, len(edges) - 2)
        outer = []
        for b in range(len(edges) - 1):
            sel = idx == b
            if sel.any():
                outer.append((float(r[sel].max()), 0.5 * (edges[b] + edges[b + 1])))
        pts = [(0.0, outer[0][1])] + outer + [(0.0, outer[-1][1])]
        pts.append(pts[0])
        return np.array(pts, dtype=float)
