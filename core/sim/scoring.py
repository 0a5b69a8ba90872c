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
- ``MarkerScore``: the perceived markers against their true centres (seen ratio, 3D error).

The same scores for any run: ``TruthScore`` takes the run's events — a ``FrameEvent`` per camera
frame (its truth, the markers perception found, the goal it led to) and a ``CommandEvent`` per
command sent — from the headless runner as it runs, or from a recording afterwards
(``recording_events``: the truth, perceived markers, goals and joint states a deskarm recording
holds), so a replay or a remote run is scored without the runner (``score_recording``).
Marker-less objects are scored in ``core.sim.object_scoring``.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterable, Iterator, Mapping, Optional, Sequence, Union

import numpy as np

FOLLOW_REACH_TOL_M = 0.002  # a true aim IK reaches within this counts as reachable


def percentile(values, q: float) -> Optional[float]:
    """The q-th percentile of ``values`` (None when empty)."""
    return float(np.percentile(np.asarray(values, dtype=float), q)) if len(values) else None


def rounded(v, nd: int = 3):
    """A summary figure rounded to ``nd`` places (None stays None: nothing was measured)."""
    return None if v is None else round(float(v), nd)



class MarkerScore:
    """The perceived markers against the truth: of the (frame, marker) pairs visible in both views
    by the truth, how many perception found, and how far from their true centres (mm).

    ``samples``: where the 3D error samples go (a list, or the headless runner's bounded reservoir).
    """

    def __init__(self, samples: Optional[list] = None):
        self.errors_mm = samples if samples is not None else []
        self.visible_pairs = 0  # (frame, marker) pairs visible in both views by the truth
        self.seen_pairs = 0  # of those, how many perception found

    def note_frame(self, truth, found: Mapping[int, Sequence[float]]) -> list[float]:
        """One frame's truth (None: nothing to score) and the markers perception found in it
        (marker id -> centre, robot_base); returns this frame's 3D errors (mm)."""
        errors: list[float] = []
        if truth is None:
            return errors
        for obj in truth.objects:
            if obj.marker_id < 0 or not (obj.visible_left and obj.visible_right):
                continue
            self.visible_pairs += 1
            p = found.get(obj.marker_id)
            if p is not None:
                self.seen_pairs += 1
                errors.append(float(np.linalg.norm(np.subtract(p, obj.base_p_centre))) * 1e3)
        self.errors_mm.extend(errors)
        return errors

    def summary(self) -> dict:
        """``error_3d_mm_p50/p95`` (None before any) and ``markers_seen_ratio`` (0 before any)."""
        return {
            "error_3d_mm_p50": rounded(percentile(self.errors_mm, 50)),
            "error_3d_mm_p95": rounded(percentile(self.errors_mm, 95)),
            "markers_seen_ratio": rounded(self.seen_pairs / self.visible_pairs if self.visible_pairs else 0.0),
        }


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
            "follow_tracking_mm_p50": rounded(percentile(self.errors_mm, 50)),
            "follow_tracking_mm_p95": rounded(percentile(self.errors_mm, 95)),
            "follow_tracking_samples": self.steps,
            "follow_reachable_ratio": rounded(self.reachable_steps / self.steps if self.steps else None),
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
            "cups_correct_ratio": rounded(self.correct / self.decisions if self.decisions else None),
            "cups_decision_frames": self.decisions,
        }


# ------------------------------------------------------------------------------------------------
# the run's events, from a live run or a recording


@dataclass(frozen=True)
class FrameEvent:
    """One camera frame as the scores see it: its time, its truth (None: not a simulated frame),
    the markers perception found (marker id -> centre, robot_base) and the goal it led to (the
    target point, robot_base, when the goal was valid; else None)."""

    t: float
    truth: object
    markers: Mapping[int, tuple]
    goal: Optional[tuple] = None

    @classmethod
    def of(cls, frame, result, goal=None) -> "FrameEvent":
        """The event of a StereoFrame, its PerceptionResult and the targeter's Goal for it."""
        found = {int(m.marker_id): tuple(float(v) for v in m.base_p_centre) for m in result.markers
                 if m.found and m.base_p_centre is not None}
        target = None
        if goal is not None and goal.valid:
            target = tuple(float(v) for v in goal.base_p_target)
        return cls(float(frame.t), frame.truth, found, target)


@dataclass(frozen=True)
class CommandEvent:
    """One command sent: its time, the commanded joints and the arm's joints then (IK's hint)."""

    t: float
    q_cmd: tuple
    q_hint: Optional[tuple] = None


