"""Teach the desk detector a new object from a few frames (no Qt; training needs torch).

A user shows the object to the camera, moving it, and marks it in a few frames (a box, or a tap
on it). ``carry_boxes`` lets a tracker (``core.detect.tracking.ObjectTracker``) carry each mark
through the frames that follow it (until the next mark), so ≤ 10 marks label ≤ 60 frames.
``teach`` then extends the current desk model on CPU: one more class output fed by new head
channels of its own (``widen_for_new_class``), trained — the backbone and every old weight frozen,
so the old classes' scores and boxes stay exactly what they were — on domain-randomised copies of
the frames (``core.detect.learned.randomise``: white balance, exposure, blur, noise, JPEG, lens
distortion, other backgrounds) and on negatives (textures, and the frames with the object painted
out). The boxes stay the old model's unless ``TeachConfig.learn_boxes`` (then the old classes'
boxes move a little: on the simulated desk their mAP fell from 0.97 to 0.81). The new
model is written to the user's config folder (``user_dir("config")/models``): ``desk_objects.onnx``
(what ``make_detector("desk")`` loads from then on) and ``<name>.onnx``; the model it replaced is
kept as ``desk_objects.previous.onnx``. A cancelled run (``cancelled()`` True) writes nothing.
"""
from __future__ import annotations

import math
import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional, Sequence

import numpy as np

__all__ = ["TeachConfig", "TeachResult", "Mark", "carry_boxes", "box_from_tap", "teach", "user_model_dir",
           "user_model_path", "valid_name", "read_marks", "MAX_FRAMES", "MAX_MARKS"]

MAX_FRAMES = 60
MAX_MARKS = 10
SILENT_HEAT = 0.05  # cells where the new object's heat target is below this: its channels should be silent
BOX_KEEP_WEIGHT = 5.0  # how hard the old boxes are kept there
SILENCE_WEIGHT = 0.5  # and the new channels kept silent
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


def box_from_tap(image: np.ndarray, tap: tuple[float, float]) -> tuple[float, float, float, float]:
    """A box around the object under a tap: the region of similar colour flooded from the tap
    (GrabCut-refined when it is large), as x0, y0, x1, y1."""
    import cv2

    h, w = image.shape[:2]
    x, y = int(np.clip(tap[0], 0, w - 1)), int(np.clip(tap[1], 0, h - 1))
    blurred = cv2.GaussianBlur(image, (5, 5), 0)
    mask = np.zeros((h + 2, w + 2), np.uint8)
    flags = 4 | cv2.FLOODFILL_MASK_ONLY | cv2.FLOODFILL_FIXED_RANGE | (255 << 8)
    cv2.floodFill(blurred, mask, (x, y), (0, 0, 0), (18, 18, 18), (18, 18, 18), flags)
    ys, xs = np.nonzero(mask[1:-1, 1:-1])
    if len(xs) < 16:
        r = 0.08 * min(w, h)
        return (max(0.0, x - r), max(0.0, y - r), min(float(w), x + r), min(float(h), y + r))
    return (float(xs.min()), float(ys.min()), float(xs.max() + 1), float(ys.max() + 1))


def carry_boxes(frames: Sequence[np.ndarray], marks: Sequence[Mark], tracker: str = "CSRT") -> list[Optional[tuple]]:
    """Each frame's box of the object (x0, y0, x1, y1) or None: the marked frames' own, and the
    tracker's from each mark to the next (frames before the first mark are tracked backwards)."""
    from core.detect.tracking import ObjectTracker, available_trackers

    kind = tracker if tracker in available_trackers() else available_trackers()[0]
    boxes: list[Optional[tuple]] = [None] * len(frames)
    at = {}
    for m in marks:
        i = int(m.frame)
        if not 0 <= i < len(frames):
            raise ValueError(f"mark on frame {i}: there are {len(frames)} frames")
        at[i] = m.box if m.box is not None else box_from_tap(frames[i], m.tap)
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
    steps: int = 2000  # batches of fine-tuning (on cached backbone features: cheap)
    max_seconds: float = 240.0  # and at most this long
    batch_size: int = 16
    learning_rate: float = 2e-3
    copies: int = 320  # randomised images of the object made up front (the frames, flipped, recoloured …)
    negative_share: float = 0.4  # and this share more without it
    new_channels: int = 32  # head channels added for the new class (the old ones are kept as they are)
    learn_boxes: bool = False  # also learn the new object's boxes (through the new channels; the old boxes move a little)
    seed: int = 0
    threads: int = 1


