"""Round things seen obliquely: CircleDetector's ellipse path, and a colour blob fused with the
ellipse of its top (``fuse_round_tops``).

Drawn frames (ellipses on a wood-like texture) for the geometry, and the simulated desk's
``objects`` scenario for what matters: the discs' and cups' tops found in both views, nothing
on the wood or the marker cards.
"""
from __future__ import annotations

import itertools
import math

import cv2
import numpy as np
import pytest

from core.detect.base import Detection
from core.detect.circles import CircleDetector, CircleParams, ellipse_points
from core.detect.stereo import fuse_round_tops
from core.settings import SettingsError

W, H = 640, 480


def _wood(seed: int = 7, size=(W, H)) -> np.ndarray:
    """Brown wood-ish texture: slow blotches and stretched grain (edges for Canny to find)."""
    w, h = size
    rng = np.random.default_rng(seed)
    coarse = cv2.resize(rng.uniform(0, 1, (10, 14)).astype(np.float32), (w, h), interpolation=cv2.INTER_CUBIC)
    grain = cv2.GaussianBlur(rng.normal(0, 1, (h, w)).astype(np.float32), (0, 0), sigmaX=12, sigmaY=1.0)
    v = 120 + 30 * coarse + 25 * grain
    return np.dstack([v * 0.45, v * 0.7, v]).clip(0, 255).astype(np.uint8)


def _ellipse(img, centre, axes, angle_deg, colour, scale: int = 16) -> None:
    """A filled, anti-aliased ellipse: ``axes`` are the semi-axes (px), ``angle_deg`` that of the first."""
    c = (round(centre[0] * scale), round(centre[1] * scale))
    a = (round(axes[0] * scale), round(axes[1] * scale))
    cv2.ellipse(img, c, a, angle_deg, 0, 360, colour, -1, cv2.LINE_AA, 4)


def _cylinder(img, centre, a, b, height_px, side_bgr, top_bgr) -> None:
    """An upright cylinder seen from above at an angle: its side (a band ``height_px`` tall) and
    its elliptic top (semi-axes a across, b along the view) at ``centre``."""
    cx, cy = centre
    _ellipse(img, (cx, cy + height_px), (a, b), 0, side_bgr)
    cv2.rectangle(img, (round(cx - a), round(cy)), (round(cx + a), round(cy + height_px)),
                  side_bgr, -1)
    _ellipse(img, (cx, cy), (a, b), 0, top_bgr)


def _nearest(found, point):
    return min(found, key=lambda d: math.hypot(d.centre_px[0] - point[0], d.centre_px[1] - point[1]))


def test_an_oblique_disc_is_found_as_an_ellipse_with_its_outline():
    img = _wood()
    _ellipse(img, (300.3, 220.6), (40, 27), 20, (40, 120, 235))  # aspect 0.68, tilted 20°
    found = CircleDetector().detect(img)
    assert found, "no ellipse found"
    d = _nearest(found, (300.3, 220.6))
    assert (d.kind, d.label) == ("circle", "circle")
    assert math.hypot(d.centre_px[0] - 300.3, d.centre_px[1] - 220.6) < 1.0, d.centre_px
    assert abs(d.radius_px - 40) < 2.0  # the semi-major axis
    assert d.score > 0.9
    assert d.contour is not None and d.contour.shape == (36, 2)
    # the outline is the ellipse: its box and aspect
    x, y, w, h = d.box
    assert x < 300.3 < x + w and y < 220.6 < y + h
    ev = np.linalg.eigvalsh(np.cov((d.contour - d.contour.mean(axis=0)).T))
    assert abs(math.sqrt(ev[0] / ev[1]) - 27 / 40) < 0.05


def test_hough_circles_miss_the_oblique_disc_that_the_ellipses_find():
    img = _wood()
    _ellipse(img, (300.0, 220.0), (40, 24), 0, (40, 120, 235))  # aspect 0.6
    hough = CircleDetector(CircleParams(ellipses=False, min_radius_px=15)).detect(img)
    assert not any(math.hypot(d.centre_px[0] - 300, d.centre_px[1] - 220) < 3 and abs(d.radius_px - 40) < 4
                   for d in hough)
    assert any(math.hypot(d.centre_px[0] - 300, d.centre_px[1] - 220) < 1 for d in CircleDetector().detect(img))


