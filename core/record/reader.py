"""Read a deskarm recording: a rosbag2 folder (MCAP storage, ROS 2 CDR) back into deskarm terms.

``open_recording(path)`` makes one pass over the recording and keeps what is small (session
info, calibration, joint states, ground truth, goals, e-stops, the time of every image pair);
the images themselves are read again on demand by ``Recording.pairs(start)``.

A whole recording is read with rosbags' ``AnyReader``. A recording that rosbags refuses (cut
short, written by a process killed with ``kill -9``: no summary, no footer, maybe no
``metadata.yaml``) is read with the ``mcap`` library's streaming reader up to the first broken
record; ``Recording.problem`` then says which file breaks where, and everything before replays.

Times: header stamps (the session clock's seconds at capture) for stamped messages, log times
for the others; ``Recording`` reports them in seconds since the first image pair (``t0_ns``).
"""
from __future__ import annotations

import bisect
import json
import math
import struct
import tempfile
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator, Optional

import numpy as np

from core.messages import GroundTruth, ObjectTruth

# the topic contract lives in core.record.topics (the recorder writes what this reads)
from core.record.topics import CAMERA_LEFT_IMAGE as LEFT_IMAGE  # noqa: E402
from core.record.topics import CAMERA_LEFT_INFO as LEFT_INFO  # noqa: E402
from core.record.topics import CAMERA_RIGHT_IMAGE as RIGHT_IMAGE  # noqa: E402
from core.record.topics import CAMERA_RIGHT_INFO as RIGHT_INFO  # noqa: E402
from core.record.topics import (  # noqa: E402
    ESTOP,
    GOAL,
    JOINTS_COMMANDED,
    JOINTS_MEASURED,
    MARKERS,
    SESSION,
    TF,
    TF_STATIC,
    TRUTH_MARKERS,
)
IMAGE_TOPICS = (LEFT_IMAGE, RIGHT_IMAGE)
# everything but the images: read once at open and kept
SMALL_TOPICS = (LEFT_INFO, RIGHT_INFO, JOINTS_COMMANDED, JOINTS_MEASURED, TF_STATIC, TF, MARKERS,
                TRUTH_MARKERS, GOAL, ESTOP, SESSION)

DEFAULT_FPS = 30.0  # when the session does not say
MAX_PENDING = 16  # unpaired images kept per side while pairing
NS = 1_000_000_000


class RecordingError(RuntimeError):
    """A recording cannot be opened or holds nothing to replay (the message names the path)."""


@dataclass(frozen=True)
class SessionInfo:
    """The /deskarm/session JSON of a recording."""

    deskarm_version: str = ""
    robot: str = ""
    camera: str = ""
    pair_id: str = ""
    scenario: str = ""
    fps: float = 0.0
    calibration_yaml: str = ""
    base_T_camera: Optional[np.ndarray] = None  # 4x4, camera_left in robot_base
    raw: dict = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class RecordBreak:
    """Where a recording stops being readable."""

    file: Path
    t_s: float  # time of the last readable message, s since the first image pair
    byte: int  # offset in ``file`` after the last whole record
    reason: str

    def message(self) -> str:
        return (f"{self.file}: unreadable after {self.t_s:.1f} s (byte {self.byte}): {self.reason}"
                f" — the part before replays")


@dataclass(frozen=True)
class RecordedJoints:
    """One /deskarm/joint_states/* message."""

    t_s: float  # header stamp, s since the first image pair
    names: tuple[str, ...]
    q: tuple[float, ...]  # rad (or m for prismatic joints)


@dataclass(frozen=True, eq=False)
class RecordedPair:
    """One left/right image pair as recorded (JPEG bytes), with the ground truth of its instant."""

    index: int  # position in Recording.pair_times_s
    t_s: float  # left capture time, s since the first image pair
    skew_s: float  # |t_left - t_right|
    left_jpeg: bytes
    right_jpeg: bytes
    truth: Optional[GroundTruth] = None


@dataclass(frozen=True)
class _Msg:
    topic: str
    log_ns: int
    msg: object


