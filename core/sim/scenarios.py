"""What happens on the simulated desk: every object's place as a smooth function of time.

Pure geometry, no OpenCV: a scenario maps ``t`` (s) to a ``SceneState`` (cards lying on the
desk, upside-down cups, the ball, a passing hand, marker-less things, lift panels and door
handles). ``core.sim.desk`` draws
that state.
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

# marker-less things (the objects scenario): their ObjectTruth.marker_id is THING_ID_BASE − index
# (−1 stays the cups game's ball) and their label is "<colour> <kind>", the kind its last word
THING_KINDS = ("ball", "plush", "disc", "cup")
THING_ID_BASE = -11

# the panel scene: a lift panel's buttons and a door handle are not Things (a button is part of
# its panel) but SceneState.panels / SceneState.handles; their truth ids and labels:
# button n → BUTTON_ID_BASE − n ("button n"), the handle → HANDLE_ID ("door handle")
BUTTON_ID_BASE = -20
HANDLE_ID = -30
PANEL_KINDS = ("button", "handle")


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


# the teleop scenario's wristband: a marker printed on a band round the forearm, face up
WRISTBAND_V_M = -0.075  # band centre from the hand's origin along the fingers (m; negative: on the forearm)
WRISTBAND_LIFT_M = 0.012  # the band's printed face is this far above the hand's plane (m)
WRISTBAND_WIDTH_M = 0.062  # the band's width along the forearm (m)


@dataclass(frozen=True)
class Wristband:
    """A marker on a wristband, lying face up on top of the forearm (the teleop hand source)."""

    marker_id: int
    x: float  # marker centre, robot_base (m)
    y: float
    z: float
    yaw: float  # the hand's yaw (rad); the marker's top edge faces the fingers' side … rotated like the hand

    @property
    def centre(self) -> tuple[float, float, float]:
        return (float(self.x), float(self.y), float(self.z))


@dataclass(frozen=True)
class Hand:
    """A flat hand + forearm hovering over the desk, fingers pointing along ``yaw``; optionally
    wearing a wristband with a marker (``band_marker_id``, the teleop scenario)."""

    x: float  # hand origin (the knuckles' line, palm side), robot_base (m)
    y: float
    z: float = HAND_HEIGHT_M
    yaw: float = 0.0  # rad; 0: fingers towards +y, forearm towards the user (-y)
    band_marker_id: Optional[int] = None  # a marker id on a wristband, or None (a bare hand)

    @property
    def band(self) -> Optional[Wristband]:
        """The wristband (its marker centre and yaw), None for a bare hand."""
        if self.band_marker_id is None:
            return None
        # fingers along (−sin yaw, cos yaw); the band sits WRISTBAND_V_M along them
        fx, fy = -math.sin(self.yaw), math.cos(self.yaw)
        return Wristband(int(self.band_marker_id), float(self.x + fx * WRISTBAND_V_M),
                         float(self.y + fy * WRISTBAND_V_M), float(self.z + WRISTBAND_LIFT_M), float(self.yaw))


def hand_for_band(band_p, yaw: float, band_marker_id: Optional[int]) -> Hand:
    """The hand whose wristband marker centre is at ``band_p`` (robot_base, m)."""
    fx, fy = -math.sin(yaw), math.cos(yaw)
    x, y, z = (float(v) for v in band_p)
    return Hand(x - fx * WRISTBAND_V_M, y - fy * WRISTBAND_V_M, z - WRISTBAND_LIFT_M, yaw, band_marker_id)


@dataclass(frozen=True)
class Thing:
    """A marker-less object on the desk: a ball, a plush, a disc (a cylinder) or an upside-down cup.

    Its truth point (``centre``): a ball's centre, a plush's centre, the middle of a disc's or a
    cup's top face — where the object's pixels are around in both views.
    """

    kind: str  # one of THING_KINDS
    label: str  # "<colour> <kind>", e.g. "red ball"
    truth_id: int  # ObjectTruth.marker_id, <= THING_ID_BASE
    x: float  # centre of its footprint, robot_base (m)
    y: float
    radius_m: float  # ball, disc: radius; cup: rim radius (its top is CUP_RIM − CUP_TOP narrower); plush: half length
    height_m: float  # disc, cup: height; plush: height and width; ball: its diameter
    colour: tuple[int, int, int]  # BGR body colour (shading varies around it)
    yaw: float = 0.0  # plush: direction of its long axis about z (rad)

    def __post_init__(self) -> None:
        if self.kind not in THING_KINDS:
            raise ValueError(f"thing kind {self.kind!r}: must be one of {', '.join(THING_KINDS)}")

    @property
    def centre(self) -> tuple[float, float, float]:
        """The truth point in robot_base (m), see the class docstring."""
        if self.kind == "disc" or self.kind == "cup":
            return (float(self.x), float(self.y), float(self.height_m))
        return (float(self.x), float(self.y), float(self.height_m) / 2)


def thing_kind(label: str) -> Optional[str]:
    """The kind of a marker-less object from its truth label: "red ball" → "ball", "button 5" →
    "button", "door handle" → "handle"; None for other labels (cards, cups with markers).

    (ObjectTruth.kind says the same without parsing; this stays for callers that have a label.)
    """
    words = str(label).split()
    if not words:
        return None
    if words[-1] in THING_KINDS:
        return words[-1]
    if len(words) == 2 and words[0] == "button" and words[1].isdigit():
        return "button"
    if words[-1] == "handle":
        return "handle"
    return None


@dataclass(frozen=True)
class Panel:
    """A lift call panel lying flat on the desk, face up: a brushed-metal plate with 9 round push
    buttons in a 3×3 grid.

    Panel frame: origin at the middle of the plate's footprint, u along ``yaw`` (yaw 0: u = +x),
    v 90° further (yaw 0: v = +y, away from the arm), up = +z. The buttons are numbered row-major
    as they read to someone at the arm looking along +v: 1 2 3 is the far row (+v), 1 on the −u
    side; 7 8 9 is the near row. Each button's digit is upright for that reader (its top towards
    +v): the stereo rig across the desk sees the digits upside down, a camera on the arm's hand
    upright.
    """

    x: float  # middle of the plate, robot_base (m)
    y: float
    yaw: float = 0.0  # rad about z
    width_m: float = 0.13  # plate size along u
    length_m: float = 0.15  # plate size along v
    thickness_m: float = 0.015  # the plate's top face is this high above the desk
    button_radius_m: float = 0.011
    button_pitch_m: float = 0.04  # centre to centre, along rows and columns
    button_proud_m: float = 0.004  # a button's top face stands this far above the plate
    press_depth_m: float = 0.003  # travel of a button when pressed
    lit: tuple[int, ...] = ()  # buttons whose ring is lit (selected / registered call)
    pressed: tuple[int, ...] = ()  # buttons held down (their top face press_depth_m lower)
    truth_id_base: int = BUTTON_ID_BASE  # button n has truth id truth_id_base − n

    BUTTONS = tuple(range(1, 10))

    def __post_init__(self) -> None:
        for name in ("lit", "pressed"):
            bad = [n for n in getattr(self, name) if n not in self.BUTTONS]
            if bad:
                raise ValueError(f"Panel.{name} = {getattr(self, name)}: button numbers are 1…9, not {bad}")
        if 3 * self.button_pitch_m > min(self.width_m, self.length_m):
            raise ValueError(f"Panel button_pitch_m = {self.button_pitch_m}: 3 rows must fit the "
                             f"{self.width_m} × {self.length_m} m plate")

    def _check(self, n: int) -> int:
        if n not in self.BUTTONS:
            raise ValueError(f"button {n!r}: a lift panel's buttons are numbered 1…9")
        return int(n)

    def button_uv(self, n: int) -> tuple[float, float]:
        """Button n's centre in the panel frame (u, v), m."""
        row, col = divmod(self._check(n) - 1, 3)
        return ((col - 1) * self.button_pitch_m, (1 - row) * self.button_pitch_m)

    def to_base(self, u: float, v: float, z: float = 0.0) -> tuple[float, float, float]:
        """A panel-frame point (u, v at height z above the desk) in robot_base (m)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return (float(self.x + c * u - s * v), float(self.y + s * u + c * v), float(z))

    @property
    def top_z(self) -> float:
        """Height of the plate's top face above the desk (m)."""
        return float(self.thickness_m)

    def button_top_z(self, n: int) -> float:
        """Height of button n's top face above the desk (m), lower while it is pressed."""
        down = self.press_depth_m if self._check(n) in self.pressed else 0.0
        return float(self.thickness_m + self.button_proud_m - down)

    def button_centre(self, n: int) -> tuple[float, float, float]:
        """The middle of button n's top face, robot_base (m): where to press it (its truth point)."""
        u, v = self.button_uv(n)
        return self.to_base(u, v, self.button_top_z(n))

    def button_pressed_centre(self, n: int) -> tuple[float, float, float]:
        """Where the middle of button n's top face is at the end of its travel (robot_base, m)."""
        u, v = self.button_uv(n)
        return self.to_base(u, v, self.thickness_m + self.button_proud_m - self.press_depth_m)

    @property
    def normal(self) -> tuple[float, float, float]:
        """The panel's outward normal in robot_base (it lies flat: straight up); press along −normal."""
        return (0.0, 0.0, 1.0)

    def button_truth_id(self, n: int) -> int:
        """ObjectTruth.marker_id of button n."""
        return self.truth_id_base - self._check(n)

    @staticmethod
    def button_label(n: int) -> str:
        return f"button {n}"


