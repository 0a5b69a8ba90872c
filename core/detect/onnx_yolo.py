"""A learned object detector: a YOLO model exported to ONNX, run by OpenCV's DNN module or onnxruntime.

No model ships with deskarm: the user points at an ``.onnx`` file (e.g. ``yolo export format=onnx``).
The output layout is recognised by its shape:

* YOLOv5         ``(1, N, 5+C)``  rows ``cx, cy, w, h, objectness, C class scores``
* YOLOv8 / v11   ``(1, 4+C, N)``  columns ``cx, cy, w, h, C class scores`` (transposed, no objectness)
* end-to-end     ``(1, N, 6)``    rows ``x1, y1, x2, y2, score, class`` (YOLO26, YOLOv10: NMS already done)
* YOLOv2         ``(1, A·(5+C), H, W)`` darknet's region layer: per anchor a and grid cell
  ``tx, ty, tw, th, to, C class logits``; box centre ``(cell + σ(t)) · stride``, size
  ``anchor · exp(t) · stride``, score ``σ(to) · softmax(class)``. The A anchors (width, height pairs
  in grid cells, as in darknet's ``[region] anchors``) come from ``anchors`` or the model's
  metadata key ``anchors`` ("1.08,1.19, 3.42,4.41, …")

Boxes are in the pixels of the letterboxed network input and are mapped back to the image.
Class names come from ``classes`` (a list or a file with one name per line), else from the model's
metadata (ultralytics writes ``names`` as ``"{0: 'person', 1: 'bicycle'}"``), else ``"class N"``.

The ONNX file is read with a small protobuf reader (input shape and metadata only), so the ``onnx``
package is not needed at run time; ``onnxruntime`` is used only when it is importable.
"""
from __future__ import annotations

import ast
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Optional, Sequence, Union

import cv2
import numpy as np

from core.detect.base import BaseDetector, Detection
from core.settings import SettingsError, check_range

__all__ = ["OnnxYoloDetector", "OnnxYoloParams", "OnnxModelInfo", "read_onnx_info", "letterbox", "LAYOUTS",
           "DEFAULT_INPUT_SIZE", "parse_anchors"]

DEFAULT_INPUT_SIZE = 640
LAYOUTS = ("yolov5", "yolov8", "end2end", "yolov2")
LAYOUT_HELP = ("supported layouts: YOLOv5 (1, N, 5+C) [cx, cy, w, h, objectness, class scores...]; "
               "YOLOv8/v11 (1, 4+C, N) [cx, cy, w, h, class scores...]; "
               "end-to-end YOLO26/YOLOv10 (1, N, 6) [x1, y1, x2, y2, score, class]; "
               "YOLOv2 (1, A*(5+C), H, W) with A anchors [tx, ty, tw, th, objectness, class logits...]")
PAD_VALUE = (114, 114, 114)
MAX_CANDIDATES = 30000  # boxes handed to NMS at most (ultralytics' max_nms)

PathLike = Union[str, Path]


# --------------------------------------------------------------------------- the ONNX file, read by hand
@dataclass(frozen=True)
class OnnxModelInfo:
    """What the detector needs from an ONNX file: the image input and the metadata."""
    input_name: str
    input_shape: tuple[Optional[int], ...]  # None for a dynamic (named or unset) dimension
    metadata: dict[str, str] = field(default_factory=dict)


def _varint(buf: memoryview, pos: int) -> tuple[int, int]:
    result = shift = 0
    while True:
        if pos >= len(buf):
            raise ValueError("truncated protobuf varint")
        b = buf[pos]
        pos += 1
        result |= (b & 0x7F) << shift
        if not b & 0x80:
            return result, pos
        shift += 7