def test_min_aspect_keeps_flat_ellipses_out():
    img = _wood()
    _ellipse(img, (320.0, 240.0), (60, 18), 0, (30, 200, 230))  # aspect 0.3, like the plush
    near = lambda found: [d for d in found if math.hypot(d.centre_px[0] - 320, d.centre_px[1] - 240) < 3]
    assert near(CircleDetector(CircleParams(min_aspect=0.2)).detect(img))
    assert not near(CircleDetector().detect(img))  # default min_aspect 0.5


def test_a_cylinder_gives_one_ellipse_its_top_not_its_outline():
    img = _wood()
    _cylinder(img, (320.0, 200.0), 36, 25, 40, (90, 30, 80), (170, 90, 160))
    found = [d for d in CircleDetector().detect(img) if 250 < d.centre_px[0] < 390 and 150 < d.centre_px[1] < 290]
    assert len(found) == 1, [(d.centre_px, d.radius_px, d.score) for d in found]
    assert math.hypot(found[0].centre_px[0] - 320, found[0].centre_px[1] - 200) < 1.5, found[0].centre_px


def test_largest_first_and_the_radius_range():
    img = _wood()
    for centre, axes in (((150.0, 150.0), (20, 15)), ((400.0, 300.0), (50, 36)), ((480.0, 120.0), (32, 24))):
        _ellipse(img, centre, axes, 0, (235, 235, 235))  # white cups' tops (EdgeDrawing runs on grey)
    found = CircleDetector().detect(img)
    radii = [d.radius_px for d in found]
    assert radii == sorted(radii, reverse=True)
    assert len(found) >= 3 and abs(found[0].radius_px - 50) < 2
    capped = CircleDetector(CircleParams(max_radius_px=40)).detect(img)
    assert capped and max(d.radius_px for d in capped) < 40
    assert len(CircleDetector(CircleParams(max_objects=1)).detect(img)) == 1


def test_a_large_image_is_downscaled_and_still_found_in_full_size_px():
    img = _wood(size=(1600, 1200))
    _ellipse(img, (820.0, 610.0), (110, 75), 10, (40, 120, 235))
    found = CircleDetector(CircleParams(max_side_px=800)).detect(img)
    d = _nearest(found, (820, 610))
    assert math.hypot(d.centre_px[0] - 820, d.centre_px[1] - 610) < 2.0
    assert abs(d.radius_px - 110) < 4.0


def test_ellipses_in_a_roi_come_back_in_full_image_px():
    img = _wood()
    _ellipse(img, (300.0, 220.0), (40, 27), 0, (40, 120, 235))
    found = CircleDetector().detect(img, roi=(230, 160, 140, 120))
    assert found and math.hypot(found[0].centre_px[0] - 300, found[0].centre_px[1] - 220) < 1.0


def test_bare_wood_gives_no_ellipse():
    assert CircleDetector().detect(_wood(seed=3)) == []


@pytest.mark.parametrize("changes, message", [
    ({"min_aspect": 0.0}, "circles.min_aspect = 0.0 is outside the allowed range 0.05…1.0"),
    ({"max_side_px": 10}, "circles.max_side_px = 10 is outside the allowed range 64…10000"),
    ({"ellipses": "yes"}, "circles.ellipses = 'yes' must be true or false"),
])
def test_ellipse_settings_name_the_field_and_range(changes, message):
    with pytest.raises(SettingsError, match=message.replace(".", r"\.")):
        CircleDetector().with_params(**changes)


def test_ellipse_points_lie_on_the_ellipse():
    pts = ellipse_points(10.0, 20.0, 5.0, 2.0, math.radians(30), 12)
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    u = (pts[:, 0] - 10) * c + (pts[:, 1] - 20) * s
    v = -(pts[:, 0] - 10) * s + (pts[:, 1] - 20) * c
    assert np.allclose((u / 5) ** 2 + (v / 2) ** 2, 1.0)


# --- the simulated desk -------------------------------------------------------------------------
@pytest.fixture(scope="module")
def desk_views():
    from core.sim.desk import SimDesk
    from core.sim.rig import SimRig

    rig = SimRig()
    desk = SimDesk(rig, "objects")
    arm = np.array([[0, 0, 0], [0, 0, 0.066], [0, 0, 0.191], [0.09, 0, 0.191]])  # the arm at home
    views = []
    for t in (0.4, 3.3):  # the hand is away
        left, right, truth = desk.render(t, arm)
        boxes = desk.image_boxes(t, arm)
        for side, img in (("left", left), ("right", right)):
            points = {o.marker_id: rig.project(side, np.array(o.base_p_centre))[0] for o in truth.objects}
            arm_px = rig.project(side, arm)
            views.append((side, img, boxes[side], points, arm_px))
    return views


