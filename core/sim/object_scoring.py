"""Scoring marker-less objects against the simulated desk's truth: how well the detectors see the
things on the desk (``note_objects``) and how closely the arm follows one (``ObjectFollowScore``).

Both take the run's events — each frame's ``GroundTruth`` with the object observations (or the
object follower's status), each control step's joints — and count into a *sink*: an object with
the fields of ``ObjectCounts`` (the headless runner's ``RunMetrics`` has the same ones, so its JSON
keeps its keys). ``objects_summary`` and ``object_follow_summary`` turn a sink into its part of the
headless JSON. No Qt, no session: tests feed synthetic events.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Callable, Optional, Sequence

import numpy as np

from core.sim.scenarios import thing_kind
from core.sim.scoring import percentile, rounded

OBJECT_SEEN_M = 0.03  # an object observation this near its truth (same label) counts as seeing it
FAST_OBJECT_M_S = 0.15  # error_3d_mm_*_moving: truth objects at least this fast (unsynchronised webcams)
OBJECT_FOLLOW_REACH_TOL_M = 0.01  # object following is scored while the true aim is within this of the reachable space
FOLLOW_ON_AIM_M = 0.01  # … from the first time the tool came this near its true aim (not the sprint there)
REACHED_M = 0.005  # time_to_reach_stopped: the tool within this of the approach's end
ARRIVAL_WINDOW_S = 0.06  # arrival speed: tool displacement over this window (three 50 Hz ticks) / its length
CIRCLE_LABEL = "circle"  # what core.detect.circles labels its detections
ROUND_KINDS = ("ball", "disc", "cup")  # the truth kinds a "circle" detection can be


def detector_labels(perception) -> Optional[tuple[str, ...]]:
    """The labels an object perception's detectors can give: colour names (hsv), "circle"
    (circles); markers (aruco) name no thing. None when one of them names its detections freely
    (a learned model's classes: every truth object is a target then)."""
    if perception is None:
        return None
    labels: list[str] = []
    for detector in perception.detectors:
        name = getattr(detector, "name", "")
        colours = getattr(detector.params, "colours", None)
        if colours is not None:
            labels += [c.name for c in colours]
        elif name == "circles":
            labels.append(CIRCLE_LABEL)
        elif name != "aruco":
            return None
    return tuple(labels)


def label_specificity(label: str, truth_label: str) -> int:
    """How well a detection labelled ``label`` names the truth object ``truth_label`` ("red ball"):
    2 for the whole label, its colour ("red") or its kind ("ball", a model's class); 1 for the
    generic "circle" when the kind is round (ball, disc, cup); 0 when it does not name it."""
    label, words = str(label).strip().lower(), str(truth_label).strip().lower().split()
    if not label or not words:
        return 0
    if label in (" ".join(words), " ".join(words[:-1]), words[-1]):
        return 2
    if label == CIRCLE_LABEL and words[-1] in ROUND_KINDS:
        return 1
    return 0


def label_matches(label: str, truth_label: str) -> bool:
    """Does a detection labelled ``label`` name the truth object ``truth_label`` ("red ball")?
    Yes for the whole label, its colour ("red"), its kind ("ball"), or "circle" for a round kind
    (ball, disc, cup); see ``label_specificity``."""
    return label_specificity(label, truth_label) > 0


@dataclass
class ObjectCounts:
    """A sink for the object scores (the headless runner's RunMetrics has these fields too)."""

    object_visible_pairs: int = 0  # (frame, truth object) pairs visible in both views by ground truth
    object_seen_pairs: int = 0  # of those, with an observation of its label within OBJECT_SEEN_M
    object_error_mm: dict = field(default_factory=dict)  # kind -> samples (mm)
    object_id_switches: int = 0
    object_velocity_error_mm_s: list = field(default_factory=list)
    object_error_fast_mm: list = field(default_factory=list)  # truth objects moving at ≥ FAST_OBJECT_M_S
    object_follow_error_mm: list = field(default_factory=list)
    object_stops: int = 0  # stopped events of the followed object
    object_approaches: int = 0  # cubic approaches planned (stops and re-plans)
    arrival_speed_mm_s: list = field(default_factory=list)  # tool speed at the end of each approach
    time_to_reach_stopped_s: list = field(default_factory=list)  # stopped event -> tool within REACHED_M

    def object_error(self, kind: str) -> list:
        """The error samples of one kind of object (created on first use)."""
        return self.object_error_mm.setdefault(kind, [])


def _seen(samples) -> int:
    """Samples appended so far (a bounded reservoir keeps fewer than it saw)."""
    return getattr(samples, "seen", len(samples))


def objects_summary(counts) -> dict:
    """The objects' part of the headless JSON from a sink (see ``ObjectCounts``)."""
    kinds = sorted(counts.object_error_mm)
    return {
        "targets_seen_ratio": rounded(counts.object_seen_pairs / counts.object_visible_pairs
                                      if counts.object_visible_pairs else 0.0),
        "error_3d_mm_p50_by_kind": {k: rounded(percentile(counts.object_error_mm[k], 50)) for k in kinds},
        "error_3d_mm_p95_by_kind": {k: rounded(percentile(counts.object_error_mm[k], 95)) for k in kinds},
        "id_switches": counts.object_id_switches,
        "velocity_error_mm_s_p50": rounded(percentile(counts.object_velocity_error_mm_s, 50)),
        "error_3d_mm_p50_moving": rounded(percentile(counts.object_error_fast_mm, 50)),
        "error_3d_mm_p95_moving": rounded(percentile(counts.object_error_fast_mm, 95)),
        "moving_samples": _seen(counts.object_error_fast_mm),
    }


def object_follow_summary(counts) -> dict:
    """The object-following part of the headless JSON from a sink (see ``ObjectCounts``)."""
    return {
        "object_follow_error_mm_p50": rounded(percentile(counts.object_follow_error_mm, 50)),
        "object_follow_error_mm_p95": rounded(percentile(counts.object_follow_error_mm, 95)),
        "object_follow_samples": _seen(counts.object_follow_error_mm),
        "object_stops": counts.object_stops,
        "object_approaches": counts.object_approaches,
        "arrival_speed_mm_s_p50": rounded(percentile(counts.arrival_speed_mm_s, 50)),
        "time_to_reach_stopped_s_p50": rounded(percentile(counts.time_to_reach_stopped_s, 50)),
    }


def note_objects(counts, t: float, truth, observations, labels: Optional[Sequence[str]],
                 last_ids: dict, truth_prev: dict) -> None:
    """Score the marker-less objects of one frame (time ``t``) against its ground truth.

    Targets: the truth things (labels "<colour> <kind>") visible in both views that one of the
    detectors can name (``labels``, see ``detector_labels``; None: any): a colour, a class = a
    kind, the whole label, or the generic "circle" for a ball, a disc or a cup.

    Each target takes one triangulated observation, each observation names at most one target:
    among the observations that can name it and lie within OBJECT_SEEN_M, the most specific label
    first (``label_specificity``: a colour or class over "circle", so with hsv and circles together
    a ball is scored on its colour track, whichever is nearer), then the nearest. A target with
    none is not seen; farther observations are not error samples (they are other objects, or this
    one misplaced beyond recognition — the seen ratio shows that). A seen target gives its kind's
    3D error, its velocity error (against the truth's, from consecutive truth positions) and its
    id: an id switch is a change of the object_id of the observation with the *same label* that
    scored this target last (two detectors' tracks of one object are two ids, not switches).

    ``last_ids`` ((truth id, label) -> object id) and ``truth_prev`` (truth id -> (t, position))
    are the caller's state, kept from frame to frame; ``counts`` is the sink (``ObjectCounts``).
    """
    if truth is None:
        return
    t = float(t)
    targets = []
    for obj in truth.objects:
        kind = thing_kind(obj.label)
        if kind is None:
            continue
        p = np.asarray(obj.base_p_centre, dtype=float)
        prev = truth_prev.get(obj.marker_id)
        velocity = None
        if prev is not None and t - prev[0] > 1e-6:
            velocity = (p - prev[1]) / (t - prev[0])
        if prev is None or t - prev[0] > 1e-6:
            truth_prev[obj.marker_id] = (t, p)
        if not (obj.visible_left and obj.visible_right):
            continue
        if labels is not None and not any(label_matches(label, obj.label) for label in labels):
            continue
        targets.append((obj, kind, p, velocity))
    measured = [o for o in observations if o.triangulated and o.base_p is not None]
    candidates = []
    for ti, (obj, _, p, _) in enumerate(targets):
        for oi, o in enumerate(measured):
            specificity = label_specificity(o.label, obj.label)
            if specificity == 0:
                continue
            dist = float(np.linalg.norm(np.asarray(o.base_p) - p))
            if dist <= OBJECT_SEEN_M:
                candidates.append((-specificity, dist, ti, oi))
    candidates.sort()
    matched: dict[int, tuple[float, int]] = {}
    used = set()
    for _, dist, ti, oi in candidates:
        if ti in matched or oi in used:
            continue
        matched[ti] = (dist, oi)
        used.add(oi)
    for ti, (obj, kind, p, velocity) in enumerate(targets):
        counts.object_visible_pairs += 1
        if ti not in matched:
            continue
        dist, oi = matched[ti]
        counts.object_seen_pairs += 1
        counts.object_error(kind).append(dist * 1e3)
        if velocity is not None and float(np.linalg.norm(velocity)) >= FAST_OBJECT_M_S:
            counts.object_error_fast_mm.append(dist * 1e3)
        o = measured[oi]
        key = (obj.marker_id, o.label)
        last_id = last_ids.get(key)
        if last_id is not None and last_id != o.object_id:
            counts.object_id_switches += 1
        last_ids[key] = o.object_id
        if velocity is not None and o.velocity_base is not None:
            counts.object_velocity_error_mm_s.append(
                float(np.linalg.norm(np.asarray(o.velocity_base) - velocity)) * 1e3)


class ObjectFollowScore:
    """Following a marker-less object (see ``object_follow_summary``), from the follower's status.

    Follow error: the tool vs the pointing position (``aim``) of the followed object's *true* place
    (extrapolated from the latest frame to the step's time with its true velocity), or the nearest
    point the arm reaches when that is at most OBJECT_FOLLOW_REACH_TOL_M out of reach; only while the
    object is seen, while the follower tracks it or stays on it (not while it watches or
    approaches), and from the first time the tool came within FOLLOW_ON_AIM_M of that point after
    it was (re)acquired (the arm's sprint to a newly seen object is not a following error).
    Stops, approaches, the time from a stopped event to the tool within REACHED_M of the
    approach's end, and the tool's speed at the end of the approach (over ARRIVAL_WINDOW_S).

    ``kinematics``: ``fk(q)`` and ``ik(p, q_hint)``; ``aim``: the targeter's pointing rule;
    ``counts``: the sink (``ObjectCounts`` by default). Feed it ``note_frame`` per camera frame and
    ``note_step`` per control step, each with the follower's ``ObjectFollowStatus`` then.
    """

    def __init__(self, kinematics, aim: Callable, counts=None):
        self.kinematics = kinematics
        self.aim = aim
        self.counts = counts if counts is not None else ObjectCounts()
        # the truth's motion (truth id -> (t, position, velocity)), the truth object the followed
        # observation is, the tool's recent positions and the approach scored
        self._truth_motion: dict[int, tuple[float, np.ndarray, np.ndarray]] = {}
        self._followed_truth_id: Optional[int] = None
        self._on_aim = False
        self._object_id: Optional[int] = None
        self._tool_track: deque = deque(maxlen=16)  # (t, tool position) per control step
        self._approach_scored: dict[int, set] = {}  # approach number -> {"reach", "arrival"} done
        self._approach_seen = 0
        self._approach_info: Optional[tuple] = None  # (number, t0, t_end, goal) of the latest approach

    def note_frame(self, t: float, truth, status) -> None:
        """Which truth object the followed observation is (by label, nearest), and every truth
        object's motion (for the follow error at control-step times)."""
        if truth is None:
            return
        t = float(t)
        for obj in truth.objects:
            p = np.asarray(obj.base_p_centre, dtype=float)
            prev = self._truth_motion.get(obj.marker_id)
            v = np.zeros(3) if prev is None else prev[2]
            if prev is not None and t - prev[0] > 1e-6:
                v = (p - prev[1]) / (t - prev[0])
            self._truth_motion[obj.marker_id] = (t, p, v)
        if status.object_id != self._object_id or status.phase in ("lost", "watch", "approach"):
            # another track, or following starts over: scored again once the tool is on it
            self._object_id = status.object_id
            self._on_aim = False
        if not status.seen or status.base_p_object is None:
            self._followed_truth_id = None
            return
        seen_p = np.asarray(status.base_p_object)
        best, best_d = None, OBJECT_SEEN_M * 3
        for obj in truth.objects:
            if not label_matches(status.label, obj.label):
                continue
            d = float(np.linalg.norm(np.asarray(obj.base_p_centre) - seen_p))
            if d < best_d:
                best, best_d = obj.marker_id, d
        self._followed_truth_id = best

    def note_step(self, now: float, q, status) -> None:
        """One control step at ``now`` with the arm's measured joints ``q``."""
        c = self.counts
        tool = np.asarray(self.kinematics.fk(q), dtype=float)
        self._tool_track.append((now, tool))
        c.object_stops, c.object_approaches = status.stops, status.approaches
        self._score_approach(now, tool, status)
        if (not status.seen or self._followed_truth_id is None
                or status.phase not in ("track", "arrived")):
            return
        t_truth, p_truth, v_truth = self._truth_motion[self._followed_truth_id]
        aim = np.asarray(self.aim(p_truth + v_truth * (now - t_truth)))
        ik = self.kinematics.ik(tuple(aim), q)
        if float(ik.error_m) > OBJECT_FOLLOW_REACH_TOL_M:
            return
        error = float(np.linalg.norm(tool - np.asarray(ik.base_p_reached)))
        if not self._on_aim:
            self._on_aim = error <= FOLLOW_ON_AIM_M
            if not self._on_aim:
                return
        c.object_follow_error_mm.append(error * 1e3)

    def _score_approach(self, now: float, tool: np.ndarray, status) -> None:
        """The time to reach a stopped object and the speed on arrival, once per approach."""
        c = self.counts
        if status.approaches != self._approach_seen and status.approach_t0 is not None:
            self._approach_seen = status.approaches
            self._approach_info = (status.approaches, status.approach_t0, status.approach_t_end,
                                   np.asarray(status.approach_goal))
        info = self._approach_info
        if info is None:
            return
        number, t0, t_end, goal = info
        done = self._approach_scored.setdefault(number, set())
        if not (status.approaches == number and status.phase in ("approach", "arrived")):
            self._approach_info = None  # cancelled (the object moved) or replaced
            return
        if "reach" not in done and float(np.linalg.norm(tool - goal)) <= REACHED_M:
            done.add("reach")
            c.time_to_reach_stopped_s.append(now - t0)
        if "arrival" not in done and now >= t_end:
            past = [(t, p) for t, p in self._tool_track if t <= now - ARRIVAL_WINDOW_S + 1e-9]
            if past:
                t_past, p_past = past[-1]
                done.add("arrival")
                c.arrival_speed_mm_s.append(float(np.linalg.norm(tool - p_past)) / (now - t_past) * 1e3)
