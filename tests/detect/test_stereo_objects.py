"""Stereo objects: match detections across the views, triangulate, keep ids, compensate skew.

Synthetic pairs: filled coloured discs drawn with OpenCV at the projections of known 3D points
into both views of the simulated rig (its exact calibration, slightly rotated right camera), on a
grey desk with pixel noise.
"""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from core.detect.colour import HsvDetector, HsvParams, DEFAULT_COLOURS
from core.detect.stereo import ObjectObservation, StereoObjectPerception
from core.messages import StereoFrame
from core.sim.rig import SimRig

BGR = {"red": (30, 30, 220), "blue": (220, 90, 10), "green": (20, 190, 20), "yellow": (20, 210, 230)}
BALL_R = 0.02  # m


@pytest.fixture(scope="module")
def rig():
    return SimRig()


def _perception(rig, **kw) -> StereoObjectPerception:
    """The perception under test. Most tests here check one frame's geometry with balls floating
    in front of the camera (at 0.6 m depth below the simulated desk plane): unless a test asks
    otherwise, new objects are reported from their first frame (min_hits=1) and any 3D point counts
    (desk_check off)."""
    kw.setdefault("min_hits", 1)
    kw.setdefault("desk_check", False)
    return StereoObjectPerception(rig.calibration(), rig.base_T_camera,
                                  [HsvDetector(HsvParams(colours=DEFAULT_COLOURS))], **kw)


def _at_depth(rig, depth, x=0.0, y=0.0) -> np.ndarray:
    """robot_base point ``depth`` m in front of camera_left, ``x``, ``y`` m off its axis."""
    T = rig.base_T_camera
    return T[:3, 3] + depth * T[:3, 2] + x * T[:3, 0] + y * T[:3, 1]


def _render(rig, side, balls, rng, noise=3.0) -> np.ndarray:
    """A view with ``balls`` [(colour name, base point)] drawn as filled discs."""
    w, h = rig.size
    img = np.full((h, w, 3), (95, 100, 105), np.uint8)
    for name, p in balls:
        c = rig.project(side, p)[0]
        r = BALL_R * rig.config.focal_px / float(rig.depth(side, p)[0])
        s = 16  # shift=4: 1/16 px
        cv2.circle(img, (int(round(c[0] * s)), int(round(c[1] * s))), int(round(r * s)), BGR[name], -1,
                   cv2.LINE_AA, 4)
    if noise:
        img = np.clip(img.astype(np.float32) + rng.normal(0, noise, img.shape), 0, 255).astype(np.uint8)
    return img


def _frame(rig, seq, t, left_balls, right_balls, rng, skew_s=0.0) -> StereoFrame:
    return StereoFrame(seq=seq, t=t, left=_render(rig, "left", left_balls, rng),
                       right=_render(rig, "right", right_balls, rng), skew_s=skew_s)


def _triangulated(obs: list[ObjectObservation]) -> list[ObjectObservation]:
    return [o for o in obs if o.triangulated]


@pytest.mark.parametrize("depth", [0.40, 0.50, 0.60])
def test_static_balls_triangulate_within_2mm(rig, depth):
    rng = np.random.default_rng(int(depth * 100))
    balls = [("red", _at_depth(rig, depth, -0.06, 0.02)), ("blue", _at_depth(rig, depth, 0.07, -0.03)),
             ("green", _at_depth(rig, depth + 0.03, 0.0, 0.05))]
    perc = _perception(rig)
    obs = _triangulated(perc.process(_frame(rig, 1, 0.0, balls, balls, rng)))
    assert sorted(o.label for o in obs) == ["blue", "green", "red"]
    truth = dict(balls)
    for o in obs:
        err = np.linalg.norm(np.asarray(o.base_p) - truth[o.label])
        print(f"depth {depth:.2f} {o.label}: error {err * 1e3:.2f} mm, dy {o.epipolar_dy_px:+.3f} px, "
              f"disparity {o.disparity_px:.2f} px")
        assert err < 0.002, (o.label, err)
        assert abs(o.epipolar_dy_px) < 0.5
        assert o.seen_left and o.seen_right and o.left is not None and o.right is not None
        assert o.velocity_base is None  # first frame


