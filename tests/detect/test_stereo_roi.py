"""StereoObjectPerception beyond one frame: tentative tracks, the desk check, occluded objects split
in two, ROI search and trackers in the loop (re-seeding, removal).

Synthetic pairs from the simulated rig (exact calibration): coloured balls on a textured desk
(z = 0 in robot_base), drawn at the projections of known robot_base points; an occluder (the
arm's grey link, a skin-coloured hand) drawn over them where a test says.
"""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from core.detect.colour import DEFAULT_COLOURS, HsvDetector, HsvParams
from core.detect.stereo import StereoObjectPerception
from core.messages import StereoFrame
from core.sim.rig import SimRig

BGR = {"red": (30, 30, 220), "blue": (220, 90, 10), "green": (20, 190, 20), "yellow": (20, 210, 230)}
R_BALL = 0.022  # m
FPS = 30.0


@pytest.fixture(scope="module")
def rig():
    return SimRig()


@pytest.fixture(scope="module")
def desk(rig):
    rng = np.random.default_rng(11)
    w, h = rig.size
    coarse = cv2.resize(rng.uniform(0, 1, (12, 16)).astype(np.float32), (w, h), interpolation=cv2.INTER_CUBIC)
    grey = 110 + 40 * coarse
    return np.dstack([grey * 0.8, grey * 0.9, grey]).clip(0, 255).astype(np.uint8)


def _perception(rig, **kw) -> StereoObjectPerception:
    return StereoObjectPerception(rig.calibration(), rig.base_T_camera,
                                  [HsvDetector(HsvParams(colours=DEFAULT_COLOURS))], **kw)


def _ball(x, y):
    return np.array([x, y, R_BALL])


def _render(rig, desk, side, balls, rng, occluders=()) -> np.ndarray:
    """``balls`` [(colour, base point)] as shaded discs; ``occluders`` [(colour BGR, (x0, y0, x1, y1)
    in the left view's px)] drawn on top (shifted by ~60 px of disparity in the right view)."""
    img = desk.copy()
    for name, p in balls:
        c = rig.project(side, p)[0]
        r = R_BALL * rig.config.focal_px / float(rig.depth(side, p)[0])
        s = 16
        cv2.circle(img, (int(round(c[0] * s)), int(round(c[1] * s))), int(round(r * s)), BGR[name], -1, cv2.LINE_AA, 4)
    for colour, (x0, y0, x1, y1) in occluders:
        dx = 0 if side == "left" else -62
        cv2.rectangle(img, (x0 + dx, y0), (x1 + dx, y1), colour, -1)
    noise = rng.normal(0, 2.0, img.shape)
    return (img + noise).clip(0, 255).astype(np.uint8)


def _frame(rig, desk, k, balls, rng, occluders=(), right_balls=None) -> StereoFrame:
    right_balls = balls if right_balls is None else right_balls
    return StereoFrame(seq=k, t=k / FPS, left=_render(rig, desk, "left", balls, rng, occluders),
                       right=_render(rig, desk, "right", right_balls, rng, occluders))


def _tri(obs):
    return [o for o in obs if o.triangulated]


def test_a_new_object_gets_its_id_after_min_hits_frames_and_a_flicker_never(rig, desk):
    rng = np.random.default_rng(1)
    perc = _perception(rig, min_hits=3)
    red = _ball(0.0, 0.2)
    seen = []
    for k in range(5):
        balls = [("red", red)] + ([("blue", _ball(0.1, 0.25))] if k == 1 else [])  # blue: one frame only
        seen.append(perc.process(_frame(rig, desk, k, balls, rng)))
    assert [len(o) for o in seen] == [0, 0, 1, 1, 1]
    assert {o.object_id for frame in seen for o in frame} == {1}  # the flicker took no id
    assert seen[2][0].frames_tracked == 3


def test_a_point_below_the_desk_is_no_object(rig, desk):
    rng = np.random.default_rng(2)
    below = np.array([0.0, 0.2, -0.05])  # 5 cm under the desk plane: a mismatched pair
    perc = _perception(rig, min_hits=1)
    assert perc.process(_frame(rig, desk, 0, [("red", below)], rng)) == []
    perc = _perception(rig, min_hits=1, desk_check=False)
    assert len(perc.process(_frame(rig, desk, 0, [("red", below)], rng))) == 1


