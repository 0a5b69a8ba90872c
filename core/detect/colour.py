"""Colour blobs: named HSV ranges, morphology, connected outlines, largest first.

Hue is OpenCV's 0 … 179 (degrees / 2), saturation and value 0 … 255. A range whose ``h_lo`` is
greater than its ``h_hi`` wraps around 0 (red: 170 … 179 and 0 … 8).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import cv2
import numpy as np

from core.detect.base import BaseDetector, Detection, check_image, options_factory
from core.settings import SettingsError, check_range

HUE_MAX = 179  # OpenCV 8-bit hue: 0 … 179


@dataclass(frozen=True)
class HsvRange:
    """A named colour: an HSV box (hue wraps around 0 when ``h_lo > h_hi``)."""

    name: str  # what detections of this colour are labelled, e.g. "red"
    h_lo: int  # hue low, 0 … 179
    s_lo: int  # saturation low, 0 … 255
    v_lo: int  # value low, 0 … 255
    h_hi: int  # hue high, 0 … 179 (below h_lo: the range wraps through 0)
    s_hi: int = 255  # saturation high, s_lo … 255
    v_hi: int = 255  # value high, v_lo … 255

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip() or any(c in self.name for c in "=,"):
            raise SettingsError(f"colour.name = {self.name!r} must be a non-empty name without '=' or ','")
        for field, hi in (("h_lo", HUE_MAX), ("h_hi", HUE_MAX), ("s_lo", 255), ("s_hi", 255), ("v_lo", 255), ("v_hi", 255)):
            value = getattr(self, field)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise SettingsError(f"colour {self.name}.{field} = {value!r} must be a whole number 0…{hi}")
            check_range(f"colour {self.name}", field, int(value), 0, hi)
            object.__setattr__(self, field, int(value))
        if self.s_lo > self.s_hi:
            raise SettingsError(f"colour {self.name}: s_lo = {self.s_lo} is above s_hi = {self.s_hi}")
        if self.v_lo > self.v_hi:
            raise SettingsError(f"colour {self.name}: v_lo = {self.v_lo} is above v_hi = {self.v_hi}")

    @property
    def wraps(self) -> bool:
        """True when the hue range passes through 0 (h_lo > h_hi), as red's does."""
        return self.h_lo > self.h_hi

    def mask(self, hsv: np.ndarray) -> np.ndarray:
        """255 where an HSV image (OpenCV 8-bit) lies in this range, else 0."""
        if not self.wraps:
            return cv2.inRange(hsv, (self.h_lo, self.s_lo, self.v_lo), (self.h_hi, self.s_hi, self.v_hi))
        return cv2.inRange(hsv, (self.h_lo, self.s_lo, self.v_lo), (HUE_MAX, self.s_hi, self.v_hi)) | \
            cv2.inRange(hsv, (0, self.s_lo, self.v_lo), (self.h_hi, self.s_hi, self.v_hi))

    def text(self) -> str:
        """``NAME=HLO,SLO,VLO,HHI,SHI,VHI`` (what ``parse_hsv_range`` reads)."""
        return f"{self.name}={self.h_lo},{self.s_lo},{self.v_lo},{self.h_hi},{self.s_hi},{self.v_hi}"


def parse_hsv_range(text: str) -> HsvRange:
    """``"red=170,120,70,8,255,255"`` (NAME=HLO,SLO,VLO,HHI,SHI,VHI) -> HsvRange; ValueError otherwise."""
    name, sep, values = str(text).partition("=")
    parts = [p.strip() for p in values.split(",")]
    if not sep or not name.strip() or len(parts) != 6:
        raise ValueError(f"colour {text!r} is not NAME=HLO,SLO,VLO,HHI,SHI,VHI, e.g. red=170,120,70,8,255,255")
    try:
        numbers = [int(p) for p in parts]
    except ValueError:
        raise ValueError(f"colour {text!r}: the six values must be whole numbers (hue 0…179, S and V 0…255)") from None
    h_lo, s_lo, v_lo, h_hi, s_hi, v_hi = numbers
    return HsvRange(name.strip(), h_lo, s_lo, v_lo, h_hi, s_hi, v_hi)


