"""The detector deskarm ships: ``resources/models/desk_objects.onnx`` run by OnnxYoloDetector.

``make_detector("desk")`` builds it (options are OnnxYoloDetector's: score_threshold, nms_iou,
backend, …). No torch: OpenCV's DNN module (or onnxruntime when installed) runs the model.
"""
from __future__ import annotations

from pathlib import Path

SHIPPED_MODEL = "desk_objects.onnx"


def shipped_model_path() -> Path:
    """Where the shipped model file is (installed package data, else the source tree)."""
    try:
        from importlib.resources import files

        return Path(str(files("resources") / "models" / SHIPPED_MODEL))
    except (ModuleNotFoundError, TypeError):  # resources not importable: use the source tree
        return Path(__file__).resolve().parents[3] / "resources" / "models" / SHIPPED_MODEL


def make_desk_detector(**options):
    """OnnxYoloDetector on the shipped desk model; FileNotFoundError naming the path and the fix."""
    from core.detect.onnx_yolo import OnnxYoloDetector

    path = shipped_model_path()
    if not path.is_file():
        raise FileNotFoundError(f"the shipped desk model is missing: {path} — reinstall deskarm, or make it with "
                                f"`deskarm train-detector --out {path}` (needs the train extra)")
    detector = OnnxYoloDetector(path, **options)
    detector.name = "desk"
    return detector
