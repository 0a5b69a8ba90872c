"""The desk detector's ONNX graph, built from plain numpy weights (numpy + onnx, no torch).

``core.detect.learned.model.export_onnx`` folds a DeskNet's batch norm and hands its weights here;
a test without torch builds a tiny model the same way. The graph:

* the backbone (stride 8, and a stride-16 branch upsampled and concatenated back), the head, the
  class scores (sigmoids) and the boxes (``stride · exp(clip(raw))`` distances to the edges,
  decoded to cx, cy, w, h in input pixels) — one candidate row per stride-8 cell;
* one *taught branch* per class taught later (``core.detect.learned.teach``): conv-ReLU layers of
  its own on the backbone's features and the head's output, its own score and its own box, giving
  H·W more candidate rows that hold only that class's score (0 for every other class), while the
  old rows hold 0 for the taught classes. The old rows are computed by the same nodes as in the
  model the branch was added to, so they are what they were, bit for bit.

Output "output0" (1, 4 + C, (1 + T) · H · W): the YOLOv8 layout ``OnnxYoloDetector`` decodes (each
row a candidate with per-class scores; NMS per class). Only Conv, Relu, Resize (nearest), Concat,
Sigmoid, Clip, Exp, Add and Reshape: OpenCV's DNN module runs it.
"""
from __future__ import annotations

import json
from typing import Optional, Sequence

import numpy as np

__all__ = ["build_desk_onnx", "STRIDE", "MAX_LOG_DISTANCE", "grid_centres", "taught_branches"]

STRIDE = 8  # px of the network input per output cell
MAX_LOG_DISTANCE = 6.0  # raw box outputs are clipped to ±this before exp (e^6 · 8 px ≈ 3200 px)


def grid_centres(h: int, w: int, stride: int = STRIDE) -> tuple[np.ndarray, np.ndarray]:
    """Cell centres (x (W,), y (H,)) in input pixels: cell i's centre is at (i + 0.5) · stride."""
    return (np.arange(w) + 0.5) * stride, (np.arange(h) + 0.5) * stride


def taught_branches(metadata: dict) -> list[dict]:
    """The taught branches a model's ``architecture`` metadata describes ([] for none)."""
    arch = metadata.get("architecture")
    if not arch:
        return []
    return list(json.loads(arch).get("taught", []))


