"""core.detect.onnx_yolo on tiny ONNX models built here (no download): each model's output is a
constant tensor in one YOLO layout with planted boxes, so decoding, letterboxing, NMS and names
are checked exactly."""
import numpy as np
import pytest

onnx = pytest.importorskip("onnx")
from onnx import TensorProto, helper, numpy_helper

from core.detect.base import Detector
from core.detect.onnx_yolo import (
    OnnxYoloDetector,
    OnnxYoloParams,
    guess_layout,
    letterbox,
    parse_names,
    read_onnx_info,
)
from core.settings import SettingsError

NAMES = "{0: 'person', 1: 'bicycle', 2: 'cup'}"
# a 640x480 image into a 320x320 input: scale 0.5, 320x240 content, 40 px grey above and below
SCALE, LEFT, TOP = 0.5, 0.0, 40.0


def build_model(path, output, input_hw=(320, 320), names=NAMES, extra_meta=None, dynamic=False):
    """A model whose only output is ``output`` (+ 0 x the input's mean, so the input is used)."""
    output = np.asarray(output, np.float32)
    dims = ["height", "width"] if dynamic else list(input_hw)
    image = helper.make_tensor_value_info("images", TensorProto.FLOAT, [1, 3] + dims)
    out = helper.make_tensor_value_info("output0", TensorProto.FLOAT, list(output.shape))
    ones = [1] * output.ndim
    nodes = [
        helper.make_node("ReduceMean", ["images"], ["mean"], keepdims=1),
        helper.make_node("Constant", [], ["zero"], value=numpy_helper.from_array(np.zeros((), np.float32))),
        helper.make_node("Mul", ["mean", "zero"], ["nothing"]),
        helper.make_node("Constant", [], ["shape"], value=numpy_helper.from_array(np.array(ones, np.int64))),
        helper.make_node("Reshape", ["nothing", "shape"], ["nothing_nd"]),
        helper.make_node("Constant", [], ["planted"], value=numpy_helper.from_array(output)),
        helper.make_node("Add", ["planted", "nothing_nd"], ["output0"]),
    ]
    model = helper.make_model(helper.make_graph(nodes, "planted", [image], [out]),
                              opset_imports=[helper.make_opsetid("", 13)])
    model.ir_version = 8
    meta = {} if names is None else {"names": names}
    meta.update(extra_meta or {})
    if meta:
        helper.set_model_props(model, meta)
    onnx.checker.check_model(model)
    onnx.save(model, str(path))
    return path


def to_input(x1, y1, x2, y2):
    """Image box (x1, y1, x2, y2) of the 640x480 frame -> the 320x320 network input."""
    return x1 * SCALE + LEFT, y1 * SCALE + TOP, x2 * SCALE + LEFT, y2 * SCALE + TOP


def cxcywh(x1, y1, x2, y2):
    return (x1 + x2) / 2, (y1 + y2) / 2, x2 - x1, y2 - y1


FRAME = np.zeros((480, 640, 3), np.uint8)
# image boxes (x1, y1, x2, y2), class, score
A = ((100, 50, 300, 250), 1, 0.9)          # bicycle
A_DUP = ((104, 54, 304, 252), 1, 0.8)      # the same bicycle again: NMS removes it
A_CUP = ((100, 50, 300, 250), 2, 0.6)      # same place, other class: kept (NMS per class)
B = ((400, 300, 600, 470), 0, 0.7)         # person
LOW = ((10, 10, 50, 50), 0, 0.1)           # below the threshold


def v8_output(planted, n=16, classes=3):
    out = np.zeros((1, 4 + classes, n), np.float32)
    for i, (box, cls, score) in enumerate(planted):
        out[0, :4, i] = cxcywh(*to_input(*box))
        out[0, 4 + cls, i] = score
    return out


def v5_output(planted, n=16, classes=3, objectness=1.0):
    out = np.zeros((n, 5 + classes), np.float32)
    for i, (box, cls, score) in enumerate(planted):
        out[i, :4] = cxcywh(*to_input(*box))
        out[i, 4] = objectness
        out[i, 5 + cls] = score / objectness
    return out[None]


