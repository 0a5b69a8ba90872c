"""Seeing any object (issue 11): detectors, trackers, ONNX backends and the whole object loop,
on renders of the simulated desk's ``objects`` scenario at 640×480 (8 marker-less things, 2 cards).

Frames are rendered once up front (``SimDesk.render`` at 30 fps scenario time); only detection,
tracking and perception are timed. Everything of one frame is measured back to back, frame after
frame (interleaved), so every row saw the same machine state as its baseline.

Rows:

- **baseline**: ``StereoMarkerPerception.process`` on the same frames — the marker loop deskarm
  already runs every frame (ROI search around the markers, point-wise rectification): what a
  detector costs is shown as a multiple of it.
- **detector, full frame**: ``detector.detect(left)`` + ``detector.detect(right)`` (ms per pair)
  for hsv (the default named colours), circles, aruco and an ONNX YOLO model (backend "auto",
  what the user gets).
- **detector, ROI**: the same detector run once per object inside a window around its predicted
  position (``detect(image, roi=…)``): where it found that object in the previous frame, moved on
  by its motion since the frame before (constant velocity in the image); window side
  ``ROI_BOX_FACTOR`` × the box's longer side, at least ``ROI_MIN_PX``; summed over the objects and
  both views (ms per pair). Only the objects already known are looked for: new objects still need
  a full-frame pass now and then. A model that finds nothing (the synthetic one) gets windows
  around the objects' true positions instead, so its ROI cost is still what a real model's
  would be. The extra column says how many of this frame's full-frame detections the ROIs found
  again.
- **trackers**: ``ObjectTracker.update`` (the OpenCV tracker on its search window, plus the
  appearance check) following the red ball through the sequence, left view, per update, no
  detections given (no re-seeding); updates after the tracker declared the ball lost do nothing
  and are not timed (the extra column says so). The baseline is the hsv detector on one full
  view of the same frame (detecting every frame instead of tracking).
- **ONNX backends**: the same model and images through OpenCV's DNN module and onnxruntime
  (``OnnxYoloDetector(backend=…)``), ms per pair; "onnxruntime not installed" skips that row only.
- **object loop**: ``StereoObjectPerception.process`` with hsv per frame, as ``deskarm --detector
  hsv`` runs it (detect both views, match, triangulate, track), against the marker baseline; and
  the same loop with the options meant to make it cheaper (``roi_search``; a KCF tracker with the
  detector on every 3rd frame) against it.

The ONNX model: ``resources/models/desk_objects.onnx`` when it exists, else a synthetic
YOLOv8-layout network built here with the ``onnx`` package (random convolution weights, ~1 GFLOP
at 320×320, no detections: its figures are the cost of a network of that size, not of a detector
that finds anything). Run alone: ``python -m bench.bench_detect [--quick]``.
"""
from __future__ import annotations

import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

REPO = Path(__file__).resolve().parents[1]
SHIPPED_MODEL = REPO / "resources" / "models" / "desk_objects.onnx"
FPS = 30.0  # scenario time between rendered frames (s⁻¹)
ROI_MIN_PX = 96  # smallest ROI window side
ROI_BOX_FACTOR = 3.0  # ROI window side = this × the previous box's longer side
PREDICT_GATE_PX = 40.0  # a detection this near one of the same label a frame earlier is that object
MATCH_PX = 3.0  # an ROI detection within this of a full-frame one (same label) found it again
DETECTORS = ("hsv", "circles", "aruco")
TRACKERS = ("KCF", "CSRT", "MIL", "MOSSE")
TRACKED_COLOUR = "red"  # the hsv label of the object the trackers follow (the red ball)
SYNTHETIC_INPUT = 320
SYNTHETIC_CLASSES = 8  # the objects scenario's things