def _typestore():
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


@dataclass(frozen=True)
class _Stamp:
    """Only a message's header stamp: what the scan at open needs of an image (its JPEG is not copied)."""
    ns: int


_CDR_LE = b"\x00\x01"  # the encapsulation of a little-endian plain CDR message
_CDR_STAMP = struct.Struct("<iI")  # header.stamp (sec, nanosec), the first field after the 4-byte encapsulation


def _stamp_of_raw(raw: bytes, msgtype: str, typestore):
    """A ``_Stamp`` read from a serialised message whose first field is a std_msgs/Header (every
    image topic's), else the message deserialised in full."""
    if len(raw) >= 12 and raw[:2] == _CDR_LE:
        sec, nanosec = _CDR_STAMP.unpack_from(raw, 4)
        return _Stamp(int(sec) * NS + int(nanosec))
    return typestore.deserialize_cdr(bytes(raw), msgtype)


def _stamp_ns(msg) -> Optional[int]:
    if isinstance(msg, _Stamp):
        return msg.ns
    header = getattr(msg, "header", None)
    if header is None:
        return None
    return int(header.stamp.sec) * NS + int(header.stamp.nanosec)


def deskarm_version() -> str:
    """This deskarm's version (the installed package's), "" when unknown."""
    try:
        from importlib.metadata import version

        return version("deskarm")
    except Exception:  # noqa: BLE001 - not installed: unknown
        return ""


# ----------------------------------------------------------------------------------------------
# message sources: rosbags for whole recordings, mcap's streaming reader for broken ones


class _RosbagsSource:
    """Messages through rosbags' AnyReader (a complete rosbag2 folder)."""

    name = "rosbags"

    def __init__(self, folder: Path, typestore) -> None:
        from rosbags.highlevel import AnyReader

        self.folder = folder
        self.typestore = typestore
        self._factory = lambda: AnyReader([folder], default_typestore=typestore)
        with self._factory() as reader:  # refuses a truncated file here (no footer/summary)
            self.files = [Path(p) for p in getattr(reader, "paths", [folder])]

    def messages(self, topics, start_log_ns: Optional[int] = None, stamps_only=()) -> Iterator[_Msg]:
        """``topics``' messages in log order; those of ``stamps_only`` as their header stamp only."""
        with self._factory() as reader:
            conns = [c for c in reader.connections if c.topic in topics]
            if not conns:
                return
            for conn, log_ns, raw in reader.messages(connections=conns, start=start_log_ns):
                msg = (_stamp_of_raw(raw, conn.msgtype, self.typestore) if conn.topic in stamps_only
                       else reader.deserialize(raw, conn.msgtype))
                yield _Msg(conn.topic, int(log_ns), msg)


class _StreamSource:
    """Messages through mcap's StreamReader, up to the first broken record of each file."""

    name = "mcap stream"

    def __init__(self, files: list[Path], typestore) -> None:
        self.files = files
        self.typestore = typestore
        self.breaks: dict[Path, tuple[int, str]] = {}  # file -> (byte after the last whole record, reason)

    def messages(self, topics, start_log_ns: Optional[int] = None, stamps_only=()) -> Iterator[_Msg]:
        """As ``_RosbagsSource.messages``."""
        from mcap.records import Channel, Message, Schema
        from mcap.stream_reader import StreamReader

        for path in self.files:
            with open(path, "rb") as f:
                reader = StreamReader(f, record_size_limit=1 << 31)
                schemas: dict[int, str] = {}
                channels: dict[int, tuple[str, str]] = {}
                good = 0
                records = reader.records
                while True:
                    try:
                        record = next(records)
                    except StopIteration:
                        break
                    except Exception as exc:  # noqa: BLE001 - a cut or corrupt tail, any parser error
                        reason = str(exc).strip() or type(exc).__name__
                        if type(exc).__name__ == "EndOfFile":
                            reason = "the file ends inside a record (cut short, or the recorder was killed)"
                        self.breaks.setdefault(path, (good, reason))
                        break
                    good = reader._stream.count  # after the last whole (outer) record
                    if isinstance(record, Schema):
                        schemas[record.id] = record.name
                    elif isinstance(record, Channel):
                        channels[record.id] = (record.topic, schemas.get(record.schema_id, ""))
                    elif isinstance(record, Message):
                        topic, msgtype = channels.get(record.channel_id, ("", ""))
                        if topic not in topics or (start_log_ns is not None and record.log_time < start_log_ns):
                            continue
                        try:
                            msg = (_stamp_of_raw(record.data, msgtype, self.typestore) if topic in stamps_only
                                   else self.typestore.deserialize_cdr(bytes(record.data), msgtype))
                        except Exception:  # noqa: BLE001 - one undecodable message is skipped
                            continue
                        yield _Msg(topic, int(record.log_time), msg)