def e2e_output(planted, n=300):
    out = np.zeros((1, n, 6), np.float32)
    for i, (box, cls, score) in enumerate(planted):
        out[0, i, :4] = to_input(*box)
        out[0, i, 4], out[0, i, 5] = score, cls
    return out


def check(found, expected):
    """Detections equal the planted (box, class, score) in order, boxes back in image pixels."""
    assert [(d.label, round(d.score, 4)) for d in found] == \
        [(["person", "bicycle", "cup"][cls], round(score, 4)) for _, cls, score in expected]
    for d, ((x1, y1, x2, y2), _, _) in zip(found, expected):
        assert d.kind == "object"
        assert d.box == pytest.approx((x1, y1, x2 - x1, y2 - y1), abs=0.01)
        assert d.centre_px == pytest.approx(((x1 + x2) / 2, (y1 + y2) / 2), abs=0.01)


def test_yolov8_layout_is_decoded_and_nms_removes_the_duplicate(tmp_path):
    path = build_model(tmp_path / "v8.onnx", v8_output([A, A_DUP, A_CUP, B, LOW]))
    det = OnnxYoloDetector(path, backend="cv2")
    assert (det.layout, det.num_classes, det.input_wh, det.output_shape) == ("yolov8", 3, (320, 320), (1, 7, 16))
    check(det.detect(FRAME), [A, B, A_CUP])


def test_yolov5_layout_multiplies_objectness(tmp_path):
    weak = ((200, 200, 260, 260), 2, 0.2)  # 0.5 objectness x 0.4 class score: under 0.25
    out = v5_output([A, A_DUP, B])
    out[0, 10, :4] = cxcywh(*to_input(*weak[0]))
    out[0, 10, 4], out[0, 10, 5 + 2] = 0.5, 0.4
    det = OnnxYoloDetector(build_model(tmp_path / "v5.onnx", out), backend="cv2")
    assert det.layout == "yolov5"
    check(det.detect(FRAME), [A, B])
    lower = det.with_params(score_threshold=0.15)
    assert lower._net is det._net  # a threshold change keeps the loaded network
    check(lower.detect(FRAME), [A, B, weak])
    check(det.detect(FRAME), [A, B])


def test_end_to_end_layout_needs_no_nms(tmp_path):
    det = OnnxYoloDetector(build_model(tmp_path / "e2e.onnx", e2e_output([A, A_DUP, B, LOW])), backend="cv2")
    assert det.layout == "end2end"
    check(det.detect(FRAME), [A, A_DUP, B])  # already the model's final answer: both bicycles stay


def test_roi_offsets_the_boxes_and_grey_frames_work(tmp_path):
    # a 320x240 crop at (200, 100) is letterboxed like the frame, at scale 1 with 40 px above
    box = (100, 50, 300, 150)  # in crop pixels
    out = np.zeros((1, 7, 8), np.float32)
    out[0, :4, 0] = cxcywh(box[0], box[1] + 40, box[2], box[3] + 40)
    out[0, 4, 0] = 0.9
    det = OnnxYoloDetector(build_model(tmp_path / "roi.onnx", out), backend="cv2")
    found = det.detect(np.zeros((480, 640), np.uint8), roi=(200, 100, 320, 240))
    assert len(found) == 1
    assert found[0].box == pytest.approx((300, 150, 200, 100))
    assert found[0].centre_px == pytest.approx((400, 200))
    with pytest.raises(ValueError, match="outside"):
        det.detect(FRAME, roi=(700, 0, 10, 10))


def test_boxes_are_clipped_to_the_image(tmp_path):
    out = np.zeros((1, 7, 8), np.float32)
    out[0, :4, 0] = cxcywh(-20, 20, 100, 60)  # starts left of the input, overlaps the top padding
    out[0, 4, 0] = 0.9
    det = OnnxYoloDetector(build_model(tmp_path / "clip.onnx", out), backend="cv2")
    (d,) = det.detect(FRAME)
    assert d.box == pytest.approx((0, 0, 200, 40))


