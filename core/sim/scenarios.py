"""What happens on the simulated desk: every object's place as a smooth function of time.

Pure geometry, no OpenCV: a scenario maps ``t`` (s) to a ``SceneState`` (cards lying on the
desk, upside-down cups, the ball, a passing hand). ``core.sim.desk`` draws that state.
Deterministic given ``seed`` and ``t``. Frame: robot_base (x right, y forward, z up, desk z = 0), m.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

# the arm's useful workspace on the desk (m, robot_base)
WORKSPACE_X = (-0.18, 0.18)
WORKSPACE_Y = (0.04, 0.21)

CUP_HEIGHT_M = 0.08  # an upside-down cup: rim on the desk, closed bottom (with the marker) on top
CUP_TOP_RADIUS_M = 0.034
CUP_RIM_RADIUS_M = 0.039
BALL_RADIUS_M = 0.015
HAND_HEIGHT_M = 0.15  # the occluding hand hovers this high above the desk

MAX_MARKERS = 8


@dataclass(frozen=True)
class Card:
    """A printed marker lying flat on the desk, face up."""

    marker_id: int
    x: float  # centre, robot_base (m)
    y: float
    yaw: float = 0.0  # rotation about z (rad); 0: the marker's top edge faces +y


@dataclass(frozen=True)
class Cup:
    """An upside-down cup with a marker on its top."""

    marker_id: int
    x: float  # rim centre, robot_base (m)
    y: float
    lift: float = 0.0  # rim height above the desk (m); > 0 while the cup is lifted
    label: str = ""
    yaw: float = 0.0  # rotation of the marker on the top about z (rad)


@dataclass(frozen=True)
class Ball:
    """The ball of the cups game, lying on the desk under (or beside) its cup."""

    x: float  # centre, robot_base (m); the centre is BALL_RADIUS_M above the desk
    y: float


@dataclass(frozen=True)
class Hand:
    """A flat hand + forearm hovering over the desk, fingers pointing along ``yaw``."""

    x: float  # palm centre, robot_base (m)
    y: float
    z: float = HAND_HEIGHT_M
    yaw: float = 0.0  # rad; 0: fingers towards +y, forearm towards the user (-y)


@dataclass(frozen=True)
class SceneState:
    """Everything on the desk at one instant."""

    cards: tuple[Card, ...] = ()
    cups: tuple[Cup, ...] = ()
    ball: Optional[Ball] = None
    hands: tuple[Hand, ...] = ()
    pointing_target_id: Optional[int] = None  # cups: the id of the cup hiding the ball


def smooth_step(s: float) -> float:
    """0 → 1 on s ∈ [0, 1] with zero slope at both ends (half a cosine); clamped outside."""
    s = min(max(s, 0.0), 1.0)
    return 0.5 - 0.5 * math.cos(math.pi * s)


def bump(s: float) -> float:
    """0 → 1 → 0 on s ∈ [0, 1] (sin²), zero with zero slope at both ends and outside."""
    if s <= 0.0 or s >= 1.0:
        return 0.0
    return math.sin(math.pi * s) ** 2


class Scenario:
    """Base class: ``state(t)`` is the scene at time t (s)."""

    name = ""

    def __init__(self, marker_ids: Sequence[int], seed: int = 0):
        self.marker_ids = tuple(int(i) for i in marker_ids)
        self.seed = int(seed)

    def state(self, t: float) -> SceneState:  # pragma: no cover - abstract
        raise NotImplementedError


# places for cards on the desk (m): the first two are the documented static spots
STATIC_SPOTS = ((-0.08, 0.14), (0.07, 0.17), (0.15, 0.08), (-0.15, 0.21), (0.0, 0.22),
                (-0.16, 0.06), (0.17, 0.22), (0.0, 0.06))
STATIC_YAWS = (0.17, -0.26, -0.1, 0.35, 0.2, 0.5, -0.45, 0.0)
# spare spots for extra cards in the cups game: clear of the cups' swap arcs
CUPS_SPARE_SPOTS = ((-0.17, 0.05), (0.17, 0.05), (-0.19, 0.22), (0.19, 0.22),
                    (-0.26, 0.13), (0.26, 0.13))


class StaticScenario(Scenario):
    """Cards lying still: the first id at (−0.08, 0.14), the second at (0.07, 0.17), extras around."""

    name = "static"

    def __init__(self, marker_ids: Sequence[int], seed: int = 0):
        super().__init__(marker_ids, seed)
        self._cards = tuple(
            Card(mid, *STATIC_SPOTS[i], yaw=STATIC_YAWS[i]) for i, mid in enumerate(self.marker_ids)
        )

    def state(self, t: float) -> SceneState:
        return SceneState(cards=self._cards)


class CupsScenario(Scenario):
    """The cups-and-ball game: show the ball under a lifted cup, cover it, swap the cups, repeat.

    One round lasts ``ROUND_S``: the ball's cup lifts and shows the ball (``SHOW_S``), then the
    cups swap places ``len(SWAP_STARTS)`` times along half circles about their midpoint, then they
    rest so the arm can point. Each round draws a new ball cup and new swap directions.
    """

    name = "cups"
    ROUND_S = 14.0
    SHOW_S = 3.0  # the ball is visible during the first part of it
    LIFT_M = 0.15  # how high the ball's cup is lifted in the show phase
    LIFT_RAMP_S = 0.6
    SWAP_S = 2.0
    SWAP_STARTS = (3.5, 6.5, 9.5)  # s into the round; an odd count, so the cups alternate homes
    HOMES = ((-0.07, 0.14), (0.07, 0.14))
    # the markers sit at an angle on the cups (and turn a little while the cups slide): edges
    # parallel to the pixel grid would give ArUco's contour refinement a grid-locked bias
    YAWS = (0.35, -0.30)

    def __init__(self, marker_ids: Sequence[int], seed: int = 0):
        super().__init__(marker_ids, seed)
        if len(self.marker_ids) < 2:
            raise ValueError(f"the cups scenario needs two marker ids, got {self.marker_ids}")
        extra = self.marker_ids[2:]
        if len(extra) > len(CUPS_SPARE_SPOTS):
            raise ValueError(f"the cups scenario has room for {len(CUPS_SPARE_SPOTS) + 2} markers")
        self._cards = tuple(Card(mid, *CUPS_SPARE_SPOTS[i], yaw=0.0) for i, mid in enumerate(extra))
        self._rounds: dict[int, tuple[int, tuple[int, ...]]] = {}

    def round_plan(self, k: int) -> tuple[int, tuple[int, ...]]:
        """Round k's ball cup (0 or 1) and swap directions (±1 each), from the seed."""
        plan = self._rounds.get(k)
        if plan is None:
            rng = np.random.default_rng([self.seed & 0x7FFFFFFF, 7919, k & 0x7FFFFFFF])
            ball_cup = int(rng.integers(2))
            dirs = tuple(int(d) for d in rng.choice((-1, 1), size=len(self.SWAP_STARTS)))
            plan = (ball_cup, dirs)
            if len(self._rounds) > 64:
                self._rounds.clear()
            self._rounds[k] = plan
        return plan

    def state(self, t: float) -> SceneState:
        k = math.floor(t / self.ROUND_S)
        tau = t - k * self.ROUND_S
        ball_cup, dirs = self.round_plan(k)
        # an odd number of swaps per round: the cups start each round on alternating homes
        first = k % 2
        pos = [np.array(self.HOMES[(i + first) % 2], dtype=float) for i in range(2)]
        mid = 0.5 * (np.array(self.HOMES[0]) + np.array(self.HOMES[1]))
        turn = 0.0
        for start, direction in zip(self.SWAP_STARTS, dirs):
            if tau >= start + self.SWAP_S:
                pos = [pos[1], pos[0]]
            elif tau > start:
                theta = direction * math.pi * smooth_step((tau - start) / self.SWAP_S)
                c, s = math.cos(theta), math.sin(theta)
                rot = np.array([[c, -s], [s, c]])
                pos = [mid + rot @ (p - mid) for p in pos]
                turn = 0.25 * direction * math.sin(math.pi * (tau - start) / self.SWAP_S)
                break
            else:
                break
        lift = self.LIFT_M * (
            smooth_step(tau / self.LIFT_RAMP_S)
            - smooth_step((tau - (self.SHOW_S - self.LIFT_RAMP_S)) / self.LIFT_RAMP_S)
        )
        cups = []
        for i, mid_id in enumerate(self.marker_ids[:2]):
            label = f"cup {'AB'[i]}" + (" (ball)" if i == ball_cup else "")
            cups.append(Cup(mid_id, float(pos[i][0]), float(pos[i][1]),
                            lift=lift if i == ball_cup else 0.0, label=label,
                            yaw=self.YAWS[i] + turn))
        ball = Ball(float(pos[ball_cup][0]), float(pos[ball_cup][1]))
        return SceneState(cards=self._cards, cups=tuple(cups), ball=ball,
                          pointing_target_id=self.marker_ids[ball_cup])


