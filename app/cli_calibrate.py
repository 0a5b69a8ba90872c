"""``deskarm calibrate``: stereo calibration from saved board pictures.

    deskarm calibrate --left 'shots/left_*.png' --right 'shots/right_*.png' \\
        --board chessboard:9x6 --square 0.025 [--out FILE] [--export-ros DIR] [--json]

Prints one line per pair (used, or rejected and why), then a summary; ``--json`` ends with one
JSON object. Without ``--out`` the result goes where the app loads it at start
(``<config>/calibration.yaml``; the one it replaces is kept as ``calibration.previous.yaml``).
A calibration that fails a sanity check (implausible focal length, board distance, too little tilt,
fewer than 6 pairs or a focal length uncertain by more than 3 % when pairs are left out, baseline ~0,
swapped, upside-down or mirrored camera, pictures paired off by one, RMS too high) is reported and
not written unless ``--force``; a mistake that fails several checks at once is said first, alone,
and the checks it explains after it. A board described with the wrong size stops early (after 3
pairs that agree) naming the chessboard in view when it calibrates. Exit codes: 0 calibrated,
1 calibration failed (too few usable pairs, or a failed check without ``--force``), 2 bad arguments.
"""
from __future__ import annotations

import argparse
import glob
import json
import os
import sys
from pathlib import Path
from typing import Optional

EARLY_CHECK_PAIRS = 4  # when none of the first pairs shows the board, look for a likely mistake
EARLY_AGREE_PAIRS = 3  # … or as soon as this many pairs agree on another (smaller) board in view


def build_parser(prog: str = "deskarm calibrate") -> argparse.ArgumentParser:
    from core.vision.stereo_calibration import BOARD_FORMS, DISTORTION_MODELS

    p = argparse.ArgumentParser(
        prog=prog,
        description="Calibrate the stereo camera from pairs of board pictures (left and right taken "
        "at the same time). Pairs where either view misses the board, and outlier pairs, are "
        "rejected with the reason; the rest give the calibration the app uses.",
    )
    src = p.add_argument_group("pictures")
    src.add_argument("--left", metavar="GLOB", help="left images, e.g. 'shots/left_*.png' (quote it)")
    src.add_argument("--right", metavar="GLOB", help="right images, e.g. 'shots/right_*.png'")
    src.add_argument("--folder", metavar="DIR",
                     help="a folder of left_*/right_* pairs or left/ + right/ subfolders (e.g. a wizard session)")
    p.add_argument("--board", help=f"the board: {BOARD_FORMS} (a wizard session folder names its own)")
    p.add_argument("--square", type=float, metavar="METRES", help="side of one square in metres, e.g. 0.025")
    p.add_argument("--out", metavar="FILE",
                   help="where to write the calibration YAML (default: the app's calibration, loaded at start)")
    p.add_argument("--install", action="store_true",
                   help="with --out: also install the result as the app's calibration")
    p.add_argument("--no-save", action="store_true", help="calibrate and report, write nothing")
    p.add_argument("--export-ros", metavar="DIR", help="also write left.yaml and right.yaml (ROS camera_info) there")
    p.add_argument("--json", action="store_true", help="end with one JSON object of the results")
    p.add_argument("--distortion", default="auto", choices=DISTORTION_MODELS,
                   help="distortion terms to estimate (default: auto — fewer with few pairs)")
    p.add_argument("--max-error", type=float, default=0.0, metavar="PX",
                   help="reject pairs whose reprojection RMS exceeds PX (default: automatic, 3x the median, ≥ 0.5 px)")
    p.add_argument("--no-sb", action="store_true",
                   help="skip the slow findChessboardCornersSB fallback (faster, finds fewer boards)")
    p.add_argument("--wide", action="store_true",
                   help="wide-angle lenses: accept a horizontal field of view up to 170° (default 20–120°)")
    p.add_argument("--swap", action="store_true",
                   help="the left and right pictures are swapped: use --left as right and --right as left")
    p.add_argument("--force", action="store_true",
                   help="save / install even when a sanity check fails (focal length, baseline, tilt, RMS …)")
    p.add_argument("--quiet", action="store_true", help="no per-pair lines")
    return p