BASELINE = "detect baseline: marker perception (objects)"
OBJECT_LOOP = "object loop: StereoObjectPerception(hsv)"
# (row name, StereoObjectPerception options, what it does): the first as DeskSession builds it for
# `--detector hsv`; the others are its options meant for a cheaper loop (skipped when it lacks them)
OBJECT_LOOPS = (
    (OBJECT_LOOP, {}, "as `deskarm --detector hsv` runs it: detect both full views, match, triangulate, track"),
    ("object loop: hsv, roi_search", {"roi_search": True},
     "detect in windows around the tracks' predictions, full frame every 10th frame (and on doubt)"),
    ("object loop: hsv, kcf tracker, detect every 3", {"tracker": "kcf", "detect_every": 3},
     "KCF per object and view; the detector on every 3rd frame, the trackers' boxes in between"),
)
TRACK_BASELINE = "track baseline: hsv detect, one full view"
ORT_MISSING = "onnxruntime not installed"


def _ms(t0: float, t1: float) -> float:
    return (t1 - t0) * 1e3


# --------------------------------------------------------------------------------------------
# frames


def render_sequence(n: int, seed: int = 0):
    """The simulated rig and ``n`` consecutive stereo frames (30 fps) of the objects scenario."""
    from core.sim.desk import SimDesk
    from core.sim.rig import SimRig

    rig = SimRig()
    desk = SimDesk(rig, scenario="objects", seed=seed)
    return rig, [desk.stereo_frame(k + 1, k / FPS) for k in range(n)]


def predicted_centres(previous: Sequence, before: Sequence = (), gate_px: float = PREDICT_GATE_PX):
    """Where each of ``previous`` (last frame's detections) should be now: moved on by its motion
    since ``before`` (the frame before: the nearest detection of the same label within ``gate_px``),
    else where it was."""
    out = []
    for d in previous:
        cx, cy = d.centre_px
        near = [b for b in before if b.label == d.label and math.dist(b.centre_px, d.centre_px) <= gate_px]
        if near:
            bx, by = min(near, key=lambda b: math.dist(b.centre_px, d.centre_px)).centre_px
            cx, cy = 2 * cx - bx, 2 * cy - by
        out.append((cx, cy))
    return out


def roi_windows(detections: Sequence, shape, before: Sequence = (), min_px: int = ROI_MIN_PX,
                factor: float = ROI_BOX_FACTOR) -> list[tuple[int, int, int, int]]:
    """One square window (x, y, w, h) per detection: centred on its predicted position (see
    ``predicted_centres``), ``factor`` × its longer box side (at least ``min_px``), moved inside
    an image of ``shape``."""
    H, W = shape[:2]
    out = []
    for d, (cx, cy) in zip(detections, predicted_centres(detections, before)):
        side = int(math.ceil(max(min_px, factor * max(d.box[2], d.box[3]))))
        w, h = min(side, W), min(side, H)
        x = min(max(int(round(cx - w / 2)), 0), W - w)
        y = min(max(int(round(cy - h / 2)), 0), H - h)
        out.append((x, y, w, h))
    return out


def truth_windows(rig, truth, side: str, shape, size_px: int = ROI_MIN_PX) -> list[tuple[int, int, int, int]]:
    """``size_px`` windows around the projected truth centres of the objects visible in ``side``
    (for a model that finds nothing, e.g. the synthetic one: where a real one would look)."""
    H, W = shape[:2]
    out = []
    for obj in truth.objects:
        if not (obj.visible_left if side == "left" else obj.visible_right):
            continue
        cx, cy = rig.project(side, np.asarray(obj.base_p_centre, float))[0]
        w, h = min(size_px, W), min(size_px, H)
        x = min(max(int(round(cx - w / 2)), 0), W - w)
        y = min(max(int(round(cy - h / 2)), 0), H - h)
        out.append((x, y, w, h))
    return out


def refound(full: Sequence, found: Sequence) -> int:
    """How many of ``full`` detections have one in ``found`` with the same label within MATCH_PX."""
    n = 0
    for d in full:
        if any(f.label == d.label and math.dist(f.centre_px, d.centre_px) <= MATCH_PX for f in found):
            n += 1
    return n


# --------------------------------------------------------------------------------------------
# the ONNX model


