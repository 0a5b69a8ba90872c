"""Teach the desk detector a new object from a few frames (no Qt; training needs torch).

A user shows the object to the camera, moving it, and marks it in a few frames (a box, or a tap
on it). ``carry_boxes`` lets a tracker (``core.detect.tracking.ObjectTracker``) carry each mark
through the frames that follow it (until the next mark), so ≤ 10 marks label ≤ 60 frames.
``teach`` then extends the current desk model on CPU with a branch of the new class's own
(``core.detect.learned.model.TaughtBranch``: two 3×3 layers on the frozen backbone's and head's
features, its own score and its own box, trained with the focal and GIoU losses of
``model.detection_loss``), exported as candidate rows of its own (``onnx_graph``): every old
output is computed by the same nodes as before, so the old classes' boxes and scores stay exactly
what they were, and a second class can be taught on top (``finetune.net_from_onnx`` reads the
branches back). It learns from domain-randomised copies of the frames (mirrored, zoomed and
shifted; ``core.detect.learned.randomise``: white balance, exposure, blur, noise, JPEG, lens
distortion, other backgrounds; a second copy pasted in, a side covered) and negatives (the frames
with the object painted out, textures, renders of the simulated desk holding only what the model
already knows), the cells it wrongly likes mined again and again as the run goes (hard negatives). The new
model is written to the user's config folder (``user_dir("config")/models``): ``desk_objects.onnx``
(what ``make_detector("desk")`` loads from then on) and ``<name>.onnx``; the model it replaced is
kept as ``desk_objects.previous.onnx``. A cancelled run (``cancelled()`` True) writes nothing.
"""
from __future__ import annotations

import json
import math
import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional, Sequence

import numpy as np

__all__ = ["TeachConfig", "TeachResult", "Mark", "carry_boxes", "box_from_tap", "lesson_background", "teach",
           "user_model_dir", "user_model_path", "valid_name", "read_marks", "MAX_FRAMES", "MAX_MARKS"]

MAX_FRAMES = 60
MAX_MARKS = 10
SILENT_HEAT = 0.05  # cells where the new object's heat target is below this are not it (hard negatives)
MINE_AT = (0.3, 0.55, 0.8)  # fractions of the run at which the hard negative cells are looked for again
HARD_PER_IMAGE = 3  # at most this many per image
HARD_MIN_SCORE = 0.05  # scored at least this
HARD_SHARE = 0.4  # share of each batch's windows around a hard negative cell (once found)
MINE_IMAGES = 256  # images looked at each time (the others keep the cells found before)
TURN = 0.3  # share of the copies with the object flipped upside down or turned half round in its box
COPY_PASTE = 0.4  # share of the copies with one more of the object pasted somewhere
OCCLUDE = 0.3  # share of the copies with a side of the object covered
DESK_NEGATIVES_FIRST_SEED = 500_000  # their scenes: training seeds (below the held-out ones)
NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9 _-]{0,31}$")


def user_model_dir() -> Path:
    from core.paths import user_dir

    return user_dir("config") / "models"


def user_model_path() -> Path:
    """The user's desk model (the shipped classes and every taught one), when they taught one."""
    return user_model_dir() / "desk_objects.onnx"


def valid_name(name: str) -> str:
    name = str(name).strip()
    if not NAME_RE.match(name):
        raise ValueError(f"object name {name!r}: 1–32 letters, digits, spaces, '-' or '_', starting with a "
                         f"letter or digit")
    return name


@dataclass(frozen=True)
class Mark:
    """The user's mark on frame ``frame``: a box (x0, y0, x1, y1) or a tap (x, y)."""

    frame: int
    box: Optional[tuple[float, float, float, float]] = None
    tap: Optional[tuple[float, float]] = None


