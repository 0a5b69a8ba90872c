"""Colour, circle and marker detectors on drawn frames and on the simulated desk."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from core.detect.base import Detection, Detector
from core.detect.circles import CircleDetector, CircleParams
from core.detect.colour import HsvDetector, HsvParams, HsvRange, colour_from_pixel, parse_hsv_range
from core.detect.markers import ArucoDetector, ArucoParams
from core.detect.registry import (
    DETECTORS, detector_names, make_detector, parse_detector_list, register_detector,
)
from core.settings import SettingsError

DATA = Path(__file__).resolve().parents[1] / "data"
DESK_BGR = (105, 140, 170)  # light wood, BGR
RED_BALL = ((200, 150), 30, (40, 40, 210))  # centre, radius px, BGR
YELLOW_BLOB = ((450, 330), 38, (40, 210, 230))
BLUE_DISC = ((520, 120), 22, (200, 90, 30))
MARKER_ID, MARKER_TL, MARKER_SIDE = 7, (300, 60), 96


def scene(seed: int = 1) -> np.ndarray:
    """640x480: a wood-coloured desk with noise, a red ball, a yellow blob, a blue disc, a marker."""
    img = np.empty((480, 640, 3), np.uint8)
    img[:] = DESK_BGR
    for (cx, cy), r, colour in (RED_BALL, YELLOW_BLOB, BLUE_DISC):
        cv2.circle(img, (cx, cy), r, colour, -1, cv2.LINE_AA)
    cv2.circle(img, (RED_BALL[0][0] - 8, RED_BALL[0][1] - 8), 8, (140, 140, 250), -1, cv2.LINE_AA)  # highlight
    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_6X6_250)
    marker = cv2.aruco.generateImageMarker(dictionary, MARKER_ID, MARKER_SIDE)
    x, y = MARKER_TL
    q = MARKER_SIDE // 6  # white quiet zone (generateImageMarker has none)
    img[y - q:y + MARKER_SIDE + q, x - q:x + MARKER_SIDE + q] = 255
    img[y:y + MARKER_SIDE, x:x + MARKER_SIDE] = marker[:, :, None]
    noise = np.zeros(img.shape, np.int16)
    cv2.setRNGSeed(seed)
    cv2.randn(noise, 0, 6)
    return np.clip(img.astype(np.int16) + noise, 0, 255).astype(np.uint8)


@pytest.fixture(scope="module")
def frame() -> np.ndarray:
    return scene()


def assert_close(a, b, tol, what=""):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert np.all(np.abs(a - b) <= tol), f"{what}: {a} vs {b} (tol {tol})"


# --- Detection and the Detector protocol -------------------------------------------------------
def test_every_detector_follows_the_protocol():
    for d in (HsvDetector(), CircleDetector(), ArucoDetector()):
        assert isinstance(d, Detector)
        assert d.name in DETECTORS


def test_a_detection_refuses_an_unknown_kind_and_a_score_outside_0_1():
    with pytest.raises(ValueError, match="kind"):
        Detection("thing", "x", 0.5, (0, 0, 1, 1), (0, 0))
    with pytest.raises(ValueError, match="score = 1.5 is outside the allowed range 0…1"):
        Detection("object", "cup", 1.5, (0, 0, 1, 1), (0, 0))


def test_a_detection_is_frozen_and_its_arrays_read_only():
    d = Detection("marker", "7", 1.0, (0, 0, 2, 2), (1, 1), corners=np.zeros((4, 2)))
    with pytest.raises(Exception):
        d.label = "8"
    with pytest.raises(ValueError):
        d.corners[0, 0] = 3.0


def test_detectors_refuse_non_images_and_rois_outside_the_image(frame):
    det = HsvDetector()
    with pytest.raises(ValueError, match="8-bit BGR"):
        det.detect(frame.astype(np.float32))
    with pytest.raises(ValueError, match="outside the 640x480 image"):
        det.detect(frame, roi=(700, 10, 50, 50))
    with pytest.raises(ValueError, match="positive width"):
        det.detect(frame, roi=(10, 10, 0, 50))


# --- colour ------------------------------------------------------------------------------------
def test_hsv_finds_the_red_ball_yellow_blob_and_blue_disc_largest_first(frame):
    found = HsvDetector().detect(frame)
    assert [d.label for d in found] == ["yellow", "red", "blue"]
    for d, ((cx, cy), r, _) in zip(found, (YELLOW_BLOB, RED_BALL, BLUE_DISC)):
        assert d.kind == "colour"
        assert_close(d.centre_px, (cx, cy), 1.0, d.label)
        assert_close(d.radius_px, r, 2.0, d.label)
        assert_close(d.box, (cx - r, cy - r, 2 * r + 1, 2 * r + 1), 2.0, d.label)
        assert d.score > 0.95
        assert d.contour.shape[1] == 2 and len(d.contour) >= 4


def test_red_wraps_around_hue_zero():
    red = HsvRange("red", 172, 120, 70, 8)
    assert red.wraps
    hsv = np.array([[[0, 200, 200], [5, 200, 200], [175, 200, 200], [90, 200, 200], [12, 200, 200]]], np.uint8)
    assert red.mask(hsv).ravel().tolist() == [255, 255, 255, 0, 0]


def test_min_area_and_max_objects_limit_the_blobs(frame):
    assert [d.label for d in HsvDetector(HsvParams(min_area_px=3000)).detect(frame)] == ["yellow"]
    two_red = frame.copy()
    cv2.circle(two_red, (80, 400), 12, (40, 40, 210), -1)
    reds = HsvDetector(HsvParams(colours=(HsvRange("red", 172, 120, 70, 8),))).detect(two_red)
    assert len(reds) == 2 and reds[0].radius_px > reds[1].radius_px
    only_one = HsvDetector(HsvParams(colours=(HsvRange("red", 172, 120, 70, 8),), max_objects=1)).detect(two_red)
    assert len(only_one) == 1 and only_one[0].centre_px == reds[0].centre_px


def test_roi_search_gives_the_full_frame_results_inside_it(frame):
    roi = (380, 260, 160, 150)  # around the yellow blob only
    for det in (HsvDetector(), CircleDetector(CircleParams(min_radius_px=15))):
        full = [d for d in det.detect(frame) if _inside(d, roi)]
        part = det.detect(frame, roi=roi)
        assert len(full) == len(part) == 1, (det.name, full, part)
        assert part[0].label == full[0].label
        assert_close(part[0].centre_px, full[0].centre_px, 0.01, det.name)
        assert_close(part[0].box, full[0].box, 0.01, det.name)


def test_aruco_roi_search_gives_the_full_frame_marker(frame):
    det = ArucoDetector()
    roi = (270, 30, 160, 160)
    full, part = det.detect(frame), det.detect(frame, roi=roi)
    assert [d.label for d in part] == [d.label for d in full] == [str(MARKER_ID)]
    assert_close(part[0].corners, full[0].corners, 0.05, "corners")


def _inside(d: Detection, roi) -> bool:
    x, y, w, h = d.box
    rx, ry, rw, rh = roi
    return rx <= x and ry <= y and x + w <= rx + rw and y + h <= ry + rh


def test_a_tapped_pixel_picks_the_colour_of_that_object(frame):
    for (cx, cy), r, _ in (RED_BALL, YELLOW_BLOB, BLUE_DISC):
        picked = colour_from_pixel(frame, cx + r // 3, cy + r // 3, name="mine")
        found = HsvDetector(HsvParams(colours=(picked,))).detect(frame)
        assert found, picked
        assert_close(found[0].centre_px, (cx, cy), 1.5, picked.text())
        assert len(found) == 1, (picked, [d.centre_px for d in found])


def test_a_tapped_red_pixel_gives_a_range_wrapping_through_zero():
    hsv = np.zeros((20, 20, 3), np.uint8)
    hsv[:] = (2, 200, 210)
    hsv[:, 10:] = (177, 200, 210)  # half the patch on each side of hue 0
    picked = colour_from_pixel(cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR), 10, 10, tolerance=6)
    assert picked.wraps and 170 <= picked.h_lo <= 179 and 0 <= picked.h_hi <= 9, picked


def test_a_tapped_grey_pixel_accepts_any_hue_but_only_low_saturation():
    img = np.full((10, 10, 3), 128, np.uint8)
    picked = colour_from_pixel(img, 5, 5)
    assert (picked.h_lo, picked.h_hi, picked.s_lo) == (0, 179, 0) and picked.s_hi <= 45
    with pytest.raises(ValueError, match="pixel \\(12, 3\\) is outside the 10x10 image"):
        colour_from_pixel(img, 12, 3)


def test_hsv_ranges_parse_and_print_the_cli_format():
    r = parse_hsv_range("ball=170,120,70,8,255,255")
    assert r == HsvRange("ball", 170, 120, 70, 8, 255, 255)
    assert parse_hsv_range(r.text()) == r
    with pytest.raises(ValueError, match="NAME=HLO,SLO,VLO,HHI,SHI,VHI"):
        parse_hsv_range("ball=1,2,3")
    with pytest.raises(ValueError, match="h_hi = 200 is outside the allowed range 0…179"):
        parse_hsv_range("ball=1,2,3,200,5,6")


@pytest.mark.parametrize("changes, message", [
    ({"min_area_px": -1}, "hsv.min_area_px = -1 is outside the allowed range 0.0…10000000.0"),
    ({"open_px": 40}, "hsv.open_px = 40 is outside the allowed range 0…31"),
    ({"max_objects": 0}, "hsv.max_objects = 0 is outside the allowed range 1…1000"),
    ({"colours": ()}, "hsv.colours is empty"),
])
def test_hsv_settings_name_the_field_and_range(changes, message):
    with pytest.raises(SettingsError, match=message.replace(".", r"\.").replace("(", r"\(")):
        HsvDetector().with_params(**changes)


def test_hsv_range_refuses_inverted_saturation_and_duplicate_names():
    with pytest.raises(SettingsError, match="s_lo = 200 is above s_hi = 100"):
        HsvRange("x", 10, 200, 0, 20, 100, 255)
    with pytest.raises(SettingsError, match="names red more than once"):
        HsvParams(colours=(HsvRange("red", 0, 1, 1, 5), HsvRange("red", 1, 1, 1, 5)))


# --- circles -----------------------------------------------------------------------------------
@pytest.mark.parametrize("params", [
    CircleParams(min_radius_px=15),
    CircleParams(method="HOUGH_GRADIENT_ALT", param1=300, param2=0.8, min_radius_px=15),
])
def test_circles_find_the_three_discs_largest_first(frame, params):
    found = CircleDetector(params).detect(frame)
    expected = sorted((YELLOW_BLOB, RED_BALL, BLUE_DISC), key=lambda c: -c[1])
    assert len(found) == 3, [(d.centre_px, d.radius_px) for d in found]
    for d, ((cx, cy), r, _) in zip(found, expected):
        assert d.kind == "circle"
        assert_close(d.centre_px, (cx, cy), 2.5, params.method)
        assert_close(d.radius_px, r, 2.5, params.method)
        assert d.score > 0.8


def test_circles_on_an_empty_desk_find_nothing():
    assert CircleDetector().detect(np.full((240, 320, 3), DESK_BGR, np.uint8)) == []


@pytest.mark.parametrize("changes, message", [
    ({"method": "HOUGH_STANDARD"}, "circles.method = 'HOUGH_STANDARD' must be one of"),
    ({"dp": 0.5}, "circles.dp = 0.5 is outside the allowed range 1.0…4.0"),
    ({"blur_px": 4}, "circles.blur_px = 4 must be odd"),
    ({"method": "HOUGH_GRADIENT_ALT"}, "circles.param2 = 30.0 is outside the allowed range 0.01…1.0"),
    ({"min_radius_px": 20, "max_radius_px": 10}, "circles.max_radius_px = 10 is outside the allowed range 20…10000"),
])
def test_circle_settings_name_the_field_and_range(changes, message):
    with pytest.raises(SettingsError, match=message.replace(".", r"\.").replace("(", r"\(")):
        CircleDetector().with_params(**changes)


# --- markers -----------------------------------------------------------------------------------
def test_aruco_adapter_returns_the_marker_with_its_corners(frame):
    found = ArucoDetector().detect(frame)
    assert len(found) == 1
    d = found[0]
    x, y = MARKER_TL
    s = MARKER_SIDE
    assert (d.kind, d.label, d.score) == ("marker", str(MARKER_ID), 1.0)
    assert_close(d.corners, [(x, y), (x + s, y), (x + s, y + s), (x, y + s)], 1.5, "corners")
    assert_close(d.centre_px, (x + s / 2, y + s / 2), 1.0, "centre")
    assert_close(d.box, (x, y, s, s), 1.5, "box")


def test_aruco_ids_filter_and_dictionary_validation(frame):
    assert ArucoDetector(ArucoParams(ids=(8,))).detect(frame) == []
    assert ArucoDetector(ArucoParams(dictionary="DICT_4X4_50")).detect(frame) == []
    with pytest.raises(SettingsError, match="aruco.dictionary: unknown ArUco dictionary 'DICT_9X9'"):
        ArucoParams(dictionary="DICT_9X9")
    with pytest.raises(SettingsError, match=r"aruco.ids \[300\] are outside the allowed range 0…249"):
        ArucoParams(ids=(300,))


# --- the simulated desk ------------------------------------------------------------------------
def test_the_simulated_ball_is_found_by_colour_circles_and_a_tap():
    from core.sim.desk import SimDesk
    from core.sim.rig import SimRig

    rig = SimRig()
    desk = SimDesk(rig, "cups")
    left, _, truth = desk.render(1.5)  # the show: the ball is visible
    ball = truth.by_id()[-1]
    u, v = rig.project("left", np.array(ball.base_p_centre))[0]
    reds = HsvDetector(HsvParams(colours=(HsvRange("red", 172, 120, 70, 8),), min_area_px=10)).detect(left)
    assert reds and np.hypot(reds[0].centre_px[0] - u, reds[0].centre_px[1] - v) < 2.0, (reds[:1], u, v)
    r = reds[0].radius_px
    roi = (u - 3 * r, v - 3 * r, 6 * r, 6 * r)
    circles = CircleDetector(CircleParams(min_radius_px=max(3, int(r * 0.6)), max_radius_px=int(r * 1.5) + 2,
                                          min_dist_px=r, param2=15)).detect(left, roi=roi)
    assert circles and np.hypot(circles[0].centre_px[0] - u, circles[0].centre_px[1] - v) < 2.0, (circles, u, v)
    picked = colour_from_pixel(left, u, v)
    tapped = HsvDetector(HsvParams(colours=(picked,), min_area_px=10)).detect(left)
    assert tapped and np.hypot(tapped[0].centre_px[0] - u, tapped[0].centre_px[1] - v) < 2.0, (picked, tapped[:1])
    markers = ArucoDetector().detect(left)
    assert {"23", "50"} <= {d.label for d in markers}


# --- registry ----------------------------------------------------------------------------------
def test_the_registry_names_the_builtins_and_reserves_onnx():
    # the built-ins first, then any registered later (another detector may join), "onnx:PATH" last
    assert DETECTORS[:3] == ("aruco", "hsv", "circles") and DETECTORS[-1] == "onnx:PATH"
    assert parse_detector_list(" aruco, hsv ") == ["aruco", "hsv"]
    assert parse_detector_list("onnx:models/cups.onnx,circles") == ["onnx:models/cups.onnx", "circles"]


@pytest.mark.parametrize("text, message", [
    ("", "no detector given; valid: aruco, hsv, circles, (.+, )?onnx:PATH"),
    ("aruco,,hsv", "has an empty item"),
    ("aruco,yolo", "unknown detector 'yolo'; valid: aruco, hsv, circles, (.+, )?onnx:PATH"),
    ("hsv,hsv", "detector hsv is listed twice"),
    ("onnx:", "needs something after the colon, e.g. onnx:PATH"),
])
def test_bad_detector_lists_say_what_is_wrong(text, message):
    with pytest.raises(ValueError, match=message):
        parse_detector_list(text)


def test_make_detector_passes_options_and_names_unknown_ones():
    det = make_detector("hsv", colours=["ball=170,120,70,8,255,255"], min_area_px=5)
    assert [c.name for c in det.params.colours] == ["ball"] and det.params.min_area_px == 5
    assert make_detector("circles", method="HOUGH_GRADIENT_ALT", param2=0.9).params.param2 == 0.9
    assert make_detector("aruco", dictionary="DICT_APRILTAG_36H11").params.dictionary == "DICT_APRILTAG_36h11"
    with pytest.raises(ValueError, match="hsv detector has no option colors; valid: colours"):
        make_detector("hsv", colors=[])


def test_a_factory_registered_by_prefix_gets_the_text_after_the_colon():
    seen = []

    def factory(arg, **options):
        seen.append((arg, options))
        return HsvDetector()

    register_detector("fake", factory, prefix=True)
    try:
        assert "fake:ARG" in detector_names()
        assert isinstance(make_detector("fake:some/where.bin", threshold=0.3), HsvDetector)
        assert seen == [("some/where.bin", {"threshold": 0.3})]
    finally:
        from core.detect import registry
        registry._PREFIXED.pop("fake")


def test_onnx_names_load_the_onnx_module_lazily():
    """"onnx:PATH" resolves to core.detect.onnx_yolo.OnnxYoloDetector only when asked for."""
    import importlib.util

    if importlib.util.find_spec("core.detect.onnx_yolo") is None:
        with pytest.raises(ValueError, match="not available"):
            make_detector("onnx:model.onnx")
    else:
        with pytest.raises((OSError, ValueError)):
            make_detector("onnx:/no/such/model.onnx")
