"""Replay: a recording of the simulated desk played back as a camera scores like the live run;
cut, killed and missing recordings say what is wrong and replay what is readable."""
import io
import json
import os
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from app.headless import run_headless
from core.clock import SimClock, WallClock
from core.record.reader import RecordingError, open_recording
from core.record.replay import ReplayStereoCamera
from core.session import DeskSession, SessionOptions
from core.vision.cameras import CameraError, open_camera, parse_camera_spec
from make_recording import make_recording

ROOT = Path(__file__).resolve().parents[2]
SECONDS = 3.0
FPS = 15.0


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """3 s of the wandering desk at 15 fps, JPEG quality 95, and what its frames gave live."""
    return make_recording(tmp_path_factory.mktemp("rec") / "wander", seconds=SECONDS, fps=FPS, quality=95)


def cut_copy(src: Path, dst: Path, keep: float = 0.5, metadata: bool = True) -> Path:
    """A copy of the recording whose .mcap keeps only its first ``keep`` of bytes."""
    shutil.copytree(src, dst)
    mcap = next(dst.glob("*.mcap"))
    with open(mcap, "r+b") as f:
        f.truncate(int(os.path.getsize(mcap) * keep))
    if not metadata:  # as a recorder killed with kill -9 before writing it leaves the folder
        (dst / "metadata.yaml").unlink()
    return mcap


def replay_all(cam) -> list:
    frames = []
    while (frame := cam.read()) is not None:
        frames.append(frame)
    return frames


def check_close(actual, expected, tol, what):
    assert abs(actual - expected) <= tol, f"{what}: replay {actual} vs live {expected} (tolerance {tol})"


# ----------------------------------------------------------------------------------------------
# reading


def test_the_reader_finds_session_calibration_pairs_truth_and_joint_states(recording):
    rec = open_recording(recording.path)
    assert rec.warnings == [] and rec.problem is None
    assert len(rec.pair_times_s) == recording.frames
    assert np.allclose(np.array(rec.pair_times_s) + recording.frame_times[0], recording.frame_times)
    assert rec.session.robot == "desk_rrr" and rec.session.scenario == "wander" and rec.session.fps == FPS
    assert rec.calibration is not None and rec.calibration.image_size == (640, 480)
    assert rec.base_T_camera.shape == (4, 4)
    assert rec.topics["/deskarm/camera/left/image/compressed"] == recording.frames
    truth = rec.truth_at(rec.pair_times_s[5])
    assert {o.marker_id for o in truth.objects} >= {23, 50}
    t, q = recording.measured_q[10]
    assert np.allclose(rec.joints_at(t - recording.frame_times[0]).q, q)
    assert rec.joints_at(-1.0) is None


def test_the_scan_at_open_reads_image_stamps_as_full_deserialisation_does(recording, monkeypatch):
    """Opening reads each image's stamp from its CDR bytes (its JPEG is not copied); the pairs,
    their times and the lazily made ground truth are what deserialising every image gives."""
    from core.record import reader

    fast = open_recording(recording.path)
    header = b"\x00\x01\x00\x00" + (7).to_bytes(4, "little") + (250).to_bytes(4, "little")  # stamp 7 s 250 ns
    assert reader._stamp_of_raw(header, "sensor_msgs/msg/CompressedImage", None) == reader._Stamp(7 * 10**9 + 250)
    monkeypatch.setattr(reader, "_stamp_of_raw", lambda raw, msgtype, store: store.deserialize_cdr(bytes(raw), msgtype))
    full = open_recording(recording.path)
    assert fast._pair_stamps == full._pair_stamps and fast._pair_log_ns == full._pair_log_ns
    assert fast.pair_times_s == full.pair_times_s and len(fast.pair_times_s) == recording.frames
    for t_s in fast.pair_times_s[::7]:
        a, b = fast.truth_at(t_s), full.truth_at(t_s)
        assert a is fast.truth_at(t_s)  # made once, then kept
        assert [(o.marker_id, o.base_p_centre) for o in a.objects] == [(o.marker_id, o.base_p_centre) for o in b.objects]
    assert [r.t_s for r in fast.joints["measured"]] == sorted(r.t_s for r in fast.joints["measured"])