def test_an_arm_across_a_ball_starts_no_second_track(rig, desk):
    """A grey bar across the ball splits its blob in two: merged into one, one id all along."""
    rng = np.random.default_rng(3)
    for merge in (True, False):
        perc = _perception(rig, min_hits=2, merge_fragments=merge)
        ids, counts, errors = set(), [], []
        for k in range(40):
            p = _ball(-0.05 + 0.002 * k, 0.2)  # 6 cm/s sideways
            c = rig.project("left", p)[0]
            bar = ((150, 150, 150), (int(c[0]) - 40, int(c[1]) - 4, int(c[0]) + 40, int(c[1]) + 4)) if 10 <= k < 30 else None
            obs = _tri(perc.process(_frame(rig, desk, k, [("red", p)], rng, occluders=[bar] if bar else [])))
            ids |= {o.object_id for o in obs}
            counts.append(len(obs))
            errors += [np.linalg.norm(np.subtract(o.base_p, p)) for o in obs]
        if merge:
            assert ids == {1} and max(counts) == 1, (ids, counts)
            print(f"bar across a ball, fragments merged: worst error {max(errors) * 1e3:.1f} mm")
            assert max(errors) < 0.01
        else:
            assert len(ids) > 1 or max(counts) > 1, (ids, counts)  # the failure the merging prevents


def _moving(k):
    return [("red", _ball(0.06 * np.cos(k / 15.0), 0.2 + 0.04 * np.sin(k / 15.0))), ("blue", _ball(0.1, 0.27)),
            ("green", _ball(-0.12, 0.14))]


def test_roi_search_sees_what_the_full_search_sees(rig, desk):
    rng_a, rng_b = np.random.default_rng(4), np.random.default_rng(4)
    full = _perception(rig, min_hits=2)
    roi = _perception(rig, min_hits=2, roi_search=True, full_frame_every=8)
    flags, worst = [], 0.0
    for k in range(48):
        fa = _frame(rig, desk, k, _moving(k), rng_a)
        fb = _frame(rig, desk, k, _moving(k), rng_b)
        a, b = _tri(full.process(fa)), _tri(roi.process(fb))
        flags.append(roi.last_full_frame_search)
        assert set(roi.last_timings_ms) >= {"detect", "track", "match", "total"}
        assert [(o.object_id, o.label) for o in a] == [(o.object_id, o.label) for o in b], k
        for oa, ob in zip(a, b):
            worst = max(worst, float(np.linalg.norm(np.subtract(oa.base_p, ob.base_p))))
    # full searches: the first frames (no tracks, then tentative ones), then every 8th frame
    assert flags[:2] == [True, True] and sum(flags) <= 2 + 48 // 8 + 1, flags
    assert not all(flags[2:])
    print(f"ROI vs full search: {sum(flags)} of 48 frames full, worst 3D difference {worst * 1e3:.3f} mm")
    assert worst < 0.001


def test_roi_search_finds_a_new_object_at_the_next_full_search(rig, desk):
    rng = np.random.default_rng(5)
    perc = _perception(rig, min_hits=1, roi_search=True, full_frame_every=6)
    first_seen = None
    for k in range(20):
        balls = [("red", _ball(0.0, 0.2))] + ([("blue", _ball(0.1, 0.27))] if k >= 7 else [])
        obs = perc.process(_frame(rig, desk, k, balls, rng))
        if first_seen is None and any(o.label == "blue" for o in obs):
            first_seen = k
            assert perc.last_full_frame_search
    assert first_seen is not None and 7 <= first_seen < 7 + 6


