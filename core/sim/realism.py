"""A realism preset for the simulated cameras: what a cheap USB webcam does to a clean render.

The simulated desk renders clean images (a little Gaussian lens blur and luma noise). Real webcam
frames also carry defocus and motion blur, a rolling shutter's shear, exposure flicker under mains
lighting, shot noise with chroma in it, vignetting, barrel distortion and JPEG (MJPEG) blocks.
``apply_realism(images, rng, t, preset)`` adds all of these to one frame (one image, or a stereo
pair: the pair shares the frame's blur, shear and flicker — the rig shakes and the room's light
flickers for both — and each view gets its own noise and JPEG).

``image_stats`` measures what the issue asks to compare between renders and real photos:
sharpness (variance of the Laplacian), the noise level in flat areas and the colour saturation
histogram; ``python -m core.sim.realism --compare DIR`` prints them side by side for the real
photos of DIR and for renders of the simulated desk with and without the preset.

Geometry: distortion moves pixels (up to ``distortion_k1`` of the half diagonal at the corners);
``distort_points`` maps truth pixels the same way for labels that must follow it.
"""
from __future__ import annotations

import argparse
import math
import sys
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Optional, Sequence, Union

import cv2
import numpy as np

__all__ = ["RealismPreset", "PRESETS", "WEBCAM", "preset_named", "apply_realism", "distort_points",
           "ImageStats", "image_stats", "mean_stats", "compare_with_real", "main"]

SATURATION_BINS = 8  # bins of the saturation histogram (HSV S, 0…255)
FLAT_SHARE = 0.25  # the flattest quarter of an image's pixels is where its noise is measured


@dataclass(frozen=True)
class RealismPreset:
    """What a webcam adds to a clean render; each range is drawn per frame (uniform)."""

    name: str = "webcam"  # shown in banners and reports
    defocus_sigma_px: tuple[float, float] = (0.3, 1.0)  # extra Gaussian defocus σ (px at 640 wide)
    motion_blur_px: tuple[float, float] = (0.0, 3.0)  # length of a linear motion blur (px), random direction
    rolling_shutter_px: float = 2.0  # at most this horizontal shift between the top and bottom rows (px)
    flicker: float = 0.05  # exposure flicker: relative amplitude of the 100 Hz mains beat (0…0.5)
    flicker_hz: float = 100.0  # light flicker frequency (Hz): twice the mains
    exposure_jitter: float = 0.03  # and a random relative exposure change per frame (σ)
    read_noise: float = 2.5  # sensor read noise σ (grey levels, per channel)
    shot_noise: float = 0.25  # shot noise: σ² grows by this much per grey level of signal
    chroma_noise: float = 0.6  # share of the noise that differs between the colour channels (0 luma… 1 independent)
    vignetting: float = 0.25  # brightness lost at the corners (0…0.9), falling off with r²
    distortion_k1: float = -0.02  # radial distortion at the half diagonal (barrel < 0), share of the radius
    jpeg_quality: tuple[int, int] = (60, 85)  # JPEG quality drawn per image (MJPEG webcams: 60…90)

    def __post_init__(self) -> None:
        def check_range(field: str, lo_hi, lo: float, hi: float) -> None:
            a, b = lo_hi
            if not (lo <= a <= b <= hi):
                raise ValueError(f"realism preset {field} = {lo_hi!r}: need {lo} <= low <= high <= {hi}")

        check_range("defocus_sigma_px", self.defocus_sigma_px, 0.0, 5.0)
        check_range("motion_blur_px", self.motion_blur_px, 0.0, 30.0)
        check_range("jpeg_quality", self.jpeg_quality, 5, 100)
        for field, lo, hi in (("rolling_shutter_px", 0.0, 50.0), ("flicker", 0.0, 0.5), ("flicker_hz", 0.0, 1000.0),
                              ("exposure_jitter", 0.0, 0.5), ("read_noise", 0.0, 50.0), ("shot_noise", 0.0, 5.0),
                              ("chroma_noise", 0.0, 1.0), ("vignetting", 0.0, 0.9), ("distortion_k1", -0.2, 0.2)):
            value = getattr(self, field)
            if not (lo <= value <= hi):  # also NaN
                raise ValueError(f"realism preset {field} = {value!r} is outside {lo}…{hi}")


