"""AP and mAP@0.5 (core.detect.learned.evaluation) on hand-made cases whose answer is known."""
import math

import numpy as np
import pytest

from core.detect.learned.evaluation import (
    ScoredBox,
    TruthBox,
    average_precision,
    box_iou,
    evaluate_detections,
)

BALL_A = (10.0, 10.0, 30.0, 30.0)
BALL_B = (100.0, 50.0, 120.0, 70.0)
CUP = (200.0, 100.0, 260.0, 180.0)


def truth():
    """Two images: two balls and a cup."""
    return [[TruthBox("ball", BALL_A), TruthBox("cup", CUP)], [TruthBox("ball", BALL_B)]]


def test_box_iou_of_known_boxes():
    a = np.array([[0, 0, 10, 10]])
    b = np.array([[0, 0, 10, 10], [5, 0, 15, 10], [20, 20, 30, 30], [0, 0, 10, 5]])
    assert box_iou(a, b)[0] == pytest.approx([1.0, 50 / 150, 0.0, 0.5])


def test_perfect_detections_score_one():
    found = [[ScoredBox("ball", BALL_A, 0.9), ScoredBox("cup", CUP, 0.8)], [ScoredBox("ball", BALL_B, 0.7)]]
    scores = evaluate_detections(truth(), found, ["ball", "cup"])
    assert scores.classes["ball"].ap == pytest.approx(1.0)
    assert scores.classes["cup"].ap == pytest.approx(1.0)
    assert scores.mean_ap == pytest.approx(1.0)
    assert scores.classes["ball"].recall == 1.0 and scores.classes["ball"].precision == 1.0


def test_one_missed_ball_halves_its_recall_and_its_ap():
    found = [[ScoredBox("ball", BALL_A, 0.9), ScoredBox("cup", CUP, 0.8)], []]
    scores = evaluate_detections(truth(), found, ["ball", "cup"])
    assert scores.classes["ball"].ap == pytest.approx(0.5)
    assert scores.classes["ball"].recall == pytest.approx(0.5)
    assert scores.mean_ap == pytest.approx(0.75)


def test_a_false_positive_above_the_true_ones_costs_precision():
    # ranked: FP (0.95), TP (0.9), TP (0.7) → precision 0, 1/2, 2/3 at recall 0, 0.5, 1
    found = [[ScoredBox("ball", (300, 300, 320, 320), 0.95), ScoredBox("ball", BALL_A, 0.9)],
             [ScoredBox("ball", BALL_B, 0.7)]]
    scores = evaluate_detections(truth(), found, ["ball"])
    # monotone precision: 2/3 over the whole recall range
    assert scores.classes["ball"].ap == pytest.approx(2 / 3)
    assert scores.classes["ball"].false_positives == 1


def test_a_false_positive_below_every_true_one_costs_nothing():
    found = [[ScoredBox("ball", BALL_A, 0.9)], [ScoredBox("ball", BALL_B, 0.7), ScoredBox("ball", (0, 0, 5, 5), 0.1)]]
    assert evaluate_detections(truth(), found, ["ball"]).classes["ball"].ap == pytest.approx(1.0)


def test_a_duplicate_detection_is_a_false_positive():
    found = [[ScoredBox("ball", BALL_A, 0.9), ScoredBox("ball", BALL_A, 0.85)], [ScoredBox("ball", BALL_B, 0.7)]]
    scores = evaluate_detections(truth(), found, ["ball"])
    assert scores.classes["ball"].false_positives == 1
    # ranked TP, FP, TP → precision 1, 1/2, 2/3: AP = 0.5·1 + 0.5·2/3
    assert scores.classes["ball"].ap == pytest.approx(0.5 + 1 / 3)


def test_class_confusion_is_a_miss_and_a_false_positive():
    found = [[ScoredBox("ball", BALL_A, 0.9), ScoredBox("ball", CUP, 0.8)], [ScoredBox("ball", BALL_B, 0.7)]]
    scores = evaluate_detections(truth(), found, ["ball", "cup"])
    assert scores.classes["cup"].ap == 0.0  # the cup was never found as a cup
    assert scores.classes["ball"].false_positives == 1
    assert scores.classes["ball"].ap == pytest.approx(0.5 + 1 / 3)  # TP, FP, TP
    assert scores.mean_ap == pytest.approx((0.5 + 1 / 3) / 2)


def test_iou_exactly_at_the_threshold_matches_and_just_below_does_not():
    gt = [[TruthBox("ball", (0.0, 0.0, 10.0, 10.0))]]
    at = [[ScoredBox("ball", (0.0, 0.0, 10.0, 5.0), 0.9)]]  # IoU 50/100 = 0.5
    below = [[ScoredBox("ball", (0.0, 0.0, 10.0, 4.9), 0.9)]]  # IoU 0.49
    assert evaluate_detections(gt, at, ["ball"], iou_threshold=0.5).mean_ap == pytest.approx(1.0)
    assert evaluate_detections(gt, below, ["ball"], iou_threshold=0.5).mean_ap == 0.0
    assert evaluate_detections(gt, below, ["ball"], iou_threshold=0.45).mean_ap == pytest.approx(1.0)


def test_difficult_boxes_are_neither_owed_nor_rewarded():
    gt = [[TruthBox("ball", BALL_A), TruthBox("ball", BALL_B, difficult=True)]]
    missed = evaluate_detections(gt, [[ScoredBox("ball", BALL_A, 0.9)]], ["ball"])
    found = evaluate_detections(gt, [[ScoredBox("ball", BALL_B, 0.95), ScoredBox("ball", BALL_A, 0.9)]], ["ball"])
    assert missed.classes["ball"].ap == pytest.approx(1.0)
    assert found.classes["ball"].ap == pytest.approx(1.0)
    assert found.classes["ball"].n_truth == 1 and found.classes["ball"].false_positives == 0


def test_a_class_without_truth_has_no_ap_and_stays_out_of_the_mean():
    found = [[ScoredBox("ball", BALL_A, 0.9), ScoredBox("plush", (0, 0, 50, 20), 0.6)],
             [ScoredBox("ball", BALL_B, 0.7)]]
    scores = evaluate_detections(truth(), found, ["ball", "plush"])
    assert math.isnan(scores.classes["plush"].ap)
    assert scores.classes["plush"].false_positives == 1
    assert scores.mean_ap == pytest.approx(1.0)
    assert scores.to_dict()["classes"]["plush"]["ap"] is None


def test_nothing_detected_scores_zero():
    scores = evaluate_detections(truth(), [[], []], ["ball", "cup"])
    assert scores.mean_ap == 0.0
    assert "mAP" in scores.table()


def test_average_precision_of_a_curve():
    # recall 0.5 at precision 1, then recall 1 at precision 0.5
    assert average_precision([0.5, 1.0], [1.0, 0.5]) == pytest.approx(0.75)
    assert average_precision([], []) == 0.0


def test_mismatched_image_counts_are_an_error():
    with pytest.raises(ValueError, match="2 images of ground truth but 1"):
        evaluate_detections(truth(), [[]])
