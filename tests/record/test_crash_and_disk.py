"""A recording survives its process being killed (readable up to the last chunk), and a disk
that fails stops the recording with a message naming the path while the loop goes on."""
from __future__ import annotations

import errno
import io
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from collections import Counter
from pathlib import Path

import pytest
from ruamel.yaml import YAML

from core.record import TOPICS
from core.record.recorder import list_recordings
from core.record.writer import read_truncated

ROOT = Path(__file__).resolve().parents[2]

RECORD_FOREVER = textwrap.dedent("""
    import sys, time
    import numpy as np
    from core.messages import JointState, StereoFrame
    from core.record.recorder import Recorder

    info = {"deskarm_version": "test", "robot": "desk_rrr", "camera": "noise", "pair_id": "p",
            "calibration_yaml": "", "base_T_camera": np.eye(4).tolist(), "scenario": "static", "fps": 30.0}
    rec = Recorder(sys.argv[1], info, queue_size=8).start()
    rng = np.random.default_rng(0)
    images = [rng.integers(0, 255, (240, 320, 3), dtype=np.uint8) for _ in range(4)]
    seq = 0
    while True:  # until killed
        seq += 1
        rec.frame(StereoFrame(seq=seq, t=seq / 30, left=images[seq % 4], right=images[(seq + 1) % 4]))
        rec.state(JointState(seq=seq, t=seq / 30, q=(0.1, 0.2, 0.3)))
        time.sleep(0.005)
""")


def wait_for(condition, timeout_s: float, what: str) -> None:
    """Poll ``condition`` (a file growing: there is no event to wait on across processes)."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(0.02)


def test_a_recording_killed_mid_way_is_readable_up_to_its_last_chunk(tmp_path):
    bag = tmp_path / "killed"
    mcap = bag / "killed.mcap"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-c", RECORD_FOREVER, str(bag)], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        # several 1 MiB chunks on disk, and the process still writing the next one
        wait_for(lambda: mcap.is_file() and mcap.stat().st_size > 3 * 2**20 or proc.poll() is not None,
                 30, "the recording to pass 3 MiB")
        assert proc.poll() is None, proc.stderr.read().decode()
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)
    assert proc.returncode == -signal.SIGKILL

    # metadata.yaml was written at start: a rosbag2 folder, marked as still recording
    meta = YAML(typ="safe").load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["custom_data"]["deskarm_state"] == "recording" and meta["storage_identifier"] == "mcap"
    assert {t["topic_metadata"]["name"] for t in meta["topics_with_message_count"]} == set(TOPICS)
    with pytest.raises(Exception):  # no summary/footer: a seeking reader cannot open it …
        from mcap.reader import SeekingReader

        with open(mcap, "rb") as f:
            list(SeekingReader(f).iter_messages())

    # … the independent non-seeking reader decodes every message up to the cut
    from mcap.reader import NonSeekingReader
    from mcap_ros2.decoder import DecoderFactory

    decoded = Counter()
    stamps = []
    with open(mcap, "rb") as f:
        reader = NonSeekingReader(f, decoder_factories=[DecoderFactory()])
        try:
            for schema, channel, message, ros_msg in reader.iter_decoded_messages(log_time_order=False):
                decoded[channel.topic] += 1
                if channel.topic == "/deskarm/camera/left/image/compressed":
                    assert ros_msg.format == "jpeg" and bytes(ros_msg.data[:2]) == b"\xff\xd8"
                    stamps.append(ros_msg.header.stamp.sec * 10**9 + ros_msg.header.stamp.nanosec)
        except Exception as exc:  # the record the kill cut short
            cut = exc
        else:
            cut = None
    images = decoded["/deskarm/camera/left/image/compressed"]
    assert images >= 10, decoded
    assert abs(decoded["/deskarm/camera/right/image/compressed"] - images) <= 1
    assert decoded["/deskarm/session"] == 1 and decoded["/deskarm/estop"] == 1
    assert stamps == sorted(stamps) and len(set(stamps)) == len(stamps)
    # deskarm's own tolerant reader gives the same messages and stops quietly at the cut
    ours = Counter(topic for topic, *_ in read_truncated(mcap))
    assert ours == decoded, (ours, decoded, cut)
    # the recording is listed, marked incomplete
    (info,) = list_recordings(tmp_path)
    assert info.path == bag and not info.complete and info.size_bytes > 3 * 2**20


def test_a_full_disk_stops_the_recording_with_a_message_and_the_loop_goes_on(tmp_path, monkeypatch):
    from app.headless import run_headless
    from core.record import writer
    from core.session import SessionOptions

    write = writer.BagWriter.write
    calls = {"n": 0}

    def fills_up(self, topic, t_ns, msg):
        calls["n"] += 1
        if calls["n"] > 200:  # the disk fills after a while
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return write(self, topic, t_ns, msg)

    monkeypatch.setattr(writer.BagWriter, "write", fills_up)
    path = tmp_path / "full"
    out = io.StringIO()
    code = run_headless(SessionOptions(camera="sim", simulated_clock=True), 3.0, True, out=out, record=str(path))
    assert code == 0
    summary = json.loads(out.getvalue().strip().splitlines()[-1])
    error = summary["record_error"]
    assert error and str(path) in error and "no space left on device" in error.lower(), error
    assert f"deskarm: {error}" in out.getvalue()  # said on its own line too
    assert summary["frames"] >= 80  # 3 s at 30 fps: the loop ran to the end
    assert 0 < summary["frames_recorded"] < summary["frames"]
    assert summary["duration_s"] == pytest.approx(3.0, abs=0.1)
    # what was written before the disk filled is readable
    written = Counter(topic for topic, *_ in read_truncated(path / "full.mcap"))
    assert written["/deskarm/session"] == 1 and written["/deskarm/camera/left/image/compressed"] >= 1


def test_a_recorder_that_cannot_create_its_folder_says_which_and_why(tmp_path):
    from core.record.recorder import Recorder

    blocked = tmp_path / "file"
    blocked.write_text("not a folder")
    info = {"deskarm_version": "t", "robot": "r", "camera": "c", "pair_id": "p", "calibration_yaml": "",
            "base_T_camera": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "scenario": "s", "fps": 1.0}
    with pytest.raises(OSError, match=str(blocked / "rec")):
        Recorder(blocked / "rec", info).start()