class WanderScenario(Scenario):
    """Cards gliding over the workspace (sums of sines), now and then off the image and back,
    and a hand sweeping across above the desk every ``HAND_PERIOD_S``."""

    name = "wander"
    EXCURSION_S = 4.0  # how long a trip off the image takes (out and back)
    EXCURSION_M = 0.55  # how far sideways it goes (beyond the image edge at this rig)
    HAND_PERIOD_S = 15.0
    HAND_OFFSET_S = 10.0
    HAND_SWEEP_S = 4.0
    HAND_X_M = 0.62  # the sweep runs from -HAND_X_M to +HAND_X_M (or back)

    def __init__(self, marker_ids: Sequence[int], seed: int = 0):
        super().__init__(marker_ids, seed)
        rng = np.random.default_rng([self.seed & 0x7FFFFFFF, 4242])
        n = len(self.marker_ids)
        (x_lo, x_hi), (y_lo, y_hi) = (-0.16, 0.16), (0.065, 0.185)
        lane = (x_hi - x_lo) / n
        self._cards = []
        for i in range(n):
            cx = x_lo + lane * (i + 0.5)
            ax = max(0.01, min(0.06, lane / 2 - 0.04))  # cards keep clear of their neighbours
            ay = (y_hi - y_lo) / 2
            self._cards.append(dict(
                cx=cx, cy=(y_lo + y_hi) / 2,
                ax=(0.6 * ax, 0.4 * ax), ay=(0.6 * ay, 0.4 * ay),
                fx=tuple(rng.uniform(0.03, 0.11, 2)), fy=tuple(rng.uniform(0.03, 0.11, 2)),
                px=tuple(rng.uniform(0, 2 * math.pi, 2)), py=tuple(rng.uniform(0, 2 * math.pi, 2)),
                yaw0=float(rng.uniform(-0.3, 0.3)), fyaw=float(rng.uniform(0.02, 0.08)),
                pyaw=float(rng.uniform(0, 2 * math.pi)),
                side=-1.0 if cx < 0 else 1.0,
                period=20.0 + 6.0 * i, offset=5.0 + 7.0 * i,
            ))

    def state(self, t: float) -> SceneState:
        cards = []
        for mid, c in zip(self.marker_ids, self._cards):
            x = c["cx"] + sum(a * math.sin(2 * math.pi * f * t + p) for a, f, p in zip(c["ax"], c["fx"], c["px"]))
            y = c["cy"] + sum(a * math.sin(2 * math.pi * f * t + p) for a, f, p in zip(c["ay"], c["fy"], c["py"]))
            s = ((t - c["offset"]) % c["period"]) / self.EXCURSION_S
            x += c["side"] * self.EXCURSION_M * bump(s)
            yaw = c["yaw0"] + 0.5 * math.sin(2 * math.pi * c["fyaw"] * t + c["pyaw"])
            cards.append(Card(mid, x, y, yaw))
        hands = ()
        k = math.floor((t - self.HAND_OFFSET_S) / self.HAND_PERIOD_S)
        s = (t - self.HAND_OFFSET_S - k * self.HAND_PERIOD_S) / self.HAND_SWEEP_S
        if 0.0 < s < 1.0:
            direction = 1.0 if k % 2 == 0 else -1.0
            x = direction * self.HAND_X_M * (2.0 * smooth_step(s) - 1.0)
            y = 0.13 + 0.02 * math.sin(math.pi * s)
            hands = (Hand(x, y, HAND_HEIGHT_M, yaw=-0.25 * direction * math.sin(math.pi * s)),)
        return SceneState(cards=tuple(cards), hands=hands)


SCENARIOS: dict[str, type[Scenario]] = {
    "static": StaticScenario,
    "cups": CupsScenario,
    "wander": WanderScenario,
}


def scenario_names() -> tuple[str, ...]:
    """Names accepted by ``SimDesk(scenario=...)``."""
    return tuple(SCENARIOS)


def make_scenario(name: str, marker_ids: Sequence[int], seed: int = 0) -> Scenario:
    """The scenario called ``name``; ValueError naming the valid ones otherwise."""
    cls = SCENARIOS.get(name)
    if cls is None:
        raise ValueError(f"unknown simulated desk scenario {name!r}; valid: {', '.join(SCENARIOS)}")
    if not 1 <= len(marker_ids) <= MAX_MARKERS:
        raise ValueError(f"the simulated desk takes 1…{MAX_MARKERS} marker ids, got {len(marker_ids)}")
    return cls(marker_ids, seed)
