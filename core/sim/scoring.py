"""Scoring a run against the simulated desk's ground truth: the metrics that need to know what
really happened, next to the truth they need.

Each scorer is fed the run's events — every camera frame's ``GroundTruth`` (``note_frame``) and
every command the control step sent (``note_command``) — and gives its part of the headless
JSON (``summary``). No Qt, no session: a scorer takes the kinematics and the pointing rule it
scores with, so tests feed it synthetic events.

- ``FollowScore`` (FOLLOW mode: the static and wander scenarios): how closely the commanded tool
  follows the followed marker. By the wander scenario's design about half of its commands are out
  of reach (the cards glide beyond the arm's reach), so the error is taken to the *reachable
  projection* of the true aim — the nearest point the arm reaches — at every control step, not only
  after the arm settled on a still goal (``reach_error_mm_*``, null when the goal never stops).
- ``CupsScore`` (the cups game): at every frame where the game points at a cup (a valid goal), is
  it the cup that hides the ball by the simulator's truth (``GroundTruth.pointing_target_id``)?
"""
from __future__ import annotations

from typing import Callable, Optional, Sequence

import numpy as np

FOLLOW_REACH_TOL_M = 0.002  # a true aim IK reaches within this counts as reachable


def _percentile(values, q: float) -> Optional[float]:
    return float(np.percentile(np.asarray(values, dtype=float), q)) if len(values) else None


def _rounded(v, nd: int = 3):
    return None if v is None else round(float(v), nd)


class FollowScore:
    """The commanded tool vs the reachable projection of the followed marker's true aim, over time.

    ``kinematics``: ``fk(q)`` and ``ik(p, q_hint)`` (with ``error_m`` and ``base_p_reached``);
    ``aim``: the targeter's pointing rule (marker centre -> where the tool should point, robot_base);
    ``marker_id``: the followed marker. ``samples``: where error samples go (a list, or the headless
    runner's bounded reservoir).

    At each command (``note_command``), while the marker was visible in both views at the latest
    frame (the arm could know where it is): the marker's true centre carried from that frame to the
    command's time with its true velocity, through ``aim``; its nearest reachable point (IK); the
    error is the distance from the commanded tool point (FK of the command) to it. The step counts
    as reachable when IK reaches the true aim within FOLLOW_REACH_TOL_M.
    """

    def __init__(self, kinematics, aim: Callable, marker_id: int, samples: Optional[list] = None):
        self.kinematics = kinematics
        self.aim = aim
        self.marker_id = int(marker_id)
        self.errors_mm = samples if samples is not None else []
        self.steps = 0  # commands scored (the marker visible in both views)
        self.reachable_steps = 0  # of those, with the true aim in reach
        self._truth: Optional[tuple[float, np.ndarray, np.ndarray, bool]] = None  # (t, centre, velocity, visible)

    def note_frame(self, t: float, truth) -> None:
        """A camera frame taken at ``t`` with its ground truth (None: not a simulated frame)."""
        obj = None if truth is None else truth.by_id().get(self.marker_id)
        if obj is None:
            self._truth = None
            return
        p = np.asarray(obj.base_p_centre, dtype=float)
        prev = self._truth
        v = np.zeros(3) if prev is None or t - prev[0] <= 1e-6 else (p - prev[1]) / (t - prev[0])
        self._truth = (float(t), p, v, bool(obj.visible_left and obj.visible_right))

    def note_command(self, t: float, q_cmd: Sequence[float], q_hint: Optional[Sequence[float]] = None) -> None:
        """A command sent at ``t`` (joint values ``q_cmd``); ``q_hint``: the arm's joints, for IK."""
        truth = self._truth
        if truth is None or not truth[3]:
            return
        t_truth, p, v, _ = truth
        aim = np.asarray(self.aim(p + v * (t - t_truth)), dtype=float)
        if not np.all(np.isfinite(aim)):
            return
        ik = self.kinematics.ik(tuple(float(x) for x in aim), q_hint if q_hint is not None else q_cmd)
        reached = np.asarray(ik.base_p_reached, dtype=float)
        tool = np.asarray(self.kinematics.fk(q_cmd), dtype=float)
        self.steps += 1
        self.reachable_steps += int(float(ik.error_m) <= FOLLOW_REACH_TOL_M)
        self.errors_mm.append(float(np.linalg.norm(tool - reached)) * 1e3)

    def summary(self) -> dict:
        """``follow_tracking_mm_p50/p95``, ``follow_tracking_samples`` and ``follow_reachable_ratio``
        (the share of scored steps whose true aim was in reach; None before any)."""
        return {
            "follow_tracking_mm_p50": _rounded(_percentile(self.errors_mm, 50)),
            "follow_tracking_mm_p95": _rounded(_percentile(self.errors_mm, 95)),
            "follow_tracking_samples": self.steps,
            "follow_reachable_ratio": _rounded(self.reachable_steps / self.steps if self.steps else None),
        }


class CupsScore:
    """The cups game's correctness: the share of decision frames (the game points at a cup: a valid
    goal) whose goal is on the cup that hides the ball by the truth.

    The cup the goal is on is the cup whose true pointing position (``aim`` of its true centre) is
    nearest to the goal — the cup the arm is sent to, whatever the game believes internally.
    """

    def __init__(self, aim: Callable, cup_ids: Sequence[int]):
        self.aim = aim
        self.cup_ids = tuple(int(i) for i in cup_ids)
        self.decisions = 0
        self.correct = 0

    def note_decision(self, base_p_goal, truth) -> Optional[bool]:
        """One frame's valid goal (robot_base) with the frame's truth; whether it is on the ball's
        cup (None: the truth cannot say — no truth, no hiding cup, or a cup missing)."""
        if truth is None or truth.pointing_target_id is None:
            return None
        cups = truth.by_id()
        if any(i not in cups for i in self.cup_ids):
            return None
        goal = np.asarray(base_p_goal, dtype=float)
        nearest = min(self.cup_ids,
                      key=lambda i: float(np.linalg.norm(np.asarray(self.aim(cups[i].base_p_centre)) - goal)))
        ok = nearest == truth.pointing_target_id
        self.decisions += 1
        self.correct += int(ok)
        return ok

    def summary(self) -> dict:
        """``cups_correct_ratio`` (None before any decision) and ``cups_decision_frames``."""
        return {
            "cups_correct_ratio": _rounded(self.correct / self.decisions if self.decisions else None),
            "cups_decision_frames": self.decisions,
        }