WEBCAM = RealismPreset()
PRESETS = {"webcam": WEBCAM}  # --sim-realism NAME


def preset_named(name: Union[str, RealismPreset, None]) -> Optional[RealismPreset]:
    """The preset called ``name`` ("webcam"), a preset as given, or None for None/"off"/"none"."""
    if name is None or isinstance(name, RealismPreset):
        return name
    key = str(name).strip().lower()
    if key in ("", "off", "none"):
        return None
    if key not in PRESETS:
        raise ValueError(f"realism preset {name!r}: use one of {', '.join(PRESETS)} (or off)")
    return PRESETS[key]


# -- the image model -----------------------------------------------------------------------------

_MAPS: dict = {}  # (w, h, k1) -> (map_x, map_y) of the distortion (float32)
_VIGNETTES: dict = {}  # (w, h, channels, strength) -> gain (float32, h x w x channels)
_NOISE: dict = {}  # (h, w, channels, chroma) -> unit noise field (float32), NOISE_SHIFTS larger each way
_SIGMAS: dict = {}  # (read, shot) -> σ by grey level (float32 LUT of 256)
NOISE_SHIFTS = 64  # a frame's noise is a window of a larger field at one of 64 x 64 offsets


def _radius2(w: int, h: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pixel grids (x, y) and r² from the image centre, r = 1 at the half diagonal."""
    cx, cy = (w - 1) / 2.0, (h - 1) / 2.0
    half_diag = math.hypot(cx, cy) or 1.0
    x, y = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
    r2 = ((x - cx) ** 2 + (y - cy) ** 2) / half_diag ** 2
    return x, y, r2


def _distortion_maps(w: int, h: int, k1: float) -> tuple[np.ndarray, np.ndarray]:
    """remap maps of a radial distortion: output pixel p shows the clean image at p·(1 + k1·r²)⁻¹
    (approximately the inverse of ``distort_points``, exact to first order in k1)."""
    key = (w, h, k1)
    if key not in _MAPS:
        x, y, r2 = _radius2(w, h)
        cx, cy = (w - 1) / 2.0, (h - 1) / 2.0
        s = 1.0 / (1.0 + k1 * r2)  # where the clean image's point shown here came from (inverse)
        _MAPS.clear()
        _MAPS[key] = ((cx + (x - cx) * s).astype(np.float32), (cy + (y - cy) * s).astype(np.float32))
    return _MAPS[key]


def distort_points(points, size: tuple[int, int], preset: RealismPreset = WEBCAM) -> np.ndarray:
    """Where clean-render pixels (N, 2) appear in an image with the preset's lens distortion."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    w, h = size
    cx, cy = (w - 1) / 2.0, (h - 1) / 2.0
    half_diag = math.hypot(cx, cy) or 1.0
    d = pts - (cx, cy)
    r2 = (d ** 2).sum(axis=1, keepdims=True) / half_diag ** 2
    # the clean point p0 shows at p with p·(1 + k1 r(p)²)⁻¹ = p0: solve by fixed point (k1 is small)
    out = d.copy()
    for _ in range(4):
        r2 = (out ** 2).sum(axis=1, keepdims=True) / half_diag ** 2
        out = d * (1.0 + preset.distortion_k1 * r2)
    return out + (cx, cy)


def _vignette(w: int, h: int, channels: int, strength: float) -> np.ndarray:
    key = (w, h, channels, strength)
    if key not in _VIGNETTES:
        _, _, r2 = _radius2(w, h)
        gain = (1.0 - strength * r2).astype(np.float32)
        _VIGNETTES.clear()
        _VIGNETTES[key] = cv2.merge([gain] * channels) if channels > 1 else gain
    return _VIGNETTES[key]


def _noise_field(h: int, w: int, channels: int, chroma: float) -> np.ndarray:
    """Unit-σ noise, NOISE_SHIFTS larger than the image each way: a share ``chroma`` differs
    between the channels, the rest is common to them (luma); drawn once per size (seeded)."""
    key = (h, w, channels, chroma)
    if key not in _NOISE:
        rng = np.random.default_rng([h, w, channels, 2027])
        shape = (h + NOISE_SHIFTS, w + NOISE_SHIFTS)
        luma = rng.standard_normal(shape, dtype=np.float32)
        if channels > 1:
            field = (math.sqrt(1.0 - chroma * chroma) * luma[:, :, None]
                     + chroma * rng.standard_normal(shape + (channels,), dtype=np.float32))
        else:
            field = luma
        _NOISE.clear()
        _NOISE[key] = np.ascontiguousarray(field, dtype=np.float32)
    return _NOISE[key]


def _sigma_lut(read: float, shot: float) -> np.ndarray:
    """σ of the sensor noise at each grey level: read noise and shot noise (σ² = read² + shot·level)."""
    key = (read, shot)
    if key not in _SIGMAS:
        _SIGMAS[key] = np.sqrt(read * read + shot * np.arange(256, dtype=np.float32)).astype(np.float32)
    return _SIGMAS[key]


def _motion_kernel(length: float, angle: float) -> Optional[np.ndarray]:
    """A normalised line kernel ``length`` px long at ``angle`` rad (None below a pixel)."""
    if length < 1.0:
        return None
    n = int(math.ceil(length)) | 1
    k = np.zeros((n, n), np.float32)
    c = (n - 1) / 2.0
    dx, dy = math.cos(angle) * (length - 1) / 2.0, math.sin(angle) * (length - 1) / 2.0
    cv2.line(k, (int(round(c - dx)), int(round(c - dy))), (int(round(c + dx)), int(round(c + dy))), 1.0, 1,
             cv2.LINE_AA)
    total = float(k.sum())
    return k / total if total > 0 else None


def _frame_draws(rng: np.random.Generator, t: float, preset: RealismPreset) -> dict:
    """The per-frame parameters shared by the views of one frame."""
    phase = rng.uniform(0.0, 2 * math.pi)
    gain = (1.0 + preset.flicker * math.sin(2 * math.pi * preset.flicker_hz * float(t) + phase)
            + preset.exposure_jitter * float(rng.standard_normal()))
    return {
        "defocus": float(rng.uniform(*preset.defocus_sigma_px)),
        "motion": _motion_kernel(float(rng.uniform(*preset.motion_blur_px)), float(rng.uniform(0.0, math.pi))),
        "shear": float(rng.uniform(-1.0, 1.0)) * preset.rolling_shutter_px,
        "gain": max(0.2, gain),
    }


def _one_image(img: np.ndarray, draws: dict, rng: np.random.Generator, preset: RealismPreset) -> np.ndarray:
    h, w = img.shape[:2]
    scale = w / 640.0  # blur lengths are given for a 640-wide image
    # optics and shutter: distortion + rolling shutter's shear as one remap (rows read top to bottom
    # while the scene moves sideways: row y is shifted by shear·y/h)
    map_x, map_y = _distortion_maps(w, h, preset.distortion_k1)
    shear = draws["shear"] * scale
    if shear:
        rows = (np.arange(h, dtype=np.float32) / max(1, h - 1) - 0.5) * shear
        map_x = map_x + rows[:, None]
    out = cv2.remap(img, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    if draws["defocus"] * scale > 0.05:
        out = cv2.GaussianBlur(out, (0, 0), draws["defocus"] * scale)
    if draws["motion"] is not None:
        out = cv2.filter2D(out, -1, draws["motion"], borderType=cv2.BORDER_REFLECT)
    # exposure (flicker) and vignetting, then the sensor's noise on the light it got: σ by grey
    # level (a LUT), times a window of a unit noise field at a random offset (no per-frame randn)
    channels = 1 if out.ndim == 2 else out.shape[2]
    lit = cv2.multiply(out, _vignette(w, h, channels, preset.vignetting), scale=draws["gain"], dtype=cv2.CV_8U)
    sigma = cv2.LUT(lit, _sigma_lut(preset.read_noise, preset.shot_noise))
    field = _noise_field(h, w, channels, preset.chroma_noise)
    dy, dx = (int(v) for v in rng.integers(0, NOISE_SHIFTS, size=2))
    noise = cv2.multiply(sigma, field[dy:dy + h, dx:dx + w])
    out = cv2.add(lit, noise, dtype=cv2.CV_8U)
    quality = int(rng.integers(preset.jpeg_quality[0], preset.jpeg_quality[1] + 1))
    if quality < 100:
        ok, buf = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, quality])
        if ok:
            out = cv2.imdecode(buf, cv2.IMREAD_UNCHANGED)
    return out


