"""Fine-tune an exported desk model (an .onnx deskarm wrote) on CPU, calibrate its score, export it.
Needs torch (the optional ``train`` extra).

* ``net_from_onnx``: the DeskNet inside a deskarm .onnx (its batch norm was folded into the
  convolutions on export; here each BN is the identity with the folded bias, and stays frozen),
  with the branches of the classes taught on it (``DeskNet.taught``, from its ``architecture``);
* ``add_classes``: the same network with more class outputs (the old ones keep their weights);
* ``finetune``: a training loop over a *batch source* (a callable that returns images, boxes,
  labels, difficult — e.g. renders with domain randomisation, or a taught object's frames), with
  parts of the network frozen, a time limit, a progress callback (fraction done, seconds left) and
  a cancel check; it returns None when cancelled (the caller keeps the old model);
* ``platt``: the score calibration — a logistic fit of "the detection is right" on the logit of
  the raw score, folded into the class outputs so a score of 0.5 is right half the time.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Optional, Sequence

import numpy as np
import torch
import torch.nn as nn

from core.detect.learned.model import (BN_EPS, DeskNet, TaughtBranch, _flip_batch, detection_loss, make_targets,
                                        optimise_step)

__all__ = ["net_from_onnx", "add_classes", "finetune", "FinetuneResult", "platt", "apply_platt", "model_names"]

BatchSource = Callable[[np.random.Generator, int], tuple[np.ndarray, list, list, list]]


def model_names(path) -> list[str]:
    """The class names in a deskarm .onnx's ``names`` metadata."""
    from core.detect.onnx_yolo import parse_names, read_onnx_info

    info = read_onnx_info(path)
    return list(parse_names(info.metadata.get("names", "")) or [])


def net_from_onnx(path) -> tuple[DeskNet, list[str], dict]:
    """(network, class names, metadata) of a deskarm .onnx; BN layers hold the identity. The names
    are the old classes', then the taught ones' (one ``net.taught`` branch each)."""
    import json

    import onnx
    from onnx import numpy_helper

    model = onnx.load(str(path))
    meta = {p.key: p.value for p in model.metadata_props}
    weights = {i.name: numpy_helper.to_array(i) for i in model.graph.initializer}
    arch = json.loads(meta.get("architecture", '{"widths": [16, 24, 48, 80], "head_width": 48}'))
    names = model_names(path)
    taught = arch.get("taught", [])
    net = DeskNet(len(names) - len(taught), arch["widths"], arch["head_width"])
    for prefix, seq in (("stride8", net.stride8), ("stride16", net.stride16), ("head", net.head)):
        for i, block in enumerate(seq):
            conv, bn = block[0], block[1]
            conv.weight.data = torch.from_numpy(weights[f"{prefix}.{i}.weight"].copy())
            bn.weight.data.fill_(1.0)
            bn.bias.data = torch.from_numpy(weights[f"{prefix}.{i}.bias"].copy())
            bn.running_mean.zero_()
            bn.running_var.fill_(1.0 - BN_EPS)
    for name, conv in (("classes", net.classes), ("box", net.box)):
        conv.weight.data = torch.from_numpy(weights[f"{name}.weight"].copy())
        conv.bias.data = torch.from_numpy(weights[f"{name}.bias"].copy())
    for j, spec in enumerate(taught):
        branch = TaughtBranch(net.branch_input, int(spec["width"]), spec.get("kernels", (3, 3)))
        parts = [(str(i), conv) for i, conv in enumerate(branch.layers)]
        for part, conv in parts + [("score", branch.score), ("box", branch.box)]:
            conv.weight.data = torch.from_numpy(weights[f"taught{j}.{part}.weight"].copy())
            conv.bias.data = torch.from_numpy(weights[f"taught{j}.{part}.bias"].copy())
        net.add_taught(branch)
    return net.eval(), names, meta


def add_classes(net: DeskNet, extra: int) -> DeskNet:
    """``net`` with ``extra`` more class outputs (new ones start at p = 0.01 everywhere)."""
    if len(net.taught):
        raise ValueError("this model has taught classes (their names follow the old ones'): teach the new "
                         "classes too (core.detect.learned.teach) instead of adding outputs")
    old = net.classes
    new = nn.Conv2d(old.in_channels, old.out_channels + extra, 1)
    with torch.no_grad():
        new.weight[:old.out_channels] = old.weight
        new.bias[:old.out_channels] = old.bias
        nn.init.normal_(new.weight[old.out_channels:], std=0.01)
        new.bias[old.out_channels:] = -math.log((1 - 0.01) / 0.01)
    net.classes = new
    net.num_classes = old.out_channels + extra
    return net


@dataclass
class FinetuneResult:
    net: DeskNet
    seconds: float
    steps: int
    final_loss: float


def _freeze_bn(net: nn.Module) -> None:
    for m in net.modules():
        if isinstance(m, nn.BatchNorm2d):
            m.eval()