@dataclass(frozen=True)
class DoorHandle:
    """A lever door handle on a round rose, mounted on the desk as if the desk were the door.

    A round rose on the desk, a neck up to the lever at its pivot, and the lever: a bar
    ``length_m`` long from the pivot along ``yaw``, its axis ``bar_height_m`` above the desk.
    Truth point (``centre``): the middle of the bar's top.
    """

    x: float  # pivot (the rose's centre), robot_base (m)
    y: float
    yaw: float = 0.0  # direction the lever points from the pivot (rad; 0: +x)
    length_m: float = 0.12  # pivot axis to the lever's tip
    thickness_m: float = 0.018  # bar diameter
    bar_height_m: float = 0.03  # the bar's axis above the desk
    rose_radius_m: float = 0.026
    rose_height_m: float = 0.008
    neck_radius_m: float = 0.011
    truth_id: int = HANDLE_ID
    label: str = "door handle"

    def along(self, s: float, z: Optional[float] = None) -> tuple[float, float, float]:
        """The point ``s`` m along the lever's axis from the pivot (robot_base); z defaults to the axis."""
        return (float(self.x + s * math.cos(self.yaw)), float(self.y + s * math.sin(self.yaw)),
                float(self.bar_height_m if z is None else z))

    @property
    def centre(self) -> tuple[float, float, float]:
        """The middle of the bar's top, robot_base (m)."""
        return self.along(self.length_m / 2, self.bar_height_m + self.thickness_m / 2)

    @property
    def tip(self) -> tuple[float, float, float]:
        """The lever's free end on its axis (where to push it down), robot_base (m)."""
        return self.along(self.length_m)