Event = Union[FrameEvent, CommandEvent]


class TruthScore:
    """Every truth score of a run, fed its events (``note``): the markers always, following a
    marker (``follow_id``) and the cups game (``cup_ids``) when asked.

    ``kinematics`` (``fk``, ``ik``) and ``aim`` (the targeter's pointing rule) are what FollowScore
    and CupsScore score with; ``follow_samples``: where FollowScore's samples go; ``markers``: the
    MarkerScore to count into (a new one by default).
    """

    def __init__(self, kinematics=None, aim: Optional[Callable] = None, follow_id: Optional[int] = None,
                 cup_ids: Optional[Sequence[int]] = None, follow_samples: Optional[list] = None,
                 markers: Optional[MarkerScore] = None):
        self.markers = markers if markers is not None else MarkerScore()
        self.follow = (FollowScore(kinematics, aim, follow_id, samples=follow_samples)
                       if follow_id is not None else None)
        self.cups = CupsScore(aim, cup_ids) if cup_ids is not None else None
        self.truth_seen = False  # a frame carried truth: the follow and cups scores mean something

    @classmethod
    def for_targeter(cls, kinematics, targeter, **kwargs) -> "TruthScore":
        """The scores of a run whose targeter is ``targeter`` (its mode says which; its pointing
        rule is read at each use, as the targeter applies it)."""
        from core.messages import TargetMode

        aim = lambda p: targeter.pointing.apply(p)  # noqa: E731 (the targeter's rule at the time)
        follow = targeter.follow_id if targeter.mode is TargetMode.FOLLOW else None
        cups = targeter.cup_ids if targeter.mode is TargetMode.CUPS else None
        return cls(kinematics, aim, follow, cups, **kwargs)

    def note(self, event: Event) -> list[float]:
        """One event; for a frame, its markers' 3D errors (mm), for a live status line."""
        if isinstance(event, CommandEvent):
            if self.follow is not None:
                self.follow.note_command(event.t, event.q_cmd, event.q_hint)
            return []
        errors = self.markers.note_frame(event.truth, event.markers)
        if event.truth is None:
            return errors
        self.truth_seen = True
        if self.follow is not None:
            self.follow.note_frame(event.t, event.truth)
        if self.cups is not None and event.goal is not None:
            self.cups.note_decision(event.goal, event.truth)
        return errors

    def scores(self) -> list:
        """The follow and cups scores that apply (none before a frame carried truth)."""
        return [s for s in (self.follow, self.cups) if s is not None] if self.truth_seen else []

    def summary(self) -> dict:
        """The markers' part of the headless JSON, then the follow and cups parts that apply."""
        return {**self.markers.summary(), **{k: v for s in self.scores() for k, v in s.summary().items()}}


def recording_events(recording) -> Iterator[Event]:
    """The events a recording holds (``core.record.reader.Recording``, duck-typed), in time order.

    A frame per image pair, with the truth recorded for its instant, the markers perceived at its
    time and the latest goal recorded at or before it (a goal is recorded when a command carries a
    new valid one: a goal that became invalid later is not known); a command per commanded joint
    state, its hint the measured joints at or before it. Visibility comes from the recording's
    truth (projected through the recorded calibration), so it may differ from the live run's at
    the image borders.
    """
    markers = {round(t, 6): dict(found) for t, found in recording.markers}
    goals = sorted(recording.goals)
    events: list[tuple[float, int, Event]] = []
    g = 0
    for t in recording.pair_times_s:
        while g < len(goals) and goals[g][0] <= t + 1e-9:
            g += 1
        goal = goals[g - 1][1] if g else None
        found = markers.get(round(t, 6), {})
        events.append((t, 0, FrameEvent(t, recording.truth_at(t), found, goal)))
    for row in recording.joints["commanded"]:
        hint = recording.joints_at(row.t_s, "measured")
        events.append((row.t_s, 1, CommandEvent(row.t_s, row.q, None if hint is None else hint.q)))
    events.sort(key=lambda e: (e[0], e[1]))
    return (e for _, _, e in events)


def score_events(events: Iterable[Event], score: TruthScore) -> TruthScore:
    """Feed ``events`` to ``score``; returns it."""
    for event in events:
        score.note(event)
    return score


def score_recording(recording, kinematics, aim: Callable, follow_id: Optional[int] = None,
                    cup_ids: Optional[Sequence[int]] = None) -> TruthScore:
    """Score a recording (see ``recording_events``) as the headless runner scores a live run."""
    return score_events(recording_events(recording), TruthScore(kinematics, aim, follow_id, cup_ids))