def build_desk_onnx(layers: dict, arch: dict, names: Sequence[str], input_wh: tuple[int, int],
                    metadata: Optional[dict] = None, opset: int = 17, features_only: bool = False):
    """The ONNX ModelProto of a desk detector.

    ``layers``: name → (weight (O, I, k, k), bias (O,), stride) for "stride8.0" … "stride16.0" …,
    "head.0", "head.1", "classes", "box", and per taught branch j its layers "taught{j}.0",
    "taught{j}.1" …, "taught{j}.score", "taught{j}.box" (batch norm already folded). ``arch``:
    {"widths", "head_width", "taught": [{"name", "width", "kernels"}, …]} (written to the
    ``architecture`` metadata).
    ``names``: the old classes, then one per taught branch. ``features_only``: a graph whose output
    "features" (1, c + d + head_width, H, W) is what a taught branch sees (teaching runs it in
    OpenCV's DNN, several times faster than torch on a CPU)."""
    import onnx
    from onnx import helper, numpy_helper

    layers = dict(layers)  # the zero layers are added to a copy
    w, h = (int(v) for v in input_wh)
    if h % 16 or w % 16:
        raise ValueError(f"input {w}x{h}: width and height must be multiples of 16")
    taught = list(arch.get("taught", []))
    n_old = int(layers["classes"][0].shape[0])
    if len(names) != n_old + len(taught):
        raise ValueError(f"{len(names)} class names for a network with {n_old} classes and {len(taught)} taught")
    num_classes = len(names)
    gh, gw = h // STRIDE, w // STRIDE
    nodes, inits = [], []

    def const(name: str, array: np.ndarray) -> str:
        inits.append(numpy_helper.from_array(np.ascontiguousarray(array), name))
        return name

    def conv(x: str, name: str, relu: bool = True) -> str:
        weight, bias, stride = layers[name]
        weight, bias = np.asarray(weight, np.float32), np.asarray(bias, np.float32)
        k = weight.shape[-1]
        out = f"{name}_conv" if relu else name
        nodes.append(helper.make_node("Conv", [x, const(f"{name}.weight", weight), const(f"{name}.bias", bias)],
                                      [out], name=f"{name}/Conv", kernel_shape=[k, k], strides=[stride, stride],
                                      pads=[k // 2] * 4))
        if not relu:
            return out
        nodes.append(helper.make_node("Relu", [out], [name], name=f"{name}/Relu"))
        return name

    def seq(x: str, prefix: str) -> str:
        i = 0
        while f"{prefix}.{i}" in layers:
            x = conv(x, f"{prefix}.{i}")
            i += 1
        return x

    def zeros(x: str, channels_in: int, count: int, name: str) -> str:
        # exact zeros of the grid's shape: a 1×1 convolution with zero weights (OpenCV's DNN runs
        # it; a Concat with a constant input it may not)
        layers[name] = (np.zeros((count, channels_in, 1, 1), np.float32), np.zeros(count, np.float32), 1)
        return conv(x, name, relu=False)

    mix = STRIDE * np.array([[-0.5, 0, 0.5, 0], [0, -0.5, 0, 0.5], [1, 0, 1, 0], [0, 1, 0, 1]], np.float32)
    const("decode.weight", mix.reshape(4, 4, 1, 1))
    const("decode.bias", np.zeros(4, np.float32))
    const("clip.min", np.array(-MAX_LOG_DISTANCE, np.float32))
    const("clip.max", np.array(MAX_LOG_DISTANCE, np.float32))
    gx, gy = grid_centres(gh, gw)
    grid = np.zeros((1, 4, gh, gw), np.float32)
    grid[0, 0] = gx[None, :]
    grid[0, 1] = gy[:, None]
    const("decode.grid", grid)

    def boxes(raw: str, prefix: str) -> str:
        # (l, t, r, b) distances → (cx − gx, cy − gy, w, h), times the stride, as a fixed 1×1 convolution
        nodes.append(helper.make_node("Clip", [raw, "clip.min", "clip.max"], [f"{prefix}_clipped"],
                                      name=f"{prefix}/Clip"))
        nodes.append(helper.make_node("Exp", [f"{prefix}_clipped"], [f"{prefix}_ltrb"], name=f"{prefix}/Exp"))
        nodes.append(helper.make_node("Conv", [f"{prefix}_ltrb", "decode.weight", "decode.bias"],
                                      [f"{prefix}_rel"], name=f"{prefix}/decode", kernel_shape=[1, 1]))
        nodes.append(helper.make_node("Add", [f"{prefix}_rel", "decode.grid"], [f"{prefix}_cxcywh"],
                                      name=f"{prefix}/grid"))
        return f"{prefix}_cxcywh"

    f8 = seq("images", "stride8")
    f16 = seq(f8, "stride16")
    nodes.append(helper.make_node("Resize", [f16, "", const("up.scales", np.array([1, 1, 2, 2], np.float32))],
                                  ["up"], name="up/Resize", mode="nearest"))
    nodes.append(helper.make_node("Concat", [f8, "up"], ["cat"], name="cat/Concat", axis=1))
    hx = seq("cat", "head")
    head_width = int(layers[hx][0].shape[0])
    if features_only:
        c_out = int(layers[f8][0].shape[0]) + int(layers[f16][0].shape[0]) + head_width
        nodes.append(helper.make_node("Concat", ["cat", hx], ["features"], name="features/Concat", axis=1))
        return _model(helper, onnx, nodes, inits, "features", [1, c_out, gh, gw], h, w, opset, {})
    cls = conv(hx, "classes", relu=False)
    nodes.append(helper.make_node("Sigmoid", [cls], ["scores"], name="scores/Sigmoid"))
    # the old rows: exactly the nodes of a model without taught classes (box/Clip … keep their names)
    nodes.append(helper.make_node("Clip", [conv(hx, "box", relu=False), "clip.min", "clip.max"], ["box_clipped"],
                                  name="box/Clip"))
    nodes.append(helper.make_node("Exp", ["box_clipped"], ["ltrb"], name="box/Exp"))
    nodes.append(helper.make_node("Conv", ["ltrb", "decode.weight", "decode.bias"], ["cxcywh_rel"],
                                  name="decode/Conv", kernel_shape=[1, 1]))
    nodes.append(helper.make_node("Add", ["cxcywh_rel", "decode.grid"], ["cxcywh"], name="decode/Add"))
    old_rows = ["cxcywh", "scores"]
    if taught:
        old_rows.append(zeros(hx, head_width, len(taught), "old.no_taught"))
    nodes.append(helper.make_node("Concat", old_rows, ["rows"], name="rows/Concat", axis=1))
    blocks = ["rows"]
    if taught:
        nodes.append(helper.make_node("Concat", ["cat", hx], ["taught_in"], name="taught_in/Concat", axis=1))
    for j, branch in enumerate(taught):
        p = f"taught{j}"
        x = seq("taught_in", p)
        width = int(layers[x][0].shape[0])
        logit = conv(x, f"{p}.score", relu=False)
        nodes.append(helper.make_node("Sigmoid", [logit], [f"{p}_score"], name=f"{p}/Sigmoid"))
        parts = [boxes(conv(x, f"{p}.box", relu=False), f"{p}.box")]
        before, after = n_old + j, len(taught) - j - 1
        if before:
            parts.append(zeros(x, width, before, f"{p}.zeros_before"))
        parts.append(f"{p}_score")
        if after:
            parts.append(zeros(x, width, after, f"{p}.zeros_after"))
        nodes.append(helper.make_node("Concat", parts, [f"{p}_rows"], name=f"{p}/Concat", axis=1))
        blocks.append(f"{p}_rows")
    if len(blocks) > 1:  # the candidates of each block one after the other: stacked along the grid's rows
        nodes.append(helper.make_node("Concat", blocks, ["all_rows"], name="all_rows/Concat", axis=2))
        rows = "all_rows"
    else:
        rows = "rows"
    n = (1 + len(taught)) * gh * gw
    nodes.append(helper.make_node("Reshape", [rows, const("output.shape", np.array([1, 4 + num_classes, n], np.int64))],
                                  ["output0"], name="output0/Reshape"))
    meta = {"names": repr({i: str(n) for i, n in enumerate(names)}), "imgsz": f"[{h}, {w}]", "stride": str(STRIDE),
            "task": "detect", "batch": "1",
            "description": "deskarm desk-object detector (CenterNet-style, stride 8), trained on simulated renders",
            "author": "deskarm", "license": "MIT", "architecture": json.dumps(arch)}
    for key, value in (metadata or {}).items():
        meta[str(key)] = json.dumps(value) if isinstance(value, (dict, list)) else str(value)
    return _model(helper, onnx, nodes, inits, "output0", [1, 4 + num_classes, n], h, w, opset, meta)


def _model(helper, onnx, nodes, inits, output: str, shape, h: int, w: int, opset: int, meta: dict):
    from onnx import TensorProto

    graph = helper.make_graph(
        nodes, "deskarm_desk_detector",
        [helper.make_tensor_value_info("images", TensorProto.FLOAT, [1, 3, h, w])],
        [helper.make_tensor_value_info(output, TensorProto.FLOAT, list(shape))],
        initializer=inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", opset)],
                              producer_name="deskarm", producer_version="1")
    model.ir_version = 8
    if meta:
        helper.set_model_props(model, meta)
    onnx.checker.check_model(model)
    return model
