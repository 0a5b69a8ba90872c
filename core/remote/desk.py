"""A desk served by ``deskarm serve`` on another machine, as this machine's camera and bridge.

``deskarm --remote tcp/HOST:7447`` builds its ``DeskSession`` from these two, so the window and
the headless runner work unchanged on a remote desk:

- ``RemoteStereoCamera`` — a ``CameraSource`` fed by a ``DeskClient``: each new image pair
  (the left and right CompressedImage with the same stamp) decoded to BGR is a ``StereoFrame``.
  Perception runs here, on this machine. ``calibration()`` is rebuilt from the two CameraInfo
  messages (the server publishes no calibration file): K, D and the rectified R, P of each
  camera give the stereo pose (see :func:`calibration_from_camera_info`). ``base_T_camera()``
  is the server's /tf_static (robot_base → camera_left).
- ``RemoteBridge`` — a ``MotorBridge`` whose ``send(command)`` sends the command's target point
  as a goal (/deskarm/cmd/goal, robot_base): the serving machine runs its own control step,
  joint limits and workspace checks on it. ``joint_state()`` is the server's
  /deskarm/joint_states/measured, e-stop is /deskarm/cmd/estop and re-arm a held
  /deskarm/cmd/rearm (the window's own hold comes first). While the bridge is connected the
  client claims control and sends its heartbeat, so the server pauses its arm when this machine
  goes away.

Credentials: this machine's ``remote/client.toml`` in the config folder (the controller.toml or
viewer.toml that ``deskarm serve --pair`` made on the serving machine) when it exists; a server
that refuses it is said in one line (``core.remote.security.refusal_line``).

Times: a ``StereoFrame.t`` is the capture stamp (the server's wall clock) mapped onto the local
session clock through this machine's wall clock — ``t = clock.now() - (time.time() - stamp)``,
never later than the arrival. On one machine that is the capture instant; across machines it
is off by the two wall clocks' offset (synchronise them with chrony/NTP), so latencies measured
from it include the network and the JPEG round trip.

A link that goes quiet (no message for ``LINK_TIMEOUT_S``) is a visible state, never a crash:
``read()`` returns None, ``is_connected`` is False and ``status_message`` says
"remote desk not answering — retrying" (Zenoh keeps reconnecting to the endpoint by itself).
"""
from __future__ import annotations

import threading
import time
from typing import Optional

import numpy as np

from core.devices.bridge import BridgeError, MotorBridge
from core.messages import (
    FRAME_CAMERA_LEFT,
    FRAME_ROBOT_BASE,
    BridgeStatus,
    JointCommand,
    JointState,
    SequenceCounter,
    StereoFrame,
)
from core.motion.safety import to_servo_bytes_deg
from core.remote import ros
from core.remote.link import LinkOptions, check_endpoint
from core.vision.calibration import StereoCalibration
from core.vision.cameras import CameraSource

LINK_TIMEOUT_S = 1.5  # no message from the server for this long: the link counts as lost (it publishes ≥ 2 Hz)
CONNECT_TIMEOUT_S = 10.0  # a session waits this long for the server's camera_info and /tf_static
READ_TIMEOUT_S = 0.25  # read() returns None after this long without a new image pair
WAIT_SLICE_S = 0.05  # waits are cut in slices this long so interrupt() ends them
PAIR_TIMEOUT_S = 0.2  # after a left image, how long its right image may take
GOAL_REFRESH_S = 0.5  # an unchanged goal is sent again this often (a restarted server gets it)
GOAL_EPS_M = 1e-4  # a goal closer than this to the last one sent is unchanged
NOT_ANSWERING = "remote desk not answering — retrying"
LEFT, RIGHT = ros.IMAGE_TOPICS["left"], ros.IMAGE_TOPICS["right"]
INFO = {side: f"/deskarm/camera/{side}/camera_info" for side in ("left", "right")}
MEASURED, COMMANDED = "/deskarm/joint_states/measured", "/deskarm/joint_states/commanded"
# topics the server publishes at least twice a second whatever happens: the link's pulse
PULSE_TOPICS = ("/deskarm/session", "/deskarm/estop", LEFT)


class RemoteDeskError(RuntimeError):
    """The desk server did not answer or sent something unusable; the message says what to do."""