def _mcap_files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.is_file() and p.suffix == ".mcap")


# ----------------------------------------------------------------------------------------------
# pairing and ground truth


class _Pairer:
    """Left/right images paired by header stamp: the other side's closest within ``tol_ns``.
    Unpaired images older than a pair are dropped."""

    def __init__(self, tol_ns: int) -> None:
        self.tol_ns = tol_ns
        self.pending = {LEFT_IMAGE: deque(maxlen=MAX_PENDING), RIGHT_IMAGE: deque(maxlen=MAX_PENDING)}

    def feed(self, topic: str, stamp_ns: int, log_ns: int, payload=None):
        """((left stamp, log, payload), (right stamp, log, payload)) when ``stamp_ns`` completes a pair."""
        other = RIGHT_IMAGE if topic == LEFT_IMAGE else LEFT_IMAGE
        cands = self.pending[other]
        best = min(cands, key=lambda e: abs(e[0] - stamp_ns), default=None)
        if best is None or abs(best[0] - stamp_ns) > self.tol_ns:
            self.pending[topic].append((stamp_ns, log_ns, payload))
            return None
        for side in (topic, other):
            keep = [e for e in self.pending[side] if e[0] > max(best[0], stamp_ns) and e is not best]
            self.pending[side].clear()
            self.pending[side].extend(keep)
        mine = (stamp_ns, log_ns, payload)
        return (mine, best) if topic == LEFT_IMAGE else (best, mine)


def _truth_of(msg, calibration, base_T_camera) -> GroundTruth:
    """A GroundTruth from a /deskarm/truth/markers MarkerArray.

    Visibility is read from the namespace when it says ("…hidden", "…left_only", "…right_only");
    otherwise a marker counts as visible in a view when its centre, with half its size around it,
    projects inside that image (known from the recorded calibration; without one: visible)."""
    objects = []
    for m in msg.markers:
        if int(getattr(m, "action", 0)) not in (0,):  # ADD/MODIFY only
            continue
        p = (float(m.pose.position.x), float(m.pose.position.y), float(m.pose.position.z))
        ns = str(m.ns).lower()
        if "hidden" in ns:
            vis = (False, False)
        elif "left_only" in ns:
            vis = (True, False)
        elif "right_only" in ns:
            vis = (False, True)
        else:
            vis = _projected_visibility(p, float(m.scale.x), calibration, base_T_camera)
        objects.append(ObjectTruth(int(m.id), p, vis[0], vis[1], str(m.text)))
    return GroundTruth(tuple(objects))


def _projected_visibility(base_p, size_m, calibration, base_T_camera) -> tuple[bool, bool]:
    if calibration is None or base_T_camera is None:
        return True, True
    import cv2

    camera_T_base = np.linalg.inv(base_T_camera)
    left_p = camera_T_base[:3, :3] @ np.asarray(base_p) + camera_T_base[:3, 3]  # in camera_left
    right_p = calibration.R @ left_p + calibration.T.reshape(3)  # in camera_right
    w, h = calibration.image_size
    out = []
    for p, M, D in ((left_p, calibration.M1, calibration.D1), (right_p, calibration.M2, calibration.D2)):
        if p[2] <= 1e-6:
            out.append(False)
            continue
        px, _ = cv2.projectPoints(p.reshape(1, 1, 3), np.zeros(3), np.zeros(3), M, D)
        u, v = px.reshape(2)
        margin = float(M[0, 0]) * max(size_m, 0.0) * 0.71 / p[2]  # half the diagonal
        out.append(bool(margin <= u <= w - 1 - margin and margin <= v <= h - 1 - margin))
    return out[0], out[1]