@dataclass(frozen=True)
class SceneState:
    """Everything on the desk at one instant."""

    cards: tuple[Card, ...] = ()
    cups: tuple[Cup, ...] = ()
    ball: Optional[Ball] = None
    hands: tuple[Hand, ...] = ()
    pointing_target_id: Optional[int] = None  # cups: the id of the cup hiding the ball
    things: tuple[Thing, ...] = ()  # marker-less objects (the objects scenario)
    panels: tuple[Panel, ...] = ()  # lift panels (the panel scenario); their buttons have truth ids
    handles: tuple[DoorHandle, ...] = ()  # door handles (the panel scenario)


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


class ObjectsScenario(Scenario):
    """Marker-less things for the detectors and trackers: balls, a plush, discs, cups, a hand.

    - red ball: round an ellipse (peak 0.075 m/s); green ball: still;
    - blue ball: every BLUE_PERIOD_S rolls off the image past −x and back (peak 0.19 m/s), out
      of both views for ~3 s of it;
    - yellow plush (an elongated ellipsoid): slides back and forth along y (peak 0.051 m/s),
      turning slowly;
    - orange disc (flat) and purple cylinder: still; a hand comes in from +x every HAND_PERIOD_S
      and hovers over the orange disc for HAND_HOVER_S, hiding it in both views;
    - white and pink cups (upside down, no marker): still.
    The marker ids become cards in out-of-the-way spots (the session still has markers to follow).
    """

    name = "objects"
    # within the arm's reach (the default pointing offset included), clear of the things, seen by both cameras
    CARD_SPOTS = ((0.04, 0.25), (-0.125, 0.225), (0.175, 0.15), (0.15, 0.05))
    CARD_YAWS = (0.2, -0.3, 0.1, -0.15)
    BALL_RADIUS_M = 0.025
    RED_CENTRE, RED_RADII, RED_PERIOD_S = (-0.15, 0.13), (0.06, 0.035), 5.0
    BLUE_HOME, BLUE_EXCURSION_M = (0.04, 0.02), 0.62  # rolls to x = home − excursion (out of view)
    BLUE_PERIOD_S, BLUE_OFFSET_S, BLUE_TRIP_S = 16.0, 2.0, 10.0
    PLUSH_CENTRE, PLUSH_TRAVEL_M, PLUSH_PERIOD_S = (0.03, 0.145), 0.045, 5.5
    DISC_XY = (0.23, 0.085)  # the orange disc the hand hides
    HAND_PERIOD_S, HAND_OFFSET_S = 12.0, 5.0
    HAND_IN_S, HAND_HOVER_S = 2.0, 2.0  # coming in (and going out) takes HAND_IN_S
    HAND_Z_M = 0.10
    HAND_FAR_X_M = 0.70  # where the hand comes from and goes back to (out of view)
    # the hand hides the disc from above the point where the line of sight from the default rig
    # (midpoint (0, 0.42, 0.45)) to the disc's top crosses the hand's height
    VIEWPOINT = (0.0, 0.42, 0.45)

    def __init__(self, marker_ids: Sequence[int], seed: int = 0):
        super().__init__(marker_ids, seed)
        if len(self.marker_ids) > len(self.CARD_SPOTS):
            raise ValueError(f"the objects scenario has room for {len(self.CARD_SPOTS)} markers, "
                             f"got {len(self.marker_ids)}")
        self._cards = tuple(Card(mid, *self.CARD_SPOTS[i], yaw=self.CARD_YAWS[i])
                            for i, mid in enumerate(self.marker_ids))
        r = self.BALL_RADIUS_M
        self._still = {
            "green ball": dict(kind="ball", x=0.13, y=0.235, radius_m=r, height_m=2 * r, colour=(60, 170, 50)),
            "orange disc": dict(kind="disc", x=self.DISC_XY[0], y=self.DISC_XY[1], radius_m=0.03, height_m=0.008,
                                colour=(30, 125, 240)),
            "purple disc": dict(kind="disc", x=-0.20, y=0.28, radius_m=0.022, height_m=0.045,
                                colour=(150, 60, 140)),
            "white cup": dict(kind="cup", x=-0.05, y=0.30, radius_m=CUP_RIM_RADIUS_M, height_m=CUP_HEIGHT_M,
                              colour=(222, 224, 228)),
            "pink cup": dict(kind="cup", x=0.19, y=0.30, radius_m=CUP_RIM_RADIUS_M, height_m=CUP_HEIGHT_M,
                             colour=(170, 120, 240)),
        }

    LABELS = ("red ball", "green ball", "blue ball", "yellow plush", "orange disc", "purple disc",
              "white cup", "pink cup")

    def _thing(self, label: str, **kw) -> Thing:
        return Thing(label=label, truth_id=THING_ID_BASE - self.LABELS.index(label), **kw)

    def hand_at(self, t: float) -> Optional[Hand]:
        """The hand hovering over the orange disc (or on its way), None while it is away."""
        k = math.floor((t - self.HAND_OFFSET_S) / self.HAND_PERIOD_S)
        tau = t - self.HAND_OFFSET_S - k * self.HAND_PERIOD_S
        total = 2 * self.HAND_IN_S + self.HAND_HOVER_S
        if not 0.0 < tau < total:
            return None
        come = smooth_step(tau / self.HAND_IN_S)
        go = smooth_step((tau - self.HAND_IN_S - self.HAND_HOVER_S) / self.HAND_IN_S)
        # the disc's top seen from VIEWPOINT, at the hand's height
        top = np.array([self.DISC_XY[0], self.DISC_XY[1], 0.008])
        eye = np.array(self.VIEWPOINT)
        s = (self.HAND_Z_M - top[2]) / (eye[2] - top[2])
        cover = top + s * (eye - top)
        palm_x = cover[0] + 0.0275  # the palm's middle is 2.75 cm from the hand's origin along the fingers (−x)
        x = palm_x + (self.HAND_FAR_X_M - palm_x) * (1.0 - come + go)
        return Hand(float(x), float(cover[1]), self.HAND_Z_M, yaw=math.pi / 2)  # fingers towards −x

    def state(self, t: float) -> SceneState:
        r = self.BALL_RADIUS_M
        a = 2 * math.pi * t / self.RED_PERIOD_S
        red = self._thing("red ball", kind="ball", x=self.RED_CENTRE[0] + self.RED_RADII[0] * math.cos(a),
                          y=self.RED_CENTRE[1] + self.RED_RADII[1] * math.sin(a), radius_m=r, height_m=2 * r,
                          colour=(38, 38, 205))
        k = math.floor((t - self.BLUE_OFFSET_S) / self.BLUE_PERIOD_S)
        s = (t - self.BLUE_OFFSET_S - k * self.BLUE_PERIOD_S) / self.BLUE_TRIP_S
        blue = self._thing("blue ball", kind="ball", x=self.BLUE_HOME[0] - self.BLUE_EXCURSION_M * bump(s),
                           y=self.BLUE_HOME[1], radius_m=r, height_m=2 * r, colour=(200, 90, 30))
        b = 2 * math.pi * t / self.PLUSH_PERIOD_S
        plush = self._thing("yellow plush", kind="plush", x=self.PLUSH_CENTRE[0],
                            y=self.PLUSH_CENTRE[1] + self.PLUSH_TRAVEL_M * math.sin(b), radius_m=0.065,
                            height_m=0.04, colour=(40, 200, 235), yaw=0.3 + 0.3 * math.sin(2 * math.pi * t / 13.0))
        things = [red, blue, plush] + [self._thing(label, **kw) for label, kw in self._still.items()]
        things.sort(key=lambda th: -th.truth_id)  # in LABELS order
        hand = self.hand_at(t)
        return SceneState(cards=self._cards, hands=() if hand is None else (hand,), things=tuple(things))