@dataclass
class TeachResult:
    name: str
    path: Path
    names: list[str]
    seconds: float
    steps: int
    frames_used: int
    copies: list[Path] = field(default_factory=list)


def _letterbox_boxes(frames, boxes, input_wh):
    from core.detect.onnx_yolo import letterbox

    xs, bs = [], []
    for img, b in zip(frames, boxes):
        boxed, s, (left, top) = letterbox(img, input_wh)
        xs.append(boxed)
        bs.append(None if b is None else np.array([[b[0] * s + left, b[1] * s + top, b[2] * s + left,
                                                    b[3] * s + top]], np.float32))
    return xs, bs


def widen_for_new_class(net, extra: int):
    """``net`` with one more class output fed by ``extra`` new head channels, and the gradient masks
    that keep every old output exactly as it was: old head channels see only old inputs, the old
    classes and the box output see only old channels (new ones start at zero, and only the new
    class row and the box output's new columns learn on top of them)."""
    import torch
    import torch.nn as nn

    from core.detect.learned.model import BN_EPS, ConvBnRelu

    hw = net.head_width
    cin = net.head[0][0].in_channels
    new_w = hw + extra
    h0, h1 = ConvBnRelu(cin, new_w, 1), ConvBnRelu(new_w, new_w, 3)
    masks = {}
    with torch.no_grad():
        for new, old in ((h0, net.head[0]), (h1, net.head[1])):
            new[1].weight.fill_(1.0)
            new[1].bias.zero_()
            new[1].running_mean.zero_()
            new[1].running_var.fill_(1.0 - BN_EPS)
            new[1].bias[:hw] = old[1].bias
            new[1].weight[:hw] = old[1].weight
            new[1].running_mean[:hw] = old[1].running_mean
            new[1].running_var[:hw] = old[1].running_var
        nn.init.kaiming_normal_(h0[0].weight, nonlinearity="relu")
        h0[0].weight[:hw] = net.head[0][0].weight
        nn.init.kaiming_normal_(h1[0].weight, nonlinearity="relu")
        h1[0].weight[:hw] = 0.0
        h1[0].weight[:hw, :hw] = net.head[1][0].weight
        m0 = torch.zeros_like(h0[0].weight)
        m0[hw:] = 1.0
        m1 = torch.zeros_like(h1[0].weight)
        m1[hw:] = 1.0
        bn_mask = torch.zeros(new_w)
        bn_mask[hw:] = 1.0
        old_cls = net.classes
        cls = nn.Conv2d(new_w, old_cls.out_channels + 1, 1)
        cls.weight.zero_()
        cls.weight[:old_cls.out_channels, :hw] = old_cls.weight
        cls.bias[:old_cls.out_channels] = old_cls.bias
        nn.init.normal_(cls.weight[old_cls.out_channels:], std=0.01)
        cls.bias[old_cls.out_channels:] = -math.log((1 - 0.01) / 0.01)
        mc = torch.zeros_like(cls.weight)
        mc[old_cls.out_channels:] = 1.0
        mcb = torch.zeros_like(cls.bias)
        mcb[old_cls.out_channels:] = 1.0
        box = nn.Conv2d(new_w, 4, 1)
        box.weight.zero_()
        box.weight[:, :hw] = net.box.weight
        box.bias.copy_(net.box.bias)
        mb = torch.zeros_like(box.weight)
        mb[:, hw:] = 1.0
    net.head = nn.Sequential(h0, h1)
    net.classes, net.box = cls, box
    net.head_width = new_w
    net.num_classes = cls.out_channels
    masks = {h0[0].weight: m0, h1[0].weight: m1, h0[1].weight: bn_mask, h0[1].bias: bn_mask,
             h1[1].weight: bn_mask, h1[1].bias: bn_mask, cls.weight: mc, cls.bias: mcb, box.weight: mb}
    return net, masks


