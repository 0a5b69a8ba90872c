"""Dense disparity and metric depth on the rectified pair, computed only while a view shows it.

Matchers: StereoSGBM in all its modes (SGBM, HH, SGBM_3WAY, HH4) and StereoBM, optionally
followed by the edge-aware WLS filter (opencv-contrib ximgproc), optionally at half resolution.
Disparity is always float pixels of the full-size rectified left view (SGBM's int16 output is
fixed point /16 — TECH_NOTES), so ``depth_at`` and ``depth_m`` are metric through Q.

Parameters are two validated dataclasses (``SgbmParams`` for the block matching, shared by SGBM
and BM; ``StereoMatchParams`` for matcher choice, WLS and resolution); presets of both are kept
per camera pair in a TOML file under the user's config folder.
"""
from __future__ import annotations

import math
import threading
import time
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Optional, Sequence

import cv2
import numpy as np

from core.paths import os_error_reason, write_file_atomically
from core.settings import SettingsError, SgbmParams, StereoMatchParams
from core.vision.calibration import StereoCalibration

_MODES = {
    "SGBM": cv2.StereoSGBM_MODE_SGBM,
    "HH": cv2.StereoSGBM_MODE_HH,
    "SGBM_3WAY": cv2.StereoSGBM_MODE_SGBM_3WAY,
    "HH4": cv2.StereoSGBM_MODE_HH4,
}
_BM_PREFILTER = {"XSOBEL": cv2.StereoBM_PREFILTER_XSOBEL,
                 "NORMALIZED_RESPONSE": cv2.StereoBM_PREFILTER_NORMALIZED_RESPONSE}


def make_sgbm(params: SgbmParams, channels: int = 1):
    """A cv2.StereoSGBM configured from ``params`` (P1/P2 automatic where 0)."""
    p1, p2 = params.penalties(channels)
    return cv2.StereoSGBM_create(
        minDisparity=params.min_disparity,
        numDisparities=params.num_disparities,
        blockSize=params.block_size,
        P1=p1,
        P2=p2,
        disp12MaxDiff=params.disp12_max_diff,
        preFilterCap=params.pre_filter_cap,
        uniquenessRatio=params.uniqueness_ratio,
        speckleWindowSize=params.speckle_window_size,
        speckleRange=params.speckle_range,
        mode=_MODES[params.mode],
    )


def make_bm(params: SgbmParams, match: StereoMatchParams = StereoMatchParams()):
    """A cv2.StereoBM from the shared parameters (its block is odd and at least 5 px)."""
    bm = cv2.StereoBM_create(numDisparities=params.num_disparities, blockSize=max(5, params.block_size))
    bm.setMinDisparity(params.min_disparity)
    bm.setPreFilterType(_BM_PREFILTER[match.bm_prefilter])
    bm.setPreFilterSize(match.bm_prefilter_size)
    bm.setPreFilterCap(params.pre_filter_cap)
    bm.setTextureThreshold(match.bm_texture_threshold)
    bm.setUniquenessRatio(params.uniqueness_ratio)
    bm.setSpeckleWindowSize(params.speckle_window_size)
    bm.setSpeckleRange(params.speckle_range)
    bm.setDisp12MaxDiff(params.disp12_max_diff)
    return bm


def half_resolution_params(params: SgbmParams) -> SgbmParams:
    """The parameters for the half-size pair: half the disparity range (still a multiple of 16)."""
    nd = max(16, int(math.ceil(params.num_disparities / 2 / 16)) * 16)
    return SgbmParams(**{**asdict(params), "num_disparities": nd,
                         "min_disparity": int(math.floor(params.min_disparity / 2))})


def make_matcher(params: SgbmParams, match: StereoMatchParams = StereoMatchParams(), channels: int = 1):
    """SGBM or BM as ``match.matcher`` says."""
    return make_bm(params, match) if match.matcher == "BM" else make_sgbm(params, channels)


@dataclass(frozen=True)
class DepthSample:
    """Depth under one pixel of the rectified left view (what a click on the disparity view shows)."""

    x: float  # rectified left image px
    y: float
    disparity_px: float  # median of the valid disparities around (x, y)
    depth_m: float  # Z along the rectified left camera's axis (m)
    camera_p: tuple[float, float, float]  # the 3D point in camera_left (m)
    base_p: Optional[tuple[float, float, float]] = None  # in robot_base when the mount is known (m)

    @property
    def depth_mm(self) -> float:
        return self.depth_m * 1e3


