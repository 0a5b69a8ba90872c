"""The desk detector's network, its loss, its training loop and its ONNX export. Needs torch.

torch is the optional ``train`` extra (``pip install -e '.[train]'``): only ``deskarm
train-detector`` and the torch tests import this module. The exported ``.onnx`` runs without
torch through ``core.detect.onnx_yolo.OnnxYoloDetector`` (OpenCV's DNN module).

The network (``DeskNet``) is a small anchor-free, single-scale detector in the CenterNet / FCOS
family, trained from scratch:

* a plain conv-BN-ReLU backbone down to stride 8, a stride-16 context branch upsampled and
  concatenated back (so a 100 px plush is seen whole while 9 px buttons keep their cell);
* per stride-8 cell: C class logits (a Gaussian "centre-ness" heat map per class, focal loss as
  in CenterNet) and 4 distances from the cell centre to the box's left, top, right and bottom
  edges (``stride · exp(raw)``, GIoU loss on the cells near each object's centre).

The exported graph decodes its own boxes and writes the YOLOv8 layout ``(1, 4 + C, H·W)``: rows
cx, cy, w, h in input pixels, then the C class scores (sigmoids). Batch norm is folded into the
convolutions, and the graph holds only Conv, Relu, Resize (nearest), Concat, Sigmoid, Clip, Exp,
Add and Reshape, which OpenCV's DNN module runs (``core.detect.learned.onnx_graph`` builds it; a class
taught later adds a branch of its own there and H·W more rows). The class names go into the model's ``names``
metadata the way ultralytics writes them, so the detector labels boxes without a classes file.
"""
from __future__ import annotations

import math
import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Callable, Optional, Sequence

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F

from core.detect.learned.onnx_graph import MAX_LOG_DISTANCE, STRIDE, build_desk_onnx

__all__ = ["DeskNet", "TaughtBranch", "TrainConfig", "TrainResult", "STRIDE", "make_targets", "detection_loss",
           "decode", "train_detector", "export_onnx", "fold_batch_norm", "net_layers", "optimise_step"]

HEAT_SIGMA_MIN_CELLS = 0.6  # a centre's Gaussian is at least this wide (in cells) ...
HEAT_SIGMA_PER_SIZE = 0.15  # ... and this fraction of the box's size (in cells) for larger boxes
REGRESS_MIN_HEAT = 0.2  # cells whose heat for an object reaches this learn its box
BOX_LOSS_WEIGHT = 2.0  # GIoU loss against the focal loss
FOCAL_ALPHA, FOCAL_BETA = 2.0, 4.0  # CenterNet's focal loss exponents
BN_EPS = 1e-5
PAD_VALUE = 114  # letterbox grey, as OnnxYoloDetector pads