def test_two_objects_keep_their_ids_over_30_frames(rig):
    rng = np.random.default_rng(1)
    perc = _perception(rig)
    ids: dict[str, set] = {"red": set(), "blue": set()}
    for k in range(30):
        t = k / 30.0
        # red sweeps right, blue left (they pass each other 7 cm apart: no occlusion), both drift in depth
        red = _at_depth(rig, 0.50 + 0.002 * k, -0.08 + 0.006 * k, 0.035)
        blue = _at_depth(rig, 0.55 - 0.002 * k, 0.08 - 0.006 * k, -0.035)
        balls = [("red", red), ("blue", blue)]
        obs = _triangulated(perc.process(_frame(rig, k, t, balls, balls, rng)))
        assert len(obs) == 2
        truth = dict(balls)
        for o in obs:
            ids[o.label].add(o.object_id)
            assert np.linalg.norm(np.asarray(o.base_p) - truth[o.label]) < 0.003
    assert len(ids["red"]) == 1 and len(ids["blue"]) == 1 and ids["red"] != ids["blue"], ids
    # the Kalman velocity of red: 0.006 m/frame · 30 = 0.18 m/s sideways (+ depth drift)
    v = np.asarray(obs[[o.label for o in obs].index("red")].velocity_base)
    assert abs(np.linalg.norm(v) - np.hypot(0.18, 0.06)) < 0.03, v


def test_same_colour_objects_keep_their_ids(rig):
    rng = np.random.default_rng(2)
    perc = _perception(rig)
    first = None
    for k in range(20):
        a = _at_depth(rig, 0.48, -0.07 + 0.003 * k, 0.0)
        b = _at_depth(rig, 0.52, 0.07 - 0.001 * k, 0.04)
        obs = _triangulated(perc.process(_frame(rig, k, k / 30.0, [("red", a), ("red", b)],
                                                [("red", a), ("red", b)], rng)))
        assert len(obs) == 2
        by_id = {o.object_id: np.asarray(o.base_p) for o in obs}
        mapping = {i: ("a" if np.linalg.norm(p - a) < 0.005 else "b") for i, p in by_id.items()}
        assert sorted(mapping.values()) == ["a", "b"]
        if first is None:
            first = mapping
        assert mapping == first


def test_colour_in_one_view_only_is_not_triangulated(rig):
    rng = np.random.default_rng(3)
    perc = _perception(rig)
    red, green = _at_depth(rig, 0.5, -0.05), _at_depth(rig, 0.5, 0.05)
    obs = perc.process(_frame(rig, 1, 0.0, [("red", red), ("green", green)], [("red", red)], rng))
    assert [o.label for o in obs] == ["red"] and obs[0].triangulated
    # a tracked object that vanishes from one view is reported from the other, not triangulated
    obs = perc.process(_frame(rig, 2, 1 / 30, [("red", red)], [], rng))
    assert len(obs) == 1 and not obs[0].triangulated and obs[0].seen_left and not obs[0].seen_right
    assert obs[0].object_id == 1 and obs[0].right is None
    assert np.linalg.norm(np.asarray(obs[0].base_p) - red) < 0.003  # the track's prediction


def test_label_mismatch_is_rejected(rig):
    rng = np.random.default_rng(4)
    perc = _perception(rig)
    p = _at_depth(rig, 0.5)
    # the same place, red on the left, blue on the right: geometrically perfect, but not one object
    assert perc.process(_frame(rig, 1, 0.0, [("red", p)], [("blue", p)], rng)) == []
    assert perc.tracks == {}


def test_matching_gates_rows_disparity_and_size(rig):
    perc = _perception(rig)
    from core.detect.base import Detection

    def det(label, r):
        return Detection(kind="colour", label=label, score=1.0, box=(0, 0, 2 * r, 2 * r), centre_px=(0, 0),
                         radius_px=r)

    L = [det("red", 10), det("red", 10), det("red", 10), det("red", 10)]
    R = [det("red", 10), det("red", 10), det("red", 20), det("blue", 10)]
    rl = np.array([[300.0, 100.0], [300.0, 200.0], [300.0, 300.0], [300.0, 400.0]])
    rr = np.array([[280.0, 106.0],  # row 6 px off: rejected
                   [301.0, 200.0],  # negative disparity: rejected
                   [280.0, 300.0],  # twice the size: rejected
                   [280.0, 400.0]])  # blue: rejected
    assert perc.match(L, R, rl, rr) == []
    rr2 = np.array([[280.0, 101.0], [270.0, 200.5], [250.0, 300.0], [280.0, 150.0]])
    R2 = [det("red", 10), det("red", 11), det("red", 12), det("red", 10)]
    pairs = perc.match(L, R2, rl, rr2)
    assert sorted((i, j) for i, j, _ in pairs) == [(0, 0), (1, 1), (2, 2)]


def _skew_run(rig, compensate: bool, frames: int = 12, skew_s: float = 0.016, speed: float = 0.2, seed=5):
    """A red ball moving sideways at ``speed`` (m/s, along camera x) at 50 cm; right view ``skew_s`` late."""
    rng = np.random.default_rng(seed)
    perc = _perception(rig, compensate_skew=compensate)
    x_axis = rig.base_T_camera[:3, 0]
    start = _at_depth(rig, 0.50, -0.06)
    errors, depth_errors, flags = [], [], []
    for k in range(frames):
        t = k / 30.0
        p_left = start + speed * t * x_axis
        p_right = start + speed * (t + skew_s) * x_axis
        obs = _triangulated(perc.process(_frame(rig, k, t, [("red", p_left)], [("red", p_right)], rng, skew_s)))
        assert len(obs) == 1 and obs[0].object_id == 1
        cam_truth = np.linalg.inv(rig.base_T_camera) @ np.append(p_left, 1.0)
        errors.append(np.linalg.norm(np.asarray(obs[0].base_p) - p_left))
        depth_errors.append(obs[0].camera_p[2] - cam_truth[2])
        flags.append(obs[0].skew_compensated)
    return np.array(errors), np.array(depth_errors), flags


