"""The rosbag2 folder a recording writes: rosbags' MCAP writer, made safe against a killed process.

rosbags' ``Writer`` writes ``metadata.yaml`` and the MCAP summary/footer only at ``close()``,
and flushes a chunk once it exceeds 1 MiB. A process killed with ``kill -9`` would then leave
no ``metadata.yaml`` and an unfinished chunk in memory. ``BagWriter`` therefore

- registers every topic of ``TOPICS`` at open, so the schemas and channels sit in the first
  chunk (a reader of a truncated file meets them before any message);
- writes a provisional ``metadata.yaml`` at open (``custom_data.deskarm_state: recording``,
  message counts 0), replaced by rosbags' own at close (``deskarm_state: complete``);
- closes the pending chunk and flushes the file at least every ``flush_s`` seconds of wall time
  and every ``flush_s`` seconds of recorded time (a ``--fast`` run records faster than the wall
  clock), and at 1 MiB (rosbags' own limit). A kill then loses what the pending chunk held — at
  most ``flush_s`` plus the gap to the next message — and what the recorder's queue still held
  (normally a frame or two). Measured: ``kill -9`` of a real-time ``deskarm --headless --record``
  at random moments lost 0.005–0.49 s of recorded time in 28 runs at 10 and 30 fps, idle or with
  both cores busy (tests/record/test_kill_recording.py); with the former 1 s flush up to 1.19 s.

What a reader must do with a recording whose ``deskarm_state`` is still ``recording``: read the
``.mcap`` with a non-seeking reader (``mcap.reader.NonSeekingReader`` / ``mcap.stream_reader.
StreamReader``) and stop at the first incomplete record (``EndOfFile`` or a struct/length error
at the tail) — every message before it is whole. ``read_truncated`` below does exactly that.
"""
from __future__ import annotations

import os
import time
from io import StringIO
from pathlib import Path
from typing import Iterator, Optional

from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.rosbag2.metadata import dump_qos_v9

from core.record.topics import TOPICS, TRANSIENT_LOCAL_TOPICS, TYPESTORE, serialize

ROSBAG_VERSION = 9
FLUSH_S = 0.5  # a killed recording loses about this much at most (plus the gap to the next message)
STATE_RECORDING = "recording"
STATE_COMPLETE = "complete"


def _qos(transient_local: bool) -> Qos:
    zero = QosTime(0, 0)
    return Qos(QosHistory.KEEP_LAST, 1 if transient_local else 10, QosReliability.RELIABLE,
               QosDurability.TRANSIENT_LOCAL if transient_local else QosDurability.VOLATILE,
               zero, zero, QosLiveliness.AUTOMATIC, zero, False)


def _compress_chunks(writer: Writer) -> None:
    """zstd on each MCAP chunk (every MCAP reader decodes it): a still scene's repeated JPEG bytes
    (core.record.recorder) take a few bytes after their first copy in a chunk; JPEGs themselves
    barely shrink. A rosbags without storage compression writes uncompressed chunks."""
    try:
        from rosbags.rosbag2 import CompressionFormat, CompressionMode

        writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    except (ImportError, AttributeError):  # pragma: no cover - older rosbags
        pass