def read_marks(path) -> list[Mark]:
    """Marks from a text file: one per line, ``FRAME x0 y0 x1 y1`` (a box) or ``FRAME x y`` (a tap);
    FRAME is the index in the sorted image list or the image's file name; '#' starts a comment."""
    marks = []
    for n, line in enumerate(Path(path).read_text().splitlines(), 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        parts = line.replace(",", " ").split()
        try:
            frame = parts[0]
            values = [float(v) for v in parts[1:]]
        except ValueError:
            raise ValueError(f"{path}:{n}: {line!r}: expected FRAME x0 y0 x1 y1 or FRAME x y") from None
        if len(values) == 4:
            marks.append(Mark(frame=frame, box=tuple(values)))  # type: ignore[arg-type]
        elif len(values) == 2:
            marks.append(Mark(frame=frame, tap=tuple(values)))  # type: ignore[arg-type]
        else:
            raise ValueError(f"{path}:{n}: {line!r}: expected FRAME x0 y0 x1 y1 or FRAME x y")
    return marks


MOTION_LEVEL = 25  # a pixel this far (0–255, any channel) from the lesson's background moved
GRABCUT_SQUARES = (0.12, 0.18, 0.26, 0.36, 0.5, 0.7)  # half-sides (of the image's short side) tried round a still tap
STILL_AGREE = 0.8  # a square's box is the object's when the next square's box overlaps it this much (IoU)
HAND_CUT_KEPT = 0.6  # the moving region is the object unless the colour cut keeps less of it than this (IoU)


def lesson_background(frames: Sequence[np.ndarray], most: int = 15) -> Optional[np.ndarray]:
    """What stays still in the lesson: the per-pixel median of (up to ``most`` of) its frames, or
    None for fewer than 3 frames or frames of different sizes."""
    if len(frames) < 3 or len({f.shape for f in frames}) != 1:
        return None
    step = max(1, math.ceil(len(frames) / most))
    return np.median(np.stack(list(frames)[::step]), axis=0).astype(np.uint8)


def _component_at(mask: np.ndarray, x: int, y: int, reach: float):
    """The connected component of ``mask`` at (x, y) — or the nearest one within ``reach`` px —
    as (its mask, its stats row x y w h area), or None."""
    import cv2

    n, lab, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    if n < 2:
        return None
    k = lab[y, x]
    if k == 0:
        ys, xs = np.nonzero(lab)
        d = np.hypot(xs - x, ys - y)
        j = int(np.argmin(d))
        if d[j] > reach:
            return None
        k = lab[ys[j], xs[j]]
    return lab == k, stats[k]


def _box(st, dx: int = 0, dy: int = 0) -> tuple[float, float, float, float]:
    x, y, w, h = (int(v) for v in st[:4])
    return (float(x + dx), float(y + dy), float(x + w + dx), float(y + h + dy))


def _iou(a, b) -> float:
    ix = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    iy = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - ix * iy
    return ix * iy / union if union > 0 else 0.0


def _moving_box(image: np.ndarray, x: int, y: int, background: np.ndarray):
    """The box of what moved under the tap (the image against the lesson's still background), cut
    by colour when a hand (or anything else moving with it) joins it; None when nothing moved there."""
    import cv2

    h, w = image.shape[:2]
    moving = (cv2.absdiff(image, background).max(axis=2) > MOTION_LEVEL).astype(np.uint8)
    moving = cv2.morphologyEx(moving, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
    moving = cv2.morphologyEx(moving, cv2.MORPH_CLOSE, np.ones((7, 7), np.uint8))
    found = _component_at(moving, x, y, 0.03 * min(w, h))
    if found is None or not 16 <= found[1][4] <= 0.5 * w * h:
        return None
    region, st = found
    box = _box(st)
    # the colour cut: the colours round the tap are the object's (sure), the rest of the moving
    # region may be (GrabCut decides), what stood still is not
    bx, by, bw, bh = (int(v) for v in st[:4])
    m = int(0.1 * max(bw, bh)) + 4
    x0, y0, x1, y1 = max(0, bx - m), max(0, by - m), min(w, bx + bw + m), min(h, by + bh + m)
    inside = region[y0:y1, x0:x1]
    cx, cy = x - x0, y - y0
    if not inside[cy, cx]:
        return box
    r = max(2, int(0.6 * cv2.distanceTransform(inside.astype(np.uint8), cv2.DIST_L2, 5)[cy, cx]))
    mask = np.where(inside, cv2.GC_PR_BGD, cv2.GC_BGD).astype(np.uint8)
    cv2.circle(mask, (cx, cy), r, int(cv2.GC_FGD), -1)
    try:
        cv2.grabCut(image[y0:y1, x0:x1], mask, None, np.zeros((1, 65)), np.zeros((1, 65)), 3, cv2.GC_INIT_WITH_MASK)
    except cv2.error:
        return box
    kept = ((mask == cv2.GC_FGD) | (mask == cv2.GC_PR_FGD)) & inside
    found = _component_at(cv2.morphologyEx(kept.astype(np.uint8), cv2.MORPH_CLOSE, np.ones((5, 5), np.uint8)),
                          cx, cy, 3)
    if found is None:
        return box
    core, st2 = found
    # the cut hugs the object's inside: give back the moving pixels near it (a thin rim, a pale border)
    d = int(max(3, 0.12 * max(st2[2], st2[3])))
    grown = cv2.dilate(core.astype(np.uint8), cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * d + 1, 2 * d + 1)))
    cut = _box(_component_at((grown > 0) & inside, cx, cy, 3)[1], x0, y0)
    return box if _iou(cut, box) >= HAND_CUT_KEPT else cut