# Defaults for saturated, reasonably lit objects. Red is BallFinder's (core.motion.targeting).
# Orange, purple and pink were measured on the simulated desk (objects scenario, 60 views, arm
# and hand in view: each found its object in every view where it is ≥ 70 % visible, no blob
# elsewhere). The wood there is H 10…16 at S ≤ ~130 (rarely 186), so orange needs S ≥ 185; the
# arm's tool tip is orange too but fully saturated (S ≥ 250 inside its outline), so orange stops
# at S 238 — a tool tip must never be taken for an object the arm then follows. Pink (a pale
# magenta, S ~107) sits between purple (H ~147) and red (from 172).
DEFAULT_COLOURS = (
    HsvRange("red", 172, 120, 70, 8),
    HsvRange("orange", 9, 185, 100, 20, 238, 255),
    HsvRange("yellow", 22, 120, 100, 34),
    HsvRange("green", 40, 80, 50, 85),
    HsvRange("blue", 95, 120, 50, 130),
    HsvRange("purple", 135, 90, 50, 156),
    HsvRange("pink", 157, 60, 120, 171),
)


@dataclass(frozen=True)
class HsvParams:
    """Settings of ``HsvDetector``."""

    colours: tuple[HsvRange, ...] = DEFAULT_COLOURS  # named colours to look for, ≥ 1, unique names
    open_px: int = 3  # opening kernel (ellipse) against speckles, px, 0 (off) … 31
    close_px: int = 5  # closing kernel (ellipse) filling holes and highlights, px, 0 (off) … 31
    min_area_px: float = 30.0  # smallest blob kept, px², 0 … 10_000_000
    max_objects: int = 10  # most blobs reported per colour (largest first), 1 … 1000

    def __post_init__(self) -> None:
        colours = tuple(self.colours) if not isinstance(self.colours, HsvRange) else (self.colours,)
        if not colours:
            raise SettingsError("hsv.colours is empty: give at least one colour (NAME=HLO,SLO,VLO,HHI,SHI,VHI)")
        for c in colours:
            if not isinstance(c, HsvRange):
                raise SettingsError(f"hsv.colours must hold HsvRange values, not {type(c).__name__}")
        names = [c.name for c in colours]
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            raise SettingsError(f"hsv.colours names {', '.join(dupes)} more than once: names must be unique")
        object.__setattr__(self, "colours", colours)
        for field, hi in (("open_px", 31), ("close_px", 31), ("max_objects", 1000)):
            value = getattr(self, field)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise SettingsError(f"hsv.{field} = {value!r} must be a whole number")
        check_range("hsv", "open_px", self.open_px, 0, 31)
        check_range("hsv", "close_px", self.close_px, 0, 31)
        check_range("hsv", "min_area_px", self.min_area_px, 0.0, 10_000_000.0)
        check_range("hsv", "max_objects", self.max_objects, 1, 1000)


def _bit_luts(colours: tuple[HsvRange, ...]) -> list[tuple[int, np.ndarray]]:
    """Per group of 8 colours (first index, 1x256x3 table): bit k of entry [h, s, v] of channel 0, 1,
    2 is set when h, s, v lies in colour first + k's hue (wrapping), saturation, value range; a
    pixel whose three looked-up channels all have bit k is exactly where ``HsvRange.mask`` is 255."""
    out = []
    for first in range(0, len(colours), 8):
        lut = np.zeros((1, 256, 3), np.uint8)
        for k, c in enumerate(colours[first:first + 8]):
            bit = np.uint8(1 << k)
            if c.wraps:
                lut[0, c.h_lo:HUE_MAX + 1, 0] |= bit
                lut[0, :c.h_hi + 1, 0] |= bit
            else:
                lut[0, c.h_lo:c.h_hi + 1, 0] |= bit
            lut[0, c.s_lo:c.s_hi + 1, 1] |= bit
            lut[0, c.v_lo:c.v_hi + 1, 2] |= bit
        out.append((first, lut))
    return out


def _kernel(size: int) -> Optional[np.ndarray]:
    return None if size <= 1 else cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))


