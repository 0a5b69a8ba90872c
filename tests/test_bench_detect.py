"""bench/bench_detect.py (no timing asserts): its rows exist, have finite samples and name baselines
of the same table; the ROI windows sit on the predicted positions; the synthetic ONNX model is a
YOLOv8 layout; a missing onnxruntime skips only its row."""
import math

import numpy as np
import pytest

from bench import bench_detect
from core.detect.base import Detection


def blob(label, cx, cy, size=20.0):
    return Detection(kind="colour", label=label, score=1.0, box=(cx - size / 2, cy - size / 2, size, size),
                     centre_px=(cx, cy))


def test_quick_rows_have_finite_samples_and_baselines_in_the_table():
    rows = bench_detect.rows(quick=True)
    names = [r["name"] for r in rows]
    assert len(names) == len(set(names)), names
    for r in rows:
        assert r["unit"] == "ms" and r["samples"], r["name"]
        assert all(math.isfinite(v) and v >= 0 for v in r["samples"]), r
        assert r["baseline"] is None or r["baseline"] in names, (r["name"], r["baseline"])
    for detector in bench_detect.DETECTORS:
        full, roi = f"detect {detector}: full frame", f"detect {detector}: ROI per object"
        assert full in names and roi in names
        assert next(r for r in rows if r["name"] == roi)["baseline"] == full
    assert bench_detect.OBJECT_LOOP in names
    assert any(n.startswith("track KCF") for n in names)
    hsv_roi = next(r for r in rows if r["name"] == "detect hsv: ROI per object")
    # every hsv blob the full frame found, its ROI found again (the windows are in the right place)
    found = hsv_roi["extra"].split("found again: ")[1]
    again, of = (int(v) for v in found.split(" of "))
    assert of > 0 and again == of, hsv_roi["extra"]
    try:
        import onnx  # noqa: F401  (builds the synthetic model when none ships)
        have_model = True
    except ImportError:
        have_model = bench_detect.SHIPPED_MODEL.is_file()
    if have_model:
        assert "onnx via cv2.dnn: full frame" in names
        assert any(n.startswith("detect onnx") for n in names)


def test_roi_windows_centre_on_the_predicted_position_and_stay_inside():
    shape = (480, 640, 3)
    before = [blob("red", 100.0, 200.0)]
    now = [blob("red", 110.0, 205.0), blob("blue", 630.0, 10.0, size=50.0)]
    red, blue = bench_detect.roi_windows(now, shape, before)
    # the red blob moved (+10, +5): its window is centred on (120, 210), 96 px (3 x 20 < 96)
    assert red == (72, 162, 96, 96)
    # the blue one has no earlier position: 3 x 50 = 150 px around where it was, moved inside
    assert blue == (640 - 150, 0, 150, 150)


def test_prediction_ignores_another_label_and_far_detections():
    now = [blob("red", 110.0, 205.0)]
    assert bench_detect.predicted_centres(now, [blob("blue", 100.0, 200.0)]) == [(110.0, 205.0)]
    assert bench_detect.predicted_centres(now, [blob("red", 300.0, 200.0)]) == [(110.0, 205.0)]
    assert bench_detect.predicted_centres(now, [blob("red", 100.0, 200.0), blob("red", 108.0, 204.0)]) == \
        [(112.0, 206.0)]


def test_refound_counts_same_label_within_the_match_distance():
    full = [blob("red", 10.0, 10.0), blob("blue", 50.0, 50.0)]
    assert bench_detect.refound(full, [blob("red", 11.0, 11.0), blob("red", 50.0, 50.0)]) == 1
    assert bench_detect.refound(full, [blob("red", 20.0, 10.0)]) == 0


def test_synthetic_model_is_a_yolov8_layout_that_finds_nothing(tmp_path):
    pytest.importorskip("onnx")
    from core.detect.onnx_yolo import OnnxYoloDetector

    path = bench_detect.build_synthetic_yolo(tmp_path / "m.onnx")
    detector = OnnxYoloDetector(path, backend="cv2")
    assert (detector.layout, detector.input_wh, detector.num_classes) == ("yolov8", (320, 320), 8)
    assert detector.output_shape == (1, 12, 40 * 40 + 20 * 20 + 10 * 10)
    image = np.random.default_rng(0).integers(0, 256, (480, 640, 3), dtype=np.uint8)
    assert detector.detect(image) == []


def test_missing_onnxruntime_skips_only_its_row(tmp_path, monkeypatch, capsys):
    pytest.importorskip("onnx")
    path = bench_detect.build_synthetic_yolo(tmp_path / "m.onnx")
    _, frames = bench_detect.render_sequence(1)
    monkeypatch.setattr(bench_detect, "onnxruntime_installed", lambda: False)
    rows = bench_detect.onnx_backend_rows(frames, path, "synthetic")
    assert [r["name"] for r in rows] == ["onnx via cv2.dnn: full frame"]
    assert "onnxruntime not installed" in capsys.readouterr().err
