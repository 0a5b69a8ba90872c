"""Detection accuracy the way PASCAL VOC scores it: average precision per class and mAP@0.5.

Pure numpy (no torch, no OpenCV), so CI scores the shipped model without the training extra.

Matching, per class and over all images at once: detections are taken best score first; each is
matched to the ground-truth box of its class with the highest IoU in its image. With
``IoU >= iou_threshold`` it is a true positive if that box is not matched yet, a false positive
(a duplicate) if it is; below the threshold it is a false positive. A detection whose best box is
*difficult* (mostly hidden or cut by the image edge) counts neither way, and difficult boxes are
not owed: finding them is not rewarded, missing them is not punished. A detection of the wrong
class is a false positive of its own class (and the true object, unless found, a miss of its).

AP is the area under the precision-recall curve with precision made monotone (VOC 2010 and later,
"all points"). mAP is the mean AP over the classes that have at least one non-difficult box.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Iterable, Optional, Sequence

import numpy as np

__all__ = ["TruthBox", "ScoredBox", "ClassScore", "DetectionScores", "box_iou", "average_precision",
           "evaluate_detections"]


@dataclass(frozen=True)
class TruthBox:
    """A ground-truth box: class name and (x0, y0, x1, y1) in image pixels."""

    label: str
    box: tuple[float, float, float, float]
    difficult: bool = False  # mostly hidden or cut off: neither owed nor punished


@dataclass(frozen=True)
class ScoredBox:
    """A detection: class name, (x0, y0, x1, y1) in image pixels and its score (higher = surer)."""

    label: str
    box: tuple[float, float, float, float]
    score: float


@dataclass(frozen=True)
class ClassScore:
    """One class's result: AP (nan without ground truth), counts, and precision/recall at a score."""

    label: str
    ap: float
    n_truth: int  # non-difficult ground-truth boxes
    n_detections: int  # detections of this class (those matching difficult boxes left out)
    true_positives: int  # at ``score_threshold``
    false_positives: int  # at ``score_threshold``
    precision: float  # at ``score_threshold`` (nan when nothing was detected)
    recall: float  # at ``score_threshold`` (nan without ground truth)

    def to_dict(self) -> dict:
        return {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in self.__dict__.items()}


@dataclass(frozen=True)
class DetectionScores:
    """Per-class scores and their mean (mAP) at one IoU threshold."""

    iou_threshold: float
    score_threshold: float  # where the per-class precision and recall are read
    classes: dict[str, ClassScore] = field(default_factory=dict)
    n_images: int = 0

    @property
    def mean_ap(self) -> float:
        """mAP: mean AP over the classes with ground truth (nan when none has any)."""
        aps = [c.ap for c in self.classes.values() if c.n_truth > 0]
        return float(np.mean(aps)) if aps else float("nan")

    def to_dict(self) -> dict:
        m = self.mean_ap
        return {"iou_threshold": self.iou_threshold, "score_threshold": self.score_threshold,
                "n_images": self.n_images, "map": None if math.isnan(m) else m,
                "classes": {name: c.to_dict() for name, c in self.classes.items()}}

    def table(self) -> str:
        """A few lines for a terminal: AP, boxes, precision and recall per class, then mAP."""
        lines = [f"{'class':<10} {'AP@' + format(self.iou_threshold, 'g'):>8} {'boxes':>6} {'found':>6} "
                 f"{'P@' + format(self.score_threshold, 'g'):>7} {'R@' + format(self.score_threshold, 'g'):>7}"]

        def f(v: float) -> str:
            return "    -" if math.isnan(v) else f"{v:.3f}"

        for c in self.classes.values():
            lines.append(f"{c.label:<10} {f(c.ap):>8} {c.n_truth:>6} {c.n_detections:>6} {f(c.precision):>7} "
                         f"{f(c.recall):>7}")
        lines.append(f"{'mAP':<10} {f(self.mean_ap):>8}   ({self.n_images} images)")
        return "\n".join(lines)


