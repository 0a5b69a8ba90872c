"""The other end of a remote desk: subscribe, decode, send goals, e-stop and settings back.

``DeskClient`` keeps the latest message of each topic with its receive time (no queues) and
counts arrivals; ``wait_for`` blocks on a condition until a message satisfies a predicate, so
callers (tests, the CLI, a GUI worker) never poll with sleeps.

Latency = receive wall time − the message's stamp (the capture instant on the server, in the
server's wall clock). On one machine (loopback) both clocks are the same clock; across machines
it includes the offset between the two clocks, so synchronise them (chrony/NTP: typically
< 1 ms on a LAN) before trusting a cross-machine figure. The e-stop round trip needs no clock
agreement: send and echo are both timed on this machine.

Control: a client made with ``control=True`` claims the arm (``/deskarm/cmd/control``) and keeps
re-claiming with its heartbeat until the server's status names it; goals, settings and re-arm
count only from the client in control. ``take_control`` takes it from another client (an
explicit hand-over). A watcher (``control=False``) never claims and never re-arms; it may STOP.
A re-arm is a hold (``rearm``: /deskarm/cmd/rearm at 10 Hz until the server re-arms).
"""
from __future__ import annotations

import json
import os
import threading
import time
from dataclasses import dataclass
from typing import Callable, Optional

from core.messages import FRAME_ROBOT_BASE
from core.remote import ros
from core.remote.link import LinkOptions, open_session

HEARTBEAT_HZ = 10.0
CONTROL_WAIT_S = 5.0  # a controlling client's first command waits this long for the grant
REARM_TIMEOUT_S = 5.0  # a re-arm hold gives up after this long without the server re-arming


@dataclass(frozen=True)
class Received:
    """One decoded message with when it arrived."""

    topic: str
    msg: object  # rosbags message
    received_wall: float  # time.time() on arrival
    received_mono: float  # time.monotonic() on arrival
    index: int  # arrival count of this topic (1 = first)
    attachment: Optional[ros.Attachment] = None