def _calibration_from_yaml(text: str):
    """A StereoCalibration from deskarm's calibration YAML text (through the file loader)."""
    from core.vision.calibration import load_calibration

    with tempfile.TemporaryDirectory(prefix="deskarm-replay-") as tmp:
        path = Path(tmp) / "recorded_calibration.yaml"
        path.write_text(text, encoding="utf-8")
        return load_calibration(path)


# ----------------------------------------------------------------------------------------------
# the recording


class Recording:
    """One opened recording (see ``open_recording``)."""

    def __init__(self, folder: Path, source, typestore) -> None:
        self.folder = folder
        self.path = folder
        self._source = source
        self._typestore = typestore
        self.session = SessionInfo()
        self.calibration = None  # StereoCalibration recorded in the session info, or None
        self.base_T_camera: Optional[np.ndarray] = None  # 4x4 camera_left in robot_base
        self.warnings: list[str] = []
        self.problem: Optional[RecordBreak] = None
        self.topics: dict[str, int] = {}  # topic -> messages read
        self.t0_ns = 0  # stamp of the first image pair (the zero of every t_s)
        self.start_log_ns = 0
        self.end_log_ns = 0
        self.pair_times_s: list[float] = []  # left stamp of every image pair, s since t0
        self._pair_log_ns: list[int] = []  # earliest log time of each pair's two messages
        self._pair_stamps: list[int] = []
        self.joints: dict[str, list[RecordedJoints]] = {"commanded": [], "measured": []}
        self.goals: list[tuple[float, tuple[float, float, float]]] = []  # (t_s, base_p_target)
        self.estops: list[tuple[float, bool]] = []  # (t_s by log time, engaged)
        self.markers: list[tuple[float, dict[int, tuple[float, float, float]]]] = []  # perceived, robot_base
        self._truth_stamps: list[int] = []
        self._truths: list = []  # GroundTruth, or the recorded message until it is first asked for
        self._truth_msgs: list[tuple[int, object]] = []
        self._scan()

    # -- the one pass at open ---------------------------------------------------------------
    def _scan(self) -> None:
        fps = DEFAULT_FPS
        pairer = None
        image_stamps = []  # (topic, stamp, log) until the session info gives the fps
        small: list[_Msg] = []
        logs = []
        last_log = None
        try:
            for m in self._source.messages(set(SMALL_TOPICS) | set(IMAGE_TOPICS), stamps_only=set(IMAGE_TOPICS)):
                last_log = m.log_ns
                logs.append(m.log_ns)
                self.topics[m.topic] = self.topics.get(m.topic, 0) + 1
                if m.topic in IMAGE_TOPICS:
                    image_stamps.append((m.topic, _stamp_ns(m.msg), m.log_ns))
                else:
                    if m.topic == SESSION and not self.session.raw:
                        self._read_session(m.msg)
                        fps = self.session.fps or DEFAULT_FPS
                    small.append(m)
        except Exception as exc:  # noqa: BLE001 - rosbags failing mid-file: keep what was read
            files = getattr(self._source, "files", [self.folder])
            self.problem = RecordBreak(Path(files[-1]) if files else self.folder, 0.0, -1,
                                       str(exc).strip() or type(exc).__name__)
        pairer = _Pairer(int(0.5 * NS / fps))
        for topic, stamp, log in image_stamps:
            pair = pairer.feed(topic, stamp, log)
            if pair is not None:
                (ls, ll, _), (rs, rl, _) = pair
                self._pair_stamps.append(ls)
                self._pair_log_ns.append(min(ll, rl))
        self.start_log_ns = min(logs) if logs else 0
        self.end_log_ns = max(logs) if logs else 0
        self.t0_ns = self._pair_stamps[0] if self._pair_stamps else 0
        self.pair_times_s = [(s - self.t0_ns) / NS for s in self._pair_stamps]
        self._pair_log0 = self._pair_log_ns[0] if self._pair_log_ns else self.start_log_ns
        for m in small:
            self._keep(m)
        # sorted once, after the scan (sorting after every message made opening quadratic: a
        # 45 s recording took 7 s to open), with each kind's times kept for joints_at's bisect
        for rows in self.joints.values():
            rows.sort(key=lambda r: r.t_s)
        self._joint_times = {kind: [r.t_s for r in rows] for kind, rows in self.joints.items()}
        for stamp, msg in self._truth_msgs:
            self._truth_stamps.append(stamp)
            self._truths.append(msg)  # made into a GroundTruth when asked for (truth_at): 0.5 ms each
        order = np.argsort(self._truth_stamps, kind="stable")
        self._truth_stamps = [self._truth_stamps[i] for i in order]
        self._truths = [self._truths[i] for i in order]
        self._fps = fps
        breaks = getattr(self._source, "breaks", {})
        if breaks:
            path, (byte, reason) = next(iter(breaks.items()))
            t_s = ((last_log if last_log is not None else self.start_log_ns) - self._pair_log0) / NS
            self.problem = RecordBreak(path, max(0.0, t_s), byte, reason)
        elif self.problem is not None and last_log is not None:
            self.problem = RecordBreak(self.problem.file, max(0.0, (last_log - self._pair_log0) / NS),
                                       self.problem.byte, self.problem.reason)
        if self.problem is not None:
            self.warnings.insert(0, self.problem.message())
        if not self.session.raw:
            self.warnings.append(f"{self.folder}: no /deskarm/session message — the recorded calibration and "
                                 "camera pose are unknown")

    def _read_session(self, msg) -> None:
        try:
            raw = json.loads(msg.data)
            if not isinstance(raw, dict):
                raise ValueError("not a JSON object")
        except ValueError as exc:
            self.warnings.append(f"{self.folder}: /deskarm/session is not valid JSON ({exc})")
            return
        base_T = raw.get("base_T_camera")
        try:
            base_T = None if base_T is None else np.asarray(base_T, dtype=np.float64).reshape(4, 4)
        except ValueError:
            self.warnings.append(f"{self.folder}: /deskarm/session base_T_camera is not a 4x4 matrix — ignored")
            base_T = None
        try:
            fps = float(raw.get("fps") or 0.0)
        except (TypeError, ValueError):
            fps = 0.0
        self.session = SessionInfo(
            deskarm_version=str(raw.get("deskarm_version", "")), robot=str(raw.get("robot", "")),
            camera=str(raw.get("camera", "")), pair_id=str(raw.get("pair_id", "")),
            scenario=str(raw.get("scenario", "")), fps=fps if math.isfinite(fps) and fps > 0 else 0.0,
            calibration_yaml=str(raw.get("calibration_yaml", "") or ""), base_T_camera=base_T, raw=raw)
        self.base_T_camera = base_T
        if self.session.calibration_yaml:
            from core.vision.calibration import CalibrationError

            try:
                self.calibration = _calibration_from_yaml(self.session.calibration_yaml)
            except CalibrationError as exc:
                reason = str(exc).split(": ", 1)[-1]
                self.warnings.append(f"{self.folder}: the recorded calibration is unusable ({reason})")

    def _rel_s(self, stamp_ns: int) -> float:
        return (stamp_ns - self.t0_ns) / NS

    def _log_rel_s(self, log_ns: int) -> float:
        return (log_ns - self._pair_log0) / NS

    def _keep(self, m: _Msg) -> None:
        msg = m.msg
        if m.topic == TRUTH_MARKERS:
            stamps = [_stamp_ns(x) for x in msg.markers]
            self._truth_msgs.append((stamps[0] if stamps else m.log_ns - self._pair_log0 + self.t0_ns, msg))
        elif m.topic in (JOINTS_COMMANDED, JOINTS_MEASURED):
            key = "commanded" if m.topic == JOINTS_COMMANDED else "measured"
            self.joints[key].append(RecordedJoints(self._rel_s(_stamp_ns(msg)), tuple(str(n) for n in msg.name),
                                                   tuple(float(v) for v in msg.position)))
        elif m.topic == GOAL:
            self.goals.append((self._rel_s(_stamp_ns(msg)), (float(msg.point.x), float(msg.point.y),
                                                             float(msg.point.z))))
        elif m.topic == ESTOP:
            self.estops.append((self._log_rel_s(m.log_ns), bool(msg.data)))
        elif m.topic == MARKERS:
            stamps = [_stamp_ns(x) for x in msg.markers]
            t_s = self._rel_s(stamps[0]) if stamps else self._log_rel_s(m.log_ns)
            self.markers.append((t_s, {int(x.id): (float(x.pose.position.x), float(x.pose.position.y),
                                                   float(x.pose.position.z)) for x in msg.markers}))
        if m.topic == TF_STATIC and self.base_T_camera is None:
            for tr in msg.transforms:
                if tr.child_frame_id == "camera_left":
                    self.base_T_camera = _matrix_of(tr.transform)

    # -- what a caller asks ---------------------------------------------------------------------
    @property
    def duration_s(self) -> float:
        """From the first to the last message (log times)."""
        return max(0.0, (self.end_log_ns - self.start_log_ns) / NS)

    @property
    def frame_period_s(self) -> float:
        """The recorded frame period: the median gap between image pairs (else 1/fps)."""
        if len(self.pair_times_s) >= 2:
            return float(np.median(np.diff(self.pair_times_s)))
        return 1.0 / self._fps

    @property
    def frames_s(self) -> float:
        """From the first image pair to one period after the last."""
        return self.pair_times_s[-1] + self.frame_period_s if self.pair_times_s else 0.0

    def truth_at(self, t_s: float) -> Optional[GroundTruth]:
        """The ground truth recorded for the instant ``t_s`` (within half a frame period), else None."""
        if not self._truth_stamps:
            return None
        stamp = self.t0_ns + int(round(t_s * NS))
        i = bisect.bisect_left(self._truth_stamps, stamp)
        best = min((j for j in (i - 1, i) if 0 <= j < len(self._truth_stamps)),
                   key=lambda j: abs(self._truth_stamps[j] - stamp))
        if abs(self._truth_stamps[best] - stamp) > 0.5 * self.frame_period_s * NS:
            return None
        truth = self._truths[best]
        if not isinstance(truth, GroundTruth):
            truth = self._truths[best] = _truth_of(truth, self.calibration, self.base_T_camera)
        return truth

    def joints_at(self, t_s: float, kind: str = "measured") -> Optional[RecordedJoints]:
        """The last ``kind`` (measured | commanded) joint state at or before ``t_s``, else None."""
        rows = self.joints[kind]
        i = bisect.bisect_right(self._joint_times[kind], t_s + 1e-9)
        return rows[i - 1] if i else None

    def index_at(self, t_s: float) -> int:
        """The first image pair at or after ``t_s`` (clamped to the last)."""
        if not self.pair_times_s:
            return 0
        i = bisect.bisect_left(self.pair_times_s, t_s - 1e-9)
        return min(i, len(self.pair_times_s) - 1)

    def pairs(self, start: int = 0) -> Iterator[RecordedPair]:
        """The image pairs from index ``start`` on, in order (JPEG bytes, ground truth attached)."""
        if start >= len(self._pair_stamps):
            return
        first_stamp = self._pair_stamps[start]
        pairer = _Pairer(int(0.5 * NS / self._fps))
        index = {s: i for i, s in enumerate(self._pair_stamps)}
        # a little before the pair: its partner may have been logged earlier
        start_log = self._pair_log_ns[start] - int(NS / self._fps) if start > 0 else None
        for m in self._source.messages(set(IMAGE_TOPICS), start_log):
            pair = pairer.feed(m.topic, _stamp_ns(m.msg), m.log_ns, bytes(m.msg.data))
            if pair is None:
                continue
            (ls, _, left), (rs, _, right) = pair
            if ls < first_stamp or ls not in index:
                continue
            t_s = self._rel_s(ls)
            yield RecordedPair(index[ls], t_s, abs(ls - rs) / NS, left, right, self.truth_at(t_s))

    def compatibility_warnings(self, robot: Optional[str] = None, version: Optional[str] = None) -> list[str]:
        """Warnings (never raised) when the recording comes from another robot profile or another
        deskarm version than the running one (``version`` defaults to the installed one)."""
        out = []
        version = deskarm_version() if version is None else version
        rec = self.session
        if robot and rec.robot and rec.robot != robot:
            out.append(f"{self.folder}: recorded with robot profile {rec.robot!r}, this session uses {robot!r} — "
                       f"the recomputed commands are for {robot!r} (start with --robot {rec.robot} to compare)")
        if version and rec.deskarm_version and rec.deskarm_version != version:
            out.append(f"{self.folder}: recorded by deskarm {rec.deskarm_version}, this is deskarm {version} — "
                       "results may differ")
        return out

    def summary(self) -> str:
        """One line: folder, duration, pairs, topics."""
        return (f"{self.folder}: {self.frames_s:.1f} s, {len(self.pair_times_s)} image pairs, "
                f"{len(self.topics)} topics" + (" (cut short)" if self.problem else ""))