class RemoteDesk:
    """The shared link of one remote desk: a ``DeskClient`` used by its camera and its bridge.

    The client opens with the first user's ``acquire`` and closes with the last ``release``
    (when this object opened it; a client handed in stays open, its owner closes it).
    """

    def __init__(self, endpoint: Optional[str] = None, client=None, domain_id: int = 0, credential=None):
        if endpoint is None and client is None:
            raise ValueError("a remote desk needs an endpoint (e.g. tcp/192.168.1.20:7447) or a DeskClient")
        if endpoint is None:
            endpoint = ", ".join(client.link.connect) or client.link.describe()
        else:
            check_endpoint(endpoint)
        self.endpoint = endpoint
        self.domain_id = int(domain_id)
        self.credential = credential  # security.Credential; None: this machine's remote/client.toml if any
        self._client = client
        self._owns_client = client is None
        self._users: set[int] = set()
        self._lock = threading.Lock()

    @property
    def client(self):
        """The open DeskClient, or None before the first ``acquire`` / after the last ``release``."""
        return self._client

    def acquire(self, user) -> object:
        """The client, opened if needed (RemoteDeskError when Zenoh cannot open a session)."""
        from core.remote.client import DeskClient
        from core.remote.link import LinkError

        with self._lock:
            if self._client is None:
                from core.remote.security import CredentialError, default_credential

                try:
                    credential = self.credential if self.credential is not None else default_credential()
                except CredentialError as exc:
                    raise RemoteDeskError(str(exc)) from None
                link = LinkOptions(connect=(self.endpoint,), scouting=False, domain_id=self.domain_id,
                                   credential=credential)
                try:
                    self._client = DeskClient(link, heartbeat=False)
                except LinkError as exc:
                    raise RemoteDeskError(f"{self.endpoint}: {exc}") from None
            self._users.add(id(user))
            return self._client

    def release(self, user) -> None:
        """``user`` is done; the last one out closes the client this object opened."""
        with self._lock:
            self._users.discard(id(user))
            if self._users or not self._owns_client or self._client is None:
                return
            client, self._client = self._client, None
        client.close()

    def last_heard(self) -> Optional[float]:
        """time.monotonic() of the newest message from the server, or None."""
        client = self._client
        if client is None:
            return None
        times = [r.received_mono for r in (client.latest(t) for t in PULSE_TOPICS) if r is not None]
        return max(times) if times else None

    def alive(self, timeout_s: float = LINK_TIMEOUT_S) -> bool:
        """True when the server was heard from within ``timeout_s``."""
        last = self.last_heard()
        return last is not None and time.monotonic() - last < timeout_s

    def server_estopped(self) -> Optional[bool]:
        """The server's latest /deskarm/estop echo (None before one arrived)."""
        client = self._client
        r = client.latest("/deskarm/estop") if client is not None else None
        return None if r is None else bool(r.msg.data)


def _as_desk(source) -> RemoteDesk:
    return source if isinstance(source, RemoteDesk) else RemoteDesk(client=source)


def local_time(stamp_wall_s: float, clock, received_wall_s: Optional[float] = None) -> float:
    """A server wall-clock stamp on the local session clock, never later than its arrival."""
    now_wall = time.time()
    age = max(0.0, now_wall - stamp_wall_s)
    if received_wall_s is not None:
        age = max(age, now_wall - received_wall_s)
    return clock.now() - age


# ---- calibration and pose from the served messages ---------------------------------------------

def calibration_from_camera_info(left, right, source: str = "") -> StereoCalibration:
    """A StereoCalibration from the two CameraInfo messages of a rectified stereo pair.

    Each camera gives K, D and its rectifying rotation R_i and projection P_i. The rectified
    frames are parallel and the right one sits at ``t = (P2[0,3]/P2[0,0], P2[1,3]/P2[1,1], 0)``
    from the left one, so ``X_right = R2ᵀ (R1 X_left + t)``: ``R = R2ᵀ R1``, ``T = R2ᵀ t``.
    """
    for side, info in (("left", left), ("right", right)):
        if info.width <= 0 or info.height <= 0 or float(info.k[0]) <= 0 or len(info.p) != 12:
            raise RemoteDeskError(f"camera_info of the {side} camera is unusable "
                                  f"({info.width}x{info.height}, fx={float(info.k[0]):g}) — check the server's calibration")
    if (left.width, left.height) != (right.width, right.height):
        raise RemoteDeskError(f"camera_info sizes differ: left {left.width}x{left.height}, "
                              f"right {right.width}x{right.height}")
    R1 = np.asarray(left.r, np.float64).reshape(3, 3)
    R2 = np.asarray(right.r, np.float64).reshape(3, 3)
    P2 = np.asarray(right.p, np.float64).reshape(3, 4)
    t_rect = np.array([P2[0, 3] / P2[0, 0], P2[1, 3] / P2[1, 1], 0.0])
    R = R2.T @ R1
    T = (R2.T @ t_rect).reshape(3, 1)
    if np.linalg.norm(T) < 1e-6:
        raise RemoteDeskError("camera_info gives no stereo baseline (P of the right camera has no offset)")
    return StereoCalibration(
        M1=np.asarray(left.k, np.float64).reshape(3, 3), D1=np.asarray(left.d, np.float64).reshape(1, -1),
        M2=np.asarray(right.k, np.float64).reshape(3, 3), D2=np.asarray(right.d, np.float64).reshape(1, -1),
        R=R, T=T, image_size=(int(left.width), int(left.height)), source=source)