# The half-size search (issue 28: a Pi 4 budget). Colours are first looked for in the image shrunk
# to half its size (INTER_AREA: each pixel the mean of a 2x2 block), a quarter of the pixels to
# convert and classify; the masks are then made, opened, closed and outlined at full size only in
# a box around each patch found there, so the blobs and their outlines are those of the
# full-size search wherever the half-size image shows the blob at all (tests/detect/
# test_colour_regions.py: identical on the simulated desk, its webcam-like renders, blurred noise
# and the real photos). A blob that survives a 3 px opening and is 16 px² or more nearly always
# holds a whole 2x2 block of its colour, whose mean the half-size image keeps in range; one that
# does not (a thin diagonal chain, a 2x2 mean leaving a narrow range) can be missed. So the
# half-size search is used only with ``open_px`` ≥ HALF_SIZE_MIN_OPEN_PX and ``min_area_px`` ≥
# HALF_SIZE_MIN_AREA_PX, and the whole image is searched at full size otherwise.
HALF_SIZE_MIN_OPEN_PX = 3
HALF_SIZE_MIN_AREA_PX = 16.0
HALF_SIZE_MIN_SIDE_PX = 16  # a smaller image (an ROI) is searched at full size
HALF_SIZE_MAX_BOXES = 12  # a colour found in more patches than this: one box around them all


