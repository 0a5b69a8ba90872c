"""The desk as a server: the headless pipeline on one machine, published over Zenoh.

``DeskServer`` runs the loop of the headless runner (camera frames at the camera rate,
perception, targeting, the control step when the session's ``ControlSchedule`` says so, the
bridge with the window's reconnection backoff) and publishes, per frame / result / command /
state, the messages of ``core.remote.ros.TOPICS`` — the same messages the recordings hold.

Commands come back from clients (``/deskarm/cmd/...``):

- e-stop (std_msgs/Bool true): ``controller.estop()`` in the Zenoh callback itself (the next
  control step sends nothing), then ``bridge.estop()`` and the ``/deskarm/estop`` echo in the
  same loop iteration it arrives in (the loop never sleeps more than a control tick, 20 ms).
  false re-arms both.
- goal (geometry_msgs/PointStamped in robot_base): manual mode, that target.
- settings (std_msgs/String JSON): ``{"mode": "follow"|"manual"|"lissajous"|"cups",
  "follow_id": 23, "lissajous_running": true}``; anything else is refused and the session
  status says what was refused.
- heartbeat (std_msgs/Header, 10 Hz): once a client has sent one, a gap longer than
  ``link_timeout_s`` (0.5 s) pauses the arm (``controller.pause("remote link lost")``: it holds its
  last command, it never keeps following a target nobody can watch) until heartbeats return.

The server's core objects are used from the loop thread only; Zenoh callbacks queue commands
(and set the controller's e-stop flag, a single attribute write).

ROS 2: keys and payloads follow rmw_zenoh's design (``core.remote.ros``); no liveliness tokens
are declared, so ROS tools see the data only when subscribing to the topic by name.
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
from core.remote import ros
from core.remote.link import LinkOptions, open_session

LINK_TIMEOUT_S = 0.5  # heartbeat gap after which the link counts as lost
LINK_LOST = "remote link lost"  # the controller's pause reason
STATUS_PERIOD_S = 0.5  # /deskarm/session and /deskarm/estop at least this often
TF_STATIC_PERIOD_S = 1.0  # /tf_static again for late joiners (Zenoh has no latched topics here)
SETTINGS_KEYS = ("mode", "follow_id", "lissajous_running", "camera")


@dataclass
class ServerOptions:
    """How the server publishes."""

    link: LinkOptions = field(default_factory=lambda: LinkOptions(listen=("tcp/0.0.0.0:7447",)))
    jpeg_quality: int = 80  # 1…100
    hash_style: str = "rihs01"  # rihs01 (Iron and later) | humble (rmw_zenoh's TypeHashNotSupported)
    link_timeout_s: float = LINK_TIMEOUT_S  # heartbeat gap that pauses the arm (s)

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
    refused: list = field(default_factory=list)  # settings refused (text)


class DeskServer:
    """Runs a ``DeskSession`` and serves it over Zenoh until :meth:`stop`."""

    def __init__(self, session, options: Optional[ServerOptions] = None, status: Callable[[str], None] | None = None):
        self.s = session
        self.options = options or ServerOptions()
        self.status = status or (lambda line: None)
        self.stats = ServerStats()
        self.ready = threading.Event()  # set once publishing (the Zenoh session is open)
        self._stop = threading.Event()
        self._zenoh = None
        self._pubs: dict[str, object] = {}
        self._subs: list = []
        self._gid = os.urandom(ros.GID_SIZE)
        self._seq = 0
        self._inbox: deque = deque()  # (topic, decoded message, receive monotonic s) from callbacks
        self._last_heartbeat: Optional[float] = None  # monotonic s of the latest heartbeat
        self._clients: set[str] = set()
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
        for topic, msgtype in ros.TOPICS.items():
            self._pubs[topic] = self._zenoh.declare_publisher(ros.key_expr(topic, msgtype, domain, style))
        for topic, msgtype in ros.COMMANDS.items():
            self._subs.append(self._zenoh.declare_subscriber(
                ros.key_pattern(topic, msgtype, domain), self._callback(topic, msgtype)))

    def close(self) -> None:
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
            self._epoch = time.time() - t0
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
                schedule.goal_arrived(clock.now())
                while schedule.due(clock.now()):
                    self._control_step()
                if clock.now() >= next_line:
                    next_line += 1.0
                    self.status(self.status_line())
        finally:
            self.ready.set()  # nobody waits forever on a server that failed to start
            try:
                s.close()
            finally:
                self.close()
        return self.stats

    # ---- commands in --------------------------------------------------------------------------

    def _callback(self, topic: str, msgtype: str):
        def on_sample(sample) -> None:
            received = time.monotonic()
            try:
                msg = ros.deserialize(sample.payload.to_bytes(), msgtype)
            except Exception as exc:  # a foreign or corrupt payload: refuse it, keep serving
                self.stats.refused.append(f"{topic}: undecodable payload ({exc})")
                return
            if topic == "/deskarm/cmd/estop" and msg.data:
                self.s.controller.estop()  # at once: the next control step, in any thread, sends nothing
                self._inbox.append((topic, msg, received))
                self._wake()  # the loop stops the bridge and echoes now, not after its wait
                return
            if topic == "/deskarm/cmd/heartbeat":
                self._last_heartbeat = received
                self.stats.heartbeats += 1
            self._inbox.append((topic, msg, received))
        return on_sample

    def _apply_commands(self) -> None:
        """Commands received since the last call, in order, on the loop thread."""
        s = self.s
        while self._inbox:
            topic, msg, _ = self._inbox.popleft()
            if topic == "/deskarm/cmd/estop":
                self.stats.estops_received += 1
                if msg.data:
                    s.controller.estop()
                    s.bridge.estop()
                else:
                    s.controller.rearm()
                    s.bridge.rearm()
                self._publish("/deskarm/estop", ros.bool_msg(self.estopped))
                self._status_dirty = True
            elif topic == "/deskarm/cmd/goal":
                self.stats.goals_received += 1
                if msg.header.frame_id not in ("", FRAME_ROBOT_BASE):
                    self._refuse(f"goal in frame {msg.header.frame_id!r}: expected {FRAME_ROBOT_BASE!r}")
                    continue
                p = (msg.point.x, msg.point.y, msg.point.z)
                try:
                    s.targeter.set_mode(TargetMode.MANUAL)
                    s.targeter.set_manual_target(p)
                except ValueError as exc:
                    self._refuse(f"goal {p}: {exc}")
                    continue
                self._goal = s.targeter.update(None)
                self._status_dirty = True
                if self.schedule is not None:
                    self.schedule.goal_arrived(s.clock.now())
            elif topic == "/deskarm/cmd/settings":
                self._apply_settings(msg.data)
            elif topic == "/deskarm/cmd/heartbeat":
                if msg.frame_id and msg.frame_id not in self._clients:
                    self._clients.add(msg.frame_id)
                    self._status_dirty = True

    def _apply_settings(self, text: str) -> None:
        s = self.s
        try:
            settings = json.loads(text)
            if not isinstance(settings, dict):
                raise ValueError("not a JSON object")
        except ValueError as exc:
            self._refuse(f"settings {text[:80]!r}: {exc}")
            return
        for key, value in settings.items():
            try:
                if key == "mode":
                    s.targeter.set_mode(TargetMode(value))
                elif key == "follow_id":
                    s.targeter.set_follow_id(int(value))
                elif key == "lissajous_running":
                    s.targeter.set_lissajous_running(bool(value))
                elif key == "camera":  # exposure, gain, brightness, contrast (CameraSettings fields)
                    if not isinstance(value, dict):
                        raise ValueError("expected an object of camera settings")
                    s.camera.set_settings(CameraSettings(**value))
                else:
                    raise ValueError(f"unknown key; valid: {', '.join(SETTINGS_KEYS)}")
            except (ValueError, TypeError) as exc:
                self._refuse(f"settings {key}={value!r}: {exc}")
        self._status_dirty = True

    def _refuse(self, text: str) -> None:
        self.stats.refused.append(text)
        del self.stats.refused[:-20]
        self._status_dirty = True

    def _check_link(self) -> None:
        """Pause the arm while a client that sent heartbeats has gone quiet; resume when they return."""
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
        if hasattr(s.camera, "set_arm_points"):
            s.camera.set_arm_points(s.kinematics.chain_points(state.q))
        if state.measured:
            self._publish("/deskarm/joint_states/measured", ros.joint_state(names, state.q, wall))
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
        pub.put(ros.serialize(msg, ros.TOPICS[topic]), attachment=attachment)
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
            "clients": sorted(self._clients), "note": c.note, "frames": self.stats.frames,
            "bridge_connected": s.bridge.is_connected, "refused": self.stats.refused[-5:],
            "camera_settings": _settings_dict(s.camera),
        }

    def _publish_status(self) -> None:
        now = time.monotonic()
        if now >= self._next_tf_static:
            self._next_tf_static = now + TF_STATIC_PERIOD_S
            base_T_camera = getattr(self.s.perception, "base_T_camera", None)
            if base_T_camera is not None:
                wall = time.time()
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
