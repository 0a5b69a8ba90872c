"""Per-class score calibration of the desk model (core.detect.learned.calibrate): which detections
are right, the fold of one (a, b) per class into a .onnx's class outputs (no torch: the models are
run by OpenCV's DNN module), the per-class fit (torch: finetune.platt) and the validation photos."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import pytest
from onnx import TensorProto, helper, numpy_helper

from core.detect.learned.calibrate import compose, fold_into_onnx, match_detections, photo_variants
from core.detect.onnx_yolo import OnnxYoloDetector

CLASSES = ("ball", "cup", "button")
DESK_MODEL = Path(__file__).resolve().parents[2] / "resources" / "models" / "desk_objects.onnx"
REAL = Path(__file__).resolve().parents[1] / "data" / "stereo_7x5_320x240"


@dataclass
class Found:
    label: str
    score: float
    box: tuple  # x, y, w, h


def logit(p):
    p = np.clip(np.asarray(p, np.float64), 1e-9, 1 - 1e-9)
    return np.log(p / (1 - p))


def sigmoid(z):
    return 1 / (1 + np.exp(-np.asarray(z, np.float64)))


def class_head_model(path, weight, bias):
    """A model that is only a desk model's class head: features (1, F, 2, 2) -> 1x1 conv
    (classes.weight, classes.bias) -> Sigmoid -> scores (1, C, 2, 2)."""
    c, f = weight.shape[:2]
    node_conv = helper.make_node("Conv", ["features", "classes.weight", "classes.bias"], ["classes"])
    node_sig = helper.make_node("Sigmoid", ["classes"], ["scores"])
    graph = helper.make_graph(
        [node_conv, node_sig], "head",
        [helper.make_tensor_value_info("features", TensorProto.FLOAT, [1, f, 2, 2])],
        [helper.make_tensor_value_info("scores", TensorProto.FLOAT, [1, c, 2, 2])],
        [numpy_helper.from_array(weight.astype(np.float32), "classes.weight"),
         numpy_helper.from_array(bias.astype(np.float32), "classes.bias")])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    helper.set_model_props(model, {"names": "{0: 'ball', 1: 'cup', 2: 'button'}"})
    import onnx

    onnx.save(model, str(path))
    return path


def run_head(path, features):
    net = cv2.dnn.readNetFromONNX(str(path))
    net.setInput(features.astype(np.float32))
    return net.forward().astype(np.float64)


# ------------------------------------------------------------------------------- which are right
def test_the_best_detection_of_a_box_is_right_its_duplicate_and_other_classes_are_wrong():
    boxes = np.array([[10, 10, 50, 50], [100, 100, 140, 150]], np.float32)
    labels = np.array([0, 2])
    difficult = np.array([False, False])
    found = [Found("ball", 0.9, (11, 11, 40, 40)),  # right
             Found("ball", 0.6, (12, 10, 38, 40)),  # the same ball again: a duplicate, wrong
             Found("cup", 0.8, (100, 100, 40, 50)),  # a cup on the button's box: wrong class
             Found("button", 0.3, (101, 102, 39, 48)),  # right, although weaker than the wrong cup
             Found("button", 0.7, (200, 200, 20, 20))]  # nothing there
    got = match_detections(found, boxes, labels, difficult, CLASSES)
    assert got == [(0, 0.9, True), (1, 0.8, False), (2, 0.7, False), (0, 0.6, False), (2, 0.3, True)]


def test_a_detection_of_a_difficult_box_counts_neither_way_and_unknown_labels_are_left_out():
    boxes = np.array([[10, 10, 50, 50]], np.float32)
    got = match_detections([Found("ball", 0.9, (10, 10, 40, 40)), Found("teapot", 0.95, (10, 10, 40, 40))],
                           boxes, np.array([0]), np.array([True]), CLASSES)
    assert got == []
    assert match_detections([Found("cup", 0.4, (0, 0, 5, 5))], np.zeros((0, 4)), np.zeros(0, int),
                            np.zeros(0, bool), CLASSES) == [(1, 0.4, False)]  # a negative image: all wrong


# ------------------------------------------------------------------------------- the fold
def test_each_class_gets_its_own_map_folded_into_its_row(tmp_path):
    rng = np.random.default_rng(3)
    weight = rng.normal(0, 1, (3, 5, 1, 1))
    bias = rng.normal(0, 1, 3)
    src = class_head_model(tmp_path / "head.onnx", weight, bias)
    ab = [(2.5, -1.0), (0.5, 0.3), (1.0, -2.0)]
    dst = fold_into_onnx(src, tmp_path / "cal.onnx", ab, metadata={"deskarm_calibration": {"x": 1}})
    features = rng.normal(0, 1, (1, 5, 2, 2))
    before, after = run_head(src, features), run_head(dst, features)
    for c, (a, b) in enumerate(ab):
        np.testing.assert_allclose(after[0, c], sigmoid(a * logit(before[0, c]) + b), rtol=1e-4, atol=1e-6)
    import onnx

    props = {p.key: p.value for p in onnx.load(str(dst)).metadata_props}
    assert props["deskarm_calibration"] == '{"x": 1}' and props["names"].startswith("{0: 'ball'")


def test_a_fold_that_would_reverse_a_class_or_miss_one_is_refused(tmp_path):
    src = class_head_model(tmp_path / "head.onnx", np.ones((3, 5, 1, 1)), np.zeros(3))
    with pytest.raises(ValueError, match="a > 0"):
        fold_into_onnx(src, tmp_path / "x.onnx", [(1, 0), (-1, 0), (1, 0)])
    with pytest.raises(ValueError, match="3 classes"):
        fold_into_onnx(src, tmp_path / "x.onnx", [(1, 0), (1, 0)])
    assert not (tmp_path / "x.onnx").exists()


def test_composed_maps_are_the_two_maps_one_after_the_other():
    first, then = [(2.0, 0.5), (0.7, -1.0)], [(1.5, -0.2), (3.0, 0.1)]
    z = np.linspace(-4, 4, 9)
    for (a1, b1), (a2, b2), (a, b) in zip(first, then, compose(first, then)):
        np.testing.assert_allclose(a * z + b, a2 * (a1 * z + b1) + b2)


def test_the_shipped_model_folded_with_one_map_for_all_classes_keeps_its_boxes_and_maps_its_scores(tmp_path):
    image = cv2.imread(str(REAL / "left02.jpg"))
    a, b = 1.7, -0.4
    dst = fold_into_onnx(DESK_MODEL, tmp_path / "desk.onnx", [(a, b)] * 6)
    before = OnnxYoloDetector(DESK_MODEL, score_threshold=0.001, backend="cv2").detect(image)
    after = OnnxYoloDetector(dst, score_threshold=0.0, backend="cv2").detect(image)
    assert before
    for d in before[:20]:
        match = [q for q in after if q.label == d.label and np.allclose(q.box, d.box, atol=0.05)]
        assert match, d
        assert match[0].score == pytest.approx(float(sigmoid(a * logit(d.score) + b)), abs=2e-4)


# ------------------------------------------------------------------------------- the fit (torch)
def test_per_class_fits_undo_each_class_own_over_or_under_confidence():
    pytest.importorskip("torch")
    from core.detect.learned.calibrate import fit_per_class

    rng = np.random.default_rng(0)
    truth = {0: (3.0, -1.0), 1: (0.5, 0.5)}  # class 0 under-confident, class 1 over-confident
    ids, scores, right = [], [], []
    for c, (a, b) in truth.items():
        z = rng.normal(0, 2, 4000)
        ids += [c] * len(z)
        scores += list(sigmoid(z))
        right += list(rng.random(len(z)) < sigmoid(a * z + b))
    ids += [2] * 5  # class 2: five detections — too few for a fit of its own
    scores += [0.9] * 5
    right += [False] * 5
    fits = fit_per_class(np.array(ids), np.array(scores), np.array(right), 3)
    for c, (a, b) in truth.items():
        assert fits[c][0] == pytest.approx(a, rel=0.12) and fits[c][1] == pytest.approx(b, abs=0.15)
    from core.detect.learned.finetune import platt

    pooled = platt(np.array(scores), np.array(right))
    assert fits[2] == pytest.approx(pooled)  # the fit of all classes together
    one = fit_per_class(np.array(ids), np.array(scores), np.array(right), 3, min_detections=len(ids) + 1)
    assert one == [pytest.approx(pooled)] * 3  # what retrain_desk calibrates with (no --per-class)


# ------------------------------------------------------------------------------- validation photos
def test_photo_variants_are_new_crops_of_the_photos_and_repeat_with_the_seed():
    photos = [cv2.imread(str(REAL / "left01.jpg")), cv2.imread(str(REAL / "right01.jpg"))]
    one = photo_variants(np.random.default_rng(5), photos, 6)
    two = photo_variants(np.random.default_rng(5), photos, 6)
    assert len(one) == 6 and all(v.shape == (240, 320, 3) and v.dtype == np.uint8 for v in one)
    assert all(np.array_equal(x, y) for x, y in zip(one, two))
    assert not any(np.array_equal(v, p) for v in one for p in photos)
    plain = photo_variants(np.random.default_rng(5), photos, 20, effects=False)
    # a crop of a photo, resized: a variant's colours are the photos' colours
    assert all(abs(float(v.mean()) - float(np.mean([p.mean() for p in photos]))) < 40 for v in plain)
    assert photo_variants(np.random.default_rng(5), [], 3) == []