def _fail(message: str, code: int = 2) -> int:
    print(f"deskarm calibrate: {message}", file=sys.stderr)
    return code


def _expand(pattern: str) -> list[Path]:
    return sorted(Path(p) for p in glob.glob(os.path.expanduser(pattern), recursive=True) if Path(p).is_file())


def _collect_pairs(args) -> tuple[list[tuple[Path, Path]], list[str]]:
    """(pairs, warnings) from --left/--right globs or --folder; ValueError when nothing usable."""
    from core.vision.cameras import IMAGE_SUFFIXES, find_image_pairs, pair_image_files

    warnings: list[str] = []
    if args.folder:
        folder = Path(args.folder)
        if not folder.is_dir():
            raise ValueError(f"--folder {args.folder!r} is not a folder")
        pairs = find_image_pairs(folder)
        if not pairs:
            raise ValueError(f"--folder {args.folder!r} holds no left_*/right_* image pairs "
                             f"(or left/ and right/ subfolders)")
        return pairs, warnings
    if not (args.left and args.right):
        raise ValueError("give --left GLOB and --right GLOB (or --folder DIR)")
    lefts = [p for p in _expand(args.left) if p.suffix.lower() in IMAGE_SUFFIXES]
    rights = [p for p in _expand(args.right) if p.suffix.lower() in IMAGE_SUFFIXES]
    if not lefts:
        raise ValueError(f"--left {args.left!r} matches no image files")
    if not rights:
        raise ValueError(f"--right {args.right!r} matches no image files")
    pairs, lonely_l, lonely_r = pair_image_files(lefts, rights)
    if not pairs:
        raise ValueError(f"cannot pair the {len(lefts)} left and {len(rights)} right images by name — "
                         f"name them like left_001.png / right_001.png")
    warnings += [f"{p.name}: no right image with a matching name — skipped" for p in lonely_l]
    warnings += [f"{p.name}: no left image with a matching name — skipped" for p in lonely_r]
    return pairs, warnings