def build_synthetic_yolo(path, input_size: int = SYNTHETIC_INPUT, classes: int = SYNTHETIC_CLASSES,
                         seed: int = 0) -> Path:
    """A YOLOv8-layout network (output (1, 4+C, N), N over strides 8, 16 and 32) with random
    convolution weights, saved to ``path``: a stem, four down-sampling stages (16…256 channels,
    SiLU) and a 3×3 + 1×1 head per stride, ~1 GFLOP at 320×320 (YOLOv8n: ~2.2). Class scores are
    sigmoid(−9): it finds nothing, so only the network and the decoding are timed."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    rng = np.random.default_rng(seed)
    nodes, weights = [], []

    def conv(x: str, c_in: int, c_out: int, k: int, stride: int, name: str, silu: bool = True,
             bias: Optional[np.ndarray] = None, zero: bool = False) -> str:
        w = np.zeros((c_out, c_in, k, k), np.float32) if zero else \
            (rng.standard_normal((c_out, c_in, k, k)) * math.sqrt(2.0 / (c_in * k * k))).astype(np.float32)
        b = np.zeros(c_out, np.float32) if bias is None else np.asarray(bias, np.float32)
        weights.extend([numpy_helper.from_array(w, f"{name}_w"), numpy_helper.from_array(b, f"{name}_b")])
        nodes.append(helper.make_node("Conv", [x, f"{name}_w", f"{name}_b"], [f"{name}_conv"], kernel_shape=[k, k],
                                      strides=[stride, stride], pads=[k // 2] * 4))
        if not silu:
            return f"{name}_conv"
        nodes.append(helper.make_node("Sigmoid", [f"{name}_conv"], [f"{name}_gate"]))
        nodes.append(helper.make_node("Mul", [f"{name}_conv", f"{name}_gate"], [name]))
        return name

    channels = (16, 32, 64, 128, 256)
    x = conv("images", 3, channels[0], 3, 2, "stem")
    features = []
    for i in range(1, len(channels)):
        x = conv(x, channels[i - 1], channels[i], 3, 2, f"down{i}")
        x = conv(x, channels[i], channels[i], 3, 1, f"block{i}")
        if i >= 2:  # strides 8, 16, 32
            features.append((x, channels[i]))
    flats = []
    for j, (feature, c) in enumerate(features):
        h = conv(feature, c, 64, 3, 1, f"head{j}")
        box = conv(h, 64, 4, 1, 1, f"box{j}", silu=False)
        logits = conv(h, 64, classes, 1, 1, f"cls{j}", silu=False, bias=np.full(classes, -9.0), zero=True)
        nodes.append(helper.make_node("Sigmoid", [logits], [f"score{j}"]))
        nodes.append(helper.make_node("Concat", [box, f"score{j}"], [f"pred{j}"], axis=1))
        weights.append(numpy_helper.from_array(np.array([1, 4 + classes, -1], np.int64), f"flat_shape{j}"))
        nodes.append(helper.make_node("Reshape", [f"pred{j}", f"flat_shape{j}"], [f"flat{j}"]))
        flats.append(f"flat{j}")
    nodes.append(helper.make_node("Concat", flats, ["output0"], axis=2))
    anchors = sum((input_size // s) ** 2 for s in (8, 16, 32))
    graph = helper.make_graph(
        nodes, "synthetic_yolov8",
        [helper.make_tensor_value_info("images", TensorProto.FLOAT, [1, 3, input_size, input_size])],
        [helper.make_tensor_value_info("output0", TensorProto.FLOAT, [1, 4 + classes, anchors])],
        initializer=weights)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)])
    model.ir_version = 8
    names = ", ".join(f"{k}: 'class {k}'" for k in range(classes))
    helper.set_model_props(model, {"names": "{" + names + "}"})
    onnx.checker.check_model(model)
    onnx.save(model, str(path))
    return Path(path)


def onnx_model(workdir) -> tuple[Optional[Path], str]:
    """(model path, how to name it in the table), or (None, why there is none)."""
    if SHIPPED_MODEL.is_file():
        return SHIPPED_MODEL, f"shipped model {SHIPPED_MODEL.name}"
    try:
        path = build_synthetic_yolo(Path(workdir) / "synthetic_yolov8.onnx")
    except ImportError:
        return None, f"no {SHIPPED_MODEL.relative_to(REPO)} and no onnx package to build a synthetic model"
    return path, f"synthetic YOLOv8-layout {SYNTHETIC_INPUT}x{SYNTHETIC_INPUT}, random weights (no {SHIPPED_MODEL.name} yet)"


def onnxruntime_installed() -> bool:
    try:
        import onnxruntime  # noqa: F401
    except ImportError:
        return False
    return True


# --------------------------------------------------------------------------------------------
# rows


class _DetectorRun:
    """One detector's full-frame and ROI samples over the sequence."""

    def __init__(self, name: str, detector, fallback_truth: bool = False):
        self.name, self.detector, self.fallback_truth = name, detector, fallback_truth
        self.full_ms: list[float] = []
        self.roi_ms: list[float] = []
        self.windows: list[int] = []  # ROI windows per pair
        self.full_found = 0  # full-frame detections on frames that had ROIs
        self.roi_found = 0  # … of which the ROIs found again
        self.used_truth = False
        self.previous: Optional[dict] = None  # side -> the previous frame's full-frame detections
        self.before: dict = {"left": [], "right": []}  # … and the frame before's

    def step(self, rig, frame) -> None:
        windows = None
        if self.previous is not None:
            windows = {side: roi_windows(self.previous[side], getattr(frame, side).shape, self.before[side])
                       for side in ("left", "right")}
            if self.fallback_truth and not any(windows.values()) and frame.truth is not None:
                windows = {side: truth_windows(rig, frame.truth, side, getattr(frame, side).shape)
                           for side in ("left", "right")}
                self.used_truth = True
        t0 = time.perf_counter()
        left = self.detector.detect(frame.left)
        right = self.detector.detect(frame.right)
        t1 = time.perf_counter()
        self.full_ms.append(_ms(t0, t1))
        if windows is not None:
            found = {"left": [], "right": []}
            t0 = time.perf_counter()
            for side in ("left", "right"):
                image = getattr(frame, side)
                for window in windows[side]:
                    found[side].extend(self.detector.detect(image, roi=window))
            t1 = time.perf_counter()
            self.roi_ms.append(_ms(t0, t1))
            self.windows.append(len(windows["left"]) + len(windows["right"]))
            for side, full in (("left", left), ("right", right)):
                self.full_found += len(full)
                self.roi_found += refound(full, found[side])
        if self.previous is not None:
            self.before = self.previous
        self.previous = {"left": left, "right": right}


