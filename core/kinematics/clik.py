"""Closed-loop inverse kinematics (CLIK) of any serial arm described by a URDF, with Pinocchio.

Frame robot_base is the URDF's root link. The joints of a profile are the URDF joints between
the root and the tip frame (``profile.geometry.tip_frame``), in chain order; every other joint
(gripper fingers, …) is locked at its neutral value in a reduced model, so q has exactly the
profile's joints. Mimic joints on the chain stay in the model but are not variables: Pinocchio
derives each from the joint it mimics (``mimic_values``), so no solve moves one on its own.
The model is built once and shared read-only; every thread that calls the solver gets its own
``pin.Data`` (and random generator) on first use, so one solver object can serve several
workers. A finite target absurdly far away (1e308 m) is solved as the point of its ray
``FAR_TARGET_FACTOR`` reaches away, so no squared error overflows; distances in the answer are
still measured to the real target.

IK is damped least squares (Levenberg–Marquardt) on the tip's error, as in Pinocchio's CLIK
example but with a full step (``DT = 1``) and an adaptive damping
``λ = (DAMP_MIN + DAMP_ERR·|e|²)·μ`` where μ grows tenfold on a step that would increase the
error (the step is then retried from the same point) and shrinks on an accepted one. After
every step each joint is clamped into its limits, so no iterate — and no answer — ever leaves
them; joints that the descent pushes against a limit leave the next solve (an active set), so
solutions on a limit converge too. The error is expressed in robot_base: position
``p_des − p`` and orientation ``log3(R_des · Rᵀ)``, each axis scaled by the caller's weight
(0 drops an axis).

- Warm solves (``q_current`` given) start from ``q_current`` and so stay on its branch; if that
  attempt fails they try ``WARM_ATTEMPTS`` seeds more (the answer then says the branch changed).
- Cold solves (``q_current`` None) start from a seed bank — ``SEED_BANK_SIZE`` random in-limit
  configurations, nearest tip pose first — then alternate random configurations and further
  seeds, up to ``COLD_ATTEMPTS`` attempts. An attempt whose error does not halve within
  ``STALL_WINDOW`` iterations is abandoned early.
- A target no attempt reaches gives the best configuration found, polished by a descent that
  runs until it stops making progress (the nearest reachable point; a local one in principle,
  the global one in practice), with ``success`` False and the distance in ``error_m``. The
  search stops early once ``UNREACHABLE_AGREE`` random starts end at the same smallest error.

``workspace_radius_range`` and ``workspace_outline_side`` are approximate: they come from the
seed bank's sampled forward kinematics.
"""
from __future__ import annotations

import math
import threading
from typing import TYPE_CHECKING, Optional, Sequence

import numpy as np
import pinocchio as pin

from core.kinematics.base import (
    FAR_TARGET_FACTOR,
    IKResult,
    ProfileError,
    all_finite,
    bring_near,
    distance_m,
    format_distance,
    pose_parts,
)
from core.kinematics.urdf import MimicJoint, UrdfChain, frame_names, read_urdf_chain

if TYPE_CHECKING:
    from core.kinematics.profile import RobotProfile

EPS_POS_M = 1e-6  # converged when the tip is this close to the target (each weighted axis)
EPS_ROT_RAD = 1e-5  # … and, for pose solves, its orientation this close
IT_MAX = 60  # iterations per attempt
DT = 1.0  # step fraction: the full Gauss–Newton/LM step (Pinocchio's example uses 0.1)
DAMP_MIN = 1e-6  # damping floor (m², added to J·Jᵀ)
DAMP_ERR = 0.1  # damping grows with the squared error far from the target
DAMP_UP = 10.0  # μ multiplier after a rejected step
DAMP_DOWN = 0.3  # μ multiplier after an accepted step (never below 1)
MU_MAX = 1e10  # a step still rejected at this μ: the attempt sits in a local minimum
STALL_WINDOW = 8  # abandon an attempt whose error did not drop …
STALL_RATIO = 0.5  # … below this fraction of its value STALL_WINDOW iterations earlier,
STALL_MIN_E = 1e-8  # … unless its (weighted) error² is below this: near a singular solution
#                     convergence is slow but sure, so such attempts run to IT_MAX
POLISH_IT_MAX = 200  # iterations polishing the best attempt of a failed solve (the nearest point) …
POLISH_REL_DECREASE = 1e-12  # … until an accepted step lowers the error² by less than this fraction
COLD_ATTEMPTS = 40  # attempts of a cold solve: FIRST_BANK_SEEDS nearest seeds, then …
FIRST_BANK_SEEDS = 5  # … random starts and further bank seeds alternating
WARM_ATTEMPTS = 4  # seeds tried after a failed warm attempt
UNREACHABLE_AGREE = 3  # random-start attempts ending at the same smallest error: stop, it is
#                        the nearest point (bank seeds are neighbours sharing basins: not counted)
AGREE_REL = 1e-6  # relative tolerance of "the same error"
SEED_BANK_SIZE = 4000  # random in-limit configurations whose tip poses seed cold solves
SEED_ROT_SCALE_M = 0.1  # weight of the rotation (Frobenius distance) against metres in seed lookup

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
_DEFAULT_WEIGHTS = (1.0, 1.0, 1.0, 1.0, 1.0, 1.0)
_ONES3 = np.ones(3)
_ONES6 = np.ones(6)