def test_skew_makes_depth_error_and_compensation_removes_it(rig):
    err_off, dz_off, flags_off = _skew_run(rig, compensate=False)
    err_on, dz_on, flags_on = _skew_run(rig, compensate=True)
    print(f"skew 16 ms, 0.2 m/s: depth error without compensation {np.abs(dz_off).mean() * 1e3:.1f} mm "
          f"(3D {err_off.mean() * 1e3:.1f} mm); with, after 3 frames: max |dz| "
          f"{np.abs(dz_on[3:]).max() * 1e3:.2f} mm, max 3D {err_on[3:].max() * 1e3:.2f} mm")
    assert not any(flags_off)
    assert flags_on[0] is False and flags_on[1] is False and all(flags_on[2:])  # needs two right centres
    assert 0.020 < np.abs(dz_off).mean() < 0.035  # ~27 mm (TECH_NOTES)
    assert np.abs(dz_on[3:]).max() < 0.003
    assert err_on[3:].max() < 0.003


def test_zero_skew_is_left_alone_and_repeated_frames_reuse(rig):
    rng = np.random.default_rng(6)
    perc = _perception(rig)
    p = _at_depth(rig, 0.5)
    frame = _frame(rig, 1, 0.0, [("red", p)], [("red", p)], rng)
    first = perc.process(frame)
    assert not first[0].skew_compensated
    again = perc.process(StereoFrame(seq=2, t=0.033, left=frame.left, right=frame.right, repeated=True))
    assert again == first
    assert perc.tracks[1].frames == 1


def test_blob_centre_is_sub_pixel(rig):
    """The thresholded outline's centroid steps with the pixel grid; the refined one does not."""
    from core.detect.stereo import blob_centre
    det = HsvDetector(HsvParams(colours=DEFAULT_COLOURS))
    raw, refined = [], []
    for k in range(16):
        img = np.full((80, 80, 3), (95, 100, 105), np.uint8)
        c = (40.0 + k / 16.0, 40.0 + k / 32.0)
        cv2.circle(img, (int(round(c[0] * 16)), int(round(c[1] * 16))), 18 * 16, BGR["blue"], -1, cv2.LINE_AA, 4)
        (d,) = det.detect(img)
        raw.append(np.linalg.norm(np.subtract(d.centre_px, c)))
        refined.append(np.linalg.norm(np.subtract(blob_centre(img, d), c)))
    print(f"blob centre error: outline mean {np.mean(raw):.3f} max {max(raw):.3f} px, "
          f"refined mean {np.mean(refined):.3f} max {max(refined):.3f} px")
    assert max(refined) < 0.07 and np.mean(refined) < np.mean(raw)


def test_a_tracker_box_is_re_placed_where_the_other_views_patch_matches():
    """stereo_matched_centre finds a ball's patch from one view in the other, to a fraction of a
    pixel, starting from a tracker box 3 px off (1 px of disparity is ~10 mm of depth at 50 cm)."""
    from core.detect.base import Detection
    from core.detect.stereo import stereo_matched_centre

    rng = np.random.default_rng(5)
    desk = cv2.GaussianBlur(rng.uniform(90, 160, (240, 320, 3)).astype(np.float32), (0, 0), 2.0)

    def ball_at(cx: float) -> np.ndarray:  # a plain red ball, anti-aliased at a sub-pixel place
        big = cv2.resize(desk, None, fx=8, fy=8, interpolation=cv2.INTER_NEAREST)
        cv2.circle(big, (int(round(cx * 8)), 120 * 8), 18 * 8, (40, 40, 200), -1)
        return cv2.resize(big, (320, 240), interpolation=cv2.INTER_AREA).clip(0, 255).astype(np.uint8)

    left_cx, disparity = 170.3, 23.6
    left, right = ball_at(left_cx), ball_at(left_cx - disparity)

    def det(cx: float) -> Detection:
        return Detection(kind="colour", label="red", score=0.5, box=(cx - 20, 100, 40, 40), centre_px=(cx, 120.0))

    off_by_3 = det(left_cx - disparity + 3.0)  # where a drifting tracker put it in the right view
    found = stereo_matched_centre(left, det(left_cx), right, off_by_3)
    assert found is not None
    assert abs(found[0] - (left_cx - disparity)) < 0.15 and abs(found[1] - 120.0) < 0.15, found
    # a patch that is not there (the other view shows only the desk) moves nothing
    assert stereo_matched_centre(left, det(left_cx), ball_at(-100.0), off_by_3) is None