class HsvDetector(BaseDetector):
    """Blobs of named HSV colours, largest first (across colours), at most ``max_objects`` per colour.

    Each detection carries its outline (``contour``), bounding box, centroid (image moments of
    the outline) and the radius of its enclosing circle. ``score`` is the blob's solidity (area
    / convex-hull area): 1 for a disc or a square, lower for ragged or stringy blobs.
    """

    name = "hsv"
    params_type = HsvParams

    def __init__(self, params: Optional[HsvParams] = None):
        super().__init__(params)
        p = self._params
        self._open = _kernel(p.open_px)
        self._close = _kernel(p.close_px)
        # a region's margin around its colour's pixels: the opening and the closing together reach
        # 2·(open radius + close radius) px (their erosions, at the region's edge, must see only
        # pixels that are 0 in the whole image too), and the outlines need a row of 0 around them
        self._margin = p.open_px + p.close_px + 2
        self._luts = _bit_luts(p.colours)
        # detect() searches a half-size image first (see HALF_SIZE_MIN_OPEN_PX); masks() never does
        self.half_size = p.open_px >= HALF_SIZE_MIN_OPEN_PX and p.min_area_px >= HALF_SIZE_MIN_AREA_PX

    def masks(self, image_bgr: np.ndarray) -> dict[str, np.ndarray]:
        """Each colour's cleaned mask (after opening and closing) of a whole image, by name (the
        full-size search: every pixel)."""
        image = _bgr(image_bgr)
        out = {c.name: np.zeros(image.shape[:2], np.uint8) for c in self._params.colours}
        for name, cleaned, x0, y0 in self._regions(image):
            out[name][y0:y0 + cleaned.shape[0], x0:x0 + cleaned.shape[1]] = cleaned
        return out

    @staticmethod
    def _bits(hsv: np.ndarray, lut: np.ndarray) -> np.ndarray:
        """Bit k set where the pixel is in colour first + k's range (``_bit_luts``): all 8 colours of a
        group in one table look-up and two ANDs instead of 8 inRange passes over the image."""
        h_bits, s_bits, v_bits = cv2.split(cv2.LUT(hsv, lut))
        return cv2.bitwise_and(cv2.bitwise_and(h_bits, s_bits), v_bits)

    def _regions(self, image: np.ndarray) -> list[tuple[str, np.ndarray, int, int]]:
        """Each colour's cleaned mask around its pixels only: (name, mask of a region, region x0, y0),
        for the colours present.

        The opening and closing run on the bounding box of the colour's pixels grown by
        ``_margin`` (none when there are none), not on the whole image: most colours are absent or small
        in a view, and the morphology on whole masks was most of this detector's time. Outside
        that box the whole-image result is 0 too, so the outlines are the same (see _margin)."""
        hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
        h_img, w_img = hsv.shape[:2]
        out = []
        colours = self._params.colours
        m = self._margin
        for first, lut in self._luts:
            bits = self._bits(hsv, lut)
            for k, colour in enumerate(colours[first:first + 8]):
                mask = cv2.bitwise_and(bits, 1 << k)  # 1 << k where in range, else 0
                x, y, w, h = cv2.boundingRect(mask)  # of the non-zero pixels; 0 wide when there are none
                if w == 0 or h == 0:
                    continue
                x0, y0, x1, y1 = max(x - m, 0), max(y - m, 0), min(x + w + m, w_img), min(y + h + m, h_img)
                _, region = cv2.threshold(mask[y0:y1, x0:x1], 0, 255, cv2.THRESH_BINARY)
                out.append((colour.name, *self._cleaned(region, x0, y0)))
        return out

    def _half_size_regions(self, image: np.ndarray) -> list[tuple[str, np.ndarray, int, int]]:
        """``_regions``' masks around each patch of a colour that the half-size image shows (see
        HALF_SIZE_MIN_OPEN_PX): (name, cleaned mask of a box, box x0, y0), boxes of one colour apart."""
        h_img, w_img = image.shape[:2]
        small = cv2.resize(image, (w_img // 2, h_img // 2), interpolation=cv2.INTER_AREA)
        hsv = cv2.cvtColor(small, cv2.COLOR_BGR2HSV)
        sx, sy = w_img / small.shape[1], h_img / small.shape[0]  # 2, or a little more for odd sides
        # a full-size pixel of the colour lies within one half-size pixel of a patch (its block
        # mixed with the background there may be out of range); then the morphology's margin
        m = self._margin + 2
        out = []
        colours = self._params.colours
        for first, lut in self._luts:
            bits = self._bits(hsv, lut)
            for k, colour in enumerate(colours[first:first + 8]):
                mask = cv2.bitwise_and(bits, 1 << k)
                whole = cv2.boundingRect(mask)
                if whole[2] == 0 or whole[3] == 0:
                    continue
                patches, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
                rects = [whole] if len(patches) > HALF_SIZE_MAX_BOXES else [cv2.boundingRect(c) for c in patches]
                boxes = _merged([(max(int(x * sx) - m, 0), max(int(y * sy) - m, 0),
                                  min(int(math.ceil((x + w) * sx)) + m, w_img), min(int(math.ceil((y + h) * sy)) + m, h_img))
                                 for x, y, w, h in rects])
                for x0, y0, x1, y1 in boxes:  # one colour in a small box: one inRange beats the table
                    region = colour.mask(cv2.cvtColor(image[y0:y1, x0:x1], cv2.COLOR_BGR2HSV))
                    out.append((colour.name, *self._cleaned(region, x0, y0)))
        return out

    def _cleaned(self, region: np.ndarray, x0: int, y0: int) -> tuple[np.ndarray, int, int]:
        """A colour's region mask (255 in range) opened and closed: (mask, x0, y0)."""
        if self._open is not None:
            region = cv2.morphologyEx(region, cv2.MORPH_OPEN, self._open)
        if self._close is not None:
            region = cv2.morphologyEx(region, cv2.MORPH_CLOSE, self._close)
        return region, x0, y0

    def _detect(self, image: np.ndarray, half_size: Optional[bool] = None) -> list[Detection]:
        p = self._params
        image = _bgr(image)
        if half_size is None:
            half_size = self.half_size
        if half_size and min(image.shape[:2]) >= HALF_SIZE_MIN_SIDE_PX:
            regions = self._half_size_regions(image)
        else:
            regions = self._regions(image)
        blobs_of: dict[str, list] = {}
        for name, region, x0, y0 in regions:
            contours, _ = cv2.findContours(region, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE, offset=(x0, y0))
            blobs = blobs_of.setdefault(name, [])
            for contour in contours:
                m = cv2.moments(contour)
                area = m["m00"]
                if area <= 0.0 or area < p.min_area_px:
                    continue
                blobs.append((area, m, contour))
        found: list[tuple[float, Detection]] = []
        for colour in p.colours:  # the colours' order, as one whole-image region per colour gave
            blobs = blobs_of.get(colour.name)
            if not blobs:
                continue
            blobs.sort(key=lambda b: -b[0])
            for area, m, contour in blobs[: p.max_objects]:
                pts = contour.reshape(-1, 2).astype(np.float64)
                hull_area = cv2.contourArea(cv2.convexHull(contour))
                (_, _), radius = cv2.minEnclosingCircle(contour)
                x, y, w, h = cv2.boundingRect(contour)
                found.append((area, Detection(
                    kind="colour", label=colour.name,
                    score=min(1.0, area / hull_area) if hull_area > 0 else 0.0,
                    box=(x, y, w, h), centre_px=(m["m10"] / area, m["m01"] / area),
                    radius_px=radius, contour=pts,
                )))
        found.sort(key=lambda f: -f[0])
        return [d for _, d in found]


def _bgr(image_bgr: np.ndarray) -> np.ndarray:
    """A checked image as BGR (a grey one converted)."""
    image = check_image(image_bgr)
    return cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image


def _merged(boxes: list[tuple[int, int, int, int]]) -> list[tuple[int, int, int, int]]:
    """Boxes (x0, y0, x1, y1) that overlap or touch replaced by their union until none do."""
    boxes = list(boxes)
    merged = True
    while merged:
        merged = False
        for i in range(len(boxes)):
            a = boxes[i]
            for j in range(i + 1, len(boxes)):
                b = boxes[j]
                if a[0] <= b[2] and b[0] <= a[2] and a[1] <= b[3] and b[1] <= a[3]:
                    boxes[i] = (min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3]))
                    del boxes[j]
                    merged = True
                    break
            if merged:
                break
    return boxes


