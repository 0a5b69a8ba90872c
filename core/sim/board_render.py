"""Calibration boards rendered into a stereo pair of known geometry: test data with exact truth.

A board texture (chessboard or ChArUco) is warped onto a plane at a known pose in front of two
pinhole cameras (4× supersampled and area-averaged, so edges carry sub-pixel coverage), then the
lens distortion is applied with a remap, then light falloff, blur, sensor noise and optionally
JPEG compression (webcams send MJPG). Because the intrinsics, distortion and the right camera's
pose are known, a calibration from these images can be scored against the truth.

Used by the tests, the calibration bench and (through ``RenderedBoardCamera``) the wizard's tests,
which need a camera that shows a board held still at a sequence of poses. ``board_overlay`` /
``paint_overlay`` put a board over any other render at ``held_board_poses`` (the simulated desk
camera's ``show_board``, while the calibration wizard is open).
"""
from __future__ import annotations

import functools
import math
import os
import struct
import zlib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Optional, Sequence, Union

import cv2
import numpy as np

from core.messages import SequenceCounter, StereoFrame
from core.vision.cameras import ClockPacedSource
from core.vision.stereo_calibration import BoardDetection, BoardSpec, ChessboardSpec, pose_params

# ----------------------------------------------------------------------------------------------
# the rig


