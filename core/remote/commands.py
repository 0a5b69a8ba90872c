"""Every payload from the network is hostile until parsed, bounded and range-checked.

Pure functions and small bounded containers, tested without Zenoh or threads:

- ``MAX_PAYLOAD``: bytes accepted per command topic (checked before anything is decoded);
- ``decode``: CDR -> message, or a ``Refused`` with a reason (never an exception);
- ``parse_settings`` / ``parse_control``: JSON objects without recursion blow-ups (size and
  nesting are checked before ``json.loads``), each value type- and range-checked;
- ``check_goal``: a finite point inside the reach box (the targeter checks the workspace next);
- ``client_id``: a short printable id;
- ``RateLimiter``: a token bucket per (topic, source), bounded in sources;
- ``Refusals``: counted, the last few kept, each text truncated;
- ``Clients``: heartbeat ids with their last time, bounded and expiring.
"""
from __future__ import annotations

import json
import math
import re
from collections import OrderedDict, deque
from dataclasses import dataclass
from typing import Optional

MAX_PAYLOAD = {  # bytes: CDR with its 4-byte header; a frame_id or client id of up to 64 characters
    "/deskarm/cmd/goal": 160,
    "/deskarm/cmd/estop": 16,
    "/deskarm/cmd/settings": 4096,
    "/deskarm/cmd/heartbeat": 128,
    "/deskarm/cmd/rearm": 128,
    "/deskarm/cmd/control": 512,
    "/target_position": 40,
    "/target_pitch": 16,
    "/target_roll": 16,
}
MAX_JSON_DEPTH = 4  # {"camera": {...}} is 2
REACH_M = 2.0  # |x|, |y|, |z| of a goal beyond this is no desk arm's (robot_base, m)
FOLLOW_ID_MAX = 999  # ArUco ids of the dictionaries deskarm uses are below 1000
MAX_TEXT = 120  # characters of a refused value kept in a refusal
MAX_REFUSALS_KEPT = 5
MAX_CLIENTS = 16
CLIENT_EXPIRE_S = 10.0  # a heartbeat id unseen this long leaves the client list
CLIENT_ID_RE = re.compile(r"[A-Za-z0-9_.:@-]{1,64}")
MODES = ("follow", "manual", "lissajous", "cups")
CAMERA_KEYS = ("exposure", "gain", "brightness", "contrast")


class Refused(ValueError):
    """A payload refused, with the reason the status shows."""


def short(value, limit: int = MAX_TEXT) -> str:
    """``repr(value)`` cut to ``limit`` characters (a refusal never echoes a huge payload)."""
    text = repr(value) if not isinstance(value, str) else value
    return text if len(text) <= limit else text[:limit] + f"… ({len(text)} characters)"


def check_size(topic: str, payload: bytes) -> None:
    limit = MAX_PAYLOAD.get(topic, 256)
    if len(payload) > limit:
        raise Refused(f"{topic}: payload of {len(payload)} bytes, more than {limit}")


def decode(topic: str, payload: bytes, msgtype: str):
    """The message of ``payload`` (size-checked first), or Refused with the reason."""
    from core.remote import ros

    check_size(topic, payload)
    try:
        return ros.deserialize(payload, msgtype)
    except Exception as exc:  # truncated CDR, a foreign type, garbage: all refused alike
        raise Refused(f"{topic}: undecodable {msgtype} ({short(str(exc), 60)})") from None


def json_depth(text: str) -> int:
    """The deepest nesting of brackets and braces outside strings (no recursion)."""
    depth = deepest = 0
    in_string = escaped = False
    for ch in text:
        if in_string:
            if escaped:
                escaped = False
            elif ch == "\\":
                escaped = True
            elif ch == '"':
                in_string = False
        elif ch == '"':
            in_string = True
        elif ch in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif ch in "]}":
            depth -= 1
    return deepest