def _fields(buf: memoryview):
    """Yield (field number, wire type, value) of one protobuf message; value is int or memoryview."""
    pos = 0
    while pos < len(buf):
        key, pos = _varint(buf, pos)
        number, wire = key >> 3, key & 7
        if wire == 0:
            value, pos = _varint(buf, pos)
        elif wire == 1:
            value, pos = buf[pos:pos + 8], pos + 8
        elif wire == 2:
            length, pos = _varint(buf, pos)
            value, pos = buf[pos:pos + length], pos + length
        elif wire == 5:
            value, pos = buf[pos:pos + 4], pos + 4
        else:
            raise ValueError(f"unsupported protobuf wire type {wire}")
        if pos > len(buf):
            raise ValueError("truncated protobuf message")
        yield number, wire, value


def _text(value: memoryview) -> str:
    return bytes(value).decode("utf-8", errors="replace")


def _shape_of(value_info: memoryview) -> tuple[str, Optional[tuple[Optional[int], ...]]]:
    """ValueInfoProto -> (name, dims or None when it is not a tensor with a shape)."""
    name, dims = "", None
    for number, wire, value in _fields(value_info):
        if number == 1 and wire == 2:
            name = _text(value)
        elif number == 2 and wire == 2:  # TypeProto
            for n2, w2, tensor_type in _fields(value):
                if n2 != 1 or w2 != 2:  # TypeProto.tensor_type
                    continue
                for n3, w3, shape in _fields(tensor_type):
                    if n3 != 2 or w3 != 2:  # TypeProto.Tensor.shape
                        continue
                    dims = []
                    for n4, w4, dim in _fields(shape):
                        if n4 != 1 or w4 != 2:  # TensorShapeProto.dim
                            continue
                        size = None
                        for n5, w5, v5 in _fields(dim):
                            if n5 == 1 and w5 == 0:  # dim_value
                                size = v5 if v5 > 0 else None
                        dims.append(size)
                    dims = tuple(dims)
    return name, dims


def read_onnx_info(path: PathLike) -> OnnxModelInfo:
    """The first image-like (4-D) graph input and the metadata_props of an ONNX file."""
    data = memoryview(Path(path).read_bytes())
    metadata: dict[str, str] = {}
    inputs: list[tuple[str, Optional[tuple]]] = []
    initialisers: set[str] = set()
    for number, wire, value in _fields(data):
        if number == 14 and wire == 2:  # ModelProto.metadata_props
            entry = {n: _text(v) for n, w, v in _fields(value) if w == 2}
            if 1 in entry:
                metadata[entry[1]] = entry.get(2, "")
        elif number == 7 and wire == 2:  # ModelProto.graph
            for n2, w2, v2 in _fields(value):
                if n2 == 11 and w2 == 2:  # GraphProto.input
                    inputs.append(_shape_of(v2))
                elif n2 == 5 and w2 == 2:  # GraphProto.initializer (old exports list them as inputs too)
                    for n3, w3, v3 in _fields(v2):
                        if n3 == 8 and w3 == 2:  # TensorProto.name
                            initialisers.add(_text(v3))
    real = [(n, d) for n, d in inputs if n not in initialisers]
    if not real:
        raise ValueError(f"{path}: no graph input found (is this an ONNX model?)")
    name, dims = next(((n, d) for n, d in real if d is not None and len(d) == 4), real[0])
    return OnnxModelInfo(name, tuple(dims) if dims is not None else (), metadata)


# --------------------------------------------------------------------------- helpers
def parse_names(text: str) -> Optional[list[str]]:
    """Ultralytics' ``names`` metadata ("{0: 'person', ...}" or a list) -> list indexed by class id."""
    try:
        value = ast.literal_eval(text)
    except (ValueError, SyntaxError, MemoryError, RecursionError):
        return None
    if isinstance(value, dict) and value:
        try:
            items = {int(k): str(v) for k, v in value.items()}
        except (TypeError, ValueError):
            return None
        if min(items) < 0:
            return None
        return [items.get(i, f"class {i}") for i in range(max(items) + 1)]
    if isinstance(value, (list, tuple)) and value:
        return [str(v) for v in value]
    return None


