"""YOLOv2 outputs (1, A·(5+C), H, W) with anchors, decoded by core.detect.onnx_yolo on tiny ONNX
models built here: planted raw region-layer values, boxes checked against darknet's formulas."""
import json
import math

import cv2
import numpy as np
import pytest

pytest.importorskip("onnx")

from app.cli_detect import run
from core.detect.onnx_yolo import OnnxYoloDetector, guess_layout, parse_anchors
from core.settings import SettingsError
from tests.detect.test_onnx_yolo import FRAME, LEFT, SCALE, TOP, build_model

ANCHORS = (1.5, 1.0, 3.0, 2.0)  # two anchors (w, h) in grid cells
ANCHOR_TEXT = "1.5,1.0, 3.0,2.0"
GRID = 10  # 320 / 32
CLASSES = 3


def region_output(planted, anchors=ANCHORS, classes=CLASSES, grid=GRID):
    """Darknet region-layer output: every cell's objectness logit -12 except the planted ones,
    given as (anchor, row, col, tx, ty, tw, th, objectness logit, class logits)."""
    n = len(anchors) // 2
    out = np.zeros((n, 5 + classes, grid, grid), np.float32)
    out[:, 4] = -12.0
    for a, row, col, tx, ty, tw, th, to, logits in planted:
        out[a, :5, row, col] = (tx, ty, tw, th, to)
        out[a, 5:, row, col] = logits
    return out.reshape(1, n * (5 + classes), grid, grid)


def expected_box(a, row, col, tx, ty, tw, th, to, logits, anchors=ANCHORS, stride=32.0):
    """The image box (x1, y1, x2, y2), label and score darknet's formulas give (independent of the decoder)."""
    sig = lambda v: 1 / (1 + math.exp(-v))  # noqa: E731
    cx, cy = (col + sig(tx)) * stride, (row + sig(ty)) * stride
    w, h = anchors[2 * a] * math.exp(tw) * stride, anchors[2 * a + 1] * math.exp(th) * stride
    p = np.exp(np.asarray(logits, float) - max(logits))
    p /= p.sum()
    cls = int(np.argmax(p))
    box = ((cx - w / 2 - LEFT) / SCALE, (cy - h / 2 - TOP) / SCALE, (cx + w / 2 - LEFT) / SCALE,
           (cy + h / 2 - TOP) / SCALE)
    return box, ["person", "bicycle", "cup"][cls], sig(to) * p[cls]


CUP = (1, 4, 6, 0.0, 0.0, math.log(2.0), math.log(2.0), 3.0, (0.0, 0.0, 5.0))
PERSON = (0, 7, 2, 0.5, -0.3, 0.2, 0.4, 2.0, (4.0, 0.0, 1.0))
CUP_AGAIN = (0, 4, 6, 0.1, 0.0, math.log(4.0), math.log(4.0), 1.0, (0.0, 0.0, 5.0))  # same place, other anchor
FAINT = (0, 1, 1, 0.0, 0.0, 0.0, 0.0, -3.0, (0.0, 5.0, 0.0))  # objectness 0.05: below the threshold


def check(found, planted):
    want = sorted((expected_box(*p) for p in planted), key=lambda e: -e[2])
    assert [(d.label, round(d.score, 4)) for d in found] == [(label, round(score, 4)) for _, label, score in want]
    for d, ((x1, y1, x2, y2), _, _) in zip(found, want):
        assert d.box == pytest.approx((x1, y1, x2 - x1, y2 - y1), abs=0.05)


def test_yolov2_output_is_decoded_with_the_anchors_in_the_model_metadata(tmp_path):
    path = build_model(tmp_path / "v2.onnx", region_output([CUP, PERSON, FAINT]), extra_meta={"anchors": ANCHOR_TEXT})
    det = OnnxYoloDetector(path, backend="cv2")
    assert (det.layout, det.num_classes, det.anchors, det.output_shape) == ("yolov2", 3, ANCHORS, (1, 16, 10, 10))
    check(det.detect(FRAME), [CUP, PERSON])


def test_yolov2_nms_keeps_the_stronger_of_two_anchors_on_one_object(tmp_path):
    path = build_model(tmp_path / "v2.onnx", region_output([CUP, CUP_AGAIN]), extra_meta={"anchors": ANCHOR_TEXT})
    check(OnnxYoloDetector(path, backend="cv2").detect(FRAME), [CUP])


def test_anchors_given_by_the_caller_replace_the_metadata(tmp_path):
    path = build_model(tmp_path / "v2.onnx", region_output([CUP]), extra_meta={"anchors": "9,9, 9,9"})
    det = OnnxYoloDetector(path, backend="cv2", anchors=ANCHORS)
    assert det.anchors == ANCHORS
    check(det.detect(FRAME), [CUP])


def test_a_yolov2_model_without_anchors_says_how_to_give_them(tmp_path):
    path = build_model(tmp_path / "v2.onnx", region_output([CUP]))
    with pytest.raises(ValueError, match="--anchors"):
        OnnxYoloDetector(path, backend="cv2")
    with pytest.raises(ValueError, match="3 anchors"):  # 16 channels are not 3 * (5 + C)
        OnnxYoloDetector(path, backend="cv2", anchors=(1, 1, 2, 2, 3, 3))
    with pytest.raises(SettingsError, match="anchors"):
        OnnxYoloDetector(path, backend="cv2", anchors=(1, 1, 2))


def test_parse_anchors_reads_darknet_and_list_forms():
    assert parse_anchors("1.08,1.19,  3.42,4.41") == (1.08, 1.19, 3.42, 4.41)
    assert parse_anchors("[[1, 2], [3, 4]]") == (1.0, 2.0, 3.0, 4.0)
    assert parse_anchors(None) is None and parse_anchors(" ") is None
    with pytest.raises(ValueError, match="> 0"):
        parse_anchors("1,-2")
    assert guess_layout((1, 16, 10, 10), num_anchors=2) == "yolov2"


def test_deskarm_detect_decodes_a_yolov2_model_with_anchors_on_the_command_line(tmp_path, capsys):
    path = build_model(tmp_path / "v2.onnx", region_output([CUP]))
    image = tmp_path / "frame.png"
    cv2.imwrite(str(image), FRAME)
    assert run("detect", [str(image), "--detector", f"onnx:{path}", "--anchors", ANCHOR_TEXT, "--json"]) == 0
    found = json.loads(capsys.readouterr().out)["images"][0]["detections"]
    (box, label, score), = [expected_box(*CUP)]
    assert [d["label"] for d in found] == [label] and found[0]["score"] == pytest.approx(score, abs=1e-4)
    assert run("detect", [str(image), "--detector", "hsv", "--anchors", ANCHOR_TEXT]) == 2
    assert "onnx:PATH" in capsys.readouterr().err