def _still_box(image: np.ndarray, x: int, y: int):
    """GrabCut in squares growing round the tap: the foreground's component under the tap in the
    first square that holds it whole and the next square agrees with (else the largest square's);
    None when nothing stands out."""
    import cv2

    h, w = image.shape[:2]
    found_boxes = []  # (box, held whole)
    for half in GRABCUT_SQUARES:
        r = int(half * min(w, h))
        x0, y0, x1, y1 = max(1, x - r), max(1, y - r), min(w - 1, x + r), min(h - 1, y + r)
        if x1 - x0 < 8 or y1 - y0 < 8:
            continue
        m = max(8, r // 2)  # GrabCut sees the square and this much round it (the background it learns)
        cx0, cy0, cx1, cy1 = max(0, x0 - m), max(0, y0 - m), min(w, x1 + m), min(h, y1 + m)
        mask = np.zeros((cy1 - cy0, cx1 - cx0), np.uint8)
        try:
            cv2.grabCut(image[cy0:cy1, cx0:cx1], mask, (x0 - cx0, y0 - cy0, x1 - x0, y1 - y0), np.zeros((1, 65)),
                        np.zeros((1, 65)), 4, cv2.GC_INIT_WITH_RECT)
        except cv2.error:
            continue
        fg = ((mask == cv2.GC_FGD) | (mask == cv2.GC_PR_FGD)).astype(np.uint8)
        found = _component_at(cv2.morphologyEx(fg, cv2.MORPH_CLOSE, np.ones((5, 5), np.uint8)), x - cx0, y - cy0, r)
        if found is None:
            continue
        box = _box(found[1], cx0, cy0)
        whole = ((box[0] > x0 + 1 or x0 <= 1) and (box[1] > y0 + 1 or y0 <= 1) and (box[2] < x1 - 1 or x1 >= w - 1)
                 and (box[3] < y1 - 1 or y1 >= h - 1))
        if found_boxes and found_boxes[-1][1] and _iou(found_boxes[-1][0], box) >= STILL_AGREE:
            return found_boxes[-1][0]
        found_boxes.append((box, whole))
    return found_boxes[-1][0] if found_boxes else None


def _flood_box(image: np.ndarray, x: int, y: int):
    """The box of the region of similar colour flooded from the tap; None when it is tiny."""
    import cv2

    h, w = image.shape[:2]
    blurred = cv2.GaussianBlur(image, (5, 5), 0)
    mask = np.zeros((h + 2, w + 2), np.uint8)
    flags = 4 | cv2.FLOODFILL_MASK_ONLY | cv2.FLOODFILL_FIXED_RANGE | (255 << 8)
    cv2.floodFill(blurred, mask, (x, y), (0, 0, 0), (18, 18, 18), (18, 18, 18), flags)
    ys, xs = np.nonzero(mask[1:-1, 1:-1])
    if len(xs) < 16:
        return None
    return (float(xs.min()), float(ys.min()), float(xs.max() + 1), float(ys.max() + 1))


def box_from_tap(image: np.ndarray, tap: tuple[float, float], frames: Optional[Sequence[np.ndarray]] = None,
                 background: Optional[np.ndarray] = None) -> tuple[float, float, float, float]:
    """A box (x0, y0, x1, y1) around the object under a tap on ``image``.

    With the lesson's ``frames`` (or their still ``background``: ``lesson_background``), the object
    is what moved under the tap, cut by colour where a hand moving with it joins it. Without them,
    or when nothing moved there: GrabCut in squares growing round the tap (the foreground's part
    under it), else the region of similar colour flooded from it, else a small square."""
    import cv2

    if image.ndim == 2:  # GrabCut and the colour cut want three channels
        image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    h, w = image.shape[:2]
    x, y = int(np.clip(tap[0], 0, w - 1)), int(np.clip(tap[1], 0, h - 1))
    if background is None and frames is not None:
        background = lesson_background(frames)
    box = None
    if background is not None and background.shape == image.shape and image.dtype == np.uint8:
        box = _moving_box(image, x, y, background)
    if box is None:
        box = _still_box(image, x, y)
    if box is None:
        box = _flood_box(image, x, y)
    if box is None:
        r = 0.08 * min(w, h)
        box = (max(0.0, x - r), max(0.0, y - r), min(float(w), x + r), min(float(h), y + r))
    return box


def carry_boxes(frames: Sequence[np.ndarray], marks: Sequence[Mark], tracker: str = "CSRT") -> list[Optional[tuple]]:
    """Each frame's box of the object (x0, y0, x1, y1) or None: the marked frames' own (a tap's box
    is ``box_from_tap``'s, seeing what moved against the frames' still background), and the
    tracker's from each mark to the next (frames before the first mark are tracked backwards)."""
    from core.detect.tracking import ObjectTracker, available_trackers

    kind = tracker if tracker in available_trackers() else available_trackers()[0]
    boxes: list[Optional[tuple]] = [None] * len(frames)
    at = {}
    background = None
    for m in marks:
        i = int(m.frame)
        if not 0 <= i < len(frames):
            raise ValueError(f"mark on frame {i}: there are {len(frames)} frames")
        if m.box is None and background is None:
            background = lesson_background(frames)
        at[i] = m.box if m.box is not None else box_from_tap(frames[i], m.tap, background=background)
    if not at:
        raise ValueError("no marks: box or tap the object in at least one frame")
    order = sorted(at)

    def run(start: int, stop: int, step: int) -> None:
        b = at[start]
        t = ObjectTracker(kind, lost_after=3)
        t.start(frames[start], (b[0], b[1], b[2] - b[0], b[3] - b[1]), 0.0)
        for k, i in enumerate(range(start + step, stop, step), 1):
            state = t.update(frames[i], k / 10.0)
            if state.lost or not state.ok or state.box is None:
                break
            x, y, bw, bh = (float(v) for v in state.box)
            boxes[i] = (x, y, x + bw, y + bh)

    for j, i in enumerate(order):
        boxes[i] = tuple(float(v) for v in at[i])
        run(i, order[j + 1] if j + 1 < len(order) else len(frames), 1)
    if order[0] > 0:
        run(order[0], -1, -1)
    return boxes


@dataclass(frozen=True)
class TeachConfig:
    steps: int = 4000  # batches of training (on cached backbone features: cheap); the time limit may stop earlier
    max_seconds: float = 240.0  # wall-time budget of the whole run, preparation included (0: no limit)
    batch_size: int = 16
    learning_rate: float = 3e-3  # Adam peak, cosine down to 5 % of it
    copies: int = 480  # randomised images of the object made up front (flipped, zoomed, recoloured …)
    negative_share: float = 0.5  # and this share more without it
    desk_negatives: int = 96  # and renders of the simulated desk with only the classes the model knows
    branch_width: int = 32  # channels of the new class's own layers
    branch_kernels: tuple[int, ...] = (3, 3)  # their kernel sizes
    crop_cells: int = 16  # each step trains on windows of this many cells (or the object's size and 4 more)
    seed: int = 0
    threads: int = 1  # torch's and OpenCV's CPU threads (2 made a step 14× slower on a machine busy with other work)

    def __post_init__(self) -> None:
        if self.steps < 1 or self.batch_size < 1 or self.copies < 1:
            raise ValueError(f"steps = {self.steps}, batch_size = {self.batch_size} and copies = {self.copies} "
                             f"must be ≥ 1")
        if self.max_seconds < 0 or not 0 <= self.negative_share <= 4:
            raise ValueError(f"max_seconds = {self.max_seconds} must be ≥ 0 and negative_share = "
                             f"{self.negative_share} in 0 … 4")


@dataclass
class TeachResult:
    name: str
    path: Path
    names: list[str]
    seconds: float
    steps: int
    frames_used: int
    copies: list[Path] = field(default_factory=list)
    images: int = 0  # positives and negatives the branch trained on


def _letterbox_boxes(frames, boxes, input_wh):
    from core.detect.onnx_yolo import letterbox

    xs, bs = [], []
    for img, b in zip(frames, boxes):
        boxed, s, (left, top) = letterbox(img, input_wh)
        xs.append(boxed)
        bs.append(None if b is None else np.array([[b[0] * s + left, b[1] * s + top, b[2] * s + left,
                                                    b[3] * s + top]], np.float32))
    return xs, bs


def _zoom(rng: np.random.Generator, img: np.ndarray, box: np.ndarray, zoom=(0.7, 1.4)):
    """The image scaled by a random factor and shifted so the object lands anywhere (wholly) in it;
    (image, box). What the shift uncovers is the letterbox grey."""
    import cv2

    h, w = img.shape[:2]
    x0, y0, x1, y1 = (float(v) for v in box[0])
    bw, bh = max(x1 - x0, 1.0), max(y1 - y0, 1.0)
    s = float(min(rng.uniform(*zoom), 0.95 * w / bw, 0.95 * h / bh))
    nx0 = rng.uniform(0, max(w - s * bw, 0.0))
    ny0 = rng.uniform(0, max(h - s * bh, 0.0))
    tx, ty = nx0 - s * x0, ny0 - s * y0
    out = cv2.warpAffine(img, np.array([[s, 0, tx], [0, s, ty]], np.float32), (w, h), flags=cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=(114, 114, 114))
    return out, np.array([[nx0, ny0, nx0 + s * bw, ny0 + s * bh]], np.float32)


def _paint_out(rng: np.random.Generator, img: np.ndarray, box: np.ndarray) -> np.ndarray:
    """The image without the object: its box (and a margin) inpainted or covered by a texture."""
    import cv2

    from core.detect.learned.randomise import texture

    h, w = img.shape[:2]
    x0, y0, x1, y1 = (float(v) for v in box[0])
    m = 0.12 * max(x1 - x0, y1 - y0)
    x0, y0 = int(max(0, x0 - m)), int(max(0, y0 - m))
    x1, y1 = int(min(w, max(x1 + m, x0 + 1))), int(min(h, max(y1 + m, y0 + 1)))
    out = img.copy()
    if rng.random() < 0.6:
        mask = np.zeros((h, w), np.uint8)
        mask[y0:y1, x0:x1] = 255
        return cv2.inpaint(out, mask, 5, cv2.INPAINT_TELEA)
    out[y0:y1, x0:x1] = texture(rng, y1 - y0, x1 - x0)
    return out


def _paste_copy(rng: np.random.Generator, img: np.ndarray, boxes: np.ndarray, patch: np.ndarray):
    """``img`` with one more copy of the object (``patch``, its crop, rescaled 0.8–1.2) somewhere,
    feathered in; (image, boxes with the copy's)."""
    import cv2

    h, w = img.shape[:2]
    s = rng.uniform(0.8, 1.2)
    pw, ph = max(2, int(patch.shape[1] * s)), max(2, int(patch.shape[0] * s))
    if pw >= w or ph >= h:
        return img, boxes
    patch = cv2.resize(patch, (pw, ph), interpolation=cv2.INTER_LINEAR)
    for _ in range(8):  # a place that hides at most a third of each object already there
        x0, y0 = int(rng.integers(0, w - pw + 1)), int(rng.integers(0, h - ph + 1))
        ix = np.clip(np.minimum(boxes[:, 2], x0 + pw) - np.maximum(boxes[:, 0], x0), 0, None)
        iy = np.clip(np.minimum(boxes[:, 3], y0 + ph) - np.maximum(boxes[:, 1], y0), 0, None)
        area = np.maximum((boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1]), 1.0)
        if np.all(ix * iy / area <= 1 / 3):
            break
    else:
        return img, boxes
    mask = np.zeros((ph, pw), np.float32)
    mask[1:-1, 1:-1] = 1.0
    mask = cv2.GaussianBlur(mask, (0, 0), 0.8)[..., None]
    out = img.copy()
    region = out[y0:y0 + ph, x0:x0 + pw].astype(np.float32)
    out[y0:y0 + ph, x0:x0 + pw] = np.clip(patch * mask + region * (1 - mask), 0, 255).astype(np.uint8)
    return out, np.concatenate([boxes, np.array([[x0, y0, x0 + pw, y0 + ph]], np.float32)])