@dataclass(frozen=True)
class LegendTick:
    """One mark of the disparity colour bar."""

    disparity_px: float
    depth_m: float  # inf at zero disparity
    bgr: tuple[int, int, int]


class DisparityComputer:
    """Rectify a raw stereo pair and compute float disparity (px) of the left rectified view.

    ``set_params`` / ``set_match_params`` may be called from the GUI thread; ``compute`` runs in
    the perception worker. ``last_timings_ms`` tells how long the last compute took per step.
    """

    def __init__(self, calib: StereoCalibration, params: SgbmParams | None = None,
                 match: StereoMatchParams | None = None):
        self.calib = calib
        (self._lx, self._ly), (self._rx, self._ry) = calib.rectify_maps()
        self._lock = threading.Lock()
        self.params = params or SgbmParams()
        self.match = match or StereoMatchParams()
        self.last_timings_ms: dict[str, float] = {}
        # camera_left <- rectified left camera
        self._camera_R_rect = np.asarray(calib.R1, np.float64).T
        self._last = None  # (left, right, matchers, disparity) of the last compute
        self._build()

    def _build(self) -> None:
        params = half_resolution_params(self.params) if self.match.half_resolution else self.params
        left = make_matcher(params, self.match)
        right = wls = None
        if self.match.wls:
            right = cv2.ximgproc.createRightMatcher(left)
            wls = cv2.ximgproc.createDisparityWLSFilter(left)
            wls.setLambda(float(self.match.wls_lambda))
            wls.setSigmaColor(float(self.match.wls_sigma))
        self._matchers = (left, right, wls)

    def set_params(self, params: SgbmParams) -> None:
        """New block-matching parameters (takes effect at the next compute)."""
        with self._lock:
            self.params = params
            self._build()

    def set_match_params(self, match: StereoMatchParams) -> None:
        """New matcher choice / WLS / resolution (takes effect at the next compute)."""
        with self._lock:
            self.match = match
            self._build()

    def set_all(self, params: SgbmParams, match: StereoMatchParams) -> None:
        with self._lock:
            self.params, self.match = params, match
            self._build()

    def rectify(self, left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The rectified pair (same type as the input)."""
        return (
            cv2.remap(left, self._lx, self._ly, cv2.INTER_LINEAR),
            cv2.remap(right, self._rx, self._ry, cv2.INTER_LINEAR),
        )

    def compute(self, left: np.ndarray, right: np.ndarray) -> np.ndarray:
        """Disparity in pixels (float32, full size) of the rectified left view; invalid pixels are
        below ``valid_min`` (matchers mark them min_disparity − 1).

        The very arrays of the previous call with the same matchers (a source re-delivering a
        still frame) get the previous map back (the same array: read it, do not modify it)."""
        with self._lock:
            matchers = self._matchers
        last = self._last
        if last is not None and last[0] is left and last[1] is right and last[2] is matchers:
            return last[3]
        disparity = self._compute(left, right)
        self._last = (left, right, matchers, disparity)
        return disparity

    def _compute(self, left: np.ndarray, right: np.ndarray) -> np.ndarray:
        t0 = time.perf_counter()
        gl = cv2.cvtColor(left, cv2.COLOR_BGR2GRAY) if left.ndim == 3 else left
        gr = cv2.cvtColor(right, cv2.COLOR_BGR2GRAY) if right.ndim == 3 else right
        rl, rr = self.rectify(gl, gr)
        with self._lock:
            (matcher, right_matcher, wls), half = self._matchers, self.match.half_resolution
        full_size = (rl.shape[1], rl.shape[0])
        if half:
            rl = cv2.resize(rl, (full_size[0] // 2, full_size[1] // 2), interpolation=cv2.INTER_AREA)
            rr = cv2.resize(rr, (full_size[0] // 2, full_size[1] // 2), interpolation=cv2.INTER_AREA)
        t1 = time.perf_counter()
        raw = matcher.compute(rl, rr)
        t2 = time.perf_counter()
        if wls is not None:
            raw_right = right_matcher.compute(rr, rl)
            raw = wls.filter(raw, rl, disparity_map_right=raw_right)
        t3 = time.perf_counter()
        # SGBM / BM return fixed-point int16 with 4 fractional bits (TECH_NOTES: divide by 16)
        disp = raw.astype(np.float32) / 16.0
        if half:
            invalid = disp < self.valid_min_half()
            disp *= 2.0  # half-size pixels -> full-size pixels
            disp[invalid] = self.params.min_disparity - 1
            disp = cv2.resize(disp, full_size, interpolation=cv2.INTER_NEAREST)
        t4 = time.perf_counter()
        self.last_timings_ms = {"rectify": (t1 - t0) * 1e3, "match": (t2 - t1) * 1e3,
                                "wls": (t3 - t2) * 1e3, "total": (t4 - t0) * 1e3}
        return disp

    def valid_min_half(self) -> float:
        return float(half_resolution_params(self.params).min_disparity)

    @property
    def valid_min(self) -> float:
        """Disparities below this are 'no match' (px)."""
        return float(self.params.min_disparity)

    def valid_mask(self, disparity_px: np.ndarray) -> np.ndarray:
        """Pixels with a match and a finite depth (disparity above zero)."""
        return (disparity_px >= self.valid_min) & (disparity_px > 0)

    def depth_m(self, disparity_px: np.ndarray) -> np.ndarray:
        """Per-pixel 3D points (H,W,3) in the rectified left camera (m) from float disparity."""
        return cv2.reprojectImageTo3D(disparity_px, self.calib.Q)

    def depth_map_m(self, disparity_px: np.ndarray) -> np.ndarray:
        """Z (H,W) in the rectified left camera (m); NaN where there is no valid match."""
        Q = self.calib.Q
        d = disparity_px.astype(np.float64)
        # Z = Q23 / (Q32·d + Q33) for Q = [..; 0 0 0 f; 0 0 -1/Tx (cx-cx')/Tx]
        den = Q[3, 2] * d + Q[3, 3]
        with np.errstate(divide="ignore", invalid="ignore"):
            z = Q[2, 3] / den
        z[~self.valid_mask(disparity_px) | ~np.isfinite(z) | (z <= 0)] = np.nan
        return z.astype(np.float32)

    def depth_at(self, disparity_px: np.ndarray, x: float, y: float, radius: int = 2,
                 base_T_camera: Optional[np.ndarray] = None) -> Optional[DepthSample]:
        """Depth and 3D point at rectified-left pixel (x, y): the median valid disparity in a
        (2·radius+1)² window; None where nothing matched."""
        h, w = disparity_px.shape[:2]
        xi, yi = int(round(x)), int(round(y))
        if not (0 <= xi < w and 0 <= yi < h):
            return None
        win = disparity_px[max(0, yi - radius): yi + radius + 1, max(0, xi - radius): xi + radius + 1]
        valid = win[self.valid_mask(win)]
        if valid.size == 0:
            return None
        d = float(np.median(valid))
        X = self.calib.Q @ np.array([x, y, d, 1.0])
        if abs(X[3]) < 1e-12:
            return None
        rect_p = X[:3] / X[3]
        if rect_p[2] <= 0:
            return None
        cam_p = self._camera_R_rect @ rect_p
        base_p = None
        if base_T_camera is not None:
            bp = base_T_camera[:3, :3] @ cam_p + base_T_camera[:3, 3]
            base_p = (float(bp[0]), float(bp[1]), float(bp[2]))
        return DepthSample(float(x), float(y), d, float(rect_p[2]),
                           (float(cam_p[0]), float(cam_p[1]), float(cam_p[2])), base_p)

    # display ---------------------------------------------------------------------------------
    def display_range(self) -> tuple[float, float]:
        """The fixed disparity range the colours span (px): the matcher's search range."""
        lo = float(self.params.min_disparity)
        return lo, lo + float(self.params.num_disparities)

    def colorize(self, disparity_px: np.ndarray, colormap: int = cv2.COLORMAP_TURBO) -> np.ndarray:
        """BGR image of the disparity over the fixed search range (not min-max normalised);
        no-match pixels black."""
        return colorize_disparity(disparity_px, *self.display_range(), colormap=colormap,
                                  valid=self.valid_mask(disparity_px))

    def legend(self, n: int = 5, colormap: int = cv2.COLORMAP_TURBO) -> list[LegendTick]:
        """Colour bar marks from the far to the near end, each with its depth."""
        lo, hi = self.display_range()
        return disparity_legend(self.calib, lo, hi, n, colormap)


def colorize_disparity(disparity_px: np.ndarray, lo: float, hi: float, colormap: int = cv2.COLORMAP_TURBO,
                       valid: Optional[np.ndarray] = None) -> np.ndarray:
    """Disparity (px) mapped linearly from [lo, hi] onto ``colormap``; invalid pixels black."""
    scale = 255.0 / max(1e-6, hi - lo)
    u8 = np.clip((disparity_px - lo) * scale, 0, 255).astype(np.uint8)
    out = cv2.applyColorMap(u8, colormap)
    if valid is None:
        valid = disparity_px >= lo
    out[~valid] = 0
    return out


def disparity_legend(calib: StereoCalibration, lo: float, hi: float, n: int = 5,
                     colormap: int = cv2.COLORMAP_TURBO) -> list[LegendTick]:
    """``n`` marks evenly spaced in disparity over [lo, hi], with the metric depth of each."""
    Q = calib.Q
    lut = cv2.applyColorMap(np.arange(256, dtype=np.uint8).reshape(-1, 1), colormap).reshape(256, 3)
    out = []
    for d in np.linspace(lo, hi, max(2, n)):
        den = Q[3, 2] * d + Q[3, 3]
        z = float(Q[2, 3] / den) if abs(den) > 1e-12 else math.inf
        if z <= 0:
            z = math.inf
        k = int(round((d - lo) / max(1e-6, hi - lo) * 255))
        out.append(LegendTick(float(d), z, tuple(int(c) for c in lut[min(255, max(0, k))])))
    return out


def legend_image(ticks: Sequence[LegendTick], height: int = 240, width: int = 24,
                 colormap: int = cv2.COLORMAP_TURBO) -> np.ndarray:
    """A vertical colour bar (near = top) for ``ticks`` (label them with ``tick.depth_m``)."""
    ramp = np.linspace(255, 0, height).astype(np.uint8).reshape(-1, 1)
    return cv2.applyColorMap(np.repeat(ramp, width, axis=1), colormap)


# ----------------------------------------------------------------------------------------------
# presets per camera pair (TOML)


class PresetError(ValueError):
    """A stereo preset file is unreadable or holds an invalid value (the message names file and key)."""


PRESETS_FILE = "stereo_presets.toml"


def presets_path() -> Path:
    """The presets file in the user's config folder."""
    from core.paths import user_dir

    return user_dir("config") / PRESETS_FILE


def _read_presets(path: Path) -> dict:
    import tomllib

    if not path.is_file():
        return {}
    try:
        return tomllib.loads(path.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise PresetError(f"{path}: not valid TOML ({exc}) — fix or delete the file") from None
    except RecursionError:  # tomllib recurses once per nested array / inline table
        raise PresetError(f"{path}: nested too deeply to be a presets file — fix or delete the file") from None
    except OSError as exc:
        raise PresetError(f"{path}: cannot read: {os_error_reason(exc)} — make it readable for your user, "
                          f"or delete it") from None


def _short(value) -> str:
    text = repr(value) if not isinstance(value, dict) else "{…}"
    return text if len(text) <= 40 else text[:37] + "…"


def _pair_table(data: dict, pair_id: str, path: Path) -> dict:
    """The table of one camera pair ({} if it has none), its structure checked down to each
    preset: PresetError naming the file and the key where a table (or a name) was expected."""
    def wrong(key: str, value, expected: str) -> PresetError:
        return PresetError(f"{path}: {key} = {_short(value)} must be {expected} — fix or delete the file")

    pairs = data.get("pairs", {})
    if not isinstance(pairs, dict):
        raise wrong("pairs", pairs, 'a table of camera pairs ([pairs."<pair>".presets.<name>])')
    pair = pairs.get(pair_id, {})
    key = f'pairs."{pair_id}"'
    if not isinstance(pair, dict):
        raise wrong(key, pair, f"a table ([{key}.presets.<name>])")
    active = pair.get("active")
    if active is not None and not isinstance(active, str):
        raise wrong(key + ".active", active, "a preset name (a string)")
    presets = pair.get("presets", {})
    if not isinstance(presets, dict):
        raise wrong(key + ".presets", presets, f"a table of presets ([{key}.presets.<name>])")
    for name, preset in presets.items():
        if not isinstance(preset, dict):
            raise wrong(f"{key}.presets.{name}", preset, f"a table ([{key}.presets.{name}.sgbm] and .matcher)")
    return pair


def _build(cls, values, where: str, path: Path):
    if not isinstance(values, dict):
        raise PresetError(f"{path}: [{where}] must be a table")
    names = {f.name for f in fields(cls)}
    unknown = sorted(set(values) - names)
    if unknown:
        raise PresetError(f"{path}: [{where}] unknown key {unknown[0]!r}; valid: {', '.join(sorted(names))}")
    try:
        return cls(**values)
    except (SettingsError, TypeError) as exc:
        raise PresetError(f"{path}: [{where}] {exc}") from None
    except RecursionError:  # a value nested hundreds of tables deep (dotted keys parse without recursing)
        raise PresetError(f"{path}: [{where}] a value is nested too deeply — fix or delete the file") from None


def list_presets(pair_id: str, path: Optional[Path] = None) -> list[str]:
    """Names of the presets stored for a camera pair; PresetError (naming file and key) when the
    file is unreadable or the pair's part of it has the wrong structure."""
    path = Path(path) if path else presets_path()
    pair = _pair_table(_read_presets(path), pair_id, path)
    return sorted(pair.get("presets", {}))


def load_preset(pair_id: str, name: Optional[str] = None,
                path: Optional[Path] = None) -> Optional[tuple[SgbmParams, StereoMatchParams]]:
    """The preset ``name`` (default: the pair's last saved one) of a camera pair, or None if the
    pair has none; PresetError (naming file, table and key) when the stored values are invalid."""
    path = Path(path) if path else presets_path()
    pair = _pair_table(_read_presets(path), pair_id, path)
    if not pair:
        return None
    name = name or pair.get("active") or "default"
    preset = pair.get("presets", {}).get(name)
    if preset is None:
        return None
    where = f'pairs."{pair_id}".presets.{name}'
    sgbm = _build(SgbmParams, preset.get("sgbm", {}), where + ".sgbm", path)
    match = _build(StereoMatchParams, preset.get("matcher", {}), where + ".matcher", path)
    return sgbm, match


def save_preset(pair_id: str, sgbm: SgbmParams, match: StereoMatchParams = StereoMatchParams(),
                name: str = "default", path: Optional[Path] = None) -> Path:
    """Store a preset for a camera pair (and make it the pair's active one); returns the file.

    PresetError when the file cannot be read or its structure is wrong (it is not overwritten);
    an OSError naming the file and the fix when it cannot be written (read-only folder)."""
    import tomli_w

    if not name or not all(c.isalnum() or c in "-_ " for c in name):
        raise PresetError(f"preset name {name!r}: use letters, digits, '-', '_' or spaces")
    path = Path(path) if path else presets_path()
    data = _read_presets(path)
    pair = _pair_table(data, pair_id, path)
    data.setdefault("pairs", {})[pair_id] = pair
    pair["active"] = name
    pair.setdefault("presets", {})[name] = {"sgbm": asdict(sgbm), "matcher": asdict(match)}
    return write_file_atomically(path, tomli_w.dumps(data).encode())


def delete_preset(pair_id: str, name: str, path: Optional[Path] = None) -> bool:
    """Remove a preset; True if it existed (errors as for ``save_preset``)."""
    import tomli_w

    path = Path(path) if path else presets_path()
    data = _read_presets(path)
    pair = _pair_table(data, pair_id, path)
    presets = pair.get("presets", {})
    if name not in presets:
        return False
    del presets[name]
    if pair.get("active") == name:
        pair["active"] = sorted(presets)[0] if presets else "default"
    write_file_atomically(path, tomli_w.dumps(data).encode())
    return True


__all__ = [
    "make_sgbm", "make_bm", "make_matcher", "half_resolution_params", "DisparityComputer", "DepthSample",
    "LegendTick", "colorize_disparity", "disparity_legend", "legend_image", "PresetError", "presets_path",
    "list_presets", "load_preset", "save_preset", "delete_preset",
]