def test_blob_centre_equals_the_plain_weighted_centroid():
    """blob_centre's OpenCV formulation (masked means, affine transform, moments) gives the plain
    numpy one's centres: anti-aliased discs and ellipses of every size, on textured backgrounds."""
    from core.detect import stereo

    def plain(image, d, grow_px=2):
        pts = np.round(d.contour).astype(np.int32)
        pad = grow_px + 4
        lo, hi = pts.min(axis=0) - pad, pts.max(axis=0) + pad + 1
        mask = np.zeros((int(hi[1] - lo[1]), int(hi[0] - lo[0])), np.uint8)
        cv2.drawContours(mask, [(pts - lo).reshape(-1, 1, 2)], 0, 255, -1)
        k3 = stereo._K3
        inner = cv2.erode(mask, k3, iterations=2)
        near = cv2.dilate(mask, k3, iterations=grow_px)
        ring = cv2.dilate(mask, k3, iterations=grow_px + 3) & ~cv2.dilate(mask, k3, iterations=grow_px + 1)
        patch = image[lo[1]:hi[1], lo[0]:hi[0]].astype(np.float64)
        fg, bg = patch[inner > 0].mean(axis=0), patch[ring > 0].mean(axis=0)
        span = fg - bg
        w = np.clip(((patch - bg) @ span) / float(span @ span), 0.0, 1.0)
        w[near == 0] = 0.0
        w[inner > 0] = 1.0
        ys, xs = np.mgrid[0:w.shape[0], 0:w.shape[1]]
        return lo[0] + (w * xs).sum() / w.sum(), lo[1] + (w * ys).sum() / w.sum()

    rng = np.random.default_rng(7)
    det = HsvDetector(HsvParams(colours=DEFAULT_COLOURS))
    compared = 0
    for _ in range(6):
        img = cv2.GaussianBlur(rng.integers(60, 140, (240, 320, 3), np.uint8), (0, 0), 2)
        for colour in BGR.values():
            c = (int(rng.uniform(40, 280) * 16), int(rng.uniform(40, 200) * 16))
            axes = (int(rng.uniform(6, 30) * 16), int(rng.uniform(6, 30) * 16))
            cv2.ellipse(img, c, axes, float(rng.uniform(0, 180)), 0, 360, colour, -1, cv2.LINE_AA, 4)
        for d in det.detect(img):
            got, want = stereo.blob_centre(img, d), plain(img, d)
            assert abs(got[0] - want[0]) < 1e-3 and abs(got[1] - want[1]) < 1e-3, (d.label, got, want)
            compared += 1
    assert compared >= 12


def test_a_tracks_remembered_size_and_image_velocity_follow_every_new_view():
    """A track keeps its size and image velocity between the many calls of one frame, and gives
    new ones as soon as a view is noted or its history changes (never a stale answer)."""
    from core.detect.base import Detection
    from core.detect.stereo import _ObjectTrack

    track = _ObjectTrack(1, "colour", "red", kalman=None, history=5)

    def seen(t, x, w):
        d = Detection(kind="colour", label="red", score=1.0, box=(x, 50.0, w, w), centre_px=(x + w / 2, 50 + w / 2))
        track.note_view("left", t, d, whole=True)
        track.left_hist.append((t, x + w / 2, 50 + w / 2))

    seen(0.0, 100.0, 20.0)
    assert track.size("left") == (20.0, 20.0) and track.image_velocity("left") is None
    seen(0.1, 110.0, 24.0)
    assert track.size("left") == (24.0, 24.0)
    assert np.allclose(track.image_velocity("left"), (120.0, 20.0))  # px/s: centre 110 → 122, 60 → 62
    assert track.size("left") == track.size("left") and track.image_velocity("left") is track.image_velocity("left")
    seen(0.2, 130.0, 22.0)  # faster; smaller than the largest of the recent sizes
    assert track.size("left") == (24.0, 24.0)
    assert track.image_velocity("left")[0] > 120.0
    track.left_hist.clear()
    track.left_hist.extend([(0.0, 10.0, 0.0), (0.1, 10.0, 0.0)])
    assert np.allclose(track.image_velocity("left"), (0.0, 0.0))
    for _ in range(5):  # a full deque: appending drops the oldest, same length, new ends
        seen(track.left_hist[-1][0] + 0.1, 130.0, 22.0)
    assert np.allclose(track.image_velocity("left"), (0.0, 0.0))
    seen(track.left_hist[-1][0] + 0.1, 140.0, 22.0)
    assert track.image_velocity("left")[0] > 0.0
