"""A still scene costs little to record (file bytes counted per second of recorded frames, no
timing): a pair equal to the last one encoded within sensor noise is written with the same JPEG
bytes, which the MCAP chunks' compression stores about once per chunk; a moving scene is encoded
every frame; the replay reads every frame back."""
from __future__ import annotations

import numpy as np
import pytest

from core.clock import SimClock
from core.messages import GroundTruth, ObjectTruth, StereoFrame
from core.record import Recorder
from core.record.recorder import folder_size
from core.record.replay import ReplayStereoCamera

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

FPS = 30.0
SECONDS = 3.0


def session_info() -> dict:
    return {"deskarm_version": "test", "robot": "desk_rrr", "camera": "test camera", "pair_id": "pair",
            "calibration_yaml": "", "base_T_camera": np.eye(4).tolist(), "scenario": "static", "fps": FPS}


def desk_pair():
    """A rendered pair of the simulated desk (real texture: JPEG sizes like a camera's)."""
    from core.sim.desk import SimDesk
    from core.sim.rig import SimRig

    left, right, _ = SimDesk(SimRig(), scenario="static").render(0.0)
    return left, right


def noisy(image: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A new array of the same scene with a camera's frame-to-frame noise (±3 levels)."""
    noise = rng.integers(-3, 4, size=image.shape, dtype=np.int16)
    return np.clip(image.astype(np.int16) + noise, 0, 255).astype(np.uint8)


def truth(k: int) -> GroundTruth:
    return GroundTruth((ObjectTruth(23, (0.05, 0.1, 0.001 * k), True, True, "card 23"),))


def record(path, frames) -> Recorder:
    rec = Recorder(path, session_info(), queue_size=len(frames) + 1)  # a queue for all: none dropped
    rec.start()
    for f in frames:
        rec.frame(f)
    rec.close()
    assert rec.error == "" and rec.frames_dropped == 0
    return rec


def chunk_count(folder) -> int:
    from mcap.reader import make_reader

    with open(next(folder.glob("*.mcap")), "rb") as f:
        return len(make_reader(f).get_summary().chunk_indexes)


def jpeg_pair_bytes(left, right) -> int:
    import cv2

    return sum(len(cv2.imencode(".jpg", im, [cv2.IMWRITE_JPEG_QUALITY, 85])[1]) for im in (left, right))


def test_a_still_scene_costs_about_one_image_pair_per_chunk_and_replays_every_frame(tmp_path):
    left, right = desk_pair()
    rng = np.random.default_rng(0)
    n = int(SECONDS * FPS)
    frames = [StereoFrame(seq=k + 1, t=100.0 + k / FPS, left=noisy(left, rng), right=noisy(right, rng), truth=truth(k))
              for k in range(n)]
    rec = record(tmp_path / "still", frames)
    pair = jpeg_pair_bytes(left, right)
    recorded_s = n / FPS  # seconds of recorded frames (the clock of the frames, not the test's)
    size = folder_size(rec.path)
    chunks = chunk_count(rec.path)
    # each chunk (closed at 1 MiB of messages, ~11 pairs, or FLUSH_S of writing) stores the pair about once
    assert size < 1.3 * pair * chunks, (size, pair, chunks)
    # every pair stored would be FPS pairs a second; here under a quarter of that even if a slow machine
    # closed a chunk every FLUSH_S on top of the 1 MiB ones (~0.1 measured)
    assert size / recorded_s < 0.25 * FPS * pair, (size, pair, chunks)
    assert rec.frames_written == n and rec.frames_still == n - 1  # one encoded pair, the rest its bytes

    cam = ReplayStereoCamera(rec.path, clock=SimClock(100.0))
    cam.connect()
    got = []
    while (f := cam.read()) is not None:
        got.append(f)
    cam.disconnect()
    assert len(got) == n
    np.testing.assert_allclose(np.diff([f.t for f in got]), 1 / FPS, atol=1e-6)
    assert [f.truth.objects[0].base_p_centre[2] for f in got] == pytest.approx([0.001 * k for k in range(n)])
    assert sum(f.repeated for f in got) == n - 1  # decoded once, the same arrays after
    assert np.abs(got[-1].left.astype(int) - left.astype(int)).mean() < 4


def test_a_moving_scene_encodes_every_image_pair(tmp_path):
    left, right = desk_pair()
    frames = []
    for k in range(30):
        lk, rk = left.copy(), right.copy()
        x = 100 + 4 * k  # a 20 px dark card moving 4 px a frame
        lk[200:220, x:x + 20] = 0
        rk[200:220, x - 30:x - 10] = 0
        frames.append(StereoFrame(seq=k + 1, t=k / FPS, left=lk, right=rk))
    rec = record(tmp_path / "moving", frames)
    assert rec.frames_still == 0 and rec.frames_written == 30
    cam = ReplayStereoCamera(rec.path, clock=SimClock())
    cam.connect()
    got = []
    while (f := cam.read()) is not None:
        got.append(f)
    cam.disconnect()
    assert len(got) == 30 and not any(f.repeated for f in got)
    for k in (0, 29):  # the card is where it was
        x = 100 + 4 * k
        assert got[k].left[205:215, x + 5:x + 15].mean() < 40 and got[k].left[205:215, x + 30:x + 40].mean() > 40


def test_the_size_shown_while_recording_is_the_size_on_disk(tmp_path):
    """The window's ● REC shows ``Recorder.file_bytes``: the .mcap on disk, whose chunks are
    compressed — not the message bytes before compression (a still desk showed 56 MB for a 7.7 MB
    file under Xvfb)."""
    left, right = desk_pair()
    rng = np.random.default_rng(1)
    frames = [StereoFrame(seq=k + 1, t=100.0 + k / FPS, left=noisy(left, rng), right=noisy(right, rng), truth=truth(k))
              for k in range(45)]
    rec = record(tmp_path / "shown", frames)
    on_disk = next(rec.path.glob("*.mcap")).stat().st_size
    assert rec.file_bytes == on_disk
    assert rec.file_bytes < rec.bytes_written / 2  # the uncompressed count would overstate it