# --------------------------------------------------------------------------------------- the network
class ConvBnRelu(nn.Sequential):
    """3×3 (or k×k) convolution, batch norm, ReLU."""

    def __init__(self, c_in: int, c_out: int, k: int = 3, stride: int = 1):
        super().__init__(nn.Conv2d(c_in, c_out, k, stride, k // 2, bias=False),
                         nn.BatchNorm2d(c_out, eps=BN_EPS), nn.ReLU(inplace=True))


class TaughtBranch(nn.Module):
    """A taught class's own layers (``core.detect.learned.teach``): conv-ReLU layers (a 1×1 that
    narrows the backbone's and head's features, then 3×3s) and its score logit (B, 1, H, W) and its
    own box (B, 4, H, W, raw distances as DeskNet's)."""

    def __init__(self, c_in: int, width: int = 32, kernels: Sequence[int] = (1, 3, 3)):
        super().__init__()
        self.width = int(width)
        self.kernels = tuple(int(k) for k in kernels)
        self.layers = nn.ModuleList(nn.Conv2d(c_in if i == 0 else width, width, k, padding=k // 2)
                                    for i, k in enumerate(self.kernels))
        self.score = nn.Conv2d(width, 1, 1)
        self.box = nn.Conv2d(width, 4, 1)
        nn.init.constant_(self.score.bias, -math.log((1 - 0.01) / 0.01))
        nn.init.normal_(self.score.weight, std=0.01)
        nn.init.normal_(self.box.weight, std=0.01)
        nn.init.constant_(self.box.bias, math.log(2.0))

    def forward(self, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x = features
        for conv in self.layers:
            x = F.relu(conv(x))
        return self.score(x), self.box(x)


class DeskNet(nn.Module):
    """Image (B, 3, H, W) in 0…1, RGB → (class logits (B, C, H/8, W/8), box raw (B, 4, H/8, W/8)).

    ``taught``: the branches of classes taught later (``TaughtBranch``, each on ``branch_input``),
    which ``forward`` leaves out (``forward_taught`` runs them) and ``export_onnx`` exports as more
    candidate rows (their class names follow the old ones in the model's names)."""

    def __init__(self, num_classes: int, widths: Sequence[int] = (16, 24, 48, 80), head_width: int = 48):
        super().__init__()
        a, b, c, d = (int(v) for v in widths)
        self.num_classes = int(num_classes)
        self.widths = (a, b, c, d)
        self.head_width = int(head_width)
        self.stride8 = nn.Sequential(ConvBnRelu(3, a, 3, 2), ConvBnRelu(a, b, 3, 2), ConvBnRelu(b, b),
                                     ConvBnRelu(b, c, 3, 2), ConvBnRelu(c, c), ConvBnRelu(c, c))
        self.stride16 = nn.Sequential(ConvBnRelu(c, d, 3, 2), ConvBnRelu(d, d), ConvBnRelu(d, d))
        self.head = nn.Sequential(ConvBnRelu(c + d, head_width, 1), ConvBnRelu(head_width, head_width))
        self.classes = nn.Conv2d(head_width, num_classes, 1)
        self.box = nn.Conv2d(head_width, 4, 1)
        # start with every cell saying "nothing here" (p = 0.01), as RetinaNet/CenterNet do
        nn.init.constant_(self.classes.bias, -math.log((1 - 0.01) / 0.01))
        nn.init.normal_(self.box.weight, std=0.01)
        nn.init.constant_(self.box.bias, math.log(2.0))  # boxes start 2 cells from the centre each way
        self.taught = nn.ModuleList()

    @property
    def branch_input(self) -> int:
        """Channels a taught branch sees: the backbone's (stride 8 + upsampled stride 16) and the head's."""
        return self.widths[2] + self.widths[3] + self.head_width

    def features(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(backbone features (B, c + d, H/8, W/8), head output (B, head_width, H/8, W/8))."""
        f8 = self.stride8(x)
        f16 = self.stride16(f8)
        cat = torch.cat([f8, F.interpolate(f16, scale_factor=2.0, mode="nearest")], dim=1)
        return cat, self.head(cat)

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        _, h = self.features(x)
        return self.classes(h), self.box(h)

    def forward_taught(self, x: torch.Tensor) -> list[tuple[torch.Tensor, torch.Tensor]]:
        """(score logit, box raw) of each taught branch."""
        cat, h = self.features(x)
        both = torch.cat([cat, h], dim=1)
        return [branch(both) for branch in self.taught]

    def add_taught(self, branch: "TaughtBranch") -> None:
        """One more taught class, with its own branch (its name goes after the others')."""
        if branch.layers[0].in_channels != self.branch_input:
            raise ValueError(f"a taught branch on {branch.layers[0].in_channels} channels: this network's "
                             f"branches see {self.branch_input}")
        self.taught.append(branch)


def _grid(h: int, w: int, stride: int = STRIDE) -> tuple[np.ndarray, np.ndarray]:
    """Cell centres (x (W,), y (H,)) in input pixels: cell i's centre is at (i + 0.5) · stride."""
    from core.detect.learned.onnx_graph import grid_centres

    return grid_centres(h, w, stride)


def decode(class_logits: torch.Tensor, box_raw: torch.Tensor, stride: int = STRIDE) -> torch.Tensor:
    """What the exported graph outputs: (B, 4 + C, H·W), rows cx, cy, w, h (input px) then scores."""
    bsz, _, h, w = class_logits.shape
    gx, gy = _grid(h, w, stride)
    gx = torch.as_tensor(gx, dtype=box_raw.dtype).view(1, w)
    gy = torch.as_tensor(gy, dtype=box_raw.dtype).view(h, 1)
    dist = torch.exp(box_raw.clamp(-MAX_LOG_DISTANCE, MAX_LOG_DISTANCE)) * stride
    left, top, right, bottom = dist.unbind(1)
    cx = gx + (right - left) / 2
    cy = gy + (bottom - top) / 2
    boxes = torch.stack([cx, cy, left + right, top + bottom], dim=1)
    return torch.cat([boxes, torch.sigmoid(class_logits)], dim=1).reshape(bsz, 4 + class_logits.shape[1], h * w)


# --------------------------------------------------------------------------------------- targets, loss
def make_targets(boxes: np.ndarray, labels: np.ndarray, difficult: np.ndarray, input_hw: tuple[int, int],
                 num_classes: int, stride: int = STRIDE) -> dict[str, np.ndarray]:
    """Training targets of one image on the output grid (H/stride, W/stride).

    ``boxes`` (K, 4) x0 y0 x1 y1 in input pixels, ``labels`` (K,) class indices, ``difficult`` (K,)
    mostly-hidden objects (their area learns nothing either way). Returns ``heat`` (C, H, W):
    a Gaussian per object, 1 at the cell holding its centre; ``ignore`` (H, W) bool;
    ``box`` (4, H, W) the box each regression cell learns; ``box_weight`` (H, W) that cell's weight.
    """
    gh, gw = input_hw[0] // stride, input_hw[1] // stride
    gx, gy = _grid(gh, gw, stride)
    heat = np.zeros((num_classes, gh, gw), np.float32)
    ignore = np.zeros((gh, gw), bool)
    box_t = np.zeros((4, gh, gw), np.float32)
    box_w = np.zeros((gh, gw), np.float32)
    boxes = np.asarray(boxes, np.float64).reshape(-1, 4)
    for (x0, y0, x1, y1), label, hard in zip(boxes, np.asarray(labels).reshape(-1), np.asarray(difficult).reshape(-1)):
        inside_x = (gx >= x0) & (gx <= x1)
        inside_y = (gy >= y0) & (gy <= y1)
        if hard:
            # the cells on it and one cell around: partial views must not be taught as background
            near_x = (gx >= x0 - stride) & (gx <= x1 + stride)
            near_y = (gy >= y0 - stride) & (gy <= y1 + stride)
            ignore |= near_y[:, None] & near_x[None, :]
            continue
        cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
        sx = max(HEAT_SIGMA_MIN_CELLS, HEAT_SIGMA_PER_SIZE * (x1 - x0) / stride) * stride
        sy = max(HEAT_SIGMA_MIN_CELLS, HEAT_SIGMA_PER_SIZE * (y1 - y0) / stride) * stride
        g = np.exp(-((gy[:, None] - cy) ** 2) / (2 * sy * sy) - ((gx[None, :] - cx) ** 2) / (2 * sx * sx))
        ci = min(max(int(cx // stride), 0), gw - 1)
        cj = min(max(int(cy // stride), 0), gh - 1)
        g[cj, ci] = 1.0
        heat[int(label)] = np.maximum(heat[int(label)], g)
        regress = (g >= REGRESS_MIN_HEAT) & inside_y[:, None] & inside_x[None, :]
        regress[cj, ci] = True
        better = regress & (g > box_w)  # a cell shared by two objects learns the one it is nearer
        box_w = np.where(better, g, box_w)
        for k, v in enumerate((x0, y0, x1, y1)):
            box_t[k][better] = v
    ignore &= heat.max(axis=0) < 1.0  # a visible object's centre is never ignored
    return {"heat": heat, "ignore": ignore, "box": box_t, "box_weight": box_w}


def _giou_loss(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """1 − GIoU of boxes (N, 4) x0 y0 x1 y1."""
    ix0 = torch.maximum(pred[:, 0], target[:, 0])
    iy0 = torch.maximum(pred[:, 1], target[:, 1])
    ix1 = torch.minimum(pred[:, 2], target[:, 2])
    iy1 = torch.minimum(pred[:, 3], target[:, 3])
    inter = (ix1 - ix0).clamp(min=0) * (iy1 - iy0).clamp(min=0)
    area_p = (pred[:, 2] - pred[:, 0]) * (pred[:, 3] - pred[:, 1])
    area_t = (target[:, 2] - target[:, 0]) * (target[:, 3] - target[:, 1])
    union = area_p + area_t - inter + 1e-6
    cx0 = torch.minimum(pred[:, 0], target[:, 0])
    cy0 = torch.minimum(pred[:, 1], target[:, 1])
    cx1 = torch.maximum(pred[:, 2], target[:, 2])
    cy1 = torch.maximum(pred[:, 3], target[:, 3])
    hull = (cx1 - cx0) * (cy1 - cy0) + 1e-6
    return 1.0 - (inter / union - (hull - union) / hull)


def detection_loss(class_logits: torch.Tensor, box_raw: torch.Tensor, targets: dict[str, torch.Tensor],
                   stride: int = STRIDE) -> tuple[torch.Tensor, dict[str, float]]:
    """Focal loss on the heat maps + weighted GIoU loss on the boxes; (total, parts for logging)."""
    heat = targets["heat"]
    keep = (~targets["ignore"]).unsqueeze(1).to(class_logits.dtype)
    p = torch.sigmoid(class_logits).clamp(1e-4, 1 - 1e-4)
    pos = (heat >= 1.0).to(p.dtype)
    pos_loss = -torch.log(p) * (1 - p) ** FOCAL_ALPHA * pos
    neg_loss = -torch.log(1 - p) * p ** FOCAL_ALPHA * (1 - heat) ** FOCAL_BETA * (1 - pos)
    n_pos = pos.sum().clamp(min=1.0)
    focal = ((pos_loss + neg_loss) * keep).sum() / n_pos

    weight = targets["box_weight"]
    cells = weight > 0
    if bool(cells.any()):
        _, _, h, w = box_raw.shape
        gx, gy = _grid(h, w, stride)
        gx = torch.as_tensor(gx, dtype=box_raw.dtype).view(1, 1, w).expand(box_raw.shape[0], h, w)
        gy = torch.as_tensor(gy, dtype=box_raw.dtype).view(1, h, 1).expand(box_raw.shape[0], h, w)
        dist = torch.exp(box_raw.clamp(-MAX_LOG_DISTANCE, MAX_LOG_DISTANCE)) * stride
        pred = torch.stack([gx - dist[:, 0], gy - dist[:, 1], gx + dist[:, 2], gy + dist[:, 3]], dim=1)
        pred = pred.permute(0, 2, 3, 1)[cells]
        target = targets["box"].permute(0, 2, 3, 1)[cells]
        wsel = weight[cells]
        box = (_giou_loss(pred, target) * wsel).sum() / wsel.sum().clamp(min=1e-6)
    else:
        box = box_raw.sum() * 0.0
    total = focal + BOX_LOSS_WEIGHT * box
    return total, {"focal": float(focal.detach()), "box": float(box.detach())}


# --------------------------------------------------------------------------------------- training
def optimise_step(opt, loss: torch.Tensor, params, ema_pairs, step: int, max_decay: float) -> None:
    """One step of ``opt`` on ``loss`` (gradients clipped to norm 10 over ``params``), then the
    exponential moving average: each (average, live) tensor pair of ``ema_pairs`` moves towards the
    live one with decay min(max_decay, (1 + step) / (10 + step)) — short runs warm the average up;
    tensors that are not floating point (batch norm's counters) are copied."""
    opt.zero_grad(set_to_none=True)
    loss.backward()
    torch.nn.utils.clip_grad_norm_(params, 10.0)
    opt.step()
    d = min(max_decay, (1 + step) / (10 + step))
    with torch.no_grad():
        for pe, pn in ema_pairs:
            if pe.dtype.is_floating_point:
                pe.mul_(d).add_(pn.detach(), alpha=1 - d)
            else:
                pe.copy_(pn)


@dataclass(frozen=True)
class TrainConfig:
    """How to train (defaults: the shipped model's run)."""

    epochs: int = 40  # passes over the training images (the time limit may stop earlier)
    max_seconds: float = 480.0  # wall-time budget for the optimisation (0: no limit)
    batch_size: int = 16
    learning_rate: float = 3e-3  # AdamW peak, cosine to 2 % of it over the run
    weight_decay: float = 5e-4
    warmup_fraction: float = 0.03  # of the run, linear warm-up
    ema_decay: float = 0.998  # exported weights: an exponential moving average of the trained ones
    flip: bool = True  # random horizontal flips
    seed: int = 0
    threads: int = 0  # torch CPU threads (0: torch's default)
    widths: tuple[int, int, int, int] = (16, 24, 48, 80)
    head_width: int = 48

    def __post_init__(self) -> None:
        if self.epochs < 1 or self.batch_size < 1:
            raise ValueError(f"epochs = {self.epochs} and batch_size = {self.batch_size} must be ≥ 1")
        if self.max_seconds < 0 or not 0 < self.learning_rate < 1:
            raise ValueError(f"max_seconds = {self.max_seconds} must be ≥ 0 and learning_rate = "
                             f"{self.learning_rate} in (0, 1)")


@dataclass(frozen=True)
class TrainResult:
    """A trained network (EMA weights, eval mode) and how the run went."""

    net: "DeskNet"
    seconds: float
    epochs_done: float  # fractional when the time limit stopped the run
    steps: int
    final_loss: float

    def summary(self) -> dict:
        return {"seconds": round(self.seconds, 1), "epochs": round(self.epochs_done, 2), "steps": self.steps,
                "final_loss": round(self.final_loss, 4)}


def _stack_targets(all_targets: list[dict[str, np.ndarray]]) -> dict[str, torch.Tensor]:
    return {k: torch.from_numpy(np.stack([t[k] for t in all_targets])) for k in all_targets[0]}


def _flip_batch(images: torch.Tensor, targets: dict[str, torch.Tensor], flip: torch.Tensor,
                input_w: int) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
    """Mirror the chosen images (and their targets) left-right; the grid is symmetric (W = k·stride)."""
    if not bool(flip.any()):
        return images, targets
    images = images.clone()
    images[flip] = images[flip].flip(-1)
    out = {k: v.clone() for k, v in targets.items()}
    out["heat"][flip] = targets["heat"][flip].flip(-1)
    out["ignore"][flip] = targets["ignore"][flip].flip(-1)
    out["box_weight"][flip] = targets["box_weight"][flip].flip(-1)
    box = targets["box"][flip].flip(-1)
    mirrored = box.clone()
    mirrored[:, 0] = input_w - box[:, 2]
    mirrored[:, 2] = input_w - box[:, 0]
    out["box"][flip] = mirrored
    return images, out


def train_detector(images: np.ndarray, boxes: Sequence[np.ndarray], labels: Sequence[np.ndarray],
                   difficult: Sequence[np.ndarray], num_classes: int, config: TrainConfig = TrainConfig(),
                   progress: Optional[Callable[[str], None]] = None) -> TrainResult:
    """Train a DeskNet on letterboxed images (N, H, W, 3) BGR uint8 (H, W multiples of 16) with
    per-image boxes (K, 4) in their pixels, class indices (K,) and difficult flags (K,).

    Deterministic for a seed when no time limit cuts the run (torch's CPU kernels are).
    """
    say = progress or (lambda text: None)
    n, h, w = images.shape[:3]
    if h % 16 or w % 16:
        raise ValueError(f"training images are {w}x{h}: width and height must be multiples of 16")
    if config.threads:
        torch.set_num_threads(int(config.threads))
    torch.manual_seed(config.seed)
    rng = np.random.default_rng(config.seed)
    net = DeskNet(num_classes, config.widths, config.head_width)
    ema = DeskNet(num_classes, config.widths, config.head_width)
    ema.load_state_dict(net.state_dict())
    ema.eval()
    for p in ema.parameters():
        p.requires_grad_(False)

    targets = _stack_targets([make_targets(b, l, d, (h, w), num_classes) for b, l, d in zip(boxes, labels, difficult)])
    # BGR uint8 NHWC → RGB NCHW, as cv2.dnn.blobFromImage(swapRB=True) feeds the exported model
    pixels = torch.from_numpy(np.ascontiguousarray(images[..., ::-1].transpose(0, 3, 1, 2)))

    steps_per_epoch = max(1, n // config.batch_size)
    total_steps = steps_per_epoch * config.epochs
    decay, no_decay = [], []
    for name, p in net.named_parameters():
        (no_decay if p.ndim == 1 else decay).append(p)
    opt = torch.optim.AdamW([{"params": decay, "weight_decay": config.weight_decay},
                             {"params": no_decay, "weight_decay": 0.0}], lr=config.learning_rate)
    ema_tensors = list(ema.state_dict().values())  # the same tensors as the modules hold
    net_tensors = list(net.state_dict().values())
    t0 = time.perf_counter()
    step, last_loss, running = 0, float("nan"), None
    lr, parts = config.learning_rate, {"focal": float("nan"), "box": float("nan")}
    stop = False
    for epoch in range(config.epochs):
        order = rng.permutation(n)
        for i in range(steps_per_epoch):
            elapsed = time.perf_counter() - t0
            progress_frac = step / total_steps
            if config.max_seconds:
                progress_frac = max(progress_frac, elapsed / config.max_seconds)
            if progress_frac >= 1.0:
                stop = True
                break
            if progress_frac < config.warmup_fraction:
                lr = config.learning_rate * (0.1 + 0.9 * progress_frac / config.warmup_fraction)
            else:
                s = (progress_frac - config.warmup_fraction) / (1 - config.warmup_fraction)
                lr = config.learning_rate * (0.02 + 0.98 * 0.5 * (1 + math.cos(math.pi * s)))
            for group in opt.param_groups:
                group["lr"] = lr
            idx = torch.from_numpy(order[i * config.batch_size:(i + 1) * config.batch_size])
            x = pixels[idx].float().div_(255.0)
            tb = {k: v[idx] for k, v in targets.items()}
            if config.flip:
                x, tb = _flip_batch(x, tb, torch.from_numpy(rng.random(len(idx)) < 0.5), w)
            net.train()
            cls, box = net(x)
            loss, parts = detection_loss(cls, box, tb)
            optimise_step(opt, loss, net.parameters(), zip(ema_tensors, net_tensors), step, config.ema_decay)
            step += 1
            last_loss = float(loss.detach())
            running = last_loss if running is None else 0.98 * running + 0.02 * last_loss
        say(f"epoch {epoch + 1}: {step} steps, loss {running or float('nan'):.4f} (focal {parts['focal']:.3f}, box "
            f"{parts['box']:.3f}), lr {lr:.2e}, {time.perf_counter() - t0:.0f} s")
        if stop:
            break
    seconds = time.perf_counter() - t0
    return TrainResult(net=ema.eval(), seconds=seconds, epochs_done=step / steps_per_epoch, steps=step,
                       final_loss=running if running is not None else last_loss)


# --------------------------------------------------------------------------------------- ONNX export
def fold_batch_norm(block: ConvBnRelu) -> tuple[np.ndarray, np.ndarray]:
    """(weight, bias) of one convolution with its batch norm folded in (eval-mode statistics)."""
    conv, bn = block[0], block[1]
    scale = bn.weight.detach() / torch.sqrt(bn.running_var + bn.eps)
    weight = conv.weight.detach() * scale.view(-1, 1, 1, 1)
    bias = bn.bias.detach() - bn.running_mean * scale
    return weight.numpy().astype(np.float32), bias.numpy().astype(np.float32)


def net_layers(net: DeskNet, names: Sequence[str]) -> tuple[dict, dict]:
    """(layers, architecture) of ``net`` as ``onnx_graph.build_desk_onnx`` takes them (BN folded)."""
    net = net.eval()
    if len(names) != net.num_classes + len(net.taught):
        raise ValueError(f"{len(names)} class names for a network with {net.num_classes} classes and "
                         f"{len(net.taught)} taught")
    layers = {}
    for prefix, seq in (("stride8", net.stride8), ("stride16", net.stride16), ("head", net.head)):
        for i, block in enumerate(seq):
            wgt, b = fold_batch_norm(block)
            layers[f"{prefix}.{i}"] = (wgt, b, block[0].stride[0])

    def plain(conv: nn.Conv2d) -> tuple:
        return conv.weight.detach().numpy().astype(np.float32), conv.bias.detach().numpy().astype(np.float32), 1

    layers["classes"], layers["box"] = plain(net.classes), plain(net.box)
    taught = []
    for j, (branch, name) in enumerate(zip(net.taught, names[net.num_classes:])):
        for i, conv in enumerate(branch.layers):
            layers[f"taught{j}.{i}"] = plain(conv)
        layers[f"taught{j}.score"], layers[f"taught{j}.box"] = plain(branch.score), plain(branch.box)
        taught.append({"name": str(name), "width": branch.width, "kernels": list(branch.kernels)})
    arch = {"widths": list(net.widths), "head_width": net.head_width}
    if taught:
        arch["taught"] = taught
    return layers, arch


def export_onnx(net: DeskNet, path: str | os.PathLike, names: Sequence[str], input_wh: tuple[int, int],
                metadata: Optional[dict] = None, opset: int = 17) -> Path:
    """Write ``net`` as an ONNX model with a fixed (1, 3, H, W) input "images" and the YOLOv8 output
    (1, 4 + C, H/8 · W/8) "output0" — (1, 4 + C, (1 + T) · H/8 · W/8) with T taught branches
    (``core.detect.learned.onnx_graph``); ``names`` (the old classes, then the taught ones) go into
    the ``names`` metadata ("{0: 'ball', 1: 'cup'}"), plus ``imgsz``, ``stride``, ``architecture``
    and any ``metadata`` (str() of values, dicts as JSON). Needs the ``onnx`` package. Returns the path."""
    try:
        import onnx  # noqa: F401
    except ImportError:
        raise ImportError("exporting the detector needs the onnx package: pip install onnx "
                          "(it is in deskarm's train and test extras)") from None
    layers, arch = net_layers(net, names)
    model = build_desk_onnx(layers, arch, names, input_wh, metadata, opset)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    from core.paths import write_file_atomically

    write_file_atomically(path, model.SerializeToString())
    return path


def config_dict(config: TrainConfig) -> dict:
    """The training settings as plain JSON values (for the model's metadata and the report)."""
    d = asdict(config)
    d["widths"] = list(config.widths)
    return d
