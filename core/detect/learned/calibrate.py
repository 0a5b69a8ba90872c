"""Per-class score calibration of a deskarm desk model, and the real-photo validation it is chosen on.

A desk model's class scores are sigmoids of one 1×1 convolution (``classes.weight``/``classes.bias``
in the .onnx). Platt scaling fits p = sigmoid(a · logit(score) + b) to "this detection is right"
(IoU ≥ 0.5 with an unclaimed box of its class); with one (a, b) per class, folded into that class's
row of the convolution, a score of 0.5 means right about half the time for each class on its own —
a tiny button and a big cup are not held to one curve. The map is monotone per class, so each
class's ranking of its own detections does not change (a location's best class can, where two
classes were close). ``python -m app.retrain_desk`` fits one map for all classes unless told
``--per-class``: for the shipped model, per class lost on the real validation photos (it raised
cups, plushes and handles, under-confident on renders, and those are what fire on real photos).

* ``match_detections``: which detections of one image are right;
* ``collect``: (class id, score, right) of every detection of a detector over labelled images;
* ``fit_per_class``: one (a, b) per class (the fit of all classes for a class with too little data);
* ``fold_into_onnx``: write the per-class map into a copy of a .onnx (no torch);
* ``photo_variants``: crops, flips, rescales and camera effects of real photos (validation negatives).

Only ``fit_per_class`` needs torch (it calls ``finetune.platt``); the rest is numpy, OpenCV and onnx.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Iterable, Optional, Sequence

import numpy as np

from core.detect.learned.evaluation import box_iou

__all__ = ["match_detections", "collect", "fit_per_class", "fold_into_onnx", "photo_variants",
           "compose", "MIN_DETECTIONS", "MIN_RIGHT", "MATCH_IOU"]

MATCH_IOU = 0.5  # a detection is right at this IoU with a box of its class (the mAP@0.5 rule)
MIN_DETECTIONS = 40  # a class with fewer detections (or ...
MIN_RIGHT = 10  # ... fewer right ones, or fewer wrong ones) takes the fit of all classes


def match_detections(detections, boxes: np.ndarray, labels: np.ndarray, difficult: np.ndarray,
                     classes: Sequence[str]) -> list[tuple[int, float, bool]]:
    """(class id, score, right) of each detection of one image, best score first.

    ``detections``: objects with ``label``, ``score`` and ``box`` (x, y, w, h px); ``boxes`` (K, 4)
    x0, y0, x1, y1 px with ``labels`` (K,) class ids into ``classes`` and ``difficult`` (K,). A
    detection is right when its best box of its class (IoU ≥ MATCH_IOU) is not claimed by a better
    one; one whose best box is difficult is left out (neither right nor wrong, as the mAP does);
    a label not in ``classes`` is left out too."""
    boxes = np.asarray(boxes, np.float64).reshape(-1, 4)
    labels = np.asarray(labels).reshape(-1)
    difficult = np.asarray(difficult, bool).reshape(-1)
    claimed = np.zeros(len(boxes), bool)
    out = []
    for det in sorted(detections, key=lambda q: -q.score):
        if det.label not in classes:
            continue
        cid = list(classes).index(det.label)
        x, y, w, h = det.box
        right = False
        if len(boxes):
            ious = box_iou(np.array([[x, y, x + w, y + h]], np.float64), boxes)[0]
            ious[labels != cid] = 0.0
            j = int(np.argmax(ious))
            if ious[j] >= MATCH_IOU:
                if difficult[j]:
                    continue
                right = not claimed[j]
                claimed[j] = True
        out.append((cid, float(det.score), right))
    return out


def collect(detector, samples: Iterable[tuple], classes: Sequence[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(class ids, scores, right) of ``detector``'s detections over ``samples`` — (image, boxes,
    labels, difficult) each; a negative image has no boxes, so all its detections are wrong."""
    ids, scores, right = [], [], []
    for image, boxes, labels, difficult in samples:
        for cid, score, ok in match_detections(detector.detect(image), boxes, labels, difficult, classes):
            ids.append(cid)
            scores.append(score)
            right.append(ok)
    return np.array(ids, np.int64), np.array(scores, np.float64), np.array(right, bool)