class DeskClient:
    """Subscribes to a DeskServer's topics and sends commands back."""

    def __init__(self, link: LinkOptions, heartbeat: bool = True, hash_style: str = "rihs01",
                 topics: Optional[tuple[str, ...]] = None, client_id: Optional[str] = None,
                 control: Optional[bool] = None):
        self.link = link
        self.control = heartbeat if control is None else bool(control)  # claim the arm (a watcher does not)
        self.hash_style = hash_style
        self.client_id = client_id or f"client-{os.getpid()}-{os.urandom(3).hex()}"
        self._cond = threading.Condition()
        self._latest: dict[str, Received] = {}
        self._counts: dict[str, int] = {}
        self.latencies_s: dict[str, list[float]] = {side: [] for side in ros.IMAGE_TOPICS}
        self._gid = os.urandom(ros.GID_SIZE)
        self._seq = 0
        self._pub_lock = threading.Lock()
        self._zenoh = open_session(link)
        domain = link.domain_id
        self._pubs = {topic: self._zenoh.declare_publisher(ros.key_expr(topic, msgtype, domain, hash_style))
                      for topic, msgtype in ros.ALL_COMMANDS.items()}
        self._take = False
        self._granted = False  # control was granted once (the heartbeat stops claiming)
        self._subs = [self._zenoh.declare_subscriber(ros.key_pattern(topic, msgtype, domain),
                                                     self._callback(topic, msgtype))
                      for topic, msgtype in ros.TOPICS.items() if topics is None or topic in topics]
        self._hb_stop = threading.Event()
        self._hb_thread: Optional[threading.Thread] = None
        if heartbeat:
            self.start_heartbeat()

    # ---- lifecycle ----------------------------------------------------------------------------

    def start_heartbeat(self) -> None:
        """Send /deskarm/cmd/heartbeat at 10 Hz from a thread (the server pauses the arm without it)."""
        if self._hb_thread is not None and self._hb_thread.is_alive():
            return
        self._hb_stop.clear()
        self._hb_thread = threading.Thread(target=self._heartbeat_loop, name="deskarm-heartbeat", daemon=True)
        self._hb_thread.start()

    def stop_heartbeat(self) -> None:
        """Stop the heartbeat (as a dropped link would)."""
        self._hb_stop.set()
        if self._hb_thread is not None:
            self._hb_thread.join(timeout=2.0)
            self._hb_thread = None

    def close(self) -> None:
        """Stop the heartbeat, give control back when this client holds it, close the session."""
        self.stop_heartbeat()
        if self._zenoh is not None and (self.control or self.in_control()):  # granted, or maybe about to be
            for _ in range(3):  # a put just before the session closes can be lost: until the server confirms
                before = self.count("/deskarm/session")
                self.release_control()
                if self.wait_for("/deskarm/session", lambda r: json.loads(r.msg.data).get("controller") != self.client_id,
                                 timeout=1.0, after=before) is not None:
                    break
        if self._zenoh is not None:
            self._zenoh.close()
            self._zenoh = None

    def __enter__(self) -> "DeskClient":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _heartbeat_loop(self) -> None:
        period = 1.0 / HEARTBEAT_HZ
        while not self._hb_stop.is_set():
            if self.control and not self._granted:  # claim until granted once; a take-over is never undone here
                if self.in_control():
                    self._granted = True
                else:
                    self._claim()
            self._send("/deskarm/cmd/heartbeat", ros.header(time.time(), self.client_id))
            self._hb_stop.wait(period)

    # ---- control ------------------------------------------------------------------------------

    def in_control(self) -> bool:
        """True when the server's latest status names this client as the one in control."""
        status = self.session()
        return bool(status) and status.get("controller") == self.client_id

    def _claim(self) -> None:
        request = {"claim": self.client_id}
        if self._take:
            request["take"] = True
        self._send("/deskarm/cmd/control", ros.json_msg(request))

    def wait_control(self, timeout: float = CONTROL_WAIT_S) -> bool:
        """Claim the arm until the server's status names this client (True), or False after ``timeout``."""
        self.control = True
        deadline = time.monotonic() + timeout
        while not self.in_control():
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return False
            self._claim()
            self.wait_for("/deskarm/session", lambda r: json.loads(r.msg.data).get("controller") == self.client_id,
                          timeout=min(0.2, remaining))
        return True

    def take_control(self, timeout: float = CONTROL_WAIT_S) -> bool:
        """Take the arm from whichever client holds it (an explicit hand-over); True once granted."""
        self._take = True
        try:
            return self.wait_control(timeout)
        finally:
            self._take = False

    def release_control(self) -> None:
        """Give the arm back (another controller may claim it; the arm stays paused until one does)."""
        self.control = False
        self._granted = False
        self._send("/deskarm/cmd/control", ros.json_msg({"release": self.client_id}))

    # ---- receiving ----------------------------------------------------------------------------

    def _callback(self, topic: str, msgtype: str):
        def on_sample(sample) -> None:
            wall, mono = time.time(), time.monotonic()
            try:
                msg = ros.deserialize(sample.payload.to_bytes(), msgtype)
            except Exception:  # not ours or corrupt: ignore it
                return
            attachment = None
            if sample.attachment is not None:
                try:
                    attachment = ros.Attachment.decode(sample.attachment.to_bytes())
                except ValueError:
                    attachment = None
            with self._cond:
                n = self._counts.get(topic, 0) + 1
                self._counts[topic] = n
                self._latest[topic] = Received(topic, msg, wall, mono, n, attachment)
                for side, image_topic in ros.IMAGE_TOPICS.items():
                    if topic == image_topic:
                        samples = self.latencies_s[side]
                        samples.append(wall - ros.stamp_s(msg.header.stamp))
                        del samples[:-20000]
                self._cond.notify_all()
        return on_sample

    def latest(self, topic: str) -> Optional[Received]:
        with self._cond:
            return self._latest.get(topic)

    def count(self, topic: str) -> int:
        with self._cond:
            return self._counts.get(topic, 0)

    def wait_for(self, topic: str, predicate: Callable[[Received], bool] = lambda r: True,
                 timeout: float = 5.0, after: int = 0) -> Optional[Received]:
        """The first latest message of ``topic`` (arrival index > ``after``) for which ``predicate``
        holds, or None after ``timeout`` seconds."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while True:
                r = self._latest.get(topic)
                if r is not None and r.index > after and predicate(r):
                    return r
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return None
                self._cond.wait(remaining)

    # decoded views
    def image(self, side: str = "left"):
        """The latest camera image (BGR uint8) of ``side``, or None."""
        import cv2
        import numpy as np

        r = self.latest(ros.IMAGE_TOPICS[side])
        if r is None:
            return None
        return cv2.imdecode(np.frombuffer(bytes(r.msg.data), np.uint8), cv2.IMREAD_COLOR)

    def markers(self) -> dict[int, tuple[float, float, float]]:
        """{marker id: (x, y, z) in robot_base, m} of the latest MarkerArray."""
        r = self.latest("/deskarm/markers")
        return ros.markers_of(r.msg) if r is not None else {}

    def joints(self, which: str = "commanded") -> Optional[tuple[float, ...]]:
        r = self.latest(f"/deskarm/joint_states/{which}")
        return tuple(float(v) for v in r.msg.position) if r is not None else None

    def session(self) -> Optional[dict]:
        r = self.latest("/deskarm/session")
        return json.loads(r.msg.data) if r is not None else None

    # ---- sending ------------------------------------------------------------------------------

    def _send(self, topic: str, msg) -> None:
        with self._pub_lock:
            if self._zenoh is None:
                return
            self._seq += 1
            attachment = ros.Attachment(self._seq, time.time_ns(), self._gid).encode()
            self._pubs[topic].put(ros.serialize(msg, ros.ALL_COMMANDS[topic]), attachment=attachment)

    def _ensure_control(self, wait: bool) -> None:
        if self.control and wait and not self.in_control():
            self.wait_control()

    def send_goal(self, base_p, frame_id: str = FRAME_ROBOT_BASE, wait: bool = True) -> None:
        """Point the arm at ``base_p`` (x, y, z in m, robot_base): the server switches to manual mode.
        A controlling client first waits (``wait``) until the server granted it control."""
        self._ensure_control(wait)
        self._send("/deskarm/cmd/goal", ros.point_stamped(base_p, time.time(), frame_id))

    def send_estop(self, stop: bool = True) -> None:
        """E-stop (True). ``False`` is sent as asked, and refused by the server: re-arm with :meth:`rearm`."""
        self._send("/deskarm/cmd/estop", ros.bool_msg(stop))

    def send_settings(self, settings: dict, wait: bool = True) -> None:
        """Mode and settings, e.g. ``{"mode": "follow", "follow_id": 23}``."""
        self._ensure_control(wait)
        self._send("/deskarm/cmd/settings", ros.json_msg(settings))

    def rearm(self, timeout: float = REARM_TIMEOUT_S, stop: Optional[threading.Event] = None) -> bool:
        """Hold the re-arm: /deskarm/cmd/rearm at 10 Hz until a server status newer than the
        request says it is armed (True), ``timeout`` passed or ``stop`` was set (False). Needs
        control (a controller credential); a viewer's requests never reach the server."""
        deadline = time.monotonic() + timeout
        self._ensure_control(True)
        period = 1.0 / HEARTBEAT_HZ
        stop = stop or threading.Event()
        before = self.count("/deskarm/session")  # only a status sent after this counts (the last may be stale)
        while not stop.is_set():
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return False
            self._send("/deskarm/cmd/rearm", ros.header(time.time(), self.client_id))
            if self.wait_for("/deskarm/session", lambda r: json.loads(r.msg.data).get("estopped") is False,
                             timeout=min(period, remaining), after=before) is not None:
                return True
        return False

    def request_rearm(self) -> threading.Thread:
        """:meth:`rearm` in a thread (for a caller that must not block: the window's bridge)."""
        thread = threading.Thread(target=self.rearm, name="deskarm-rearm", daemon=True)
        thread.start()
        return thread

    def estop_round_trip(self, timeout: float = 2.0) -> Optional[float]:
        """Send an e-stop and wait for the server's /deskarm/estop echo saying it holds: seconds
        (this machine's clock only), or None without an echo within ``timeout``."""
        before = self.count("/deskarm/estop")
        t0 = time.monotonic()
        self.send_estop(True)
        r = self.wait_for("/deskarm/estop", lambda r: bool(r.msg.data), timeout=timeout, after=before)
        return None if r is None else r.received_mono - t0
