"""Calibration health: the median rectified vertical offset of matched markers, and its banner."""
import numpy as np
import pytest

from core.clock import SimClock
from core.messages import MarkerObservation, PerceptionResult
from core.sim.camera import SimStereoCamera
from core.sim.rig import rot_xyz
from core.vision.calibration import StereoCalibration
from core.vision.calibration_health import CalibrationHealth
from core.vision.perception import StereoMarkerPerception


def result(seq, *dys, found=True):
    markers = tuple(MarkerObservation(marker_id=i, found=found, epipolar_dy_px=dy) for i, dy in enumerate(dys))
    return PerceptionResult(seq=seq, t=seq / 30, markers=markers, timings_ms={}, full_frame_search=False)


def test_small_offsets_are_healthy_and_large_ones_say_drifted_with_the_number():
    h = CalibrationHealth(window=20, min_samples=5)
    for k in range(10):
        h.feed(result(k, 0.2, -0.3))
    assert not h.drifted and h.message() == "" and h.median_dy_px == pytest.approx(0.25)
    for k in range(10, 30):
        h.feed(result(k, 1.6, -1.4))
    status = h.status()
    assert status.drifted and status.median_dy_px == pytest.approx(1.5)
    assert status.message.startswith("calibration may have drifted") and "1.5 px" in status.message


def test_too_few_detections_say_nothing():
    h = CalibrationHealth(min_samples=10)
    h.feed(result(1, 5.0, 5.0))
    assert h.median_dy_px is None and not h.drifted and h.message() == ""


def test_lost_markers_and_repeated_results_do_not_count():
    h = CalibrationHealth(min_samples=1)
    h.feed(result(1, 3.0, found=False))
    assert h.samples == 0
    r = result(2, 0.5)
    h.feed(r)
    h.feed(r)
    h.feed(result(3, None))
    assert h.samples == 1
    h.reset()
    assert h.samples == 0


def test_settings_are_validated():
    with pytest.raises(ValueError, match="threshold_px"):
        CalibrationHealth(threshold_px=0)
    with pytest.raises(ValueError, match="min_samples"):
        CalibrationHealth(window=5, min_samples=6)


def _run(calibration, frames=20):
    cam = SimStereoCamera(scenario="static", clock=SimClock())
    perception = StereoMarkerPerception(calibration, cam.rig.base_T_camera)
    health = CalibrationHealth(window=60, min_samples=10)
    with cam:
        for _ in range(frames):
            health.feed(perception.process(cam.read()))
    return health


def test_the_exact_calibration_is_healthy_and_a_knocked_camera_is_noticed():
    exact = SimStereoCamera(clock=SimClock()).calibration()
    assert not _run(exact).drifted
    # the right camera tilted by 0.3° about its x axis since calibration: rows no longer agree
    c = exact
    knocked = StereoCalibration(M1=c.M1, D1=c.D1, M2=c.M2, D2=c.D2, R=rot_xyz(np.radians(0.3), 0, 0) @ c.R,
                                T=c.T, image_size=c.image_size)
    h = _run(knocked)
    assert h.drifted and h.median_dy_px > 1.0 and "drifted" in h.message()