class PanelScenario(Scenario):
    """A lift panel of 9 buttons and a door handle, for the assistive work (pressing buttons,
    opening a door).

    - the panel (Panel: 13 × 15 cm brushed-metal plate, 1.5 cm thick) lies at PANEL_XY, turned
      PANEL_YAW; its buttons' rings light one after the other, SCAN_S each (a scanning selection,
      as with a one- or two-switch input), from button 1 at t = 0;
    - a door handle (DoorHandle: a 12 cm lever 3 cm above the desk on a rose) has its pivot at
      HANDLE_PIVOT and points to −x, its middle at about (0.12, 0.13);
    - a hand comes in from −x every HAND_PERIOD_S and hovers for HAND_HOVER_S with its
      fingertips just past button HAND_BUTTON (seen from the rig), hiding the 1-4-7 column and
      part of the 2-5-8 one in both views;
    - the marker ids become cards in out-of-the-way spots (the objects scenario's).
    Everything but the hand is still. Truth: buttons −21…−29 ("button 1"…), the handle −30.
    """

    name = "panel"
    PANEL_XY, PANEL_YAW = (-0.03, 0.13), 0.06
    HANDLE_PIVOT, HANDLE_YAW = (0.18, 0.13), math.pi
    SCAN_S = 2.0
    HAND_PERIOD_S, HAND_OFFSET_S = 15.0, 6.0
    HAND_IN_S, HAND_HOVER_S = 2.0, 2.5
    HAND_Z_M = 0.10
    HAND_FAR_X_M = -0.70
    HAND_BUTTON = 4
    HAND_TIP_PAST_M = 0.012  # the fingertips reach this far past HAND_BUTTON's centre (along +x)
    VIEWPOINT = ObjectsScenario.VIEWPOINT
    # within the arm's reach, clear of the panel and the handle, seen by both cameras
    CARD_SPOTS = ((0.04, 0.25), (-0.15, 0.05), (0.15, 0.05), (-0.11, 0.235))

    def __init__(self, marker_ids: Sequence[int], seed: int = 0):
        super().__init__(marker_ids, seed)
        spots = self.CARD_SPOTS
        if len(self.marker_ids) > len(spots):
            raise ValueError(f"the panel scenario has room for {len(spots)} markers, got {len(self.marker_ids)}")
        self._cards = tuple(Card(mid, *spots[i], yaw=ObjectsScenario.CARD_YAWS[i])
                            for i, mid in enumerate(self.marker_ids))
        self._handle = DoorHandle(*self.HANDLE_PIVOT, yaw=self.HANDLE_YAW)

    def panel_at(self, t: float) -> Panel:
        """The panel at time t (only its lit ring changes)."""
        lit = int(math.floor(t / self.SCAN_S)) % 9 + 1
        return Panel(*self.PANEL_XY, yaw=self.PANEL_YAW, lit=(lit,))

    def hand_at(self, t: float) -> Optional[Hand]:
        """The hand hovering over the panel's −x side (or on its way), None while it is away."""
        k = math.floor((t - self.HAND_OFFSET_S) / self.HAND_PERIOD_S)
        tau = t - self.HAND_OFFSET_S - k * self.HAND_PERIOD_S
        if not 0.0 < tau < 2 * self.HAND_IN_S + self.HAND_HOVER_S:
            return None
        come = smooth_step(tau / self.HAND_IN_S)
        go = smooth_step((tau - self.HAND_IN_S - self.HAND_HOVER_S) / self.HAND_IN_S)
        # the button's top seen from VIEWPOINT, at the hand's height
        top = np.array(Panel(*self.PANEL_XY, yaw=self.PANEL_YAW).button_centre(self.HAND_BUTTON))
        eye = np.array(self.VIEWPOINT)
        cover = top + (self.HAND_Z_M - top[2]) / (eye[2] - top[2]) * (eye - top)
        tip_x = cover[0] + self.HAND_TIP_PAST_M
        x0 = tip_x - 0.105  # fingers towards +x: the fingertips are 10.5 cm from the hand's origin
        x = x0 + (self.HAND_FAR_X_M - x0) * (1.0 - come + go)
        return Hand(float(x), float(cover[1]), self.HAND_Z_M, yaw=-math.pi / 2)

    def state(self, t: float) -> SceneState:
        hand = self.hand_at(t)
        return SceneState(cards=self._cards, hands=() if hand is None else (hand,),
                          panels=(self.panel_at(t),), handles=(self._handle,))