@dataclass(frozen=True, eq=False)
class StereoRigTruth:
    """A stereo pair's true intrinsics, distortion and extrinsics (OpenCV conventions, metres)."""

    K1: np.ndarray  # 3x3 left camera matrix (px)
    D1: np.ndarray  # (5,) left distortion k1 k2 p1 p2 k3
    K2: np.ndarray
    D2: np.ndarray
    R: np.ndarray  # rotation camera_left -> camera_right
    T: np.ndarray  # (3,) translation camera_left -> camera_right (m)
    size: tuple[int, int]  # (width, height) px

    @property
    def baseline_m(self) -> float:
        return float(np.linalg.norm(self.T))

    def camera(self, side: str) -> tuple[np.ndarray, np.ndarray]:
        """(K, D) of ``side`` in {"left", "right"}."""
        return (self.K1, self.D1) if side == "left" else (self.K2, self.D2)

    def pose_in(self, side: str, R: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A board pose given in camera_left, expressed in ``side``'s camera frame."""
        if side == "left":
            return R, t
        return self.R @ R, self.R @ t + self.T

    def scaled(self, factor: float) -> "StereoRigTruth":
        """The same rig delivering images ``factor`` times the size (pixel-centre convention)."""
        S = np.array([[factor, 0, (factor - 1) / 2], [0, factor, (factor - 1) / 2], [0, 0, 1.0]])
        w, h = self.size
        return replace(self, K1=S @ self.K1, K2=S @ self.K2,
                       size=(int(round(w * factor)), int(round(h * factor))))


def default_rig(distortion: bool = False, size: tuple[int, int] = (640, 480)) -> StereoRigTruth:
    """The simulated desk's rig (430 px focal length at 640x480, 6 cm baseline, slightly rotated
    right camera), optionally with webcam-like barrel distortion, at ``size`` (same aspect)."""
    from core.sim.rig import SimRig

    rig = SimRig()
    calib = rig.calibration()
    K1 = rig.K.copy()
    K2 = rig.K.copy()
    K2[0, 0] *= 1.004  # two webcams of one model still differ a little
    K2[1, 1] *= 1.004
    K2[0, 2] += 3.0
    K2[1, 2] -= 2.0
    if distortion:
        D1 = np.array([-0.12, 0.05, 0.0005, -0.0004, 0.0])
        D2 = np.array([-0.10, 0.04, -0.0003, 0.0006, 0.0])
    else:
        D1 = np.zeros(5)
        D2 = np.zeros(5)
    truth = StereoRigTruth(K1, D1, K2, D2, calib.R.copy(), calib.T.reshape(3).copy(), rig.size)
    if tuple(size) != rig.size:
        truth = truth.scaled(size[0] / rig.size[0])
    return truth


def sim_rig_truth(rig) -> StereoRigTruth:
    """The StereoRigTruth of a ``SimRig`` (or anything with ``K``, ``size`` and ``calibration()``):
    the same pinhole in both cameras, no distortion, the rig's exact extrinsics."""
    calib = rig.calibration()
    return StereoRigTruth(np.array(rig.K, float), np.zeros(5), np.array(rig.K, float), np.zeros(5),
                          np.array(calib.R, float), np.array(calib.T, float).reshape(3), tuple(rig.size))


# ----------------------------------------------------------------------------------------------
# board textures


@dataclass(frozen=True, eq=False)
class BoardTexture:
    """A board's printed image and where its texels lie on the board plane."""

    image: np.ndarray  # uint8 grey, white paper margin included
    A: np.ndarray  # 3x3: texture px (u, v, 1) -> board-frame point (x, y, 1) in metres
    outline_m: np.ndarray  # (4,2) the paper's corners in the board frame (m)


@functools.lru_cache(maxsize=8)
def board_texture(board: BoardSpec, px_per_square: int = 64) -> BoardTexture:
    """The board as printed (white margin of ¾ square) and its texel → metre mapping."""
    ppx = int(px_per_square)
    margin = int(round(0.75 * ppx))
    m_per_px = board.square_m / ppx
    if isinstance(board, ChessboardSpec):
        nx, ny = board.cols + 1, board.rows + 1
        img = np.full((ny * ppx + 2 * margin, nx * ppx + 2 * margin), 255, np.uint8)
        for j in range(ny):
            for i in range(nx):
                if (i + j) % 2 == 0:
                    img[margin + j * ppx: margin + (j + 1) * ppx, margin + i * ppx: margin + (i + 1) * ppx] = 0
        origin = board.square_m  # board frame: first inner corner
    else:
        nx, ny = board.squares_x, board.squares_y
        size = (nx * ppx + 2 * margin, ny * ppx + 2 * margin)
        img = board.cv_board().generateImage(size, marginSize=margin, borderBits=1)
        origin = 0.0  # board frame: the board's outer corner
    # texel centres: u + 0.5 texels from the texture's edge, the board starts at ``margin``
    A = np.array([[m_per_px, 0.0, (0.5 - margin) * m_per_px - origin],
                  [0.0, m_per_px, (0.5 - margin) * m_per_px - origin],
                  [0.0, 0.0, 1.0]])
    h, w = img.shape
    corners_px = np.array([[-0.5, -0.5, 1], [w - 0.5, -0.5, 1], [w - 0.5, h - 0.5, 1], [-0.5, h - 0.5, 1]])
    outline = (A @ corners_px.T).T[:, :2]
    img.setflags(write=False)
    return BoardTexture(img, A, outline)


# ----------------------------------------------------------------------------------------------
# poses


@dataclass(frozen=True, eq=False)
class BoardPose:
    """Board frame -> camera_left: X_left = R @ X_board + t (m)."""

    R: np.ndarray
    t: np.ndarray  # (3,)

    @property
    def distance_m(self) -> float:
        return float(np.linalg.norm(self.t))


def _rot(rx: float, ry: float, rz: float) -> np.ndarray:
    cx, sx, cy, sy, cz, sz = math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry), math.cos(rz), math.sin(rz)
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def project(rig: StereoRigTruth, side: str, pose: BoardPose, board_pts: np.ndarray) -> np.ndarray:
    """Image px (N,2) of board-frame points (N,2 or N,3) in ``side`` (with distortion)."""
    pts = np.asarray(board_pts, np.float64)
    if pts.shape[1] == 2:
        pts = np.hstack([pts, np.zeros((len(pts), 1))])
    R, t = rig.pose_in(side, pose.R, pose.t)
    K, D = rig.camera(side)
    rvec, _ = cv2.Rodrigues(R)
    out, _ = cv2.projectPoints(pts.reshape(-1, 1, 3), rvec, t.reshape(3, 1), K, D)
    return out.reshape(-1, 2)


def _inside(px: np.ndarray, size, margin: float) -> np.ndarray:
    w, h = size
    return (px[:, 0] >= margin) & (px[:, 0] <= w - 1 - margin) & (px[:, 1] >= margin) & (px[:, 1] <= h - 1 - margin)