def _circular_median_hue(h: np.ndarray) -> float:
    """Median of hues (0 … 179) taken around their circular mean, so red near 0/179 works."""
    angles = h.astype(np.float64) * (2.0 * math.pi / 180.0)
    mean = math.atan2(np.sin(angles).mean(), np.cos(angles).mean()) * 180.0 / (2.0 * math.pi)
    diffs = (h.astype(np.float64) - mean + 90.0) % 180.0 - 90.0
    return float((mean + np.median(diffs)) % 180.0)


def colour_from_pixel(image_bgr: np.ndarray, x: float, y: float, tolerance: int = 10,
                      name: str = "picked", patch_px: int = 2) -> HsvRange:
    """The colour of the object at pixel (x, y): a range around the median HSV of a small patch.

    The patch is (2 · ``patch_px`` + 1)² pixels (clipped to the image). The range is hue ±
    ``tolerance`` (wrapping through 0 for red), saturation from half the picked value up and value
    from 40 % of the picked value up, so the shaded side of a lit object still matches.
    A nearly grey pick (saturation < 40) has no meaningful hue: any hue, saturation up to
    picked + 40, value ± 4 · ``tolerance``. ValueError for a pixel outside the image.
    """
    image = check_image(image_bgr)
    if image.ndim == 2:
        image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    check_range("colour_from_pixel", "tolerance", tolerance, 1, 89)
    H, W = image.shape[:2]
    xi, yi = int(round(x)), int(round(y))
    if not (0 <= xi < W and 0 <= yi < H):
        raise ValueError(f"pixel ({x}, {y}) is outside the {W}x{H} image")
    r = max(0, int(patch_px))
    patch = image[max(0, yi - r):yi + r + 1, max(0, xi - r):xi + r + 1]
    hsv = cv2.cvtColor(patch, cv2.COLOR_BGR2HSV).reshape(-1, 3)
    s = float(np.median(hsv[:, 1]))
    v = float(np.median(hsv[:, 2]))
    tol = int(tolerance)
    if s < 40:
        return HsvRange(name, 0, 0, int(max(0, v - 4 * tol)), HUE_MAX,
                        int(min(255, s + 40)), int(min(255, v + 4 * tol)))
    h = _circular_median_hue(hsv[:, 0])
    h_lo = int(round(h - tol)) % 180
    h_hi = int(round(h + tol)) % 180
    return HsvRange(name, h_lo, int(s * 0.5), int(v * 0.4), h_hi, 255, 255)


def make_hsv(**options) -> HsvDetector:
    """Registry factory: ``HsvDetector(HsvParams(**options))`` (``colours`` may be texts "NAME=…")."""
    if "colours" in options:
        colours = options["colours"]
        colours = (colours,) if isinstance(colours, (str, HsvRange)) else tuple(colours)
        options["colours"] = tuple(parse_hsv_range(c) if isinstance(c, str) else c for c in colours)
    return options_factory(HsvDetector, HsvParams, "hsv")(**options)
