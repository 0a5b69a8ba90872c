"""Analytic kinematics of the yaw–shoulder–elbow (RRR) desk arm.

Frame robot_base: origin on the desk below the yaw axis, x right, y forward, z up (desk z = 0).
Joint values q = (q1, q2, q3), rad:

- q1 base yaw: azimuth of the arm's vertical plane, from +x towards +y;
- q2 shoulder: elevation of the upper arm above the horizontal, in that plane;
- q3 elbow: forearm angle relative to the upper arm (0 straight, negative bends down).

With h the shoulder height, L1 the upper arm and L2 the forearm::

    s = L1 cos q2 + L2 cos(q2 + q3)          # signed horizontal reach along the azimuth
    z = h + L1 sin q2 + L2 sin(q2 + q3)
    x = s cos q1,  y = s sin q1

IK is closed form and returns every in-limit branch (azimuth φ with s > 0 or φ + π with s < 0,
reaching over the back; elbow bent either way), picking the one nearest the current joints.
An unreachable target never raises: the result carries the nearest reachable point, found
exactly on the circle arcs that bound the workspace. The hot path uses ``math`` on scalars
(numpy costs more than the whole solve for three numbers).
"""
from __future__ import annotations

import math
from typing import Optional, Sequence

import numpy as np

from core.kinematics.base import IKResult, format_distance
from core.kinematics.profile import ProfileError, RobotProfile

PI = math.pi
TWO_PI = 2.0 * math.pi

AXIS_EPS_M = 1e-12  # a target this close to the yaw axis has a free yaw: keep the current one
ACOS_TOL = 1e-9  # cos q3 up to 1 + ACOS_TOL is clamped to ±1 (a target ≲ 5e-11 m outside)
LIMIT_TOL_RAD = 1e-6  # an angle this far outside its limit is snapped onto it, then FK-checked
EXACT_TOL_M = 1e-10  # a snapped solution is exact when its FK lands this close to the target
SAME_BRANCH_RAD = 1e-7  # solutions closer than this in every joint are one branch
TIE_TOL_M = 1e-12  # nearest points this close in distance are ties, broken by joint distance


def _wrap_pi(a: float) -> float:
    """Angle difference wrapped to [-π, π)."""
    return (a + PI) % TWO_PI - PI


def _wrap_into(a: float, lo: float, hi: float) -> list[tuple[float, bool]]:
    """Every ``a + 2πk`` inside [lo - tol, hi + tol], snapped onto [lo, hi]; with a snapped flag."""
    k = math.ceil((lo - LIMIT_TOL_RAD - a) / TWO_PI)
    v = a + k * TWO_PI
    out = []
    hi_tol = hi + LIMIT_TOL_RAD
    while v <= hi_tol:
        if v < lo:
            out.append((lo, True))
        elif v > hi:
            out.append((hi, True))
        else:
            out.append((v, False))
        v += TWO_PI
    return out