def apply_realism(images, rng: np.random.Generator, t: float = 0.0,
                  preset: Optional[RealismPreset] = WEBCAM):
    """One frame as a webcam would deliver it: ``images`` is a BGR uint8 image or a sequence of
    views of the same instant (a stereo pair); returns the same shape (new arrays).

    ``rng`` draws everything (deterministic for a seeded generator); ``t`` (s) is the frame's time,
    which sets the phase of the mains flicker. None as ``preset`` returns the images unchanged.
    """
    if preset is None:
        return images
    single = isinstance(images, np.ndarray)
    views = [images] if single else list(images)
    for img in views:
        if not (isinstance(img, np.ndarray) and img.dtype == np.uint8 and img.ndim in (2, 3)):
            raise ValueError("apply_realism needs uint8 images (H x W or H x W x C)")
    draws = _frame_draws(rng, t, preset)
    out = [_one_image(img, draws, rng, preset) for img in views]
    return out[0] if single else type(images)(out) if isinstance(images, tuple) else out


# -- image statistics ----------------------------------------------------------------------------

@dataclass(frozen=True)
class ImageStats:
    """What the comparison with real photos looks at (one image, or the mean of several)."""

    size: tuple[int, int]  # (w, h) measured
    sharpness: float  # variance of the Laplacian of the grey image (higher: sharper, or noisier)
    noise: float  # noise σ (grey levels) in the flattest FLAT_SHARE of the image (Immerkær's operator)
    saturation_mean: float  # mean HSV saturation, 0…255
    saturation_hist: tuple[float, ...]  # SATURATION_BINS shares of pixels by saturation, summing to 1