def test_class_names_from_metadata_file_list_or_numbers(tmp_path):
    out = v8_output([B, A_CUP])
    with_names = build_model(tmp_path / "named.onnx", out)
    unnamed = build_model(tmp_path / "unnamed.onnx", out, names=None)
    names_file = tmp_path / "my.names"
    names_file.write_text("hand\nmug\nbox\n\n")

    det = OnnxYoloDetector(with_names, backend="cv2")
    assert (det.names, det.names_source) == (["person", "bicycle", "cup"], "model metadata")
    assert [d.label for d in det.detect(FRAME)] == ["person", "cup"]
    det = OnnxYoloDetector(with_names, classes=str(names_file), backend="cv2")  # the file wins
    assert (det.names, det.names_source) == (["hand", "mug", "box"], "classes file")
    assert [d.label for d in det.detect(FRAME)] == ["hand", "box"]
    det = OnnxYoloDetector(unnamed, classes=["a", "b", "c"], backend="cv2")
    assert [d.label for d in det.detect(FRAME)] == ["a", "c"]
    det = OnnxYoloDetector(unnamed, backend="cv2")
    assert [d.label for d in det.detect(FRAME)] == ["class 0", "class 2"]


def test_names_metadata_parsing():
    assert parse_names("{0: 'person', 1: 'bicycle'}") == ["person", "bicycle"]
    assert parse_names("{0: 'a', 2: 'c'}") == ["a", "class 1", "c"]
    assert parse_names("['x', 'y']") == ["x", "y"]
    assert parse_names("not python") is None
    assert parse_names("") is None


@pytest.mark.parametrize("shape", [(1, 5, 5), (1, 3, 4), (1, 84, 84), (1, 2, 3, 4)])
def test_an_unknown_output_shape_is_a_clear_error(tmp_path, shape):
    path = build_model(tmp_path / "odd.onnx", np.zeros(shape, np.float32), names=None)
    with pytest.raises(ValueError) as err:
        OnnxYoloDetector(path, backend="cv2")
    text = str(err.value)
    assert str(shape) in text
    assert "YOLOv5 (1, N, 5+C)" in text and "YOLOv8/v11 (1, 4+C, N)" in text and "(1, N, 6)" in text


def test_class_count_from_names_must_match_the_layout(tmp_path):
    # (1, 7, 16) is YOLOv8 with 3 classes; metadata naming 80 classes makes it inconsistent
    names = repr({i: f"c{i}" for i in range(80)})
    path = build_model(tmp_path / "wrong.onnx", v8_output([A]), names=names)
    with pytest.raises(ValueError, match=r"\(1, 7, 16\) with 80 class names"):
        OnnxYoloDetector(path, backend="cv2")
    assert OnnxYoloDetector(path, backend="cv2", layout="yolov8").layout == "yolov8"


def test_layout_guessing_rules():
    assert guess_layout((1, 84, 8400)) == "yolov8"
    assert guess_layout((1, 25200, 85)) == "yolov5"
    assert guess_layout((1, 300, 6)) == "end2end"
    # (1, N, 6): one-class YOLOv5 when N is YOLOv5's anchor count at that input size
    assert guess_layout((1, 25200, 6), input_wh=(640, 640)) == "yolov5"
    assert guess_layout((1, 300, 6), input_wh=(640, 640)) == "end2end"
    assert guess_layout((1, 300, 6), end2end_hint=False) == "yolov5"
    assert guess_layout((1, 300, 6)) == "end2end"  # nothing else known