def _p50_p95(values) -> str:
    if not len(values):
        return "n/a"
    return f"p50 {np.median(values):.1f} p95 {np.percentile(values, 95):.1f}"


def detector_rows(rig, frames, onnx_path: Optional[Path] = None, onnx_what: str = "",
                  onnx_frames: Optional[int] = None) -> list[dict]:
    """Baseline, each detector full frame vs ROI, and the hsv object loop, interleaved per frame.

    The ONNX detector (when ``onnx_path``) runs on the first ``onnx_frames`` frames only (each of
    its ROIs is a whole network pass)."""
    from core.detect.registry import make_detector
    from core.detect.stereo import StereoObjectPerception
    from core.vision.perception import StereoMarkerPerception

    calibration = rig.calibration()
    markers = StereoMarkerPerception(calibration, rig.base_T_camera)
    loops = {}
    for name, options, note in OBJECT_LOOPS:
        try:
            loops[name] = (StereoObjectPerception(calibration, rig.base_T_camera, [make_detector("hsv")], **options),
                           note)
        except (TypeError, ValueError) as exc:  # an option this StereoObjectPerception does not have
            print(f"bench: '{name}' skipped: {exc}", file=sys.stderr)
    runs = [_DetectorRun(name, make_detector(name)) for name in DETECTORS]
    onnx_run = None
    if onnx_path is not None:
        detector = make_detector(f"onnx:{onnx_path}")
        onnx_run = _DetectorRun(f"onnx ({detector.backend})", detector, fallback_truth=True)
    limit = len(frames) if onnx_frames is None else max(2, min(onnx_frames, len(frames)))

    base_ms = []
    loop_ms = {name: [] for name in loops}
    loop_counts = {name: [] for name in loops}
    loop_err_mm = {name: [] for name in loops}
    for k, frame in enumerate(frames):
        t0 = time.perf_counter()
        markers.process(frame)
        base_ms.append(_ms(t0, time.perf_counter()))
        for name, (loop, _) in loops.items():
            t0 = time.perf_counter()
            observations = loop.process(frame)
            loop_ms[name].append(_ms(t0, time.perf_counter()))
            loop_counts[name].append(sum(1 for o in observations if o.triangulated))
            loop_err_mm[name].extend(_errors_mm(observations, frame.truth))
        for run in runs:
            run.step(rig, frame)
        if onnx_run is not None and k < limit:
            onnx_run.step(rig, frame)

    out = [{"name": BASELINE, "unit": "ms", "samples": base_ms, "baseline": None,
            "extra": f"StereoMarkerPerception.process, 2 cards; {len(frames)} frames of the objects scenario, "
                     f"640x480, 30 fps"}]
    for run in runs + ([onnx_run] if onnx_run is not None else []):
        out += _run_rows(run, onnx_what if run is onnx_run else "")
    for name, (_, note) in loops.items():
        out.append({"name": name, "unit": "ms", "samples": loop_ms[name],
                    "baseline": BASELINE if name == OBJECT_LOOP else OBJECT_LOOP,
                    "extra": f"{note}; objects triangulated per frame {_p50_p95(loop_counts[name])}; "
                             f"3D error vs truth centre (mm) {_p50_p95(loop_err_mm[name])}"})
    return out


