"""The three ways a user with a motor impairment picks a box: touch, two switches, one switch timed.

Pure state machines (no Qt, no clock of their own): the GUI — or a simulated user — feeds them
taps, switch presses and the time, and they answer with ``ScanEvent`` s.

- ``TouchSelector``: a tap selects the box it falls in; a tap outside every box is "ignored"
  (the GUI acknowledges it briefly, the arm never moves).
- ``TwoSwitchScanner``: switch "next" moves the highlight to the next box (wrapping), switch
  "confirm" selects the highlighted one.
- ``OneSwitchScanner``: the highlight advances by itself every ``period_s`` (0.5–5 s); a press
  shorter than ``long_press_s`` confirms the box highlighted when the switch went down; holding
  it ``long_press_s`` stops the arm and cancels ("stop"), so every action needs only one switch.
  The highlight stands still while the switch is held.

Boxes are (x, y, w, h) in image pixels, in scanning order (``reading_order`` sorts detections
row by row, left to right); ``grown_boxes`` gives the bigger targets a view draws and hit-tests.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

Box = tuple[float, float, float, float]

MIN_PERIOD_S, MAX_PERIOD_S = 0.5, 5.0


@dataclass(frozen=True)
class ScanEvent:
    """What an input did: "highlight" (index), "select" (index), "ignored" (a tap outside every
    box), "stop" (the arm must stop, the choice is cancelled)."""

    kind: str
    t: float
    index: Optional[int] = None
    point: Optional[tuple[float, float]] = None


def reading_order(boxes: Sequence[Box], row_tolerance: float = 0.5) -> list[int]:
    """Indices of ``boxes`` row by row (top first), left to right within a row; boxes whose
    centres differ by less than ``row_tolerance`` box heights in y share a row."""
    if not boxes:
        return []
    centres = [(b[0] + b[2] / 2, b[1] + b[3] / 2, b[3]) for b in boxes]
    order = sorted(range(len(boxes)), key=lambda i: centres[i][1])
    rows: list[list[int]] = [[order[0]]]
    for i in order[1:]:
        last = rows[-1]
        mean_y = sum(centres[j][1] for j in last) / len(last)
        if abs(centres[i][1] - mean_y) <= row_tolerance * centres[i][2]:
            last.append(i)
        else:
            rows.append([i])
    return [i for row in rows for i in sorted(row, key=lambda j: centres[j][0])]


def _check_boxes(boxes: Sequence[Box]) -> list[Box]:
    out = [tuple(float(v) for v in b) for b in boxes]
    if any(len(b) != 4 or b[2] <= 0 or b[3] <= 0 or not all(map(math.isfinite, b)) for b in out):
        raise ValueError("boxes must be (x, y, w, h) with w, h > 0")
    return out


class TouchSelector:
    """A tap selects the box it falls in (the smallest, when boxes overlap)."""

    def __init__(self, boxes: Sequence[Box]):
        self.boxes = _check_boxes(boxes)

    def tap(self, x: float, y: float, t: float) -> ScanEvent:
        inside = [i for i, (bx, by, bw, bh) in enumerate(self.boxes) if bx <= x <= bx + bw and by <= y <= by + bh]
        if not inside:
            return ScanEvent("ignored", float(t), None, (float(x), float(y)))
        best = min(inside, key=lambda i: self.boxes[i][2] * self.boxes[i][3])
        return ScanEvent("select", float(t), best, (float(x), float(y)))


class TwoSwitchScanner:
    """Switch "next" moves the highlight, switch "confirm" selects it. The highlight starts on box 0."""

    def __init__(self, n_boxes: int):
        if n_boxes < 1:
            raise ValueError("scanning needs at least one box")
        self.n = int(n_boxes)
        self.highlight = 0
        self.presses = 0

    def next(self, t: float) -> ScanEvent:
        self.presses += 1
        self.highlight = (self.highlight + 1) % self.n
        return ScanEvent("highlight", float(t), self.highlight)

    def confirm(self, t: float) -> ScanEvent:
        self.presses += 1
        return ScanEvent("select", float(t), self.highlight)


class OneSwitchScanner:
    """Timed scanning: the highlight steps every ``period_s`` from ``start(t)``; a short press
    confirms, a long press stops. Call ``tick(t)`` as time passes (it returns the highlight
    steps since the last call), ``press(t)`` and ``release(t)`` on the switch's edges."""

    def __init__(self, n_boxes: int, period_s: float = 1.0, long_press_s: float = 1.5):
        if n_boxes < 1:
            raise ValueError("scanning needs at least one box")
        if not MIN_PERIOD_S <= period_s <= MAX_PERIOD_S:
            raise ValueError(f"scan period {period_s} s is outside {MIN_PERIOD_S}…{MAX_PERIOD_S} s")
        if not 0.2 <= long_press_s <= 10.0:
            raise ValueError(f"long press {long_press_s} s is outside 0.2…10 s")
        self.n = int(n_boxes)
        self.period_s = float(period_s)
        self.long_press_s = float(long_press_s)
        self.highlight = 0
        self.presses = 0
        self._next_step: Optional[float] = None
        self._down_since: Optional[float] = None
        self._down_highlight = 0
        self._stopped_this_press = False

    def start(self, t: float) -> ScanEvent:
        self.highlight = 0
        self._next_step = float(t) + self.period_s
        return ScanEvent("highlight", float(t), 0)

    def tick(self, t: float) -> list[ScanEvent]:
        t = float(t)
        events: list[ScanEvent] = []
        if self._down_since is not None:
            if not self._stopped_this_press and t - self._down_since >= self.long_press_s:
                self._stopped_this_press = True
                events.append(ScanEvent("stop", self._down_since + self.long_press_s, None))
            return events
        while self._next_step is not None and t >= self._next_step:
            self.highlight = (self.highlight + 1) % self.n
            events.append(ScanEvent("highlight", self._next_step, self.highlight))
            self._next_step += self.period_s
        return events

    def press(self, t: float) -> list[ScanEvent]:
        events = self.tick(t)
        self.presses += 1
        self._down_since = float(t)
        self._down_highlight = self.highlight
        self._stopped_this_press = False
        return events

    def release(self, t: float) -> list[ScanEvent]:
        t = float(t)
        if self._down_since is None:
            return []
        events = self.tick(t)  # may report the stop if the release came late
        held = t - self._down_since
        self._down_since = None
        if self._stopped_this_press or held >= self.long_press_s:
            if not self._stopped_this_press:
                events.append(ScanEvent("stop", t, None))
            self._next_step = t + self.period_s  # scanning resumes where it was
            return events
        if self._next_step is not None:
            self._next_step = t + self.period_s
        events.append(ScanEvent("select", t, self._down_highlight))
        return events


