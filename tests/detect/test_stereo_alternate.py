"""A heavy detector (a network a view) runs in one view a frame between full searches: the right
view's boxes are the tracks' predicted boxes placed by the left view's patch (issue 28: the desk
detector in a Raspberry Pi 4 core's budget). Same ids, 3D positions as close to the truth."""
from __future__ import annotations

import numpy as np

from core.detect.colour import DEFAULT_COLOURS, HsvDetector, HsvParams
from core.detect.stereo import StereoObjectPerception
from test_stereo_roi import _frame, _moving, _tri, desk, rig  # noqa: F401 (pytest fixtures)


class Heavy:
    """The HSV detector dressed as a heavy one, counting the images it is given."""

    heavy = True

    def __init__(self):
        self.inner = HsvDetector(HsvParams(colours=DEFAULT_COLOURS))
        self.name, self.images = "heavy hsv", 0

    def detect(self, image, roi=None):
        self.images += 1
        return self.inner.detect(image, roi)


def _perception(rig, detector, **kw) -> StereoObjectPerception:
    return StereoObjectPerception(rig.calibration(), rig.base_T_camera, [detector], min_hits=2, **kw)


def test_heavy_detectors_search_one_view_a_frame_and_measure_as_both_views_do(rig, desk):  # noqa: F811
    rng_a, rng_b = np.random.default_rng(6), np.random.default_rng(6)
    heavy = Heavy()
    both = _perception(rig, HsvDetector(HsvParams(colours=DEFAULT_COLOURS)))
    one = _perception(rig, heavy, full_frame_every=10)
    assert one.alternating and not both.alternating  # an ordinary detector: both views every frame
    per_frame, errors_one, errors_both = [], [], []
    for k in range(60):
        truth = dict(_moving(k))
        a = _tri(both.process(_frame(rig, desk, k, _moving(k), rng_a)))
        before = heavy.images
        b = _tri(one.process(_frame(rig, desk, k, _moving(k), rng_b)))
        per_frame.append(heavy.images - before)
        assert [(o.object_id, o.label) for o in a] == [(o.object_id, o.label) for o in b], k
        errors_both += [np.linalg.norm(np.subtract(o.base_p, truth[o.label.split()[0]])) for o in a]
        errors_one += [np.linalg.norm(np.subtract(o.base_p, truth[o.label.split()[0]])) for o in b]
    assert per_frame[:2] == [2, 2]  # no tracks yet, then tentative ones: both views
    assert per_frame.count(1) >= 45 and set(per_frame) <= {1, 2}, per_frame  # a full search every 10th frame
    print(f"one view a frame: 3D error p95 {np.percentile(errors_one, 95) * 1e3:.2f} mm "
          f"(both views {np.percentile(errors_both, 95) * 1e3:.2f} mm)")
    assert np.percentile(errors_one, 95) <= max(1.5 * np.percentile(errors_both, 95), 0.003)


def test_a_missed_track_brings_both_views_back_until_it_is_found_or_dropped(rig, desk):  # noqa: F811
    rng = np.random.default_rng(7)
    heavy = Heavy()
    perc = _perception(rig, heavy, full_frame_every=10)
    per_frame = []
    for k in range(30):
        balls = _moving(k) if not 12 <= k < 16 else _moving(k)[1:]  # the red ball gone for 4 frames
        before = heavy.images
        obs = perc.process(_frame(rig, desk, k, balls, rng))
        per_frame.append(heavy.images - before)
    assert per_frame[5:12].count(1) >= 5
    assert per_frame[13:17] == [2, 2, 2, 2]  # red missed: both views (the frame it vanished was searched in one)
    assert {o.label.split()[0] for o in _tri(obs)} == {"red", "blue", "green"}
    assert perc.alternate_views is None and not _perception(rig, heavy, alternate_views=False).alternating