class TeleopScenario(Scenario):
    """A user drives the arm by hand: a hand wearing a wristband with a marker (the first marker id)
    moves along a recorded-looking path above the desk (smooth, human speeds, a small tremor).

    The script (scenario time, s; ``gesture_times`` gives the gestures' true times):
    - 0 … 1.5 the hand comes in from +x to CORNER_A; holds still there 1.5 s (the calibration
      gesture's first corner: "still for 1 s" is complete at 2.5 s);
    - 3.0 … 5.0 it moves to the opposite corner CORNER_B and holds still 1.5 s (the calibration is
      complete at ``CALIBRATE_T`` = 6.0 s: the second second of stillness);
    - 6.5 … 19.5 free motion inside the volume (sums of sines, peak ~7 cm/s), during which the other
      hand hovers over the band (OCCLUDE_*: it comes in over 0.5 s, covers it for 1.2 s while the
      band hand keeps moving, goes away): the hand is lost, the arm must hold;
    - 19.5 … the hand goes to REST and holds still; from COVER_IN_T the other hand comes in and
      covers the band from COVER_T on, for good (the end gesture, complete at ``END_T`` = COVER_T +
      END_COVER_S: the band unseen for END_COVER_S after a still hand was covered).
    The other marker ids become cards in out-of-the-way spots. Truth: the band's marker centre
    (``band_centre``), its visibility (the marker id's ObjectTruth), the corners and gesture times.
    """

    name = "teleop"
    YAW = math.pi / 2  # fingers towards −x, the forearm comes from +x (a user beside the arm)
    ENTRY = (0.30, 0.21, 0.19)
    CORNER_A = (-0.06, 0.17, 0.14)  # band centre at the two calibration corners (robot_base, m)
    CORNER_B = (0.07, 0.25, 0.21)
    REST = (0.0, 0.21, 0.17)
    ENTER_S, HOLD_A_S, MOVE_AB_S, HOLD_B_S = 1.5, 2.0, 2.0, 2.0  # 1 s still + margin for a loaded real-time run
    STILL_S = 1.0  # stillness a corner needs (TeleopParams.still_hold_s)
    FREE_T0, FREE_T1, BLEND_S = 6.5, 19.5, 1.5
    WANDER_CENTRE = (0.005, 0.21, 0.175)
    WANDER_AMPLITUDE = (0.055, 0.035, 0.03)  # m per axis (two sines each, 0.6 and 0.4 of it)
    OCCLUDE_T, OCCLUDE_S, OTHER_IN_S = 12.0, 1.2, 0.5
    COVER_IN_T = 20.6
    END_COVER_S = 1.0  # TeleopParams.end_cover_s
    OTHER_LIFT_M = 0.05  # the other hand hovers this far above the band
    OTHER_FAR_X_M = 0.75  # where the other hand comes from (out of view)
    TREMOR = ((0.00015, 8.3), (0.0001, 5.7))  # (amplitude m, frequency Hz): physiological tremor
    VIEWPOINT = (0.0, 0.42, 0.45)  # the default rig's midpoint: the other hand sits on the line of sight
    CARD_SPOTS = ((-0.125, 0.225), (-0.15, 0.05), (0.15, 0.05), (-0.20, 0.15))

    def __init__(self, marker_ids: Sequence[int], seed: int = 0):
        super().__init__(marker_ids, seed)
        extra = self.marker_ids[1:]
        if len(extra) > len(self.CARD_SPOTS):
            raise ValueError(f"the teleop scenario has room for {len(self.CARD_SPOTS) + 1} markers, "
                             f"got {len(self.marker_ids)}")
        self.band_marker_id = self.marker_ids[0]
        self._cards = tuple(Card(mid, *self.CARD_SPOTS[i], yaw=ObjectsScenario.CARD_YAWS[i])
                            for i, mid in enumerate(extra))
        rng = np.random.default_rng([self.seed & 0x7FFFFFFF, 1313])
        self._freq = rng.uniform(0.06, 0.14, (3, 2))  # Hz
        self._phase = rng.uniform(0.0, 2 * math.pi, (3, 2))
        self._tremor_phase = rng.uniform(0.0, 2 * math.pi, (3, len(self.TREMOR)))
        self.cover_t = self.COVER_IN_T + self.OTHER_IN_S

    # --- the script ---------------------------------------------------------------------------
    @property
    def calibrate_t(self) -> float:
        """When the calibration gesture is complete: the second corner held still STILL_S."""
        return self.ENTER_S + self.HOLD_A_S + self.MOVE_AB_S + self.STILL_S

    @property
    def end_t(self) -> float:
        """When the end gesture is complete: the band covered for END_COVER_S."""
        return self.cover_t + self.END_COVER_S

    def gesture_times(self) -> dict[str, float]:
        """True times (scenario s) of the gestures: {"corner": first corner, "calibrate", "end"}."""
        return {"corner": self.ENTER_S + self.STILL_S, "calibrate": self.calibrate_t, "end": self.end_t}

    def corners(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """The band's true positions during the two calibration holds (robot_base, m)."""
        return self.CORNER_A, self.CORNER_B

    def occlusion_window(self) -> tuple[float, float]:
        """When the other hand is over (or coming to / leaving) the band during free motion."""
        return (self.OCCLUDE_T - self.OTHER_IN_S, self.OCCLUDE_T + self.OCCLUDE_S + self.OTHER_IN_S)

    def _wander(self, t: float) -> np.ndarray:
        c = np.asarray(self.WANDER_CENTRE, float)
        out = c.copy()
        for axis in range(3):
            a = self.WANDER_AMPLITUDE[axis]
            for k, share in enumerate((0.6, 0.4)):
                out[axis] += share * a * math.sin(2 * math.pi * self._freq[axis, k] * (t - self.FREE_T0)
                                                  + self._phase[axis, k])
        return out

    def _path(self, t: float) -> np.ndarray:
        """The band centre without tremor (robot_base, m)."""
        a, b = np.asarray(self.CORNER_A), np.asarray(self.CORNER_B)
        t1 = self.ENTER_S
        t2 = t1 + self.HOLD_A_S
        t3 = t2 + self.MOVE_AB_S
        if t < t1:
            return np.asarray(self.ENTRY) + (a - np.asarray(self.ENTRY)) * smooth_step(t / t1)
        if t < t2:
            return a
        if t < t3:
            return a + (b - a) * smooth_step((t - t2) / self.MOVE_AB_S)
        if t < self.FREE_T0:
            return b
        if t < self.FREE_T1:
            blend_in = smooth_step((t - self.FREE_T0) / self.BLEND_S)
            blend_out = smooth_step((t - (self.FREE_T1 - self.BLEND_S)) / self.BLEND_S)
            p = b + (self._wander(t) - b) * blend_in
            return p + (np.asarray(self.REST) - p) * blend_out
        return np.asarray(self.REST, float)

    def _tremor(self, t: float) -> np.ndarray:
        out = np.zeros(3)
        for axis in range(3):
            for k, (amp, f) in enumerate(self.TREMOR):
                out[axis] += amp * math.sin(2 * math.pi * f * t + self._tremor_phase[axis, k])
        return out

    def band_centre(self, t: float) -> np.ndarray:
        """The wristband marker's centre at time t (robot_base, m): the hand's truth point."""
        return self._path(t) + self._tremor(t)

    def hand_at(self, t: float) -> Hand:
        """The hand wearing the band."""
        return hand_for_band(self.band_centre(t), self.YAW, self.band_marker_id)

    def other_hand_at(self, t: float) -> Optional[Hand]:
        """The other (bare) hand: over the band during the occlusion, and for good from the cover on."""
        in_s = self.OTHER_IN_S
        if t >= self.COVER_IN_T:
            come, go = smooth_step((t - self.COVER_IN_T) / in_s), 0.0
        else:
            t0 = self.OCCLUDE_T - in_s
            t_go = self.OCCLUDE_T + self.OCCLUDE_S
            if not t0 < t < t_go + in_s:
                return None
            come, go = smooth_step((t - t0) / in_s), smooth_step((t - t_go) / in_s)
        band = self.band_centre(t)
        eye = np.asarray(self.VIEWPOINT)
        z = band[2] + self.OTHER_LIFT_M
        cover = band + (z - band[2]) / (eye[2] - band[2]) * (eye - band)
        # the palm's middle is 2.75 cm from the hand's origin along the fingers (−x at this yaw)
        x0 = cover[0] + 0.0275
        x = x0 + (self.OTHER_FAR_X_M - x0) * (1.0 - come + go)
        return Hand(float(x), float(cover[1]), float(z), yaw=self.YAW)

    def state(self, t: float) -> SceneState:
        hands = [self.hand_at(t)]
        other = self.other_hand_at(t)
        if other is not None:
            hands.append(other)
        return SceneState(cards=self._cards, hands=tuple(hands))


SCENARIOS: dict[str, type[Scenario]] = {
    "static": StaticScenario,
    "cups": CupsScenario,
    "wander": WanderScenario,
    "objects": ObjectsScenario,
    "panel": PanelScenario,
    "teleop": TeleopScenario,
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
