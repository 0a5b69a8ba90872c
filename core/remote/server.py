"""The desk as a server: the headless pipeline on one machine, published over Zenoh.

``DeskServer`` runs the loop of the headless runner (camera frames at the camera rate,
perception, targeting, the control step when the session's ``ControlSchedule`` says so, the
bridge with the window's reconnection backoff) and publishes, per frame / result / command /
state, the messages of ``core.remote.ros.TOPICS`` — the same messages the recordings hold.

Who may send what is Zenoh's access control (``core.remote.security``: a viewer may put only
on the e-stop key, a controller on every command key); this server adds one controller at a
time and checks every payload (``core.remote.commands``). Commands (``/deskarm/cmd/...``):

- e-stop (std_msgs/Bool true, anyone who sees the arm): ``controller.estop()`` in the Zenoh
  callback itself (the next control step sends nothing), then ``bridge.estop()`` and the
  ``/deskarm/estop`` echo in the same loop iteration it arrives in. ``false`` is refused: a
  re-arm is never one message.
- control (std_msgs/String JSON ``{"claim": ID}``, ``{"release": ID}``, ``{"claim": ID, "take":
  true}``): the arm's motion belongs to one client at a time; a claim while another holds it is
  refused unless it says ``take`` (an explicit hand-over) or the holder has sent no heartbeat
  for ``CONTROL_EXPIRE_S`` (its session is gone); the arm stays paused until the new holder's
  own heartbeat arrives.
- re-arm (std_msgs/Header, frame_id = the controlling client's id), held: sent at 10 Hz for
  ``REARM_HOLD_S`` without a gap, like the window's hold-to-re-arm.
- goal (geometry_msgs/PointStamped in robot_base): manual mode, that target.
- settings (std_msgs/String JSON): ``{"mode": "follow"|"manual"|"lissajous"|"cups",
  "follow_id": 23, "lissajous_running": true, "camera": {...}}``; each value type- and
  range-checked, anything else refused with a reason.
- heartbeat (std_msgs/Header, 10 Hz, frame_id = client id): the controlling client's keeps the
  link; once it has sent one, a gap longer than ``link_timeout_s`` (0.5 s) pauses the arm
  (``controller.pause("remote link lost")``) until that same client's heartbeats return —
  another session's heartbeat never resumes it.
- ``/target_position`` (geometry_msgs/Point, the ROS interface): a goal, while no deskarm client
  holds control; ``/target_pitch`` / ``/target_roll`` (std_msgs/Float64, rad) the tool's
  orientation on arms with a wrist (refused with the reason on position-only arms). The
  original interface's ``/motor_commands`` (raw joint values) has no equivalent: every motion
  goes through deskarm's IK, limits and workspace checks.

Goal, settings, re-arm and heartbeat count only from the controlling client (the sample's
rmw attachment GID and the id it claimed with). Payloads are size-limited before decoding,
rate-limited per (topic, source) after Zenoh's own per-connection downsampling, and a refused
one never stops the loop: refusals are counted and the last few shown in the status.

The server's core objects are used from the loop thread only; Zenoh callbacks queue commands
(and set the controller's e-stop flag, a single attribute write).

ROS 2: keys and payloads follow rmw_zenoh's design (``core.remote.ros``) and its liveliness
tokens declare the node ``deskarm_server``, its publishers and subscriptions
(``core.remote.graph``); ``/joint_states`` and a transient-local ``/robot_description`` are
published too.
"""
from __future__ import annotations

import json
import math
import os
import threading
import time
from collections import deque
from dataclasses import dataclass, field, replace
from typing import Callable, Optional

import numpy as np

from core.devices.bridge import BridgeError
from core.devices.reconnect import Reconnector
from core.settings import CameraSettings
from core.messages import (
    FRAME_CAMERA_LEFT,
    FRAME_CAMERA_RIGHT,
    FRAME_ROBOT_BASE,
    FRAME_TOOL,
    TargetMode,
)
from core.remote import commands as cmds
from core.remote import graph, ros
from core.remote.link import LOCAL_LISTEN, LinkOptions, open_session
from core.record.topics import ros_epoch

