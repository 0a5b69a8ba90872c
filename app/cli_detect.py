"""``deskarm detect``: run detectors on image files and print what they find.

    deskarm detect IMAGE… [--detector NAME[,NAME…]] [--colour NAME=HLO,SLO,VLO,HHI,SHI,VHI]…
                   [--dictionary NAME] [--json]

Detectors: aruco, hsv, circles, onnx:PATH (see ``core.detect.registry``). ``--colour`` replaces
the hsv detector's default colours (and adds hsv when it is not listed); hue is OpenCV's 0…179,
a low hue above the high one wraps through 0 (red). Per image it prints each detection's kind,
label, score, box (x, y, w, h px), centre (px), radius and, for markers, the four corners.
An unreadable image is one line on stderr naming the file, exit code 1 (the other images are
still processed); a bad detector or option is one line, exit code 2. No Qt is imported.
"""
from __future__ import annotations

import argparse
import json
import sys

PROG = "deskarm detect"


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2 (argparse's own default)
        self.exit(2, f"{self.prog}: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, description="Find markers, coloured blobs, circles or learned objects in image files.")
    p.add_argument("images", nargs="+", metavar="IMAGE", help="image files (anything cv2.imread reads)")
    p.add_argument("--detector", default="aruco,hsv", metavar="NAME[,NAME…]",
                   help="detectors to run: aruco, hsv, circles, onnx:PATH (default: aruco,hsv)")
    p.add_argument("--colour", "--color", action="append", default=[], metavar="NAME=HLO,SLO,VLO,HHI,SHI,VHI",
                   help="hsv: a colour to look for (repeatable; replaces the defaults red, orange, yellow, green, blue, purple, pink)")
    p.add_argument("--dictionary", default=None, metavar="NAME",
                   help="aruco: marker dictionary (default: DICT_6X6_250, the simulated desk's)")
    p.add_argument("--json", action="store_true", help="print one JSON object only")
    return p


def build_detectors(detector_list: str, colours: list[str], dictionary: str | None) -> list:
    """The detectors the options name; ValueError (SettingsError too) naming what is wrong."""
    from core.detect.colour import parse_hsv_range
    from core.detect.registry import make_detector, parse_detector_list

    names = parse_detector_list(detector_list)
    ranges = tuple(parse_hsv_range(text) for text in colours)
    if ranges and "hsv" not in names:
        names.append("hsv")
    detectors = []
    for name in names:
        options: dict = {}
        if name == "hsv" and ranges:
            options["colours"] = ranges
        if name == "aruco" and dictionary is not None:
            options["dictionary"] = dictionary
        detectors.append(make_detector(name, **options))
    return detectors


def _format(d) -> str:
    x, y, w, h = d.box
    text = (f"  {d.kind:<7} {d.label:<10} score {d.score:.2f}  box {x:.1f},{y:.1f},{w:.1f},{h:.1f}"
            f"  centre ({d.centre_px[0]:.1f}, {d.centre_px[1]:.1f})")
    if d.radius_px is not None:
        text += f"  radius {d.radius_px:.1f}"
    if d.corners is not None:
        text += "  corners " + " ".join(f"({cx:.1f}, {cy:.1f})" for cx, cy in d.corners)
    return text


def run(command: str, argv: list[str]) -> int:
    """Entry point of ``deskarm detect`` (``command`` is the subcommand name)."""
    args = build_parser().parse_args(argv)
    try:
        detectors = build_detectors(args.detector, args.colour, args.dictionary)
    except (ValueError, TypeError) as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # e.g. onnx:PATH naming a missing model file
        print(f"{PROG}: {exc}", file=sys.stderr)
        return 2
    import cv2

    failed = False
    results = []
    for path in args.images:
        image = cv2.imread(path, cv2.IMREAD_COLOR)
        if image is None:
            print(f"{PROG}: {path}: cannot read the image (missing, unreadable or not an image format OpenCV knows)",
                  file=sys.stderr)
            failed = True
            continue
        detections = [d for det in detectors for d in det.detect(image)]
        results.append((path, image.shape, detections))
        if not args.json:
            h, w = image.shape[:2]
            print(f"{path} ({w}x{h}): {len(detections)} detection{'s' if len(detections) != 1 else ''}")
            for d in detections:
                print(_format(d))
    if args.json:
        print(json.dumps({
            "detectors": [det.name for det in detectors],
            "images": [{"path": path, "width": shape[1], "height": shape[0],
                        "detections": [d.to_dict() for d in detections]} for path, shape, detections in results],
        }))
    return 1 if failed else 0