def read_classes_file(path: PathLike) -> list[str]:
    """One class name per line (darknet's coco.names); trailing blank lines are dropped."""
    lines = [line.strip() for line in Path(path).read_text(encoding="utf-8").splitlines()]
    while lines and not lines[-1]:
        lines.pop()
    return lines


def _size_wh(size: Union[int, Sequence[int]]) -> tuple[int, int]:
    if isinstance(size, (int, np.integer)):
        return int(size), int(size)
    w, h = (int(v) for v in size)
    return w, h


def quiet_session_options(ort):
    """onnxruntime session options whose worker threads sleep between runs instead of spinning.

    By default they spin after every run waiting for the next: in deskarm's loop (one run per view,
    then tracking, the next camera frame ~30 ms later) that spinning was ~9 of the ~12 ms of CPU a
    run of the shipped desk model cost here (2.7 ms without, same wall time) — CPU a Pi's
    cores, and a CPU budget, need for the window and the rest of the loop."""
    so = ort.SessionOptions()
    so.add_session_config_entry("session.intra_op.allow_spinning", "0")
    so.add_session_config_entry("session.inter_op.allow_spinning", "0")
    return so


def network_input(boxed: np.ndarray) -> np.ndarray:
    """``cv2.dnn.blobFromImage(boxed, 1 / 255, swapRB=True)`` to the bit in a tenth of its time: the
    (1, 3, H, W) float32 input filled one plane at a time (R, G, B)."""
    planes = cv2.split(boxed)
    blob = np.empty((1, 3) + boxed.shape[:2], np.float32)
    for k in range(3):
        np.multiply(planes[2 - k], np.float32(1 / 255.0), out=blob[0, k], dtype=np.float32)
    return blob


def letterbox(image: np.ndarray, size_wh: tuple[int, int]) -> tuple[np.ndarray, float, tuple[float, float]]:
    """Resize keeping the aspect ratio and pad to ``size_wh`` (ultralytics' way, grey 114).

    Returns (padded image, scale, (left, top) padding): ``image_xy = (input_xy - pad) / scale``.
    """
    h, w = image.shape[:2]
    out_w, out_h = size_wh
    scale = min(out_w / w, out_h / h)
    new_w, new_h = int(round(w * scale)), int(round(h * scale))
    if (new_w, new_h) != (w, h):
        image = cv2.resize(image, (new_w, new_h), interpolation=cv2.INTER_LINEAR)
    dw, dh = (out_w - new_w) / 2, (out_h - new_h) / 2
    top, bottom = int(round(dh - 0.1)), int(round(dh + 0.1))
    left, right = int(round(dw - 0.1)), int(round(dw + 0.1))
    if top or bottom or left or right:
        image = cv2.copyMakeBorder(image, top, bottom, left, right, cv2.BORDER_CONSTANT, value=PAD_VALUE)
    return image, scale, (float(left), float(top))


def parse_anchors(value) -> Optional[tuple[float, ...]]:
    """YOLOv2 anchors -> (w0, h0, w1, h1, …) in grid cells: "1.08,1.19, 3.42,4.41", "[[1.08, 1.19], …]"
    or numbers; None for None or an empty text. ValueError for an odd count or a value ≤ 0."""
    if value is None:
        return None
    if isinstance(value, str):
        text = value.replace("[", " ").replace("]", " ").replace("(", " ").replace(")", " ").replace(",", " ")
        if not text.split():
            return None
        try:
            numbers = [float(v) for v in text.split()]
        except ValueError:
            raise ValueError(f"anchors {value!r}: expected numbers, e.g. 1.08,1.19,3.42,4.41") from None
    else:
        numbers = [float(v) for v in np.asarray(value, dtype=float).ravel()]
    if not numbers or len(numbers) % 2:
        raise ValueError(f"anchors {value!r}: need width,height pairs (an even count of numbers)")
    if not all(np.isfinite(numbers)) or min(numbers) <= 0:
        raise ValueError(f"anchors {value!r}: every width and height must be > 0 (grid cells)")
    return tuple(numbers)