def _reduced_model(chain: UrdfChain):
    """The model with every joint off the root→tip chain locked at its neutral value (clamped);
    the chain's mimic joints stay (they have no coordinates of their own)."""
    model = chain.model
    keep = set(chain.chain_joint_ids) | set(chain.mimic_joint_ids)
    lock = [j for j in range(1, model.njoints) if j not in keep]
    if not lock:
        return model
    q_ref = pin.neutral(model)
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    finite = np.isfinite(lo) & np.isfinite(hi)
    q_ref[finite] = np.clip(q_ref[finite], lo[finite], hi[finite])
    return pin.buildReducedModel(model, lock, q_ref)


# --------------------------------------------------------------------------------------------
# The solver


def _make_small_solve():
    """np.linalg.solve without its per-call dispatch (3.6x faster on 6x6 here): NumPy's own
    LAPACK gufunc, with the public function as the fallback if a NumPy release moves it."""
    try:
        from numpy.linalg import _umath_linalg

        gufunc = _umath_linalg.solve1
        probe = gufunc(np.eye(2) * 2.0, np.ones(2))
        if not np.allclose(probe, 0.5):
            raise ValueError("unexpected result")
    except Exception:  # any NumPy without it: the public, slower path
        return np.linalg.solve
    return gufunc


_small_solve = _make_small_solve()


def _solve3_spd(A: np.ndarray, b: np.ndarray, lam: float) -> np.ndarray:
    """(A + λI)⁻¹ b for a symmetric 3×3 A, in closed form (a third of np.linalg.solve's cost)."""
    (a, b_, c), (_, d, e), (_, _, f) = A.tolist()
    a += lam
    d += lam
    f += lam
    x, y, z = b.tolist()
    c00 = d * f - e * e
    c01 = c * e - b_ * f
    c02 = b_ * e - c * d
    det = a * c00 + b_ * c01 + c * c02
    if not (abs(det) > 1e-300):
        return np.linalg.lstsq(A + lam * np.eye(3), b, rcond=None)[0]
    c11 = a * f - c * c
    c12 = b_ * c - a * e
    c22 = a * d - b_ * b_
    inv = 1.0 / det
    return np.array((
        (c00 * x + c01 * y + c02 * z) * inv,
        (c01 * x + c11 * y + c12 * z) * inv,
        (c02 * x + c12 * y + c22 * z) * inv,
    ))



