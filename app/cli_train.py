"""``deskarm train-detector`` and ``deskarm eval-detector``: the desk detector's training and its score.

    deskarm train-detector [--images N] [--epochs E] [--minutes M] [--out PATH] [--data DIR]
                           [--test-images N] [--input WxH] [--seed S] [--threads T] [--json]
    deskarm train-detector --add DIR [--name NAME]
    deskarm eval-detector [MODEL] [--images N] [--seed S] [--view stereo|hand|both] [--realistic]
                          [--score-threshold X] [--backend B] [--json]

``train-detector --add DIR`` teaches the detector a new object from the frames and marks in DIR
(``deskarm teach NAME --images DIR``, ``app.cli_teach``; NAME defaults to DIR's name).

``train-detector`` renders N labelled images of random simulated-desk scenes — about two thirds
seen by the stereo rig, a third (``core.sim.dataset.HAND_SHARE``) by the assistive arm's hand
camera (cached in DIR, default the user cache folder), trains the small detector of ``core.detect.learned.model`` on
them for E epochs or M minutes, whichever ends first, exports it to ONNX (default
``resources/models/desk_objects.onnx``) and scores the exported file, run by OpenCV's DNN module,
on held-out renders it never saw, of each camera apart: per-class AP and mAP@0.5 on the rig's views
and on the hand camera's. It needs the optional ``train`` extra (torch, CPU). ``eval-detector``
scores any YOLO-layout ONNX model (default: the shipped one) on fresh held-out renders of the
cameras ``--view`` names (default the stereo rig's), without torch. Both print a table, or one JSON object with ``--json``.
Exit codes: 0 done, 2 bad option or missing dependency/model.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

TRAIN = "train-detector"
EVAL = "eval-detector"
COMMANDS = (TRAIN, EVAL)
EVAL_SCORE_THRESHOLD = 0.05  # detections kept for the precision-recall curve (AP needs the low ones)
REPORT_SCORE_THRESHOLD = 0.25  # where precision and recall are read (OnnxYoloDetector's default)


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2 (argparse's own default)
        self.exit(2, f"{self.prog}: {message}\n")


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not WIDTHxHEIGHT, e.g. 320x240") from None
    if w % 16 or h % 16 or not (64 <= w <= 1280 and 64 <= h <= 1280):
        raise argparse.ArgumentTypeError(f"{text!r}: width and height must be multiples of 16 in 64…1280")
    return w, h


def _positive(kind):
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if value <= 0:
            raise argparse.ArgumentTypeError(f"{text!r} must be greater than 0")
        return value
    return parse


def add_parser(subparsers) -> None:
    """Add both subcommands to an argparse ``subparsers`` (``parser.add_subparsers()``)."""
    for name in COMMANDS:
        _fill(subparsers.add_parser(name, help=_HELP[name], description=_HELP[name]), name)


_HELP = {
    TRAIN: "Render labelled desk images, train the small desk detector (needs torch), export and score it.",
    EVAL: "Score a YOLO ONNX model (default: the shipped desk model) on fresh held-out renders of the desk.",
}


def _fill(p: argparse.ArgumentParser, command: str) -> argparse.ArgumentParser:
    from core.sim.dataset import TEST_SEED_BASE, VIEWS

    if command == TRAIN:
        p.add_argument("--images", type=_positive(int), default=8000, metavar="N",
                       help="training images (two images of each of N/2 random scenes, a third of them from the "
                            "hand camera; default 8000)")
        p.add_argument("--epochs", type=_positive(int), default=40, metavar="E",
                       help="passes over them at most (default 40)")
        p.add_argument("--minutes", type=_positive(float), default=12.0, metavar="M",
                       help="wall-time budget of the optimisation (default 12)")
        p.add_argument("--out", default=None, metavar="PATH",
                       help="where to write the .onnx (default: resources/models/desk_objects.onnx)")
        p.add_argument("--data", default=None, metavar="DIR",
                       help="cache folder of the rendered images (default: <user cache>/desk-dataset)")
        p.add_argument("--test-images", type=_positive(int), default=200, metavar="N",
                       help="held-out renders the exported model is scored on, per camera (default 200)")
        p.add_argument("--input", type=_size, default=(320, 240), metavar="WxH",
                       help="network input, multiples of 16 (default 320x240: half the 640x480 camera)")
        p.add_argument("--seed", type=int, default=0, help="training seed (weights, order, flips; default 0)")
        p.add_argument("--threads", type=int, default=0, metavar="T",
                       help="torch CPU threads (default: torch's; 1 is faster on a busy, shared CPU)")
        p.add_argument("--add", default=None, metavar="DIR",
                       help="teach a new object instead: DIR holds ≤ 60 frames and boxes.txt (see deskarm teach)")
        p.add_argument("--name", default=None, metavar="NAME", help="with --add: the object's name (default DIR's)")
    else:
        p.add_argument("model", nargs="?", default=None, metavar="MODEL",
                       help="a YOLO-layout .onnx (default: the shipped resources/models/desk_objects.onnx)")
        p.add_argument("--images", type=_positive(int), default=200, metavar="N",
                       help="renders to score on (default 200)")
        p.add_argument("--seed", type=int, default=TEST_SEED_BASE, metavar="S",
                       help=f"first held-out scene seed, ≥ {TEST_SEED_BASE} (default {TEST_SEED_BASE})")
        p.add_argument("--view", choices=VIEWS, default="stereo",
                       help="which camera's renders: the stereo rig's two views (default), the assistive arm's "
                            "hand camera (the lift panel up close), or both mixed as in training")
        p.add_argument("--realistic", action="store_true",
                       help="also score the same renders through the webcam realism preset (core.sim.realism)")
        p.add_argument("--score-threshold", type=float, default=EVAL_SCORE_THRESHOLD, metavar="X",
                       help=f"lowest detection score kept for the AP curve (default {EVAL_SCORE_THRESHOLD})")
        p.add_argument("--backend", choices=("cv2", "onnxruntime", "auto"), default="cv2",
                       help="what runs the model (default cv2: OpenCV's DNN module)")
    p.add_argument("--json", action="store_true", help="print one JSON object only")
    return p


def build_parser(command: str) -> argparse.ArgumentParser:
    return _fill(_Parser(prog=f"deskarm {command}", description=_HELP[command]), command)


# ---------------------------------------------------------------------------------------------- eval
def score_realistic(detector, n_images: int, first_seed: int, classes, view: str = "stereo",
                    preset="webcam"):
    """``score_detector`` on the same held-out renders passed through the realism preset
    (``core.sim.realism.apply_realism``: blur, rolling shutter, flicker, noise, vignetting, distortion,
    JPEG; one draw per scene, seeded by it); the truth boxes follow the lens distortion."""
    from core.detect.learned.evaluation import ScoredBox, TruthBox, evaluate_detections
    from core.sim.dataset import held_out_seeds, render_views
    from core.sim.realism import apply_realism, distort_points, preset_named

    import numpy as np

    preset = preset_named(preset)
    n_scenes = -(-int(n_images) // 2)
    truths, found = [], []
    render_s = detect_s = 0.0
    for seed in held_out_seeds(n_scenes, first_seed):
        t0 = time.perf_counter()
        pair = render_views(seed, tuple(classes), view)
        images = apply_realism([s.image for s in pair], np.random.default_rng([seed, 27]), t=seed / 30.0,
                               preset=preset)
        render_s += time.perf_counter() - t0
        for sample, image in list(zip(pair, images))[:n_images - len(truths)]:
            h, w = image.shape[:2]
            boxes = []
            for b in sample.boxes:
                x0, y0, x1, y1 = b.box
                edge = np.linspace(0, 1, 7)
                pts = np.concatenate([np.column_stack([x0 + (x1 - x0) * edge, np.full(7, y0)]),
                                      np.column_stack([x0 + (x1 - x0) * edge, np.full(7, y1)]),
                                      np.column_stack([np.full(7, x0), y0 + (y1 - y0) * edge]),
                                      np.column_stack([np.full(7, x1), y0 + (y1 - y0) * edge])])
                d = distort_points(pts, (w, h), preset)
                boxes.append(TruthBox(b.label, (float(d[:, 0].min()), float(d[:, 1].min()), float(d[:, 0].max()),
                                                float(d[:, 1].max())), b.difficult))
            t0 = time.perf_counter()
            detections = detector.detect(image)
            detect_s += time.perf_counter() - t0
            truths.append(boxes)
            found.append([ScoredBox(q.label, (q.box[0], q.box[1], q.box[0] + q.box[2], q.box[1] + q.box[3]), q.score)
                          for q in detections])
    scores = evaluate_detections(truths, found, list(classes), 0.5, REPORT_SCORE_THRESHOLD)
    n = max(len(truths), 1)
    return scores, {"render_ms_per_image": 1000 * render_s / n, "detect_ms_per_image": 1000 * detect_s / n}


def _score(model_path: Path, n_images: int, first_seed: int, score_threshold: float, backend: str,
           view: str = "stereo", realistic: bool = False) -> dict:
    """Score a model file on held-out renders of ``view`` (through the realism preset when
    ``realistic``): a JSON-ready dict (raises ValueError/OSError)."""
    from core.detect.onnx_yolo import OnnxYoloDetector
    from core.sim.dataset import CLASSES, score_detector

    detector = OnnxYoloDetector(model_path, backend=backend, score_threshold=score_threshold)
    classes = [name for name in detector.names if name in CLASSES]
    if not classes:
        raise ValueError(f"{model_path}: none of its classes {detector.names or '(unnamed)'} is a desk class "
                         f"({', '.join(CLASSES)}); name them in the model's 'names' metadata")
    if realistic:
        scores, timing = score_realistic(detector, n_images, first_seed, classes, view)
    else:
        scores, timing = score_detector(detector, n_images, first_seed, classes, 0.5, REPORT_SCORE_THRESHOLD, view)
    out = {"model": str(model_path), "backend": detector.backend, "input": list(detector.input_wh),
           "images": scores.n_images, "first_seed": first_seed, "view": view,
           "realism": "webcam" if realistic else None, "detect_score_threshold": score_threshold}
    out.update(scores.to_dict())
    out["timing"] = {k: round(v, 2) for k, v in timing.items()}
    out["_table"] = scores.table()
    return out


def _print_score(result: dict, as_json: bool) -> None:
    table = result.pop("_table")
    if as_json:
        print(json.dumps(result))
        return
    camera = {"stereo": "stereo rig", "hand": "hand camera", "both": "stereo rig and hand camera"}[result["view"]]
    realism = " through the webcam realism preset" if result.get("realism") else " (clean)"
    print(f"{result['model']}: {result['images']} held-out renders of the {camera}{realism} (seeds from "
          f"{result['first_seed']}), backend {result['backend']}, input {result['input'][0]}x{result['input'][1]}")
    print(table)
    t = result["timing"]
    print(f"detect {t['detect_ms_per_image']:.1f} ms per 640x480 image (render {t['render_ms_per_image']:.1f} ms)")


def _run_eval(args) -> int:
    from core.sim.dataset import TEST_SEED_BASE

    prog = f"deskarm {EVAL}"
    if args.model is None:
        from core.detect.learned.shipped import shipped_model_path

        model = shipped_model_path()
    else:
        model = Path(args.model)
    if args.seed < TEST_SEED_BASE:
        print(f"{prog}: --seed {args.seed}: held-out scenes start at {TEST_SEED_BASE} (lower seeds are training "
              f"scenes)", file=sys.stderr)
        return 2
    if not 0.0 <= args.score_threshold <= 1.0:
        print(f"{prog}: --score-threshold {args.score_threshold} must be in 0…1", file=sys.stderr)
        return 2
    if not model.is_file():
        print(f"{prog}: model not found: {model}", file=sys.stderr)
        return 2
    try:
        result = _score(model, args.images, args.seed, args.score_threshold, args.backend, args.view)
        real = (_score(model, args.images, args.seed, args.score_threshold, args.backend, args.view, True)
                if args.realistic else None)
    except (ValueError, ImportError) as exc:
        print(f"{prog}: {exc}", file=sys.stderr)
        return 2
    if real is not None and args.json:
        real.pop("_table")
        result["realistic"] = real
    _print_score(result, args.json)
    if real is not None and not args.json:
        _print_score(real, False)
    return 0


# ---------------------------------------------------------------------------------------------- train
def _default_out() -> Path:
    from core.detect.learned.shipped import shipped_model_path

    return shipped_model_path()


def _run_train(args) -> int:
    prog = f"deskarm {TRAIN}"
    if args.add is not None:
        from app.cli_teach import teach_folder

        folder = Path(args.add)
        minutes = args.minutes if "--minutes" in args.argv else 4.0
        return teach_folder(args.name or folder.resolve().name, folder, None, minutes=minutes, as_json=args.json,
                            prog=prog)
    try:
        import torch  # noqa: F401
    except ImportError:
        print(f"{prog}: torch is not installed — pip install -e '.[train]' (torch 2.13.0, CPU wheel)",
              file=sys.stderr)
        return 2
    try:
        import onnx  # noqa: F401
    except ImportError:
        print(f"{prog}: the onnx package is not installed — pip install -e '.[train]'", file=sys.stderr)
        return 2
    from core.detect.learned.model import TrainConfig, config_dict, export_onnx, train_detector
    from core.paths import user_dir
    from core.sim.dataset import CLASSES, DATASET_VERSION, HAND_SHARE, TEST_SEED_BASE, is_hand_scene, training_arrays

    log_stream = sys.stderr if args.json else sys.stdout

    def say(text: str) -> None:
        print(text, file=log_stream, flush=True)

    out = Path(args.out) if args.out else _default_out()
    data = Path(args.data) if args.data else user_dir("cache") / "desk-dataset"
    try:
        config = TrainConfig(epochs=args.epochs, max_seconds=60.0 * args.minutes, seed=args.seed, threads=args.threads)
    except ValueError as exc:
        print(f"{prog}: {exc}", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    say(f"rendering/reading {args.images} training images ({args.input[0]}x{args.input[1]}) in {data}")
    try:
        images, boxes, labels, difficult = training_arrays(args.images, args.input, data, CLASSES, progress=say)
    except OSError as exc:
        print(f"{prog}: {data}: cannot write the rendered images: {exc}", file=sys.stderr)
        return 2
    data_s = time.perf_counter() - t0
    counts = {name: int(sum(int(((lab == i) & ~d).sum()) for lab, d in zip(labels, difficult)))
              for i, name in enumerate(CLASSES)}
    n_scenes = -(-len(images) // 2)
    hand_images = min(len(images), 2 * sum(is_hand_scene(seed) for seed in range(n_scenes)))
    say(f"{len(images)} images ({hand_images} from the hand camera), boxes per class {counts}, ready in "
        f"{data_s:.0f} s; training "
        f"(≤ {config.epochs} epochs, ≤ {args.minutes:g} min)")
    result = train_detector(images, boxes, labels, difficult, len(CLASSES), config, progress=say)
    training = {**result.summary(), "images": len(images), "hand_images": hand_images, "hand_share": HAND_SHARE,
                "scene_seeds": [0, n_scenes - 1], "boxes": counts, "dataset_version": DATASET_VERSION, "config": config_dict(config),
                "command": "deskarm train-detector " + " ".join(args.argv)}
    meta = {"deskarm_training": training}
    try:
        export_onnx(result.net, out, CLASSES, args.input, metadata=meta)
        score = _score(out, args.test_images, TEST_SEED_BASE, EVAL_SCORE_THRESHOLD, "cv2", "stereo")
        hand = _score(out, args.test_images, TEST_SEED_BASE, EVAL_SCORE_THRESHOLD, "cv2", "hand")
        for key, result_of_view in (("deskarm_eval", score), ("deskarm_eval_hand", hand)):
            meta[key] = {"images": result_of_view["images"], "first_seed": TEST_SEED_BASE,
                         "view": result_of_view["view"], "map50": result_of_view["map"],
                         "ap50": {k: v["ap"] for k, v in result_of_view["classes"].items()}}
        export_onnx(result.net, out, CLASSES, args.input, metadata=meta)  # the same weights, with their scores
    except OSError as exc:
        print(f"{prog}: {exc}", file=sys.stderr)
        return 2
    score["training"] = training
    score["data_seconds"] = round(data_s, 1)
    score["model_bytes"] = out.stat().st_size
    if not args.json:
        say(f"trained in {result.seconds:.0f} s ({result.epochs_done:.1f} epochs, {result.steps} steps); wrote "
            f"{out} ({score['model_bytes'] / 1e6:.2f} MB)")
        _print_score(score, False)
        _print_score(hand, False)
        return 0
    hand.pop("_table")
    score["hand"] = hand
    _print_score(score, True)
    return 0


def run(command: str, argv: list[str]) -> int:
    """Entry point of ``deskarm train-detector`` / ``deskarm eval-detector`` (``command`` says which)."""
    if command not in COMMANDS:
        raise ValueError(f"unknown command {command!r}; valid: {', '.join(COMMANDS)}")
    args = build_parser(command).parse_args(argv)
    args.argv = list(argv)
    return _run_train(args) if command == TRAIN else _run_eval(args)


def main(argv: list[str] | None = None) -> int:
    """``python -m app.cli_train train-detector …`` (what ``deskarm`` dispatches to)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in COMMANDS:
        print(f"usage: {sys.argv[0] if argv is None else 'cli_train'} {{{','.join(COMMANDS)}}} …", file=sys.stderr)
        return 2
    return run(argv[0], argv[1:])


if __name__ == "__main__":
    sys.exit(main())