def _run_rows(run: _DetectorRun, what: str) -> list[dict]:
    full_name = f"detect {run.name}: full frame"
    note = f"; {what}" if what else ""
    rows = [{"name": full_name, "unit": "ms", "samples": run.full_ms, "baseline": BASELINE,
             "extra": f"ms per stereo pair: detect(left) + detect(right), 640x480{note}"}]
    if run.roi_ms:
        share = f"{run.roi_found} of {run.full_found}" if run.full_found else "n/a (nothing found full frame)"
        where = ("the objects' true positions (the model finds nothing)" if run.used_truth
                 else "its detections' predicted positions")
        rows.append({"name": f"detect {run.name}: ROI per object", "unit": "ms", "samples": run.roi_ms,
                     "baseline": full_name,
                     "extra": f"ms per pair; windows per pair {_p50_p95(run.windows)} around {where} "
                              f"(>= {ROI_MIN_PX} px, {ROI_BOX_FACTOR:g}x box); full-frame detections found "
                              f"again: {share}"})
    return rows


def _errors_mm(observations, truth) -> list[float]:
    """3D errors (mm) of triangulated hsv objects against the truth thing of their colour."""
    if truth is None:
        return []
    by_colour = {}
    for obj in truth.objects:
        words = obj.label.split()
        if len(words) == 2:
            by_colour.setdefault(words[0], []).append(obj)
    out = []
    for o in observations:
        things = by_colour.get(o.label, [])
        if o.triangulated and o.base_p is not None and len(things) == 1:
            out.append(1e3 * math.dist(o.base_p, things[0].base_p_centre))
    return out


class _TimedTracker:
    """Stands in for an ObjectTracker's OpenCV tracker (its private ``_tracker``) to time its
    ``update`` on the search window alone and count its failures; ``summary()`` says "n/a" when
    ObjectTracker no longer keeps it there."""

    def __init__(self, tracker=None):
        self.tracker = tracker
        self.ms: list[float] = []
        self.failed = 0
        self.window = "?"  # the search window's size, w x h px

    @classmethod
    def wrap(cls, object_tracker) -> "_TimedTracker":
        inner = getattr(object_tracker, "_tracker", None)
        timed = cls(inner)
        if inner is not None and hasattr(inner, "update"):
            object_tracker._tracker = timed  # re-seeding would replace it: these runs never re-seed
        return timed

    def update(self, image):
        t0 = time.perf_counter()
        ok, box = self.tracker.update(image)
        self.ms.append(_ms(t0, time.perf_counter()))
        self.failed += 0 if ok else 1
        self.window = f"{image.shape[1]}x{image.shape[0]} px"
        return ok, box

    def __getattr__(self, name):
        return getattr(self.tracker, name)

    def summary(self) -> str:
        if not self.ms:
            return "n/a"
        return f"{_p50_p95(self.ms)} ms, window {self.window}, failed {self.failed} of {len(self.ms)}"


