"""``deskarm detect``: run detectors on image files and print what they find.

    deskarm detect IMAGE… [--detector NAME[,NAME…]] [--colour NAME=HLO,SLO,VLO,HHI,SHI,VHI]…
                   [--dictionary NAME|FILE] [--markers FILE]
                   [--board COLSxROWS] [--square M] [--marker M] [--legacy] [--json]

Detectors: every name of ``core.detect.registry`` (aruco, hsv, circles, charuco, diamond, desk,
onnx:PATH). ``--colour`` replaces the hsv detector's default colours (and adds hsv when it is not
listed); hue is OpenCV's 0…179, a low hue above the high one wraps through 0 (red).
``--dictionary`` (a predefined name or a dictionary file written by cv2.aruco
``Dictionary.writeDictionary``) is every marker kind's; without it aruco uses the markers file's
dictionary (``--markers``, default ``markers.toml`` in the config folder), charuco and diamond
DICT_4X4_50. ``--board``, ``--square``, ``--marker`` and ``--legacy`` describe the ChArUco board
(squares, metres; the diamond uses the square/marker sizes). Per image it prints each
detection's kind, label, score, box (x, y, w, h px), centre (px), radius, for markers and
diamonds the four corners, for boards how many corners were found. An unreadable image is one
line on stderr naming the file, exit code 1 (the other images are still processed); a bad
detector or option is one line, exit code 2. No Qt is imported.
"""
from __future__ import annotations

import argparse
import json
import sys

from core.detect.charuco import DEFAULT_BOARD_DICTIONARY
from core.vision.perception import DEFAULT_DICTIONARY

PROG = "deskarm detect"


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2 (argparse's own default)
        self.exit(2, f"{self.prog}: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    from core.detect.registry import detector_names

    names = ", ".join(detector_names())
    p = _Parser(prog=PROG, description="Find markers, ChArUco boards and diamonds, coloured blobs, circles or "
                                       "learned objects in image files.")
    p.add_argument("images", nargs="+", metavar="IMAGE", help="image files (anything cv2.imread reads)")
    p.add_argument("--detector", default="aruco,hsv", metavar="NAME[,NAME…]",
                   help=f"detectors to run: {names} (default: aruco,hsv)")
    p.add_argument("--colour", "--color", action="append", default=[], metavar="NAME=HLO,SLO,VLO,HHI,SHI,VHI",
                   help="hsv: a colour to look for (repeatable; replaces the defaults red, orange, yellow, green, blue, purple, pink)")
    p.add_argument("--dictionary", default=None, metavar="NAME|FILE",
                   help="aruco, charuco, diamond: the marker dictionary — a predefined name (e.g. DICT_4X4_50) or a "
                        "dictionary file (YAML/JSON/XML as cv2.aruco Dictionary.writeDictionary writes); default: "
                        f"aruco the markers file's (else {DEFAULT_DICTIONARY}), charuco and diamond "
                        f"{DEFAULT_BOARD_DICTIONARY}")
    p.add_argument("--markers", default=None, metavar="FILE",
                   help="aruco: take the dictionary from this markers file (default: markers.toml in the config "
                        "folder, when there is one)")
    p.add_argument("--board", default="7x5", metavar="COLSxROWS",
                   help="charuco: the board's squares across and down (default: 7x5 — 6x4 inner corners)")
    p.add_argument("--square", type=float, default=0.03, metavar="METRES",
                   help="charuco, diamond: side of a chessboard square (default: 0.03)")
    p.add_argument("--marker", type=float, default=0.022, metavar="METRES",
                   help="charuco, diamond: side of a marker, smaller than the square (default: 0.022)")
    p.add_argument("--legacy", action="store_true",
                   help="charuco: a board drawn by OpenCV before 4.6 (an even number of rows starts with a marker)")
    p.add_argument("--anchors", default=None, metavar="W,H[,W,H…]",
                   help="onnx:PATH with a YOLOv2 output (1, A*(5+C), H, W): its anchors, width,height pairs in grid "
                        "cells as in darknet's [region] anchors (default: the model's metadata key 'anchors')")
    p.add_argument("--json", action="store_true", help="print one JSON object only")
    return p


def _board_size(text: str) -> tuple[int, int]:
    try:
        cols, rows = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise ValueError(f"--board {text!r} is not COLSxROWS squares, e.g. 7x5") from None
    return cols, rows


def markers_dictionary(markers: str | None) -> tuple[str, str | None]:
    """The dictionary of the markers file (``markers`` or markers.toml in the config folder) and a
    note when the default file is broken (its built-in dictionary is used then); MarkersError
    (a ValueError) when an explicit file is."""
    from core.vision.markers import markers_for_session

    config, note = markers_for_session(markers)
    return config.dictionary, note


def build_detectors(detector_list: str, colours: list[str], dictionary: str | None,
                    board: str = "7x5", square_m: float = 0.03, marker_m: float = 0.022,
                    legacy: bool = False, markers: str | None = None, notes: list | None = None,
                    anchors: str | None = None) -> list:
    """The detectors the options name; ValueError (SettingsError too) naming what is wrong.
    ``notes`` collects what the user should hear (a broken markers.toml)."""
    from core.detect.colour import parse_hsv_range
    from core.detect.registry import make_detector, parse_detector_list

    names = parse_detector_list(detector_list)
    if anchors is not None and not any(n.startswith("onnx:") for n in names):
        raise ValueError(f"--anchors {anchors} is for a YOLOv2 model: add --detector onnx:PATH")
    ranges = tuple(parse_hsv_range(text) for text in colours)
    if ranges and "hsv" not in names:
        names.append("hsv")
    detectors = []
    for name in names:
        options: dict = {}
        if name == "hsv" and ranges:
            options["colours"] = ranges
        if name == "aruco":
            if dictionary is not None:
                options["dictionary"] = dictionary
            else:
                options["dictionary"], note = markers_dictionary(markers)
                if note and notes is not None:
                    notes.append(note)
        if name in ("charuco", "diamond"):
            options.update(square_m=square_m, marker_m=marker_m)
            if dictionary is not None:
                options["dictionary"] = dictionary
        if name == "charuco":
            options["squares_x"], options["squares_y"] = _board_size(board)
            options["legacy"] = legacy
        if anchors is not None and name.startswith("onnx:"):
            options["anchors"] = anchors
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
    if d.points is not None:
        text += f"  {len(d.points)} corners found"
    return text


def run(command: str, argv: list[str]) -> int:
    """Entry point of ``deskarm detect`` (``command`` is the subcommand name)."""
    args = build_parser().parse_args(argv)
    notes: list[str] = []
    try:
        detectors = build_detectors(args.detector, args.colour, args.dictionary, args.board, args.square,
                                    args.marker, args.legacy, args.markers, notes, args.anchors)
    except (ValueError, TypeError) as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # e.g. onnx:PATH naming a missing model file
        print(f"{PROG}: {exc}", file=sys.stderr)
        return 2
    for note in notes:
        print(f"{PROG}: {note}", file=sys.stderr)
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