def run(command: str, argv: list[str]) -> int:
    """Entry point of ``deskarm calibrate`` (see module docstring)."""
    args = build_parser(f"deskarm {command}").parse_args(argv)
    import cv2

    from core.vision.calibration import (
        export_ros_camera_info,
        install_calibration,
        save_calibration,
    )
    from core.vision.stereo_calibration import (
        BoardError,
        CalibrationFailed,
        CalibrationOptions,
        DetectOptions,
        calibrate_stereo,
        detect_pair,
        parse_board,
        read_session_board,
        seen_grid,
        suggest_board,
    )

    say = (lambda *a: None) if args.quiet else (lambda *a: print(*a, flush=True))
    # -- arguments ---------------------------------------------------------------------------
    try:
        if args.board is None:
            if not args.folder:
                raise ValueError("give --board, e.g. --board chessboard:9x6 --square 0.025")
            board = read_session_board(args.folder)
        else:
            if args.square is None:
                raise ValueError("give --square METRES, the side of one square, e.g. 0.025")
            board = parse_board(args.board, args.square)
        options = CalibrationOptions(distortion=args.distortion, max_pair_error_px=args.max_error, wide=args.wide)
        if args.install and not args.out:
            raise ValueError("--install goes with --out (without --out the result is installed anyway)")
        if args.no_save and (args.out or args.install):
            raise ValueError("--no-save contradicts --out / --install")
        pairs, warnings = _collect_pairs(args)
        if args.swap:
            pairs = [(rp, lp) for lp, rp in pairs]
    except (BoardError, ValueError) as exc:
        return _fail(str(exc))
    for w in warnings:
        say(f"warning: {w}")
    say(f"board: {board.describe()}; {len(pairs)} pairs")

    # -- detection ---------------------------------------------------------------------------
    detect_options = DetectOptions(use_sb=not args.no_sb)
    detections, names, sample_images = [], [], []
    from core.vision.stereo_calibration import BoardDetection, PairDetection

    for k, (lp, rp) in enumerate(pairs, start=1):
        left, right = cv2.imread(str(lp)), cv2.imread(str(rp))
        if left is None or right is None:
            bad = lp if left is None else rp
            det = PairDetection(BoardDetection(False, reason="unreadable"), BoardDetection(False, reason="unreadable"),
                                reasons=(f"cannot read {bad.name} (not an image?)",))
        else:
            det = detect_pair(left, right, board, detect_options)
            if len(sample_images) < 3:
                sample_images.append(left)
        detections.append(det)
        names.append(lp.name)
        status = (f"ok ({len(det.object_points)} corners, {det.left.method}/{det.right.method})" if det.ok
                  else f"rejected: {det.reason}")
        say(f"[{k:3d}/{len(pairs)}] {lp.name} + {rp.name}: {status}")
        seen = seen_grid(detections)
        if k < len(pairs) and not any(d.ok for d in detections) and (
                k == EARLY_CHECK_PAIRS or (seen is not None and k == EARLY_AGREE_PAIRS)):
            # a wrong board description fails every pair, slowly: stop early when we can tell why
            hint = suggest_board(sample_images, board, pairs=pairs, seen=seen)
            if hint:
                message = (f"the first {k} pairs show no {board.describe()} — stopped early\nhint: {hint}")
                if args.json:
                    print(json.dumps({"error": message.splitlines()[0], "hint": hint, "pairs_total": len(pairs),
                                      "pairs_used": 0, "pairs_rejected": k, "out": None, "installed": False,
                                      "rejected": [{"pair": n, "reason": d.reason} for n, d in zip(names, detections)]}))
                print(f"deskarm calibrate: {message}", file=sys.stderr)
                return 1

    # -- calibration -------------------------------------------------------------------------
    say("calibrating …")
    try:
        report = calibrate_stereo(detections, None, names, options, None, board)
    except CalibrationFailed as exc:
        hint = None
        if sum(d.ok for d in detections) < options.min_pairs:
            hint = suggest_board(sample_images, board, pairs=pairs, seen=seen_grid(detections))
        message = str(exc) + (f"\nhint: {hint}" if hint else "")
        if args.json:
            rejected = [{"pair": p.name, "reason": p.reason} for p in exc.pairs if p.reason]
            print(json.dumps({"error": str(exc), "hint": hint, "pairs_total": len(detections),
                              "pairs_used": 0, "pairs_rejected": len(rejected), "rejected": rejected,
                              "out": None, "installed": False}))
        print(f"deskarm calibrate: {message}", file=sys.stderr)
        return 1
    for p in report.pairs:
        if p.used:
            say(f"  {p.name}: error {p.error_px:.3f} px (left {p.error_left_px:.3f}, right {p.error_right_px:.3f}), "
                f"epipolar {p.epipolar_px:.3f} px")
    for line in report.summary_lines():
        print(line, flush=True)

    # -- writing -----------------------------------------------------------------------------
    out: Optional[Path] = None
    installed = False
    extra = {**report.file_extras(), "square_m": float(board.square_m)}
    refused = not report.ok and not args.force
    if refused and not args.no_save:
        print("not saved: the calibration failed a sanity check (see 'problem:' above) — fix it and calibrate "
              "again, or save it anyway with --force", file=sys.stderr, flush=True)
    try:
        if not args.no_save and not refused:
            if args.out:
                out = save_calibration(args.out, report.calibration, extra)
                print(f"saved {out}", flush=True)
            if not args.out or args.install:
                installed_path = install_calibration(report.calibration, extra)
                installed = True
                out = out or installed_path
                print(f"saved {installed_path} (the app loads it at start)", flush=True)
        if args.export_ros and not refused:
            for path in export_ros_camera_info(report.calibration, args.export_ros):
                print(f"saved {path} (ROS camera_info)", flush=True)
    except OSError as exc:
        return _fail(f"cannot write the result: {exc}", 1)
    if args.json:
        print(json.dumps({**report.summary(str(out) if out else None), "installed": installed,
                          "forced": bool(args.force and not report.ok)}))
    return 1 if refused else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(run("calibrate", sys.argv[1:]))