def test_input_size_from_the_model_or_default(tmp_path):
    fixed = build_model(tmp_path / "fixed.onnx", v8_output([A]), input_hw=(256, 320))
    info = read_onnx_info(fixed)
    assert (info.input_name, info.input_shape, info.metadata["names"]) == ("images", (1, 3, 256, 320), NAMES)
    assert OnnxYoloDetector(fixed, backend="cv2").input_wh == (320, 256)
    with pytest.raises(ValueError, match="fixed input"):
        OnnxYoloDetector(fixed, backend="cv2", input_size=640)

    dynamic = build_model(tmp_path / "dyn.onnx", v8_output([A]), dynamic=True)
    assert read_onnx_info(dynamic).input_shape == (1, 3, None, None)
    assert OnnxYoloDetector(dynamic, backend="cv2").input_wh == (640, 640)
    det = OnnxYoloDetector(dynamic, backend="cv2", input_size=320)
    check(det.detect(FRAME), [A])
    meta = build_model(tmp_path / "meta.onnx", v8_output([A]), dynamic=True, extra_meta={"imgsz": "[320, 416]"})
    assert OnnxYoloDetector(meta, backend="cv2").input_wh == (416, 320)


def test_letterbox_pads_grey_and_keeps_the_aspect():
    boxed, scale, pad = letterbox(np.full((480, 640, 3), 255, np.uint8), (320, 320))
    assert boxed.shape == (320, 320, 3) and scale == 0.5 and pad == (0.0, 40.0)
    assert (boxed[:40] == 114).all() and (boxed[40:280] == 255).all() and (boxed[280:] == 114).all()


def test_backend_choice_and_bad_files(tmp_path):
    path = build_model(tmp_path / "m.onnx", v8_output([A]))
    try:
        import onnxruntime
        have_ort = True
    except ImportError:
        have_ort = False
    assert OnnxYoloDetector(path).backend == ("onnxruntime" if have_ort else "cv2")
    if not have_ort:
        with pytest.raises(ImportError, match="onnxruntime is not installed"):
            OnnxYoloDetector(path, backend="onnxruntime")
    with pytest.raises(SettingsError, match="backend"):
        OnnxYoloDetector(path, backend="tensorrt")
    with pytest.raises(SettingsError, match="score_threshold"):
        OnnxYoloDetector(path, score_threshold=1.5)
    with pytest.raises(FileNotFoundError):
        OnnxYoloDetector(tmp_path / "missing.onnx")
    junk = tmp_path / "junk.onnx"
    junk.write_bytes(b"\xff\xff\xff\xff not a model")
    with pytest.raises(ValueError, match="junk.onnx"):
        OnnxYoloDetector(junk, backend="cv2")


def test_it_is_a_detector_made_by_the_registry(tmp_path):
    path = build_model(tmp_path / "reg.onnx", v8_output([A, B]))
    registry = pytest.importorskip("core.detect.registry")
    det = registry.make_detector(f"onnx:{path}", score_threshold=0.8, backend="cv2")
    assert isinstance(det, Detector) and isinstance(det.params, OnnxYoloParams)
    assert det.name == f"onnx:{path}" and det.params.score_threshold == 0.8
    check(det.detect(FRAME), [A])
    wider = det.with_params(score_threshold=0.5)
    check(wider.detect(FRAME), [A, B])
    reloaded = det.with_params(classes=("x", "y", "z"))  # names change: the model is loaded again
    assert reloaded._net is not det._net and [d.label for d in reloaded.detect(FRAME)] == ["y"]


@pytest.mark.parametrize("shape", [(320, 320, 3), (256, 320, 3), (1, 7, 3)])
def test_the_network_input_is_opencv_dnn_blob_to_the_bit(shape):
    """The letterboxed image as the model's input: what cv2.dnn.blobFromImage(1/255, swapRB) gives."""
    import cv2

    from core.detect.onnx_yolo import network_input

    image = np.random.default_rng(sum(shape)).integers(0, 256, shape, dtype=np.uint8)
    expected = cv2.dnn.blobFromImage(image, 1 / 255.0, swapRB=True, crop=False)
    got = network_input(image)
    assert got.dtype == np.float32 and got.flags.c_contiguous
    assert np.array_equal(got, expected)
