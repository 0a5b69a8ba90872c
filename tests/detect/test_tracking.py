"""ObjectTracker: an OpenCV tracker on a cropped window, re-seeded and checked by detections."""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import pytest

from core.detect.tracking import ObjectTracker, available_trackers, iou

W, H = 640, 480
SIDE = 44  # px, the square's side
FPS = 30.0


@dataclass(frozen=True)
class _Det:  # the shape of core.detect.base.Detection that the tracker reads
    box: tuple
    centre_px: tuple


def _background(seed: int = 3) -> np.ndarray:
    """A desk-like texture: smooth wood-ish blotches and fine grain."""
    rng = np.random.default_rng(seed)
    coarse = cv2.resize(rng.uniform(0, 1, (12, 16)).astype(np.float32), (W, H), interpolation=cv2.INTER_CUBIC)
    fine = cv2.GaussianBlur(rng.normal(0, 1, (H, W)).astype(np.float32), (0, 0), 1.2)
    grey = 120 + 40 * coarse + 6 * fine
    img = np.dstack([grey * 0.75, grey * 0.9, grey]).clip(0, 255).astype(np.uint8)
    return img


BG = _background()


def _frame(centre, rng, present: bool = True) -> np.ndarray:
    img = BG.copy()
    if present:
        x, y = centre
        p0 = (int(round(x - SIDE / 2)), int(round(y - SIDE / 2)))
        p1 = (p0[0] + SIDE, p0[1] + SIDE)
        cv2.rectangle(img, p0, p1, (40, 40, 200), -1)  # a red box…
        cv2.rectangle(img, (p0[0] + 8, p0[1] + 8), (p0[0] + 22, p0[1] + 30), (230, 230, 230), -1)  # …with a label
        cv2.circle(img, (p0[0] + 32, p0[1] + 14), 6, (30, 160, 40), -1)
    noise = rng.normal(0, 2.0, img.shape)
    return (img + noise).clip(0, 255).astype(np.uint8)


def _box(centre) -> tuple:
    return (centre[0] - SIDE / 2, centre[1] - SIDE / 2, SIDE, SIDE)


def _path(k: int) -> np.ndarray:
    """The square's centre at frame k: ~5 px/frame across, a gentle wave up and down."""
    return np.array([150.0 + 5.0 * k, 240.0 + 40.0 * np.sin(k / 10.0)])


def test_trackers_of_this_build_are_listed():
    kinds = available_trackers()
    for kind in ("KCF", "CSRT", "MIL", "MOSSE"):
        assert kind in kinds
    with pytest.raises(ValueError, match="unknown tracker"):
        ObjectTracker("GOTURN")


@pytest.mark.parametrize("kind", ["KCF", "CSRT"])
def test_a_moving_square_is_tracked_over_60_frames(kind):
    rng = np.random.default_rng(1)
    tracker = ObjectTracker(kind)
    tracker.start(_frame(_path(0), rng), _box(_path(0)), t=0.0)
    errors = []
    for k in range(1, 61):
        state = tracker.update(_frame(_path(k), rng), k / FPS)  # no detections: the tracker alone
        assert state.ok and not state.lost
        errors.append(float(np.linalg.norm(np.array(state.centre_px) - _path(k))))
    assert max(errors) < 4.0, errors
    # image velocity: ~150 px/s across
    assert abs(state.velocity_px_s[0] - 150.0) < 30.0


def test_reseeding_from_a_detection_fixes_a_drift():
    rng = np.random.default_rng(2)
    tracker = ObjectTracker("KCF", reseed_every=1000)  # only the drift test can re-seed
    c0 = _path(0)
    wrong = (c0[0] - SIDE / 2 + 22, c0[1] - SIDE / 2 + 22, SIDE, SIDE)  # a quarter of the box off
    tracker.start(_frame(c0, rng), wrong, t=0.0)
    for k in range(1, 6):
        state = tracker.update(_frame(_path(k), rng), k / FPS)
    err_before = float(np.linalg.norm(np.array(state.centre_px) - _path(5)))
    assert err_before > 20.0  # it follows the wrong spot
    assert iou(state.box, _box(_path(5))) < 0.3
    k = 6
    state = tracker.update(_frame(_path(k), rng), k / FPS, detections=[_Det(_box(_path(k)), tuple(_path(k)))])
    assert state.reseeded and state.ok
    for k in range(7, 30):
        state = tracker.update(_frame(_path(k), rng), k / FPS)
        assert state.ok
    assert float(np.linalg.norm(np.array(state.centre_px) - _path(29))) < 4.0
    assert tracker.reseeds == 1


def test_reseeds_every_n_frames_from_matching_detections():
    rng = np.random.default_rng(4)
    tracker = ObjectTracker("KCF", reseed_every=10)
    tracker.start(_frame(_path(0), rng), _box(_path(0)), t=0.0)
    other = _Det(_box((500.0, 80.0)), (500.0, 80.0))  # another object: never matched
    reseeded_at = []
    for k in range(1, 41):
        c = _path(k)
        state = tracker.update(_frame(c, rng), k / FPS, detections=[other, _Det(_box(c), tuple(c))])
        if state.reseeded:
            reseeded_at.append(k)
    assert reseeded_at == [10, 20, 30, 40]
    assert float(np.linalg.norm(np.array(state.centre_px) - _path(40))) < 2.0


def test_an_object_that_left_is_lost_at_once_and_never_reported_ok():
    rng = np.random.default_rng(5)
    tracker = ObjectTracker("KCF")
    tracker.start(_frame(_path(0), rng), _box(_path(0)), t=0.0)
    for k in range(1, 20):
        assert tracker.update(_frame(_path(k), rng), k / FPS).ok
    states = [tracker.update(_frame(_path(k), rng, present=False), k / FPS) for k in range(20, 40)]
    assert not any(s.ok for s in states)
    first_lost = next(i for i, s in enumerate(states) if s.lost)
    assert first_lost <= 2, [(s.ok, s.lost) for s in states]
    assert all(s.lost for s in states[first_lost:])