def _occlude(rng: np.random.Generator, img: np.ndarray, box: np.ndarray, source: np.ndarray) -> np.ndarray:
    """``img`` with a side of the object (15–45 % of its box) covered by a patch of ``source``
    taken anywhere (another thing on the desk, the desk, a hand …): partly hidden views."""
    h, w = img.shape[:2]
    x0, y0, x1, y1 = (int(v) for v in box)
    x0, y0, x1, y1 = max(0, x0), max(0, y0), min(w, x1), min(h, y1)
    bw, bh = x1 - x0, y1 - y0
    if bw < 4 or bh < 4:
        return img
    f = rng.uniform(0.15, 0.45)
    side = int(rng.integers(4))
    if side == 0:
        r = (x0, y0, x0 + int(bw * f), y1)
    elif side == 1:
        r = (x1 - int(bw * f), y0, x1, y1)
    elif side == 2:
        r = (x0, y0, x1, y0 + int(bh * f))
    else:
        r = (x0, y1 - int(bh * f), x1, y1)
    rw, rh = r[2] - r[0], r[3] - r[1]
    if rw < 1 or rh < 1:
        return img
    sx, sy = int(rng.integers(0, w - rw + 1)), int(rng.integers(0, h - rh + 1))
    out = img.copy()
    out[r[1]:r[3], r[0]:r[2]] = source[sy:sy + rh, sx:sx + rw]
    return out