def visible_fraction(rig: StereoRigTruth, board: BoardSpec, pose: BoardPose, side: str = "left",
                     margin_px: float = 2.0) -> float:
    """Share of the board's inner corners inside the ``side`` image."""
    px = project(rig, side, pose, board.object_points())
    return float(_inside(px, rig.size, margin_px).mean())


def random_poses(board: BoardSpec, rig: StereoRigTruth, n: int, seed: int = 0,
                 distance_m: tuple[float, float] = (0.35, 0.8), max_tilt_deg: float = 40.0,
                 max_roll_deg: float = 30.0, margin_px: float = 6.0,
                 partial: int = 0, partial_visible: tuple[float, float] = (0.35, 0.8)) -> list[BoardPose]:
    """``n`` varied board poses 35–80 cm in front of the rig, the whole paper inside both images;
    the last ``partial`` of them put part of the board out of the left view (a share of the inner
    corners in ``partial_visible`` stays visible)."""
    rng = np.random.default_rng(seed)
    tex = board_texture(board)
    centre = tex.outline_m.mean(axis=0)
    w, h = rig.size
    Kinv = np.linalg.inv(rig.K1)
    out: list[BoardPose] = []
    tries = 0
    while len(out) < n:
        tries += 1
        if tries > 200 * (n + 5):
            raise RuntimeError(f"could not place {n} boards in view — board too large for {distance_m} m?")
        want_partial = len(out) >= n - partial
        z = rng.uniform(*distance_m)
        spread = 0.65 if want_partial else 0.5
        u = w / 2 + rng.uniform(-spread, spread) * w * (1.3 if want_partial else 1.0)
        v = h / 2 + rng.uniform(-spread, spread) * h * (1.3 if want_partial else 1.0)
        c = z * (Kinv @ np.array([u, v, 1.0]))
        tilt = math.radians(max_tilt_deg)
        R = _rot(rng.uniform(-tilt, tilt), rng.uniform(-tilt, tilt), math.radians(rng.uniform(-max_roll_deg, max_roll_deg)))
        t = c - R @ np.array([centre[0], centre[1], 0.0])
        pose = BoardPose(R, t)
        # the board must face the cameras (not be seen from behind)
        normal_cam = R[:, 2]
        if normal_cam @ t <= 0.5 * np.linalg.norm(t):  # seen from the front, less than 60° off
            continue
        if want_partial:
            frac = visible_fraction(rig, board, pose, "left")
            if partial_visible[0] <= frac <= partial_visible[1]:
                out.append(pose)
            continue
        ok = all(_inside(project(rig, side, pose, tex.outline_m), rig.size, margin_px).all() for side in ("left", "right"))
        if ok:
            out.append(pose)
    return out


# ----------------------------------------------------------------------------------------------
# rendering


@dataclass(frozen=True)
class RenderOptions:
    """How the camera degrades the ideal image."""

    supersample: int = 4  # render at this factor and area-average (anti-aliased edges)
    blur_sigma_px: float = 0.7  # lens / focus blur (px)
    noise_sigma: float = 2.0  # sensor noise (8-bit levels)
    light: tuple[float, float] = (1.0, 1.0)  # light level at the image's left and right edges (× paper white)
    vignette: float = 0.0  # darkening at the corners (0 … 0.8)
    jpeg_quality: int = 0  # 0: no compression; else JPEG quality as a webcam's MJPG stream
    background: int = 120  # mean background level


CHEAP_WEBCAM = RenderOptions(supersample=4, blur_sigma_px=0.8, noise_sigma=4.0, light=(0.45, 1.05),
                             vignette=0.35, jpeg_quality=80, background=110)