LINK_TIMEOUT_S = 0.5  # heartbeat gap after which the link counts as lost
LINK_LOST = "remote link lost"  # the controller's pause reason
STATUS_PERIOD_S = 0.5  # /deskarm/session and /deskarm/estop at least this often
TF_STATIC_PERIOD_S = 1.0  # /tf_static again for late joiners (Zenoh has no latched topics here)
SETTINGS_KEYS = ("mode", "follow_id", "lissajous_running", "camera")
REARM_HOLD_S = 1.0  # a remote re-arm: requests held this long (the window's hold is as long)
CONTROL_EXPIRE_S = 10.0  # a controlling client silent this long (no heartbeat) is gone: another may claim
INBOX_MAX = 512  # commands queued between two loop iterations at most (a flood beyond is dropped)
# Python-side per-source rates (Hz): a second line behind Zenoh's downsampling (security.COMMAND_RATE_HZ)
RATE_HZ = {"/deskarm/cmd/goal": 100.0, "/deskarm/cmd/settings": 20.0, "/deskarm/cmd/heartbeat": 25.0,
           "/deskarm/cmd/rearm": 25.0, "/deskarm/cmd/control": 10.0, "/deskarm/cmd/estop": 50.0,
           "/target_position": 100.0}
LATCHED = ("/robot_description", "/tf_static")


@dataclass
class ServerOptions:
    """How the server publishes."""

    link: LinkOptions = field(default_factory=lambda: LinkOptions(listen=(LOCAL_LISTEN,)))
    jpeg_quality: int = 80  # 1…100
    hash_style: str = "rihs01"  # rihs01 (Iron and later) | humble (rmw_zenoh's TypeHashNotSupported)
    link_timeout_s: float = LINK_TIMEOUT_S  # heartbeat gap that pauses the arm (s)
    rearm_hold_s: float = REARM_HOLD_S  # how long a remote re-arm must be held (s)
    graph: bool = True  # declare rmw_zenoh liveliness tokens (the ROS 2 graph sees the node)
    rate_hz: Optional[dict] = None  # per (topic, source) command rates (Hz); None: RATE_HZ

    def __post_init__(self) -> None:
        if not (1 <= int(self.jpeg_quality) <= 100):
            raise ValueError(f"--jpeg-quality {self.jpeg_quality}: outside 1…100")
        if not (0.05 <= float(self.link_timeout_s) <= 60):
            raise ValueError(f"link timeout {self.link_timeout_s} s: outside 0.05…60 s")
        ros.type_hash("std_msgs/msg/Bool", self.hash_style)  # raises naming the valid styles


@dataclass
class ServerStats:
    """What the server counted (for its status line and the tests)."""

    frames: int = 0
    commands_sent: int = 0
    published: int = 0
    publish_ms: deque = field(default_factory=lambda: deque(maxlen=600))  # per frame: encode + put
    goals_received: int = 0
    estops_received: int = 0
    heartbeats: int = 0
    link_losses: int = 0
    refused: cmds.Refusals = field(default_factory=cmds.Refusals)  # counted, the last few texts kept
    received: int = 0  # command samples that reached this process
    dropped: int = 0  # commands dropped by the rate limiter or a full inbox
    ignored_heartbeats: int = 0  # heartbeats from a client not in control