def test_another_robot_or_deskarm_version_is_a_warning_not_an_error(tmp_path):
    live = make_recording(tmp_path / "old", seconds=0.3, fps=FPS, deskarm_version="0.0.1")
    rec = open_recording(live.path, robot="umi_rtx")
    joined = " ".join(rec.warnings)
    assert "robot profile 'desk_rrr'" in joined and "'umi_rtx'" in joined
    assert "deskarm 0.0.1" in joined
    assert open_recording(live.path, robot="desk_rrr").compatibility_warnings("desk_rrr", version="0.0.1") == []


# ----------------------------------------------------------------------------------------------
# the camera


def test_replay_through_headless_scores_like_the_live_run(recording):
    out = io.StringIO()
    options = SessionOptions(camera=f"replay:{recording.path}", simulated_clock=True, scenario="wander")
    assert run_headless(options, SECONDS + 0.1, True, out=out) == 0
    summary = json.loads(out.getvalue().strip().splitlines()[-1])
    assert summary["frames"] == recording.frames
    check_close(summary["error_3d_mm_p50"], recording.error_3d_mm_p50, 0.1, "error_3d_mm_p50")
    assert summary["markers_seen_ratio"] > 0.95


def test_deskarm_headless_replays_a_recording_from_the_command_line(recording):
    out = subprocess.run(
        [sys.executable, "-m", "app.cli", "--headless", "--camera", f"replay:{recording.path}", "--fast",
         "--duration", str(SECONDS + 0.1), "--json"], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    summary = json.loads(out.stdout.strip().splitlines()[-1])
    assert summary["frames"] == recording.frames
    check_close(summary["error_3d_mm_p50"], recording.error_3d_mm_p50, 0.1, "error_3d_mm_p50")
    assert f"REPLAY — {recording.path}" in out.stderr  # the banner; stdout is the JSON alone


def test_the_session_uses_the_recorded_calibration_and_camera_pose(recording):
    session = DeskSession.create(SessionOptions(camera=f"replay:{recording.path}", simulated_clock=True))
    try:
        rec = session.camera.recording
        assert session.camera.kind == "replay" and session.camera.name == f"replay: {recording.path}"
        assert session.camera.pair_id == "sim"
        assert np.allclose(session.calibration.M1, rec.calibration.M1)
        assert np.allclose(session.calibration.T, rec.calibration.T)
        assert np.allclose(session.perception.base_T_camera, rec.base_T_camera)
        assert not any("UNCALIBRATED" in b for b in session.banners)
    finally:
        session.close()


def test_frames_carry_the_recorded_times_truth_and_images(recording):
    clock = SimClock(100.0)
    cam = ReplayStereoCamera(recording.path, clock=clock)
    cam.connect()
    assert cam.duration_s == pytest.approx(recording.frames / FPS, abs=1e-6)
    frames = replay_all(cam)
    assert len(frames) == recording.frames
    offsets = np.array([f.t for f in frames]) - 100.0
    assert np.allclose(offsets, np.array(recording.frame_times) - recording.frame_times[0])
    assert all(f.truth is not None for f in frames)
    assert np.array_equal(frames[0].left, recording.left_images[0])
    assert not frames[0].left.flags.writeable


def test_the_end_is_reported_and_loop_starts_again(recording):
    cam = ReplayStereoCamera(recording.path, clock=SimClock())
    cam.connect()
    assert len(replay_all(cam)) == recording.frames
    assert not cam.is_connected and cam.progress == 1.0
    assert "replay finished" in cam.status_message
    t = cam.clock.now()
    assert cam.read() is None and cam.clock.now() > t  # a caller's loop waits, it does not spin

    looping = ReplayStereoCamera(recording.path, clock=SimClock(), loop=True)
    looping.connect()
    first = [looping.read() for _ in range(recording.frames)]
    assert looping.read() is None  # the turn
    again = looping.read()
    assert looping.is_connected and again.t > first[-1].t
    assert np.array_equal(again.left, first[0].left)


def test_fast_delivers_as_fast_as_read_on_a_wall_clock(recording):
    cam = ReplayStereoCamera(recording.path, clock=WallClock(), fast=True)
    cam.connect()
    frames = replay_all(cam)  # 3 s of recording: at recorded speed this test would take 3 s
    assert len(frames) == recording.frames and cam.progress == 1.0


def test_seek_jumps_to_the_recorded_time_from_another_thread(recording):
    cam = ReplayStereoCamera(recording.path, clock=SimClock())
    cam.connect()
    first = cam.read()
    done = threading.Event()
    threading.Thread(target=lambda: (cam.seek(2.0), done.set())).start()
    assert done.wait(5.0)
    frame = cam.read()
    rec = cam.recording
    k = rec.index_at(2.0)
    assert frame.t - cam._t0 == pytest.approx(rec.pair_times_s[k])
    assert cam.progress == pytest.approx((rec.pair_times_s[k] + rec.frame_period_s) / rec.frames_s)
    assert frame.truth is not None and frame.t > first.t
    state = cam.recorded_state_at(frame.t)
    assert state is not None and state.measured and state.t <= frame.t
    cam.seek(0.0)
    assert np.array_equal(cam.read().left, first.left)


# ----------------------------------------------------------------------------------------------
# broken and missing recordings


@pytest.mark.parametrize("metadata", [True, False], ids=["cut", "killed-without-metadata"])
def test_a_cut_recording_says_where_it_breaks_and_the_part_before_replays(recording, tmp_path, metadata):
    mcap = cut_copy(recording.path, tmp_path / "cut", metadata=metadata)
    rec = open_recording(mcap.parent)
    assert rec.problem is not None
    message = rec.warnings[0]
    assert message.startswith(f"{mcap}: unreadable after ") and "(byte " in message
    assert message.endswith("the part before replays")
    assert 0 < rec.problem.byte <= os.path.getsize(mcap)
    assert 0.2 * recording.frames < len(rec.pair_times_s) < recording.frames
    assert rec.problem.t_s == pytest.approx(rec.pair_times_s[-1], abs=0.2)

    cam, banner = open_camera(f"replay:{mcap.parent}", clock=SimClock())
    assert str(mcap) in cam.status_message
    frames = replay_all(cam)
    assert len(frames) == len(rec.pair_times_s) and all(f.truth is not None for f in frames)
    assert "replay finished" in cam.status_message and str(mcap) in cam.status_message


def test_a_recording_cut_before_any_image_pair_is_an_error_naming_the_file(recording, tmp_path):
    mcap = cut_copy(recording.path, tmp_path / "stub", keep=0.001)
    with pytest.raises(RecordingError, match="no readable image pairs") as err:
        open_recording(mcap.parent)
    assert str(mcap) in str(err.value)


def test_a_missing_recording_is_one_clear_message(tmp_path):
    missing = tmp_path / "nope"
    with pytest.raises(CameraError, match=f"{missing}: no such recording"):
        open_camera(f"replay:{missing}", clock=SimClock())
    (tmp_path / "empty").mkdir()
    with pytest.raises(CameraError, match="no .mcap file"):
        open_camera(f"replay:{tmp_path / 'empty'}", clock=SimClock())
    out = subprocess.run([sys.executable, "-m", "app.cli", "--headless", "--camera", f"replay:{missing}",
                          "--fast", "--duration", "1"], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert out.returncode != 0
    assert f"{missing}: no such recording" in out.stderr and "Traceback" not in out.stderr


def test_the_camera_spec_names_a_recording_by_string():
    assert parse_camera_spec("replay:/data/run1") == ("replay", ("/data/run1",))
    with pytest.raises(ValueError, match="name the recording"):
        parse_camera_spec("replay:")


def test_a_replay_never_drives_a_real_arm(recording):
    """A recorded scene is not on the desk: a real bridge is refused at start and on a switch."""
    path = recording.path
    with pytest.raises(ValueError, match="drives only the simulated arm"):
        DeskSession.create(SessionOptions(camera=f"replay:{path}", bridge="v2:/dev/deskarm-no-such-port"))
    session = DeskSession.create(SessionOptions(camera=f"replay:{path}"))
    try:
        assert "replay" in session.real_arm_refusal("v2:/dev/ttyACM0")
        assert session.real_arm_refusal("sim://") == ""
    finally:
        session.close()