def matrix_of_transform(tf) -> np.ndarray:
    """A geometry_msgs/Transform as a 4x4 parent_T_child."""
    q = tf.rotation
    x, y, z, w = float(q.x), float(q.y), float(q.z), float(q.w)
    n = (x * x + y * y + z * z + w * w) ** 0.5 or 1.0
    x, y, z, w = x / n, y / n, z / n, w / n
    T = np.eye(4)
    T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    T[:3, 3] = (tf.translation.x, tf.translation.y, tf.translation.z)
    return T


def base_T_camera_of(tf_message) -> Optional[np.ndarray]:
    """robot_base → camera_left of a /tf_static TFMessage, or None when it has none."""
    for t in tf_message.transforms:
        if t.header.frame_id == FRAME_ROBOT_BASE and t.child_frame_id == FRAME_CAMERA_LEFT:
            return matrix_of_transform(t.transform)
    return None


# ---- the camera ---------------------------------------------------------------------------------

class RemoteStereoCamera(CameraSource):
    """The served desk's image pairs as a CameraSource (see the module docstring)."""

    kind = "remote"

    def __init__(self, source, clock=None):
        super().__init__()
        from core.clock import WallClock

        self.desk = _as_desk(source)
        self.clock = clock or WallClock()
        self._open = False
        self._interrupt = threading.Event()
        self._seq = SequenceCounter()
        self._last_left_index = 0
        self._last_jpeg: Optional[tuple[bytes, bytes]] = None
        self._last_images: Optional[tuple[np.ndarray, np.ndarray]] = None
        self._calibration: Optional[StereoCalibration] = None
        self._size: Optional[tuple[int, int]] = None
        self.last_stamp_wall: Optional[float] = None  # capture stamp (server wall s) of the last frame
        self.frames = 0  # image pairs delivered
        self.pairs_dropped = 0  # left images whose right image never came

    @property
    def name(self) -> str:
        return f"remote: {self.desk.endpoint}"

    def set_settings(self, settings) -> None:
        """Exposure, gain, brightness, contrast: sent to the serving machine's cameras."""
        super().set_settings(settings)
        client = getattr(self.desk, "client", None)
        if client is not None:
            from dataclasses import asdict

            client.send_settings({"camera": asdict(settings)}, wait=False)

    @property
    def pair_id(self) -> str:
        return f"remote:{self.desk.endpoint}"

    def connect(self) -> None:
        """Subscribe (RemoteDeskError when Zenoh cannot open a session); frames follow the link."""
        if not self._open:
            self.desk.acquire(self)
            self._open = True

    def disconnect(self) -> None:
        if self._open:
            self._open = False
            self._interrupt.set()
            self.desk.release(self)

    @property
    def is_connected(self) -> bool:
        return self._open and self.desk.alive()

    def interrupt(self) -> None:
        self._interrupt.set()

    def wait_ready(self, timeout: float = CONNECT_TIMEOUT_S) -> None:
        """Block until both camera_info messages and /tf_static have arrived (what a session
        needs to start), else RemoteDeskError naming what is missing and what to check."""
        client = self.desk.client
        if client is None:
            raise RemoteDeskError(f"{self.name}: not connected")
        deadline = time.monotonic() + timeout
        missing = []
        for topic in (INFO["left"], INFO["right"], "/tf_static"):
            if client.wait_for(topic, timeout=max(0.0, deadline - time.monotonic())) is None:
                missing.append(topic)
        if missing:
            heard = "it answers but sent no " + ", ".join(missing) if self.desk.last_heard() else "nothing arrived"
            from core.remote.security import port_answers, refusal_line

            if not self.desk.last_heard() and _refused(client) and port_answers(self.desk.endpoint):
                raise RemoteDeskError(refusal_line((self.desk.endpoint,), client.link.credential))
            raise RemoteDeskError(
                f"{self.desk.endpoint}: no desk server answered within {timeout:g} s ({heard}) — is "
                "`deskarm serve` running on that machine, listening on that port, and the port open in its firewall?")
        if self.base_T_camera() is None:
            raise RemoteDeskError(f"{self.desk.endpoint}: /tf_static has no robot_base → camera_left transform")
        self.calibration()

    def calibration(self) -> Optional[StereoCalibration]:
        """The stereo calibration rebuilt from the served camera_info pair (None before it arrived)."""
        if self._calibration is not None:
            return self._calibration
        client = self.desk.client
        if client is None:
            return None
        left, right = client.latest(INFO["left"]), client.latest(INFO["right"])
        if left is None or right is None:
            return None
        self._calibration = calibration_from_camera_info(left.msg, right.msg, source=f"camera_info from {self.desk.endpoint}")
        self._size = self._calibration.image_size
        return self._calibration

    def base_T_camera(self) -> Optional[np.ndarray]:
        """robot_base → camera_left as the server's /tf_static says (its hand-eye calibration)."""
        client = self.desk.client
        r = client.latest("/tf_static") if client is not None else None
        return base_T_camera_of(r.msg) if r is not None else None

    def actual_mode(self) -> list[tuple[int, int, float]]:
        """[(width, height, fps)] of the served images, once camera_info arrived."""
        return [(self._size[0], self._size[1], 0.0)] if self._size else []

    def read(self) -> Optional[StereoFrame]:
        """The next served image pair, or None after READ_TIMEOUT_S without one (or on interrupt)."""
        client = self.desk.client
        if not self._open or client is None:
            return None
        self._interrupt.clear()
        deadline = time.monotonic() + READ_TIMEOUT_S
        while not self._interrupt.is_set() and self._open:
            left = client.wait_for(LEFT, timeout=min(WAIT_SLICE_S, max(0.0, deadline - time.monotonic())),
                                   after=self._last_left_index)
            if left is None:
                if time.monotonic() >= deadline:
                    break
                continue
            stamp = ros.stamp_s(left.msg.header.stamp)
            right = client.wait_for(RIGHT, lambda r: ros.stamp_s(r.msg.header.stamp) >= stamp,
                                    timeout=PAIR_TIMEOUT_S)
            latest_left = client.latest(LEFT)
            if right is None or ros.stamp_s(right.msg.header.stamp) != stamp:
                # its right image was replaced by a newer one (or never came): try the newest left
                self.pairs_dropped += 1
                if right is None or latest_left.index == left.index:
                    self._last_left_index = left.index
                continue
            self._last_left_index = left.index
            frame = self._frame(left, right, stamp)
            if frame is not None:
                self.status_message = ""
                return frame
        if self._open and not self.desk.alive():
            self.status_message = f"{self.desk.endpoint}: {NOT_ANSWERING}"
        return None

    def _frame(self, left, right, stamp: float) -> Optional[StereoFrame]:
        import cv2

        jpegs = (bytes(left.msg.data), bytes(right.msg.data))
        repeated = self._last_jpeg is not None and jpegs == self._last_jpeg
        if repeated:
            images = self._last_images
        else:
            images = tuple(cv2.imdecode(np.frombuffer(j, np.uint8), cv2.IMREAD_COLOR) for j in jpegs)
            if images[0] is None or images[1] is None:
                self.status_message = f"{self.desk.endpoint}: an image could not be decoded (not JPEG/PNG?)"
                return None
            self._last_jpeg, self._last_images = jpegs, images
        self.frames += 1
        self.last_stamp_wall = stamp
        t = local_time(stamp, self.clock, received_wall_s=right.received_wall)
        return StereoFrame(seq=self._seq.next(), t=t, left=images[0], right=images[1], repeated=repeated)


