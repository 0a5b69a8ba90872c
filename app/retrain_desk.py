"""Remake the shipped desk model with domain randomisation: ``python -m app.retrain_desk`` (needs torch).

Starts from a deskarm .onnx (default the shipped one: its weights are read back, batch norm
frozen), fine-tunes it on cached renders of the simulated desk (``core.sim.dataset``) made
domain-randomised (``core.detect.learned.randomise``, and a share through ``core.sim.realism``'s
webcam preset), with a share of each batch negatives: real photos (the training pairs of
``core.detect.learned.retrain``) and textures with distractors. Then it calibrates the score
(Platt: a logistic fit of "this detection is right" on the raw score's logit, over randomised
renders of training seeds 500 000… that the fine-tuning never used, and negatives) and folds the
fit into the class outputs, so 0.5 means right half the time. Writes ``--out`` and
``<out>.raw.onnx`` (before calibration).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from core.detect.learned.retrain import REAL_TRAIN_PAIRS, real_photo_split


def stamp_scores(path, n_images: int = 200, real_dir=None) -> dict:
    """Score the model at ``path`` (held-out renders: the rig clean and through the realism preset,
    the hand camera; the held-out real photos) and write the figures into its metadata
    (``deskarm_eval``, ``deskarm_eval_realistic``, ``deskarm_eval_hand``, ``deskarm_real_photos``)."""
    import cv2
    import onnx

    from app.cli_train import EVAL_SCORE_THRESHOLD, _score
    from core.detect.learned.retrain import REAL_TEST_PAIRS, SURE, false_boxes_per_image
    from core.detect.onnx_yolo import OnnxYoloDetector
    from core.sim.dataset import TEST_SEED_BASE

    meta = {}
    for key, view, realistic in (("deskarm_eval", "stereo", False), ("deskarm_eval_realistic", "stereo", True),
                                 ("deskarm_eval_hand", "hand", False)):
        r = _score(Path(path), n_images, TEST_SEED_BASE, EVAL_SCORE_THRESHOLD, "cv2", view, realistic)
        meta[key] = {"images": r["images"], "first_seed": TEST_SEED_BASE, "view": view,
                     "realism": r["realism"], "map50": r["map"],
                     "ap50": {k: v["ap"] for k, v in r["classes"].items()}}
        print(r["_table"], flush=True)
    if real_dir is not None:
        photos = real_photo_split(Path(real_dir), REAL_TEST_PAIRS)
        per_image, found = false_boxes_per_image(OnnxYoloDetector(path, score_threshold=0.05),
                                                 [cv2.imread(str(p)) for p in photos], SURE)
        meta["deskarm_real_photos"] = {"photos": [p.name for p in photos], "false_boxes_per_image_at_0.5": per_image}
    model = onnx.load(str(path))
    props = {p.key: p.value for p in model.metadata_props}
    props.update({k: json.dumps(v) for k, v in meta.items()})
    onnx.helper.set_model_props(model, props)
    onnx.save(model, str(path))
    return meta


def _main(argv=None) -> int:
    import cv2
    import torch

    from core.detect.learned import finetune as ft
    from core.detect.learned.randomise import negative_image, randomise
    from core.detect.onnx_yolo import OnnxYoloDetector
    from core.sim.dataset import CLASSES, training_arrays
    from core.sim.realism import WEBCAM, apply_realism, distort_points

    def distort_boxes(bx, size):
        out = []
        for x0, y0, x1, y1 in np.asarray(bx).reshape(-1, 4):
            d = distort_points([(x0, y0), (x1, y0), (x0, y1), (x1, y1), ((x0 + x1) / 2, y0), ((x0 + x1) / 2, y1),
                                (x0, (y0 + y1) / 2), (x1, (y0 + y1) / 2)], size, WEBCAM)
            out.append([d[:, 0].min(), d[:, 1].min(), d[:, 0].max(), d[:, 1].max()])
        return np.array(out, np.float32).reshape(-1, 4)

    p = argparse.ArgumentParser(prog="python -m app.retrain_desk", description=__doc__.split("\n\n")[0])
    p.add_argument("--start", default=None, help="the .onnx to start from (default: the shipped model)")
    p.add_argument("--out", default="/tmp/desk_objects_dr.onnx")
    p.add_argument("--images", type=int, default=2000)
    p.add_argument("--data", default=str(Path.home() / ".cache" / "deskarm" / "desk-dataset"))
    p.add_argument("--real", default="../shared/realdata/stereo_7x5_320x240")
    p.add_argument("--steps", type=int, default=600)
    p.add_argument("--minutes", type=float, default=12.0)
    p.add_argument("--batch", type=int, default=16)
    p.add_argument("--lr", type=float, default=1e-3)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--negatives", type=float, default=0.2, help="share of each batch with none of the classes")
    p.add_argument("--realism", type=float, default=0.3,
                   help="share of the randomised renders also passed through core.sim.realism's webcam preset")
    p.add_argument("--stamp", default=None, metavar="MODEL",
                   help="only score MODEL and write the figures into its metadata")
    args = p.parse_args(argv)
    if args.stamp:
        print(json.dumps(stamp_scores(args.stamp, real_dir=args.real)))
        return 0
    if args.start is None:
        from core.detect.learned.shipped import shipped_model_path

        args.start = str(shipped_model_path())
    torch.set_num_threads(1)
    say = lambda text: print(text, flush=True)  # noqa: E731
    images, boxes, labels, difficult = training_arrays(args.images, (320, 240), Path(args.data), CLASSES, progress=say)
    real = [cv2.imread(str(f)) for f in real_photo_split(Path(args.real), REAL_TRAIN_PAIRS)]
    say(f"{len(images)} renders, {len(real)} real negative photos (pairs {REAL_TRAIN_PAIRS})")
    net, names, meta = ft.net_from_onnx(args.start)
    h, w = images.shape[1:3]

    def batches(rng, step):
        xs, bs, ls, ds = [], [], [], []
        for k in range(args.batch):
            u = rng.random()
            if u < args.negatives:  # a negative: real photo or texture with distractors
                xs.append(negative_image(rng, h, w, real))
                bs.append(np.zeros((0, 4), np.float32))
                ls.append(np.zeros(0, np.int64))
                ds.append(np.zeros(0, bool))
                continue
            i = int(rng.integers(len(images)))
            if u < args.negatives + 0.15:
                xs.append(images[i]), bs.append(boxes[i]), ls.append(labels[i]), ds.append(difficult[i])
                continue
            if rng.random() < args.realism:  # the webcam preset of core.sim.realism (its distortion is ≤ 2 %)
                x = apply_realism(images[i], rng, float(step) / 30.0, WEBCAM)
                b = distort_boxes(boxes[i], (w, h))
                x, b, lab, d = randomise(rng, x, b, labels[i], difficult[i], real, strength=0.5)
            else:
                x, b, lab, d = randomise(rng, images[i], boxes[i], labels[i], difficult[i], real)
            xs.append(x), bs.append(b), ls.append(lab), ds.append(d)
        return np.stack(xs), bs, ls, ds

    last = [0.0]

    def progress(frac, left, text):
        if time.perf_counter() - last[0] > 30:
            last[0] = time.perf_counter()
            say(f"{100 * frac:.0f} % ({left:.0f} s left): {text}")

    result = ft.finetune(net, batches, args.steps, learning_rate=args.lr, max_seconds=60 * args.minutes,
                         seed=args.seed, progress=progress)
    say(f"fine-tuned in {result.seconds:.0f} s, {result.steps} steps, loss {result.final_loss:.3f}")
    tuned = result.net
    raw = Path(args.out).with_suffix(".raw.onnx")
    ft.export(tuned, raw, names)
    # calibration on renders training never used (seeds 500000…) with the randomisation, and negatives
    cal_x, cal_b, cal_l, cal_d = training_arrays(300, (320, 240), Path(args.data), CLASSES, first_seed=500000,
                                                 progress=say)
    rng = np.random.default_rng(12345)
    det = OnnxYoloDetector(raw, score_threshold=0.05)
    scores, correct = [], []
    from core.detect.learned.evaluation import box_iou

    for i in range(len(cal_x)):
        x, b, lab, d = (cal_x[i], cal_b[i], cal_l[i], cal_d[i]) if i % 2 else randomise(
            rng, cal_x[i], cal_b[i], cal_l[i], cal_d[i], real)
        taken = np.zeros(len(b), bool)
        for det_ in sorted(det.detect(x), key=lambda q: -q.score):
            bx = np.array([[det_.box[0], det_.box[1], det_.box[0] + det_.box[2], det_.box[1] + det_.box[3]]])
            ok = False
            if len(b):
                ious = box_iou(bx, b)[0]
                ious[np.array([CLASSES[int(k)] != det_.label for k in lab])] = 0
                j = int(np.argmax(ious))
                if ious[j] >= 0.5:
                    if d[j]:
                        continue
                    ok = not taken[j]
                    taken[j] = True
            scores.append(det_.score)
            correct.append(ok)
    for _ in range(150):
        x = negative_image(rng, h, w, real)
        for det_ in det.detect(x):
            scores.append(det_.score)
            correct.append(False)
    a, b0 = ft.platt(np.array(scores), np.array(correct))
    say(f"Platt calibration on {len(scores)} detections: a = {a:.3f}, b = {b0:.3f}")
    ft.apply_platt(tuned, a, b0)
    meta_out = {"deskarm_training": {"start": "the previous shipped model (weights loaded from its .onnx)",
                                     "renders": len(images), "real_negatives": [f"left/right{n:02d}" for n in
                                                                                REAL_TRAIN_PAIRS],
                                     "steps": result.steps, "seconds": round(result.seconds),
                                     "randomisation": "core.detect.learned.randomise",
                                     "calibration": {"a": a, "b": b0, "detections": len(scores)}}}
    ft.export(tuned, args.out, names, metadata=meta_out)
    say(json.dumps(meta_out))
    return 0


if __name__ == "__main__":
    sys.exit(_main())