class BagWriter:
    """One rosbag2 folder (MCAP storage) with the recording's topics; not thread-safe (one writer thread).

    ``write`` returns the bytes the message took; OSErrors (disk full, folder gone) propagate.
    """

    def __init__(self, path: str | os.PathLike, custom_data: Optional[dict[str, str]] = None,
                 flush_s: float = FLUSH_S, compress: bool = True) -> None:
        self.path = Path(path)
        self.compress = bool(compress)  # zstd on each chunk (``_compress_chunks``)
        self.flush_s = float(flush_s)
        self.custom_data = {str(k): str(v) for k, v in (custom_data or {}).items()}
        self._writer: Optional[Writer] = None
        self._connections: dict = {}
        self._last_flush = time.monotonic()
        self._unflushed_from_ns: Optional[int] = None  # recorded time of the oldest message not yet flushed
        self.bytes_written = 0  # serialized message bytes (the .mcap adds ~1 % of records and indexes)

    @property
    def mcap_path(self) -> Path:
        return self.path / f"{self.path.name}.mcap"

    @property
    def file_bytes(self) -> int:
        """The .mcap's size on disk now (compressed chunks flushed so far; 0 before the first)."""
        try:
            return self.mcap_path.stat().st_size
        except OSError:
            return 0

    def open(self) -> None:
        """Create the folder, register every topic, write the provisional metadata.yaml."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        writer = Writer(self.path, version=ROSBAG_VERSION, storage_plugin=StoragePlugin.MCAP)
        if self.compress:
            _compress_chunks(writer)
        writer.open()
        self._writer = writer
        for key, value in self.custom_data.items():
            writer.set_custom_data(key, value)
        writer.set_custom_data("deskarm_state", STATE_RECORDING)
        for topic, msgtype in TOPICS.items():
            self._connections[topic] = writer.add_connection(
                topic, msgtype, typestore=TYPESTORE,
                offered_qos_profiles=[_qos(topic in TRANSIENT_LOCAL_TOPICS)])
        self._write_provisional_metadata()

    def write(self, topic: str, t_ns: int, msg) -> int:
        """Serialize ``msg`` (CDR) onto ``topic`` with log time ``t_ns``; returns its byte count."""
        data = serialize(msg)
        self._writer.write(self._connections[topic], int(t_ns), data)
        self.bytes_written += len(data)
        if self._unflushed_from_ns is None:
            self._unflushed_from_ns = int(t_ns)
        if (time.monotonic() - self._last_flush >= self.flush_s
                or int(t_ns) - self._unflushed_from_ns >= self.flush_s * 1e9):
            self._flush()
        return len(data)

    def _storage(self):
        return getattr(self._writer, "storage", None) if self._writer is not None else None

    def _flush(self) -> None:
        """Close rosbags' pending chunk and push the file to the OS: readable after a kill."""
        storage = self._storage()
        self._last_flush = time.monotonic()
        self._unflushed_from_ns = None
        if storage is None:
            return
        chunk = getattr(storage, "chunk", None)
        # rosbags' McapWriter internals (0.10/0.11): a pending chunk in memory, the file in ``bio``.
        # A chunk without messages stays pending: its schemas and channels go with the first ones.
        if chunk is not None and hasattr(storage, "close_chunk") and chunk.msgs:
            storage.close_chunk()
        bio = getattr(storage, "bio", None)
        if bio is not None:
            bio.flush()

    def close(self) -> None:
        """Finish the MCAP (summary, footer) and write the final metadata.yaml."""
        writer, self._writer = self._writer, None
        if writer is None:
            return
        writer.set_custom_data("deskarm_state", STATE_COMPLETE)
        writer.close()

    def abort(self) -> None:
        """Stop without finishing (after an error): the file stays readable up to its last chunk."""
        writer, self._writer = self._writer, None
        if writer is not None:
            try:
                writer.abort()
            except OSError:  # the disk that failed may refuse the close too
                pass

    def _write_provisional_metadata(self) -> None:
        """metadata.yaml as rosbags would write it for an empty bag, marked ``recording``."""
        from ruamel.yaml import YAML

        w = self._writer
        info = {
            "version": ROSBAG_VERSION,
            "storage_identifier": "mcap",
            "relative_file_paths": [self.mcap_path.name],
            "duration": {"nanoseconds": 0},
            "starting_time": {"nanoseconds_since_epoch": 0},
            "message_count": 0,
            "topics_with_message_count": [
                {"topic_metadata": {"name": c.topic, "type": c.msgtype, "serialization_format": "cdr",
                                    "offered_qos_profiles": dump_qos_v9(c.ext.offered_qos_profiles),
                                    "type_description_hash": c.digest},
                 "message_count": 0}
                for c in w.connections],
            "compression_format": "",
            "compression_mode": "",
            "files": [{"path": self.mcap_path.name, "starting_time": {"nanoseconds_since_epoch": 0},
                       "duration": {"nanoseconds": 0}, "message_count": 0}],
            "custom_data": dict(w.custom_data),
            "ros_distro": "rosbags",
        }
        yaml = YAML(typ="safe")
        yaml.default_flow_style = False
        text = StringIO()
        yaml.dump({"rosbag2_bagfile_information": info}, text)
        tmp = self.path / "metadata.yaml.tmp"
        tmp.write_text(text.getvalue(), "utf-8")
        tmp.replace(self.path / "metadata.yaml")


def read_truncated(mcap_path: str | os.PathLike) -> Iterator[tuple[str, str, int, bytes]]:
    """(topic, schema name, log time ns, CDR data) of every whole message of an MCAP file,
    finished or cut short by a killed recorder (stops quietly at the first incomplete record)."""
    import struct

    from mcap.exceptions import McapError
    from mcap.records import Channel, Chunk, Message, Schema
    from mcap.stream_reader import StreamReader, breakup_chunk

    schemas: dict[int, str] = {}
    channels: dict[int, tuple[str, int]] = {}
    with open(mcap_path, "rb") as f:
        try:
            for record in StreamReader(f, skip_magic=False, emit_chunks=True).records:
                inner = breakup_chunk(record) if isinstance(record, Chunk) else [record]
                for r in inner:
                    if isinstance(r, Schema):
                        schemas[r.id] = r.name
                    elif isinstance(r, Channel):
                        channels[r.id] = (r.topic, r.schema_id)
                    elif isinstance(r, Message) and r.channel_id in channels:
                        topic, schema_id = channels[r.channel_id]
                        yield topic, schemas.get(schema_id, ""), r.log_time, r.data
        except (McapError, EOFError, struct.error, ValueError):
            return  # the tail a kill left: every message before it was whole