def guess_layout(shape: Sequence[int], num_classes: Optional[int] = None,
                 input_wh: Optional[tuple[int, int]] = None, end2end_hint: Optional[bool] = None,
                 num_anchors: Optional[int] = None) -> str:
    """One of LAYOUTS from an output shape; ValueError naming the shape when it is not clear.
    A 4-D output (1, A·(5+C), H, W) is YOLOv2's and needs ``num_anchors`` (A)."""
    shape = tuple(int(s) for s in shape)
    if len(shape) == 4 and shape[0] == 1:
        if not num_anchors:
            raise ValueError(f"YOLO output shape {shape} looks like YOLOv2's (1, A*(5+C), H, W) but the model "
                             f"names no anchors: pass anchors= (--anchors W,H,W,H,…, in grid cells) or add the "
                             f"metadata key 'anchors'); {LAYOUT_HELP}")
        per = shape[1] / num_anchors
        if per != int(per) or per < 6 or (num_classes is not None and per != 5 + num_classes):
            known = f" and {num_classes} class names" if num_classes is not None else ""
            raise ValueError(f"YOLOv2 output shape {shape} does not fit {num_anchors} anchors{known}: "
                             f"its channels must be A*(5+C); {LAYOUT_HELP}")
        return "yolov2"
    dims = shape[1:] if len(shape) == 3 and shape[0] == 1 else shape if len(shape) == 2 else None
    if dims is None:
        raise ValueError(f"unrecognised YOLO output shape {shape}: expected (1, rows, columns); {LAYOUT_HELP}")
    a, b = dims
    candidates = []
    if b == 6 and a >= 1:
        candidates.append("end2end")
    if b >= 6 and a > b and (num_classes is None or b == 5 + num_classes):
        candidates.append("yolov5")
    if a >= 5 and b > a and (num_classes is None or a == 4 + num_classes):
        candidates.append("yolov8")
    if set(candidates) == {"end2end", "yolov5"}:  # (1, N, 6): one-class YOLOv5 or end-to-end?
        if end2end_hint is not None:
            candidates = ["end2end" if end2end_hint else "yolov5"]
        elif input_wh is not None:
            w, h = input_wh
            anchors = 3 * sum((w // s) * (h // s) for s in (8, 16, 32))  # YOLOv5's grid at strides 8/16/32
            candidates = ["yolov5" if a == anchors else "end2end"]
        else:  # nothing to tell them apart: end-to-end (a one-class YOLOv5 has thousands of rows)
            candidates = ["end2end"]
    if len(candidates) != 1:
        why = "ambiguous" if candidates else "unrecognised"
        known = f" with {num_classes} class names" if num_classes is not None else ""
        raise ValueError(f"{why} YOLO output shape {shape}{known}; {LAYOUT_HELP}; "
                         f"pass layout= one of {LAYOUTS} to choose")
    return candidates[0]


# --------------------------------------------------------------------------- the detector
BACKENDS = ("auto", "cv2", "onnxruntime")
_POST_ONLY = {"score_threshold", "nms_iou", "max_detections"}  # changes that keep the loaded network


@dataclass(frozen=True)
class OnnxYoloParams:
    """Settings of ``OnnxYoloDetector``."""

    path: str  # the .onnx file
    classes: Optional[Union[tuple[str, ...], str]] = None  # names, or a file with one per line; None: metadata
    input_size: Optional[Union[int, tuple[int, int]]] = None  # (width, height) for a dynamic input; None: 640
    score_threshold: float = 0.25  # lowest score reported, 0 … 1
    nms_iou: float = 0.45  # overlap (IoU) above which the weaker box of a class is dropped, 0 … 1
    backend: str = "auto"  # "auto" (onnxruntime when installed, else OpenCV), "cv2", "onnxruntime"
    layout: Optional[str] = None  # force "yolov5", "yolov8" or "end2end"; None: from the output shape
    max_detections: int = 300  # most detections reported, 1 … 10000
    # YOLOv2 only: anchor (width, height) pairs in grid cells, flat; None: the model's metadata "anchors"
    anchors: Optional[Union[tuple[float, ...], str]] = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "path", str(self.path))
        try:
            object.__setattr__(self, "anchors", parse_anchors(self.anchors))
        except (ValueError, TypeError) as exc:
            raise SettingsError(f"onnx.anchors: {exc}") from None
        if self.classes is not None:
            if isinstance(self.classes, Path):
                object.__setattr__(self, "classes", str(self.classes))
            elif not isinstance(self.classes, str):
                object.__setattr__(self, "classes", tuple(str(c) for c in self.classes))
        if self.input_size is not None:
            try:
                wh = _size_wh(self.input_size)
            except (TypeError, ValueError):
                raise SettingsError(f"onnx.input_size = {self.input_size!r} must be a whole number or "
                                    f"(width, height)") from None
            for v in wh:
                check_range("onnx", "input_size", v, 32, 4096)
            object.__setattr__(self, "input_size", wh)
        check_range("onnx", "score_threshold", float(self.score_threshold), 0.0, 1.0)
        check_range("onnx", "nms_iou", float(self.nms_iou), 0.0, 1.0)
        if isinstance(self.max_detections, bool) or not isinstance(self.max_detections, (int, np.integer)):
            raise SettingsError(f"onnx.max_detections = {self.max_detections!r} must be a whole number")
        check_range("onnx", "max_detections", self.max_detections, 1, 10000)
        if self.backend not in BACKENDS:
            raise SettingsError(f"onnx.backend = {self.backend!r} must be one of {', '.join(BACKENDS)}")
        if self.layout is not None and self.layout not in LAYOUTS:
            raise SettingsError(f"onnx.layout = {self.layout!r} must be one of {', '.join(LAYOUTS)} (or unset)")


class OnnxYoloDetector(BaseDetector):
    """Objects found by a YOLO ONNX model: ``detect(image_bgr, roi=None) -> list[Detection]``.

    ``OnnxYoloDetector(path, classes=None, input_size=None, score_threshold=0.25, nms_iou=0.45,
    backend="auto", layout=None, max_detections=300)`` or ``OnnxYoloDetector(OnnxYoloParams(...))``.
    ``input_size`` (int or (width, height)) is needed only when the model's input is dynamic
    (a fixed input is read from the model; a different input_size is an error); default 640,
    or the ``imgsz`` the exporter wrote. ``backend`` "auto" takes onnxruntime when it is
    importable (usually the faster one on a CPU), else OpenCV's DNN. ``layout`` forces one of
    LAYOUTS when the output shape is ambiguous. The model is loaded and run once at construction,
    so a bad file or an unknown output layout fails here, not in ``detect``.
    """

    kind = "object"
    params_type = OnnxYoloParams
    heavy = True  # a forward pass a view: the stereo perception alternates views between full searches

    def __init__(self, path: Union[PathLike, OnnxYoloParams], classes: Optional[Union[Sequence[str], PathLike]] = None,
                 input_size: Optional[Union[int, Sequence[int]]] = None, score_threshold: float = 0.25,
                 nms_iou: float = 0.45, backend: str = "auto", layout: Optional[str] = None,
                 max_detections: int = 300, anchors=None, *, engine: Optional[int] = None, _loaded=None):
        if isinstance(path, OnnxYoloParams):
            params = path
        else:
            params = OnnxYoloParams(str(path), classes, input_size, score_threshold, nms_iou, backend, layout,
                                    max_detections, anchors)
        super().__init__(params)
        self.path = Path(params.path)
        self.name = f"onnx:{params.path}"
        self.last_inference_ms = 0.0  # the network's forward pass alone, for a status line
        if _loaded is not None:  # with_params changing only the post-processing: share the network
            self.__dict__.update(_loaded)
            return
        if not self.path.is_file():
            raise FileNotFoundError(f"ONNX model not found: {self.path}")
        try:
            self.info = read_onnx_info(self.path)
        except (ValueError, IndexError) as exc:
            raise ValueError(f"{self.path}: cannot read it as an ONNX model ({exc})") from exc
        self.input_wh = self._input_size(params.input_size)
        self.names = self._names(params.classes)
        try:
            self.anchors = params.anchors or parse_anchors(self.info.metadata.get("anchors"))
        except ValueError as exc:
            raise ValueError(f"{self.path}: its metadata key 'anchors': {exc}") from None

        self.backend = self._pick_backend(params.backend)
        self._session = self._net = None
        if self.backend == "onnxruntime":
            import onnxruntime as ort

            self._session = ort.InferenceSession(str(self.path), quiet_session_options(ort),
                                                 providers=["CPUExecutionProvider"])
            self._ort_input = self._session.get_inputs()[0].name
        else:
            engine = cv2.dnn.ENGINE_AUTO if engine is None else engine  # new engine first, classic fallback
            try:
                self._net = cv2.dnn.readNetFromONNX(str(self.path), engine)  # a path: bytes segfault
            except cv2.error as exc:
                raise ValueError(f"{self.path}: OpenCV DNN cannot load this model ({exc})") from exc

        # one forward pass on a grey frame: warms up and learns the output layout (fails here, not later)
        w, h = self.input_wh
        raw = self._forward(np.full((1, 3, h, w), 114 / 255, np.float32))
        end2end = self.info.metadata.get("end2end")
        hint = None if end2end is None else end2end.strip().lower() in ("true", "1", "yes")
        self.layout = params.layout or guess_layout(raw.shape, self._declared_classes, self.input_wh, hint,
                                                    len(self.anchors) // 2 if self.anchors else None)
        if self.layout == "yolov2":
            if not self.anchors:
                raise ValueError(f"{self.path}: a YOLOv2 output needs anchors (--anchors or the metadata key "
                                 f"'anchors')")
            if raw.ndim != 4 or raw.shape[1] % (len(self.anchors) // 2):
                raise ValueError(f"{self.path}: output {tuple(raw.shape)} is not YOLOv2's (1, A*(5+C), H, W) for "
                                 f"{len(self.anchors) // 2} anchors; {LAYOUT_HELP}")
        self.output_shape = tuple(raw.shape)
        self.num_classes = self._count_classes(raw.shape)

    def with_params(self, **changes) -> "OnnxYoloDetector":
        """A new detector with some settings changed; thresholds alone keep the loaded network."""
        params = replace(self._params, **changes)
        if set(changes) <= _POST_ONLY:
            shared = {k: v for k, v in self.__dict__.items() if k not in ("_params", "last_inference_ms")}
            return type(self)(params, _loaded=shared)
        return type(self)(params)

    @property
    def score_threshold(self) -> float:
        return float(self._params.score_threshold)

    @property
    def nms_iou(self) -> float:
        return float(self._params.nms_iou)

    @property
    def max_detections(self) -> int:
        return int(self._params.max_detections)

    # -- set-up
    def _input_size(self, requested) -> tuple[int, int]:
        shape = self.info.input_shape
        model_wh = None
        if len(shape) == 4 and shape[2] and shape[3]:
            model_wh = (int(shape[3]), int(shape[2]))
        if requested is not None:
            wh = _size_wh(requested)
            if model_wh is not None and wh != model_wh:
                raise SettingsError(f"onnx.input_size = {wh} (width, height) differs from the model's fixed "
                                    f"input {model_wh}: leave input_size unset")
            return wh
        if model_wh is not None:
            return model_wh
        imgsz = self.info.metadata.get("imgsz")  # ultralytics: "[640, 640]" as [height, width]
        if imgsz:
            try:
                v = ast.literal_eval(imgsz)
                if isinstance(v, (list, tuple)) and len(v) == 2:
                    return int(v[1]), int(v[0])
                if isinstance(v, int):
                    return v, v
            except (ValueError, SyntaxError, TypeError):
                pass
        return DEFAULT_INPUT_SIZE, DEFAULT_INPUT_SIZE

    def _names(self, classes) -> list[str]:
        self._declared_classes: Optional[int] = None
        if isinstance(classes, str):
            names = read_classes_file(classes)
            self.names_source = "classes file"
        elif classes is not None:
            names = list(classes)
            self.names_source = "classes"
        else:
            names = parse_names(self.info.metadata.get("names", "")) or []
            self.names_source = "model metadata" if names else "none"
        if names:
            self._declared_classes = len(names)
        return names

    def _count_classes(self, shape) -> Optional[int]:
        dims = tuple(shape)[-2:]
        if self.layout == "yolov5":
            return dims[1] - 5
        if self.layout == "yolov8":
            return dims[0] - 4
        if self.layout == "yolov2":
            return int(shape[1]) // (len(self.anchors) // 2) - 5
        return self._declared_classes

    @staticmethod
    def _pick_backend(backend: str) -> str:
        if backend == "cv2":
            return "cv2"
        try:
            import onnxruntime  # noqa: F401
        except ImportError:
            if backend == "onnxruntime":
                raise ImportError("backend='onnxruntime' but onnxruntime is not installed "
                                  "(pip install onnxruntime, or use backend='cv2')") from None
            return "cv2"
        return "onnxruntime"

    # -- running
    def _forward(self, blob: np.ndarray) -> np.ndarray:
        t0 = time.perf_counter()
        if self._session is not None:
            out = self._session.run(None, {self._ort_input: blob})[0]
        else:
            self._net.setInput(blob)
            out = self._net.forward()
        self.last_inference_ms = (time.perf_counter() - t0) * 1000
        out = np.asarray(out, dtype=np.float32)
        return out if out.ndim != 2 else out[None]

    def label(self, class_id: int) -> str:
        return self.names[class_id] if 0 <= class_id < len(self.names) else f"class {class_id}"

    def decode(self, raw: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Raw output -> (boxes x1 y1 x2 y2 in input pixels, scores, class ids), above the threshold."""
        if self.layout == "yolov2":
            return self._decode_yolov2(raw)
        rows = raw.reshape(raw.shape[-2:])
        if self.layout == "yolov8":
            rows = rows.T
        if self.layout == "end2end":
            boxes, scores, ids = rows[:, :4], rows[:, 4], np.rint(rows[:, 5]).astype(np.int64)
        else:
            if self.layout == "yolov5":
                class_scores = rows[:, 5:] * rows[:, 4:5]
            else:
                class_scores = rows[:, 4:]
            ids = np.argmax(class_scores, axis=1)
            scores = class_scores[np.arange(len(rows)), ids]
            cx, cy, bw, bh = rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3]
            boxes = np.stack([cx - bw / 2, cy - bh / 2, cx + bw / 2, cy + bh / 2], axis=1)
        keep = np.isfinite(scores) & (scores >= self.score_threshold)
        return boxes[keep], np.clip(scores[keep], 0.0, 1.0), ids[keep]

    def _decode_yolov2(self, raw: np.ndarray):
        """Darknet's region layer: (1, A·(5+C), H, W) -> boxes in input pixels, scores, class ids."""
        n_anchors = len(self.anchors) // 2
        _, channels, gh, gw = raw.shape
        t = raw.reshape(n_anchors, channels // n_anchors, gh, gw).astype(np.float64)
        anchors = np.asarray(self.anchors, dtype=np.float64).reshape(n_anchors, 2)
        sigmoid = (lambda v: 1.0 / (1.0 + np.exp(-np.clip(v, -60.0, 60.0))))
        stride_x, stride_y = self.input_wh[0] / gw, self.input_wh[1] / gh
        col = np.arange(gw)[None, None, :]
        row = np.arange(gh)[None, :, None]
        cx = (col + sigmoid(t[:, 0])) * stride_x
        cy = (row + sigmoid(t[:, 1])) * stride_y
        bw = anchors[:, 0, None, None] * np.exp(np.clip(t[:, 2], -20.0, 20.0)) * stride_x
        bh = anchors[:, 1, None, None] * np.exp(np.clip(t[:, 3], -20.0, 20.0)) * stride_y
        logits = t[:, 5:]
        prob = np.exp(logits - logits.max(axis=1, keepdims=True))
        prob /= prob.sum(axis=1, keepdims=True)
        class_scores = (sigmoid(t[:, 4])[:, None] * prob).transpose(0, 2, 3, 1).reshape(-1, channels // n_anchors - 5)
        ids = np.argmax(class_scores, axis=1)
        scores = class_scores[np.arange(len(ids)), ids]
        cx, cy, bw, bh = (v.reshape(-1) for v in (cx, cy, bw, bh))
        boxes = np.stack([cx - bw / 2, cy - bh / 2, cx + bw / 2, cy + bh / 2], axis=1)
        keep = np.isfinite(scores) & (scores >= self.score_threshold)
        return (boxes[keep].astype(np.float32), np.clip(scores[keep], 0.0, 1.0).astype(np.float32), ids[keep])

    def _nms(self, boxes, scores, ids) -> np.ndarray:
        order = np.argsort(-scores, kind="stable")
        if self.layout == "end2end" or len(scores) == 0:
            return order[: self.max_detections]
        order = order[:MAX_CANDIDATES]
        boxes, scores, ids = boxes[order], scores[order], ids[order]
        xywh = np.column_stack([boxes[:, 0], boxes[:, 1], boxes[:, 2] - boxes[:, 0], boxes[:, 3] - boxes[:, 1]])
        keep = cv2.dnn.NMSBoxesBatched(xywh.astype(np.float32).tolist(), scores.astype(np.float32).tolist(),
                                       ids.astype(np.int32).tolist(), self.score_threshold, self.nms_iou)
        keep = np.asarray(keep, dtype=np.int64).reshape(-1)
        keep = keep[np.argsort(-scores[keep], kind="stable")]
        return order[keep[: self.max_detections]]

    def _detect(self, image: np.ndarray) -> list[Detection]:
        """Objects in a BGR or grey image (already cropped to the ROI by BaseDetector), best first."""
        if image.ndim == 2:
            image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        h, w = image.shape[:2]
        boxed, scale, (left, top) = letterbox(image, self.input_wh)
        raw = self._forward(network_input(boxed))
        boxes, scores, ids = self.decode(raw)
        found = []
        for i in self._nms(boxes, scores, ids):
            x1, y1, x2, y2 = boxes[i]
            x1 = float(np.clip((x1 - left) / scale, 0, w))
            x2 = float(np.clip((x2 - left) / scale, 0, w))
            y1 = float(np.clip((y1 - top) / scale, 0, h))
            y2 = float(np.clip((y2 - top) / scale, 0, h))
            if x2 <= x1 or y2 <= y1:
                continue
            found.append(Detection(kind=self.kind, label=self.label(int(ids[i])), score=float(scores[i]),
                                   box=(x1, y1, x2 - x1, y2 - y1), centre_px=((x1 + x2) / 2, (y1 + y2) / 2)))
        return found

    def __repr__(self) -> str:
        return (f"OnnxYoloDetector({self.path.name!r}, layout={self.layout}, backend={self.backend}, "
                f"input={self.input_wh[0]}x{self.input_wh[1]}, classes={self.num_classes})")
