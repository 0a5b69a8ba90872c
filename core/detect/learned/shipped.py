"""The detector deskarm ships: ``resources/models/desk_objects.onnx`` run by OnnxYoloDetector.

``make_detector("desk")`` builds it — or, once the user has taught it an object (``deskarm teach``,
``core.detect.learned.teach``), the user's model ``<config>/models/desk_objects.onnx`` (the shipped
classes and the taught ones; ``desk_model_path``) (options are OnnxYoloDetector's: score_threshold, nms_iou,
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


def shipped_model_engine() -> int:
    """The OpenCV DNN engine the shipped model runs in: OpenCV 5's classic one, a third less CPU a
    pass than the new (3.3 against 5.3 ms here; outputs within 1e-3, tested). Only for this file:
    the classic engine crashes on some other models (a dynamic input size), which get the default."""
    import cv2

    return cv2.dnn.ENGINE_CLASSIC


def taught_model_path() -> Path:
    """Where the user's model with taught objects is (it may not exist)."""
    from core.paths import user_dir

    return user_dir("config") / "models" / SHIPPED_MODEL


def desk_model_path() -> Path:
    """The desk model ``make_detector("desk")`` runs: the user's taught one when there is one, else the shipped."""
    taught = taught_model_path()
    return taught if taught.is_file() else shipped_model_path()


def make_desk_detector(**options):
    """OnnxYoloDetector on the desk model (``desk_model_path``); FileNotFoundError naming the path and the fix."""
    from core.detect.onnx_yolo import OnnxYoloDetector

    path = desk_model_path()
    if not path.is_file():
        raise FileNotFoundError(f"the shipped desk model is missing: {path} — reinstall deskarm, or make it with "
                                f"`deskarm train-detector --out {path}` (needs the train extra)")
    if path == shipped_model_path() and "engine" not in options:
        options["engine"] = shipped_model_engine()
    detector = OnnxYoloDetector(path, **options)
    detector.name = "desk"
    return detector
