"""The shipped desk model on real webcam photos that hold none of its classes, and on a small fixed
set of clean renders (issue 27 item 1). CI, no torch: the .onnx runs in OpenCV's DNN module.

The photos: tests/data/stereo_7x5_320x240, pairs 01–09 (18 images: a person holding a chessboard
in an orange tray). They are held out: the model's training used pairs 10–12 of the same folder
in ../shared/realdata as negatives (``core.detect.learned.retrain.REAL_TRAIN_PAIRS``), the model
and its calibration were chosen on pairs 13–14 (``REAL_VALIDATION_PAIRS``), and these were
scored once, after the choice. The model before issue 27 put 14 boxes at score ≥ 0.5 on them
(0.78 per image), the first issue-27 model one (a "button" in right07.jpg: 0.056); this one puts
none there (one at ≥ 0.25). The issue asks for ≤ 0.05 per image: with 18 photos, no box at all.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import pytest

from core.detect.learned.retrain import (REAL_TEST_PAIRS, REAL_TRAIN_PAIRS, REAL_VALIDATION_PAIRS,
                                         false_boxes_per_image, real_photo_split)
from core.detect.registry import make_detector
from core.sim.dataset import CLASSES, score_detector

REAL = Path(__file__).resolve().parents[1] / "data" / "stereo_7x5_320x240"
MAX_FALSE_PER_IMAGE = 0.05  # issue 27: ≤ 0.05 boxes at score ≥ 0.5 per real photo of none of the classes
RENDERS = 40  # the small fixed render set: held-out scenes 1 000 000 … 1 000 019, both views
MIN_CLEAN_MAP = 0.95


@pytest.fixture(scope="module")
def desk():
    return make_detector("desk", backend="cv2", score_threshold=0.05)


def test_the_held_out_photos_are_not_the_training_negatives():
    assert not set(REAL_TEST_PAIRS) & set(REAL_TRAIN_PAIRS)
    assert not set(REAL_VALIDATION_PAIRS) & (set(REAL_TRAIN_PAIRS) | set(REAL_TEST_PAIRS))
    photos = real_photo_split(REAL, REAL_TEST_PAIRS)
    assert len(photos) == 18, "tests/data/stereo_7x5_320x240 should hold pairs 01–09"
    assert not real_photo_split(REAL, REAL_TRAIN_PAIRS + REAL_VALIDATION_PAIRS)  # not copied here


def test_real_photos_of_none_of_the_classes_get_no_sure_boxes(desk):
    images = [cv2.imread(str(p)) for p in real_photo_split(REAL, REAL_TEST_PAIRS)]
    per_image, found = false_boxes_per_image(desk, images, 0.5)
    print(f"false boxes at score ≥ 0.5: {per_image:.3f} per image on {len(images)} real photos: {found}")
    assert per_image <= MAX_FALSE_PER_IMAGE, found


def test_clean_renders_keep_their_map(desk):
    scores, _ = score_detector(desk, RENDERS, classes=list(CLASSES))
    print(scores.table())
    assert scores.mean_ap >= MIN_CLEAN_MAP