def fit_per_class(ids: np.ndarray, scores: np.ndarray, right: np.ndarray, n_classes: int,
                  min_detections: int = MIN_DETECTIONS, min_right: int = MIN_RIGHT) -> list[tuple[float, float]]:
    """One Platt (a, b) per class (``finetune.platt``, needs torch); a class with fewer than
    ``min_detections`` detections, or fewer than ``min_right`` right or wrong ones, gets the fit
    of all classes together (a logistic fit on a handful of points says nothing)."""
    from core.detect.learned.finetune import platt

    ids, scores, right = np.asarray(ids), np.asarray(scores), np.asarray(right, bool)
    if len(scores) == 0:
        raise ValueError("no detections to calibrate on")
    pooled = platt(scores, right)
    out = []
    for c in range(int(n_classes)):
        mine = ids == c
        n, n_right = int(mine.sum()), int(right[mine].sum())
        if n < min_detections or n_right < min_right or n - n_right < min_right:
            out.append(pooled)
        else:
            out.append(platt(scores[mine], right[mine]))
    return out


def compose(first: Sequence[tuple[float, float]], then: Sequence[tuple[float, float]]) -> list[tuple[float, float]]:
    """The per-class map ``then`` applied after ``first`` (both (a, b) on the logit), as one (a, b) each."""
    return [(a2 * a1, a2 * b1 + b2) for (a1, b1), (a2, b2) in zip(first, then)]


def fold_into_onnx(src, dst, ab: Sequence[tuple[float, float]], metadata: Optional[dict] = None) -> Path:
    """Copy the desk model ``src`` to ``dst`` with class c's logit z replaced by a_c · z + b_c
    (its row of ``classes.weight`` times a_c, its bias a_c · bias + b_c); ``metadata`` entries
    (JSON-encoded) are added to the model's metadata. No torch."""
    import onnx
    from onnx import numpy_helper

    model = onnx.load(str(src))
    init = {i.name: i for i in model.graph.initializer}
    if "classes.weight" not in init or "classes.bias" not in init:
        raise ValueError(f"{src}: no classes.weight/classes.bias initializers (not a deskarm desk model)")
    weight = numpy_helper.to_array(init["classes.weight"]).astype(np.float64)
    bias = numpy_helper.to_array(init["classes.bias"]).astype(np.float64)
    if len(ab) != len(bias):
        raise ValueError(f"{len(ab)} (a, b) pairs for a model of {len(bias)} classes")
    a = np.array([p[0] for p in ab], np.float64)
    b = np.array([p[1] for p in ab], np.float64)
    if not np.all(np.isfinite(a)) or not np.all(np.isfinite(b)) or np.any(a <= 0):
        raise ValueError(f"a calibration must keep each class's order (a > 0, finite): a = {a.tolist()}, b = {b.tolist()}")
    dtype = numpy_helper.to_array(init["classes.weight"]).dtype
    init["classes.weight"].CopyFrom(numpy_helper.from_array((weight * a.reshape(-1, *([1] * (weight.ndim - 1))))
                                                            .astype(dtype), "classes.weight"))
    init["classes.bias"].CopyFrom(numpy_helper.from_array((a * bias + b).astype(dtype), "classes.bias"))
    if metadata:
        props = {p.key: p.value for p in model.metadata_props}
        props.update({k: json.dumps(v) for k, v in metadata.items()})
        onnx.helper.set_model_props(model, props)
    onnx.save(model, str(dst))
    return Path(dst)


def photo_variants(rng: np.random.Generator, photos: Sequence[np.ndarray], n: int,
                   size_wh: tuple[int, int] = (320, 240), effects: bool = True) -> list[np.ndarray]:
    """``n`` variants of real photos: a random crop of 50–100 % of the side, flipped half the
    time, resized to ``size_wh``, and (``effects``) the camera effects of
    ``core.detect.learned.randomise`` (white balance, exposure, blur, noise, JPEG). No drawn
    distractors: what a model says on them is what it says on that real scene."""
    import cv2

    from core.detect.learned.randomise import camera_effects

    if not len(photos):
        return []
    w, h = size_wh
    out = []
    for _ in range(int(n)):
        photo = photos[int(rng.integers(len(photos)))]
        ph, pw = photo.shape[:2]
        s = rng.uniform(0.5, 1.0)
        cw, ch = max(8, int(pw * s)), max(8, int(ph * s))
        x, y = int(rng.integers(0, pw - cw + 1)), int(rng.integers(0, ph - ch + 1))
        img = cv2.resize(photo[y:y + ch, x:x + cw], (w, h), interpolation=cv2.INTER_AREA)
        if rng.random() < 0.5:
            img = img[:, ::-1].copy()
        out.append(camera_effects(rng, img) if effects else img)
    return out