class DeskServer:
    """Runs a ``DeskSession`` and serves it over Zenoh until :meth:`stop`."""

    def __init__(self, session, options: Optional[ServerOptions] = None, status: Callable[[str], None] | None = None,
                 recorder=None):
        self.s = session
        self.recorder = recorder  # a core.record Recorder of this session (started by run), or None
        self.options = options or ServerOptions()
        self.status = status or (lambda line: None)
        self.stats = ServerStats()
        self.ready = threading.Event()  # set once publishing (the Zenoh session is open)
        self.applied = threading.Condition()  # notified after the loop applied received commands
        self._stop = threading.Event()
        self._zenoh = None
        self._pubs: dict[str, object] = {}
        self._subs: list = []
        self._gid = os.urandom(ros.GID_SIZE)
        self._seq = 0
        self._inbox: deque = deque()  # (topic, decoded message, receive monotonic s, source) from callbacks
        self._last_heartbeat: Optional[float] = None  # monotonic s of the controlling client's latest heartbeat
        self._clients = cmds.Clients()
        self._holder: Optional[tuple[str, str]] = None  # (client id, source GID hex) in control
        self._holder_seen = 0.0  # monotonic s of the holder's claim or latest heartbeat
        self._rearm = cmds.HoldTracker(cmds.Hold(hold_s=self.options.rearm_hold_s))
        self._limiter = cmds.RateLimiter(self.options.rate_hz if self.options.rate_hz is not None else RATE_HZ)
        self._limiter_lock = threading.Lock()
        self._tokens: list = []
        self._link_lost = False
        self._goal = None
        self._jpeg_cache: dict[str, bytes] = {}
        self._epoch = 0.0  # wall s - session clock s
        self._next_status = 0.0
        self._next_tf_static = 0.0
        self._status_dirty = True
        self._last_note = ""
        self.reconnector = Reconnector(now=session.clock.now)
        self.schedule = None

    # ---- lifecycle ----------------------------------------------------------------------------

    def stop(self) -> None:
        """Ask :meth:`run` to end (thread-safe, e.g. from a signal handler)."""
        self._stop.set()
        self._wake()

    def _wake(self) -> None:
        """End the loop's current wait (the clock's or the camera's) so it looks at its inbox."""
        for waiter in (self.s.clock, self.s.camera):
            interrupt = getattr(waiter, "interrupt", None)
            if interrupt is not None:
                interrupt()

    def open(self) -> None:
        """Open the Zenoh session, declare publishers and subscribers (LinkError if it cannot)."""
        self._zenoh = open_session(self.options.link)
        domain, style = self.options.link.domain_id, self.options.hash_style
        published = {**ros.TOPICS, **ros.STANDARD_TOPICS}
        for topic, msgtype in published.items():
            key = ros.key_expr(topic, msgtype, domain, style)
            self._pubs[topic] = self._declare_publisher(key, latched=topic in LATCHED)
        for topic, msgtype in ros.ALL_COMMANDS.items():
            self._subs.append(self._zenoh.declare_subscriber(
                ros.key_pattern(topic, msgtype, domain), self._callback(topic, msgtype)))
        if self.options.graph:
            zid = str(self._zenoh.zid())
            for key in graph.server_tokens(domain, zid, published, ros.ALL_COMMANDS, style, latched=LATCHED):
                self._tokens.append(self._zenoh.liveliness().declare_token(key))
        self._publish("/robot_description", ros.string_msg(robot_description(self.s)))

    def _declare_publisher(self, key: str, latched: bool):
        """A publisher; a latched one (transient local) keeps its last sample for late joiners, as
        rmw_zenoh's transient-local publishers do (zenoh-ext AdvancedPublisher with a cache)."""
        if latched:
            try:
                from zenoh import ext

                return ext.declare_advanced_publisher(self._zenoh, key, cache=ext.CacheConfig(1),
                                                      publisher_detection=True)
            except Exception:  # no zenoh-ext here: periodic republishing still reaches late joiners
                pass
        return self._zenoh.declare_publisher(key)

    def close(self) -> None:
        for token in self._tokens:
            try:
                token.undeclare()
            except Exception:  # already gone with the session
                pass
        self._tokens.clear()
        for sub in self._subs:
            try:
                sub.undeclare()
            except Exception:  # already gone with the session
                pass
        self._subs.clear()
        if self._zenoh is not None:
            self._zenoh.close()
            self._zenoh = None

    def run(self, duration_s: float = math.inf) -> ServerStats:
        """The loop: until :meth:`stop` or ``duration_s`` of the session clock. Closes the session."""
        s = self.s
        clock = s.clock
        try:
            if self._zenoh is None:
                self.open()
            s.bridge.connect()
            self.reconnector.ensure(s.bridge)
            schedule = self.schedule = s.control_schedule()
            state = s.bridge.joint_state()
            if state is not None and hasattr(s.camera, "set_arm_points"):
                s.camera.set_arm_points(s.kinematics.chain_points(state.q))
            t0 = clock.now()
            self._epoch = ros_epoch(clock)  # the recordings' offset: one stamp per frame everywhere
            if self.recorder is not None:
                self.recorder.start(calibration=s.calibration, estopped=self.estopped)
            self.ready.set()
            next_line = t0 + 1.0
            while not self._stop.is_set() and clock.now() - t0 < duration_s:
                self._apply_commands()
                self._check_link()
                self._publish_status()
                next_frame = getattr(s.camera, "next_frame_t", None)
                due = schedule.next_due(clock.now(), next_frame)
                if next_frame is not None and due < next_frame:
                    clock.wait_until(due)
                    if not self._stop.is_set():
                        self._apply_commands()
                        self._control_step()
                    continue
                frame = s.camera.read()
                if frame is None or self._stop.is_set():
                    continue
                self._apply_commands()
                result = s.perception.process(frame)
                if s.targeter.mode is TargetMode.CUPS:
                    result = replace(result, ball_left_px=s.ball_finder.find(frame.left))
                self._goal = s.targeter.update(result)
                self.stats.frames += 1
                self._publish_frame(frame, result)
                if self.recorder is not None:
                    self.recorder.frame(frame)
                    self.recorder.result(result)
                    self.recorder.estop(self.estopped)
                schedule.goal_arrived(clock.now())
                while schedule.due(clock.now()):
                    self._control_step()
                if clock.now() >= next_line:
                    next_line += 1.0
                    self.status(self.status_line())
        finally:
            self.ready.set()  # nobody waits forever on a server that failed to start
            try:
                if self.recorder is not None and self.recorder.is_recording:
                    self.recorder.close()
                s.close()
            finally:
                self.close()
        return self.stats

    # ---- commands in --------------------------------------------------------------------------

    def _callback(self, topic: str, msgtype: str):
        def on_sample(sample) -> None:
            try:
                self._receive(topic, msgtype, sample)
            except Exception as exc:  # nothing a peer sends may take the server down
                self._inbox_put(("refuse", f"{topic}: {type(exc).__name__}: {cmds.short(str(exc), 60)}", 0.0, ""))
        return on_sample

    def _receive(self, topic: str, msgtype: str, sample) -> None:
        received = time.monotonic()
        source = _source_of(sample)
        if topic == "/deskarm/cmd/estop":  # a STOP is never rate-limited away: it holds before anything else
            payload = sample.payload.to_bytes()
            refusal = ""
            try:
                msg = cmds.decode(topic, payload, msgtype)
            except cmds.Refused as exc:
                msg, refusal = None, str(exc)
            if msg is not None and msg.data is True:
                self.s.controller.estop()  # at once: the next control step, in any thread, sends nothing
                self._wake()  # the loop stops the bridge and echoes now, not after its wait
        with self._limiter_lock:  # callbacks of different subscribers may run at once
            self.stats.received += 1
            allowed = self._limiter.allow(topic, source, received)
        if not allowed:
            self.stats.dropped += 1
            return
        if topic != "/deskarm/cmd/estop":
            try:
                msg = cmds.decode(topic, sample.payload.to_bytes(), msgtype)
            except cmds.Refused as exc:
                self._inbox_put(("refuse", str(exc), received, source))
                return
        elif msg is None:
            self._inbox_put(("refuse", refusal, received, source))
            return
        self._inbox_put((topic, msg, received, source), urgent=topic == "/deskarm/cmd/estop")

    def _inbox_put(self, item, urgent: bool = False) -> None:
        if len(self._inbox) >= INBOX_MAX and not urgent:
            self.stats.dropped += 1
            return
        self._inbox.append(item)

    def _apply_commands(self) -> None:
        """Commands received since the last call, in order, on the loop thread."""
        if not self._inbox:
            return
        try:
            self._apply_inbox()
        finally:
            with self.applied:
                self.applied.notify_all()

    def _apply_inbox(self) -> None:
        while self._inbox:
            topic, msg, received, source = self._inbox.popleft()
            try:
                if topic == "refuse":
                    self._refuse(msg)
                else:
                    self._apply(topic, msg, received, source)
            except cmds.Refused as exc:
                self._refuse(str(exc))
            except Exception as exc:  # a bug or an unforeseen value: refuse it, keep serving
                self._refuse(f"{topic}: {type(exc).__name__}: {cmds.short(str(exc), 60)}")

    def _from_holder(self, topic: str, source: str, cid: Optional[str] = None) -> None:
        """Refused unless the sample comes from the client in control (and names it, when it names one)."""
        holder = self._holder
        if holder is None:
            raise cmds.Refused(f"{topic}: no client is in control — claim it first (/deskarm/cmd/control)")
        if source != holder[1] or (cid is not None and cid != holder[0]):
            raise cmds.Refused(f"{topic}: from a client not in control ({holder[0]} is)")

    def _apply(self, topic: str, msg, received: float, source: str) -> None:
        s = self.s
        if topic == "/deskarm/cmd/estop":
            self.stats.estops_received += 1
            if msg.data is not True:
                raise cmds.Refused(f"/deskarm/cmd/estop false: a re-arm is held on /deskarm/cmd/rearm by the "
                                   f"controlling client for {self.options.rearm_hold_s:g} s, never one message")
            s.controller.estop()
            s.bridge.estop()
            self._rearm.reset()
            self._publish("/deskarm/estop", ros.bool_msg(self.estopped))
            self._status_dirty = True
        elif topic == "/deskarm/cmd/control":
            self._apply_control(msg.data, source)
        elif topic == "/deskarm/cmd/heartbeat":
            cid = cmds.client_id(msg.frame_id)
            if self._clients.seen(cid, received):
                self._status_dirty = True
            holder = self._holder
            if holder is not None and (cid, source) == holder:
                self._last_heartbeat = self._holder_seen = received
                self.stats.heartbeats += 1
            else:
                self.stats.ignored_heartbeats += 1
        elif topic == "/deskarm/cmd/rearm":
            cid = cmds.client_id(msg.frame_id)
            self._from_holder(topic, source, cid)
            if self._rearm.press(cid, received):
                s.controller.rearm()
                s.bridge.rearm()
                self._publish("/deskarm/estop", ros.bool_msg(self.estopped))
            self._status_dirty = True
        elif topic == "/deskarm/cmd/goal":
            self._from_holder(topic, source)
            self.stats.goals_received += 1
            if msg.header.frame_id not in ("", FRAME_ROBOT_BASE):
                raise cmds.Refused(f"goal in frame {cmds.short(msg.header.frame_id, 40)}: expected {FRAME_ROBOT_BASE!r}")
            self._set_goal(cmds.check_goal((msg.point.x, msg.point.y, msg.point.z)))
        elif topic == "/target_position":
            if self._holder is not None:
                raise cmds.Refused(f"/target_position: {self._holder[0]} is in control of the arm")
            self.stats.goals_received += 1
            self._set_goal(cmds.check_goal((msg.x, msg.y, msg.z)))
        elif topic in ("/target_pitch", "/target_roll"):
            if self._holder is not None:
                raise cmds.Refused(f"{topic}: {self._holder[0]} is in control of the arm")
            self._set_tool_angle(topic, cmds.check_angle(topic, msg.data))
        elif topic == "/deskarm/cmd/settings":
            self._from_holder(topic, source)
            self._apply_settings(msg.data)

    def _set_goal(self, p) -> None:
        s = self.s
        try:
            s.targeter.set_mode(TargetMode.MANUAL)
            s.targeter.set_manual_target(p)
        except ValueError as exc:
            raise cmds.Refused(f"goal {p}: {exc}") from None
        self._goal = s.targeter.update(None)
        self._status_dirty = True
        if self.schedule is not None:
            self.schedule.goal_arrived(s.clock.now())

    def _set_tool_angle(self, topic: str, angle: float) -> None:
        """/target_pitch or /target_roll: the manual target's tool orientation (arms with a wrist)."""
        s = self.s
        if not hasattr(s.kinematics, "ik_pose"):
            raise cmds.Refused(f"{topic}: this arm ({s.profile.name}) has no wrist to orient — it takes "
                               "positions only (/target_position)")
        target = s.targeter.manual_target
        if target is None:
            raise cmds.Refused(f"{topic}: send /target_position first (an orientation needs a position)")
        roll, pitch, yaw = s.targeter.manual_rpy or (0.0, 0.0, 0.0)
        rpy = (angle, pitch, yaw) if topic == "/target_roll" else (roll, angle, yaw)
        try:
            s.targeter.set_mode(TargetMode.MANUAL)
            s.targeter.set_manual_pose(target, rpy, s.targeter.manual_grip_m)
        except ValueError as exc:
            raise cmds.Refused(f"{topic}: {exc}") from None
        self._goal = s.targeter.update(None)
        self._status_dirty = True

    def _apply_control(self, text: str, source: str) -> None:
        action, cid, take = cmds.parse_control(text)
        holder = self._holder
        if action == "claim":
            gone = holder is not None and time.monotonic() - self._holder_seen > CONTROL_EXPIRE_S
            if holder is None or holder == (cid, source) or take or gone:
                if holder is not None and holder != (cid, source):
                    how = "silent for more than %g s" % CONTROL_EXPIRE_S if gone and not take else "handed over"
                    self.status(f"deskarm serve: control of {holder[0]} {how}: {cid} has it now "
                                "(the arm stays paused until its heartbeat)")
                self._holder = (cid, source)
                self._holder_seen = time.monotonic()
                self._rearm.reset()
            else:
                raise cmds.Refused(f"control claimed by {cid}: {holder[0]} is in control "
                                   '(it releases, or the claim says "take": true)')
        elif holder is not None and holder == (cid, source):
            self._holder = None
        else:
            raise cmds.Refused(f"control release by {cid}: not the client in control")
        self._status_dirty = True

    def _apply_settings(self, text: str) -> None:
        s = self.s
        good, bad = cmds.parse_settings(text)
        for reason in bad:
            self._refuse(f"settings {reason}")
        for key, value in good.items():
            if key == "mode":
                s.targeter.set_mode(TargetMode(value))
            elif key == "follow_id":
                s.targeter.set_follow_id(value)
            elif key == "lissajous_running":
                s.targeter.set_lissajous_running(value)
            elif key == "camera":
                s.camera.set_settings(value)
        self._status_dirty = True

    def _refuse(self, text: str) -> None:
        self.stats.refused.add(text)
        self._status_dirty = True

    def _check_link(self) -> None:
        """Pause the arm while a client that sent heartbeats has gone quiet; resume when they return."""
        if self._clients.expire(time.monotonic()):
            self._status_dirty = True
        last = self._last_heartbeat
        lost = last is not None and time.monotonic() - last > self.options.link_timeout_s
        if lost and not self._link_lost:
            self._link_lost = True
            self.stats.link_losses += 1
            self.s.controller.pause(LINK_LOST)
            self._status_dirty = True
        elif not lost and self._link_lost:
            self._link_lost = False
            self.s.controller.resume(LINK_LOST)
            self._status_dirty = True

    @property
    def estopped(self) -> bool:
        return not self.s.controller.armed or bool(getattr(self.s.bridge, "is_estopped", False))

    @property
    def link_lost(self) -> bool:
        return self._link_lost

    # ---- the control step ---------------------------------------------------------------------

    def _control_step(self) -> None:
        s = self.s
        now = s.clock.now()
        self.schedule.ran(now)
        try:
            state = s.bridge.joint_state() if self.reconnector.ensure(s.bridge) else None
        except BridgeError as exc:
            self.reconnector.lost(s.bridge, exc)
            state = None
        if not s.bridge.is_connected:
            return
        q_now = s.controller.start_pose(state)
        cmd = s.controller.step(self._goal, q_now, now)
        if s.controller.note != self._last_note:
            self._last_note = s.controller.note
            self._status_dirty = True
        if cmd is None:
            return
        try:
            s.bridge.send(cmd)
        except BridgeError as exc:
            self.reconnector.lost(s.bridge, exc)
            return
        self.stats.commands_sent += 1
        if self.recorder is not None:
            self.recorder.command(cmd, self._goal)
        wall = self._wall(now)
        names = [j.name for j in s.profile.joints]
        self._publish("/deskarm/joint_states/commanded", ros.joint_state(names, cmd.q, wall))
        if self._goal is not None and self._goal.valid:
            self._publish("/deskarm/goal", ros.point_stamped(self._goal.base_p_target, wall))
        try:
            state = s.bridge.joint_state()
        except BridgeError as exc:
            self.reconnector.lost(s.bridge, exc)
            return
        if state is None:
            return
        if self.recorder is not None:
            self.recorder.state(state)
        if hasattr(s.camera, "set_arm_points"):
            s.camera.set_arm_points(s.kinematics.chain_points(state.q))
        if state.measured:
            self._publish("/deskarm/joint_states/measured", ros.joint_state(names, state.q, wall))
        self._publish("/joint_states", ros.joint_state(names, state.q, wall))
        tool = self._base_T_tool(state.q)
        if tool is not None:
            self._publish("/tf", ros.tf_message([ros.transform_stamped(tool, FRAME_ROBOT_BASE, FRAME_TOOL, wall)]))

    def _base_T_tool(self, q) -> Optional[np.ndarray]:
        k = self.s.kinematics
        try:
            if hasattr(k, "fk_pose"):
                return np.asarray(k.fk_pose(q), float)
            T = np.eye(4)
            T[:3, 3] = np.asarray(k.fk(q), float).reshape(3)
            return T
        except Exception:  # a kinematics without FK for this q: no /tf this step
            return None

    # ---- publishing ---------------------------------------------------------------------------

    def _wall(self, t: float) -> float:
        """Session clock seconds -> wall seconds (the stamps other machines compare with)."""
        return t + self._epoch

    def _publish(self, topic: str, msg) -> None:
        pub = self._pubs.get(topic)
        if pub is None:
            return
        self._seq += 1
        attachment = ros.Attachment(self._seq, time.time_ns(), self._gid).encode()
        pub.put(ros.serialize(msg, ros.ALL_TOPICS[topic]), attachment=attachment)
        self.stats.published += 1

    def _publish_frame(self, frame, result) -> None:
        import cv2

        w0 = time.perf_counter()
        wall = self._wall(frame.t)
        for side, image, frame_id in (("left", frame.left, FRAME_CAMERA_LEFT), ("right", frame.right, FRAME_CAMERA_RIGHT)):
            jpeg = self._jpeg_cache.get(side) if frame.repeated else None
            if jpeg is None:
                ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, int(self.options.jpeg_quality)])
                if not ok:
                    continue
                jpeg = self._jpeg_cache[side] = buf.tobytes()
            self._publish(f"/deskarm/camera/{side}/camera_info", ros.camera_info(self.s.calibration, side, wall))
            self._publish(ros.IMAGE_TOPICS[side], ros.compressed_image(jpeg, wall, frame_id))
        self._publish("/deskarm/markers", ros.marker_array(result, wall))
        self.stats.publish_ms.append((time.perf_counter() - w0) * 1e3)

    def session_status(self) -> dict:
        """The JSON published on /deskarm/session."""
        s, c = self.s, self.s.controller
        return {
            "camera": s.camera.name, "bridge": s.bridge.url, "robot": s.profile.name,
            "scenario": s.options.scenario, "mode": s.targeter.mode.value,
            "estopped": self.estopped, "paused": c.paused, "paused_by": sorted(c.paused_by),
            "link": "lost" if self._link_lost else ("ok" if self._last_heartbeat is not None else "no client"),
            "clients": self._clients.ids(), "note": cmds.short(c.note), "frames": self.stats.frames,
            "controller": self._holder[0] if self._holder is not None else None,
            "rearm_hold": round(self._rearm.progress(time.monotonic()), 2),
            "bridge_connected": s.bridge.is_connected, "refused": list(self.stats.refused.last),
            "refused_count": self.stats.refused.count, "dropped": self.stats.dropped,
            "camera_settings": _settings_dict(s.camera),
        }

    def _publish_status(self) -> None:
        now = time.monotonic()
        if now >= self._next_tf_static:
            self._next_tf_static = now + TF_STATIC_PERIOD_S
            self._publish("/robot_description", ros.string_msg(robot_description(self.s)))
            base_T_camera = getattr(self.s.perception, "base_T_camera", None)
            if base_T_camera is not None:
                wall = self._wall(self.s.clock.now())
                cal = self.s.calibration
                left_T_right = np.eye(4)  # X_right = R X_left + T  =>  left_T_right = inv([R T])
                left_T_right[:3, :3] = np.asarray(cal.R).T
                left_T_right[:3, 3] = -np.asarray(cal.R).T @ np.asarray(cal.T).reshape(3)
                self._publish("/tf_static", ros.tf_message([
                    ros.transform_stamped(base_T_camera, FRAME_ROBOT_BASE, FRAME_CAMERA_LEFT, wall),
                    ros.transform_stamped(left_T_right, FRAME_CAMERA_LEFT, FRAME_CAMERA_RIGHT, wall)]))
        if self._status_dirty or now >= self._next_status:
            self._status_dirty = False
            self._next_status = now + STATUS_PERIOD_S
            self._publish("/deskarm/session", ros.json_msg(self.session_status()))
            self._publish("/deskarm/estop", ros.bool_msg(self.estopped))

    def status_line(self) -> str:
        st, c = self.stats, self.s.controller
        pub = sorted(st.publish_ms)
        p50 = pub[len(pub) // 2] if pub else 0.0
        flags = (" E-STOP" if self.estopped else "") + (f" paused: {', '.join(sorted(c.paused_by))}" if c.paused else "")
        return (f"frames={st.frames} commands={st.commands_sent} published={st.published} "
                f"publish={p50:.2f}ms clients={len(self._clients)} link={self.session_status()['link']}{flags}")


def _settings_dict(camera) -> dict:
    """The served camera's image settings (exposure, gain, brightness, contrast) for the status."""
    from dataclasses import asdict, is_dataclass

    settings = getattr(camera, "settings", None)
    return asdict(settings) if is_dataclass(settings) else {}


def _source_of(sample) -> str:
    """The sending publisher's GID (hex) from its rmw attachment, or "" without a valid one."""
    attachment = sample.attachment
    if attachment is None:
        return ""
    try:
        return ros.Attachment.decode(attachment.to_bytes()).gid.hex()
    except ValueError:
        return ""


def robot_description(session) -> str:
    """The arm's URDF: the profile's own file for a URDF arm, else one generated from the profile
    (its joints in order with their limits; link geometry lives in the deskarm profile)."""
    from xml.sax.saxutils import quoteattr

    path = getattr(session.kinematics, "urdf_path", "")
    if path:
        try:
            with open(path, encoding="utf-8") as f:
                return f.read()
        except OSError:
            pass
    profile = session.profile
    lines = [f'<?xml version="1.0"?>', f"<robot name={quoteattr(str(profile.name))}>",
             f"  <!-- generated by deskarm from its {profile.name} profile: joints and limits; "
             "the geometry is in the profile -->", '  <link name="robot_base"/>']
    parent = "robot_base"
    for i, j in enumerate(profile.joints):
        child = "tool" if i == len(profile.joints) - 1 else f"link_{j.name}"
        kind = "prismatic" if getattr(j, "joint_type", "revolute") == "prismatic" else "revolute"
        lines += [f"  <link name={quoteattr(child)}/>",
                  f"  <joint name={quoteattr(j.name)} type={quoteattr(kind)}>",
                  f"    <parent link={quoteattr(parent)}/><child link={quoteattr(child)}/>",
                  '    <axis xyz="0 0 1"/>',
                  f'    <limit lower="{j.q_min:.6f}" upper="{j.q_max:.6f}" effort="1" velocity="1"/>',
                  "  </joint>"]
        parent = child
    lines.append("</robot>")
    return "\n".join(lines) + "\n"
