"""core.detect.pose on tiny ONNX models built here (no download): each model's output is a planted
array of a pose layout, plus a small function of the input's mean (so the input really flows and
its documented range can be checked)."""
import numpy as np
import pytest

onnx = pytest.importorskip("onnx")
from onnx import TensorProto, helper, numpy_helper  # noqa: E402

from core.detect.pose import (  # noqa: E402
    BLAZEPOSE_33,
    COCO_17,
    OnnxPoseModel,
    guess_pose_layout,
    parse_pose_output,
)


def build_model(path, output, input_shape, input_gain=None):
    """A model whose output is ``output`` + mean(input) · ``input_gain`` (an array like the output;
    zero by default)."""
    output = np.asarray(output, np.float32)
    gain = np.zeros_like(output) if input_gain is None else np.asarray(input_gain, np.float32)
    image = helper.make_tensor_value_info("image", TensorProto.FLOAT, list(input_shape))
    out = helper.make_tensor_value_info("landmarks", TensorProto.FLOAT, list(output.shape))
    nodes = [
        helper.make_node("ReduceMean", ["image"], ["mean4"], keepdims=1),  # (1, 1, 1, 1)
        helper.make_node("Constant", [], ["shape"],
                         value=numpy_helper.from_array(np.array([1] * output.ndim, np.int64))),
        helper.make_node("Reshape", ["mean4", "shape"], ["mean"]),
        helper.make_node("Constant", [], ["gain"], value=numpy_helper.from_array(gain)),
        helper.make_node("Mul", ["mean", "gain"], ["from_input"]),
        helper.make_node("Constant", [], ["planted"], value=numpy_helper.from_array(output)),
        helper.make_node("Add", ["planted", "from_input"], ["landmarks"]),
    ]
    model = helper.make_model(helper.make_graph(nodes, "pose", [image], [out]),
                              opset_imports=[helper.make_opsetid("", 13)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, str(path))
    return path


def movenet_output(points):
    """(1, 1, 17, 3) rows y, x, score (normalised) from {name: (x_norm, y_norm, score)}."""
    out = np.zeros((1, 1, 17, 3), np.float32)
    for name, (x, y, s) in points.items():
        out[0, 0, COCO_17.index(name)] = (y, x, s)
    return out


POSE = {"nose": (0.50, 0.20, 0.9), "left_shoulder": (0.62, 0.40, 0.8), "right_shoulder": (0.38, 0.40, 0.8),
        "left_wrist": (0.70, 0.30, 0.7), "right_wrist": (0.25, 0.55, 0.6)}


def test_movenet_layout_nhwc_model_gives_landmarks_in_image_pixels(tmp_path):
    gain = np.zeros((1, 1, 17, 3), np.float32)
    gain[..., 2] = 0.1 / 255.0  # a white image (pixel values 0…255 for NHWC) adds 0.1 to every score
    path = build_model(tmp_path / "movenet.onnx", movenet_output(POSE), (1, 192, 192, 3), gain)
    model = OnnxPoseModel(path)
    assert model.layout == "movenet" and model.nhwc and model.input_wh == (192, 192)
    black = model.landmarks(np.zeros((480, 640, 3), np.uint8))
    for name, (x, y, s) in POSE.items():
        got = black[name]
        assert got[0] == pytest.approx(x * 640, abs=1e-3) and got[1] == pytest.approx(y * 480, abs=1e-3)
        assert got[2] == pytest.approx(s, abs=1e-5)
    white = model.landmarks(np.full((480, 640, 3), 255, np.uint8))
    assert white["nose"][2] == pytest.approx(POSE["nose"][2] + 0.1, abs=1e-4)
    assert set(black) == set(COCO_17)


def test_blazepose_layout_nchw_model_in_input_pixels_with_visibility_logits(tmp_path):
    out = np.zeros((1, 39, 5), np.float32)
    out[0, :, 3] = -4.0  # invisible (logit)
    out[0, BLAZEPOSE_33.index("left_wrist")] = (128.0, 64.0, 0.0, 3.0, 5.0)
    out[0, BLAZEPOSE_33.index("left_shoulder")] = (150.0, 120.0, 0.0, 0.0, 5.0)
    model = OnnxPoseModel(build_model(tmp_path / "blaze.onnx", out, (1, 3, 256, 256)))
    assert model.layout == "blazepose" and not model.nhwc and model.input_wh == (256, 256)
    marks = model.landmarks(np.zeros((480, 640, 3), np.uint8))
    x, y, s = marks["left_wrist"]
    assert (x, y) == (pytest.approx(128 * 640 / 256), pytest.approx(64 * 480 / 256))
    assert s == pytest.approx(1 / (1 + np.exp(-3.0)), abs=1e-5)
    assert marks["left_shoulder"][2] == pytest.approx(0.5, abs=1e-6)
    assert marks["nose"][2] < 0.05
    assert len(marks) == 33  # the 6 extra rows of a 39-row output are not landmarks


def test_xy_score_layout_normalised_or_input_pixels():
    rows = np.zeros((1, 17, 3))
    rows[0, COCO_17.index("left_wrist")] = (0.5, 0.25, 0.9)
    marks = parse_pose_output(rows, (640, 480), (192, 192))
    assert marks["left_wrist"] == (pytest.approx(320.0), pytest.approx(120.0), pytest.approx(0.9))
    rows[0, COCO_17.index("left_wrist")] = (96.0, 48.0, 0.9)  # beyond 1.5: input pixels
    marks = parse_pose_output(rows, (640, 480), (192, 192))
    assert marks["left_wrist"][:2] == (pytest.approx(320.0), pytest.approx(120.0))


def test_non_finite_landmarks_are_left_out():
    out = movenet_output(POSE)
    out[0, 0, COCO_17.index("nose")] = (np.nan, 0.5, 0.9)
    marks = parse_pose_output(out, (640, 480), (192, 192))
    assert "nose" not in marks and "left_wrist" in marks


@pytest.mark.parametrize("shape", [(1, 17, 4), (1, 2, 17, 3), (1, 10, 3), (1, 100)])
def test_an_unknown_output_shape_names_the_supported_layouts(shape):
    with pytest.raises(ValueError, match="movenet .*blazepose"):
        guess_pose_layout(shape)


def test_a_model_with_an_unknown_output_is_refused_at_load(tmp_path):
    path = build_model(tmp_path / "odd.onnx", np.zeros((1, 17, 4), np.float32), (1, 3, 64, 64))
    with pytest.raises(ValueError, match="layout"):
        OnnxPoseModel(path)


def test_a_missing_model_says_none_ships(tmp_path):
    with pytest.raises(FileNotFoundError, match="no model ships"):
        OnnxPoseModel(tmp_path / "nothing.onnx")
