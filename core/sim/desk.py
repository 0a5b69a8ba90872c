"""The simulated desk: renders what the simulated stereo rig sees, with exact ground truth.

A wood-textured desk (warped once per camera and cached), ArUco markers lying on it or on
upside-down cups, a ball, marker-less things (shaded balls, a plush, discs, cups), lift panels
(a brushed-steel plate whose 9 buttons carry digit textures) and door handles, a passing hand
and the arm drawn from its chain points — painted far to near — then the camera's image controls
(one LUT), lens blur and sensor noise.

Truth per object: ``render``/``truth`` give each object's 3D point and whether it is fully in
view and uncovered; ``image_boxes`` gives the pixel box of what is visible of it in each view
(for training and scoring detectors).

Geometry is exact: a marker corner at robot_base point P lands at ``rig.project(side, P)``
(OpenCV's pixel-centre convention, pixel (0, 0) centred at 0.0). Markers are warped from a
texture into a 3× supersampled patch and area-averaged, so their edges carry sub-pixel coverage.
(ArUco's CORNER_REFINE_CONTOUR puts corners ~0.5 px inside each edge — ~0.75 px along the
diagonal — on these exact edges; marker centres come out within ~0.1 px.)

Sensor noise is luma noise (one cv2.randn value per pixel, added to all three channels),
seeded by (seed, t, side), so a render is reproducible.
Scenarios (what moves where) live in ``core.sim.scenarios``.
"""
from __future__ import annotations

import functools
import math
import struct
import threading
import zlib
from dataclasses import dataclass, field
from typing import Optional, Sequence, Union

import cv2
import numpy as np

from core.messages import GroundTruth, ObjectTruth, StereoFrame
from core.settings import CameraSettings
from core.sim.rig import SimRig
from core.sim.scenarios import (
    BALL_RADIUS_M,
    CUP_HEIGHT_M,
    CUP_RIM_RADIUS_M,
    CUP_TOP_RADIUS_M,
    SCENARIOS,
    Card,
    Cup,
    DoorHandle,
    Hand,
    Panel,
    Scenario,
    SceneState,
    Thing,
    WRISTBAND_WIDTH_M,
    Wristband,
    make_scenario,
    scenario_names,
)

__all__ = ["SimDesk", "ImageBox", "SCENARIOS", "scenario_names", "desk_texture", "panel_texture", "button_texture"]

SIDES = ("left", "right")

# desk texture: it covers what the rig sees of the desk (up to DESK_MAX_RANGE_M from the
# cameras), at DESK_M_PER_PX or coarser so it stays under DESK_MAX_TEXTURE_PX on a side
DESK_M_PER_PX = 0.00125
DESK_MAX_RANGE_M = 2.0
DESK_MAX_TEXTURE_PX = 2048
WALL_COLOUR = (150, 155, 158)  # above the horizon (only with rigs that look that far up)

SUPERSAMPLE = 4  # textures (the panel's buttons) are warped at 4× and area-averaged (anti-aliased edges)
# markers are warped at 3×: a moving marker is warped every frame, and 3× warps 9/16 of 4×'s pixels
# with the same accuracy (wander, 540 ArUco detections: corners 0.78 px from the truth on average,
# 0.79 at 4× — the CONTOUR refinement's known inset —, centres 0.038 px at both); 2× moved the
# corners 0.04 px further out. Edges differ from 4×'s by at most 12 levels.
MARKER_SUPERSAMPLE = 3
THING_CACHE = 256  # still things' items (per view) and shadows kept (SimDesk._cached_thing_item)
MARKER_PATCH_CACHE = 32  # warped marker patches kept for markers that lie still (SimDesk._composite_marker)
SHADOW_CACHE = 64  # per view: blurred patches of still shadow groups, projections of still shadows (_draw_shadows)
AA_MARGIN_PX = 2  # an anti-aliased fill or line changes pixels at most this far outside its outline's bounds
MARKER_PX_PER_CELL = 16  # marker texture resolution (8 cells + white border → 160 px wide)
MARKER_BORDER_CELLS = 1.0  # white quiet zone around the black border, in marker cells
MARKER_BLACK = 28  # printed black and paper white, 8-bit levels before the camera LUT
MARKER_WHITE = 226
NOISE_SHIFTS = 64  # the noise field is this much larger than an image each way (64² offsets)
EDGE_MARGIN_PX = 3.0  # a marker counts as inside an image when its corners keep this margin

# light: a lamp above, a little to the left and towards the user (unit vector to the light)
LIGHT = np.array([-0.35, -0.25, 1.0]) / np.linalg.norm([-0.35, -0.25, 1.0])
AMBIENT = 0.45
SHADOW_DARKNESS = 0.38  # fraction of light a full shadow removes
SHADOW_BLUR_PX = 2.0
NEAR_M = 0.02  # near clipping plane of the virtual cameras

CUP_COLOUR = (175, 105, 40)  # BGR, blue plastic
CUP_TOP_COLOUR = (195, 130, 70)
CUP_STRIPS = 36
CUP_SHADE_LEVELS = 24  # shading steps across a cup's side (runs of strips share one)
BALL_COLOUR = (38, 38, 205)  # BGR, red
BALL_HIGHLIGHT = (170, 170, 245)  # the red ball's specular spot
HIGHLIGHT_MIX = 0.6  # other things' specular spot: this far from their colour towards white
PLUSH_GLOSS = 0.35  # the plush's spot is duller (fabric): this far towards white
ARM_LINK_COLOUR = (178, 180, 184)  # aluminium
ARM_LINK_HIGHLIGHT = (228, 230, 234)
ARM_LINK_EDGE = (92, 94, 98)
ARM_JOINT_COLOUR = (36, 36, 40)  # black servo horns
ARM_BASE_COLOUR = (58, 58, 62)
ARM_TOOL_COLOUR = (0, 150, 255)  # orange tool tip
HAND_COLOUR = (130, 148, 172)  # greyish skin
HAND_DARK = (100, 116, 138)
WRISTBAND_COLOUR = (60, 52, 48)  # the teleop hand's dark cloth band (its marker is printed on it)

PANEL_METAL = 176  # brushed steel plate, grey level of its top before shading
PANEL_SIDE_COLOUR = (150, 152, 156)
PANEL_EDGE_COLOUR = (88, 90, 94)
PANEL_TEXTURE_M_PER_PX = 0.0004  # the plate's texture resolution (0.4 mm)
PANEL_SUPERSAMPLE = 2
BUTTON_TEXTURE_PX = 96  # a button face's texture is this many px across
BUTTON_FACE = (40, 38, 36)  # BGR, dark face
BUTTON_RING = (222, 222, 224)  # bright chrome ring
BUTTON_RING_LIT = (60, 190, 255)  # amber: the lit (selected) ring
BUTTON_DIGIT = (250, 250, 250)
BUTTON_RING_FRAC = 0.78  # the ring spans this fraction of the radius … 1
BUTTON_SIDE_COLOUR = (110, 112, 116)
HANDLE_COLOUR = (172, 174, 178)  # satin stainless
HANDLE_HIGHLIGHT = (232, 233, 236)
HANDLE_EDGE = (84, 86, 90)

ARM_BASE_RADIUS_M = 0.045
ARM_LINK_RADII_M = (0.021, 0.014, 0.011)  # base tower, upper arm, forearm (last repeats)
ARM_JOINT_RADIUS_M = 0.017
ARM_TOOL_RADIUS_M = 0.012


# ----------------------------------------------------------------------------------------------
# textures


