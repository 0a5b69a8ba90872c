"""The automatic hand-eye sweep: the arm carries its marker to spread poses, the cameras watch.

``HandEyeSweep`` plans the poses and is then driven by ``step`` on every camera frame (pure, no
threads, no clock of its own): it says where the tool should go, waits until the measured joints
got there, lets the arm settle, collects the tool marker's triangulated centre for ``hold_s``
and moves on. ``result`` solves ``base_T_camera`` from the medians.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable, Optional, Sequence

import numpy as np

from core.handeye.solve import HandEyeResult, ToolMarker, solve_rigid, tool_marker_of

PHASES = ("moving", "settling", "sampling", "done")
REACH_TOL_M = 0.010  # the measured tool is "there" within this (1° servo steps: ~3 mm at 20 cm)
MOVE_TIMEOUT_S = 6.0  # a pose not reached by then is skipped
MIN_SAMPLES = 3  # observations a pose needs to count
MIN_HEIGHT_M = 0.04  # planned tool points stay this far above the desk
MIN_FORWARD_M = 0.04  # … and this far in front of the base (y), where the cameras see the tool
MIN_RADIUS_M = 0.07  # … and this far from the base's axis (a folded arm hides its own marker)
CANDIDATES = 4000  # random joint configurations drawn to plan from


@dataclass(frozen=True)
class SweepStep:
    """What the sweep wants now."""

    goal_base_p: Optional[tuple[float, float, float]]  # tool point to go to (robot_base, m); None when done
    index: int  # pose being visited (0-based; = n when done)
    phase: str  # moving | settling | sampling | done
    progress: float  # 0 … 1
    message: str


class HandEyeSweep:
    """Plans ``n_poses`` tool points the arm reaches and the cameras share, then visits them.

    ``camera_view_check(base_p_marker) -> bool`` says whether a marker centre would be seen by
    both cameras (None: every point counts as seen).
    """

    def __init__(self, profile, kinematics, n_poses: int = 12, hold_s: float = 0.8, settle_s: float = 0.5,
                 seed: int = 0, camera_view_check: Optional[Callable[[np.ndarray], bool]] = None,
                 tool_marker: Optional[ToolMarker] = None, move_timeout_s: float = MOVE_TIMEOUT_S,
                 reach_tol_m: float = REACH_TOL_M):
        if not 1 <= int(n_poses) <= 200:
            raise ValueError(f"--poses {n_poses} is outside 1…200 (12 is a good start)")
        if not (0.0 < hold_s <= 30.0 and 0.0 <= settle_s <= 30.0):
            raise ValueError(f"hold_s = {hold_s}, settle_s = {settle_s}: need 0 < hold_s ≤ 30 and 0 ≤ settle_s ≤ 30")
        self.profile = profile
        self.kinematics = kinematics
        self.n_poses = int(n_poses)
        self.hold_s = float(hold_s)
        self.settle_s = float(settle_s)
        self.seed = int(seed)
        self.camera_view_check = camera_view_check
        self.marker = tool_marker or tool_marker_of(profile)
        self.offset = np.asarray(self.marker.offset_m, float)
        self.move_timeout_s = float(move_timeout_s)
        self.reach_tol_m = float(reach_tol_m)
        self.points = self.plan()
        self.index = 0
        self.phase = "moving"
        self._t0: Optional[float] = None
        self._cam: list = []
        self._base: list = []
        self.camera_points: list[np.ndarray] = []  # medians per pose that was seen (camera_left)
        self.base_points: list[np.ndarray] = []  # the marker centres of those poses (robot_base)
        self.pose_indices: list[int] = []  # which planned pose each pair came from
        self.unseen: list[int] = []  # poses where the marker was not seen (enough)
        self.unreached: list[int] = []  # poses the arm did not reach in time
        self.message = f"moving to pose 1 of {len(self.points)}"

    # -- planning ---------------------------------------------------------------------------
    def plan(self) -> list[np.ndarray]:
        """Tool points (robot_base) spread over the reachable, shared workspace (farthest-point order)."""
        rng = np.random.default_rng(self.seed)
        lo = np.array([j.q_min for j in self.profile.joints], float)
        hi = np.array([j.q_max for j in self.profile.joints], float)
        cand = []
        for q in rng.uniform(lo, hi, size=(CANDIDATES, len(lo))):
            p = np.asarray(self.kinematics.fk(q), float)[:3]
            if p[2] < MIN_HEIGHT_M or p[1] < MIN_FORWARD_M or math.hypot(p[0], p[1]) < MIN_RADIUS_M:
                continue
            if self.camera_view_check is not None and not self.camera_view_check(p + self.offset):
                continue
            ik = self.kinematics.ik(tuple(p), tuple(self.profile.q_home))
            if not ik.reachable or ik.error_m > 1e-3:
                continue
            cand.append(p)
        if not cand:
            return []
        C = np.array(cand)
        # farthest-point sampling: first the point farthest from the centroid, then each next
        # one farthest from all chosen
        chosen = [int(np.argmax(np.linalg.norm(C - C.mean(axis=0), axis=1)))]
        dmin = np.linalg.norm(C - C[chosen[0]], axis=1)
        while len(chosen) < min(self.n_poses, len(C)):
            k = int(np.argmax(dmin))
            chosen.append(k)
            dmin = np.minimum(dmin, np.linalg.norm(C - C[k], axis=1))
        pts = [C[k] for k in chosen]
        # visit them in a short chain from the home pose's tool point
        here = np.asarray(self.kinematics.fk(self.profile.q_home), float)[:3]
        order = []
        left = list(range(len(pts)))
        while left:
            j = min(left, key=lambda i: float(np.linalg.norm(pts[i] - here)))
            order.append(pts[j])
            here = pts[j]
            left.remove(j)
        return order

    # -- driving ----------------------------------------------------------------------------
    @property
    def done(self) -> bool:
        return self.phase == "done"

    def _progress(self, t: float) -> float:
        n = max(1, len(self.points))
        if self.done:
            return 1.0
        frac = {"moving": 0.0, "settling": 0.3, "sampling": 0.5}[self.phase]
        if self.phase == "sampling" and self._t0 is not None:
            frac += 0.5 * min(1.0, (t - self._t0) / self.hold_s)
        return min(1.0, (self.index + frac) / n)

    def _next(self, t: float) -> None:
        self.index += 1
        self._t0, self._cam, self._base = t, [], []
        if self.index >= len(self.points):
            self.phase = "done"
            self.message = (f"done: {len(self.camera_points)} of {len(self.points)} poses seen"
                            + (f", {len(self.unseen)} unseen" if self.unseen else "")
                            + (f", {len(self.unreached)} not reached" if self.unreached else ""))
        else:
            self.phase = "moving"

    def step(self, t: float, observation_camera_p, q_measured: Sequence[float]) -> SweepStep:
        """Advance with one camera frame: ``observation_camera_p`` is the tool marker's
        triangulated centre in camera_left (None when not seen in this frame), ``q_measured``
        the arm's measured joints. Returns where to go now."""
        if not self.points and not self.done:
            self.phase = "done"
            self.message = "no pose planned: no reachable tool point is in both camera views"
        if self.done:
            return SweepStep(None, len(self.points), "done", 1.0, self.message)
        goal = self.points[self.index]
        if self._t0 is None:
            self._t0 = t
        tip = np.asarray(self.kinematics.fk(q_measured), float)[:3]
        n = len(self.points)
        if self.phase == "moving":
            if float(np.linalg.norm(tip - goal)) <= self.reach_tol_m:
                self.phase, self._t0 = "settling", t
            elif t - self._t0 > self.move_timeout_s:
                self.unreached.append(self.index)
                self.message = f"pose {self.index + 1} not reached in {self.move_timeout_s:g} s — skipped"
                self._next(t)
                return self.step(t, observation_camera_p, q_measured)
            else:
                self.message = f"moving to pose {self.index + 1} of {n}"
        if self.phase == "settling":
            if t - self._t0 >= self.settle_s:
                self.phase, self._t0, self._cam, self._base = "sampling", t, [], []
            else:
                self.message = f"settling at pose {self.index + 1} of {n}"
        if self.phase == "sampling":
            if observation_camera_p is not None and all(map(math.isfinite, observation_camera_p)):
                self._cam.append(np.asarray(observation_camera_p, float))
                self._base.append(tip + self.offset)
            self.message = f"sampling pose {self.index + 1} of {n} ({len(self._cam)} sightings)"
            if t - self._t0 >= self.hold_s:
                if len(self._cam) >= MIN_SAMPLES:
                    self.camera_points.append(np.median(np.array(self._cam), axis=0))
                    self.base_points.append(np.median(np.array(self._base), axis=0))
                    self.pose_indices.append(self.index)
                else:
                    self.unseen.append(self.index)
                self._next(t)
                if self.done:
                    return SweepStep(None, n, "done", 1.0, self.message)
                goal = self.points[self.index]
        return SweepStep(tuple(float(v) for v in goal), self.index, self.phase, self._progress(t), self.message)

    # -- answer -----------------------------------------------------------------------------
    def result(self, camera_pair: str = "") -> HandEyeResult:
        """Solve ``base_T_camera`` from the poses seen so far (method "sweep")."""
        skipped = len(self.unseen) + len(self.unreached)
        notes = []
        if self.unseen:
            notes.append(f"marker {self.marker.marker_id} not seen at {len(self.unseen)} pose(s)")
        if self.unreached:
            notes.append(f"{len(self.unreached)} pose(s) not reached")
        res = solve_rigid(np.array(self.camera_points).reshape(-1, 3), np.array(self.base_points).reshape(-1, 3),
                          method="sweep", camera_pair=camera_pair, skipped=skipped, skipped_note="; ".join(notes))
        if not res.ok and not self.camera_points and self.points:
            res = replace(res, problem=(
                f"tool marker {self.marker.marker_id} was never seen in both views at any of the "
                f"{len(self.points)} poses — fix the marker (id {self.marker.marker_id}, "
                f"{self.marker.size_m * 1e3:.0f} mm, DICT_6X6_250) on the tool facing up, check that both "
                "cameras see the arm's workspace and the light, then run again"))
        elif not self.points:
            res = replace(res, ok=False, problem=("no pose planned: no reachable tool point is in both camera "
                                                  "views — point the cameras at the arm's workspace"))
        return res