def tracker_rows(frames) -> list[dict]:
    """ObjectTracker.update per kind following the red ball (left view), beside hsv full-view detection."""
    from core.detect.registry import make_detector
    from core.detect.tracking import ObjectTracker, available_trackers

    hsv = make_detector("hsv")
    seeds = [d for d in hsv.detect(frames[0].left) if d.label == TRACKED_COLOUR]
    if not seeds:
        raise RuntimeError(f"track bench: no {TRACKED_COLOUR} blob in the first frame to seed the trackers")
    kinds = [k for k in TRACKERS if k in available_trackers()]
    trackers, inner = {}, {}
    for kind in kinds:
        tracker = ObjectTracker(kind)
        tracker.start(frames[0].left, seeds[0].box, frames[0].t)
        trackers[kind] = tracker
        inner[kind] = _TimedTracker.wrap(tracker)
    base_ms = []
    samples = {k: [] for k in kinds}
    error_px = {k: [] for k in kinds}
    lost = {k: 0 for k in kinds}
    for frame in frames[1:]:
        t0 = time.perf_counter()
        found = [d for d in hsv.detect(frame.left) if d.label == TRACKED_COLOUR]
        base_ms.append(_ms(t0, time.perf_counter()))
        for kind in kinds:
            tracker = trackers[kind]
            was_lost = tracker.lost  # a lost tracker does nothing until a detection revives it
            t0 = time.perf_counter()
            state = tracker.update(frame.left, frame.t)  # tracker only: no detections given
            if not was_lost:
                samples[kind].append(_ms(t0, time.perf_counter()))
            if not state.ok:
                lost[kind] += 1
            elif found:
                error_px[kind].append(math.dist(state.centre_px, found[0].centre_px))
    out = [{"name": TRACK_BASELINE, "unit": "ms", "samples": base_ms, "baseline": None,
            "extra": f"the alternative to tracking: HsvDetector.detect on the 640x480 left view, "
                     f"{len(base_ms)} frames"}]
    for kind in kinds:
        idle = len(frames) - 1 - len(samples[kind])
        lost_note = f"; LOST after {len(samples[kind])} updates (not timed while lost: {idle})" if idle else ""
        out.append({"name": f"track {kind}: ObjectTracker.update", "unit": "ms",
                    "samples": samples[kind] or [float("nan")],
                    "baseline": TRACK_BASELINE,
                    "extra": f"red ball, left view; the OpenCV tracker alone on its window: "
                             f"{inner[kind].summary()}; centre vs hsv (px) {_p50_p95(error_px[kind])}; "
                             f"not ok on {lost[kind]} of {len(frames) - 1} updates{lost_note}"})
    missing = [k for k in TRACKERS if k not in kinds]
    if missing:
        print(f"bench: trackers not in this OpenCV build: {', '.join(missing)}", file=sys.stderr)
    return out