def _pool(rng, xs, bs, usable, config: TeachConfig, w: int, h: int, cancelled, scene_negatives=None):
    """The images the new branch learns from: (images, boxes (K, 4) each), or None when cancelled.

    Positives: every marked or tracked frame as it is, then copies — mirrored half the time, zoomed
    and shifted, domain-randomised (``randomise``: white balance, exposure, blur, noise, JPEG, lens,
    other backgrounds), some with a second one pasted in or a side covered. Negatives: the frames
    with the object painted out (zoomed too), textures, and ``scene_negatives``' images (the app
    passes ``core.sim.dataset.desk_negatives``: renders of the desk with only the known classes)."""
    from core.detect.learned.randomise import camera_effects, randomise, texture

    images, boxes = [], []
    for k in range(config.copies):
        if cancelled is not None and k % 16 == 0 and cancelled():
            return None
        i = usable[k % len(usable)]
        img, b = xs[i], bs[i]
        if k >= len(usable):  # every frame once as it is, then randomised copies
            if rng.random() < 0.5:
                img = img[:, ::-1].copy()
                b = np.array([[w - b[0, 2], b[0, 1], w - b[0, 0], b[0, 3]]], np.float32)
            if rng.random() < 0.8:
                img, b = _zoom(rng, img, b)
            if rng.random() < TURN:  # the object itself turned over in its box (another side, another print)
                b0 = b[0]
                x0, y0 = int(max(0, round(float(b0[0])))), int(max(0, round(float(b0[1]))))
                x1, y1 = int(min(w, round(float(b0[2])))), int(min(h, round(float(b0[3]))))
                if x1 - x0 > 2 and y1 - y0 > 2:
                    img = img.copy()
                    part = img[y0:y1, x0:x1]
                    img[y0:y1, x0:x1] = part[::-1].copy() if rng.random() < 0.5 else part[::-1, ::-1].copy()
            if rng.random() < COPY_PASTE:  # another one of it (from any frame), anywhere
                j = usable[int(rng.integers(len(usable)))]
                x0, y0, x1, y1 = (int(round(float(v))) for v in bs[j][0])
                patch = xs[j][max(0, y0):max(y1, y0 + 2), max(0, x0):max(x1, x0 + 2)]
                if rng.random() < 0.5:
                    patch = patch[:, ::-1]
                img, b = _paste_copy(rng, img, b, patch)
            if rng.random() < OCCLUDE:  # partly hidden by something
                source = xs[usable[int(rng.integers(len(usable)))]]
                img = _occlude(rng, img, b[int(rng.integers(len(b)))], source)
            img, b, _, _ = randomise(rng, img, b, np.zeros(len(b), np.int64), np.zeros(len(b), bool),
                                     distractors=False)
            if len(b) == 0:  # the background paste dropped it
                continue
        images.append(img)
        boxes.append(np.asarray(b, np.float32).reshape(-1, 4))
    for k in range(int(config.copies * config.negative_share)):
        if cancelled is not None and k % 16 == 0 and cancelled():
            return None
        if k % 4 == 3:
            img = texture(rng, h, w)
        else:
            j = usable[int(rng.integers(len(usable)))]
            img, b = xs[j], bs[j]
            if rng.random() < 0.5:
                img, b = _zoom(rng, img, b)
            img = _paint_out(rng, img, b)
            if rng.random() < 0.5:
                img = img[:, ::-1].copy()
        images.append(camera_effects(rng, img))
        boxes.append(np.zeros((0, 4), np.float32))
    if config.desk_negatives and scene_negatives is not None:
        for img in scene_negatives(config.desk_negatives, (w, h), DESK_NEGATIVES_FIRST_SEED + 1000 * config.seed):
            if rng.random() < 0.5:
                img = img[:, ::-1].copy()
            images.append(camera_effects(rng, img, 0.5))
            boxes.append(np.zeros((0, 4), np.float32))
    return images, boxes


