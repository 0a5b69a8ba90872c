"""A taught class's own candidate rows in the desk detector's ONNX graph (issue 27 item 3), on tiny
models built from numpy weights (no torch): OpenCV's DNN runs the graph, the old classes' rows are
what they were bit for bit, each taught class has boxes and a score of its own, and the detector
decodes and labels them."""
import json

import numpy as np
import pytest

pytest.importorskip("onnx")
import cv2

from core.detect.learned.onnx_graph import STRIDE, build_desk_onnx, taught_branches
from core.detect.onnx_yolo import OnnxYoloDetector

W, H = 64, 48  # network input: an 8 × 6 grid of cells
WIDTHS, HEAD, OLD = (4, 6, 8, 8), 6, ("ball", "cup")


def base_layers(rng) -> dict:
    """Random weights of a tiny desk model: backbone, head, class and box outputs."""
    a, b, c, d = WIDTHS

    def layer(o, i, k, stride=1):
        return (rng.normal(0, 0.6, (o, i, k, k)).astype(np.float32), rng.normal(0, 0.1, o).astype(np.float32), stride)

    return {"stride8.0": layer(a, 3, 3, 2), "stride8.1": layer(b, a, 3, 2), "stride8.2": layer(c, b, 3, 2),
            "stride16.0": layer(d, c, 3, 2), "head.0": layer(HEAD, c + d, 1), "head.1": layer(HEAD, HEAD, 3),
            "classes": layer(len(OLD), HEAD, 1), "box": layer(4, HEAD, 1)}


def add_branch(layers: dict, j: int, width: int, score_bias: float, box_bias: float, rng) -> dict:
    """A taught branch whose layers are silent (zero weights): every cell scores sigmoid(score_bias)
    and boxes 2 · stride · e^box_bias px wide and tall, centred on the cell."""
    a, b, c, d = WIDTHS
    out = dict(layers)
    first = rng.normal(0, 0.3, (width, c + d + HEAD, 3, 3)).astype(np.float32)
    out[f"taught{j}.0"] = (first, np.zeros(width, np.float32), 1)
    out[f"taught{j}.1"] = (np.zeros((width, width, 3, 3), np.float32), np.zeros(width, np.float32), 1)
    out[f"taught{j}.score"] = (np.zeros((1, width, 1, 1), np.float32), np.full(1, score_bias, np.float32), 1)
    out[f"taught{j}.box"] = (np.zeros((4, width, 1, 1), np.float32), np.full(4, box_bias, np.float32), 1)
    return out


def write(path, layers, taught):
    arch = {"widths": list(WIDTHS), "head_width": HEAD}
    if taught:
        arch["taught"] = [{"name": n, "width": 5} for n in taught]
    model = build_desk_onnx(layers, arch, [*OLD, *taught], (W, H))
    path.write_bytes(model.SerializeToString())
    return path


def run_cv2(path, image):
    net = cv2.dnn.readNetFromONNX(str(path))
    net.setInput(cv2.dnn.blobFromImage(image, 1 / 255.0, swapRB=True))
    return net.forward()


@pytest.fixture()
def models(tmp_path):
    rng = np.random.default_rng(3)
    base = base_layers(rng)
    one = add_branch(base, 0, 5, 4.0, np.log(1.5), rng)
    two = add_branch(one, 1, 5, -4.0, 0.0, rng)
    return (write(tmp_path / "base.onnx", base, []), write(tmp_path / "one.onnx", one, ["mug"]),
            write(tmp_path / "two.onnx", two, ["mug", "tray"]))


def test_taught_classes_add_rows_of_their_own_and_leave_the_old_rows_as_they_were(models):
    image = np.random.default_rng(0).integers(0, 255, (H, W, 3), dtype=np.uint8)
    base, one, two = (run_cv2(p, image) for p in models)
    n = (H // STRIDE) * (W // STRIDE)
    assert base.shape == (1, 4 + 2, n) and one.shape == (1, 4 + 3, 2 * n) and two.shape == (1, 4 + 4, 3 * n)
    assert np.array_equal(one[:, :6, :n], base)  # the old boxes and scores, bit for bit
    assert np.array_equal(two[:, :7, :2 * n], one)  # and the first taught class's, once a second is taught
    assert not one[0, 6, :n].any() and not two[0, 6:, :n].any()  # old rows: 0 for the taught classes
    assert not two[0, 4:6, n:].any() and not two[0, 7, n:2 * n].any() and not two[0, 4:7, 2 * n:].any()
    assert np.allclose(two[0, 6, n:2 * n], 1 / (1 + np.exp(-4.0)), atol=1e-6)  # its own score
    assert np.allclose(two[0, 7, 2 * n:], 1 / (1 + np.exp(4.0)), atol=1e-6)
    # its own boxes: 1.5 cells from the centre each way, centred on each cell
    assert np.allclose(two[0, 2:4, n:2 * n], 2 * 1.5 * STRIDE, atol=1e-4)
    gx = (np.arange(W // STRIDE) + 0.5) * STRIDE
    assert np.allclose(two[0, 0, n:2 * n].reshape(H // STRIDE, W // STRIDE), gx[None, :], atol=1e-4)
    assert np.allclose(two[0, 2:4, 2 * n:], 2 * STRIDE, atol=1e-4)


def test_the_detector_labels_a_taught_class_with_its_own_boxes(models):
    _, _, two = models
    image = np.full((H, W, 3), 128, np.uint8)
    det = OnnxYoloDetector(two, backend="cv2", score_threshold=0.5)
    assert det.layout == "yolov8" and det.names == ["ball", "cup", "mug", "tray"] and det.num_classes == 4
    mugs = [d for d in det.detect(image) if d.label == "mug"]
    # its own 24 px boxes (where the image's edges do not clip them)
    assert any(abs(d.box[2] - 24.0) < 1e-3 and abs(d.box[3] - 24.0) < 1e-3 for d in mugs)
    assert all(d.label != "tray" for d in det.detect(image))  # its score is 0.018 everywhere
    meta = {"architecture": json.dumps({"taught": [{"name": "mug", "width": 5}]})}
    assert [b["name"] for b in taught_branches(meta)] == ["mug"] and taught_branches({}) == []