def onnx_backend_rows(frames, path: Path, what: str) -> list[dict]:
    """The same model and images through cv2.dnn and onnxruntime, interleaved (ms per pair)."""
    from core.detect.onnx_yolo import OnnxYoloDetector

    cv2_name = "onnx via cv2.dnn: full frame"
    detectors = {"cv2": OnnxYoloDetector(path, backend="cv2")}
    if onnxruntime_installed():
        detectors["onnxruntime"] = OnnxYoloDetector(path, backend="onnxruntime")
    else:
        print(f"bench: {ORT_MISSING} (pip install onnxruntime): its ONNX row is skipped", file=sys.stderr)
    samples = {k: [] for k in detectors}
    forward = {k: [] for k in detectors}
    found = {k: 0 for k in detectors}
    for frame in frames:
        for key, detector in detectors.items():
            t0 = time.perf_counter()
            n = len(detector.detect(frame.left))
            pass_ms = detector.last_inference_ms
            n += len(detector.detect(frame.right))
            samples[key].append(_ms(t0, time.perf_counter()))
            forward[key].append(pass_ms + detector.last_inference_ms)
            found[key] += n
    d = detectors["cv2"]
    shape = f"{d.input_wh[0]}x{d.input_wh[1]} input, {d.num_classes} classes"
    out = [{"name": cv2_name, "unit": "ms", "samples": samples["cv2"], "baseline": None,
            "extra": f"{what}; {shape}; network alone {_p50_p95(forward['cv2'])} ms; "
                     f"{found['cv2']} detections in {len(frames)} pairs"}]
    if "onnxruntime" in detectors:
        import onnxruntime

        out.append({"name": "onnx via onnxruntime: full frame", "unit": "ms",
                    "samples": samples["onnxruntime"], "baseline": cv2_name,
                    "extra": f"onnxruntime {onnxruntime.__version__} CPU; network alone "
                             f"{_p50_p95(forward['onnxruntime'])} ms; {found['onnxruntime']} detections"})
    return out


MODEL_ACCURACY = "desk model: one 640x480 view, mAP@0.5 on unseen renders"


def model_accuracy_rows(n_images: int) -> list[dict]:
    """The shipped model's accuracy (VOC mAP@0.5 on ``n_images`` held-out renders, scenes the
    training never used) with its ms per view through cv2.dnn; [] when no model ships."""
    if not SHIPPED_MODEL.is_file():
        print(f"bench: no {SHIPPED_MODEL.name}: model accuracy row skipped", file=sys.stderr)
        return []
    from core.detect.onnx_yolo import OnnxYoloDetector
    from core.sim.dataset import CLASSES, score_detector

    class Timed:
        def __init__(self, inner):
            self.inner, self.ms = inner, []

        def detect(self, image):
            t0 = time.perf_counter()
            found = self.inner.detect(image)
            self.ms.append((time.perf_counter() - t0) * 1e3)
            return found

    # the detector at a low threshold, as VOC scores it (precision/recall read at 0.25)
    detector = Timed(OnnxYoloDetector(SHIPPED_MODEL, backend="cv2", score_threshold=0.05))
    classes = [c for c in detector.inner.names if c in CLASSES]
    scores, _ = score_detector(detector, n_images, classes=classes, score_threshold=0.25)
    per_class = " ".join(f"{name} {c.ap:.2f}" for name, c in scores.classes.items() if c.n_truth)
    return [{"name": MODEL_ACCURACY, "unit": "ms", "samples": detector.ms, "baseline": BASELINE,
             "extra": f"mAP@0.5 {scores.mean_ap:.3f} on {scores.n_images} unseen renders ({per_class})"}]


def rows(quick: bool = False) -> list[dict]:
    """Every row of this file: ``quick`` renders 6 frames (ONNX on 3), else 60 (ONNX on 12)."""
    n = 6 if quick else 60
    onnx_frames = 3 if quick else 12
    rig, frames = render_sequence(n)
    with tempfile.TemporaryDirectory(prefix="deskarm-bench-onnx-") as workdir:
        path, what = onnx_model(workdir)
        if path is None:
            print(f"bench: ONNX detector rows skipped: {what}", file=sys.stderr)
        out = detector_rows(rig, frames, path, what, onnx_frames)
        out += tracker_rows(frames)
        if path is not None:
            out += onnx_backend_rows(frames[:onnx_frames], path, what)
    out += model_accuracy_rows(10 if quick else 200)
    return out


def main(argv: list[str]) -> int:
    from bench.__main__ import format_table

    t0 = time.perf_counter()
    print(format_table(rows(quick="--quick" in argv)))
    print(f"\n(bench_detect: {time.perf_counter() - t0:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