# ---- the bridge ---------------------------------------------------------------------------------

class RemoteBridge(MotorBridge):
    """The served desk's arm as a MotorBridge: goals out, measured joint states in (see the module docstring)."""

    has_feedback = True
    max_command_hz = 50.0  # goals, not servo bytes: the server's own control step runs at 50 Hz

    def __init__(self, source, profile, clock=None):
        self.desk = _as_desk(source)
        super().__init__(f"remote:{self.desk.endpoint}", profile, clock=clock)
        self._open = False
        self._last_goal: Optional[tuple[float, float, float]] = None
        self._last_goal_mono = float("-inf")
        self.goals_sent = 0
        self.last_sent_q: Optional[tuple[float, ...]] = None  # joints this machine's IK chose for the last goal
        self.message = f"remote arm on {self.desk.endpoint}"

    def connect(self) -> None:
        """Start the heartbeat (the server pauses its arm without it); BridgeError while the
        server does not answer (the reconnector retries)."""
        if not self._open:
            try:
                client = self.desk.acquire(self)
            except RuntimeError as exc:
                raise BridgeError(str(exc)) from None
            self._open = True
            client.control = True  # the heartbeat loop claims the arm until the server grants it
            client.start_heartbeat()
            if self._estopped:  # an e-stop made while disconnected holds on the server too
                client.send_estop(True)
        if not self.desk.alive():
            raise BridgeError(f"{self.desk.endpoint}: {NOT_ANSWERING}")
        self.message = f"remote arm on {self.desk.endpoint}"

    def disconnect(self) -> None:
        """Stop the heartbeat (the server pauses its arm) and let go of the link."""
        if self._open:
            self._open = False
            client = self.desk.client
            if client is not None:
                client.stop_heartbeat()
            self.desk.release(self)

    @property
    def is_connected(self) -> bool:
        return self._open and self.desk.alive()

    def _write_servo_deg(self, servo_deg: tuple[int, ...]) -> int:  # never called: send() sends goals
        raise NotImplementedError("a remote bridge sends goals, not servo angles")

    def send(self, command: JointCommand) -> tuple[int, ...]:
        """Send the command's target point as the server's goal; returns the servo angles this
        machine's IK chose (the server computes its own), or () while e-stopped / without a target."""
        if self._estopped or command.base_p_target is None:
            return ()
        client = self.desk.client
        if not self._open or client is None:
            raise BridgeError(f"{self.desk.endpoint}: not connected")
        target = tuple(float(v) for v in command.base_p_target)  # in robot_base
        now = time.monotonic()
        unchanged = (self._last_goal is not None
                     and max(abs(a - b) for a, b in zip(target, self._last_goal)) < GOAL_EPS_M)
        if not unchanged or now - self._last_goal_mono >= GOAL_REFRESH_S:
            client.send_goal(target, FRAME_ROBOT_BASE, wait=False)
            self._last_goal, self._last_goal_mono = target, now
            self.goals_sent += 1
        self.commands_sent += 1
        self.last_write_t = self.clock.now()
        self.last_source_t = command.source_t
        self.last_sent_q = tuple(command.q)
        if getattr(self.profile, "has_servos", True):
            return to_servo_bytes_deg(command.q, self.profile)
        return tuple(command.q)

    def joint_state(self) -> Optional[JointState]:
        """The server's measured joint state (its commanded one, ``measured=False``, when its arm
        has no feedback), stamped on the local clock; None before one arrived."""
        client = self.desk.client
        if client is None:
            return None
        r = client.latest(MEASURED)
        measured = r is not None
        if r is None:
            r = client.latest(COMMANDED)
        if r is None:
            return None
        t = local_time(ros.stamp_s(r.msg.header.stamp), self.clock, received_wall_s=r.received_wall)
        return JointState(seq=r.index, t=t, q=tuple(float(v) for v in r.msg.position), measured=measured)

    def _on_estop(self) -> None:
        client = self.desk.client
        if client is not None:
            client.send_estop(True)

    def _on_rearm(self) -> None:
        """The window's hold is done: hold the server's re-arm too (a thread, REARM_HOLD_S)."""
        client = self.desk.client
        if client is not None:
            client.request_rearm()

    def _estop_text(self) -> str:
        held = self.desk.server_estopped()
        echo = "the server confirms its arm is stopped" if held else "waiting for the server to confirm"
        return f"E-STOP sent to {self.desk.endpoint} — {echo}; re-arm to resume"

    def status(self) -> BridgeStatus:
        if self._open and not self.desk.alive():
            self.message = f"{self.desk.endpoint}: {NOT_ANSWERING}"
        elif self._open:
            self.message = f"remote arm on {self.desk.endpoint}"
        return super().status()


def _refused(client) -> bool:
    """True when the client reached no Zenoh peer at all (a refused handshake or nobody there)."""
    try:
        return not client._zenoh.info.peers_zid() and not client._zenoh.info.routers_zid()
    except Exception:  # a closed session: say nothing more
        return False


def open_remote_desk(endpoint: str, profile, clock=None, timeout: float = CONNECT_TIMEOUT_S, credential=None):
    """(camera, bridge) of the desk served at ``endpoint``: the camera connected and its
    calibration and pose received, the bridge not yet connected. RemoteDeskError when the
    server does not answer within ``timeout`` seconds, or refused this machine's credential
    (``credential``, default: the config folder's remote/client.toml)."""
    desk = RemoteDesk(endpoint, credential=credential)
    camera = RemoteStereoCamera(desk, clock=clock)
    camera.connect()
    try:
        camera.wait_ready(timeout)
    except Exception:
        camera.disconnect()
        raise
    return camera, RemoteBridge(desk, profile, clock=clock)
