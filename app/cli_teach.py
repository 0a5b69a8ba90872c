"""``deskarm teach``: teach the desk detector a new object from a folder of frames (needs torch).

    deskarm teach NAME --images DIR [--boxes FILE] [--steps N] [--minutes M] [--base MODEL] [--out DIR] [--json]
    deskarm train-detector --add DIR [--name NAME]      (the same: DIR holds the frames and boxes.txt)

DIR holds ≤ 60 frames (.jpg/.png, taken in name order) of the object moved in front of the camera.
``--boxes FILE`` (default DIR/boxes.txt) marks it in ≤ 10 of them, one line each: ``FRAME x0 y0 x1 y1``
(a box) or ``FRAME x y`` (a tap on it); FRAME is the frame's file name or its index. A tracker
carries each mark through the frames after it; the shipped model (or the user's, if they taught
one before) is fine-tuned on CPU with those frames and randomised negatives, and the model with the
new class is written to the config folder's ``models/desk_objects.onnx`` (``--detector desk``
uses it from then on; ``--follow-object NAME`` follows the object) and ``models/NAME.onnx``.
A progress bar and the time left are shown; Ctrl-C stops and keeps the old model.
Exit codes: 0 taught, 1 cancelled (nothing changed), 2 bad input or missing torch.
"""
from __future__ import annotations

import argparse
import json
import signal
import sys
import time
from pathlib import Path

from core.detect.learned.teach import TeachConfig

TEACH = "teach"
COMMANDS = (TEACH,)
IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png", ".bmp")


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:
        self.exit(2, f"{self.prog}: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=f"deskarm {TEACH}", description="Teach the desk detector a new object from a few frames.")
    p.add_argument("name", metavar="NAME", help="the object's name (what the detector will call it)")
    p.add_argument("--images", required=True, metavar="DIR", help="folder of ≤ 60 frames of the object")
    p.add_argument("--boxes", default=None, metavar="FILE",
                   help="≤ 10 marks: 'FRAME x0 y0 x1 y1' or 'FRAME x y' per line (default DIR/boxes.txt)")
    p.add_argument("--steps", type=int, default=TeachConfig.steps, metavar="N",
                   help=f"training steps at most (default {TeachConfig.steps}; --minutes stops it sooner)")
    p.add_argument("--minutes", type=float, default=4.0, metavar="M", help="time limit (default 4)")
    p.add_argument("--base", default=None, metavar="MODEL", help="model to extend (default: yours, else the shipped)")
    p.add_argument("--out", default=None, metavar="DIR", help="where to write (default: <config>/models)")
    p.add_argument("--json", action="store_true", help="print one JSON object at the end")
    return p


def progress_line(fraction: float, seconds_left: float, width: int = 30) -> str:
    """``[#########.....]  43 %  1:20 left``."""
    fraction = min(max(float(fraction), 0.0), 1.0)
    full = int(round(fraction * width))
    if seconds_left != seconds_left:  # nan: not known yet
        left = "--:--"
    else:
        s = int(round(max(seconds_left, 0.0)))
        left = f"{s // 60}:{s % 60:02d}"
    return f"[{'#' * full}{'.' * (width - full)}] {100 * fraction:3.0f} %  {left} left"


def load_frames(folder: Path):
    import cv2

    files = sorted(p for p in Path(folder).iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
    frames = []
    for f in files:
        img = cv2.imread(str(f))
        if img is None:
            raise ValueError(f"{f}: not an image OpenCV can read")
        frames.append(img)
    return files, frames


def teach_folder(name: str, images: Path, boxes_file, *, steps: int = TeachConfig.steps, minutes: float = 4.0, base=None,
                 out=None, as_json: bool = False, prog: str = f"deskarm {TEACH}") -> int:
    try:
        import torch  # noqa: F401
        import onnx  # noqa: F401
    except ImportError:
        print(f"{prog}: teaching needs torch and onnx — pip install -e '.[train]'", file=sys.stderr)
        return 2
    from dataclasses import replace

    from core.detect.learned.teach import MAX_FRAMES, read_marks, teach, valid_name

    images = Path(images)
    boxes_file = Path(boxes_file) if boxes_file else images / "boxes.txt"
    try:
        name = valid_name(name)
        if not images.is_dir():
            raise ValueError(f"{images}: no such folder")
        files, frames = load_frames(images)
        if not frames:
            raise ValueError(f"{images}: no .jpg/.png frames")
        if len(frames) > MAX_FRAMES:
            raise ValueError(f"{images}: {len(frames)} frames, at most {MAX_FRAMES}")
        if not boxes_file.is_file():
            raise ValueError(f"{boxes_file}: no marks — write 'FRAME x0 y0 x1 y1' lines (or give --boxes FILE)")
        marks = read_marks(boxes_file)
        by_name = {f.name: i for i, f in enumerate(files)}
        fixed = []
        for m in marks:
            key = str(m.frame)
            if key in by_name:
                fixed.append(replace(m, frame=by_name[key]))
            elif key.isdigit():
                fixed.append(replace(m, frame=int(key)))
            else:
                raise ValueError(f"{boxes_file}: frame {key!r} is neither an index nor a file in {images}")
    except (ValueError, OSError) as exc:
        print(f"{prog}: {exc}", file=sys.stderr)
        return 2
    stop = {"now": False}

    def on_sigint(signum, frame):
        stop["now"] = True

    old = signal.signal(signal.SIGINT, on_sigint)
    last = [0.0]
    tty = sys.stderr.isatty()

    def progress(fraction, left, text):
        now = time.monotonic()
        if now - last[0] < (0.2 if tty else 5.0) and fraction < 1.0:
            return
        last[0] = now
        line = progress_line(fraction, left)
        print(("\r" + line) if tty else line, end="" if tty else "\n", file=sys.stderr, flush=True)

    from core.sim.dataset import desk_negatives

    try:
        result = teach(name, frames, fixed, base_model=base, out_dir=Path(out) if out else None,
                       config=TeachConfig(steps=steps, max_seconds=60.0 * minutes), progress=progress,
                       cancelled=lambda: stop["now"], scene_negatives=desk_negatives)
    except ValueError as exc:
        print(f"\n{prog}: {exc}", file=sys.stderr)
        return 2
    finally:
        signal.signal(signal.SIGINT, old)
    if tty:
        print(file=sys.stderr)
    if result is None:
        print(f"{prog}: cancelled — the old model is kept", file=sys.stderr)
        return 1
    summary = {"name": result.name, "model": str(result.path), "classes": result.names,
               "seconds": round(result.seconds, 1), "steps": result.steps, "frames": len(frames),
               "frames_used": result.frames_used, "marks": len(fixed)}
    if as_json:
        print(json.dumps(summary))
    else:
        print(f"taught {result.name!r} from {result.frames_used} of {len(frames)} frames ({len(fixed)} marks) in "
              f"{result.seconds:.0f} s: {result.path} (classes: {', '.join(result.names)}); "
              f"try: deskarm --detector desk --follow-object {result.name!r}")
    return 0


def run(command: str, argv: list[str]) -> int:
    if command not in COMMANDS:
        raise ValueError(f"unknown command {command!r}; valid: {', '.join(COMMANDS)}")
    args = build_parser().parse_args(argv)
    return teach_folder(args.name, Path(args.images), args.boxes, steps=args.steps, minutes=args.minutes,
                        base=args.base, out=args.out, as_json=args.json)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == [TEACH]:
        argv = argv[1:]
    return run(TEACH, argv)


if __name__ == "__main__":
    sys.exit(main())
