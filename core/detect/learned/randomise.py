"""Domain randomisation for the desk detector's training images (numpy + OpenCV, no torch).

The shipped model once saw only clean renders of the simulated desk, and on real photos it was
confidently wrong (markers called buttons, black squares cups). ``randomise`` turns a letterboxed
render and its boxes into one a real webcam could have taken, and ``negative_image`` makes images
that hold none of the classes:

* camera: white balance, exposure and gamma, contrast, saturation, motion or defocus blur, sensor
  noise (Gaussian + shot), JPEG compression, barrel/pincushion lens distortion (boxes follow);
* distractors that are none of the classes, drawn where no labelled object is: chessboards and
  printed ArUco markers, hands, cables, screens, books, mugs of every colour (a handle, a side
  view), small clutter (stickers, screws, switches);
* backgrounds: object crops pasted onto random textures (noise, stripes, checks, gradients) or onto
  real photos (``real_negatives``); real photos and textures alone are negatives (no boxes).

Every function takes a ``numpy.random.Generator`` and is deterministic given it.
"""
from __future__ import annotations

import math
from typing import Optional, Sequence

import cv2
import numpy as np

__all__ = ["randomise", "negative_image", "texture", "draw_distractors", "camera_effects", "distort_lens",
           "paste_on_background"]


def _u8(x: np.ndarray) -> np.ndarray:
    return np.clip(x, 0, 255).astype(np.uint8)


