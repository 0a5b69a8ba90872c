"""The shipped model on real photos: which real photos train it and which are held out, and the
false-box figure (no torch). ``python -m app.retrain_desk`` (needs torch) remakes
``desk_objects.onnx`` by domain-randomised fine-tuning and score calibration.

Real photos: the 14 webcam pairs of ``../shared/realdata/stereo_7x5_320x240`` (an orange tray with
a chessboard held by a person: none of the classes). Pairs 10–12 are training negatives, pairs
13–14 validation (the model and its calibration are chosen on them, never trained on them); pairs
01–09 (the ones in ``tests/data/stereo_7x5_320x240``) are held out and only ever scored, once, at
the end. ``tests/data/charuco`` holds ChArUco patterns drawn onto photos of pairs 01, 03 and 05:
they are the held-out scenes, so they are neither trained on nor used for validation.
"""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

REAL_TRAIN_PAIRS = (10, 11, 12)  # negatives for training
REAL_VALIDATION_PAIRS = (13, 14)  # the model, its checkpoint and its calibration are chosen on these
REAL_TEST_PAIRS = tuple(range(1, 10))  # held out: scored only (in tests/data)
SURE = 0.5  # a box at this score or above is one the app acts on


def real_photo_split(folder: Path, pairs: Sequence[int]) -> list[Path]:
    """The left and right photo of each pair number in ``folder`` that exists."""
    out = []
    for n in pairs:
        for side in ("left", "right"):
            p = Path(folder) / f"{side}{n:02d}.jpg"
            if p.is_file():
                out.append(p)
    return out


def false_boxes_per_image(detector, images: Sequence[np.ndarray], threshold: float = SURE) -> tuple[float, list]:
    """Boxes at score ≥ ``threshold`` per image on images that hold none of the detector's classes;
    (mean, [(label, score) per image])."""
    found = []
    for img in images:
        found.append([(d.label, round(float(d.score), 3)) for d in detector.detect(img) if d.score >= threshold])
    return (sum(len(f) for f in found) / max(len(images), 1)), found