class ClikKinematics:
    """FK, Jacobian and closed-loop IK (position or weighted pose) of a URDF profile.

    Read-only after construction and safe to share between threads (each thread gets its own
    ``pin.Data``). ``seed`` fixes the seed bank and the random restarts, so solves are
    reproducible.
    """

    def __init__(self, profile: RobotProfile, seed: int = 0, seed_bank_size: int = SEED_BANK_SIZE) -> None:
        if profile.kind != "urdf":
            raise ProfileError(
                f"{profile.source or profile.name}: ClikKinematics needs a URDF profile (kind 'urdf'),"
                f" got kind {profile.kind!r}"
            )
        g = profile.geometry
        chain = read_urdf_chain(g.urdf_path, g.tip_frame)
        self.profile = profile
        self.urdf_path: str = chain.path
        self.tip_frame: str = chain.tip
        self.model = _reduced_model(chain)  # shared, read-only
        # the variables: mimic joints have no coordinates (nq = 0), their values are derived
        names = tuple(self.model.names[j] for j in range(1, self.model.njoints)
                      if self.model.joints[j].nq > 0)
        self.mimic_joints: tuple[MimicJoint, ...] = chain.mimics
        self._mimic_index = tuple(names.index(mj.primary) for mj in chain.mimics)
        if names != profile.joint_names:
            raise ProfileError(
                f"{profile.source or profile.name}: the profile's joints {profile.joint_names} are not"
                f" the URDF chain to {chain.tip!r}: {names}"
            )
        self.n_joints: int = len(names)
        self.joint_names: tuple[str, ...] = names
        self._fid = self.model.getFrameId(chain.tip)
        self.camera_frame: str = g.camera_frame
        self._camera_fid = self.model.getFrameId(g.camera_frame) if g.camera_frame else None
        self.q_min: tuple[float, ...] = tuple(profile.q_min)
        self.q_max: tuple[float, ...] = tuple(profile.q_max)
        self._lo = np.array(self.q_min, dtype=float)
        self._hi = np.array(self.q_max, dtype=float)
        self._mid = 0.5 * (self._lo + self._hi)
        # the open interval (lo, hi): q is on a limit exactly when clamping into it changes q
        self._lo_open = np.nextafter(self._lo, np.inf)
        self._hi_open = np.nextafter(self._hi, -np.inf)
        self.q_home: tuple[float, ...] = tuple(float(v) for v in np.clip(profile.q_home, self._lo, self._hi))
        self.seed = int(seed)
        self.seed_bank_size = max(0, int(seed_bank_size))
        self._tls = threading.local()
        self._bank_lock = threading.Lock()
        self._bank: Optional[dict] = None
        self.reach_bound_m: float = self._reach_bound()
        self._far_m = FAR_TARGET_FACTOR * max(self.reach_bound_m, 1.0)

    # ---------------------------------------------------------------------------------------
    # Per-thread state

    def _state(self):
        """This thread's (pin.Data, numpy Generator), created on first use."""
        tls = self._tls
        try:
            return tls.data, tls.rng
        except AttributeError:
            tls.data = self.model.createData()
            tls.rng = np.random.default_rng(self.seed + 1)
            return tls.data, tls.rng

    def new_data(self):
        """A fresh ``pin.Data`` for this model (workers that manage their own)."""
        return self.model.createData()

    # ---------------------------------------------------------------------------------------
    # Forward kinematics

    def _q_array(self, q: Sequence[float]) -> np.ndarray:
        a = np.asarray(q, dtype=float).reshape(-1)
        if a.shape[0] != self.n_joints:
            raise ValueError(f"q has {a.shape[0]} values but {self.profile.name!r} has {self.n_joints} joints")
        return a

    def fk(self, q: Sequence[float]) -> np.ndarray:
        """Tool point ``base_p_tool`` in robot_base (m), shape (3,)."""
        d, _ = self._state()
        pin.forwardKinematics(self.model, d, self._q_array(q))
        return pin.updateFramePlacement(self.model, d, self._fid).translation.copy()

    def fk_tuple(self, q: Sequence[float]) -> tuple[float, float, float]:
        """``fk`` as a tuple."""
        p = self.fk(q)
        return (float(p[0]), float(p[1]), float(p[2]))

    def fk_pose(self, q: Sequence[float]) -> np.ndarray:
        """Tool pose ``base_T_tool`` (4x4) in robot_base."""
        d, _ = self._state()
        pin.forwardKinematics(self.model, d, self._q_array(q))
        return pin.updateFramePlacement(self.model, d, self._fid).homogeneous.copy()

    def frame_pose(self, q: Sequence[float], frame: str) -> np.ndarray:
        """Pose (4x4, robot_base) of any URDF frame; ValueError listing the frames if unknown."""
        if not self.model.existFrame(frame):
            raise ValueError(f"{self.urdf_path}: no frame {frame!r}; valid frames: {', '.join(frame_names(self.model))}")
        d, _ = self._state()
        pin.forwardKinematics(self.model, d, self._q_array(q))
        return pin.updateFramePlacement(self.model, d, self.model.getFrameId(frame)).homogeneous.copy()

    def camera_pose(self, q: Sequence[float]) -> Optional[np.ndarray]:
        """``base_T_camera`` (4x4) of the profile's eye-in-hand camera frame, or None without one."""
        if self._camera_fid is None:
            return None
        return self.frame_pose(q, self.camera_frame)

    def mimic_values(self, q: Sequence[float]) -> dict[str, float]:
        """The chain's mimic joints' values (rad or m) for ``q``: ``multiplier · q_X + offset``."""
        return {mj.name: mj.value(float(q[i])) for mj, i in zip(self.mimic_joints, self._mimic_index)}

    def chain_points(self, q: Sequence[float]) -> np.ndarray:
        """robot_base origin, each joint's origin (mimic joints too) and the tool point (m),
        shape (n + m + 2, 3) for n joints and m mimic joints on the chain."""
        d, _ = self._state()
        pin.forwardKinematics(self.model, d, self._q_array(q))
        pts = np.empty((self.model.njoints + 1, 3))
        pts[0] = 0.0
        for j in range(1, self.model.njoints):
            pts[j] = d.oMi[j].translation
        pts[-1] = pin.updateFramePlacement(self.model, d, self._fid).translation
        return pts

    def jacobian(self, q: Sequence[float]) -> np.ndarray:
        """d(base_p_tool)/dq, shape (3, n): rows x, y, z in robot_base."""
        return self.jacobian_pose(q)[:3].copy()

    def jacobian_pose(self, q: Sequence[float]) -> np.ndarray:
        """Tool twist Jacobian (6, n) in robot_base axes at the tool point (linear; angular)."""
        d, _ = self._state()
        J = pin.computeFrameJacobian(self.model, d, self._q_array(q), self._fid, _LWA)
        return np.array(J, dtype=float).reshape(6, self.n_joints)

    # ---------------------------------------------------------------------------------------
    # Limits

    def within_limits(self, q: Sequence[float], tol: float = 0.0) -> bool:
        """True when every joint is finite and inside its limits (± ``tol``)."""
        a = np.asarray(q, dtype=float)
        return bool(a.shape == (self.n_joints,) and np.all(np.isfinite(a))
                    and np.all(a >= self._lo - tol) and np.all(a <= self._hi + tol))

    def _sanitize(self, q: Optional[Sequence[float]]) -> np.ndarray:
        """q as an in-limit array: NaN → middle of the range, outside → clamped; None → home."""
        if q is None:
            return np.array(self.q_home)
        a = np.array(q, dtype=float)
        if a.shape != self._lo.shape:
            a = a.reshape(-1)
            if a.shape[0] != self.n_joints:
                raise ValueError(f"q has {a.shape[0]} values but {self.profile.name!r} has {self.n_joints} joints")
        if not math.isfinite(sum(a.tolist())):  # a NaN or an infinity somewhere (or absurd values)
            nan = np.isnan(a)
            a[nan] = self._mid[nan]
        return np.maximum(np.minimum(a, self._hi), self._lo)

    def _reach_bound(self) -> float:
        """An upper bound of the tool's distance from robot_base's origin (m)."""
        m = self.model
        total = 0.0
        mimics = {mj.name: mj for mj in self.mimic_joints}
        for j in range(1, m.njoints):
            total += float(np.linalg.norm(m.jointPlacements[j].translation))
            iq = m.joints[j].idx_q
            mj = mimics.get(m.names[j])
            if mj is not None:  # idx_q is the mimicked joint's coordinate
                if mj.joint_type == "prismatic":
                    total += abs(mj.multiplier) * max(abs(self._lo[iq]), abs(self._hi[iq])) + abs(mj.offset)
            elif m.joints[j].shortname().startswith("JointModelP"):
                total += max(abs(self._lo[iq]), abs(self._hi[iq]))
        return total + float(np.linalg.norm(m.frames[self._fid].placement.translation))

    # ---------------------------------------------------------------------------------------
    # Seed bank

    def _seed_bank(self) -> dict:
        """Random in-limit configurations and their tip poses (built once, on first need)."""
        bank = self._bank
        if bank is not None:
            return bank
        with self._bank_lock:
            if self._bank is not None:
                return self._bank
            rng = np.random.default_rng(self.seed)
            k = self.seed_bank_size
            qs = rng.uniform(self._lo, self._hi, (k, self.n_joints))
            pos = np.empty((k, 3))
            rot = np.empty((k, 9))
            d = self.model.createData()
            for i in range(k):
                pin.forwardKinematics(self.model, d, qs[i])
                M = pin.updateFramePlacement(self.model, d, self._fid)
                pos[i] = M.translation
                rot[i] = M.rotation.reshape(-1)
            feats = np.hstack([pos, SEED_ROT_SCALE_M * rot])
            self._bank = {
                "q": qs, "pos": pos, "pos2": np.einsum("ij,ij->i", pos, pos),
                "feat": feats, "feat2": np.einsum("ij,ij->i", feats, feats),
            }
            return self._bank

    def _seed_order(self, p_des: np.ndarray, R_des: Optional[np.ndarray], count: int) -> np.ndarray:
        """Indices of the ``count`` bank configurations whose tip poses are nearest the target."""
        bank = self._seed_bank()
        if bank["q"].shape[0] == 0 or count <= 0:
            return np.empty(0, dtype=int)
        if R_des is None:
            dist = bank["pos2"] - 2.0 * (bank["pos"] @ p_des)
        else:
            x = np.concatenate([p_des, SEED_ROT_SCALE_M * R_des.reshape(-1)])
            dist = bank["feat2"] - 2.0 * (bank["feat"] @ x)
        count = min(count, dist.shape[0])
        if count == 1:
            return np.array([int(np.argmin(dist))])
        idx = np.argpartition(dist, count - 1)[:count]
        return idx[np.argsort(dist[idx])]

    # ---------------------------------------------------------------------------------------
    # Inverse kinematics

    def ik(self, base_p_target: Sequence[float], q_current: Optional[Sequence[float]] = None) -> IKResult:
        """Joint values putting the tool point on ``base_p_target`` (robot_base, m).

        ``q_current`` given: a warm solve that stays on its branch when it can; None: a cold
        solve from the seed bank and random restarts. Never raises for an unreachable or
        non-finite target: ``success`` is False and ``q`` the nearest configuration found.
        """
        try:
            p = np.array(base_p_target, dtype=float).reshape(3)
        except ValueError:
            raise ValueError(f"base_p_target must be 3 numbers (x, y, z in m), got {base_p_target!r}") from None
        return self._solve(p, None, _ONES3, q_current, True)

    def ik_pose(
        self,
        oMdes,
        q_current: Optional[Sequence[float]] = None,
        weights: Sequence[float] = _DEFAULT_WEIGHTS,
    ) -> IKResult:
        """Joint values putting the tool frame at ``oMdes`` (pin.SE3 or 4x4, in robot_base).

        ``weights`` = (wx, wy, wz, wrx, wry, wrz) scale the position (m) and orientation (rad)
        errors along robot_base's axes; 0 drops an axis (e.g. ``wrz = 0`` leaves the tool's yaw
        free). All-zero orientation weights make it a position solve.
        """
        p, R = pose_parts(oMdes)
        if weights is _DEFAULT_WEIGHTS:  # the common case skips the checks below
            return self._solve(p, R, _ONES6, q_current, True)
        w = np.asarray(weights, dtype=float).reshape(-1)
        if w.shape != (6,) or not np.all(np.isfinite(w)) or np.any(w < 0) or not np.any(w[:3] > 0):
            raise ValueError(
                f"weights = {tuple(weights)} must be 6 finite numbers ≥ 0 (wx, wy, wz, wrx, wry, wrz),"
                " with at least one position weight > 0"
            )
        if not np.any(w[3:] > 0):
            w3 = w[:3].copy()
            return self._solve(p, None, w3, q_current, bool(np.all(w3 == 1.0)))
        return self._solve(p, R, w, q_current, bool(np.all(w == 1.0)))

    def _solve(self, p_des, R_des, w, q_current, unit: bool) -> IKResult:
        d, rng = self._state()
        warm = q_current is not None
        q_start = self._sanitize(q_current)
        x, y, z = p_des.tolist()
        isfinite = math.isfinite
        if not (isfinite(x) and isfinite(y) and isfinite(z)
                and (R_des is None or all(map(isfinite, R_des.ravel().tolist())))):
            return self._result(d, q_start, p_des, R_des, w, False, 0, 0, "target is not finite")
        p_target = p_des
        far = self._far_m
        if not (-far <= x <= far and -far <= y <= far and -far <= z <= far):
            # absurdly far (1e308 m): aim at the point of its ray `far` away, where squared errors
            # stay finite; the answer's distances are still measured to the real target
            p_des = np.array(bring_near((x, y, z), far))
            x, y, z = p_des.tolist()
        beyond = math.sqrt(x * x + y * y + z * z) > self.reach_bound_m  # surely out of reach
        starts: list = []
        if warm:
            starts.append(q_start)
            n_more = WARM_ATTEMPTS
        else:
            n_more = COLD_ATTEMPTS
        if beyond:
            n_more = min(n_more, WARM_ATTEMPTS)
        best_q, best_E, total_it = None, math.inf, 0
        agree = 0
        order = None
        n_total = len(starts) + n_more
        bank_q = None
        next_bank = 0
        attempt = 0
        for attempt in range(n_total):
            from_random = False
            if attempt < len(starts):
                q0 = starts[attempt]
            else:
                k = attempt - len(starts)
                if order is None:  # the nearest seed costs one argmin; the full order is lazy
                    order = self._seed_order(p_des, R_des, 1)
                    bank_q = self._seed_bank()["q"]
                elif len(order) == 1 and next_bank >= 1:
                    order = self._seed_order(p_des, R_des, n_more)
                use_bank = k < FIRST_BANK_SEEDS or (k - FIRST_BANK_SEEDS) % 2 == 1
                if use_bank and next_bank < len(order):
                    q0 = bank_q[order[next_bank]]
                    next_bank += 1
                else:
                    q0 = rng.uniform(self._lo, self._hi)
                    from_random = True
            q, ok, it, E, raw = self._attempt(d, q0, p_des, R_des, w, unit)
            total_it += it
            if ok:
                msg = ""
                if warm and attempt > 0:
                    jump = float(np.max(np.abs(q - q_start)))
                    msg = f"solved on another branch: joints jump by up to {jump:.2f}"
                # d holds q's placement (the last evaluation was the accepted step)
                return self._converged_result(d, q, E, raw, total_it, attempt, msg)
            if best_q is None or E < best_E * (1.0 - AGREE_REL):
                best_q, best_E = q, E
                agree = 1 if from_random else 0
            elif from_random and E <= best_E * (1.0 + AGREE_REL):
                agree += 1
                if agree >= UNREACHABLE_AGREE:
                    break
        # the best attempt stopped when its error stopped halving: polish it into the nearest point
        q, ok, it, E, _ = self._attempt(d, best_q, p_des, R_des, w, unit, polish=True)
        total_it += it
        return self._result(d, q, p_target, R_des, w, ok, total_it, attempt, "" if ok else None)

    def _attempt(self, d, q0, p_des, R_des, w, unit, polish: bool = False):
        """One damped least-squares descent from ``q0``: (q, success, iterations, error², raw).

        ``raw`` = (|p_des − p|², |log3(R_des·Rᵀ)|²) at the returned q, unweighted (0 for the
        orientation of a position solve). Written for speed — this loop is the solver's whole
        cost, and a warm solve is two iterations of it: locals only, one Pinocchio call per
        evaluation, the error and the convergence test in Python floats (NumPy's per-call cost
        dwarfs six multiplications), NumPy only for the Jacobian algebra, and a closed-form 3×3
        solve for position problems.
        """
        model, fid, lo, hi = self.model, self._fid, self._lo, self._hi
        cfj, log3, solve, array = pin.computeFrameJacobian, pin.log3, _small_solve, np.array
        minimum, maximum = np.minimum, np.maximum
        oMf = d.oMf
        pose = R_des is not None
        ne = 6 if pose else 3
        n = self.n_joints
        one_joint = n == 1
        px, py, pz = p_des.tolist()
        if not unit:
            wcol = w[:, None]
            # 1 for an axis that counts towards convergence, 0 for one the caller dropped
            cx, cy, cz, *c_rot = (1.0 if v > 0.0 else 0.0 for v in w.tolist())
            crx, cry, crz = c_rot if pose else (0.0, 0.0, 0.0)
        eps_p2, eps_r2 = EPS_POS_M * EPS_POS_M, EPS_ROT_RAD * EPS_ROT_RAD
        rx = ry = rz = e2r = 0.0

        q = q0
        qn_on_limit = maximum(minimum(q, self._hi_open), self._lo_open).tobytes() != q.tobytes()
        on_limit = qn_on_limit
        history = []
        it = 0
        mu = 1.0
        J = e = None
        E = math.inf
        raw = (math.inf, math.inf)
        qn = q
        while True:
            # evaluate qn (the start, or a candidate step)
            Jn = cfj(model, d, qn, fid, _LWA)
            if one_joint:  # Pinocchio hands a 6×1 Jacobian back as a vector
                Jn = Jn.reshape(6, 1)
            M = oMf[fid]
            tx, ty, tz = M.translation.tolist()
            ex, ey, ez = px - tx, py - ty, pz - tz
            e2p = ex * ex + ey * ey + ez * ez
            if pose:
                rx, ry, rz = log3(R_des.dot(M.rotation.T)).tolist()
                e2r = rx * rx + ry * ry + rz * rz
                en = array((ex, ey, ez, rx, ry, rz))
            else:
                en = array((ex, ey, ez))
                Jn = Jn[:3]
            if unit:
                En = e2p + e2r
            else:
                en *= w
                Jn = Jn * wcol
                En = float(en.dot(en))
            if En < E:  # accept (always, for the start)
                q, J, e, E = qn, Jn, en, En
                raw = (e2p, e2r)
                on_limit = qn_on_limit
                mu = max(mu * DAMP_DOWN, 1.0)
                # converged? the raw error of the axes that count, against the tolerances
                if unit:
                    ok = e2p < eps_p2 and e2r < eps_r2
                else:
                    ok = (cx * ex * ex + cy * ey * ey + cz * ez * ez < eps_p2
                          and crx * rx * rx + cry * ry * ry + crz * rz * rz < eps_r2)
                if ok:
                    return q, True, it, E, raw
                if polish:  # nearest point of an unreachable target: run until no progress
                    if history and history[-1] - E <= POLISH_REL_DECREASE * history[-1]:
                        return q, False, it, E, raw
                elif (len(history) > STALL_WINDOW and E > STALL_MIN_E
                        and E > STALL_RATIO * history[-STALL_WINDOW - 1]):
                    return q, False, it, E, raw
                history.append(E)
            else:
                if J is None:  # the start's error is not finite (no FK there): nothing to descend
                    return q, False, it, math.inf, raw
                mu *= DAMP_UP
                if mu > MU_MAX:  # no descent direction left inside the limits: a local minimum
                    return q, False, it, E, raw
            if it >= (POLISH_IT_MAX if polish else IT_MAX):
                return q, False, it, E, raw
            it += 1
            lam = (DAMP_MIN + DAMP_ERR * E) * mu
            # joints held at a limit by the descent direction leave the solve (active set), so
            # the others converge instead of fighting a step the clamp keeps undoing
            Jf = J
            held = None
            if on_limit:
                g = e.dot(J)
                held = ((q <= lo) & (g < 0.0)) | ((q >= hi) & (g > 0.0))
                if held.all():
                    return q, False, it, E, raw
                if held.any():
                    Jf = J[:, ~held]
                else:
                    held = None
            JfT = Jf.T
            nf = JfT.shape[0]
            if nf < ne:
                A = JfT.dot(Jf)
                A.flat[:: nf + 1] += lam
                dqf = solve(A, JfT.dot(e))
            elif ne == 3:
                dqf = JfT.dot(_solve3_spd(Jf.dot(JfT), e, lam))
            else:
                A = Jf.dot(JfT)
                A.flat[::7] += lam
                dqf = JfT.dot(solve(A, e))
            if held is None:
                qf = q + dqf if DT == 1.0 else q + DT * dqf
            else:
                dq = np.zeros(n)
                dq[~held] = dqf
                qf = q + dq if DT == 1.0 else q + DT * dq
            # clamp into the limits; "on a limit" when the clamp changed anything (bitwise)
            qn = maximum(minimum(qf, hi), lo)
            qn_on_limit = held is not None or qn.tobytes() != qf.tobytes()

    def _converged_result(self, d, q, E, raw, iterations, restarts, message) -> IKResult:
        """The answer of a converged attempt (the warm-start hot path, so nothing is recomputed):
        q is in limits, d holds its tip placement, E is the weighted squared residual and raw
        the unweighted squared position and orientation errors."""
        p = tuple(d.oMf[self._fid].translation.tolist())
        qt = tuple(q.tolist())
        return IKResult(
            q=qt, success=True, reachable=True, error_m=math.sqrt(raw[0]), base_p_reached=p,
            branches=(qt,), message=message, iterations=iterations, residual=math.sqrt(E),
            error_rad=math.sqrt(raw[1]), restarts=restarts,
        )

    def _result(self, d, q, p_des, R_des, w, ok, iterations, restarts, message) -> IKResult:
        """The answer for any q (clamped into the limits), its errors computed afresh."""
        q = np.minimum(np.maximum(np.asarray(q, dtype=float), self._lo), self._hi)
        pin.forwardKinematics(self.model, d, q)
        M = pin.updateFramePlacement(self.model, d, self._fid)
        p = M.translation
        # sums and squares of a finite target can overflow (1e308 m): test each value, and
        # measure with hypot
        finite = all_finite(p_des.tolist())
        error_m = distance_m(p_des, p) if finite else math.inf
        error_rad = 0.0
        e = np.zeros(3 if R_des is None else 6)
        if finite:
            e[:3] = p_des - p
        if R_des is not None:
            if all_finite(R_des.ravel().tolist()):
                e[3:] = pin.log3(R_des @ M.rotation.T)
                error_rad = math.sqrt(float(e[3:] @ e[3:]))  # |log3| is the rotation angle
            else:
                error_rad = math.inf
        residual = math.hypot(*(e * w).tolist()) if finite else math.inf
        residual = math.inf if math.isnan(residual) else residual
        if message is None:
            if R_des is None or error_rad < EPS_ROT_RAD:
                message = f"out of reach by {format_distance(error_m)}"
            else:
                message = f"pose not reached: {format_distance(error_m)}, {math.degrees(error_rad):.2g}°"
        qt = tuple(q.tolist())
        return IKResult(
            q=qt, success=ok, reachable=ok, error_m=error_m,
            base_p_reached=(float(p[0]), float(p[1]), float(p[2])),
            branches=(qt,) if ok else (), message=message, iterations=int(iterations),
            residual=residual, error_rad=error_rad, restarts=int(restarts),
        )

    # ---------------------------------------------------------------------------------------
    # Workspace (approximate: from the seed bank's sampled forward kinematics)

    def workspace_radius_range(self) -> tuple[float, float]:
        """(min, max) horizontal distance (m) of the tool from robot_base's z axis.

        Approximate: the range over the seed bank's ``SEED_BANK_SIZE`` sampled configurations.
        """
        pos = self._seed_bank()["pos"]
        if pos.shape[0] == 0:
            return (0.0, self.reach_bound_m)
        r = np.hypot(pos[:, 0], pos[:, 1])
        return (float(r.min()), float(r.max()))

    def workspace_outline_side(self, n_bins: int = 40) -> np.ndarray:
        """Approximate outline of the reachable set as (s, z) rows (m), for the side view.

        s is the horizontal distance from robot_base's z axis (≥ 0), z the height above the
        desk: the sampled tool points binned by height, outer edge going up, inner edge coming
        back down, closed. Approximate (seed-bank samples), unlike the RRR arm's exact outline.
        """
        pos = self._seed_bank()["pos"]
        if pos.shape[0] < 2:
            return np.zeros((0, 2))
        r = np.hypot(pos[:, 0], pos[:, 1])
        z = pos[:, 2]
        edges = np.linspace(z.min(), z.max(), max(2, int(n_bins)) + 1)
        idx = np.clip(np.digitize(z, edges) - 1, 0, len(edges) - 2)
        outer, inner = [], []
        for b in range(len(edges) - 1):
            sel = idx == b
            if not sel.any():
                continue
            zc = 0.5 * (edges[b] + edges[b + 1])
            outer.append((float(r[sel].max()), zc))
            inner.append((float(r[sel].min()), zc))
        pts = outer + inner[::-1]
        pts.append(pts[0])
        return np.array(pts, dtype=float)