def test_unconfirmed_by_detections_for_lost_after_opportunities_is_lost():
    rng = np.random.default_rng(6)
    tracker = ObjectTracker("KCF", lost_after=5)
    tracker.start(_frame(_path(0), rng), _box(_path(0)), t=0.0)
    lost_at = None
    for k in range(1, 12):  # the object stays, but the detector no longer confirms it
        state = tracker.update(_frame(_path(k), rng), k / FPS, detections=[])
        if state.lost and lost_at is None:
            lost_at = k
        if lost_at is not None:
            assert state.lost and not state.ok
    assert lost_at == 5
    # a matching detection brings it back
    k = 12
    state = tracker.update(_frame(_path(k), rng), k / FPS, detections=[_Det(_box(_path(k)), tuple(_path(k)))])
    assert state.ok and not state.lost and state.reseeded


class _CountingTracker:
    """Wraps an OpenCV tracker and counts its updates."""

    def __init__(self, inner):
        self.inner, self.updates = inner, 0

    def update(self, crop):
        self.updates += 1
        return self.inner.update(crop)


def test_observing_detections_runs_no_tracker_and_the_next_update_starts_from_the_last_one():
    rng = np.random.default_rng(8)
    tracker = ObjectTracker("KCF")
    tracker.start(_frame(_path(0), rng), _box(_path(0)), t=0.0)
    counting = tracker._tracker = _CountingTracker(tracker._tracker)
    for k in range(1, 11):
        state = tracker.observe(_frame(_path(k), rng), k / FPS, _box(_path(k)))
        assert state.ok and not state.lost and state.box == pytest.approx(_box(_path(k)))
    assert counting.updates == 0  # the detector saw it: no tracker run
    assert abs(state.velocity_px_s[0] - 150.0) < 30.0
    reseeds = tracker.reseeds
    for k in range(11, 31):  # the detector stops seeing it: the tracker takes over from frame 10's box
        state = tracker.update(_frame(_path(k), rng), k / FPS)
        assert state.ok
        assert float(np.linalg.norm(np.array(state.centre_px) - _path(k))) < 4.0, k
    assert tracker.reseeds == reseeds + 1  # seeded once, lazily, from the last observation


def test_an_observation_brings_a_lost_object_back():
    rng = np.random.default_rng(9)
    tracker = ObjectTracker("KCF", lost_after=2)
    tracker.start(_frame(_path(0), rng), _box(_path(0)), t=0.0)
    for k in range(1, 4):
        state = tracker.update(_frame(_path(k), rng), k / FPS, detections=[])
    assert state.lost
    state = tracker.observe(_frame(_path(4), rng), 4 / FPS, _box(_path(4)))
    assert state.ok and not state.lost
    state = tracker.update(_frame(_path(5), rng), 5 / FPS)
    assert state.ok and float(np.linalg.norm(np.array(state.centre_px) - _path(5))) < 4.0


def test_match_picks_the_detection_of_the_tracked_object():
    rng = np.random.default_rng(10)
    tracker = ObjectTracker("KCF")
    assert tracker.match([_Det(_box(_path(0)), tuple(_path(0)))], 0.0) is None  # not started
    tracker.start(_frame(_path(0), rng), _box(_path(0)), t=0.0)
    mine, other = _Det(_box(_path(1)), tuple(_path(1))), _Det(_box((500.0, 80.0)), (500.0, 80.0))
    assert tracker.match([other, mine], 1 / FPS) is mine
    assert tracker.match([other], 1 / FPS) is None


def _plain_disc_frame(centre, rng) -> np.ndarray:
    """A plain red disc on the desk texture: nothing inside it for a correlation filter to lock on."""
    img = BG.copy()
    cv2.circle(img, (int(round(centre[0])), int(round(centre[1]))), SIDE // 2, (40, 40, 200), -1, cv2.LINE_AA)
    return (img + rng.normal(0, 2.0, img.shape)).clip(0, 255).astype(np.uint8)


def test_mosse_follows_a_plain_ball_given_the_desk_around_it():
    """OpenCV's legacy MOSSE learns on its init box alone and gives up when its response's
    peak-to-sidelobe ratio is under 5.7: on a plain disc that filled the box, every update failed.
    With the ring of desk around it (CONTEXT_PAD) it follows, as it followed markers on the
    original desk."""
    rng = np.random.default_rng(4)
    raw = cv2.legacy.TrackerMOSSE_create()  # the plain OpenCV tracker on the disc's own box: fails
    raw.init(_plain_disc_frame(_path(0), rng), tuple(float(v) for v in _box(_path(0))))
    raw_ok = [raw.update(_plain_disc_frame(_path(k), rng))[0] for k in range(1, 21)]
    assert raw_ok.count(True) <= 2, raw_ok
    tracker = ObjectTracker("MOSSE")
    tracker.start(_plain_disc_frame(_path(0), rng), _box(_path(0)), t=0.0)
    errors = []
    for k in range(1, 61):
        state = tracker.update(_plain_disc_frame(_path(k), rng), k / FPS)  # no detections
        assert state.ok and not state.lost, k
        errors.append(float(np.linalg.norm(np.array(state.centre_px) - _path(k))))
        assert abs(state.box[2] - SIDE) <= 2 and abs(state.box[3] - SIDE) <= 2  # the ball's box, not the context
    assert max(errors) < 3.0, errors
