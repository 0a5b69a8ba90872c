"""The detectors on real webcam photos: tests/data/stereo_7x5_320x240 (two cheap USB webcams,
320x240, a person holding a 7x5 chessboard in a bright orange tray; 9 pairs).

Real data, so the checks are what these photos support, with the measured figures printed:
- the tray's colour picked at one tray pixel (``colour_from_pixel``) finds the tray as the
  largest blob of every image, and its box holds every chessboard corner;
- ``CircleDetector`` with its defaults reports no circle anywhere near the tray's size (it does
  report smaller false circles on the chessboard and the background: a detector's limits);
- with the stereo calibration from these very pairs, ``StereoObjectPerception`` triangulates the
  tray's centre near the chessboard's triangulated centre. The tray is cut by the image border
  in every pair (the board fills the view), differently in the two views, which moves the
  blob's centroid: four pairs are held to 3 cm, every pair's figure is printed.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from core.detect.circles import CircleDetector
from core.detect.colour import HsvDetector, HsvParams, colour_from_pixel
from core.detect.stereo import StereoObjectPerception
from core.messages import StereoFrame
from core.vision.stereo_calibration import ChessboardSpec, calibrate_stereo, detect_pair

REAL = Path(__file__).resolve().parents[1] / "data" / "stereo_7x5_320x240"
BOARD_7x5 = ChessboardSpec(7, 5, 0.025)  # square size unknown: 25 mm, as the calibration tests
TRAY_PIXEL = (20, 120)  # left01.jpg: the tray's left rim
TRAY_TOLERANCE = 4  # hue ± 4: ± 10 also takes in the face and the arms next to the tray


@pytest.fixture(scope="module")
def pairs():
    lefts = sorted(REAL.glob("left*.jpg"))
    assert len(lefts) >= 8, "tests/data/stereo_7x5_320x240 is missing"
    return [(cv2.imread(str(p)), cv2.imread(str(p.with_name(p.name.replace("left", "right"))))) for p in lefts]


@pytest.fixture(scope="module")
def boards(pairs):
    found = [detect_pair(left, right, BOARD_7x5) for left, right in pairs]
    assert all(p.ok for p in found), [p.reason for p in found]
    return found


@pytest.fixture(scope="module")
def tray_detector(pairs):
    tray = colour_from_pixel(pairs[0][0], *TRAY_PIXEL, tolerance=TRAY_TOLERANCE, name="tray")
    assert tray.s_lo > 80 and (tray.h_lo < 20 or tray.wraps), tray  # a saturated orange
    return HsvDetector(HsvParams(colours=(tray,)))


def _edges_touched(box, shape) -> int:
    x, y, w, h = box
    H, W = shape[:2]
    return int(x <= 0) + int(y <= 0) + int(x + w >= W) + int(y + h >= H)


def test_the_picked_tray_colour_finds_the_tray_around_every_corner(pairs, boards, tray_detector):
    for k, ((left, right), board) in enumerate(zip(pairs, boards)):
        for side, image, found in (("left", left, board.left), ("right", right, board.right)):
            dets = tray_detector.detect(image)
            assert dets, f"pair {k + 1} {side}: no tray blob"
            tray = dets[0]  # largest first
            x, y, w, h = tray.box
            corners = found.corners.reshape(-1, 2)
            inside = ((corners[:, 0] >= x) & (corners[:, 0] <= x + w) & (corners[:, 1] >= y)
                      & (corners[:, 1] <= y + h))
            assert inside.all(), f"pair {k + 1} {side}: {int((~inside).sum())} corners outside the tray box {tray.box}"
            # the board is most of the tray: the blob is much larger than the board's corner spread
            span = corners.max(axis=0) - corners.min(axis=0)
            assert w > span[0] and h > span[1]


def test_circles_report_nothing_of_the_trays_size(pairs, tray_detector):
    circles = CircleDetector()
    largest, false_circles = 0.0, 0
    for left, right in pairs:
        for image in (left, right):
            tray = tray_detector.detect(image)[0]
            found = circles.detect(image)
            false_circles += len(found)
            for c in found:
                largest = max(largest, c.radius_px)
                assert c.radius_px < 0.25 * min(tray.box[2], tray.box[3]), (c.radius_px, tray.box)
    print(f"circles on {2 * len(pairs)} real images: {false_circles} circles (chessboard squares, background), "
          f"largest radius {largest:.0f} px; tray boxes ≥ 200 px")


def test_the_tray_centre_triangulates_near_the_board_centre(pairs, boards, tray_detector):
    report = calibrate_stereo(boards, board=BOARD_7x5)
    assert report.ok, report.problems
    # camera_left is the base frame here; no desk in these photos, so no desk check
    perception = StereoObjectPerception(report.calibration, np.eye(4), [tray_detector], desk_check=False,
                                        min_hits=1, max_dy_px=6.0)
    errors = []
    for k, ((left, right), board) in enumerate(zip(pairs, boards)):
        perception.reset()
        obs = perception.process(StereoFrame(seq=k, t=0.0, left=left, right=right))
        rl = perception.geometry.rectify_points("left", board.left_points.reshape(-1, 2))
        rr = perception.geometry.rectify_points("right", board.right_points.reshape(-1, 2))
        board_centre = perception.geometry.triangulate_rectified(rl, rr).mean(axis=0)
        tray_l, tray_r = tray_detector.detect(left)[0], tray_detector.detect(right)[0]
        cut = max(_edges_touched(tray_l.box, left.shape), _edges_touched(tray_r.box, right.shape))
        tray_obs = [o for o in obs if o.left is not None and o.left.box == tray_l.box and o.triangulated]
        if not tray_obs:
            print(f"pair {k + 1}: tray not paired across the views (cut by {cut} image edges)")
            errors.append((k, None, cut))
            continue
        err = float(np.linalg.norm(np.subtract(tray_obs[0].camera_p, board_centre)))
        print(f"pair {k + 1}: tray centre {err * 1e3:.0f} mm from the board centre at "
              f"{board_centre[2] * 1e3:.0f} mm depth; cut by {cut} image edges, dy {tray_obs[0].epipolar_dy_px:+.2f} px")
        errors.append((k, err, cut))
    paired = [e for _, e, _ in errors if e is not None]
    # measured: 8 of 9 pairs paired; 18, 22, 23, 24 mm where the tray is cut little, 47–80 mm where
    # more, 179 mm for pair 2 (its right view cuts the tray's left third off)
    assert len(paired) >= len(pairs) - 2, errors
    assert sum(e < 0.03 for e in paired) >= 4, errors
    assert max(paired) < 0.25, errors
