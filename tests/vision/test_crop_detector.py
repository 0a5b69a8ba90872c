"""CropDetector: an ArUco detector for a crop keeps the full frame's smallest marker in pixels."""
import cv2
import numpy as np

from core.detect.markers import ArucoDetector
from core.vision.perception import CropDetector, make_detector


def test_the_crop_rate_scales_with_the_crop_and_is_cached():
    source = make_detector("DICT_6X6_250", fast=True)
    base = source.getDetectorParameters().minMarkerPerimeterRate
    crops = CropDetector()
    d1 = crops.for_crop(source, 640, 160)
    assert np.isclose(d1.getDetectorParameters().minMarkerPerimeterRate, base * 4)
    assert crops.for_crop(source, 640, 160) is d1  # the same rate: nothing rebuilt
    tiny = crops.for_crop(source, 640, 1)  # capped at the maximum rate
    p = tiny.getDetectorParameters()
    assert p.minMarkerPerimeterRate == p.maxMarkerPerimeterRate
    assert source.getDetectorParameters().minMarkerPerimeterRate == base  # the source is untouched


def test_an_aruco_roi_search_finds_what_the_full_frame_finds_in_its_window():
    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_6X6_250)
    image = np.full((480, 640, 3), 255, np.uint8)
    image[300:324, 300:324] = cv2.cvtColor(cv2.aruco.generateImageMarker(dictionary, 5, 24), cv2.COLOR_GRAY2BGR)
    image[100:180, 100:180] = cv2.cvtColor(cv2.aruco.generateImageMarker(dictionary, 7, 80), cv2.COLOR_GRAY2BGR)
    det = ArucoDetector()
    full = {d.label: d for d in det.detect(image)}
    assert set(full) == {"5", "7"}
    for label, roi in (("5", (280, 280, 64, 64)), ("7", (80, 80, 120, 120))):
        found = det.detect(image, roi=roi)
        assert [d.label for d in found] == [label]
        assert np.allclose(found[0].corners, full[label].corners, atol=0.05)