class RRRKinematics:
    """Forward/inverse kinematics, Jacobian and workspace of an RRR profile (read-only, shared)."""

    def __init__(
        self, profile: RobotProfile, joint_weights: Sequence[float] = (1.0, 1.0, 1.0)
    ) -> None:
        if profile.kind != "rrr" or len(profile.joints) != 3:
            raise ProfileError(
                f"{profile.source or profile.name}: RRRKinematics needs kind 'rrr' with 3 joints,"
                f" got kind {profile.kind!r} with {len(profile.joints)}"
            )
        if len(joint_weights) != 3 or not all(w >= 0 and math.isfinite(w) for w in joint_weights):
            raise ValueError(f"joint_weights = {tuple(joint_weights)} must be 3 finite numbers ≥ 0")
        g = profile.geometry
        self.profile = profile
        self.shoulder_height_m: float = g.shoulder_height_m  # shoulder above the desk
        self.upper_arm_m: float = g.upper_arm_m  # L1
        self.forearm_m: float = g.forearm_m  # L2
        self.q_min: tuple[float, float, float] = tuple(profile.q_min)  # type: ignore[assignment]
        self.q_max: tuple[float, float, float] = tuple(profile.q_max)  # type: ignore[assignment]
        self.joint_weights = tuple(float(w) for w in joint_weights)
        self._mid = tuple(0.5 * (a + b) for a, b in zip(self.q_min, self.q_max))
        self.q_home = self._clamp(tuple(profile.q_home))
        L1, L2 = self.upper_arm_m, self.forearm_m
        self._l1l2_sq = L1 * L1 + L2 * L2
        self._inv_2l1l2 = 1.0 / (2.0 * L1 * L2)
        self._arcs = self._boundary_arcs()

    # ---------------------------------------------------------------------------------------
    # Forward kinematics

    def fk_tuple(self, q: Sequence[float]) -> tuple[float, float, float]:
        """Tool point in robot_base (m) as a tuple; the allocation-free form of ``fk``."""
        q1, q2, q3 = q
        L1, L2 = self.upper_arm_m, self.forearm_m
        q23 = q2 + q3
        s = L1 * math.cos(q2) + L2 * math.cos(q23)
        return (
            s * math.cos(q1),
            s * math.sin(q1),
            self.shoulder_height_m + L1 * math.sin(q2) + L2 * math.sin(q23),
        )

    def fk(self, q: Sequence[float]) -> np.ndarray:
        """Tool point ``base_p_tool`` in robot_base (m), shape (3,)."""
        return np.array(self.fk_tuple(q))

    def chain_points(self, q: Sequence[float]) -> np.ndarray:
        """Base (0,0,0), shoulder, elbow and tool in robot_base (m), shape (4, 3), for drawing."""
        q1, q2, q3 = (float(v) for v in q)
        h, L1 = self.shoulder_height_m, self.upper_arm_m
        c1, s1 = math.cos(q1), math.sin(q1)
        se = L1 * math.cos(q2)  # elbow's horizontal reach in the arm plane
        return np.array(
            [
                (0.0, 0.0, 0.0),
                (0.0, 0.0, h),
                (se * c1, se * s1, h + L1 * math.sin(q2)),
                self.fk_tuple((q1, q2, q3)),
            ]
        )

    def jacobian(self, q: Sequence[float]) -> np.ndarray:
        """d(base_p_tool)/dq, shape (3, 3): rows x, y, z in robot_base; columns q1, q2, q3."""
        q1, q2, q3 = (float(v) for v in q)
        L1, L2 = self.upper_arm_m, self.forearm_m
        c1, s1 = math.cos(q1), math.sin(q1)
        c2, s2 = math.cos(q2), math.sin(q2)
        c23, s23 = math.cos(q2 + q3), math.sin(q2 + q3)
        s = L1 * c2 + L2 * c23
        ds2 = -(L1 * s2 + L2 * s23)  # ds/dq2
        ds3 = -L2 * s23  # ds/dq3
        return np.array(
            [
                [-s * s1, ds2 * c1, ds3 * c1],
                [s * c1, ds2 * s1, ds3 * s1],
                [0.0, s, L2 * c23],
            ]
        )

    # ---------------------------------------------------------------------------------------
    # Limits

    def _clamp(self, q: Sequence[float]) -> tuple[float, float, float]:
        lo, hi, mid = self.q_min, self.q_max, self._mid
        out = []
        for i in range(3):
            v = float(q[i])
            if v != v:  # NaN: nothing to hold on to, take the middle of the range
                v = mid[i]
            out.append(min(max(v, lo[i]), hi[i]))
        return (out[0], out[1], out[2])

    def within_limits(self, q: Sequence[float], tol: float = 0.0) -> bool:
        """True when every joint is finite and inside its limits (± ``tol`` rad)."""
        return all(
            math.isfinite(v) and lo - tol <= v <= hi + tol
            for v, lo, hi in zip(q, self.q_min, self.q_max)
        )

    # ---------------------------------------------------------------------------------------
    # Inverse kinematics

    def ik(self, base_p_target: Sequence[float], q_current: Optional[Sequence[float]] = None) -> IKResult:
        """Joint values reaching ``base_p_target`` (robot_base, m), nearest to ``q_current``.

        Never raises for an unreachable or non-finite target: ``success`` is False, ``q`` is the
        nearest reachable configuration (or the clamped current one for NaN/inf targets) and
        ``error_m`` the distance. ``q_current`` None means the home pose; NaN entries in it are
        read as the middle of that joint's range.
        """
        x, y, z = base_p_target
        x = float(x)
        y = float(y)
        z = float(z)
        if q_current is None:
            cur = self.q_home
        else:
            c1, c2, c3 = q_current
            cur = (float(c1), float(c2), float(c3))
            if not (math.isfinite(cur[0]) and math.isfinite(cur[1]) and math.isfinite(cur[2])):
                cur = tuple(  # type: ignore[assignment]
                    v if math.isfinite(v) else m for v, m in zip(cur, self._mid)
                )
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
            q = self._clamp(cur)
            return IKResult(q, False, False, math.inf, self.fk_tuple(q), (), "target is not finite")

        sols = self._solve(x, y, z, cur)
        if sols:
            q = sols[0] if len(sols) == 1 else self._closest(sols, cur)
            return IKResult(q, True, True, 0.0, self.fk_tuple(q), tuple(sols), "")
        return self._nearest(x, y, z, cur)

    def _closest(self, sols, cur) -> tuple[float, float, float]:
        """The solution with the smallest weighted joint distance to ``cur`` (yaw wrapped)."""
        w1, w2, w3 = self.joint_weights
        c1, c2, c3 = cur
        best = None
        best_d = math.inf
        for q in sols:
            d1 = _wrap_pi(q[0] - c1)
            d2 = q[1] - c2
            d3 = q[2] - c3
            d = w1 * d1 * d1 + w2 * d2 * d2 + w3 * d3 * d3  # x*x overflows to inf, x**2 raises
            if best is None or d < best_d:
                best, best_d = q, d
        return best  # type: ignore[return-value]

    def _yaw_planes(self, x: float, y: float, yaw_hint: float):
        """Arm planes (q1, s, d) through the target: s in-plane reach, d out-of-plane offset.

        In-limit azimuths φ + kπ (d = 0, s = ±r); on the yaw axis the hint's clamped yaw.
        """
        lo1, hi1 = self.q_min[0], self.q_max[0]
        r = math.hypot(x, y)
        if r <= AXIS_EPS_M:
            q1 = min(max(yaw_hint, lo1), hi1)
            c, s = math.cos(q1), math.sin(q1)
            return [(q1, x * c + y * s, y * c - x * s)]
        phi = math.atan2(y, x)
        k = math.ceil((lo1 - LIMIT_TOL_RAD - phi) / PI)
        q1 = phi + k * PI
        planes = []
        while q1 <= hi1 + LIMIT_TOL_RAD:
            if lo1 <= q1 <= hi1:
                planes.append((q1, r if k % 2 == 0 else -r, 0.0))
            else:  # snapped onto a yaw limit: project the target on that plane instead
                q1s = lo1 if q1 < lo1 else hi1
                c, s = math.cos(q1s), math.sin(q1s)
                planes.append((q1s, x * c + y * s, y * c - x * s))
            k += 1
            q1 = phi + k * PI
        return planes

    def _solve(self, x: float, y: float, z: float, cur) -> list:
        """Every exact in-limit solution, deduplicated."""
        out: list = []
        w = z - self.shoulder_height_m
        for q1, s, d in self._yaw_planes(x, y, cur[0]):
            if d > EXACT_TOL_M or d < -EXACT_TOL_M:
                continue
            for q2, q3 in self._planar(s, w, cur[1]):
                q = (q1, q2, q3)
                for o in out:
                    if (
                        abs(o[0] - q1) < SAME_BRANCH_RAD
                        and abs(o[1] - q2) < SAME_BRANCH_RAD
                        and abs(o[2] - q3) < SAME_BRANCH_RAD
                    ):
                        break
                else:
                    out.append(q)
        return out

    def _planar(self, s: float, w: float, q2_hint: float) -> list:
        """In-limit (q2, q3) putting the tool at (s, w) relative to the shoulder, in the arm plane."""
        L1, L2 = self.upper_arm_m, self.forearm_m
        lo2, hi2 = self.q_min[1], self.q_max[1]
        lo3, hi3 = self.q_min[2], self.q_max[2]
        c = (s * s + w * w - self._l1l2_sq) * self._inv_2l1l2  # cos q3 (law of cosines)
        clamped = False
        if c > 1.0:
            if c > 1.0 + ACOS_TOL:
                return []
            c, clamped = 1.0, True
        elif c < -1.0:
            if c < -1.0 - ACOS_TOL:
                return []
            c, clamped = -1.0, True
        sn = math.sqrt(1.0 - c * c)  # |sin q3|
        theta = math.atan2(w, s)
        out = []
        for q3_raw in (math.atan2(sn, c), math.atan2(-sn, c)) if sn > 0.0 else (math.atan2(0.0, c),):
            for q3, snapped3 in _wrap_into(q3_raw, lo3, hi3):
                k = L1 + L2 * math.cos(q3)
                m = L2 * math.sin(q3)
                if k * k + m * m < 1e-24:  # tool on the shoulder (L1 = L2, folded): q2 is free
                    q2_list = [(min(max(q2_hint, lo2), hi2), False)]
                else:
                    q2_list = _wrap_into(theta - math.atan2(m, k), lo2, hi2)
                for q2, snapped2 in q2_list:
                    q3b = q3
                    if snapped2:
                        # q2 moved onto its limit: re-aim the forearm from the elbow, then check
                        a = math.atan2(w - L1 * math.sin(q2), s - L1 * math.cos(q2)) - q2
                        cand = _wrap_into(a, lo3, hi3)
                        if not cand:
                            continue
                        q3b = cand[0][0]
                    if clamped or snapped3 or snapped2:
                        q23 = q2 + q3b
                        es = L1 * math.cos(q2) + L2 * math.cos(q23) - s
                        ew = L1 * math.sin(q2) + L2 * math.sin(q23) - w
                        if es * es + ew * ew > EXACT_TOL_M * EXACT_TOL_M:
                            continue
                    out.append((q2, q3b))
        return out

    # ---------------------------------------------------------------------------------------
    # Nearest reachable point

    def _boundary_arcs(self) -> list:
        """Circle arcs (in the arm plane) that contain the boundary of the reachable set.

        The set is the image of the box [q2 limits] × [q3 limits]; its boundary lies on the
        image of the box edges and of the singular lines q3 = kπ (stretched, folded). Each is a
        circle arc: ``(cx, cy, R, a0, width, fixes_q2, fixed, start)`` where the point at angle
        ``a0 + t`` (0 ≤ t ≤ width) has q2 = fixed, q3 = start + t (fixes_q2) or
        q3 = fixed, q2 = start + t.
        """
        L1, L2 = self.upper_arm_m, self.forearm_m
        lo2, hi2 = self.q_min[1], self.q_max[1]
        lo3, hi3 = self.q_min[2], self.q_max[2]
        arcs = []
        for q2 in (lo2, hi2):  # elbow fixed, forearm sweeps
            arcs.append((L1 * math.cos(q2), L1 * math.sin(q2), L2, q2 + lo3, hi3 - lo3, True, q2, lo3))
        q3_values = [lo3, hi3]
        k = math.ceil(lo3 / PI)
        while k * PI < hi3:
            if k * PI > lo3:
                q3_values.append(k * PI)  # stretched (even k) or folded (odd k) inside the range
            k += 1
        for q3 in q3_values:  # elbow angle fixed, whole arm turns about the shoulder
            kx, ky = L1 + L2 * math.cos(q3), L2 * math.sin(q3)
            R = math.hypot(kx, ky)
            beta = math.atan2(ky, kx) if R > 0.0 else 0.0
            arcs.append((0.0, 0.0, R, lo2 + beta, hi2 - lo2, False, q3, lo2))
        return arcs

    def _nearest_planar(self, s: float, w: float) -> list:
        """(distance, q2, q3) of the nearest point of each boundary arc to (s, w)."""
        out = []
        for cx, cy, R, a0, width, fixes_q2, fixed, start in self._arcs:
            dx, dy = s - cx, w - cy
            dist = math.hypot(dx, dy)
            if dist == 0.0 or R == 0.0:
                t = 0.0
            else:
                t = (math.atan2(dy, dx) - a0) % TWO_PI
                if t > width:  # outside the arc's span: the angularly nearer end
                    t = width if t - width < TWO_PI - t else 0.0
            a = a0 + t
            e = math.hypot(s - (cx + R * math.cos(a)), w - (cy + R * math.sin(a)))
            if fixes_q2:
                out.append((e, fixed, start + t))
            else:
                out.append((e, start + t, fixed))
        return out

    def _nearest(self, x: float, y: float, z: float, cur) -> IKResult:
        """Result for a target with no exact solution: the nearest reachable point.

        The 3D distance to a point of the planar set at reach s_a is smallest at the azimuth
        φ (s_a > 0) or φ + π (s_a < 0) when the yaw allows it, otherwise at a yaw limit; so it
        is enough to search the in-limit azimuth planes and the two yaw-limit planes, adding
        the out-of-plane offset.
        """
        w = z - self.shoulder_height_m
        lo1, hi1 = self.q_min[0], self.q_max[0]
        planes = list(self._yaw_planes(x, y, cur[0]))
        if math.hypot(x, y) > AXIS_EPS_M:
            for q1 in (lo1, hi1):
                c, sn = math.cos(q1), math.sin(q1)
                planes.append((q1, x * c + y * sn, y * c - x * sn))
        cands = []  # (distance, q)
        for q1, s, d in planes:
            inside = self._planar(s, w, cur[1])
            if inside:
                for q2, q3 in inside:
                    cands.append((abs(d), (q1, self._clamp1(q2, 1), self._clamp1(q3, 2))))
                continue
            for e, q2, q3 in self._nearest_planar(s, w):
                cands.append((math.hypot(d, e), (q1, self._clamp1(q2, 1), self._clamp1(q3, 2))))
        best_e = min((c[0] for c in cands if c[0] == c[0]), default=math.inf)
        ties = [q for e, q in cands if e <= best_e + TIE_TOL_M * (1.0 + best_e)] or [cands[0][1]]
        # _clamp also turns a NaN (only possible from overflowing, absurdly far targets) into
        # a finite in-limit value: q must stay safe whatever the input
        q = self._clamp(ties[0] if len(ties) == 1 else self._closest(ties, cur))
        reached = self.fk_tuple(q)
        error_m = math.hypot(reached[0] - x, reached[1] - y, reached[2] - z)
        if error_m != error_m:
            error_m = math.inf
        if error_m <= EXACT_TOL_M:  # on the boundary within rounding: call it reached
            return IKResult(q, True, True, 0.0, reached, (q,), "")
        return IKResult(q, False, False, error_m, reached, (), f"out of reach by {format_distance(error_m)}")

    def _clamp1(self, v: float, i: int) -> float:
        return min(max(v, self.q_min[i]), self.q_max[i])

    # ---------------------------------------------------------------------------------------
    # Workspace, for the GUI

    def workspace_radius_range(self) -> tuple[float, float]:
        """(min, max) distance (m) from the shoulder axis to the tool over the elbow's range."""
        lo3, hi3 = self.q_min[2], self.q_max[2]
        L1, L2 = self.upper_arm_m, self.forearm_m

        def rho(q3: float) -> float:
            return math.sqrt(max(0.0, self._l1l2_sq + 2.0 * L1 * L2 * math.cos(q3)))

        values = [rho(lo3), rho(hi3)]
        k = math.ceil(lo3 / PI)
        while k * PI <= hi3:
            values.append(rho(k * PI))
            k += 1
        return (min(values), max(values))

    def workspace_outline_side(self, n_per_edge: int = 48) -> np.ndarray:
        """Outline of the reachable set in the arm plane as (s, z) rows (m), for the side view.

        s is the signed reach along the arm's azimuth (negative = over the back), z the height
        above the desk. The first polyline is the closed image of the joint-limit box's edges;
        when the elbow range contains a stretched or folded pose strictly inside it, those
        arcs follow, separated by a NaN row (draw with pyqtgraph's ``connect="finite"``).
        """
        n = max(2, int(n_per_edge))
        lo2, hi2 = self.q_min[1], self.q_max[1]
        lo3, hi3 = self.q_min[2], self.q_max[2]

        def side(q2: float, q3: float) -> tuple[float, float]:
            p = self.fk_tuple((0.0, q2, q3))
            return (p[0], p[2])

        t = np.linspace(0.0, 1.0, n)
        pts = []
        pts += [side(lo2 + (hi2 - lo2) * u, hi3) for u in t]  # q3 at its upper limit
        pts += [side(hi2, hi3 + (lo3 - hi3) * u) for u in t[1:]]  # q2 at its upper limit
        pts += [side(hi2 + (lo2 - hi2) * u, lo3) for u in t[1:]]  # q3 at its lower limit
        pts += [side(lo2, lo3 + (hi3 - lo3) * u) for u in t[1:]]  # q2 at its lower limit
        k = math.ceil(lo3 / PI)
        while k * PI < hi3:
            if k * PI > lo3:
                pts.append((math.nan, math.nan))
                pts += [side(lo2 + (hi2 - lo2) * u, k * PI) for u in t]
            k += 1
        return np.array(pts, dtype=float)
