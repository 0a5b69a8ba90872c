"""Remake the shipped desk model with domain randomisation: ``python -m app.retrain_desk`` (needs torch).

Starts from a deskarm .onnx (default the shipped one: its weights are read back, batch norm
frozen), fine-tunes it on cached renders of the simulated desk (``core.sim.dataset``) made
domain-randomised (``core.detect.learned.randomise``, and a share through ``core.sim.realism``'s
webcam preset), with a share of each batch negatives: real photos (the training pairs of
``core.detect.learned.retrain``) and textures with distractors. Then it calibrates the score
(``core.detect.learned.calibrate``: Platt, a logistic fit of "this detection is right" on the raw
score's logit, over renders of training seeds 500 000… that the fine-tuning never used, half of
them randomised, and negatives) and folds the fit into the class outputs, so 0.5 means right half
the time: one fit for all classes (``--per-class``: one per class, which lost on validation — it
raised the classes that fire on real photos). Writes ``--out`` and ``<out>.raw.onnx`` (before
calibration).

Choosing without the held-out photos: ``--validate MODEL…`` prints the figures a model is chosen on
— the validation photos (pairs 13–14, never trained on) and crops/flips/camera effects of them, and
held-out renders from seed 1 500 000 (clean, realistic, hand camera) — and ``--calibrate RAW``
calibrates a model alone. ``--stamp MODEL`` scores the held-out photos (pairs 01–09) and the test
renders (seeds 1 000 000…) and writes the figures into the model: run it once, on the chosen model.
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
        print(f"{path} {key}: {r['images']} renders from seed {TEST_SEED_BASE}\n{r['_table']}", flush=True)
    if real_dir is not None:
        photos = real_photo_split(Path(real_dir), REAL_TEST_PAIRS)
        det = OnnxYoloDetector(path, score_threshold=0.05)
        images = [cv2.imread(str(p)) for p in photos]
        per_image, found = false_boxes_per_image(det, images, SURE)
        per_image_25, _ = false_boxes_per_image(det, images, 0.25)
        meta["deskarm_real_photos"] = {"photos": [p.name for p in photos], "false_boxes_per_image_at_0.5": per_image,
                                       "false_boxes_per_image_at_0.25": per_image_25,
                                       "boxes_at_0.5": {p.name: f for p, f in zip(photos, found) if f}}
        print(json.dumps(meta["deskarm_real_photos"]), flush=True)
    model = onnx.load(str(path))
    props = {p.key: p.value for p in model.metadata_props}
    props.update({k: json.dumps(v) for k, v in meta.items()})
    onnx.helper.set_model_props(model, props)
    onnx.save(model, str(path))
    return meta


CALIBRATION_FIRST_SEED = 500_000  # training seeds the fine-tuning never uses (it takes 0…999)
CALIBRATION_RENDERS = 300
CALIBRATION_NEGATIVES = 150  # negative images (training photos' crops with distractors, textures) in the fit
CALIBRATION_KEEP_FROM = 0.05  # raw scores fitted from (the eval keeps detections from 0.05 too)
VALIDATION_FIRST_SEED = 1_500_000  # held-out renders for choosing; the reported test scenes start at 1 000 000
VALIDATION_RENDERS = 200
VALIDATION_VARIANTS = 600  # crops, flips and camera effects of the validation photos


def calibration_samples(data: Path, real, n_negatives: int = CALIBRATION_NEGATIVES, seed: int = 12345):
    """(image, boxes, labels, difficult) to calibrate on: CALIBRATION_RENDERS renders of training
    seeds 500 000… (every other one domain-randomised) and ``n_negatives`` negative images
    (``negative_image`` on the training photos ``real`` and on textures)."""
    from core.detect.learned.randomise import negative_image, randomise
    from core.sim.dataset import CLASSES, training_arrays

    xs, bs, ls, ds = training_arrays(CALIBRATION_RENDERS, (320, 240), data, CLASSES, first_seed=CALIBRATION_FIRST_SEED)
    rng = np.random.default_rng(seed)
    for i in range(len(xs)):
        yield (xs[i], bs[i], ls[i], ds[i]) if i % 2 else randomise(rng, xs[i], bs[i], ls[i], ds[i], real)
    h, w = xs.shape[1:3]
    empty = (np.zeros((0, 4), np.float32), np.zeros(0, np.int64), np.zeros(0, bool))
    for _ in range(int(n_negatives)):
        yield (negative_image(rng, h, w, real),) + empty


def calibrate_model(raw, out, data: Path, real, n_negatives: int = CALIBRATION_NEGATIVES, say=print,
                    per_class: bool = False) -> list:
    """Fit one Platt (a, b) per class (``per_class``; else one for all) on ``calibration_samples``
    for the model ``raw`` and write it folded into the class outputs to ``out``
    (``core.detect.learned.calibrate``); returns the fits."""
    from core.detect.learned.calibrate import collect, fit_per_class, fold_into_onnx
    from core.detect.onnx_yolo import OnnxYoloDetector

    det = OnnxYoloDetector(raw, score_threshold=CALIBRATION_KEEP_FROM)
    names = list(det.names)
    ids, scores, right = collect(det, calibration_samples(data, real, n_negatives), names)
    ab = fit_per_class(ids, scores, right, len(names), **({} if per_class else {"min_detections": len(scores) + 1}))
    fits = {}
    for c, name in enumerate(names):
        mine = ids == c
        fits[name] = {"a": round(ab[c][0], 4), "b": round(ab[c][1], 4), "detections": int(mine.sum()),
                      "right": int(right[mine].sum())}
        say(f"  {name:7s} a = {ab[c][0]:6.3f}  b = {ab[c][1]:6.3f}  ({int(mine.sum())} detections, "
            f"{int(right[mine].sum())} right)")
    cal = {"method": ("Platt per class" if per_class else "Platt, one fit for all classes")
                     + " (core.detect.learned.calibrate), folded into the class outputs",
           "renders": f"{CALIBRATION_RENDERS} of training seeds {CALIBRATION_FIRST_SEED}… (half randomised)",
           "negative_images": int(n_negatives), "kept_from_score": CALIBRATION_KEEP_FROM, "classes": fits}
    fold_into_onnx(raw, out, ab, metadata={"deskarm_calibration": cal})
    say(f"calibration ({'per class' if per_class else 'one fit'}) on {len(scores)} detections -> {out}")
    return ab


def validate(path, real_dir, n_renders: int = VALIDATION_RENDERS, n_variants: int = VALIDATION_VARIANTS) -> dict:
    """The figures a model is chosen on (never the held-out photos or test scenes): boxes at score
    ≥ 0.5 per image on the validation photos (pairs REAL_VALIDATION_PAIRS) and on crops/flips/camera
    effects of them; mAP@0.5 on held-out renders from VALIDATION_FIRST_SEED, clean and through the
    webcam realism preset."""
    import cv2

    from app.cli_train import EVAL_SCORE_THRESHOLD, _score
    from core.detect.learned.calibrate import photo_variants
    from core.detect.learned.retrain import REAL_VALIDATION_PAIRS, SURE, false_boxes_per_image
    from core.detect.onnx_yolo import OnnxYoloDetector

    det = OnnxYoloDetector(path, score_threshold=0.05)
    photos = [cv2.imread(str(p)) for p in real_photo_split(Path(real_dir), REAL_VALIDATION_PAIRS)]
    per_photo, found = false_boxes_per_image(det, photos, SURE)
    variants = photo_variants(np.random.default_rng(2027), photos, n_variants)
    per_variant, vfound = false_boxes_per_image(det, variants, SURE)
    per_variant_25, low = false_boxes_per_image(det, variants, 0.25)
    out = {"photos": len(photos), "false_per_photo": per_photo, "found": [f for f in found if f],
           "variants": len(variants), "false_per_variant": per_variant, "false_per_variant_at_0.25": per_variant_25,
           "variant_labels": sorted({lab for f in vfound for lab, _ in f}),
           "top_variant_scores": sorted((s for f in low for _, s in f), reverse=True)[:5]}
    for key, realistic in (("clean", False), ("realistic", True)):
        r = _score(Path(path), n_renders, VALIDATION_FIRST_SEED, EVAL_SCORE_THRESHOLD, "cv2", "stereo", realistic)
        out[key] = {"map50": round(r["map"], 4), "ap50": {k: round(v["ap"], 3) for k, v in r["classes"].items()}}
    hand = _score(Path(path), n_renders, VALIDATION_FIRST_SEED, EVAL_SCORE_THRESHOLD, "cv2", "hand")
    out["hand_button_ap50"] = round(hand["classes"]["button"]["ap"], 4)
    return out


def _main(argv=None) -> int:
    import cv2

    from core.sim.realism import WEBCAM, distort_points

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
    p.add_argument("--threads", type=int, default=1, help="torch threads (the build machine is shared: 1)")
    p.add_argument("--negatives", type=float, default=0.2, help="share of each batch with none of the classes")
    p.add_argument("--realism", type=float, default=0.3,
                   help="share of the randomised renders also passed through core.sim.realism's webcam preset")
    p.add_argument("--cal-negatives", type=int, default=CALIBRATION_NEGATIVES,
                   help="negative images in the calibration fit")
    p.add_argument("--per-class", action="store_true", help="calibrate with one fit per class (default: one for all)")
    p.add_argument("--calibrate", default=None, metavar="RAW",
                   help="only calibrate the model RAW and write it to --out")
    p.add_argument("--validate", nargs="+", default=None, metavar="MODEL",
                   help="only print the validation figures of each MODEL (validation photos and renders)")
    p.add_argument("--stamp", default=None, metavar="MODEL",
                   help="only score MODEL on the held-out photos and test renders, and write the figures into "
                        "its metadata")
    args = p.parse_args(argv)
    if args.stamp:
        print(json.dumps(stamp_scores(args.stamp, real_dir=args.real)))
        return 0
    if args.validate:
        for path in args.validate:
            print(json.dumps({"model": path, **validate(path, args.real)}), flush=True)
        return 0
    if args.calibrate:
        real = [cv2.imread(str(f)) for f in real_photo_split(Path(args.real), REAL_TRAIN_PAIRS)]
        calibrate_model(args.calibrate, args.out, Path(args.data), real, args.cal_negatives,
                        lambda text: print(text, flush=True), per_class=args.per_class)
        return 0
    import torch

    from core.detect.learned import finetune as ft
    from core.detect.learned.randomise import negative_image, randomise
    from core.sim.dataset import CLASSES, training_arrays
    from core.sim.realism import apply_realism

    if args.start is None:
        from core.detect.learned.shipped import shipped_model_path

        args.start = str(shipped_model_path())
    torch.set_num_threads(args.threads)
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
    training = {"start": Path(args.start).name, "renders": len(images),
                "real_negatives": [f"left/right{n:02d}" for n in REAL_TRAIN_PAIRS], "negatives_share": args.negatives,
                "realism_share": args.realism, "steps": result.steps, "learning_rate": args.lr, "seed": args.seed,
                "seconds": round(result.seconds), "randomisation": "core.detect.learned.randomise"}
    tuned = result.net
    raw = Path(args.out).with_suffix(".raw.onnx")
    ft.export(tuned, raw, names, metadata={"deskarm_training": training})
    calibrate_model(raw, args.out, Path(args.data), real, args.cal_negatives, say, per_class=args.per_class)
    return 0


if __name__ == "__main__":
    sys.exit(_main())