def teach(name: str, frames: Sequence[np.ndarray], marks: Sequence[Mark], *, base_model=None,
          out_dir: Optional[Path] = None, config: TeachConfig = TeachConfig(),
          progress: Optional[Callable[[float, float, str], None]] = None,
          cancelled: Optional[Callable[[], bool]] = None, boxes: Optional[Sequence] = None) -> Optional[TeachResult]:
    """Teach class ``name`` from ``frames`` (BGR, ≤ MAX_FRAMES) and ``marks`` (≤ MAX_MARKS), or
    from per-frame ``boxes`` already known. ``base_model``: the .onnx to extend (default the user's
    model, else the shipped one). Returns None when cancelled (nothing written).

    The old classes' outputs stay exactly what they were: the new class gets head channels of its
    own (``widen_for_new_class``). The backbone is frozen, so its features of the randomised
    copies are computed once; the steps then train only the new channels (a few ms each)."""
    import torch
    import torch.nn.functional as F

    from core.detect.learned import finetune as ft
    from core.detect.learned.model import detection_loss, make_targets
    from core.detect.learned.randomise import camera_effects, randomise, texture
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
    # the pool: randomised copies of the frames (half of them mirrored), and negatives — textures
    # and the frames with the object painted out
    images, targets_boxes = [], []
    for k in range(config.copies):
        i = usable[k % len(usable)]
        img, b = xs[i], bs[i]
        if k % 2:
            img = img[:, ::-1].copy()
            b = np.array([[w - b[0, 2], b[0, 1], w - b[0, 0], b[0, 3]]], np.float32)
        if k >= len(usable):  # every frame once as it is, then randomised copies
            img, b, _, _ = randomise(rng, img, b, np.zeros(1, np.int64), np.zeros(1, bool), distractors=False)
        images.append(img)
        targets_boxes.append(b)
    for k in range(int(config.copies * config.negative_share)):
        if k % 2:
            j = usable[int(rng.integers(len(usable)))]
            img = xs[j].copy()
            x0, y0, x1, y1 = (int(v) for v in bs[j][0])
            x0, y0 = max(0, x0), max(0, y0)
            x1, y1 = min(w, max(x1, x0 + 1)), min(h, max(y1, y0 + 1))
            img[y0:y1, x0:x1] = texture(rng, y1 - y0, x1 - x0)
        else:
            img = texture(rng, h, w)
        images.append(camera_effects(rng, img))
        targets_boxes.append(np.zeros((0, 4), np.float32))
    n = len(images)
    feats, olds0, olds, t_boxes = [], [], [], []
    net.eval()
    with torch.no_grad():
        for a in range(0, n, 16):
            if cancelled is not None and cancelled():
                return None
            x = torch.from_numpy(np.ascontiguousarray(np.stack(images[a:a + 16])[..., ::-1].transpose(0, 3, 1, 2)))
            x = x.float().div_(255.0)
            f8 = net.stride8(x)
            cat = torch.cat([f8, F.interpolate(net.stride16(f8), scale_factor=2.0, mode="nearest")], dim=1)
            old0 = net.head[0](cat)
            old = net.head[1](old0)
            feats.append(cat)
            olds0.append(old0)
            olds.append(old)
            t_boxes.append(net.box(old))
            done = 0.25 * min(a + 16, n) / n
            el = time.perf_counter() - t_start
            say(done, el / max(done, 1e-6) * (1 - done), f"looking at {min(a + 16, n)}/{n} images")
    feats, olds0, olds, t_boxes = torch.cat(feats), torch.cat(olds0), torch.cat(olds), torch.cat(t_boxes)
    tg = [make_targets(b, np.zeros(len(b), np.int64), np.zeros(len(b), bool), (h, w), 1) for b in targets_boxes]
    tall = {k: torch.from_numpy(np.stack([t[k] for t in tg])) for k in tg[0]}
    # the new class's own channels: a 1×1 on the backbone's features, a 3×3 over the old head's
    # first layer and them, and its score over the old head's output and them; the old head,
    # classes and boxes are not touched
    k_new, hw = int(config.new_channels), olds.shape[1]
    conv_a = torch.nn.Conv2d(feats.shape[1], k_new, 1)
    conv_b = torch.nn.Conv2d(hw + k_new, k_new, 3, padding=1)
    score = torch.nn.Conv2d(hw + k_new, 1, 1)
    # the box output learns the new object's boxes through the new channels only (no bias): where
    # those are silent — everywhere but on the new object, which a penalty teaches them — every box
    # is the old model's
    box_delta = torch.nn.Conv2d(k_new, 4, 1, bias=False)
    with torch.no_grad():
        torch.nn.init.normal_(score.weight, std=0.01)
        score.bias.fill_(-math.log((1 - 0.01) / 0.01))
        box_delta.weight.zero_()
    params = [*conv_a.parameters(), *conv_b.parameters(), *score.parameters(), *box_delta.parameters()]
    opt = torch.optim.Adam(params, lr=config.learning_rate)
    t0 = time.perf_counter()
    prep = t0 - t_start
    budget = max(config.max_seconds - prep, 1.0) if config.max_seconds else 0.0
    step = 0
    for step in range(config.steps):
        if cancelled is not None and cancelled():
            return None
        elapsed = time.perf_counter() - t0
        frac = step / config.steps
        if budget:
            frac = max(frac, elapsed / budget)
        if frac >= 1.0:
            break
        for g in opt.param_groups:
            g["lr"] = config.learning_rate * (0.05 + 0.95 * 0.5 * (1 + math.cos(math.pi * frac)))
        idx = torch.from_numpy(rng.choice(n, size=min(config.batch_size, n), replace=False))
        old = olds[idx]
        a_out = torch.relu(conv_a(feats[idx]))
        b_out = torch.relu(conv_b(torch.cat([olds0[idx], a_out], dim=1)))
        logits = score(torch.cat([old, b_out], dim=1))
        tb = {k: v[idx] for k, v in tall.items()}
        if config.learn_boxes:
            delta = box_delta(b_out)
            loss, parts = detection_loss(logits, t_boxes[idx] + delta, tb)
            away = (tb["heat"][:, :1] < SILENT_HEAT).to(b_out.dtype)  # cells off the new object
            loss = loss + BOX_KEEP_WEIGHT * (delta.abs() * away).mean() + SILENCE_WEIGHT * (b_out * away).mean()
        else:  # the boxes are the old model's: the score alone learns
            tb["box_weight"] = torch.zeros_like(tb["box_weight"])
            loss, parts = detection_loss(logits, t_boxes[idx], tb)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        done = (step + 1) / config.steps
        elapsed = time.perf_counter() - t0
        if budget:
            done = max(done, elapsed / budget)
        done = min(done, 1.0)
        total = 0.25 + 0.75 * done
        say(total, (time.perf_counter() - t_start) / total * (1 - total),
            f"step {step + 1}/{config.steps}: loss {float(loss.detach()):.3f}")
    index = len(names)
    net, _ = widen_for_new_class(net, k_new)
    names = names + [name]
    with torch.no_grad():  # the trained channels into the widened network
        h0, h1 = net.head[0], net.head[1]
        h0[0].weight[hw:] = conv_a.weight
        h0[1].bias[hw:] = conv_a.bias
        h1[0].weight[hw:] = conv_b.weight
        h1[1].bias[hw:] = conv_b.bias
        net.classes.weight[index] = score.weight[0]
        net.classes.bias[index] = score.bias[0]
        if config.learn_boxes:
            net.box.weight[:, hw:] = box_delta.weight
    if cancelled is not None and cancelled():
        return None
    net.eval()
    for p in net.parameters():
        p.requires_grad_(False)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "desk_objects.onnx"
    previous = out_dir / "desk_objects.previous.onnx"
    meta_out = {"deskarm_taught": {"name": name, "frames": len(frames), "frames_used": len(usable),
                                   "marks": len(marks), "steps": step + 1, "base": str(base_model)},
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
    return TeachResult(name=name, path=path, names=names, seconds=time.perf_counter() - t_start, steps=step + 1,
                       frames_used=len(usable), copies=[own])