def texture(rng: np.random.Generator, h: int, w: int) -> np.ndarray:
    """A random textured BGR background: smooth noise, stripes, checks, gradients or speckle."""
    kind = int(rng.integers(5))
    base = rng.uniform(20, 235, 3)
    if kind == 0:  # smooth coloured noise (wood, fabric, carpet at some scale)
        small = rng.uniform(0, 255, (max(2, h // int(rng.integers(4, 40))), max(2, w // int(rng.integers(4, 40))), 3))
        img = cv2.resize(small.astype(np.float32), (w, h), interpolation=cv2.INTER_CUBIC)
        img = base + (img - 128) * rng.uniform(0.2, 1.0)
    elif kind == 1:  # stripes at any angle
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
        a = rng.uniform(0, math.pi)
        period = rng.uniform(4, 60)
        s = np.sin((xx * math.cos(a) + yy * math.sin(a)) * 2 * math.pi / period)[..., None]
        other = rng.uniform(20, 235, 3)
        img = base + (other - base) * (s > 0 if rng.random() < 0.5 else (s + 1) / 2)
    elif kind == 2:  # checks / tiles
        cell = int(rng.integers(6, 50))
        yy, xx = np.mgrid[0:h, 0:w]
        mask = (((xx // cell) + (yy // cell)) % 2)[..., None]
        other = rng.uniform(0, 255, 3)
        img = np.where(mask > 0, base, other).astype(np.float32)
    elif kind == 3:  # gradient (a wall, a lit table)
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
        a = rng.uniform(0, 2 * math.pi)
        t = ((xx * math.cos(a) + yy * math.sin(a)) / max(h, w))[..., None]
        other = rng.uniform(0, 255, 3)
        img = base + (other - base) * (t - t.min()) / max(float(t.max() - t.min()), 1e-6)
    else:  # speckle
        img = base + rng.normal(0, rng.uniform(5, 40), (h, w, 3))
        img = cv2.GaussianBlur(img.astype(np.float32), (0, 0), rng.uniform(0.5, 3))
    return _u8(img)


def _free_spot(rng, h, w, size_wh, boxes: np.ndarray, tries: int = 15) -> Optional[tuple[int, int]]:
    bw, bh = size_wh
    for _ in range(tries):
        x = int(rng.integers(-bw // 3, max(1, w - 2 * bw // 3)))
        y = int(rng.integers(-bh // 3, max(1, h - 2 * bh // 3)))
        ok = True
        for x0, y0, x1, y1 in boxes:
            ix = min(x + bw, x1) - max(x, x0)
            iy = min(y + bh, y1) - max(y, y0)
            if ix > 0 and iy > 0 and ix * iy > 0.1 * (x1 - x0) * (y1 - y0):
                ok = False
                break
        if ok:
            return x, y
    return None


def _colour(rng) -> tuple[int, int, int]:
    return tuple(int(v) for v in rng.integers(0, 256, 3))


def _draw_one(rng: np.random.Generator, img: np.ndarray, x: int, y: int, bw: int, bh: int, kind: int) -> None:
    """Draw distractor ``kind`` into the box (x, y, bw, bh) of ``img`` (in place)."""
    if kind == 0:  # chessboard (printed, maybe on a coloured tray)
        n = int(rng.integers(3, 10))
        cell = max(2, min(bw, bh) // n)
        if rng.random() < 0.4:
            cv2.rectangle(img, (x - cell, y - cell), (x + n * cell + cell, y + n * cell + cell), _colour(rng), -1)
        for i in range(n):
            for j in range(n):
                c = (0, 0, 0) if (i + j) % 2 else (235, 235, 235)
                cv2.rectangle(img, (x + i * cell, y + j * cell), (x + (i + 1) * cell, y + (j + 1) * cell), c, -1)
    elif kind == 1:  # printed ArUco marker on white paper
        side = max(12, min(bw, bh))
        marker = cv2.aruco.generateImageMarker(cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50),
                                               int(rng.integers(50)), side)
        paper = np.full((side + side // 4, side + side // 4), 240, np.uint8)
        paper[side // 8:side // 8 + side, side // 8:side // 8 + side] = marker
        y0, x0 = max(0, y), max(0, x)
        y1, x1 = min(img.shape[0], y + paper.shape[0]), min(img.shape[1], x + paper.shape[1])
        if y1 > y0 and x1 > x0:
            img[y0:y1, x0:x1] = paper[y0 - y:y1 - y, x0 - x:x1 - x, None]
    elif kind == 2:  # a hand: skin palm and fingers
        skin = np.array([rng.uniform(60, 180), rng.uniform(90, 200), rng.uniform(130, 240)])
        cx, cy = x + bw // 2, y + bh // 2
        cv2.ellipse(img, (cx, cy), (max(3, bw // 4), max(3, bh // 3)), float(rng.uniform(0, 180)), 0, 360,
                    skin.tolist(), -1)
        for k in range(5):
            a = rng.uniform(-math.pi, 0) if k < 4 else rng.uniform(0, math.pi)
            r = min(bw, bh) * rng.uniform(0.3, 0.55)
            cv2.line(img, (cx, cy), (int(cx + r * math.cos(a)), int(cy + r * math.sin(a))), (skin * 0.95).tolist(),
                     max(2, min(bw, bh) // 9))
    elif kind == 3:  # a cable
        pts = np.cumsum(rng.normal(0, max(bw, bh) / 4, (6, 2)), axis=0) + [x + bw / 2, y + bh / 2]
        cv2.polylines(img, [pts.astype(np.int32)], False, _colour(rng) if rng.random() < 0.5 else (20, 20, 20),
                      int(rng.integers(1, 5)))
    elif kind == 4:  # a screen: dark bezel, a lit picture
        cv2.rectangle(img, (x, y), (x + bw, y + bh), (int(rng.integers(0, 40)),) * 3, -1)
        m = max(2, min(bw, bh) // 12)
        inner = texture(rng, max(1, bh - 2 * m), max(1, bw - 2 * m))
        y0, x0 = max(0, y + m), max(0, x + m)
        y1, x1 = min(img.shape[0], y + bh - m), min(img.shape[1], x + bw - m)
        if y1 > y0 and x1 > x0:
            img[y0:y1, x0:x1] = inner[y0 - y - m:y1 - y - m, x0 - x - m:x1 - x - m]
    elif kind == 5:  # a book: a coloured block, a spine, lines of text
        c = _colour(rng)
        cv2.rectangle(img, (x, y), (x + bw, y + bh), c, -1)
        cv2.rectangle(img, (x, y), (x + max(2, bw // 8), y + bh), tuple(int(v * 0.6) for v in c), -1)
        for k in range(int(rng.integers(0, 6))):
            yy = y + int((k + 1) * bh / 7)
            cv2.line(img, (x + bw // 4, yy), (x + bw - bw // 8, yy), (int(rng.integers(0, 255)),) * 3, 1)
    elif kind == 7:  # small clutter: stickers, screws, switches, labels (dark, light or coloured)
        for _ in range(int(rng.integers(1, 6))):
            r = int(rng.integers(2, 9))
            cx, cy = x + int(rng.integers(0, max(1, bw))), y + int(rng.integers(0, max(1, bh)))
            c = _colour(rng) if rng.random() < 0.5 else (int(rng.integers(0, 60)),) * 3
            if rng.random() < 0.5:
                cv2.circle(img, (cx, cy), r, c, -1)
            else:
                cv2.rectangle(img, (cx - r, cy - r // 2), (cx + r, cy + r // 2), c, -1)
    else:  # a mug from the side, any colour, with its handle
        c = _colour(rng)
        body_w = max(4, int(bw * 0.7))
        cv2.rectangle(img, (x, y), (x + body_w, y + bh), c, -1)
        cv2.ellipse(img, (x + body_w // 2, y), (body_w // 2, max(2, bh // 10)), 0, 0, 360,
                    tuple(int(v * 0.5) for v in c), -1)
        cv2.ellipse(img, (x + body_w, y + bh // 2), (max(2, bw - body_w), max(3, bh // 4)), 0, -90, 90, c,
                    max(2, bw // 12))


def draw_distractors(rng: np.random.Generator, img: np.ndarray, boxes: np.ndarray, count: int) -> np.ndarray:
    """Draw ``count`` distractors (markers, boards, hands, cables, screens, books, mugs) where they
    cover little of any labelled box; returns the image (a copy)."""
    img = img.copy()
    h, w = img.shape[:2]
    boxes = np.asarray(boxes, np.float64).reshape(-1, 4)
    for _ in range(count):
        kind = int(rng.integers(8))
        size = rng.uniform(0.08, 0.45) * min(h, w)
        bw, bh = int(size * rng.uniform(0.6, 1.6)), int(size)
        spot = _free_spot(rng, h, w, (bw, bh), boxes)
        if spot is not None:
            _draw_one(rng, img, spot[0], spot[1], max(4, bw), max(4, bh), kind)
    return img


def distort_lens(rng: np.random.Generator, img: np.ndarray, boxes: np.ndarray,
                 k1: Optional[float] = None) -> tuple[np.ndarray, np.ndarray]:
    """Radial lens distortion (k1 < 0 barrel, > 0 pincushion); boxes become the hull of their
    distorted edges."""
    h, w = img.shape[:2]
    k1 = float(rng.uniform(-0.3, 0.15)) if k1 is None else k1
    f = 0.5 * w
    cx, cy = w / 2, h / 2
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    # output pixel (distorted) ← source pixel (ideal): approximate inverse by one fixed-point step
    xd, yd = (xx - cx) / f, (yy - cy) / f
    r2 = xd * xd + yd * yd
    scale = 1.0 / (1 + k1 * r2)
    mapx, mapy = (xd * scale * f + cx).astype(np.float32), (yd * scale * f + cy).astype(np.float32)
    out = cv2.remap(img, mapx, mapy, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    new = []
    for x0, y0, x1, y1 in np.asarray(boxes, np.float64).reshape(-1, 4):
        t = np.linspace(0, 1, 9)
        px = np.concatenate([x0 + (x1 - x0) * t, x0 + (x1 - x0) * t, np.full(9, x0), np.full(9, x1)])
        py = np.concatenate([np.full(9, y0), np.full(9, y1), y0 + (y1 - y0) * t, y0 + (y1 - y0) * t])
        ux, uy = (px - cx) / f, (py - cy) / f
        # forward map: distorted = ideal · (1 + k1 r_ideal²) (the inverse of the remap above, to first order)
        r2u = ux * ux + uy * uy
        dx, dy = ux * (1 + k1 * r2u) * f + cx, uy * (1 + k1 * r2u) * f + cy
        new.append([np.clip(dx.min(), 0, w), np.clip(dy.min(), 0, h), np.clip(dx.max(), 0, w), np.clip(dy.max(), 0, h)])
    return out, np.array(new, np.float32).reshape(-1, 4)


def camera_effects(rng: np.random.Generator, img: np.ndarray, strength: float = 1.0) -> np.ndarray:
    """White balance, exposure/gamma, contrast, saturation, blur, noise and JPEG, each at random."""
    s = float(strength)
    x = img.astype(np.float32)
    x *= np.exp(rng.normal(0, 0.12 * s, 3)).astype(np.float32)  # white balance
    x *= float(np.clip(np.exp(rng.normal(0, 0.22 * s)), 0.5, 1.8))  # exposure
    gamma = float(np.exp(rng.normal(0, 0.2 * s)))
    x = 255.0 * (np.clip(x, 0, 255) / 255.0) ** gamma
    mean = x.mean()
    x = mean + (x - mean) * float(np.exp(rng.normal(0, 0.2 * s)))  # contrast
    grey = x.mean(axis=2, keepdims=True)
    x = grey + (x - grey) * float(np.clip(np.exp(rng.normal(0, 0.35 * s)), 0.2, 2.0))  # saturation
    img = _u8(x)
    u = rng.random()
    if u < 0.3 * s:  # motion blur
        length = int(rng.integers(3, 10))
        k = np.zeros((length, length), np.float32)
        k[length // 2, :] = 1.0
        rot = cv2.getRotationMatrix2D((length / 2 - 0.5, length / 2 - 0.5), float(rng.uniform(0, 180)), 1.0)
        k = cv2.warpAffine(k, rot, (length, length))
        img = cv2.filter2D(img, -1, k / max(float(k.sum()), 1e-6))
    elif u < 0.6 * s:  # defocus
        img = cv2.GaussianBlur(img, (0, 0), float(rng.uniform(0.5, 1.8)))
    if rng.random() < 0.7 * s:  # sensor noise: read noise and shot noise
        sigma = float(rng.uniform(1, 9))
        x = img.astype(np.float32)
        x += rng.normal(0, 1, x.shape).astype(np.float32) * (sigma + 0.3 * np.sqrt(x))
        if rng.random() < 0.5:  # chroma-correlated, as a Bayer demosaic leaves it
            x = cv2.GaussianBlur(x, (0, 0), 0.7)
        img = _u8(x)
    if rng.random() < 0.6 * s:
        ok, enc = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, int(rng.integers(25, 92))])
        img = cv2.imdecode(enc, cv2.IMREAD_COLOR)
    return img


def paste_on_background(rng: np.random.Generator, img: np.ndarray, boxes: np.ndarray, keep: np.ndarray,
                        background: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The labelled objects of ``img`` cut out (their box grown by 10–30 %) and pasted, feathered, at
    the same place on ``background``; returns (image, boxes, which of the boxes were pasted)."""
    out = background.copy()
    h, w = img.shape[:2]
    mask = np.zeros((h, w), np.float32)
    pasted = np.zeros(len(boxes), bool)
    for i, (x0, y0, x1, y1) in enumerate(np.asarray(boxes).reshape(-1, 4)):
        if not keep[i]:
            continue
        g = rng.uniform(0.1, 0.3)
        mx, my = (x1 - x0) * g, (y1 - y0) * g
        cv2.rectangle(mask, (int(x0 - mx), int(y0 - my)), (int(x1 + mx), int(y1 + my)), 1.0, -1)
        pasted[i] = True
    mask = cv2.GaussianBlur(mask, (0, 0), 2.0)[..., None]
    out = _u8(img * mask + out * (1 - mask))
    return out, boxes, pasted


def negative_image(rng: np.random.Generator, h: int, w: int, real: Sequence[np.ndarray] = ()) -> np.ndarray:
    """An image with none of the classes: a real photo (random crop, scale, flip) or a texture,
    with distractors and camera effects."""
    if len(real) and rng.random() < 0.6:
        photo = real[int(rng.integers(len(real)))]
        ph, pw = photo.shape[:2]
        s = rng.uniform(0.5, 1.0)
        cw, ch = int(pw * s), int(ph * s)
        x, y = int(rng.integers(0, pw - cw + 1)), int(rng.integers(0, ph - ch + 1))
        img = cv2.resize(photo[y:y + ch, x:x + cw], (w, h), interpolation=cv2.INTER_AREA)
        if rng.random() < 0.5:
            img = img[:, ::-1].copy()
    else:
        img = texture(rng, h, w)
    img = draw_distractors(rng, img, np.zeros((0, 4)), int(rng.integers(0, 6)))
    return camera_effects(rng, img)


def randomise(rng: np.random.Generator, img: np.ndarray, boxes: np.ndarray, labels: np.ndarray,
              difficult: np.ndarray, real: Sequence[np.ndarray] = (), strength: float = 1.0,
              distractors: bool = True):
    """One domain-randomised copy of a letterboxed render: (image, boxes, labels, difficult)."""
    h, w = img.shape[:2]
    boxes = np.asarray(boxes, np.float32).reshape(-1, 4)
    if len(boxes) and rng.random() < 0.25 * strength:  # the objects on another background
        if len(real) and rng.random() < 0.5:
            bg = negative_image(rng, h, w, real)
        else:
            bg = texture(rng, h, w)
        img, boxes, pasted = paste_on_background(rng, img, boxes, ~np.asarray(difficult, bool), bg)
        labels, difficult = labels[pasted], difficult[pasted]
        boxes = boxes[pasted]
    if distractors and rng.random() < 0.6 * strength:
        img = draw_distractors(rng, img, boxes, int(rng.integers(1, 5)))
    if rng.random() < 0.4 * strength:
        img, boxes = distort_lens(rng, img, boxes)
    img = camera_effects(rng, img, strength)
    return img, boxes, labels, difficult