@functools.lru_cache(maxsize=8)
def _background(size: tuple[int, int], level: int, seed: int) -> np.ndarray:
    """A smooth, untextured-enough desk/wall behind the board (grey, uint8)."""
    w, h = size
    rng = np.random.default_rng(seed + 7)
    coarse = rng.standard_normal((max(2, h // 40), max(2, w // 40))).astype(np.float32)
    n = cv2.resize(coarse, (w, h), interpolation=cv2.INTER_CUBIC)
    n = cv2.GaussianBlur(n, (0, 0), 6)
    n /= float(n.std()) + 1e-9
    img = np.clip(level + 18 * n, 0, 255).astype(np.uint8)
    img.setflags(write=False)
    return img


def _distort_maps(K: np.ndarray, D: np.ndarray, size, pad) -> tuple[np.ndarray, np.ndarray]:
    return _distort_maps_cached(K.tobytes(), D.tobytes(), tuple(size), tuple(pad))


@functools.lru_cache(maxsize=16)
def _distort_maps_cached(kb: bytes, db: bytes, size, pad):
    K = np.frombuffer(kb, np.float64).reshape(3, 3)
    D = np.frombuffer(db, np.float64)
    w, h = size
    uu, vv = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    pts = np.stack([uu.ravel(), vv.ravel()], axis=1).reshape(-1, 1, 2)
    # for each pixel of the distorted image: where its ray lands in the ideal (undistorted) image
    und = cv2.undistortPoints(pts, K, D, P=K).reshape(h, w, 2)
    mx = (und[..., 0] + pad[0]).astype(np.float32)
    my = (und[..., 1] + pad[1]).astype(np.float32)
    return cv2.convertMaps(mx, my, cv2.CV_16SC2)


def render_view(board: BoardSpec, rig: StereoRigTruth, side: str, pose: BoardPose,
                options: RenderOptions = RenderOptions(), seed: int = 0) -> np.ndarray:
    """One camera's BGR uint8 image of the board at ``pose`` (given in camera_left)."""
    tex = board_texture(board)
    K, D = rig.camera(side)
    R, t = rig.pose_in(side, pose.R, pose.t)
    w, h = rig.size
    distorted = bool(np.any(D != 0))
    pad = (int(0.2 * w), int(0.2 * h)) if distorted else (0, 0)
    cw, ch = w + 2 * pad[0], h + 2 * pad[1]
    s = int(options.supersample)
    S = np.array([[s, 0, (s - 1) / 2], [0, s, (s - 1) / 2], [0, 0, 1.0]])
    Kp = K.copy()
    Kp[0, 2] += pad[0]
    Kp[1, 2] += pad[1]
    H = S @ Kp @ np.column_stack([R[:, 0], R[:, 1], t]) @ tex.A
    bg = _background((cw, ch), options.background, seed % 4)
    big = cv2.resize(bg, (cw * s, ch * s), interpolation=cv2.INTER_NEAREST)
    cv2.warpPerspective(tex.image, H, (cw * s, ch * s), dst=big, flags=cv2.INTER_LINEAR,
                        borderMode=cv2.BORDER_TRANSPARENT)
    img = cv2.resize(big, (cw, ch), interpolation=cv2.INTER_AREA)
    if distorted:
        m1, m2 = _distort_maps(K, D, (w, h), pad)
        img = cv2.remap(img, m1, m2, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    img = img.astype(np.float32)
    lo, hi = options.light
    if (lo, hi) != (1.0, 1.0) or options.vignette:
        ramp = np.linspace(lo, hi, w, dtype=np.float32)[None, :]
        light = np.repeat(ramp, h, axis=0)
        if options.vignette:
            yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
            r2 = ((xx - w / 2) / (w / 2)) ** 2 + ((yy - h / 2) / (h / 2)) ** 2
            light *= 1.0 - options.vignette * np.clip(r2 / 2, 0, 1)
        img *= light
    if options.blur_sigma_px > 0:
        img = cv2.GaussianBlur(img, (0, 0), options.blur_sigma_px)
    if options.noise_sigma > 0:
        noise = np.empty((h, w), np.float32)
        key = struct.pack("<qq", int(seed), 0 if side == "left" else 1)
        cv2.setRNGSeed(zlib.crc32(key) & 0x7FFFFFFF)
        cv2.randn(noise, 0.0, float(options.noise_sigma))
        img += noise
    grey = np.clip(img + 0.5, 0, 255).astype(np.uint8)
    bgr = cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)
    if options.jpeg_quality:
        ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, int(options.jpeg_quality)])
        bgr = cv2.imdecode(buf, cv2.IMREAD_COLOR)
    return bgr


def render_pair(board: BoardSpec, rig: StereoRigTruth, pose: BoardPose,
                options: RenderOptions = RenderOptions(), seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The (left, right) BGR images of the board at ``pose``."""
    return (render_view(board, rig, "left", pose, options, seed),
            render_view(board, rig, "right", pose, options, seed))


@dataclass(frozen=True, eq=False)
class RenderedPair:
    left: np.ndarray
    right: np.ndarray
    pose: BoardPose
    partial: bool  # part of the board is out of the left view


def render_set(board: BoardSpec, rig: StereoRigTruth, n: int, seed: int = 0,
               options: RenderOptions = RenderOptions(), partial: int = 0, **pose_kwargs) -> list[RenderedPair]:
    """``n`` rendered pairs at random poses (the last ``partial`` partly out of view)."""
    poses = random_poses(board, rig, n, seed=seed, partial=partial, **pose_kwargs)
    out = []
    for k, pose in enumerate(poses):
        left, right = render_pair(board, rig, pose, options, seed=seed * 1000 + k)
        out.append(RenderedPair(left, right, pose, k >= n - partial))
    return out


def write_pairs(folder: Union[str, os.PathLike], pairs: Sequence, fmt: str = "png",
                start: int = 1, layout: str = "flat") -> list[tuple[Path, Path]]:
    """Save pairs as ``left_NNN.fmt`` / ``right_NNN.fmt`` (``layout="flat"``) or in ``left/`` and
    ``right/`` subfolders (``layout="split"``); returns the paths."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for k, p in enumerate(pairs, start=start):
        left, right = (p.left, p.right) if hasattr(p, "left") else p
        if layout == "split":
            lp, rp = folder / "left" / f"{k:03d}.{fmt}", folder / "right" / f"{k:03d}.{fmt}"
            lp.parent.mkdir(exist_ok=True)
            rp.parent.mkdir(exist_ok=True)
        else:
            lp, rp = folder / f"left_{k:03d}.{fmt}", folder / f"right_{k:03d}.{fmt}"
        cv2.imwrite(str(lp), left)
        cv2.imwrite(str(rp), right)
        paths.append((lp, rp))
    return paths


# ----------------------------------------------------------------------------------------------
# a board painted over another render (the simulated desk shows it while the wizard is open)

PAPER_LEVELS = (28, 226)  # printed black and paper white, 8-bit (as the desk's markers)


def held_board_poses(board: BoardSpec, rig: StereoRigTruth, n: int = 20, seed: int = 0,
                     max_tilt_deg: float = 40.0, candidates: int = 10) -> list[BoardPose]:
    """``n`` poses of ``board`` held in front of ``rig`` that fill the calibration wizard's meters:
    all of the paper in both views, from "fills most of the image" to about 2.4× that distance,
    tilted, out to the image's edges, each far from the others in (x, y, size, skew).

    Drawn from ``n × candidates`` random_poses by farthest-point sampling in the wizard's pose
    parameters (starting from the nearest pose), so the extremes come first and no two poses are
    so alike that the wizard's novelty gate would refuse one.
    """
    tex = board_texture(board)
    paper = tex.outline_m
    diag_m = float(np.linalg.norm(paper[2] - paper[0]))
    w, h = rig.size
    f = float(rig.K1[0, 0])
    near = f * diag_m / (0.8 * math.hypot(w, h))  # the paper's diagonal spans ~80 % of the image's
    m = max(n, n * int(candidates))
    for _ in range(3):  # a long, thin board may need more room: step back
        try:
            pool = random_poses(board, rig, m, seed=seed, distance_m=(near, 2.4 * near),
                                max_tilt_deg=max_tilt_deg)
            break
        except RuntimeError:
            near *= 1.5
    else:  # the last try raises random_poses' own message
        pool = random_poses(board, rig, m, seed=seed, distance_m=(near, 2.4 * near), max_tilt_deg=max_tilt_deg)
    params = np.array([_image_params(board, rig, pose) for pose in pool])
    chosen = [int(np.argmax(params[:, 2]))]
    dist = np.abs(params - params[chosen[0]]).sum(axis=1)  # L1, as PoseParams.distance
    while len(chosen) < n:
        k = int(np.argmax(dist))
        chosen.append(k)
        dist = np.minimum(dist, np.abs(params - params[k]).sum(axis=1))
    return [pool[k] for k in chosen]


def _image_params(board: BoardSpec, rig: StereoRigTruth, pose: BoardPose) -> tuple[float, float, float, float]:
    """The wizard's (x, y, size, skew) of the board at ``pose`` in the left view, from the truth."""
    corners = project(rig, "left", pose, board.object_points()).astype(np.float32)
    det = BoardDetection(True, corners, np.arange(len(corners), dtype=np.int32), image_size=tuple(rig.size))
    return pose_params(det, board).as_tuple()


@dataclass(frozen=True, eq=False)
class BoardOverlay:
    """A board as one camera sees it, ready to paint over any render of that camera."""

    x0: int  # the patch's top-left pixel in the image
    y0: int
    colour: np.ndarray  # (h, w) float32, grey premultiplied by alpha (0 … 255)
    alpha: np.ndarray  # (h, w) float32 coverage 0 … 1 (anti-aliased paper edge)


def board_overlay(board: BoardSpec, rig: StereoRigTruth, side: str, pose: BoardPose, supersample: int = 4,
                  blur_sigma_px: float = 0.0, noise_sigma: float = 0.0, seed: int = 0,
                  paper: tuple[int, int] = PAPER_LEVELS) -> Optional[BoardOverlay]:
    """The printed board at ``pose`` (in camera_left) seen by ``side``, pinhole only (the rig's
    distortion is ignored); None when no part of it is in front of the camera and in the image.

    Warped at ``supersample``× and area-averaged like ``render_view``; ``blur_sigma_px`` and
    ``noise_sigma`` (8-bit levels, fixed per call: a still board gives still pixels) make it look
    like the rest of the camera's picture.
    """
    tex = board_texture(board)
    K, _ = rig.camera(side)
    R, t = rig.pose_in(side, pose.R, pose.t)
    M = K @ np.column_stack([R[:, 0], R[:, 1], t])  # board plane (x, y, 1) -> image (homogeneous)
    corners = np.c_[tex.outline_m, np.ones(4)] @ M.T
    if np.any(corners[:, 2] <= 1e-3):
        return None  # (partly) behind the camera: not a pose anyone holds a board in
    px = corners[:, :2] / corners[:, 2:3]
    w_img, h_img = rig.size
    pad = int(math.ceil(3 * blur_sigma_px)) + 2
    x0, y0 = (np.floor(px.min(axis=0)).astype(int) - pad).tolist()
    x1, y1 = (np.ceil(px.max(axis=0)).astype(int) + pad).tolist()
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w_img), min(y1, h_img)
    if x1 <= x0 or y1 <= y0:
        return None
    s = int(supersample)
    # supersampled patch pixel (xs, ys) has its centre at image x0 - 0.5 + (xs + 0.5) / s
    to_patch = np.array([[s, 0.0, (0.5 - x0) * s - 0.5], [0.0, s, (0.5 - y0) * s - 0.5], [0.0, 0.0, 1.0]])
    H = to_patch @ M @ tex.A
    black, white = paper
    texture = tex.image.astype(np.float32) * ((white - black) / 255.0) + black
    size = ((x1 - x0) * s, (y1 - y0) * s)
    # outside the paper both warps are 0: the colour comes out premultiplied by the coverage
    colour = cv2.warpPerspective(texture, H, size, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                                 borderValue=0)
    alpha = cv2.warpPerspective(np.ones(tex.image.shape, np.float32), H, size, flags=cv2.INTER_LINEAR,
                                borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    colour = cv2.resize(colour, (x1 - x0, y1 - y0), interpolation=cv2.INTER_AREA)
    alpha = cv2.resize(alpha, (x1 - x0, y1 - y0), interpolation=cv2.INTER_AREA)
    if blur_sigma_px > 0:
        colour = cv2.GaussianBlur(colour, (0, 0), blur_sigma_px)
        alpha = cv2.GaussianBlur(alpha, (0, 0), blur_sigma_px)
    if noise_sigma > 0:
        rng = np.random.default_rng([int(seed) & 0x7FFFFFFF, 0 if side == "left" else 1])
        colour += rng.standard_normal(colour.shape, dtype=np.float32) * np.float32(noise_sigma) * alpha
    return BoardOverlay(x0, y0, colour, np.clip(alpha, 0.0, 1.0))


def paint_overlay(image: np.ndarray, overlay: Optional[BoardOverlay]) -> np.ndarray:
    """Paint ``overlay`` over a BGR (or grey) uint8 ``image`` in place ("over"); returns ``image``."""
    if overlay is None:
        return image
    h, w = overlay.alpha.shape
    roi = image[overlay.y0:overlay.y0 + h, overlay.x0:overlay.x0 + w]
    a, c = overlay.alpha, overlay.colour
    if roi.ndim == 3:
        a, c = a[..., None], c[..., None]
    out = roi.astype(np.float32) * (1.0 - a) + c
    roi[...] = np.clip(out + 0.5, 0, 255).astype(np.uint8)
    return image


# ----------------------------------------------------------------------------------------------
# a camera that shows the board


class RenderedBoardCamera(ClockPacedSource):
    """A stereo source showing a board held still at each of ``poses`` for ``hold_frames`` frames,
    then moving to the next (a fake camera for the calibration wizard's tests)."""

    kind = "rendered-board"

    def __init__(self, board: BoardSpec, rig: Optional[StereoRigTruth] = None,
                 poses: Optional[Sequence[BoardPose]] = None, n_poses: int = 12, hold_frames: int = 4,
                 fps: float = 30.0, clock=None, seed: int = 0, skew_s: float = 0.0,
                 options: RenderOptions = RenderOptions(), loop: bool = True):
        super().__init__(clock)
        self.board = board
        self.rig = rig or default_rig()
        self.poses = list(poses) if poses is not None else random_poses(board, self.rig, n_poses, seed=seed)
        self.hold_frames = max(1, int(hold_frames))
        self.fps = float(fps)
        self.seed = seed
        self.skew_s = float(skew_s)
        self.options = options
        self.loop = loop
        self._cache: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._seq = SequenceCounter()
        self._frame = 0
        self._next = 0.0

    @property
    def name(self) -> str:
        return f"rendered {self.board.describe()}"

    def connect(self) -> None:
        self._connected = True
        self._next = self.clock.now()


    def pose_index(self, frame: int) -> Optional[int]:
        k = frame // self.hold_frames
        if k >= len(self.poses):
            if not self.loop:
                return None
            k %= len(self.poses)
        return k

    def read(self) -> Optional[StereoFrame]:
        if not self._connected or not self.clock.wait_until(self._next) or not self._connected:
            return None
        t = self.clock.now()
        self._next = max(self._next + 1.0 / self.fps, t)
        k = self.pose_index(self._frame)
        if k is None:
            self._connected = False
            self.status_message = "rendered board: all poses shown"
            return None
        self._frame += 1
        if k not in self._cache:
            self._cache[k] = render_pair(self.board, self.rig, self.poses[k], self.options, seed=self.seed * 1000 + k)
        left, right = self._cache[k]
        return StereoFrame(seq=self._seq.next(), t=t, left=left, right=right, skew_s=self.skew_s)


__all__ = [
    "StereoRigTruth", "default_rig", "sim_rig_truth", "held_board_poses", "BoardOverlay", "board_overlay",
    "paint_overlay", "PAPER_LEVELS", "BoardTexture", "board_texture", "BoardPose", "random_poses",
    "visible_fraction", "project", "RenderOptions", "CHEAP_WEBCAM", "render_view", "render_pair",
    "RenderedPair", "render_set", "write_pairs", "RenderedBoardCamera",
]