def finetune(net: DeskNet, batches: BatchSource, steps: int, *, train: str = "all", learning_rate: float = 1e-3,
             max_seconds: float = 0.0, seed: int = 0, flip: bool = True, threads: int = 0,
             progress: Optional[Callable[[float, float, str], None]] = None,
             cancelled: Optional[Callable[[], bool]] = None) -> Optional[FinetuneResult]:
    """Fine-tune ``net`` in place for ``steps`` batches from ``batches(rng, step)`` (BN frozen).

    ``train``: "all" (every weight), "head" (head, classes and box; the backbone frozen) or
    "classes" (the class outputs only). ``progress(fraction, seconds_left, text)`` after each step;
    ``cancelled()`` True stops the run and returns None. Returns the EMA of the weights."""
    if threads:
        torch.set_num_threads(int(threads))
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    if train == "all":
        params = list(net.parameters())
    elif train == "head":
        params = list(net.head.parameters()) + list(net.classes.parameters()) + list(net.box.parameters())
    elif train == "classes":
        params = list(net.classes.parameters())
    else:
        raise ValueError(f"train = {train!r}: all, head or classes")
    for p in net.parameters():
        p.requires_grad_(False)
    for p in params:
        p.requires_grad_(True)
    import copy

    ema = copy.deepcopy(net).eval()
    ema_t, net_t = list(ema.state_dict().values()), list(net.state_dict().values())
    opt = torch.optim.AdamW(params, lr=learning_rate, weight_decay=1e-4)
    t0 = time.perf_counter()
    running = None
    step = 0
    for step in range(steps):
        if cancelled is not None and cancelled():
            return None
        elapsed = time.perf_counter() - t0
        frac = step / steps
        if max_seconds:
            frac = max(frac, elapsed / max_seconds)
        if frac >= 1.0:
            break
        lr = learning_rate * (0.05 + 0.95 * 0.5 * (1 + math.cos(math.pi * frac)))
        if frac < 0.05:
            lr *= 0.2 + 0.8 * frac / 0.05
        for g in opt.param_groups:
            g["lr"] = lr
        images, boxes, labels, difficult = batches(rng, step)
        h, w = images.shape[1:3]
        tg = [make_targets(b, l, d, (h, w), net.num_classes) for b, l, d in zip(boxes, labels, difficult)]
        tb = {k: torch.from_numpy(np.stack([t[k] for t in tg])) for k in tg[0]}
        x = torch.from_numpy(np.ascontiguousarray(images[..., ::-1].transpose(0, 3, 1, 2))).float().div_(255.0)
        if flip:
            x, tb = _flip_batch(x, tb, torch.from_numpy(rng.random(len(x)) < 0.5), w)
        net.train()
        _freeze_bn(net)
        cls, box = net(x)
        loss, parts = detection_loss(cls, box, tb)
        optimise_step(opt, loss, params, zip(ema_t, net_t), step, 0.995)
        running = float(loss) if running is None else 0.95 * running + 0.05 * float(loss)
        if progress is not None:
            done = (step + 1) / steps
            elapsed = time.perf_counter() - t0
            if max_seconds:
                done = max(done, elapsed / max_seconds)
            left = elapsed / max(done, 1e-6) * (1 - done)
            progress(min(done, 1.0), left, f"step {step + 1}/{steps}, loss {running:.3f} (focal {parts['focal']:.3f}, "
                                           f"box {parts['box']:.3f})")
    for p in ema.parameters():
        p.requires_grad_(False)
    return FinetuneResult(net=ema.eval(), seconds=time.perf_counter() - t0, steps=step + 1,
                          final_loss=float("nan") if running is None else running)


def platt(scores: np.ndarray, correct: np.ndarray, iterations: int = 500) -> tuple[float, float]:
    """(a, b) of p = sigmoid(a · logit(score) + b) fitted to ``correct`` (maximum likelihood)."""
    s = np.clip(np.asarray(scores, np.float64), 1e-6, 1 - 1e-6)
    z = np.log(s / (1 - s))
    y = np.asarray(correct, np.float64)
    a, b = 1.0, 0.0
    for _ in range(iterations):  # Newton's method on the logistic log-likelihood
        p = 1 / (1 + np.exp(-(a * z + b)))
        g = np.array([np.sum((p - y) * z), np.sum(p - y)])
        wgt = p * (1 - p) + 1e-9
        hess = np.array([[np.sum(wgt * z * z), np.sum(wgt * z)], [np.sum(wgt * z), np.sum(wgt)]]) + 1e-6 * np.eye(2)
        step = np.linalg.solve(hess, g)
        a, b = a - step[0], b - step[1]
        if np.abs(step).max() < 1e-8:
            break
    return float(a), float(b)


def apply_platt(net: DeskNet, a: float, b: float) -> DeskNet:
    """Fold p = sigmoid(a · logit + b) into the class outputs (in place)."""
    with torch.no_grad():
        net.classes.weight.mul_(a)
        net.classes.bias.mul_(a).add_(b)
    return net


def export(net: DeskNet, path, names: Sequence[str], input_wh=(320, 240), metadata: Optional[dict] = None) -> Path:
    from core.detect.learned.model import export_onnx

    return export_onnx(net, path, names, input_wh, metadata=metadata)