@pytest.mark.parametrize("tracker", ["kcf", "csrt"])
def test_trackers_stand_in_between_detector_runs(rig, desk, tracker):
    rng = np.random.default_rng(6)
    perc = _perception(rig, min_hits=2, tracker=tracker, detect_every=3, reseed_every=3)
    ran, from_tracker, errors = [], [], []
    for k in range(30):
        p = _ball(0.04 * np.cos(k / 10.0), 0.2)
        obs = _tri(perc.process(_frame(rig, desk, k, [("red", p)], rng)))
        ran.append(perc.last_detector_run)
        if k >= 3:
            assert len(obs) == 1 and obs[0].object_id == 1, k
            from_tracker.append(obs[0].from_tracker)
            errors.append(float(np.linalg.norm(np.subtract(obs[0].base_p, p))))
    assert ran[3:].count(False) >= 15  # the detector ran on every third frame once the track settled
    assert sum(from_tracker) >= 15 and not all(from_tracker)
    print(f"{tracker} between detector runs: 3D error p50 {np.median(errors) * 1e3:.1f} mm, max {max(errors) * 1e3:.1f} mm")
    assert max(errors) < 0.015
    track = perc.tracks[1]
    assert all(t is not None and t.reseeds >= 3 for t in track.trackers.values())  # re-seeded by the detector


def test_a_ball_that_rolls_out_of_view_is_not_reported_after_the_removal_check(rig, desk):
    rng = np.random.default_rng(7)
    perc = _perception(rig, min_hits=2, tracker="kcf", tracker_lost_after=3, drop_after=10)
    last_reported = None
    gone_at = None
    for k in range(40):
        p = _ball(-0.2 - 0.012 * k, 0.2)  # rolls past the image's right edge (x < −0.33)
        in_view = rig.project("left", p)[0][0] + 10 < rig.size[0] and rig.project("right", p)[0][0] + 10 < rig.size[0]
        if not in_view and gone_at is None:
            gone_at = k
        obs = perc.process(_frame(rig, desk, k, [("blue", p)] if in_view else [], rng))
        if any(o.label == "blue" for o in obs):
            last_reported = k
    assert gone_at is not None
    # reported at most while the removal checks run (tracker: 3 detector runs without the ball)
    assert last_reported is not None and last_reported < gone_at + 3, (gone_at, last_reported)
    assert perc.tracks == {} and 1 in perc.lost


def test_a_tracker_on_an_object_hidden_by_a_hand_stops_reporting(rig, desk):
    rng = np.random.default_rng(8)
    perc = _perception(rig, min_hits=2, tracker="kcf", tracker_lost_after=4, drop_after=30)
    p = _ball(0.05, 0.22)
    c = rig.project("left", p)[0]
    hand = ((120, 160, 215), (int(c[0]) - 40, int(c[1]) - 40, int(c[0]) + 40, int(c[1]) + 40))  # skin, over it
    reported = []
    for k in range(30):
        hidden = k >= 10
        obs = perc.process(_frame(rig, desk, k, [("green", p)], rng, occluders=[hand] if hidden else []))
        reported.append(any(o.label == "green" for o in obs))
    assert all(reported[2:10])
    assert not any(reported[10 + 4:]), reported  # the tracker's removal check ended it
    tr = perc.tracks[1].trackers["left"]
    assert tr is not None and tr.lost


def test_trackers_do_not_run_while_the_detector_sees_every_object(rig, desk, monkeypatch):
    """Each tracker only notes the detections (ObjectTracker.observe); it runs (re-seeded from
    the last detection) only where the detector misses its object."""
    from core.detect.tracking import ObjectTracker

    runs = []
    real_update = ObjectTracker.update
    monkeypatch.setattr(ObjectTracker, "update", lambda self, *a, **kw: runs.append(1) or real_update(self, *a, **kw))
    rng = np.random.default_rng(21)
    perc = _perception(rig, min_hits=2, tracker="kcf")
    balls = [("red", _ball(-0.05, 0.15)), ("blue", _ball(0.08, 0.12))]
    for k in range(12):
        moved = [(name, p + np.array([0.002 * k, 0.0, 0.0])) for name, p in balls]
        obs = perc.process(_frame(rig, desk, k, moved, rng))
    assert len(_tri(obs)) == 2
    assert all(t is not None for tr in perc.tracks.values() for t in tr.trackers.values())
    assert runs == []
    # the red ball hidden from the detector in the left view: its tracker runs and stands in
    k = 12
    moved = [(name, p + np.array([0.002 * k, 0.0, 0.0])) for name, p in balls]
    left_only_blue = StereoFrame(seq=k, t=k / FPS, left=_render(rig, desk, "left", moved[1:], rng),
                                 right=_render(rig, desk, "right", moved, rng))
    obs = perc.process(left_only_blue)
    assert len(runs) == 1