def parse_object(text: str, what: str) -> dict:
    """A JSON object of at most MAX_JSON_DEPTH levels, or Refused."""
    if not isinstance(text, str):
        raise Refused(f"{what}: not text")
    if len(text) > MAX_PAYLOAD["/deskarm/cmd/settings"]:
        raise Refused(f"{what}: {len(text)} characters, more than {MAX_PAYLOAD['/deskarm/cmd/settings']}")
    if json_depth(text) > MAX_JSON_DEPTH:
        raise Refused(f"{what}: nested deeper than {MAX_JSON_DEPTH} levels")
    try:
        obj = json.loads(text, parse_constant=_no_constant)
    except (ValueError, RecursionError) as exc:
        raise Refused(f"{what} {short(text, 60)}: not JSON ({short(str(exc), 60)})") from None
    if not isinstance(obj, dict):
        raise Refused(f"{what} {short(text, 60)}: not a JSON object")
    return obj


def _no_constant(name: str):
    raise ValueError(f"{name} is not a number")


def _finite(key: str, value, lo: float, hi: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise Refused(f"{key}={short(value, 40)}: expected a number")
    v = float(value)
    if not math.isfinite(v) or not (lo <= v <= hi):
        raise Refused(f"{key}={short(value, 40)}: outside {lo:g}…{hi:g}")
    return v


def parse_settings(text: str) -> tuple[dict, list[str]]:
    """({key: checked value}, [refusal reasons]) of a settings JSON; Refused for a bad whole."""
    obj = parse_object(text, "settings")
    good: dict = {}
    bad: list[str] = []
    for key, value in list(obj.items())[:8]:
        try:
            if key == "mode":
                if value not in MODES:
                    raise Refused(f"mode={short(value, 40)}: expected one of {', '.join(MODES)}")
                good[key] = value
            elif key == "follow_id":
                if isinstance(value, bool) or not isinstance(value, int) or not (0 <= value <= FOLLOW_ID_MAX):
                    raise Refused(f"follow_id={short(value, 40)}: expected a whole number 0…{FOLLOW_ID_MAX}")
                good[key] = value
            elif key == "lissajous_running":
                if not isinstance(value, bool):
                    raise Refused(f"lissajous_running={short(value, 40)}: expected true or false")
                good[key] = value
            elif key == "camera":
                if not isinstance(value, dict) or not value or set(value) - set(CAMERA_KEYS):
                    raise Refused(f"camera={short(value, 60)}: expected an object of {', '.join(CAMERA_KEYS)}")
                from core.settings import CameraSettings

                ranges = {"exposure": (-4, 4), "gain": (0, 24), "brightness": (-100, 100), "contrast": (0.2, 3.0)}
                good[key] = CameraSettings(**{k: _finite(f"camera.{k}", v, *ranges[k]) for k, v in value.items()})
            else:
                raise Refused(f"{short(key, 40)}: unknown setting; valid: mode, follow_id, lissajous_running, camera")
        except Refused as exc:
            bad.append(str(exc))
    if len(obj) > 8:
        bad.append(f"settings: {len(obj)} keys, only the first 8 read")
    return good, bad


def parse_control(text: str) -> tuple[str, str, bool]:
    """("claim" | "release", client id, take) of a control request, or Refused."""
    obj = parse_object(text, "control")
    actions = [a for a in ("claim", "release") if a in obj]
    if len(actions) != 1:
        raise Refused('control: expected {"claim": ID} or {"release": ID} (and "take": true to take over)')
    action = actions[0]
    take = obj.get("take", False)
    if not isinstance(take, bool):
        raise Refused(f"control take={short(take, 40)}: expected true or false")
    return action, client_id(obj[action]), take


def client_id(value) -> str:
    """A client id (1–64 of letters, digits and ``_.:@-``), or Refused."""
    if not isinstance(value, str) or not CLIENT_ID_RE.fullmatch(value):
        raise Refused(f"client id {short(value, 40)}: expected 1–64 letters, digits or _.:@-")
    return value


def check_angle(topic: str, value) -> float:
    """A finite angle within ±π (rad), or Refused."""
    v = float(value)
    if not math.isfinite(v) or abs(v) > math.pi:
        raise Refused(f"{topic} {v!r} rad: expected a finite angle within ±π")
    return v


def check_goal(p) -> tuple[float, float, float]:
    """A goal (robot_base, m) with every coordinate finite and within ±REACH_M, or Refused."""
    out = []
    for axis, v in zip("xyz", p):
        v = float(v)
        if not math.isfinite(v) or abs(v) > REACH_M:
            raise Refused(f"goal {axis}={v!r} m: expected a finite value within ±{REACH_M:g} m")
        out.append(v)
    return tuple(out)  # type: ignore[return-value]


class RateLimiter:
    """Token buckets per (topic, source): ``rate_hz`` sustained, ``burst`` at once."""

    def __init__(self, rates_hz: dict[str, float], burst_s: float = 0.5, max_sources: int = 64):
        self.rates = dict(rates_hz)
        self.burst_s = float(burst_s)
        self.max_sources = int(max_sources)
        self._buckets: OrderedDict = OrderedDict()  # (topic, source) -> (tokens, last t)
        self.dropped: dict[str, int] = {}

    def allow(self, topic: str, source: str, now: float) -> bool:
        rate = self.rates.get(topic)
        if rate is None:
            return True
        cap = max(1.0, rate * self.burst_s)
        key = (topic, source)
        tokens, last = self._buckets.pop(key, (cap, now))
        tokens = min(cap, tokens + (now - last) * rate)
        ok = tokens >= 1.0
        if ok:
            tokens -= 1.0
        else:
            self.dropped[topic] = self.dropped.get(topic, 0) + 1
        self._buckets[key] = (tokens, now)
        while len(self._buckets) > self.max_sources:
            self._buckets.popitem(last=False)
        return ok


class Refusals:
    """Refusals counted; the last few texts kept, each at most MAX_TEXT characters."""

    def __init__(self, keep: int = MAX_REFUSALS_KEPT):
        self.count = 0
        self.last: deque = deque(maxlen=keep)

    def add(self, text: str) -> None:
        self.count += 1
        self.last.append(short(str(text), MAX_TEXT))

    def __len__(self) -> int:
        return self.count

    def __iter__(self):
        return iter(self.last)

    def __getitem__(self, index):
        return list(self.last)[index]


class Clients:
    """Client ids from heartbeats, each with its last time: at most MAX_CLIENTS, expiring."""

    def __init__(self, limit: int = MAX_CLIENTS, expire_s: float = CLIENT_EXPIRE_S):
        self.limit = int(limit)
        self.expire_s = float(expire_s)
        self._seen: OrderedDict[str, float] = OrderedDict()

    def seen(self, cid: str, now: float) -> bool:
        """Note ``cid`` at ``now``; True when it is new to the list."""
        new = cid not in self._seen
        self._seen.pop(cid, None)
        self._seen[cid] = now
        while len(self._seen) > self.limit:
            self._seen.popitem(last=False)
        return new

    def expire(self, now: float) -> bool:
        """Drop ids unseen for ``expire_s``; True when any left."""
        old = [c for c, t in self._seen.items() if now - t > self.expire_s]
        for c in old:
            del self._seen[c]
        return bool(old)

    def ids(self) -> list[str]:
        return sorted(self._seen)

    def __len__(self) -> int:
        return len(self._seen)


@dataclass(frozen=True)
class Hold:
    """A re-arm hold: requests from one client, gaps no longer than ``max_gap_s``, for ``hold_s``."""

    hold_s: float = 1.0
    max_gap_s: float = 0.35


class HoldTracker:
    """Tracks a held request (re-arm): True once one client's requests span ``hold_s`` unbroken."""

    def __init__(self, hold: Hold = Hold()):
        self.hold = hold
        self._who: Optional[str] = None
        self._start = 0.0
        self._last = -math.inf

    def press(self, who: str, now: float) -> bool:
        if who != self._who or now - self._last > self.hold.max_gap_s:
            self._who, self._start = who, now
        self._last = now
        if now - self._start >= self.hold.hold_s:
            self.reset()
            return True
        return False

    def reset(self) -> None:
        self._who, self._start, self._last = None, 0.0, -math.inf

    def progress(self, now: float) -> float:
        """0…1 of the current hold (0 when none or broken)."""
        if self._who is None or now - self._last > self.hold.max_gap_s:
            return 0.0
        return min(1.0, (now - self._start) / self.hold.hold_s)