def one_switch_cost(target_index: int, period_s: float, reaction_s: float = 0.4, press_s: float = 0.15) -> dict:
    """Presses and seconds a one-switch user needs to select box ``target_index`` (0-based, in
    scanning order) from the start of scanning: wait for the highlight to reach it
    (target_index · period_s), react, press and release once."""
    if reaction_s + press_s >= period_s:
        raise ValueError(f"reaction {reaction_s} s + press {press_s} s does not fit in a {period_s} s scan step: "
                         f"the highlight would move on first — lengthen the period")
    return {"presses": 1, "seconds": target_index * period_s + reaction_s + press_s}


BOX_GROWTH_MAX = 1.6  # boxes are drawn (and hit-tested) up to this much larger than the detected circle …
BOX_GAP_FRACTION = 0.9  # … but no larger than this fraction of the distance to the nearest neighbour


def grown_boxes(boxes: Sequence[Box]) -> list[Box]:
    """The boxes drawn larger about their centres (up to BOX_GROWTH_MAX), never into a neighbour:
    bigger targets for a shaky finger, the same centres."""
    if not boxes:
        return []
    centres = [(x + w / 2, y + h / 2) for x, y, w, h in boxes]
    out = []
    for i, (x, y, w, h) in enumerate(boxes):
        cx, cy = centres[i]
        gaps = [max(abs(cx - ox), abs(cy - oy)) for j, (ox, oy) in enumerate(centres) if j != i]
        size = max(w, h)
        growth = BOX_GROWTH_MAX if not gaps else min(BOX_GROWTH_MAX, max(1.0, BOX_GAP_FRACTION * min(gaps) / size))
        out.append((cx - w * growth / 2, cy - h * growth / 2, w * growth, h * growth))
    return out
