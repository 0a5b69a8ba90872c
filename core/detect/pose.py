"""Body landmarks from a pose model the user supplies as ONNX, run with OpenCV's DNN module.

No model ships with deskarm and none is downloaded: export one yourself (e.g. MoveNet
SinglePose Lightning/Thunder, or a MediaPipe-BlazePose-style landmark model) to ONNX and point
at it (``deskarm --teleop pose:PATH.onnx``). What the model must look like:

**Input**: one image tensor, float32, either NHWC ``(1, H, W, 3)`` (MoveNet's export) or NCHW
``(1, 3, H, W)``, RGB. The size is read from the file (``input_size`` when the file leaves it
dynamic; default 192×192). The whole image is resized to it (no letterbox: MoveNet's and
BlazePose's landmark coordinates are relative to the whole input). Pixel values are 0…255 for
NHWC inputs and 0…1 for NCHW ones unless ``input_range`` says otherwise.

**Output** (the first output), recognised by its shape or named by ``layout``:

* ``movenet``   ``(1, 1, 17, 3)``  17 COCO keypoints, each ``y, x, score``, y and x normalised 0…1;
* ``xy_score``  ``(1, N, 3)`` or ``(1, 1, N, 3)`` with N = 17 (COCO order) or 33 (BlazePose order),
  each ``x, y, score``; x, y normalised 0…1 when every |value| ≤ 1.5, else input pixels;
* ``blazepose`` ``(1, 33, 5)``, ``(1, 39, 5)`` or ``(1, 195)`` (39 × 5), each ``x, y, z, visibility,
  presence`` (MediaPipe's landmark model); x, y in input pixels (or normalised, as above); the
  score is the visibility, passed through a sigmoid when it is a logit (outside 0…1).

``OnnxPoseModel.landmarks(image)`` returns ``{name: (x_px, y_px, score)}`` in the image's pixels
for the named landmarks (COCO names: ``nose``, ``left_eye``, ``right_eye``, ``left_shoulder``,
``right_shoulder``, ``left_elbow``, ``right_elbow``, ``left_wrist``, ``right_wrist``, …; "left" is
the person's left). ``parse_pose_output`` does the parsing alone (tested on planted outputs).
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional, Union

import cv2
import numpy as np

from core.detect.onnx_yolo import read_onnx_info

__all__ = ["OnnxPoseModel", "parse_pose_output", "guess_pose_layout", "COCO_17", "BLAZEPOSE_33", "POSE_LAYOUTS"]

COCO_17 = ("nose", "left_eye", "right_eye", "left_ear", "right_ear", "left_shoulder", "right_shoulder",
           "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_hip", "right_hip", "left_knee",
           "right_knee", "left_ankle", "right_ankle")
BLAZEPOSE_33 = ("nose", "left_eye_inner", "left_eye", "left_eye_outer", "right_eye_inner", "right_eye",
                "right_eye_outer", "left_ear", "right_ear", "mouth_left", "mouth_right", "left_shoulder",
                "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_pinky",
                "right_pinky", "left_index", "right_index", "left_thumb", "right_thumb", "left_hip", "right_hip",
                "left_knee", "right_knee", "left_ankle", "right_ankle", "left_heel", "right_heel",
                "left_foot_index", "right_foot_index")
POSE_LAYOUTS = ("movenet", "xy_score", "blazepose")
LAYOUT_HELP = ("supported pose outputs: movenet (1, 1, 17, 3) [y, x, score] normalised; xy_score (1, N, 3) "
               "[x, y, score] with N = 17 (COCO) or 33 (BlazePose); blazepose (1, 33|39, 5) or (1, 195) "
               "[x, y, z, visibility, presence]")
DEFAULT_INPUT_SIZE = (192, 192)  # (w, h) when the file leaves the input size dynamic
NORMALISED_MAX = 1.5  # coordinates all within this are taken as normalised (0…1), else input pixels

PathLike = Union[str, Path]


def guess_pose_layout(shape: tuple) -> str:
    """The layout of a pose output from its shape; ValueError naming the supported ones otherwise."""
    shape = tuple(int(d) for d in shape)
    if shape == (1, 1, 17, 3):
        return "movenet"
    if len(shape) == 3 and shape[0] == 1 and shape[2] == 5 and shape[1] in (33, 39):
        return "blazepose"
    if shape == (1, 195):
        return "blazepose"
    if (len(shape) == 3 and shape[0] == 1 and shape[2] == 3 and shape[1] in (17, 33)) or \
            (len(shape) == 4 and shape[:2] == (1, 1) and shape[3] == 3 and shape[2] == 33):
        return "xy_score"
    raise ValueError(f"pose model output shape {shape} is not a layout deskarm reads — {LAYOUT_HELP}")


def _sigmoid_if_logit(v: np.ndarray) -> np.ndarray:
    if np.all((v >= 0.0) & (v <= 1.0)):
        return v
    return 1.0 / (1.0 + np.exp(-np.clip(v, -50, 50)))


def parse_pose_output(raw: np.ndarray, image_wh: tuple[int, int], input_wh: tuple[int, int],
                      layout: Optional[str] = None) -> dict[str, tuple[float, float, float]]:
    """A pose model's raw output → {landmark name: (x_px, y_px, score)} in the image's pixels.

    ``image_wh`` is the image's size, ``input_wh`` the network input's (the image was resized to it);
    ``layout`` one of POSE_LAYOUTS, else guessed from the shape. Non-finite landmarks are left out.
    """
    raw = np.asarray(raw, dtype=np.float64)
    layout = layout or guess_pose_layout(raw.shape)
    if layout not in POSE_LAYOUTS:
        raise ValueError(f"pose layout {layout!r}: must be one of {', '.join(POSE_LAYOUTS)}")
    w_img, h_img = image_wh
    w_in, h_in = input_wh
    if layout == "movenet":
        rows = raw.reshape(-1, 3)
        if len(rows) != 17:
            raise ValueError(f"movenet output {raw.shape}: expected 17 keypoints — {LAYOUT_HELP}")
        y, x, score = rows[:, 0], rows[:, 1], rows[:, 2]
        names = COCO_17
        x_px, y_px = x * w_img, y * h_img
    else:
        width = 5 if layout == "blazepose" else 3
        rows = raw.reshape(-1, width)
        if layout == "blazepose":
            rows = rows[:33]
        if len(rows) not in (17, 33):
            raise ValueError(f"pose output {raw.shape} as {layout}: expected 17 or 33 landmarks — {LAYOUT_HELP}")
        names = COCO_17 if len(rows) == 17 else BLAZEPOSE_33
        x, y = rows[:, 0], rows[:, 1]
        score = _sigmoid_if_logit(rows[:, 3]) if layout == "blazepose" else rows[:, 2]
        finite = np.isfinite(x) & np.isfinite(y)
        normalised = bool(np.all(np.abs(x[finite]) <= NORMALISED_MAX) and np.all(np.abs(y[finite]) <= NORMALISED_MAX))
        if normalised:
            x_px, y_px = x * w_img, y * h_img
        else:
            x_px, y_px = x * (w_img / w_in), y * (h_img / h_in)
    out = {}
    for name, a, b, s in zip(names, x_px, y_px, score):
        if np.isfinite(a) and np.isfinite(b) and np.isfinite(s):
            out[name] = (float(a), float(b), float(s))
    return out


class OnnxPoseModel:
    """A single-person pose model from an ONNX file, run by ``cv2.dnn`` (see the module doc)."""

    def __init__(self, path: PathLike, layout: Optional[str] = None,
                 input_size: Optional[tuple[int, int]] = None, input_range: Optional[float] = None,
                 engine: Optional[int] = None):
        self.path = Path(path)
        if not self.path.is_file():
            raise FileNotFoundError(f"pose model not found: {self.path} — export a MoveNet or BlazePose-style "
                                    "model to ONNX and give its path (no model ships with deskarm)")
        if layout is not None and layout not in POSE_LAYOUTS:
            raise ValueError(f"pose layout {layout!r}: must be one of {', '.join(POSE_LAYOUTS)}")
        try:
            info = read_onnx_info(self.path)
        except (ValueError, IndexError) as exc:
            raise ValueError(f"{self.path}: cannot read it as an ONNX model ({exc})") from exc
        shape = tuple(info.input_shape)
        if len(shape) != 4:
            raise ValueError(f"{self.path}: the input {info.input_name!r} has shape {shape}; a pose model takes "
                             "one image, (1, H, W, 3) or (1, 3, H, W)")
        self.nhwc = shape[3] == 3 and shape[1] != 3
        h, w = (shape[1], shape[2]) if self.nhwc else (shape[2], shape[3])
        if h is None or w is None:
            w, h = input_size or DEFAULT_INPUT_SIZE
        elif input_size is not None and tuple(input_size) != (w, h):
            raise ValueError(f"{self.path}: input_size {tuple(input_size)} differs from the model's fixed {(w, h)}")
        self.input_wh = (int(w), int(h))
        self.input_range = float(input_range) if input_range is not None else (255.0 if self.nhwc else 1.0)
        engine = cv2.dnn.ENGINE_AUTO if engine is None else engine
        try:
            self._net = cv2.dnn.readNetFromONNX(str(self.path), engine)  # a path: bytes segfault (TECH_NOTES)
        except cv2.error as exc:
            raise ValueError(f"{self.path}: OpenCV DNN cannot load this model ({exc})") from exc
        raw = self._forward(np.zeros((self.input_wh[1], self.input_wh[0], 3), np.uint8))
        self.layout = layout or guess_pose_layout(raw.shape)
        self.output_shape = tuple(raw.shape)

    def _blob(self, bgr: np.ndarray) -> np.ndarray:
        rgb = cv2.cvtColor(cv2.resize(bgr, self.input_wh, interpolation=cv2.INTER_AREA), cv2.COLOR_BGR2RGB)
        x = rgb.astype(np.float32) * (self.input_range / 255.0)
        x = x[None] if self.nhwc else x.transpose(2, 0, 1)[None]
        return np.ascontiguousarray(x)

    def _forward(self, bgr: np.ndarray) -> np.ndarray:
        self._net.setInput(self._blob(bgr))
        return np.asarray(self._net.forward())

    def landmarks(self, bgr: np.ndarray) -> dict[str, tuple[float, float, float]]:
        """The landmarks of the person in a BGR image: {name: (x_px, y_px, score)} (see the module doc)."""
        raw = self._forward(bgr)
        h, w = bgr.shape[:2]
        return parse_pose_output(raw, (w, h), self.input_wh, self.layout)