_IMMERKAER = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float32)


def image_stats(image: np.ndarray, size: Optional[tuple[int, int]] = None) -> ImageStats:
    """Sharpness, flat-area noise and saturation of a BGR (or grey) uint8 image; ``size`` (w, h)
    first resizes it (INTER_AREA), so images of different cameras are compared at one size."""
    img = np.asarray(image)
    if img.dtype != np.uint8 or img.ndim not in (2, 3):
        raise ValueError("image_stats needs a uint8 image (H x W or H x W x 3)")
    if size is not None and (img.shape[1], img.shape[0]) != tuple(size):
        img = cv2.resize(img, tuple(int(v) for v in size), interpolation=cv2.INTER_AREA)
    grey = img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    sharpness = float(cv2.Laplacian(grey, cv2.CV_64F).var())
    g = grey.astype(np.float32)
    # flat areas: the lowest gradients of a smoothed copy (the noise itself barely moves them)
    smooth = cv2.GaussianBlur(g, (0, 0), 2.0)
    grad = cv2.magnitude(cv2.Sobel(smooth, cv2.CV_32F, 1, 0), cv2.Sobel(smooth, cv2.CV_32F, 0, 1))
    response = np.abs(cv2.filter2D(g, cv2.CV_32F, _IMMERKAER))[1:-1, 1:-1]
    grad = grad[1:-1, 1:-1]
    flat = grad <= np.quantile(grad, FLAT_SHARE)
    noise = float(math.sqrt(math.pi / 2.0) / 6.0 * response[flat].mean()) if flat.any() else 0.0
    if img.ndim == 3:
        sat = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)[:, :, 1]
    else:
        sat = np.zeros_like(grey)
    hist = np.bincount((sat.ravel().astype(np.int32) * SATURATION_BINS) // 256, minlength=SATURATION_BINS)
    hist = hist / max(1, hist.sum())
    return ImageStats(size=(img.shape[1], img.shape[0]), sharpness=sharpness, noise=noise,
                      saturation_mean=float(sat.mean()), saturation_hist=tuple(float(v) for v in hist))


def mean_stats(stats: Sequence[ImageStats]) -> ImageStats:
    """The mean of several images' statistics."""
    if not stats:
        raise ValueError("mean_stats needs at least one ImageStats")
    return ImageStats(size=stats[0].size, sharpness=float(np.mean([s.sharpness for s in stats])),
                      noise=float(np.mean([s.noise for s in stats])),
                      saturation_mean=float(np.mean([s.saturation_mean for s in stats])),
                      saturation_hist=tuple(float(v) for v in np.mean([s.saturation_hist for s in stats], axis=0)))


def _real_images(directory: Path) -> list[np.ndarray]:
    files = sorted(p for p in Path(directory).iterdir() if p.suffix.lower() in (".jpg", ".jpeg", ".png"))
    images = [im for im in (cv2.imread(str(p), cv2.IMREAD_COLOR) for p in files) if im is not None]
    if not images:
        raise FileNotFoundError(f"{directory}: no .jpg/.png photos to compare with")
    return images


def _sim_images(n: int, preset: Optional[RealismPreset], seed: int = 0) -> list[np.ndarray]:
    """Views of the simulated desk's held-out dataset scenes (both views of n // 2 scenes)."""
    from core.sim.dataset import held_out_seeds, render_scene

    images = []
    for s in held_out_seeds(max(1, n // 2)):
        pair = [sample.image for sample in render_scene(s)]
        images += apply_realism(pair, np.random.default_rng([seed, s]), t=s / 30.0, preset=preset)
    return images[:max(1, n)]


def compare_with_real(real_dir, n_sim: int = 20, preset: RealismPreset = WEBCAM) -> dict:
    """{"real": ImageStats, "sim": ImageStats, "sim realistic": ImageStats}: means over the photos of
    ``real_dir`` and over ``n_sim`` renders, all measured at the real photos' size."""
    real = _real_images(Path(real_dir))
    size = (real[0].shape[1], real[0].shape[0])
    return {"real": mean_stats([image_stats(im, size) for im in real]),
            "sim": mean_stats([image_stats(im, size) for im in _sim_images(n_sim, None)]),
            f"sim {preset.name}": mean_stats([image_stats(im, size) for im in _sim_images(n_sim, preset)])}


def format_comparison(table: dict) -> str:
    """The comparison as aligned text rows (one column per image set)."""
    names = list(table)
    first = next(iter(table.values()))
    rows = [("", *names), ("size (w x h)", *[f"{s.size[0]}x{s.size[1]}" for s in table.values()]),
            ("sharpness (Laplacian var)", *[f"{s.sharpness:.0f}" for s in table.values()]),
            ("noise in flat areas (σ)", *[f"{s.noise:.2f}" for s in table.values()]),
            ("saturation mean (0…255)", *[f"{s.saturation_mean:.1f}" for s in table.values()])]
    for b in range(len(first.saturation_hist)):
        lo, hi = b * 256 // SATURATION_BINS, (b + 1) * 256 // SATURATION_BINS - 1
        rows.append((f"saturation {lo}…{hi}", *[f"{100 * s.saturation_hist[b]:.1f} %" for s in table.values()]))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return "\n".join("  ".join(c.ljust(widths[i]) if i == 0 else c.rjust(widths[i]) for i, c in enumerate(r))
                     for r in rows)


def main(argv: Optional[list[str]] = None) -> int:
    """``python -m core.sim.realism --compare DIR``: real photos beside the simulated desk."""
    p = argparse.ArgumentParser(prog="python -m core.sim.realism",
                                description="Image statistics of real photos beside renders of the simulated desk "
                                            "without and with the webcam realism preset.")
    p.add_argument("--compare", metavar="DIR", required=True, help="a folder of real photos (.jpg/.png)")
    p.add_argument("--n", type=int, default=20, help="renders per column (default 20)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    args = p.parse_args(argv)
    if not 1 <= args.n <= 1000:
        print(f"{p.prog}: --n {args.n}: need 1…1000 renders", file=sys.stderr)
        return 2
    try:
        table = compare_with_real(args.compare, args.n)
    except (FileNotFoundError, NotADirectoryError) as exc:
        print(f"{p.prog}: {exc}", file=sys.stderr)
        return 2
    if args.json:
        import json

        print(json.dumps({k: asdict(v) for k, v in table.items()}))
    else:
        print(format_comparison(table))
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