def _features(backbone, images, cancelled, say, t_start):
    """The features (N, C, H, W) float16 the ``backbone`` (an OpenCV DNN net) computes for each
    image, or None when cancelled."""
    import cv2
    import torch

    n = len(images)
    feats = None
    for a in range(n):
        if cancelled is not None and a % 16 == 0 and cancelled():
            return None
        backbone.setInput(cv2.dnn.blobFromImage(images[a], 1 / 255.0, swapRB=True))
        out = torch.from_numpy(backbone.forward())
        if feats is None:
            feats = torch.empty((n, *out.shape[1:]), dtype=torch.float16)
        feats[a] = out[0]
        if a % 16 == 15 or a == n - 1:
            done = 0.25 * (a + 1) / n
            el = time.perf_counter() - t_start
            say(done, el / max(done, 1e-6) * (1 - done), f"looking at {a + 1}/{n} images")
    return feats


def teach(name: str, frames: Sequence[np.ndarray], marks: Sequence[Mark], *, base_model=None,
          out_dir: Optional[Path] = None, config: TeachConfig = TeachConfig(),
          progress: Optional[Callable[[float, float, str], None]] = None,
          cancelled: Optional[Callable[[], bool]] = None, boxes: Optional[Sequence] = None,
          scene_negatives: Optional[Callable[[int, tuple[int, int], int], list]] = None) -> Optional[TeachResult]:
    """Teach class ``name`` from ``frames`` (BGR, ≤ MAX_FRAMES) and ``marks`` (≤ MAX_MARKS), or
    from per-frame ``boxes`` already known. ``base_model``: the .onnx to extend (default the user's
    model, else the shipped one). ``scene_negatives(count, input_wh, first_seed)``: images of
    scenes without the object (the app passes ``core.sim.dataset.desk_negatives``; core.detect
    never imports the simulated desk). Returns None when cancelled (nothing written).

    The new class gets a branch of its own (``core.detect.learned.model.TaughtBranch``: two 3×3
    layers on the frozen backbone's and head's features, its own score and its own box), exported
    as candidate rows of its own; every old output is computed as before. The features of the
    randomised copies are computed once; the steps then train only the branch (on windows of the
    feature map around the object and anywhere in the negatives), for ``config.steps`` or until
    ``config.max_seconds`` of wall time have passed since the start, whichever is first."""
    import torch

    from core.detect.learned import finetune as ft
    from core.detect.learned.model import STRIDE, TaughtBranch, detection_loss, make_targets, optimise_step
    from core.detect.learned.shipped import shipped_model_path

    name = valid_name(name)
    say = progress or (lambda f, left, text: None)
    t_start = time.perf_counter()
    if len(frames) == 0:
        raise ValueError("no frames")
    if len(frames) > MAX_FRAMES:
        raise ValueError(f"{len(frames)} frames: teach from at most {MAX_FRAMES}")
    if boxes is None:
        if len(marks) > MAX_MARKS:
            raise ValueError(f"{len(marks)} marks: at most {MAX_MARKS} (the tracker carries the box between them)")
        say(0.0, float("nan"), "following the object through the frames")
        boxes = carry_boxes(frames, marks)
    out_dir = Path(out_dir) if out_dir is not None else user_model_dir()
    if base_model is None:
        user = out_dir / "desk_objects.onnx"
        base_model = user if user.is_file() else shipped_model_path()
    net, names, meta = ft.net_from_onnx(base_model)
    if name in names:
        raise ValueError(f"the model already knows {name!r}: teach it under another name (or delete "
                         f"{out_dir / 'desk_objects.onnx'} to start again from the shipped model)")
    imgsz = meta.get("imgsz", "[240, 320]").strip("[]").split(",")
    input_wh = (int(imgsz[1]), int(imgsz[0]))
    w, h = input_wh
    xs, bs = _letterbox_boxes(frames, boxes, input_wh)
    usable = [i for i, b in enumerate(bs) if b is not None]
    if not usable:
        raise ValueError("the object was lost in every frame: mark it in more frames")
    torch.set_num_threads(int(config.threads))
    torch.manual_seed(config.seed)
    rng = np.random.default_rng(config.seed)
    say(0.0, float("nan"), "making randomised copies of the frames")
    pool = _pool(rng, xs, bs, usable, config, w, h, cancelled, scene_negatives)
    if pool is None:
        return None
    images, targets_boxes = pool
    n = len(images)
    # the frozen network's features of every image, once, by OpenCV's DNN (several times faster than
    # torch here; the exported model computes them the same way); half precision: the pool fits in memory
    import cv2

    from core.detect.learned.model import net_layers
    from core.detect.learned.onnx_graph import build_desk_onnx

    layers, arch = net_layers(net, names)
    graph = build_desk_onnx(layers, arch, names, input_wh, features_only=True)
    backbone = cv2.dnn.readNetFromONNX(np.frombuffer(graph.SerializeToString(), np.uint8))
    cv_threads = cv2.getNumThreads()
    cv2.setNumThreads(int(config.threads))
    try:
        feats = _features(backbone, images, cancelled, say, t_start)
    finally:
        cv2.setNumThreads(cv_threads)
    if feats is None:
        return None
    del images
    tg = [make_targets(b, np.zeros(len(b), np.int64), np.zeros(len(b), bool), (h, w), 1) for b in targets_boxes]
    tall = {k: torch.from_numpy(np.stack([t[k] for t in tg])) for k in tg[0]}
    gh, gw = feats.shape[2:]
    sizes = np.array([[b[0, 2] - b[0, 0], b[0, 3] - b[0, 1]] for b in targets_boxes if len(b)], np.float64)
    crop_h = int(min(gh, max(config.crop_cells, np.ceil(sizes[:, 1].max() / STRIDE) + 4)))
    crop_w = int(min(gw, max(config.crop_cells, np.ceil(sizes[:, 0].max() / STRIDE) + 4)))
    centre = [None if len(b) == 0 else (int((b[0, 1] + b[0, 3]) / 2 // STRIDE), int((b[0, 0] + b[0, 2]) / 2 // STRIDE))
              for b in targets_boxes]
    branch = TaughtBranch(net.branch_input, int(config.branch_width), config.branch_kernels)
    with torch.no_grad():  # its boxes start at the taught object's typical size
        half = np.median(sizes, axis=0) / 2 / STRIDE
        branch.box.bias.copy_(torch.tensor(np.log([half[0], half[1], half[0], half[1]]), dtype=torch.float32))
    ema = TaughtBranch(net.branch_input, int(config.branch_width), config.branch_kernels)
    ema.load_state_dict(branch.state_dict())
    opt = torch.optim.Adam(branch.parameters(), lr=config.learning_rate)
    t0 = time.perf_counter()
    # the wall-time budget counts from the start: what the preparation took, training does not get
    budget = max(config.max_seconds - (t0 - t_start), 1.0) if config.max_seconds else 0.0
    step = 0
    loss = torch.zeros(())

    hard: list[tuple[int, int, int]] = []  # (image, row, column) of cells the branch wrongly liked
    hard_p_raw: list[float] = []  # their scores when found
    hard_p = np.zeros(0)

    def around(cell: tuple[int, int]) -> tuple[int, int]:
        r0 = int(np.clip(cell[0] - rng.integers(2, max(crop_h - 2, 3)), 0, gh - crop_h))
        c0 = int(np.clip(cell[1] - rng.integers(2, max(crop_w - 2, 3)), 0, gw - crop_w))
        return r0, c0

    def pick() -> tuple[int, tuple[int, int]]:
        """An image and a window's top-left cell: around the object (not always in the middle), around
        a hard negative cell (once mined), or anywhere in a negative."""
        if len(hard) and rng.random() < HARD_SHARE:
            i, r, c = hard[int(rng.choice(len(hard), p=hard_p))]
            return i, around((r, c))
        i = int(rng.integers(n))
        if centre[i] is None:
            return i, (int(rng.integers(gh - crop_h + 1)), int(rng.integers(gw - crop_w + 1)))
        return i, around(centre[i])

    def mine() -> None:
        """The cells away from the object where the branch's score is highest now (a few per image)."""
        nonlocal hard, hard_p
        found = []
        # a random share of the images each time (the whole pool costs as much as many steps)
        look = torch.from_numpy(rng.permutation(n)[:MINE_IMAGES])
        with torch.no_grad():
            for a in range(0, len(look), 32):
                idx = look[a:a + 32]
                logit, _ = ema(feats[idx].float())
                p = torch.sigmoid(logit[:, 0])
                p = torch.where((tall["heat"][idx, 0] < SILENT_HEAT) & ~tall["ignore"][idx], p, torch.zeros_like(p))
                top = torch.topk(p.reshape(len(p), -1), HARD_PER_IMAGE, dim=1)
                for k in range(len(p)):
                    for v, flat in zip(top.values[k].tolist(), top.indices[k].tolist()):
                        if v >= HARD_MIN_SCORE:
                            found.append((v, int(idx[k]), flat // gw, flat % gw))
        seen = set(look.tolist())
        found += [(v, i, r, c) for v, (i, r, c) in zip(hard_p_raw, hard) if i not in seen]
        hard_p_raw[:] = [v for v, *_ in found]
        hard = [(i, r, c) for _, i, r, c in found]
        hard_p = np.array([v for v, *_ in found], np.float64)
        hard_p = hard_p / hard_p.sum() if len(hard_p) else hard_p

    mined = 0

    for step in range(config.steps):
        if cancelled is not None and cancelled():
            return None
        frac = step / config.steps
        if budget:
            frac = max(frac, (time.perf_counter() - t0) / budget)
        if frac >= 1.0:
            break
        lr = config.learning_rate * (0.05 + 0.95 * 0.5 * (1 + math.cos(math.pi * frac)))
        if step < 50:
            lr *= (step + 1) / 50
        for g in opt.param_groups:
            g["lr"] = lr
        if mined < len(MINE_AT) and frac >= MINE_AT[mined]:
            mine()
            mined += 1
            say(0.25 + 0.75 * frac, float("nan"), f"{len(hard)} hard negative cells")
        picks = [pick() for _ in range(min(config.batch_size, n))]
        idx = [i for i, _ in picks]
        corners = [c for _, c in picks]
        x = torch.stack([feats[i, :, r:r + crop_h, c:c + crop_w] for i, (r, c) in zip(idx, corners)]).float()
        tb = {k: torch.stack([v[i][..., r:r + crop_h, c:c + crop_w] for i, (r, c) in zip(idx, corners)])
              for k, v in tall.items()}
        # the window's boxes are in its own pixels: its cells sit where the grid puts them
        shift = torch.tensor([[c * STRIDE, r * STRIDE, c * STRIDE, r * STRIDE] for r, c in corners],
                             dtype=torch.float32)
        tb["box"] = tb["box"] - shift[:, :, None, None]
        logit, box_raw = branch(x)
        loss, parts = detection_loss(logit, box_raw, tb)
        optimise_step(opt, loss, branch.parameters(), zip(ema.parameters(), branch.parameters()), step, 0.995)
        done = (step + 1) / config.steps
        if budget:
            done = max(done, (time.perf_counter() - t0) / budget)
        total = 0.25 + 0.75 * min(done, 1.0)
        say(total, (time.perf_counter() - t_start) / total * (1 - total),
            f"step {step + 1}/{config.steps}: loss {float(loss.detach()):.3f} (focal {parts['focal']:.3f}, "
            f"box {parts['box']:.3f})")
    steps_done = step + 1 if step + 1 == config.steps else step
    if cancelled is not None and cancelled():
        return None
    net.add_taught(ema.eval())
    names = names + [name]
    for p in net.parameters():
        p.requires_grad_(False)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "desk_objects.onnx"
    previous = out_dir / "desk_objects.previous.onnx"
    taught_before = json.loads(meta.get("deskarm_taught_all", "[]")) if meta.get("deskarm_taught_all") else []
    this = {"name": name, "frames": len(frames), "frames_used": len(usable), "marks": len(marks),
            "steps": steps_done, "images": n, "seconds": round(time.perf_counter() - t_start, 1),
            "base": str(base_model)}
    meta_out = {"deskarm_taught": this, "deskarm_taught_all": taught_before + [this],
                "description": f"deskarm desk-object detector with taught classes ({', '.join(names)})"}
    for key in ("deskarm_training", "deskarm_eval", "deskarm_eval_hand"):
        if key in meta:
            meta_out[key] = meta[key]
    tmp = out_dir / f".{name}.onnx.tmp"
    ft.export(net, tmp, names, input_wh, metadata=meta_out)
    if path.is_file():
        previous.write_bytes(path.read_bytes())
    own = out_dir / f"{name}.onnx"
    own.write_bytes(tmp.read_bytes())
    tmp.replace(path)
    say(1.0, 0.0, f"taught {name!r}: {path}")
    return TeachResult(name=name, path=path, names=names, seconds=time.perf_counter() - t_start, steps=steps_done,
                       frames_used=len(usable), copies=[own], images=n)