def _matrix_of(transform) -> np.ndarray:
    """4x4 of a geometry_msgs/Transform."""
    x, y, z, w = (transform.rotation.x, transform.rotation.y, transform.rotation.z, transform.rotation.w)
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    out = np.eye(4)
    out[:3, :3] = R
    out[:3, 3] = (transform.translation.x, transform.translation.y, transform.translation.z)
    return out


def open_recording(path, robot: Optional[str] = None) -> Recording:
    """Open a recording folder (or its .mcap file); RecordingError naming the path when impossible.

    A cut or corrupt .mcap is read up to where it breaks: ``Recording.problem`` and the first of
    ``Recording.warnings`` say where. With ``robot``, a recording of another robot profile or
    deskarm version adds a warning.
    """
    path = Path(path).expanduser()
    if not path.exists():
        raise RecordingError(f"{path}: no such recording — expected a recording folder "
                             "(metadata.yaml and a .mcap file) or a .mcap file")
    folder = path if path.is_dir() else path.parent
    files = _mcap_files(folder) if path.is_dir() else [path]
    if not files:
        raise RecordingError(f"{path}: not a recording — no .mcap file in it (a rosbag2 folder with "
                             "MCAP storage is expected)")
    typestore = _typestore()
    source = None
    if path.is_dir() and (folder / "metadata.yaml").is_file():
        try:
            source = _RosbagsSource(folder, typestore)
        except Exception:  # noqa: BLE001 - rosbags refuses (no footer, no summary, provisional metadata)
            source = None
    if source is None:
        for f in files:
            try:
                with open(f, "rb") as fh:
                    magic = fh.read(8)
            except OSError as exc:
                raise RecordingError(f"{f}: cannot read ({exc.strerror})") from None
            if magic != b"\x89MCAP0\r\n":
                raise RecordingError(f"{f}: not an MCAP file (bad magic bytes)")
        source = _StreamSource(files, typestore)
    rec = Recording(folder, source, typestore)
    if not rec.pair_times_s:
        detail = f" ({rec.problem.message()})" if rec.problem else ""
        raise RecordingError(f"{path}: no readable image pairs on {LEFT_IMAGE} and {RIGHT_IMAGE}{detail}")
    if robot is not None:
        rec.warnings.extend(rec.compatibility_warnings(robot))
    return rec


__all__ = ["open_recording", "Recording", "RecordingError", "RecordBreak", "RecordedPair", "RecordedJoints",
           "SessionInfo", "deskarm_version"]