def box_iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU matrix (N, M) of boxes a (N, 4) and b (M, 4), both (x0, y0, x1, y1)."""
    a = np.asarray(a, dtype=np.float64).reshape(-1, 4)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 4)
    ix = np.clip(np.minimum(a[:, None, 2], b[None, :, 2]) - np.maximum(a[:, None, 0], b[None, :, 0]), 0, None)
    iy = np.clip(np.minimum(a[:, None, 3], b[None, :, 3]) - np.maximum(a[:, None, 1], b[None, :, 1]), 0, None)
    inter = ix * iy
    area_a = np.clip(a[:, 2] - a[:, 0], 0, None) * np.clip(a[:, 3] - a[:, 1], 0, None)
    area_b = np.clip(b[:, 2] - b[:, 0], 0, None) * np.clip(b[:, 3] - b[:, 1], 0, None)
    union = area_a[:, None] + area_b[None, :] - inter
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(union > 0, inter / union, 0.0)


def average_precision(recall: Sequence[float], precision: Sequence[float]) -> float:
    """Area under a precision-recall curve (points in the order of falling score), with the
    precision made monotone from the right and integrated where recall changes (VOC "all points")."""
    r = np.concatenate([[0.0], np.asarray(recall, dtype=np.float64), [1.0]])
    p = np.concatenate([[0.0], np.asarray(precision, dtype=np.float64), [0.0]])
    p = np.maximum.accumulate(p[::-1])[::-1]
    steps = np.nonzero(r[1:] != r[:-1])[0]
    return float(np.sum((r[steps + 1] - r[steps]) * p[steps + 1]))


def _match_class(label: str, truths: list[list[TruthBox]], detections: list[list[ScoredBox]],
                 iou_threshold: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """(scores, is_tp, is_fp) of the class's detections best first (difficult ones dropped), and
    the number of non-difficult truth boxes."""
    gt_boxes, gt_difficult, n_truth = [], [], 0
    for image_truths in truths:
        mine = [t for t in image_truths if t.label == label]
        gt_boxes.append(np.array([t.box for t in mine], dtype=np.float64).reshape(-1, 4))
        gt_difficult.append(np.array([t.difficult for t in mine], dtype=bool))
        n_truth += int(np.sum(~gt_difficult[-1]))
    entries = [(d.score, i, d.box) for i, image_dets in enumerate(detections) for d in image_dets if d.label == label]
    entries.sort(key=lambda e: -e[0])  # stable: equal scores keep their order
    taken = [np.zeros(len(b), dtype=bool) for b in gt_boxes]
    scores, tp, fp = [], [], []
    for score, i, box in entries:
        is_tp = is_fp = False
        if len(gt_boxes[i]):
            ious = box_iou(np.array([box]), gt_boxes[i])[0]
            j = int(np.argmax(ious))
            if ious[j] >= iou_threshold:
                if gt_difficult[i][j]:
                    continue  # neither rewarded nor punished
                if taken[i][j]:
                    is_fp = True  # a second detection of a box already found
                else:
                    taken[i][j] = is_tp = True
            else:
                is_fp = True
        else:
            is_fp = True
        scores.append(score)
        tp.append(is_tp)
        fp.append(is_fp)
    return np.array(scores, dtype=np.float64), np.array(tp, dtype=bool), np.array(fp, dtype=bool), n_truth


def evaluate_detections(truths: Sequence[Iterable[TruthBox]], detections: Sequence[Iterable[ScoredBox]],
                        classes: Optional[Sequence[str]] = None, iou_threshold: float = 0.5,
                        score_threshold: float = 0.25) -> DetectionScores:
    """Per-class AP and mAP of ``detections[i]`` against ``truths[i]`` for each image i.

    ``classes`` fixes the classes reported (and their order); by default every label seen in the
    truth or the detections. Detections of labels outside ``classes`` are ignored.
    ``score_threshold`` only sets where the reported precision and recall are read.
    """
    truths = [list(t) for t in truths]
    detections = [list(d) for d in detections]
    if len(truths) != len(detections):
        raise ValueError(f"{len(truths)} images of ground truth but {len(detections)} of detections")
    if not 0.0 < iou_threshold <= 1.0:
        raise ValueError(f"iou_threshold = {iou_threshold} must be in (0, 1]")
    if classes is None:
        seen = {t.label for ts in truths for t in ts} | {d.label for ds in detections for d in ds}
        classes = sorted(seen)
    out = {}
    for label in classes:
        scores, tp, fp, n_truth = _match_class(label, truths, detections, iou_threshold)
        ctp, cfp = np.cumsum(tp), np.cumsum(fp)
        if n_truth > 0:
            recall = ctp / n_truth
            precision = ctp / np.maximum(ctp + cfp, 1)
            ap = average_precision(recall, precision) if len(scores) else 0.0
        else:
            ap = float("nan")
        sure = scores >= score_threshold
        n_tp, n_fp = int(np.sum(tp & sure)), int(np.sum(fp & sure))
        out[label] = ClassScore(
            label=label, ap=ap, n_truth=n_truth, n_detections=len(scores), true_positives=n_tp,
            false_positives=n_fp,
            precision=n_tp / (n_tp + n_fp) if n_tp + n_fp else float("nan"),
            recall=n_tp / n_truth if n_truth else float("nan"))
    return DetectionScores(iou_threshold=float(iou_threshold), score_threshold=float(score_threshold),
                           classes=out, n_images=len(truths))