def _near_arm(p, arm_px, within=45.0) -> bool:
    for a, b in itertools.pairwise(arm_px):
        ab = b - a
        s = np.clip(np.dot(p - a, ab) / max(float(ab @ ab), 1e-9), 0, 1)
        if np.linalg.norm(p - (a + s * ab)) < within:
            return True
    return False


def test_the_objects_discs_and_cups_tops_are_found_in_both_views_and_nothing_on_the_wood(desk_views):
    detector = CircleDetector()
    for side, img, boxes, points, arm_px in desk_views:
        found = detector.detect(img)
        for label in ("orange disc", "purple disc", "white cup", "pink cup"):
            box = next(b for b in boxes.values() if b.label == label)
            p = points[box.truth_id]
            tol = max(4.0, 0.06 * max(box.x1 - box.x0, box.y1 - box.y0))
            assert any(math.hypot(d.centre_px[0] - p[0], d.centre_px[1] - p[1]) < tol for d in found), \
                (side, label, p, [(d.centre_px, d.radius_px) for d in found])
            # one ellipse per object: not also the cylinder's whole outline or the cup's rim
            on_it = [d for d in found if box.x0 <= d.centre_px[0] <= box.x1 and box.y0 <= d.centre_px[1] <= box.y1]
            assert len(on_it) == 1, (side, label, [(d.centre_px, d.radius_px, d.score) for d in on_it])
        for d in found:  # on a truth object (a round thing, the plush, a card) or on the arm, not the wood
            c = np.array(d.centre_px)
            on_object = any(b.x0 <= c[0] <= b.x1 and b.y0 <= c[1] <= b.y1 for b in boxes.values())
            assert on_object or _near_arm(c, arm_px), (side, d.centre_px, d.radius_px, d.score)
            on_card = any(b.kind == "marker" and b.x0 <= c[0] <= b.x1 and b.y0 <= c[1] <= b.y1 for b in boxes.values())
            assert not on_card, (side, d.centre_px)


# --- fusing a colour blob with the ellipse of its top ---------------------------------------------
def _blob(label, box, contour=None) -> Detection:
    x, y, w, h = box
    if contour is None:
        contour = [(x, y), (x + w, y), (x + w, y + h), (x, y + h)]
    return Detection(kind="colour", label=label, score=0.95, box=box, centre_px=(x + w / 2, y + h / 2),
                     radius_px=0.5 * math.hypot(w, h), contour=np.array(contour, float))


def _round(centre, a, b, score=0.9) -> Detection:
    pts = ellipse_points(centre[0], centre[1], a, b, 0.0, 36)
    return Detection(kind="circle", label="circle", score=score, box=(centre[0] - a, centre[1] - b, 2 * a, 2 * b),
                     centre_px=centre, radius_px=a, contour=pts)


def test_a_blob_takes_the_centre_of_its_oblique_top_and_the_ellipse_goes():
    blob = _blob("purple", (100, 100, 60, 70))  # top and side
    top = _round((130.0, 122.0), 28, 20)  # aspect 0.71, in the blob's upper part
    elsewhere = _round((400.0, 300.0), 20, 15)  # a white cup: nothing coloured there
    out, fused = fuse_round_tops([blob, top, elsewhere])
    assert len(out) == 2
    purple = next(d for d in out if d.label == "purple")
    assert purple.centre_px == (130.0, 122.0) and purple.box == blob.box and purple.radius_px == blob.radius_px
    assert id(purple) in fused and purple.score == pytest.approx(0.9)
    assert any(d is elsewhere for d in out)


def test_a_balls_round_outline_merges_into_its_blob_without_moving_it():
    blob = _blob("red", (200, 200, 40, 40))
    outline = _round((220.0, 219.0), 19, 19)  # a circle: a ball, not a top seen obliquely
    out, fused = fuse_round_tops([blob, outline])
    assert out == [blob] and not fused


def test_without_circles_or_blobs_nothing_changes():
    blob, ring = _blob("red", (200, 200, 40, 40)), _round((400.0, 100.0), 20, 14)
    assert fuse_round_tops([blob]) == ([blob], set())
    assert fuse_round_tops([ring]) == ([ring], set())
    far = _round((100.0, 400.0), 20, 14)
    out, fused = fuse_round_tops([blob, far])
    assert out == [blob, far] and not fused