# 16: the detector dataset's hand-camera views cycle through 12 training desks, each a texture of
# its own (~3.5 MB, ~0.2 s to make); 4 made every hand view pay for a new one
@functools.lru_cache(maxsize=16)
def desk_texture(seed: int = 0, x_range=(-0.5, 0.5), y_range=(-0.3, 0.7),
                 m_per_px: float = DESK_M_PER_PX) -> np.ndarray:
    """The desk's wood-like texture, BGR uint8, covering x_range × y_range (robot_base, m).

    Row 0 is the far (+y) edge, column 0 the −x edge: seen from above it reads like a map.
    Random (aperiodic) multi-scale noise so stereo block matching finds texture everywhere:
    grain along y (across the rig's horizontal epipolar lines), mottling and fine speckle.
    """
    w = int(round((x_range[1] - x_range[0]) / m_per_px))
    h = int(round((y_range[1] - y_range[0]) / m_per_px))
    rng = np.random.default_rng([seed & 0x7FFFFFFF, 1234])
    k = DESK_M_PER_PX / m_per_px  # feature sizes are set in metres: sigmas at the finest scale

    def noise(sx: float, sy: float) -> np.ndarray:
        # smooth noise is drawn on a coarse grid and scaled up: the same look, far cheaper
        sx, sy = sx * k, sy * k
        fx, fy = max(1, int(sx / 2)), max(1, int(sy / 2))
        n = rng.standard_normal((-(-h // fy), -(-w // fx))).astype(np.float32)
        n = cv2.GaussianBlur(n, (0, 0), sigmaX=max(sx / fx, 0.3), sigmaY=max(sy / fy, 0.3),
                             borderType=cv2.BORDER_REFLECT)
        if fx > 1 or fy > 1:
            n = cv2.resize(n, (n.shape[1] * fx, n.shape[0] * fy), interpolation=cv2.INTER_CUBIC)[:h, :w]
        return n / (float(n.std()) + 1e-9)

    grain = noise(1.0, 30.0)  # long thin streaks along y: wood grain
    bands = noise(7.0, 90.0)  # wider growth bands
    mottle = noise(10.0, 10.0)
    blotch = noise(45.0, 45.0)
    fine = noise(0.7, 0.7)
    v = 0.30 * grain + 0.45 * bands + 0.25 * mottle + 0.20 * blotch + 0.28 * fine
    # lamp fall-off across the desk (world-fixed, so both cameras agree)
    xs = x_range[0] + (np.arange(w, dtype=np.float32) + 0.5) * m_per_px
    ys = y_range[1] - (np.arange(h, dtype=np.float32) + 0.5) * m_per_px
    r2 = (xs[None, :] + 0.05) ** 2 + (ys[:, None] - 0.10) ** 2
    light = 0.72 + 0.36 * np.exp(-r2 / (2 * 0.32**2))
    base = np.array([92, 138, 182], np.float32)  # BGR, light oak
    tint = np.array([0.9, 1.0, 1.05], np.float32)  # darker streaks are a little redder
    img = base * light[..., None] * (1.0 + 0.11 * v[..., None] * tint)
    return np.clip(img + 0.5, 0, 255).astype(np.uint8)


def desk_extent(rig: SimRig) -> tuple[tuple[float, float], tuple[float, float], float]:
    """(x_range, y_range, m_per_px) of a desk texture covering what both cameras see."""
    w, h = rig.size
    u = np.concatenate([np.linspace(0, w - 1, 17), np.full(13, w - 1.0), np.linspace(w - 1, 0, 17), np.zeros(13)])
    v = np.concatenate([np.zeros(17), np.linspace(0, h - 1, 13), np.full(17, h - 1.0), np.linspace(h - 1, 0, 13)])
    pix = np.stack([u, v, np.ones_like(u)])
    pts = []
    for base_T_cam in (rig.base_T_left, rig.base_T_right):
        c = base_T_cam[:3, 3]
        d = base_T_cam[:3, :3] @ np.linalg.inv(rig.K) @ pix  # ray directions, robot_base
        for ray in d.T:
            horiz = ray[:2] / (np.linalg.norm(ray[:2]) + 1e-12)
            s = -c[2] / ray[2] if ray[2] < -1e-9 else np.inf
            p = c[:2] + s * ray[:2] if np.isfinite(s) else c[:2] + DESK_MAX_RANGE_M * horiz
            if np.linalg.norm(p - c[:2]) > DESK_MAX_RANGE_M:
                p = c[:2] + DESK_MAX_RANGE_M * horiz
            pts.append(p)
    pts = np.array(pts)
    lo = np.floor((pts.min(axis=0) - 0.05) * 20) / 20  # 5 cm margin, on a 5 cm grid (cache hits)
    hi = np.ceil((pts.max(axis=0) + 0.05) * 20) / 20
    m_per_px = max(DESK_M_PER_PX, float(np.max(hi - lo)) / DESK_MAX_TEXTURE_PX)
    return (float(lo[0]), float(hi[0])), (float(lo[1]), float(hi[1])), m_per_px


def marker_texture(dictionary, marker_id: int, clip_radius_frac: Optional[float] = None) -> np.ndarray:
    """Premultiplied BGRA texture of a marker on white paper (border MARKER_BORDER_CELLS cells).

    Row 0 is the marker's top edge (generateImageMarker's orientation). With ``clip_radius_frac``
    the paper is cut to a disc of that radius (fraction of the texture's half width).
    """
    cells = 8  # 6×6 data cells + the one-cell black border
    side = cells * MARKER_PX_PER_CELL
    marker = cv2.aruco.generateImageMarker(dictionary, int(marker_id), side, borderBits=1)
    b = int(round(MARKER_BORDER_CELLS * MARKER_PX_PER_CELL))
    marker = cv2.copyMakeBorder(marker, b, b, b, b, cv2.BORDER_CONSTANT, value=255)
    grey = np.where(marker > 127, MARKER_WHITE, MARKER_BLACK).astype(np.float32)
    n = marker.shape[0]
    alpha = np.ones((n, n), np.float32)
    if clip_radius_frac is not None:
        c = (n - 1) / 2.0
        yy, xx = np.mgrid[0:n, 0:n].astype(np.float32)
        dist = np.hypot(xx - c, yy - c)
        alpha = np.clip(clip_radius_frac * n / 2.0 - dist + 0.5, 0.0, 1.0)
    bgra = np.empty((n, n, 4), np.float32)
    bgra[..., 0] = bgra[..., 1] = bgra[..., 2] = grey * alpha
    bgra[..., 3] = 255.0 * alpha
    return np.clip(bgra + 0.5, 0, 255).astype(np.uint8)


@functools.lru_cache(maxsize=8)
def panel_texture(panel_key: tuple, m_per_px: float = PANEL_TEXTURE_M_PER_PX) -> tuple[np.ndarray, np.ndarray]:
    """(premultiplied BGRA texture, A) of a panel plate's top face: brushed steel, a dark gap
    round each button's hole, a screw in each corner, a bevelled edge.

    ``panel_key``: (width_m, length_m, button_radius_m, ((u, v) of each button)). Row 0 is the
    plate's +v edge, column 0 its −u edge; ``A`` maps texel (col, row, 1) to the panel frame (u, v, 1).
    """
    width, length, radius, holes = panel_key
    w, h = int(round(width / m_per_px)), int(round(length / m_per_px))
    rng = np.random.default_rng(77)
    # brushing: fine streaks along u (rows differ, columns barely), a slow sheen across the plate
    streaks = rng.standard_normal((h, max(8, w // 24))).astype(np.float32)
    streaks = cv2.resize(streaks, (w, h), interpolation=cv2.INTER_LINEAR)
    streaks = cv2.GaussianBlur(streaks, (0, 0), sigmaX=6.0, sigmaY=0.6)
    streaks /= float(streaks.std()) + 1e-9
    speck = cv2.GaussianBlur(rng.standard_normal((h, w)).astype(np.float32), (0, 0), 0.7)
    speck /= float(speck.std()) + 1e-9
    us = (np.arange(w, dtype=np.float32) + 0.5) * m_per_px - width / 2
    vs = length / 2 - (np.arange(h, dtype=np.float32) + 0.5) * m_per_px
    sheen = 1.0 + 0.06 * np.cos((us[None, :] * 0.6 + vs[:, None]) / length * 2 * math.pi)
    grey = PANEL_METAL * sheen * (1.0 + 0.045 * streaks + 0.02 * speck)
    bgr = np.stack([grey * 1.02, grey, grey * 0.98], axis=-1)  # a cool steel tint
    # bevel: a darker and a lighter strip along the edges
    bevel = max(2, int(round(0.0015 / m_per_px)))
    bgr[:bevel, :] *= 1.12
    bgr[:, :bevel] *= 1.08
    bgr[-bevel:, :] *= 0.80
    bgr[:, -bevel:] *= 0.84

    def at(u: float, v: float) -> tuple[float, float]:
        return ((u + width / 2) / m_per_px - 0.5, (length / 2 - v) / m_per_px - 0.5)

    img = np.ascontiguousarray(np.clip(bgr, 0, 255)).astype(np.float32)
    sh = 4  # fixed-point bits for sub-texel circles
    for u, v in holes:  # the gap between a button and its hole: a dark ring, a lighter lip
        cu, cv_ = at(u, v)
        centre = (int(round(cu * 16)), int(round(cv_ * 16)))
        cv2.circle(img, centre, int(round((radius + 0.0022) / m_per_px * 16)), (150, 152, 156), -1, cv2.LINE_AA, sh)
        cv2.circle(img, centre, int(round((radius + 0.0012) / m_per_px * 16)), (38, 38, 40), -1, cv2.LINE_AA, sh)
    for su in (-1, 1):
        for sv in (-1, 1):
            cu, cv_ = at(su * (width / 2 - 0.008), sv * (length / 2 - 0.008))
            centre = (int(round(cu * 16)), int(round(cv_ * 16)))
            cv2.circle(img, centre, int(round(0.0028 / m_per_px * 16)), (96, 98, 100), -1, cv2.LINE_AA, sh)
            cv2.circle(img, centre, int(round(0.0022 / m_per_px * 16)), (200, 202, 204), -1, cv2.LINE_AA, sh)
            a = 0.7 * su * sv  # the screw's slot
            d = np.array([math.cos(a), math.sin(a)]) * 0.0018 / m_per_px
            p0 = (int(round((cu - d[0]) * 16)), int(round((cv_ - d[1]) * 16)))
            p1 = (int(round((cu + d[0]) * 16)), int(round((cv_ + d[1]) * 16)))
            cv2.line(img, p0, p1, (70, 70, 72), max(1, int(round(0.0006 / m_per_px))), cv2.LINE_AA, sh)
    bgra = np.dstack([img, np.full((h, w), 255.0, np.float32)])
    tex = np.clip(bgra + 0.5, 0, 255).astype(np.uint8)
    A = np.array([[m_per_px, 0.0, 0.5 * m_per_px - width / 2],
                  [0.0, -m_per_px, length / 2 - 0.5 * m_per_px],
                  [0.0, 0.0, 1.0]])
    tex.setflags(write=False)
    return tex, A


@functools.lru_cache(maxsize=32)
def button_texture(number: int, lit: bool, px: int = BUTTON_TEXTURE_PX) -> np.ndarray:
    """Premultiplied BGRA texture of a push button's round top face: a dark face, a bright ring
    (amber when lit) and the white digit ``number``, upright (row 0 is the digit's top)."""
    S = 4  # drawn at 4× and area-averaged: smooth digit edges
    n = px * S
    c = (n - 1) / 2.0
    face = np.zeros((n, n, 3), np.uint8)
    face[:] = BUTTON_FACE
    yy, xx = np.mgrid[0:n, 0:n].astype(np.float32)
    dist = np.hypot(xx - c, yy - c)
    ring = dist >= BUTTON_RING_FRAC * n / 2
    face[ring] = BUTTON_RING_LIT if lit else BUTTON_RING
    face[(dist >= BUTTON_RING_FRAC * n / 2 - 1.5 * S) & ~ring] = (20, 20, 20)  # the ring's inner edge
    text = str(int(number))
    font = cv2.FONT_HERSHEY_DUPLEX
    thick = max(1, int(round(n * 0.085)))  # bold strokes: still legible ~15 px across in a view
    _, th = cv2.getTextSize(text, font, 1.0, 1)[0]
    scale = 0.62 * n / th  # the digit is 62 % of the face's width tall
    (tw, th), _ = cv2.getTextSize(text, font, scale, thick)
    org = (int(round(c - tw / 2)), int(round(c + th / 2)))
    cv2.putText(face, text, org, font, scale, BUTTON_DIGIT, thick, cv2.LINE_AA)
    face = cv2.resize(face, (px, px), interpolation=cv2.INTER_AREA).astype(np.float32)
    cs = (px - 1) / 2.0
    yy, xx = np.mgrid[0:px, 0:px].astype(np.float32)
    alpha = np.clip(px / 2.0 - np.hypot(xx - cs, yy - cs) + 0.5, 0.0, 1.0)
    bgra = np.dstack([face * alpha[..., None], 255.0 * alpha])
    tex = np.clip(bgra + 0.5, 0, 255).astype(np.uint8)
    tex.setflags(write=False)
    return tex


# ----------------------------------------------------------------------------------------------
# per-view drawing lists


@dataclass(frozen=True)
class ImageBox:
    """Where an object is visible in one camera image (``SimDesk.image_boxes``): detector training truth.

    The box is in whole pixels, slice style: the visible pixels are ``img[y0:y1, x0:x1]`` (so
    ``x1 − x0`` is the width in px; in OpenCV's pixel-centre convention the box spans
    x0 − 0.5 … x1 − 0.5). It bounds only the part that is visible: clipped to the image and
    without what nearer things cover.
    """

    truth_id: int  # ObjectTruth.marker_id
    x0: int  # first visible column
    y0: int  # first visible row
    x1: int  # last visible column + 1
    y1: int  # last visible row + 1
    visible_fraction: float  # visible px / px of the whole silhouette (unclipped, unoccluded), 0…1
    visible_px: int  # how many pixels of the object are visible
    kind: str  # ObjectTruth.kind: "ball", "plush", "disc", "cup", "button", "handle", "marker"
    label: str  # ObjectTruth.label, e.g. "red ball", "button 5"

    @property
    def width(self) -> int:
        return self.x1 - self.x0

    @property
    def height(self) -> int:
        return self.y1 - self.y0

    @property
    def centre(self) -> tuple[float, float]:
        """The box's centre in OpenCV's pixel-centre convention (px)."""
        return ((self.x0 + self.x1) / 2 - 0.5, (self.y0 + self.y1) / 2 - 0.5)


@dataclass
class _Shape:
    pts: np.ndarray  # (M, 2) image px
    colour: tuple
    fixed: Optional[np.ndarray] = field(default=None, repr=False, compare=False)  # pts in fillPoly's 1/16 px, made once

    def fill(self, img: np.ndarray) -> None:
        """``_fill(img, pts, colour)`` (anti-aliased), the fixed-point outline kept for the next
        frame (a still thing's item is drawn again every frame)."""
        if self.fixed is None:
            self.fixed = np.round(self.pts * 16.0).astype(np.int32)
        cv2.fillPoly(img, [self.fixed], self.colour, lineType=cv2.LINE_AA, shift=4)


def _merge_boxes(boxes: list, pad: int, w: int, h: int) -> list:
    """``boxes`` grown by ``pad`` and clipped to a w×h image, empty ones dropped, two that overlap
    merged into their bounding box when that is no larger than both (fewer, not much larger boxes)."""
    out: list = []
    for x0, y0, x1, y1 in boxes:
        # (plain comparisons and unpacked tuples: with two dozen boxes a view, min/max calls and
        # enumerate made this a twentieth of a render)
        x0, y0, x1, y1 = x0 - pad, y0 - pad, x1 + pad, y1 + pad
        if x0 < 0:
            x0 = 0
        if y0 < 0:
            y0 = 0
        if x1 > w:
            x1 = w
        if y1 > h:
            y1 = h
        if x0 >= x1 or y0 >= y1:
            continue
        i = 0
        while i < len(out):
            o0, p0, o1, p1 = out[i]
            if o0 < x1 and x0 < o1 and p0 < y1 and y0 < p1:
                u0 = o0 if o0 < x0 else x0
                v0 = p0 if p0 < y0 else y0
                u1 = o1 if o1 > x1 else x1
                v1 = p1 if p1 > y1 else y1
                if (u1 - u0) * (v1 - v0) <= (o1 - o0) * (p1 - p0) + (x1 - x0) * (y1 - y0):
                    x0, y0, x1, y1 = u0, v0, u1, v1
                    del out[i]
                    i = 0  # the grown box may now overlap one it missed
                    continue
            i += 1
        out.append((x0, y0, x1, y1))
    return out


@dataclass
class _Item:
    """One thing to paint, with what it hides (shapes) and what it is (truth target)."""

    depth: float  # camera z of its reference point (m); painted far to near
    shapes: list = field(default_factory=list)  # filled polygons, in order
    lines: list = field(default_factory=list)  # (pts, colour, closed) decoration, 1 px AA
    marker: Optional[tuple] = None  # (marker_id, H_img_tex, corners_px (4,2), disc) to composite
    # more textures to composite after the marker: (BGRA premultiplied texture, H_img_tex, outline px (M,2),
    # supersample); the outline bounds the texture's opaque part (it occludes like a shape)
    textures: list = field(default_factory=list)
    target: Optional[int] = None  # truth key: a marker id, or -1 for the ball
    target_region: Optional[np.ndarray] = None  # image px polygon that must stay uncovered
    target_corners: Optional[np.ndarray] = None  # image px points that must be inside the image
    occluder: bool = True
    flat: bool = False  # lies on the desk: painted before the shadows and every solid item
    # what it covers, as SimDesk._visibility needs it (made on first use; a cached thing's is kept)
    cover: Optional[tuple] = field(default=None, repr=False, compare=False)
    # the pixels its shapes and lines may change, (x0, y0, x1, y1) or () when unbounded: _item_box
    box: Optional[tuple] = field(default=None, repr=False, compare=False)
    line_fixed: Optional[list] = field(default=None, repr=False, compare=False)  # lines' points in 1/16 px
    # [corner bounds x0, y0, x1, y1; region box] of its target, as SimDesk._visibility needs them
    target_bounds: Optional[list] = field(default=None, repr=False, compare=False)
    # (image size, the covers that may hide its target, uncovered?) of the last SimDesk._visibility:
    # a still target under the same still items (their kept covers) is not masked again
    visible_kept: Optional[tuple] = field(default=None, repr=False, compare=False)
    # a still thing's item (drawn again every frame) keeps the pixels under its box before and after
    # its shapes and lines were painted, (image shape, before, after): painted over the same pixels
    # again, it pastes them (SimDesk._paint_shapes); from its second painting on (_PAINTED_ONCE)
    keep_pixels: bool = field(default=False, repr=False, compare=False)
    kept: Optional[tuple] = field(default=None, repr=False, compare=False)


_PAINTED_ONCE = ("painted once",)  # _Item.kept of an item painted once, not yet kept (SimDesk._paint_shapes)
FIXED_LIMIT = 1 << 26  # fillPoly coordinates (1/16 px) beyond this: no bound is taken (NaN, near the near plane)


def _item_box(it: _Item) -> tuple:
    """The box of the pixels ``it``'s shapes and lines may change (made once per item, with their
    fixed-point outlines), () when unbounded; its marker and textures report their own boxes."""
    if it.box is None:
        missing = [sh for sh in it.shapes if sh.fixed is None]
        allf = None
        if it.line_fixed is None and len(missing) == len(it.shapes) and len(it.shapes) + len(it.lines) > 1:
            # a new item: its shapes' and lines' outlines rounded at once, and bounded at once
            polys = [sh.pts for sh in missing] + [pts for pts, _, _ in it.lines]
            allf = np.round(np.concatenate(polys) * 16.0).astype(np.int32)
            i = 0
            for sh in missing:
                sh.fixed = allf[i:i + len(sh.pts)]
                i += len(sh.pts)
            it.line_fixed = []
            for pts, _, _ in it.lines:
                it.line_fixed.append(allf[i:i + len(pts)])
                i += len(pts)
        if missing and allf is None:  # (rounded all at once: the same values as one outline at a time)
            fixed = _fixed([sh.pts for sh in missing])
            for sh, f in zip(missing, fixed):
                sh.fixed = f
        if it.line_fixed is None:
            it.line_fixed = _fixed([pts for pts, _, _ in it.lines])
        if allf is None:
            outlines = [sh.fixed for sh in it.shapes] + it.line_fixed
            allf = np.concatenate(outlines) if len(outlines) > 1 else outlines[0] if outlines else outlines
        if len(allf) == 0:
            it.box = (0, 0, 0, 0)  # nothing to paint
            return it.box
        bx, by, bw, bh = cv2.boundingRect(allf)
        x0, y0, x1, y1 = bx, by, bx + bw - 1, by + bh - 1
        if x0 <= -FIXED_LIMIT or y0 <= -FIXED_LIMIT or x1 >= FIXED_LIMIT or y1 >= FIXED_LIMIT or bw < 0 or bh < 0:
            it.box = ()
        else:  # floor and ceil of the outline's pixel bounds, and the anti-aliasing's reach
            it.box = ((x0 >> 4) - AA_MARGIN_PX, (y0 >> 4) - AA_MARGIN_PX,
                      -(-x1 >> 4) + AA_MARGIN_PX + 1, -(-y1 >> 4) + AA_MARGIN_PX + 1)
    return it.box


def _fixed(polys: list) -> list:
    """``polys`` (M_i, 2) px as fillPoly's fixed-point points (1/16 px, int32)."""
    if len(polys) <= 1:
        return [np.round(p * 16.0).astype(np.int32) for p in polys]
    allf = np.round(np.concatenate(polys) * 16.0).astype(np.int32)
    out, i = [], 0
    for p in polys:  # (slices, as np.split gives, for a tenth of its overhead)
        j = i + len(p)
        out.append(allf[i:j])
        i = j
    return out


SHADOW_BLUR_REACH_PX = int(round(SHADOW_BLUR_PX * 3 * 2 + 1)) // 2  # GaussianBlur's kernel radius for σ (8-bit)
SHADOW_STACK_MAX_PX = 4096  # masks blurred side by side are at most this wide together (frames included)


def _blur_shadow_masks(masks: list) -> list:
    """``cv2.GaussianBlur(mask, (0, 0), SHADOW_BLUR_PX)`` of each of ``masks`` (uint8), the same
    pixels, for a sixth less CPU: the masks are blurred side by side in one image, top-aligned,
    each framed on its left, right and bottom by the kernel's reach of its own mirrored pixels
    (what BORDER_REFLECT_101 reads beyond its edges; the image's top edge mirrors its own rows),
    so that a pixel's blur reads what it read alone. OpenCV's 8-bit blur of a shadow group's mask
    (~60-400 px wide) costs ~2.6 ns a pixel, of one wide image ~1.1 ns."""
    r = SHADOW_BLUR_REACH_PX
    out: list = [None] * len(masks)
    todo = list(range(len(masks)))
    while todo:
        take, width = [], 0
        for i in todo:  # (in order, while they fit)
            w = masks[i].shape[1] + 2 * r
            if take and width + w > SHADOW_STACK_MAX_PX:
                break
            take.append(i)
            width += w
        todo = todo[len(take):]
        if len(take) == 1:
            out[take[0]] = cv2.GaussianBlur(masks[take[0]], (0, 0), SHADOW_BLUR_PX)
            continue
        canvas = np.zeros((max(masks[i].shape[0] for i in take) + r, width), np.uint8)
        x = 0
        for i in take:
            h, w = masks[i].shape
            canvas[:h + r, x:x + w + 2 * r] = cv2.copyMakeBorder(masks[i], 0, r, r, r, cv2.BORDER_REFLECT_101)
            x += w + 2 * r
        canvas = cv2.GaussianBlur(canvas, (0, 0), SHADOW_BLUR_PX)
        x = 0
        for i in take:
            h, w = masks[i].shape
            out[i] = canvas[:h, x + r:x + r + w]
            x += w + 2 * r
    return out


def _fill(img: np.ndarray, pts: np.ndarray, colour, aa: bool = True) -> None:
    cv2.fillPoly(img, [np.round(pts * 16.0).astype(np.int32)], colour,
                 lineType=cv2.LINE_AA if aa else cv2.LINE_8, shift=4)


def _circle(n: int = 32) -> np.ndarray:
    a = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    return np.stack([np.cos(a), np.sin(a)], axis=1)


_CIRCLE32 = _circle(32)
# an arm link's quads (edge, body, highlight) as (half width ka at a, kb at b, offset off) across the
# link, in widths: each corner's offset, (off + ka, off + kb, off − kb, off − ka), shape (3, 4, 1)
_LINK_QUAD_OFFSETS = np.array([[[off + ka], [off + kb], [off - kb], [off - ka]]
                               for ka, kb, off in ((1.0, 1.0, 0.0), (0.82, 0.82, 0.0), (0.28, 0.28, 0.35))])


def _unit_sphere(n_lat: int = 10, n_lon: int = 24) -> np.ndarray:
    """Points (M, 3) on the unit sphere: poles and n_lat rings of n_lon (hulls of their images)."""
    pts = [(0.0, 0.0, 1.0), (0.0, 0.0, -1.0)]
    for phi in np.linspace(0.0, math.pi, n_lat + 2)[1:-1]:
        for a in np.linspace(0.0, 2 * math.pi, n_lon, endpoint=False):
            pts.append((math.sin(phi) * math.cos(a), math.sin(phi) * math.sin(a), math.cos(phi)))
    return np.array(pts)


_SPHERE = _unit_sphere()
_PLUSH_SCALES = np.array([1.0, 0.86, 0.66, 0.42, 0.14])[:, None, None]  # its outline, 3 shades, the spot
_CUP_ANGLES = np.linspace(0.0, 2 * math.pi, CUP_STRIPS, endpoint=False)


def _shade(colour, k: float) -> tuple:
    try:
        return _shade_kept(colour, k)  # (the same few colours and gains every frame)
    except TypeError:  # a colour that is not hashable (a list)
        return tuple(float(min(255.0, c * k)) for c in colour)


@functools.lru_cache(maxsize=1024)
def _shade_kept(colour, k: float) -> tuple:
    return tuple(float(min(255.0, c * k)) for c in colour)


def _rounded_rect(u0: float, u1: float, v0: float, v1: float, r0: float, r1: float, n: int = 6) -> np.ndarray:
    """Outline (M, 2) of a rectangle [u0,u1]×[v0,v1] with corner radius r0 at v0 and r1 at v1."""
    pts = []
    for cu, cv, r, a0 in ((u1 - r1, v1 - r1, r1, 0.0), (u0 + r1, v1 - r1, r1, 90.0),
                          (u0 + r0, v0 + r0, r0, 180.0), (u1 - r0, v0 + r0, r0, 270.0)):
        for a in np.radians(np.linspace(a0, a0 + 90.0, n)):
            pts.append((cu + r * math.cos(a), cv + r * math.sin(a)))
    return np.array(pts)


# the hand in its own frame (u right, v along the fingers; m): palm + fingers, forearm, thumb
_HAND_OUTLINES = (
    _rounded_rect(-0.036, 0.036, -0.46, -0.03, 0.0, 0.0, 2),  # forearm, back towards the user
    _rounded_rect(-0.045, 0.045, -0.05, 0.105, 0.018, 0.026),
    _rounded_rect(0.030, 0.056, -0.03, 0.045, 0.012, 0.012) @ np.array([[0.94, 0.34], [-0.34, 0.94]])
    + np.array([0.012, 0.0]),
)
_HAND_GAPS = tuple(((u, 0.105 - 0.004), (u, 0.045)) for u in (-0.0225, 0.0, 0.0225))
_HAND_LOCAL = np.concatenate(_HAND_OUTLINES + tuple(np.array(gap) for gap in _HAND_GAPS))  # all at once
_HAND_PART_LENGTHS = tuple(len(p) for p in _HAND_OUTLINES) + tuple(len(g) for g in _HAND_GAPS)


class _View:
    """One camera: projection, position and the cached desk image."""

    def __init__(self, rig: SimRig, side: str, seed: int):
        self.side = side
        self.P = rig.projection(side)
        self.f = float(rig.K[0, 0])
        base_T_cam = rig.base_T_left if side == "left" else rig.base_T_right
        self.cam_pos = base_T_cam[:3, 3].copy()
        self.size = rig.size
        x_range, y_range, m = desk_extent(rig)
        tex = desk_texture(seed, x_range, y_range, m)
        A = np.array([[m, 0.0, x_range[0] + 0.5 * m],  # texel centre → desk point (m)
                      [0.0, -m, y_range[1] - 0.5 * m],
                      [0.0, 0.0, 1.0]])
        H = self.plane_homography(0.0) @ A
        self.desk = cv2.warpPerspective(tex, H, self.size, flags=cv2.INTER_LINEAR,
                                        borderMode=cv2.BORDER_REFLECT)
        # pixels whose ray never meets the desk (above the horizon) show a plain wall
        w, h = self.size
        uu, vv = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
        ray_z = (base_T_cam[:3, :3] @ np.linalg.inv(rig.K))[2]
        sky = ray_z[0] * uu + ray_z[1] * vv + ray_z[2] > -1e-3
        if np.any(sky):
            self.desk[sky] = WALL_COLOUR
        self.finished_desk: Optional[tuple] = None  # (settings key, desk after LUT and blur): SimDesk._finish_boxes
        # the image drawn into, kept between frames: where the last frame painted (boxes, None: not
        # known) the bare desk is put back, instead of copying all of it (SimDesk._draw)
        self.canvas: Optional[np.ndarray] = None
        self.canvas_dirty: Optional[list] = None
        self.canvas_lock = threading.Lock()  # (a render in another thread draws into a copy)
        self.shadow_patches: dict = {}  # still shadow groups' blurred patches: SimDesk._draw_shadows
        self.shadow_px: dict = {}  # still things' shadow polygons' projections and boxes: SimDesk._draw_shadows

    @classmethod
    def from_pose(cls, base_T_camera: np.ndarray, K: np.ndarray, size: tuple[int, int], seed: int,
                  extent: tuple) -> "_View":
        """A view from any camera pose (e.g. a camera on the arm's hand): ``base_T_camera`` (4x4,
        OpenCV optical frame: z forward, x right, y down), intrinsics ``K`` (3x3), ``size`` (w, h),
        the desk texture of ``extent`` = (x_range, y_range, m_per_px) (``desk_extent`` of a rig)."""
        self = cls.__new__(cls)
        self.side = "hand"
        camera_T_base = np.linalg.inv(base_T_camera)
        self.P = K @ camera_T_base[:3, :]
        self.f = float(K[0, 0])
        self.cam_pos = np.asarray(base_T_camera, dtype=float)[:3, 3].copy()
        self.size = (int(size[0]), int(size[1]))
        x_range, y_range, m = extent
        tex = desk_texture(seed, x_range, y_range, m)
        A = np.array([[m, 0.0, x_range[0] + 0.5 * m],
                      [0.0, -m, y_range[1] - 0.5 * m],
                      [0.0, 0.0, 1.0]])
        self.desk = cv2.warpPerspective(tex, self.plane_homography(0.0) @ A, self.size, flags=cv2.INTER_LINEAR,
                                        borderMode=cv2.BORDER_REFLECT)
        w, h = self.size
        ray_z = (np.asarray(base_T_camera, dtype=float)[:3, :3] @ np.linalg.inv(K))[2]
        corners = np.array([[0.0, 0.0, 1.0], [w - 1.0, 0.0, 1.0], [0.0, h - 1.0, 1.0], [w - 1.0, h - 1.0, 1.0]])
        if np.any(corners @ ray_z > -1e-3):  # (a camera looking down, the usual case, skips this)
            uu, vv = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
            self.desk[ray_z[0] * uu + ray_z[1] * vv + ray_z[2] > -1e-3] = WALL_COLOUR
        self.finished_desk = None
        self.canvas, self.canvas_dirty, self.canvas_lock = None, None, threading.Lock()
        self.shadow_patches = {}
        self.shadow_px = {}
        return self

    def plane_homography(self, z: float) -> np.ndarray:
        """Maps (X, Y, 1) on the horizontal plane at height z (robot_base) to image px."""
        P = self.P
        return np.column_stack([P[:, 0], P[:, 1], P[:, 2] * z + P[:, 3]])

    def project(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Image px (N, 2) and depth (N,) of robot_base points (N, 3)."""
        h = pts @ self.P[:, :3].T + self.P[:, 3]
        return h[:, :2] / h[:, 2:3], h[:, 2]

    def project_polygon(self, pts: np.ndarray) -> Optional[np.ndarray]:
        """Image px of a planar 3D polygon, clipped to the near plane; None if all behind it."""
        h = pts @ self.P[:, :3].T + self.P[:, 3]
        if np.all(h[:, 2] >= NEAR_M):
            return h[:, :2] / h[:, 2:3]
        out = []
        n = len(h)
        for i in range(n):  # Sutherland–Hodgman against depth >= NEAR_M
            a, b = h[i], h[(i + 1) % n]
            ina, inb = a[2] >= NEAR_M, b[2] >= NEAR_M
            if ina:
                out.append(a)
            if ina != inb:
                s = (NEAR_M - a[2]) / (b[2] - a[2])
                out.append(a + s * (b - a))
        if len(out) < 3:
            return None
        h = np.array(out)
        return h[:, :2] / h[:, 2:3]


# ----------------------------------------------------------------------------------------------


class SimDesk:
    """Renders the simulated desk into the rig's two cameras, with ground truth.

    ``render(t, arm_points)`` gives (left, right, GroundTruth) for scenario time t (s);
    ``image_boxes(t, arm_points)`` the visible part of each object as a pixel box per view.
    ``scenario`` is a scenario name or any ``Scenario`` instance (e.g. one that returns a
    SceneState a data generator built).
    Deterministic: the same seed, settings, t and arm give identical images.
    """

    ball_colour_bgr = BALL_COLOUR  # the ball's body colour (its shading varies ±25 % around it)

    def __init__(self, rig: SimRig, scenario: Union[str, Scenario] = "static", marker_ids: Sequence[int] = (23, 50),
                 marker_size_m: float = 0.04, seed: int = 0, blur_sigma_px: float = 0.6,
                 noise_sigma: float = 2.0, tool_marker=None):
        ids = tuple(int(i) for i in marker_ids)
        if len(set(ids)) != len(ids) or any(not 0 <= i < 250 for i in ids):
            raise ValueError(f"marker_ids = {ids}: need distinct DICT_6X6_250 ids in 0…249")
        if not 0.01 <= marker_size_m <= 0.2:
            raise ValueError(f"marker_size_m = {marker_size_m} is outside 0.01…0.2 m")
        if not 0.0 <= blur_sigma_px <= 10.0:
            raise ValueError(f"blur_sigma_px = {blur_sigma_px} is outside 0…10 px")
        if not 0.0 <= noise_sigma <= 50.0:
            raise ValueError(f"noise_sigma = {noise_sigma} is outside 0…50 levels")
        self.rig = rig
        self.marker_ids = ids
        self.marker_size_m = float(marker_size_m)
        self.seed = int(seed)
        self.blur_sigma_px = float(blur_sigma_px)
        self.noise_sigma = float(noise_sigma)
        # ±2.5σ is plenty (σ = 0.6 → 3 taps; OpenCV's own 8-bit rule would take 5)
        k = 2 * max(1, math.ceil(2.5 * self.blur_sigma_px - 0.5)) + 1
        self._blur_ksize = (k, k)
        self._dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_6X6_250)
        self._views = {side: _View(rig, side, self.seed) for side in SIDES}
        # a still thing's item in each rig view and its shadow, made once: building them was a third
        # of a render of the objects scene, where only the arm moves (render_camera's views are new
        # each call: not cached). Keyed by the frozen Thing, so a moved thing is made again.
        self._thing_items: dict[int, dict] = {id(view): {} for view in self._views.values()}
        self._thing_shadows: dict = {}
        self._arm_items_kept: dict = {}  # id(view) → (arm key, flat items, 3D items): _cached_arm_items
        self._arm_base_kept: dict = {}  # id(view) → (base point bytes, the base plate's item or None): _arm_items
        self._arm_shadows_kept: Optional[tuple] = None  # (arm bytes, shadow polygons): _shadow_polygons
        self._extent: Optional[tuple] = None  # desk texture extent for render_camera (the rig's, made on first use)
        # the printed square: black marker + white quiet zone (m)
        self._paper_m = self.marker_size_m * (8 + 2 * MARKER_BORDER_CELLS) / 8
        # the cup's top must hold the marker (its corners stay a little inside the rim)
        cell = self.marker_size_m / 8
        self.cup_top_radius_m = max(CUP_TOP_RADIUS_M, self.marker_size_m / math.sqrt(2) + 0.9 * cell)
        self.cup_rim_radius_m = self.cup_top_radius_m + (CUP_RIM_RADIUS_M - CUP_TOP_RADIUS_M)
        label_r = self.cup_top_radius_m - 0.0015
        self._textures = {}
        for i in ids:
            self._textures[(i, False)] = marker_texture(self._dictionary, i)
            self._textures[(i, True)] = marker_texture(self._dictionary, i, label_r / (self._paper_m / 2))
        self._marker_patches: dict = {}  # (id, disc, image shape, H, outline) -> warped patch: _composite_marker
        self.tool_marker = None  # (marker_id, offset_m, size_m) of the plate the arm carries
        self.set_tool_marker(tool_marker)
        self._settings = CameraSettings()
        self._lut: Optional[np.ndarray] = None
        self._noise: Optional[tuple] = None  # ((h, w, σ), noise field) of _noise_field
        self.set_scenario(scenario)

    # -- configuration ----------------------------------------------------------------------

    def set_tool_marker(self, marker) -> None:
        """The marker plate the arm carries (any object with ``marker_id``, ``offset_m`` — from the
        tool point, robot_base axes — and ``size_m``), or None for a bare tool. The plate lies
        horizontal, printed side up, its top edge facing away from the base."""
        if marker is None:
            self.tool_marker = None
            return
        marker_id, size = int(marker.marker_id), float(marker.size_m)
        offset = tuple(float(v) for v in marker.offset_m)
        if marker_id in self.marker_ids or not 0 <= marker_id < 250:
            raise ValueError(f"tool marker id {marker_id} must be a DICT_6X6_250 id (0…249) not used by the "
                             f"desk's markers {self.marker_ids}")
        if not 0.01 <= size <= 0.2 or len(offset) != 3 or not all(map(math.isfinite, offset)):
            raise ValueError(f"tool marker size {size} m / offset {offset}: need 0.01…0.2 m and 3 finite numbers")
        self._textures[(marker_id, False)] = marker_texture(self._dictionary, marker_id)
        self._marker_patches.clear()  # patches are keyed by marker id: none may outlive its texture
        self.tool_marker = (marker_id, offset, size)

    def tool_marker_centre(self, arm_points) -> Optional[np.ndarray]:
        """Centre of the tool's marker plate (robot_base) for chain points ``arm_points``, or None."""
        arm = self._check_arm(arm_points)
        if arm is None or self.tool_marker is None:
            return None
        return arm[-1] + np.asarray(self.tool_marker[1])

    def set_scenario(self, scenario: Union[str, Scenario]) -> None:
        """Switch to scenario ``scenario``: a name (one of ``scenario_names()``), built with this
        desk's marker ids and seed, or a ready ``Scenario`` instance (a data generator's own scene,
        e.g. a subclass whose ``state(t)`` returns a fixed SceneState). Time restarts at its t.

        ``self.scenario`` is the name (the instance's ``name``, or its class name when it has
        none); ``self.scenario_object`` is the Scenario itself.
        """
        if isinstance(scenario, Scenario):
            self._scenario = scenario
            self.scenario = scenario.name or type(scenario).__name__
            return
        if not isinstance(scenario, str):
            raise TypeError(f"scenario must be a name ({', '.join(scenario_names())}) or a core.sim.scenarios."
                            f"Scenario instance, got {type(scenario).__name__}")
        self._scenario = make_scenario(scenario, self.marker_ids, self.seed)
        self.scenario = scenario

    @property
    def scenario_object(self) -> Scenario:
        """The Scenario that ``scene(t)`` asks (pass it to another SimDesk to show the same scene)."""
        return self._scenario

    @property
    def settings(self) -> CameraSettings:
        """The camera's image controls, applied to every render."""
        return self._settings

    @settings.setter
    def settings(self, value: CameraSettings) -> None:
        self.set_camera_settings(value)

    def set_camera_settings(self, settings: CameraSettings) -> None:
        """Exposure (×2^EV), gain (×10^(dB/20), more noise), brightness (+), contrast (× about 128)."""
        if not isinstance(settings, CameraSettings):
            raise TypeError(f"set_camera_settings needs a CameraSettings, got {type(settings).__name__}")
        self._settings = settings
        if settings == CameraSettings():
            self._lut = None  # identity: skip the LUT pass
            return
        v = np.arange(256, dtype=np.float64) * self._gain_factor(settings)
        v = (v - 127.5) * settings.contrast + 127.5 + settings.brightness
        self._lut = np.clip(np.round(v), 0, 255).astype(np.uint8).reshape(256, 1)

    @staticmethod
    def _gain_factor(s: CameraSettings) -> float:
        return 2.0 ** s.exposure * 10.0 ** (s.gain / 20.0)

    @property
    def effective_noise_sigma(self) -> float:
        """Noise std (8-bit levels) after gain and contrast, like a real sensor's read noise."""
        s = self._settings
        return self.noise_sigma * 10.0 ** (s.gain / 20.0) * s.contrast

    # -- scene ------------------------------------------------------------------------------

    def scene(self, t: float) -> SceneState:
        """The scenario's state at time t (s)."""
        return self._scenario.state(float(t))

    def _marker_pose(self, obj) -> tuple[float, float, float, float]:
        """(x, y, z, yaw) of the marker centre on a card or cup, robot_base."""
        if isinstance(obj, Cup):
            return obj.x, obj.y, obj.lift + CUP_HEIGHT_M, obj.yaw
        if isinstance(obj, Wristband):
            return obj.x, obj.y, obj.z, obj.yaw
        return obj.x, obj.y, 0.0, obj.yaw

    @staticmethod
    def _local_to_base(pose, local: np.ndarray) -> np.ndarray:
        x, y, z, yaw = pose
        c, s = math.cos(yaw), math.sin(yaw)
        out = np.empty((len(local), 3))
        out[:, 0] = x + c * local[:, 0] - s * local[:, 1]
        out[:, 1] = y + s * local[:, 0] + c * local[:, 1]
        out[:, 2] = z
        return out

    def _square(self, pose, half: float) -> np.ndarray:
        """Corners (4, 3) of a square of half-size ``half`` on the marker's plane, in ArUco's order
        (top-left, top-right, bottom-right, bottom-left; the marker's top faces +y at yaw 0)."""
        local = np.array([[-half, half], [half, half], [half, -half], [-half, -half]])
        return self._local_to_base(pose, local)

    def marker_corners(self, t: float) -> dict[int, np.ndarray]:
        """Each marker's black-square corners (4, 3) in robot_base at time t, in ArUco's order."""
        st = self.scene(t)
        bands = tuple(h.band for h in st.hands if h.band is not None)
        return {o.marker_id: self._square(self._marker_pose(o), self.marker_size_m / 2)
                for o in (*st.cards, *st.cups, *bands)}

    # -- layout: what to paint, per view ---------------------------------------------------

    def _marker_parts(self, view: _View, obj, disc: bool):
        pose = self._marker_pose(obj)
        x, y, z, yaw = pose
        tex = self._textures[(obj.marker_id, disc)]
        n = tex.shape[0]
        s = self._paper_m / n
        A = np.array([[s, 0.0, 0.5 * s - self._paper_m / 2],  # texel centre → marker plane (m)
                      [0.0, -s, self._paper_m / 2 - 0.5 * s],  # rows run towards -y: not mirrored
                      [0.0, 0.0, 1.0]])
        c, sn = math.cos(yaw), math.sin(yaw)
        R = np.array([[c, -sn, x], [sn, c, y], [0.0, 0.0, 1.0]])
        H = view.plane_homography(z) @ R @ A
        # the paper's, the black square's and the target region's corners (as _square's), placed
        # together and projected one square at a time
        halves = (self._paper_m / 2, self.marker_size_m / 2, self.marker_size_m / 2 * (1 + 1 / 8))
        corners = self._local_to_base(pose, np.array([c for h in halves for c in ((-h, h), (h, h), (h, -h), (-h, -h))]))
        paper_px, _ = view.project(corners[0:4])
        black_px, _ = view.project(corners[4:8])
        region_px, _ = view.project(corners[8:12])
        return (obj.marker_id, H, paper_px, disc), black_px, region_px

    def _tool_plate_item(self, view: _View, arm: np.ndarray) -> Optional[_Item]:
        """The marker plate on the tool: a horizontal marker at tool point + offset."""
        marker_id, offset, size = self.tool_marker
        centre = arm[-1] + np.asarray(offset)
        yaw = math.atan2(arm[-1, 1] - arm[0, 1], arm[-1, 0] - arm[0, 0]) - math.pi / 2
        pose = (float(centre[0]), float(centre[1]), float(centre[2]), yaw)
        _, depth = view.project(centre[None])
        if depth[0] < NEAR_M * 2:
            return None
        paper = size * (8 + 2 * MARKER_BORDER_CELLS) / 8
        tex = self._textures[(marker_id, False)]
        n = tex.shape[0]
        s = paper / n
        A = np.array([[s, 0.0, 0.5 * s - paper / 2], [0.0, -s, paper / 2 - 0.5 * s], [0.0, 0.0, 1.0]])
        c, sn = math.cos(yaw), math.sin(yaw)
        R = np.array([[c, -sn, pose[0]], [sn, c, pose[1]], [0.0, 0.0, 1.0]])
        H = view.plane_homography(pose[2]) @ R @ A
        paper_px, _ = view.project(self._square(pose, paper / 2))
        # painted just in front of the tool's own disc
        return _Item(depth=float(depth[0]) - 2e-3, marker=(marker_id, H, paper_px, False))

    def _card_item(self, view: _View, card: Card) -> _Item:
        marker, black, region = self._marker_parts(view, card, disc=False)
        return _Item(depth=0.0, marker=marker, target=card.marker_id, target_region=region,
                     target_corners=black, flat=True)

    def _cup_item(self, view: _View, cup: Cup) -> _Item:
        shapes, lines, depth, _ = self._frustum_parts(view, cup.x, cup.y, cup.lift, CUP_HEIGHT_M,
                                                      self.cup_top_radius_m, self.cup_rim_radius_m,
                                                      CUP_COLOUR, CUP_TOP_COLOUR)
        marker, black, region = self._marker_parts(view, cup, disc=True)
        return _Item(depth=depth, shapes=shapes, lines=lines, marker=marker,
                     target=cup.marker_id, target_region=region, target_corners=black)

    def _frustum_parts(self, view: _View, x: float, y: float, z0: float, hgt: float, rt: float, rb: float,
                       colour, top_colour) -> tuple[list, list, float, np.ndarray]:
        """(shapes, lines, depth, hull px) of a Lambert-shaded frustum standing at (x, y, z0):
        bottom radius rb, top radius rt at z0 + hgt (an upside-down cup, a disc, a cylinder)."""
        cs, sn = np.cos(_CUP_ANGLES), np.sin(_CUP_ANGLES)
        top = np.column_stack([x + rt * cs, y + rt * sn, np.full_like(cs, z0 + hgt)])
        bot = np.column_stack([x + rb * cs, y + rb * sn, np.full_like(cs, z0)])
        p_top, _ = view.project(top)
        p_bot, _ = view.project(bot)
        _, depth = view.project(np.array([[x, y, z0 + hgt / 2]]))
        hull = cv2.convexHull(np.vstack([p_top, p_bot]).astype(np.float32))[:, 0, :].astype(np.float64)
        shapes = [_Shape(hull, _shade(colour, 0.8))]
        # side strips, Lambert-shaded; only those facing the camera
        half = math.pi / CUP_STRIPS
        mid_a = _CUP_ANGLES + half
        normals = np.column_stack([np.cos(mid_a), np.sin(mid_a), np.full_like(mid_a, (rb - rt) / hgt)])
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        mid_pts = np.column_stack([x + (rt + rb) / 2 * np.cos(mid_a), y + (rt + rb) / 2 * np.sin(mid_a),
                                   np.full_like(mid_a, z0 + hgt / 2)])
        facing = np.einsum("ij,ij->i", normals, view.cam_pos - mid_pts) > 0
        shade = np.round((AMBIENT + 0.75 * np.clip(normals @ LIGHT, 0.0, 1.0)) * CUP_SHADE_LEVELS)
        # runs of camera-facing strips with the same shade level become one polygon
        ks = np.nonzero(facing)[0]
        if len(ks) and len(ks) < CUP_STRIPS:
            start = int(np.nonzero(facing & ~np.roll(facing, 1))[0][0])  # where the arc begins
            ks = (np.arange(len(ks)) + start) % CUP_STRIPS
        run: list = []
        for j, k in enumerate(ks):
            run.append(int(k))
            if j + 1 == len(ks) or shade[ks[j + 1]] != shade[k]:
                last = (run[-1] + 1) % CUP_STRIPS
                idx_b = run + [last]
                poly = np.vstack([p_bot[idx_b], p_top[idx_b[::-1]]])
                shapes.append(_Shape(poly, _shade(colour, shade[k] / CUP_SHADE_LEVELS)))
                run = []
        lid_light = AMBIENT + 0.75 * float(LIGHT[2])
        shapes.append(_Shape(p_top, _shade(top_colour, lid_light)))
        rim_line = (p_bot[np.nonzero(facing)[0]], _shade(colour, 0.55), False)
        lines = [(p_top, _shade(colour, 0.6), True)]
        if z0 > 0.002:  # a lifted cup shows its rim's edge
            lines.append(rim_line)
        return shapes, lines, float(depth[0]), hull

    def _ball_item(self, view: _View, bx: float, by: float, radius: float = BALL_RADIUS_M,
                   colour=BALL_COLOUR, highlight=BALL_HIGHLIGHT, target: int = -1) -> _Item:
        """A shaded sphere lying on the desk (centre ``radius`` above it): the cups game's ball by
        default. Its silhouette is drawn as the circle of the centre's depth (exact to < 0.1 px
        at these distances), so the projected centre is the disc's centre."""
        centre3 = np.array([bx, by, radius])
        c, depth = view.project(centre3[None])
        c, depth = c[0], float(depth[0])
        r = view.f * radius / depth
        to_cam = view.cam_pos - centre3
        to_cam /= np.linalg.norm(to_cam)
        half = LIGHT + to_cam
        hl, _ = view.project((centre3 + 0.75 * radius * half / np.linalg.norm(half))[None])
        hl = hl[0]
        shapes = [_Shape(c + r * _CIRCLE32, _shade(colour, 0.72))]
        for k, (scale, gain) in enumerate(((0.86, 0.92), (0.66, 1.08), (0.42, 1.22))):
            ck = c + (hl - c) * (1 - scale)
            shapes.append(_Shape(ck + r * scale * _CIRCLE32, _shade(colour, gain)))
        shapes.append(_Shape(hl + r * 0.16 * _CIRCLE32, highlight))
        outline = c + r * _CIRCLE32
        return _Item(depth=depth, shapes=shapes, target=target, target_region=outline, target_corners=outline)

    def _plush_item(self, view: _View, th: Thing) -> _Item:
        """An ellipsoid lying on the desk (semi-axes: half length along yaw, half height twice),
        shaded like the balls: hulls of its projected points, shrunk towards the light's spot."""
        a, b = th.radius_m, th.height_m / 2
        axes = np.array([a, b, b])
        c, s = math.cos(th.yaw), math.sin(th.yaw)
        R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        centre3 = np.array(th.centre)
        _, depth = view.project(centre3[None])
        local = _SPHERE * axes  # ellipsoid points, its own frame
        # the spot where the surface normal halves light and view: normal n ↦ point D² n / |D n|
        to_cam = view.cam_pos - centre3
        half = LIGHT + to_cam / np.linalg.norm(to_cam)
        n_local = R.T @ (half / np.linalg.norm(half))
        spot_local = axes**2 * n_local / np.linalg.norm(axes * n_local)

        # hulls of the points scaled by each of _PLUSH_SCALES towards the outline's centre (the
        # first) or the spot: all five sets placed and projected at once, each point's arithmetic
        # as one set at a time (the rows of a product do not depend on each other)
        towards = np.stack([np.zeros(3), 0.75 * spot_local, 0.75 * spot_local, 0.75 * spot_local, 0.9 * spot_local])
        pts = centre3 + (towards[:, None, :] * (1 - _PLUSH_SCALES) + local * _PLUSH_SCALES).reshape(-1, 3) @ R.T
        px, _ = view.project(pts)
        px = px.astype(np.float32)
        n = len(local)
        hulls = [cv2.convexHull(px[k * n:(k + 1) * n])[:, 0, :].astype(np.float64) for k in range(5)]
        outline = hulls[0]
        shapes = [_Shape(outline, _shade(th.colour, 0.72))]
        for hull, gain in zip(hulls[1:4], (0.92, 1.06, 1.16)):
            shapes.append(_Shape(hull, _shade(th.colour, gain)))
        spot = tuple(float(v + PLUSH_GLOSS * (255 - v)) for v in th.colour)
        shapes.append(_Shape(hulls[4], spot))
        return _Item(depth=float(depth[0]), shapes=shapes, target=th.truth_id, target_region=outline,
                     target_corners=outline)

    def _disc_item(self, view: _View, th: Thing) -> _Item:
        """A disc or cylinder standing on the desk: from above, its lit top is a circle."""
        shapes, lines, depth, hull = self._frustum_parts(view, th.x, th.y, 0.0, th.height_m, th.radius_m,
                                                         th.radius_m, th.colour, _shade(th.colour, 1.12))
        return _Item(depth=depth, shapes=shapes, lines=lines, target=th.truth_id, target_region=hull,
                     target_corners=hull)

    def _plain_cup_item(self, view: _View, th: Thing) -> _Item:
        """An upside-down cup without a marker."""
        top_r = th.radius_m - (CUP_RIM_RADIUS_M - CUP_TOP_RADIUS_M)
        shapes, lines, depth, hull = self._frustum_parts(view, th.x, th.y, 0.0, th.height_m, top_r, th.radius_m,
                                                         th.colour, _shade(th.colour, 1.08))
        return _Item(depth=depth, shapes=shapes, lines=lines, target=th.truth_id, target_region=hull,
                     target_corners=hull)

    def _cached_thing_item(self, view: _View, th: Thing) -> _Item:
        """``_thing_item``, made once per rig view and thing (items are never changed once made)."""
        cache = self._thing_items.get(id(view))
        if cache is None:
            return self._thing_item(view, th)
        item = cache.get(th)
        if item is None:
            if len(cache) >= THING_CACHE:
                cache.clear()  # things that moved: their old items will not come back
            item = cache[th] = self._thing_item(view, th)
            item.keep_pixels = True
        return item

    def _cached_arm_items(self, view: _View, arm: np.ndarray) -> tuple[list, list]:
        """(flat items, 3D items) of the arm at chain points ``arm`` and the plate it carries; in a
        rig view made once while the arm stays still (to the bit), and then they keep their pixels
        (an idle arm over the objects scene was rebuilt and painted anew every frame)."""
        key = (arm.tobytes(), self.tool_marker)
        cache = self._arm_items_kept
        if id(view) in self._thing_items:
            hit = cache.get(id(view))
            if hit is not None and hit[0] == key:
                return hit[1], hit[2]
        flat, solid = self._arm_items(view, arm)
        if self.tool_marker is not None:
            plate = self._tool_plate_item(view, arm)
            if plate is not None:
                solid.append(plate)
        if id(view) in self._thing_items:
            for it in flat + solid:
                it.keep_pixels = True
            cache[id(view)] = (key, flat, solid)
        return flat, solid

    def _cached_card_item(self, view: _View, card: Card) -> _Item:
        """``_card_item``, made once per rig view and card (a card lying still: the objects scene's)."""
        cache = self._thing_items.get(id(view))
        if cache is None:
            return self._card_item(view, card)
        item = cache.get(card)
        if item is None:
            if len(cache) >= THING_CACHE:
                cache.clear()
            item = cache[card] = self._card_item(view, card)
        return item

    def _thing_item(self, view: _View, th: Thing) -> _Item:
        if th.kind == "ball":
            spot = tuple(float(v + HIGHLIGHT_MIX * (255 - v)) for v in th.colour)
            return self._ball_item(view, th.x, th.y, th.radius_m, th.colour, spot, th.truth_id)
        if th.kind == "plush":
            return self._plush_item(view, th)
        if th.kind == "disc":
            return self._disc_item(view, th)
        return self._plain_cup_item(view, th)

    def _panel_items(self, view: _View, panel: Panel) -> list:
        """The plate (a shaded box, its top a brushed-steel texture) and its 9 buttons (short dark
        cylinders, each top face a texture with its digit), buttons painted just after the plate."""
        top = panel.top_z
        hw, hl = panel.width_m / 2, panel.length_m / 2
        local = np.array([[-hw, hl], [hw, hl], [hw, -hl], [-hw, -hl]])  # +v edge first, clockwise from above
        top3 = self._local_to_base((panel.x, panel.y, top, panel.yaw), local)
        bot3 = top3 * np.array([1.0, 1.0, 0.0])
        p_top, _ = view.project(top3)
        p_bot, _ = view.project(bot3)
        _, depth = view.project(np.array([[panel.x, panel.y, top / 2]]))
        depth = float(depth[0])
        hull = cv2.convexHull(np.vstack([p_top, p_bot]).astype(np.float32))[:, 0, :].astype(np.float64)
        shapes = [_Shape(hull, PANEL_EDGE_COLOUR)]
        c, sn = math.cos(panel.yaw), math.sin(panel.yaw)
        for i in range(4):  # the sides facing the camera, Lambert-shaded
            j = (i + 1) % 4
            mid = (top3[i] + top3[j]) / 2 - np.array([0.0, 0.0, top / 2])
            outward = mid - np.array([panel.x, panel.y, mid[2]])
            normal = outward / np.linalg.norm(outward)
            if normal @ (view.cam_pos - mid) <= 0:
                continue
            shade = AMBIENT + 0.75 * max(0.0, float(normal @ LIGHT))
            shapes.append(_Shape(np.array([p_bot[i], p_bot[j], p_top[j], p_top[i]]), _shade(PANEL_SIDE_COLOUR, shade)))
        holes = tuple(panel.button_uv(n) for n in panel.BUTTONS)
        tex, A = panel_texture((float(panel.width_m), float(panel.length_m), float(panel.button_radius_m), holes))
        R = np.array([[c, -sn, panel.x], [sn, c, panel.y], [0.0, 0.0, 1.0]])
        H = view.plane_homography(top) @ R @ A
        items = [_Item(depth=depth, shapes=shapes, textures=[(tex, H, p_top, PANEL_SUPERSAMPLE)])]
        r = panel.button_radius_m
        n_px = BUTTON_TEXTURE_PX
        s = 2 * r / n_px
        A_button = np.array([[s, 0.0, 0.5 * s - r], [0.0, -s, r - 0.5 * s], [0.0, 0.0, 1.0]])  # rows towards −v
        for n in panel.BUTTONS:
            bx, by, z_top = panel.button_centre(n)
            ring = np.column_stack([bx + r * _CIRCLE32[:, 0], by + r * _CIRCLE32[:, 1], np.full(len(_CIRCLE32), z_top)])
            p_face, _ = view.project(ring)
            p_foot, _ = view.project(ring * np.array([1.0, 1.0, 0.0]) + np.array([0.0, 0.0, top]))
            side = cv2.convexHull(np.vstack([p_face, p_foot]).astype(np.float32))[:, 0, :].astype(np.float64)
            Rb = np.array([[c, -sn, bx], [sn, c, by], [0.0, 0.0, 1.0]])
            Hb = view.plane_homography(z_top) @ Rb @ A_button
            tex_b = button_texture(n, n in panel.lit)
            items.append(_Item(depth=depth - 1e-4 * n, shapes=[_Shape(side, BUTTON_SIDE_COLOUR)],
                               textures=[(tex_b, Hb, p_face, SUPERSAMPLE)], target=panel.button_truth_id(n),
                               target_region=p_face, target_corners=side))
        return items

    def _handle_item(self, view: _View, hd: DoorHandle) -> _Item:
        """A lever handle: a round rose on the desk, a neck and a rounded bar (shaded like the arm's links)."""
        # (the frustums' outline lines are left out: an item's lines are drawn over all its shapes,
        # the bar included)
        shapes, _, _, rose_hull = self._frustum_parts(view, hd.x, hd.y, 0.0, hd.rose_height_m,
                                                          hd.rose_radius_m * 0.9, hd.rose_radius_m, HANDLE_COLOUR,
                                                          _shade(HANDLE_COLOUR, 1.02))
        neck_shapes, _, _, _ = self._frustum_parts(view, hd.x, hd.y, hd.rose_height_m,
                                                            hd.bar_height_m - hd.rose_height_m, hd.neck_radius_m,
                                                            hd.neck_radius_m, HANDLE_COLOUR, HANDLE_COLOUR)
        shapes += neck_shapes
        ends3 = np.array([hd.along(0.0), hd.along(hd.length_m)])
        (a, b), d = view.project(ends3)
        seg = b - a
        length = float(np.hypot(*seg))
        r = hd.thickness_m / 2
        wa, wb = view.f * r / d[0], view.f * r / d[1]
        u = seg / max(length, 1e-9)
        perp = np.array([-u[1], u[0]])
        l0, _ = view.project(np.array([ends3[0], ends3[0] + 0.05 * LIGHT]))
        if perp @ (l0[1] - l0[0]) < 0:
            perp = -perp  # perp points towards the light

        def quad(k: float, off: float) -> np.ndarray:
            return np.array([a + perp * wa * (off + k), b + perp * wb * (off + k),
                             b + perp * wb * (off - k), a + perp * wa * (off - k)])

        bar = [quad(1.0, 0.0), a + wa * _CIRCLE32, b + wb * _CIRCLE32]
        shapes += [_Shape(p, HANDLE_EDGE) for p in bar]
        shapes += [_Shape(quad(0.8, 0.0), HANDLE_COLOUR), _Shape(a + 0.8 * wa * _CIRCLE32, HANDLE_COLOUR),
                   _Shape(b + 0.8 * wb * _CIRCLE32, HANDLE_COLOUR), _Shape(quad(0.25, 0.38), HANDLE_HIGHLIGHT)]
        bar_hull = cv2.convexHull(np.vstack(bar).astype(np.float32))[:, 0, :].astype(np.float64)
        outline = cv2.convexHull(np.vstack([bar_hull, rose_hull]).astype(np.float32))[:, 0, :].astype(np.float64)
        _, depth = view.project(np.array([hd.centre]))
        return _Item(depth=float(depth[0]), shapes=shapes, target=hd.truth_id, target_region=bar_hull,
                     target_corners=outline)

    def _arm_items(self, view: _View, pts3: np.ndarray) -> tuple[list, list]:
        """(flat items, 3D items) for the arm's chain points (N, 3)."""
        p, d = view.project(pts3)
        # the base plate on the desk stays where it is while the arm moves: in a rig view its item
        # is made once (and so keeps its pixels)
        rig_view = id(view) in self._thing_items
        key = pts3[0].tobytes()
        kept = self._arm_base_kept.get(id(view)) if rig_view else None
        if kept is not None and kept[0] == key:
            base_item = kept[1]
        else:
            base = np.column_stack([pts3[0, 0] + ARM_BASE_RADIUS_M * _CIRCLE32[:, 0],
                                    pts3[0, 1] + ARM_BASE_RADIUS_M * _CIRCLE32[:, 1],
                                    np.full(len(_CIRCLE32), pts3[0, 2])])
            base_px = view.project_polygon(base)
            base_item = None if base_px is None else _Item(
                depth=0.0, shapes=[_Shape(base_px, ARM_BASE_COLOUR)],
                lines=[(base_px, _shade(ARM_BASE_COLOUR, 1.6), True)], flat=True)
            if rig_view:
                self._arm_base_kept[id(view)] = (key, base_item)
        flat = [] if base_item is None else [base_item]
        items = []
        mid3 = pts3[0] + 0.05 * LIGHT
        l0, _ = view.project(np.array([pts3[0], mid3]))
        light_dir = l0[1] - l0[0]
        for i in range(len(pts3) - 1):
            a, b = p[i], p[i + 1]
            seg = b - a
            length = float(np.hypot(*seg))
            if length < 1e-6 or d[i] < NEAR_M or d[i + 1] < NEAR_M:
                continue
            u = seg / length
            perp = np.array([-u[1], u[0]])
            if perp @ light_dir < 0:
                perp = -perp  # perp points towards the light
            r = ARM_LINK_RADII_M[min(i, len(ARM_LINK_RADII_M) - 1)]
            wa, wb = view.f * r / d[i], view.f * r / d[i + 1]
            # the edge, body and highlight quads at once: corner + (perp · width) · offset, the same
            # operations in the same order per coordinate as one quad at a time
            ends = np.array([a, b, b, a])
            reach = np.array([perp * wa, perp * wb, perp * wb, perp * wa])
            quads = ends + reach * _LINK_QUAD_OFFSETS
            shapes = [_Shape(quads[0], ARM_LINK_EDGE), _Shape(quads[1], ARM_LINK_COLOUR),
                      _Shape(quads[2], ARM_LINK_HIGHLIGHT)]
            items.append(_Item(depth=float(d[i] + d[i + 1]) / 2, shapes=shapes))
        last = len(pts3) - 1
        towards_light = light_dir / (np.hypot(*light_dir) + 1e-9)
        for i in range(1, len(pts3)):
            if d[i] < NEAR_M:
                continue
            tool = i == last
            rr = view.f * (ARM_TOOL_RADIUS_M if tool else ARM_JOINT_RADIUS_M) / d[i]
            colour = ARM_TOOL_COLOUR if tool else ARM_JOINT_COLOUR
            hl = p[i] + towards_light * rr * 0.3
            shapes = [_Shape(p[i] + rr * _CIRCLE32, colour),
                      _Shape(hl + rr * 0.45 * _CIRCLE32, _shade(colour, 1.5) if tool else (80, 80, 86))]
            items.append(_Item(depth=float(d[i]) - 1e-4, shapes=shapes))
        return flat, items

    def _hand_item(self, view: _View, hand: Hand) -> Optional[_Item]:
        pose = (hand.x, hand.y, hand.z, hand.yaw)
        # its outlines and the gaps between its fingers placed and projected at once (a row's
        # arithmetic as alone: project_polygon's numbers), those crossing the near plane clipped
        base = self._local_to_base(pose, _HAND_LOCAL)
        P = view.P
        h = base @ P[:, :3].T + P[:, 3]
        front = (h[:, 2] >= NEAR_M).tolist()
        px_all = h[:, :2] / h[:, 2:3]
        pieces, i = [], 0
        for n in _HAND_PART_LENGTHS:
            k = i + n
            pieces.append(px_all[i:k] if all(front[i:k]) else view.project_polygon(base[i:k]))
            i = k
        shapes = [_Shape(px, HAND_COLOUR) for px in pieces[:len(_HAND_OUTLINES)] if px is not None]
        if not shapes:
            return None
        lines = [(px, HAND_DARK, False) for px in pieces[len(_HAND_OUTLINES):] if px is not None and len(px) == 2]
        _, depth = view.project(np.array([[hand.x, hand.y, hand.z]]))
        return _Item(depth=float(depth[0]), shapes=shapes, lines=lines)

    def _band_item(self, view: _View, band: Wristband, hand_depth: float) -> _Item:
        """A teleop hand's wristband: a dark strip across the forearm and its marker, on top of the hand."""
        pose = self._marker_pose(band)
        half_u, half_v = 0.038, WRISTBAND_WIDTH_M / 2
        strip = view.project_polygon(self._local_to_base(
            pose, np.array([[-half_u, -half_v], [half_u, -half_v], [half_u, half_v], [-half_u, half_v]])))
        marker, black, region = self._marker_parts(view, band, disc=False)
        _, depth = view.project(np.array([pose[:3]]))
        return _Item(depth=min(float(depth[0]), hand_depth - 1e-3),
                     shapes=[] if strip is None else [_Shape(strip, WRISTBAND_COLOUR)], marker=marker,
                     target=band.marker_id, target_region=region, target_corners=black)

    def _shadow_polygons(self, st: SceneState, arm: Optional[np.ndarray]) -> list:
        """Shadows cast on the desk (z = 0) by the lamp: a list of (M, 3) robot_base polygons."""
        drop = np.array([LIGHT[0] / LIGHT[2], LIGHT[1] / LIGHT[2], 1.0])

        def on_desk(pts: np.ndarray) -> np.ndarray:
            return pts - pts[:, 2:3] * drop

        polys = []
        for cup in st.cups:
            cs, sn = np.cos(_CUP_ANGLES), np.sin(_CUP_ANGLES)
            pts = np.vstack([
                np.column_stack([cup.x + self.cup_top_radius_m * cs, cup.y + self.cup_top_radius_m * sn,
                                 np.full_like(cs, cup.lift + CUP_HEIGHT_M)]),
                np.column_stack([cup.x + self.cup_rim_radius_m * cs, cup.y + self.cup_rim_radius_m * sn,
                                 np.full_like(cs, cup.lift)]),
            ])
            flat = on_desk(pts)
            hull = cv2.convexHull(flat[:, :2].astype(np.float32))[:, 0, :].astype(np.float64)
            polys.append(np.column_stack([hull, np.zeros(len(hull))]))
        if st.ball is not None:
            c = on_desk(np.array([[st.ball.x, st.ball.y, BALL_RADIUS_M]]))[0]
            circ = np.column_stack([c[0] + BALL_RADIUS_M * _CIRCLE32[:, 0] * 1.1,
                                    c[1] + BALL_RADIUS_M * _CIRCLE32[:, 1] * 1.3, np.zeros(len(_CIRCLE32))])
            polys.append(circ)
        for th in st.things:
            shadow = self._thing_shadows.get(th)
            if shadow is None:
                if len(self._thing_shadows) >= THING_CACHE:
                    self._thing_shadows.clear()
                shadow = self._thing_shadows[th] = self._thing_shadow(th, on_desk)
                shadow.setflags(write=False)  # kept: its projection in each view is kept too (_draw_shadows)
            polys.append(shadow)
        for panel in st.panels:  # the plate (the buttons' shadows fall on it and are left out)
            hw, hl = panel.width_m / 2, panel.length_m / 2
            local = np.array([[-hw, hl], [hw, hl], [hw, -hl], [-hw, -hl]])
            box = self._local_to_base((panel.x, panel.y, panel.top_z, panel.yaw), local)
            polys.append(self._dropped_hull(np.vstack([box, box * [1.0, 1.0, 0.0]]), on_desk))
        for hd in st.handles:
            cs, sn = _CIRCLE32[:, 0], _CIRCLE32[:, 1]
            rose = np.column_stack([hd.x + hd.rose_radius_m * cs, hd.y + hd.rose_radius_m * sn,
                                    np.full(len(cs), hd.rose_height_m)])
            polys.append(self._dropped_hull(rose, on_desk))
            r = hd.thickness_m / 2
            across = r * np.array([-math.sin(hd.yaw), math.cos(hd.yaw), 0.0])  # half the bar's width
            bar = [np.array(hd.along(along, hd.bar_height_m + dz)) + k * across
                   for along in (-r, hd.length_m + r) for dz in (-r, r) for k in (-1.0, 1.0)]
            polys.append(self._dropped_hull(np.array(bar), on_desk))
        n_outline = sum(_HAND_PART_LENGTHS[:len(_HAND_OUTLINES)])
        for hand in st.hands:  # (its outlines placed at once: the same rows as one at a time)
            flat = on_desk(self._local_to_base((hand.x, hand.y, hand.z, hand.yaw), _HAND_LOCAL[:n_outline]))
            i = 0
            for n in _HAND_PART_LENGTHS[:len(_HAND_OUTLINES)]:
                polys.append(flat[i:i + n])
                i += n
        if arm is not None and len(arm) >= 2:
            kept = self._arm_shadows_kept
            if kept is None or kept[0] != arm.tobytes():
                kept = self._arm_shadows_kept = (arm.tobytes(), self._arm_shadows(arm, on_desk))
            polys += kept[1]
        return polys

    @staticmethod
    def _arm_shadows(arm: np.ndarray, on_desk) -> list:
        """The arm's shadow polygons (M, 3) on the desk: its links and joints, read-only (kept while
        the arm stays still, and so are their projections: _draw_shadows)."""
        polys = []
        if len(arm) >= 2:
            sh = on_desk(arm)
            for i in range(len(sh) - 1):
                seg = sh[i + 1, :2] - sh[i, :2]
                length = float(np.hypot(*seg))
                r = ARM_LINK_RADII_M[min(i, len(ARM_LINK_RADII_M) - 1)]
                if length < 1e-6:
                    continue
                perp = np.array([-seg[1], seg[0]]) / length * r
                a, b = sh[i, :2], sh[i + 1, :2]
                quad = np.array([a + perp, b + perp, b - perp, a - perp])
                polys.append(np.column_stack([quad, np.zeros(4)]))
            for i in range(1, len(sh)):
                r = ARM_TOOL_RADIUS_M if i == len(sh) - 1 else ARM_JOINT_RADIUS_M
                polys.append(np.column_stack([sh[i, 0] + r * _CIRCLE32[:, 0], sh[i, 1] + r * _CIRCLE32[:, 1],
                                              np.zeros(len(_CIRCLE32))]))
        for p in polys:
            p.setflags(write=False)
        return polys

    @staticmethod
    def _dropped_hull(pts: np.ndarray, on_desk) -> np.ndarray:
        """The hull (M, 3) on the desk of points (N, 3) dropped along the light."""
        flat = on_desk(pts)
        hull = cv2.convexHull(flat[:, :2].astype(np.float32))[:, 0, :].astype(np.float64)
        return np.column_stack([hull, np.zeros(len(hull))])

    @staticmethod
    def _thing_shadow(th: Thing, on_desk) -> np.ndarray:
        """A thing's shadow on the desk: the hull of its points dropped along the light (M, 3)."""
        if th.kind == "ball" or th.kind == "plush":
            a, b = (th.radius_m, th.height_m / 2) if th.kind == "plush" else (th.radius_m, th.radius_m)
            c, s = math.cos(th.yaw), math.sin(th.yaw)
            R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
            pts = np.array(th.centre) + (_SPHERE * np.array([a, b, b])) @ R.T
        else:
            top_r = th.radius_m if th.kind == "disc" else th.radius_m - (CUP_RIM_RADIUS_M - CUP_TOP_RADIUS_M)
            cs, sn = np.cos(_CUP_ANGLES), np.sin(_CUP_ANGLES)
            pts = np.vstack([np.column_stack([th.x + top_r * cs, th.y + top_r * sn, np.full_like(cs, th.height_m)]),
                             np.column_stack([th.x + th.radius_m * cs, th.y + th.radius_m * sn, np.zeros_like(cs)])])
        flat = on_desk(pts)
        hull = cv2.convexHull(flat[:, :2].astype(np.float32))[:, 0, :].astype(np.float64)
        return np.column_stack([hull, np.zeros(len(hull))])

    def _layout(self, view: _View, st: SceneState, arm: Optional[np.ndarray]) -> list:
        """Items in painting order: flat things on the desk first, then far to near."""
        flat, solid = [], []
        if arm is not None:
            f, s = self._cached_arm_items(view, arm)
            flat += f
            solid += s
        flat += [self._cached_card_item(view, c) for c in st.cards]
        solid += [self._cup_item(view, c) for c in st.cups]
        if st.ball is not None:
            ball_cup = next((c for c in st.cups if c.lift > 0.001), None) if st.cups else None
            if ball_cup is not None or not st.cups:  # under a resting cup it cannot be seen
                solid.append(self._ball_item(view, st.ball.x, st.ball.y))
        solid += [self._cached_thing_item(view, th) for th in st.things]
        for panel in st.panels:
            solid += self._panel_items(view, panel)
        solid += [self._handle_item(view, hd) for hd in st.handles]
        for hand in st.hands:
            item = self._hand_item(view, hand)
            if item is not None:
                solid.append(item)
                if hand.band is not None and (hand.band.marker_id, False) in self._textures:
                    solid.append(self._band_item(view, hand.band, item.depth))
        solid.sort(key=lambda it: -it.depth)
        return flat + solid

    # -- truth -----------------------------------------------------------------------------

    def _visibility(self, items: list, size: tuple[int, int]) -> dict[int, bool]:
        """For each target: inside the image (with EDGE_MARGIN_PX) and not covered by a later item."""
        w, h = size
        m = EDGE_MARGIN_PX
        out = {}
        if not any(it.target is not None for it in items):
            return out
        # what each occluder covers: its polygons with their bounds, and the bounds of them all,
        # computed once (with a dozen targets the pairwise tests dominated the render)
        covers: list = []
        for it in items:
            if it.cover is None:
                polys = self._silhouettes(it) if it.occluder else []
                box = _item_box(it) if polys and it.marker is None and not it.textures else ()
                if box:  # a bound of them all (wider than their own: it only skips far targets)
                    it.cover = ([polys, box[:2], box[2:], None],)
                elif polys:
                    # the bounds of them all as Python floats (NaN wins, as in numpy's min); each
                    # polygon's own bounds only when a target lies within them all
                    allp = polys[0] if len(polys) == 1 else np.concatenate(polys)
                    it.cover = ([polys, tuple(allp.min(axis=0).tolist()), tuple(allp.max(axis=0).tolist()), None],)
                else:
                    it.cover = (None,)
            covers.append(it.cover[0])
        for idx, it in enumerate(items):
            if it.target is None:
                continue
            bounds = it.target_bounds  # (kept: a still thing's item is asked again every frame)
            if bounds is None:
                c = it.target_corners
                bounds = it.target_bounds = [c.min(axis=0).tolist() + c.max(axis=0).tolist(), None]
            cx0, cy0, cx1, cy1 = bounds[0]
            if not (cx0 >= m and cx1 <= w - 1 - m and cy0 >= m and cy1 <= h - 1 - m):  # (NaN: not inside)
                out[it.target] = False
                continue
            reg = it.target_region
            if bounds[1] is None:
                rx0, ry0 = np.floor(reg.min(axis=0)).astype(int) - 1
                rx1, ry1 = np.ceil(reg.max(axis=0)).astype(int) + 2
                bounds[1] = (int(rx0), int(ry0), int(rx1), int(ry1))
            x0, y0, x1, y1 = bounds[1]
            x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
            near = []  # what later items' bounds say may cover it
            for later in covers[idx + 1:]:
                if later is None:
                    continue
                lo, hi = later[1], later[2]
                if hi[0] < x0 or lo[0] > x1 or hi[1] < y0 or lo[1] > y1:
                    continue
                near.append(later)
            kept = it.visible_kept
            if (kept is not None and kept[0] == size and len(kept[1]) == len(near)
                    and all(a is b for a, b in zip(kept[1], near))):
                out[it.target] = kept[2]  # the same items (still ones' kept covers) as last time
                continue
            origin = np.array([x0, y0], dtype=float)
            target = None
            cover = None
            for later in near:
                polys, lo, hi, bounded = later
                if bounded is None:
                    bounded = later[3] = [(pts, tuple(pts.min(axis=0).tolist()), tuple(pts.max(axis=0).tolist()))
                                          for pts in polys]
                for pts, lo, hi in bounded:  # a card on top of another card hides it too
                    if hi[0] < x0 or lo[0] > x1 or hi[1] < y0 or lo[1] > y1:
                        continue
                    if cover is None:
                        target = np.zeros((y1 - y0, x1 - x0), np.uint8)
                        _fill(target, reg - origin, 255, aa=False)
                        cover = np.zeros_like(target)
                    _fill(cover, pts - origin, 255, aa=False)
            out[it.target] = cover is None or cv2.countNonZero(cv2.bitwise_and(target, cover)) == 0
            it.visible_kept = (size, near, out[it.target])  # (holding near keeps their ids)
        return out

    def _truth_entries(self, st: SceneState) -> list[tuple[int, tuple[float, float, float], str, str]]:
        """(truth id, truth point in robot_base, label, kind) of every object of ``st``, in truth order."""
        entries = []
        for card in st.cards:
            entries.append((card.marker_id, (float(card.x), float(card.y), 0.0), f"card {card.marker_id}", "marker"))
        for cup in st.cups:
            entries.append((cup.marker_id, (float(cup.x), float(cup.y), float(cup.lift + CUP_HEIGHT_M)), cup.label,
                            "marker"))
        if st.ball is not None:
            entries.append((-1, (float(st.ball.x), float(st.ball.y), BALL_RADIUS_M), "ball", "ball"))
        for th in st.things:  # marker-less things: negative ids, "<colour> <kind>" labels
            entries.append((th.truth_id, th.centre, th.label, th.kind))
        for panel in st.panels:  # a lift panel's buttons: the middle of each top face
            for n in panel.BUTTONS:
                entries.append((panel.button_truth_id(n), panel.button_centre(n), panel.button_label(n), "button"))
        for handle in st.handles:
            entries.append((handle.truth_id, handle.centre, handle.label, "handle"))
        for hand in st.hands:  # a teleop hand's wristband: its marker's centre
            if hand.band is not None:
                entries.append((hand.band.marker_id, hand.band.centre, f"wristband {hand.band.marker_id}", "marker"))
        return entries

    def _truth(self, st: SceneState, layouts: dict) -> GroundTruth:
        vis = {side: self._visibility(layouts[side], self._views[side].size) for side in SIDES}
        objects = [ObjectTruth(key, point, vis["left"].get(key, False), vis["right"].get(key, False),
                               label=label, kind=kind)
                   for key, point, label, kind in self._truth_entries(st)]
        return GroundTruth(objects=tuple(objects), pointing_target_id=st.pointing_target_id)

    def truth(self, t: float, arm_points: Optional[np.ndarray] = None) -> GroundTruth:
        """The ground truth ``render`` would return at t, without drawing any pixels."""
        st = self.scene(t)
        arm = self._check_arm(arm_points)
        layouts = {side: self._layout(self._views[side], st, arm) for side in SIDES}
        return self._truth(st, layouts)

    @staticmethod
    def _silhouettes(it: _Item) -> list[np.ndarray]:
        """The image polygons (px) an item covers: its filled shapes and its composited textures."""
        polys = [sh.pts for sh in it.shapes]
        if it.marker is not None:
            polys.append(it.marker[2])
        polys += [tex[2] for tex in it.textures]
        return polys

    def _image_boxes(self, items: list, size: tuple[int, int], names: dict) -> dict[int, "ImageBox"]:
        """Boxes of the visible pixels of each target among ``items`` (painting order), see image_boxes."""
        w, h = size
        owner = np.zeros((h, w), np.uint16)  # which item is on top at each pixel (index + 1; 0: desk)
        for idx, it in enumerate(items):
            if it.occluder or it.target is not None:
                for pts in self._silhouettes(it):
                    _fill(owner, pts, idx + 1, aa=False)
        out = {}
        for idx, it in enumerate(items):
            if it.target is None or it.target not in names:
                continue
            polys = self._silhouettes(it)
            allp = np.vstack(polys)
            if not np.all(np.isfinite(allp)):
                continue
            # the whole silhouette (also beyond the image's edges): the denominator of the fraction
            bx0, by0 = (int(v) - 1 for v in np.floor(allp.min(axis=0)))
            bx1, by1 = (int(v) + 2 for v in np.ceil(allp.max(axis=0)))
            bx0, by0 = max(bx0, -4 * w), max(by0, -4 * h)  # a ray near the near plane: bounded canvas
            bx1, by1 = min(bx1, 5 * w), min(by1, 5 * h)
            if bx1 <= bx0 or by1 <= by0:
                continue
            own = np.zeros((by1 - by0, bx1 - bx0), np.uint8)
            origin = np.array([bx0, by0], dtype=float)
            for pts in polys:
                _fill(own, pts - origin, 255, aa=False)
            total = cv2.countNonZero(own)
            x0, y0, x1, y1 = max(bx0, 0), max(by0, 0), min(bx1, w), min(by1, h)
            if total == 0 or x1 <= x0 or y1 <= y0:
                continue
            mine = owner[y0:y1, x0:x1] == idx + 1
            ys, xs = np.nonzero(mine)
            if len(xs) == 0:
                continue
            label, kind = names[it.target]
            out[it.target] = ImageBox(truth_id=it.target, x0=int(xs.min()) + x0, y0=int(ys.min()) + y0,
                                      x1=int(xs.max()) + x0 + 1, y1=int(ys.max()) + y0 + 1,
                                      visible_fraction=min(1.0, len(xs) / total), visible_px=int(len(xs)),
                                      kind=kind, label=label)
        return {key: out[key] for key in names if key in out}  # in truth order

    def image_boxes(self, t: float, arm_points: Optional[np.ndarray] = None) -> dict[str, dict[int, "ImageBox"]]:
        """Per side ("left", "right"), per truth id: the box of what is visible of each object.

        The boxes of a ``render(t, arm_points)``: each object's silhouette as drawn (its filled
        polygons and textures, without anti-aliasing), minus what nearer items (other objects, the
        hand, the arm) paint over it, clipped to the image — the painter's order of the render
        itself, so a box is tight to the drawn pixels (within ~1 px: edges are anti-aliased and
        blurred). Objects with no visible pixel in a view are left out of that view's dict.
        Every object with a truth id is there: cards and cups with markers (kind "marker"), the
        cups game's ball, marker-less things, the panel's buttons and the door handle.
        """
        st = self.scene(float(t))
        arm = self._check_arm(arm_points)
        names = {key: (label, kind) for key, _, label, kind in self._truth_entries(st)}
        return {side: self._image_boxes(self._layout(self._views[side], st, arm), self._views[side].size, names)
                for side in SIDES}

    # -- drawing -----------------------------------------------------------------------------

    def _composite_marker(self, img: np.ndarray, marker: tuple) -> Optional[tuple]:
        """A marker's paper over ``img``. Its warped patch is kept while its homography and outline
        stay the same to the bit (a marker lying still before a still camera): the supersampled warp
        was most of a still desk's drawing time, the blend that remains is a few small 8-bit ops."""
        marker_id, H, paper_px, disc = marker
        key = (marker_id, disc, img.shape, np.asarray(H, np.float64).tobytes(), np.asarray(paper_px, np.float64).tobytes())
        cache = self._marker_patches
        patch = cache.get(key)
        if patch is None:
            tool = self.tool_marker is not None and marker_id == self.tool_marker[0]
            S = SUPERSAMPLE if tool else MARKER_SUPERSAMPLE  # (see MARKER_SUPERSAMPLE)
            patch = self._warp_patch(img.shape, self._textures[(marker_id, disc)], H, paper_px, S)
            if len(cache) >= MARKER_PATCH_CACHE:
                cache.clear()  # markers that moved: their old patches will not come back
            cache[key] = patch
        return self._blend(img, patch)

    @staticmethod
    def _composite(img: np.ndarray, tex: np.ndarray, H: np.ndarray, paper_px: np.ndarray, S: int) -> Optional[tuple]:
        """Paint premultiplied BGRA ``tex`` (texel → image px homography ``H``) over ``img`` inside
        the bounding box of ``paper_px``, warped at S× and area-averaged (anti-aliased edges).
        Returns the box painted (as ``_blend``)."""
        return SimDesk._blend(img, SimDesk._warp_patch(img.shape, tex, H, paper_px, S))

    @staticmethod
    def _warp_patch(shape: tuple, tex: np.ndarray, H: np.ndarray, paper_px: np.ndarray, S: int) -> Optional[tuple]:
        """``_composite``'s patch for an image of ``shape``: (x0, y0, premultiplied BGR, 1 − α as 3
        channels), or None when it lies outside the image."""
        h_img, w_img = shape[:2]
        x0, y0 = np.floor(paper_px.min(axis=0)).astype(int) - 1
        x1, y1 = np.ceil(paper_px.max(axis=0)).astype(int) + 2
        x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w_img), min(y1, h_img)
        if x1 <= x0 or y1 <= y0:
            return None
        # supersampled patch pixel (xs, ys) has its centre at image x0 - 0.5 + (xs + 0.5) / S
        to_patch = np.array([[S, 0.0, (0.5 - x0) * S - 0.5], [0.0, S, (0.5 - y0) * S - 0.5], [0.0, 0.0, 1.0]])
        sup = cv2.warpPerspective(tex, to_patch @ H, ((x1 - x0) * S, (y1 - y0) * S), flags=cv2.INTER_LINEAR,
                                  borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0, 0))
        small = sup if S == 1 else cv2.resize(sup, (x1 - x0, y1 - y0), interpolation=cv2.INTER_AREA)
        keep = cv2.subtract(255, small[..., 3])
        return int(x0), int(y0), np.ascontiguousarray(small[..., :3]), cv2.merge([keep, keep, keep])

    @staticmethod
    def _blend(img: np.ndarray, patch: Optional[tuple]) -> Optional[tuple]:
        """Premultiplied "over" of a ``_warp_patch`` patch: roi · (1 − α) + colour·α, in 8-bit ops (±1 level).
        Returns the patch's box (x0, y0, x1, y1), or None when there was none."""
        if patch is None:
            return None
        x0, y0, colour, keep3 = patch
        roi = img[y0:y0 + colour.shape[0], x0:x0 + colour.shape[1]]
        cv2.multiply(roi, keep3, dst=roi, scale=1.0 / 255.0)
        cv2.add(roi, colour, dst=roi)
        return x0, y0, x0 + colour.shape[1], y0 + colour.shape[0]

    def _draw_shadows(self, img: np.ndarray, view: _View, polys3: list, dirty: list) -> None:
        """Darken ``img`` under the shadows ``polys3`` (robot_base polygons on the desk): a mask of
        the filled polygons, blurred, multiplied in; the boxes darkened are appended to ``dirty``.

        Shadows are masked and blurred in groups whose boxes (bounds + the blur's reach) do not
        overlap: a pixel sees only its own group's polygons within the blur's reach, so the result
        is that of one mask over them all, without blurring the empty desk between them. A group
        that lies still (same polygons to the bit: the objects scene's still things) keeps its
        blurred patch — per view, at most SHADOW_CACHE of them."""
        if not polys3:
            return
        h_img, w_img = img.shape[:2]
        pad = int(3 * SHADOW_BLUR_PX) + 2

        def projected(q: np.ndarray) -> tuple:
            p = view.project_polygon(q)
            if p is None:
                return None, None
            (x0, y0), (x1, y1) = p.min(axis=0).tolist(), p.max(axis=0).tolist()
            if not all(map(math.isfinite, (x0, y0, x1, y1))):
                return p, (0, 0, w_img, h_img)
            return p, (max(math.floor(x0) - pad, 0), max(math.floor(y0) - pad, 0),
                       min(math.ceil(x1) + pad, w_img), min(math.ceil(y1) + pad, h_img))

        kept = view.shadow_px  # id → (a kept read-only polygon, its projection, its box)
        found: list = []
        todo = []
        for j, q in enumerate(polys3):
            hit = kept.get(id(q)) if not q.flags.writeable else None
            if hit is not None and hit[0] is q:
                found.append(hit[1:])
            else:
                found.append(None)
                if len(q) >= 2:
                    todo.append(j)
        if len(todo) > 1:
            # the polygons that moved projected at once: one product for them all (a row's
            # arithmetic does not depend on the others' once there are two or more rows: the
            # same numbers as project_polygon's, which still clips those that cross the near plane)
            P = view.P
            hs = np.concatenate([polys3[j] for j in todo]) @ P[:, :3].T + P[:, 3]
            front = (hs[:, 2] >= NEAR_M).tolist()
            pxs = hs[:, :2] / hs[:, 2:3]
            i = 0
            for j in todo:
                k = i + len(polys3[j])
                if all(front[i:k]):
                    p = pxs[i:k]
                    (x0, y0), (x1, y1) = p.min(axis=0).tolist(), p.max(axis=0).tolist()
                    if not all(map(math.isfinite, (x0, y0, x1, y1))):
                        found[j] = (p, (0, 0, w_img, h_img))
                    else:
                        found[j] = (p, (max(math.floor(x0) - pad, 0), max(math.floor(y0) - pad, 0),
                                        min(math.ceil(x1) + pad, w_img), min(math.ceil(y1) + pad, h_img)))
                    if not polys3[j].flags.writeable:
                        if len(kept) >= SHADOW_CACHE:
                            kept.clear()
                        kept[id(polys3[j])] = (polys3[j], *found[j])
                i = k
        polys, boxes = [], []
        for q, hit in zip(polys3, found):
            if hit is None:
                hit = projected(q)
                if not q.flags.writeable:
                    if len(kept) >= SHADOW_CACHE:
                        kept.clear()
                    kept[id(q)] = (q, *hit)  # (holding q keeps its id from being reused)
            p, box = hit
            if p is not None:
                polys.append(p)
                boxes.append(box)
        groups: list = []  # [box, indices of its polygons]
        for i, box in enumerate(boxes):
            if box[2] <= box[0] or box[3] <= box[1]:
                continue  # off the image: nothing of it (nor of its blur) shows
            members = [i]
            merged = True
            while merged:
                merged = False
                for g, (o, idx) in enumerate(groups):
                    if o[0] < box[2] and box[0] < o[2] and o[1] < box[3] and box[1] < o[3]:
                        box = (min(o[0], box[0]), min(o[1], box[1]), max(o[2], box[2]), max(o[3], box[3]))
                        members = idx + members
                        del groups[g]
                        merged = True
                        break
            groups.append((box, members))
        cache = view.shadow_patches
        level = int(round(255 * SHADOW_DARKNESS))
        lights: list = []
        masks: dict = {}  # index in groups → (key, the group's mask) of groups not kept
        for g, ((x0, y0, x1, y1), members) in enumerate(groups):
            members.sort()  # painted in the order of polys3, as into one mask
            key = (x0, y0, x1, y1, b"".join(polys[i].tobytes() + b"|" for i in members))
            light = cache.get(key)
            if light is None:
                mask = np.zeros((y1 - y0, x1 - x0), np.uint8)
                origin = np.array([x0, y0], dtype=float)
                for i in members:
                    _fill(mask, polys[i] - origin, level)
                masks[g] = (key, mask)
            lights.append(light)
        if masks:
            blurred = _blur_shadow_masks([mask for _, mask in masks.values()])
            if len(cache) + len(masks) > SHADOW_CACHE:
                cache.clear()  # groups that moved: their old patches will not come back
            for (g, (key, _)), mask in zip(masks.items(), blurred):
                lights[g] = cache[key] = cv2.merge([cv2.subtract(255, mask)] * 3)
        for ((x0, y0, x1, y1), _), light in zip(groups, lights):
            roi = img[y0:y1, x0:x1]
            cv2.multiply(roi, light, dst=roi, scale=1.0 / 255.0)
            dirty.append((x0, y0, x1, y1))

    @staticmethod
    def _paint_shapes(img: np.ndarray, it: _Item) -> tuple:
        """Paint ``it``'s shapes, then its lines; returns ``_item_box(it)``. An item that keeps its
        pixels and finds the same pixels under its box as last time pastes last time's result
        (the same bytes: painting is a function of what lies under it)."""
        box = _item_box(it)
        roi = before = None
        if it.keep_pixels and box:
            h, w = img.shape[:2]
            x0, y0, x1, y1 = max(box[0], 0), max(box[1], 0), min(box[2], w), min(box[3], h)
            if x1 <= x0 or y1 <= y0:
                return box  # off the image
            kept = it.kept
            if kept is None:
                # painted for the first time: kept from the second on (a moving thing's or arm's
                # item is made anew each frame: its pixels would be copied twice for nothing)
                it.kept = _PAINTED_ONCE
            else:
                roi = img[y0:y1, x0:x1]
                if kept is not _PAINTED_ONCE and kept[0] == img.shape and cv2.norm(kept[1], roi, cv2.NORM_INF) == 0:
                    roi[...] = kept[2]
                    return box
                before = roi.copy()
        for sh in it.shapes:
            sh.fill(img)
        for (_, colour, closed), fixed in zip(it.lines, it.line_fixed):
            cv2.polylines(img, [fixed], closed, colour, 1, lineType=cv2.LINE_AA, shift=4)
        if roi is not None:
            it.kept = (img.shape, before, roi.copy())
        return box

    def _draw(self, view: _View, items: list, shadows3: list,
              canvas: bool = False) -> tuple[np.ndarray, Optional[list]]:
        """The view's desk with ``items`` painted (and the shadows after the flat ones), and the
        boxes (x0, y0, x1, y1) outside which it is still the bare desk (None: no such bound).

        With ``canvas`` the image is the view's kept canvas (valid until the next such draw: the
        caller finishes it into a new image), else a new copy of the desk."""
        if canvas:
            img = view.canvas
            if img is None or view.canvas_dirty is None:
                img = view.canvas = view.desk.copy()
            else:
                for x0, y0, x1, y1 in view.canvas_dirty:
                    img[y0:y1, x0:x1] = view.desk[y0:y1, x0:x1]
            view.canvas_dirty = None  # (until this drawing has told where it painted)
        else:
            img = view.desk.copy()
        dirty: list = []
        bounded = True
        n_flat = sum(1 for it in items if it.flat)
        for idx, it in enumerate(items):
            if idx == n_flat:
                self._draw_shadows(img, view, shadows3, dirty)
            if it.shapes or it.lines:
                box = self._paint_shapes(img, it)
                if box:
                    dirty.append(box)
                else:
                    bounded = False
            if it.marker is not None:
                box = self._composite_marker(img, it.marker)
                if box is not None:
                    dirty.append(box)
            for tex, H, outline_px, supersample in it.textures:
                box = self._composite(img, tex, H, outline_px, supersample)
                if box is not None:
                    dirty.append(box)
        if n_flat == len(items):
            self._draw_shadows(img, view, shadows3, dirty)
        if not bounded:
            return img, None
        # (merged once: the finish merges these, grown by the blur's reach, instead of them all)
        dirty = _merge_boxes(dirty, 0, img.shape[1], img.shape[0])
        if canvas:
            view.canvas_dirty = dirty
        return img, dirty

    def _finish(self, img: np.ndarray, t: float, side_index: int, view: Optional[_View] = None,
                dirty: Optional[list] = None) -> np.ndarray:
        """Camera controls (LUT), lens blur and sensor noise, seeded by (seed, t, side).

        With a rig ``view`` and the ``dirty`` boxes of ``_draw`` (outside them ``img`` is the view's
        bare desk), only the boxes (and the blur's reach round them) are looked up and blurred; the
        rest comes from the view's bare desk finished once per camera setting — the same pixels as
        finishing the whole image (a pixel's blur reads only its neighbours within the kernel)."""
        blur = self.blur_sigma_px > 0
        h, w = img.shape[:2]
        sigma = self.effective_noise_sigma
        noise = None
        if sigma > 0:
            # luma noise (one value per pixel, all channels), like a webcam after its chroma
            # denoiser: a window of a larger noise field drawn once per σ and image size, at an
            # offset chosen by (seed, t, side) — 4096 different frames, no per-frame randn
            # (that was 0.65 of the 1.1 ms a view spent in blur and noise)
            up, down = self._noise_field(h, w, sigma)
            key = zlib.crc32(struct.pack("<qdq", self.seed, float(t), side_index))
            dy, dx = key % NOISE_SHIFTS, (key // NOISE_SHIFTS) % NOISE_SHIFTS
            noise = (up[dy:dy + h, dx:dx + w], down[dy:dy + h, dx:dx + w])
        if view is not None and dirty is not None and (blur or self._lut is not None):
            return self._finish_boxes(img, view, dirty, noise)
        if self._lut is not None:
            cv2.LUT(img, self._lut, dst=img)
        if blur:
            img = cv2.GaussianBlur(img, self._blur_ksize, self.blur_sigma_px)
        if noise is not None:
            # img + noise saturated to 0…255, as two 8-bit ops: a pixel's noise is in only one of the
            # two fields (the other is 0), so it saturates once, exactly like the int16 sum; the
            # mixed uint8 + int16 add took 4× as long
            cv2.add(img, noise[0], dst=img)  # img is this render's own (drawn or blurred)
            cv2.subtract(img, noise[1], dst=img)
        return img

    def _finish_boxes(self, img: np.ndarray, view: _View, dirty: list, noise: Optional[tuple]) -> np.ndarray:
        """LUT and blur of ``img`` (a ``_draw`` of ``view``) done in its ``dirty`` boxes only, over
        the view's bare desk done once (see ``_finish``), and the ``noise`` windows (up, down)
        added: a new image."""
        blur = self.blur_sigma_px > 0
        lut = self._lut
        key = (None if lut is None else lut.tobytes(), self._blur_ksize if blur else None, self.blur_sigma_px)
        cached = view.finished_desk
        if cached is None or cached[0] != key:
            bare = view.desk if lut is None else cv2.LUT(view.desk, lut)
            bare = cv2.GaussianBlur(bare, self._blur_ksize, self.blur_sigma_px) if blur else bare.copy()
            cached = view.finished_desk = (key, bare)
        # the noise's positive part goes in with the copy of the finished desk (one pass, not two)
        out = cached[1].copy() if noise is None else cv2.add(cached[1], noise[0])
        h, w = img.shape[:2]
        r = self._blur_ksize[0] // 2 if blur else 0
        # a changed pixel changes the blur within r of it; those in turn read r further out
        for x0, y0, x1, y1 in _merge_boxes(dirty, r, w, h):
            ix0, iy0, ix1, iy1 = max(x0 - r, 0), max(y0 - r, 0), min(x1 + r, w), min(y1 + r, h)
            sub = img[iy0:iy1, ix0:ix1]
            if lut is not None:
                sub = cv2.LUT(sub, lut)
            if blur:
                sub = cv2.GaussianBlur(sub, self._blur_ksize, self.blur_sigma_px)
            inner = sub[y0 - iy0:y1 - iy0, x0 - ix0:x1 - ix0]
            if noise is None:
                out[y0:y1, x0:x1] = inner
            else:
                cv2.add(inner, noise[0][y0:y1, x0:x1], dst=out[y0:y1, x0:x1])
        if noise is not None:
            cv2.subtract(out, noise[1], dst=out)
        return out

    def _noise_field(self, h: int, w: int, sigma: float) -> tuple[np.ndarray, np.ndarray]:
        """Rounded Gaussian luma noise, NOISE_SHIFTS larger than an image each way, as its positive
        and its negative part (uint8, 3 equal channels; beyond ±255 a pixel saturates anyway); made
        again when σ or the image size changes."""
        cached = self._noise
        if cached is not None and cached[0] == (h, w, sigma):
            return cached[1]
        noise = np.empty((h + NOISE_SHIFTS, w + NOISE_SHIFTS), np.float32)
        cv2.setRNGSeed(zlib.crc32(struct.pack("<qd", self.seed, sigma)) & 0x7FFFFFFF)
        cv2.randn(noise, 0.0, sigma)
        field = np.clip(np.round(cv2.cvtColor(noise, cv2.COLOR_GRAY2BGR)), -255, 255).astype(np.int16)
        parts = (np.maximum(field, 0).astype(np.uint8), np.maximum(-field, 0).astype(np.uint8))
        self._noise = ((h, w, sigma), parts)
        return parts

    @staticmethod
    def _check_arm(arm_points) -> Optional[np.ndarray]:
        if arm_points is None:
            return None
        arm = np.asarray(arm_points, dtype=float)
        if arm.ndim != 2 or arm.shape[1] != 3 or len(arm) < 1:
            raise ValueError(f"arm_points must be an (N, 3) array of robot_base points, got shape {arm.shape}")
        if not np.all(np.isfinite(arm)):
            return None
        return arm

    def scene_key(self, t: float, arm_points: Optional[np.ndarray] = None) -> tuple:
        """Everything a render at ``t`` depends on but the sensor noise: equal keys give the
        same picture (the scene state, the arm's points, the camera settings)."""
        arm = self._check_arm(arm_points)
        return (self.scene(float(t)), None if arm is None else arm.tobytes(), self._settings, self.tool_marker)

    def render(self, t: float, arm_points: Optional[np.ndarray] = None) -> tuple[np.ndarray, np.ndarray, GroundTruth]:
        """Left and right BGR uint8 images at scenario time t (s), and the ground truth.

        ``arm_points``: (N, 3) chain points base → shoulder → elbow → tool in robot_base (m), or None.
        """
        t = float(t)
        st = self.scene(t)
        arm = self._check_arm(arm_points)
        shadows3 = self._shadow_polygons(st, arm)
        layouts, images = {}, []
        for i, side in enumerate(SIDES):
            view = self._views[side]
            layouts[side] = items = self._layout(view, st, arm)
            # with a blur the finish makes a new image: the view's canvas can be drawn into
            canvas = self.blur_sigma_px > 0 and view.canvas_lock.acquire(blocking=False)
            try:
                img, dirty = self._draw(view, items, shadows3, canvas)
                images.append(self._finish(img, t, i, view, dirty))
            finally:
                if canvas:
                    view.canvas_lock.release()
        return images[0], images[1], self._truth(st, layouts)

    def render_camera(self, base_T_camera: np.ndarray, K: np.ndarray, size: tuple[int, int], t: float,
                      boxes: bool = False, noise_index: int = 2,
                      max_supersample: int = SUPERSAMPLE) -> tuple[np.ndarray, Optional[dict[int, "ImageBox"]]]:
        """The scene at time t (s) seen by any camera: a BGR uint8 image, and with ``boxes`` the
        visible pixel box of each object (as ``image_boxes``), else None.

        The hook for cameras that are not the rig's (the eye-in-hand camera of ``core.sim.hand_camera``):
        ``base_T_camera`` 4x4 in robot_base (OpenCV optical frame), ``K`` 3x3, ``size`` (w, h).
        The arm itself is not drawn (a hand camera sees past its own hand); the same desk texture,
        shading, blur and noise as the rig's views (noise seeded by (seed, t, ``noise_index``)).
        ``max_supersample`` caps the textures' supersampling (a close camera sees the panel's
        textures large: 2× instead of 4× halves a render's cost, edges stay anti-aliased).
        """
        T = np.asarray(base_T_camera, dtype=float)
        Km = np.asarray(K, dtype=float)
        if T.shape != (4, 4) or Km.shape != (3, 3) or not (np.all(np.isfinite(T)) and np.all(np.isfinite(Km))):
            raise ValueError(f"render_camera needs a finite 4x4 base_T_camera and 3x3 K, got {T.shape} and {Km.shape}")
        if self._extent is None:
            self._extent = desk_extent(self.rig)
        view = _View.from_pose(T, Km, size, self.seed, self._extent)
        t = float(t)
        st = self.scene(t)
        items = self._layout(view, st, None)
        cap = max(1, int(max_supersample))
        for it in items:
            if it.textures:
                it.textures = [(tex, H, outline, min(S, cap)) for tex, H, outline, S in it.textures]
            if it.marker is not None and cap < MARKER_SUPERSAMPLE:
                it.textures.insert(0, (self._textures[(it.marker[0], it.marker[3])], it.marker[1], it.marker[2], cap))
                it.marker = None
        image = self._finish(self._draw(view, items, self._shadow_polygons(st, None))[0], t, noise_index)
        if not boxes:
            return image, None
        names = {key: (label, kind) for key, _, label, kind in self._truth_entries(st)}
        return image, self._image_boxes(items, view.size, names)

    def stereo_frame(self, seq: int, t: float, arm_points: Optional[np.ndarray] = None) -> StereoFrame:
        """``render`` packed as a StereoFrame (capture time = t)."""
        left, right, truth = self.render(t, arm_points)
        return StereoFrame(seq=seq, t=float(t), left=left, right=right, truth=truth)
