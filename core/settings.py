"""Plain-data settings shared by core and the GUI (validated in ``__post_init__``).

Widgets build these from their controls and hand them to workers; core objects read them.
Every field has one line saying what it is, its unit and its allowed range.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields


def is_number(value) -> bool:
    """An int or float read from a file, not a bool (TOML's true is not 1)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def toml_type_name(value) -> str:
    """What a value read from TOML is, in words, for messages ("a string", "a whole number")."""
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, float):
        return "a decimal number"
    if isinstance(value, int):
        return "a whole number"
    return type(value).__name__


class SettingsError(ValueError):
    """A setting is outside its allowed range; the message names field and range."""


def check_range(owner: str, name: str, value: float, lo: float, hi: float) -> None:
    """Raise SettingsError naming ``owner.name`` when ``value`` is outside [lo, hi]."""
    if not (lo <= value <= hi) or (isinstance(value, float) and math.isnan(value)):
        raise SettingsError(f"{owner}.{name} = {value!r} is outside the allowed range {lo}…{hi}")


@dataclass(frozen=True)
class CameraSettings:
    """Image controls of a camera (simulated cameras render them; real ones get them set)."""

    exposure: float = 0.0  # exposure in EV stops relative to nominal, -4 … +4
    gain: float = 0.0  # sensor gain in dB, 0 … 24 (raises noise too)
    brightness: float = 0.0  # offset added to the image, -100 … +100 (8-bit levels)
    contrast: float = 1.0  # contrast factor around mid-grey, 0.2 … 3.0

    def __post_init__(self) -> None:
        check_range("camera", "exposure", self.exposure, -4.0, 4.0)
        check_range("camera", "gain", self.gain, 0.0, 24.0)
        check_range("camera", "brightness", self.brightness, -100.0, 100.0)
        check_range("camera", "contrast", self.contrast, 0.2, 3.0)


SGBM_MODES = ("SGBM", "HH", "SGBM_3WAY", "HH4")


@dataclass(frozen=True)
class SgbmParams:
    """cv2.StereoSGBM parameters (see OpenCV's stereo_match sample)."""

    min_disparity: int = 0  # px, -64 … 64
    num_disparities: int = 64  # px, multiple of 16, 16 … 256
    block_size: int = 5  # px, odd, 1 … 21
    p1: int = 0  # smoothness penalty for ±1 px changes; 0 = automatic 8·cn·bs²
    p2: int = 0  # penalty for larger changes; 0 = automatic 32·cn·bs² (must exceed P1)
    disp12_max_diff: int = 1  # px left-right check, -1 (off) … 64
    pre_filter_cap: int = 31  # 1 … 63
    uniqueness_ratio: int = 10  # percent, 0 … 50
    speckle_window_size: int = 100  # px, 0 (off) … 300
    speckle_range: int = 2  # px, 0 … 16
    mode: str = "SGBM_3WAY"  # one of SGBM, HH, SGBM_3WAY, HH4

    def __post_init__(self) -> None:
        check_range("sgbm", "min_disparity", self.min_disparity, -64, 64)
        check_range("sgbm", "num_disparities", self.num_disparities, 16, 256)
        if self.num_disparities % 16:
            raise SettingsError(
                f"sgbm.num_disparities = {self.num_disparities} must be a multiple of 16"
            )
        check_range("sgbm", "block_size", self.block_size, 1, 21)
        if self.block_size % 2 == 0:
            raise SettingsError(f"sgbm.block_size = {self.block_size} must be odd")
        check_range("sgbm", "p1", self.p1, 0, 10_000)
        check_range("sgbm", "p2", self.p2, 0, 40_000)
        check_range("sgbm", "disp12_max_diff", self.disp12_max_diff, -1, 64)
        check_range("sgbm", "pre_filter_cap", self.pre_filter_cap, 1, 63)
        check_range("sgbm", "uniqueness_ratio", self.uniqueness_ratio, 0, 50)
        check_range("sgbm", "speckle_window_size", self.speckle_window_size, 0, 300)
        check_range("sgbm", "speckle_range", self.speckle_range, 0, 16)
        if self.mode not in SGBM_MODES:
            raise SettingsError(f"sgbm.mode = {self.mode!r}; allowed: {', '.join(SGBM_MODES)}")

    def penalties(self, channels: int) -> tuple[int, int]:
        """P1, P2 with the automatic 8·cn·bs² / 32·cn·bs² rule applied where 0."""
        area = channels * self.block_size**2
        p1 = self.p1 or 8 * area
        p2 = self.p2 or 32 * area
        return p1, max(p2, p1 + 1)


STEREO_MATCHERS = ("SGBM", "BM")
BM_PREFILTERS = ("XSOBEL", "NORMALIZED_RESPONSE")


@dataclass(frozen=True)
class StereoMatchParams:
    """Which matcher computes disparity and what surrounds it; the block-matching parameters both
    matchers share (disparities, block size, uniqueness, speckle, …) stay in :class:`SgbmParams`."""

    matcher: str = "SGBM"  # SGBM (its mode from SgbmParams.mode) or BM (block matching, ~3x faster)
    bm_prefilter: str = "XSOBEL"  # BM pre-filter: XSOBEL or NORMALIZED_RESPONSE
    bm_prefilter_size: int = 9  # BM normalized-response window (px), odd, 5 … 255
    bm_texture_threshold: int = 10  # BM: minimum local texture for a match, 0 … 1000
    wls: bool = False  # edge-aware WLS filter (a right-view match + filter, ~+60 % time)
    wls_lambda: float = 1000.0  # WLS smoothness, 100 … 20000 (500–2000 suit the simulated desk)
    wls_sigma: float = 0.9  # WLS colour sensitivity, 0.1 … 5.0 (0.8–1.0 suit the simulated desk)
    half_resolution: bool = False  # match at half size and scale back (~4x faster, for the Raspberry Pi)

    def __post_init__(self) -> None:
        if self.matcher not in STEREO_MATCHERS:
            raise SettingsError(f"stereo.matcher = {self.matcher!r}; allowed: {', '.join(STEREO_MATCHERS)}")
        if self.bm_prefilter not in BM_PREFILTERS:
            raise SettingsError(f"stereo.bm_prefilter = {self.bm_prefilter!r}; allowed: {', '.join(BM_PREFILTERS)}")
        check_range("stereo", "bm_prefilter_size", self.bm_prefilter_size, 5, 255)
        if self.bm_prefilter_size % 2 == 0:
            raise SettingsError(f"stereo.bm_prefilter_size = {self.bm_prefilter_size} must be odd")
        check_range("stereo", "bm_texture_threshold", self.bm_texture_threshold, 0, 1000)
        check_range("stereo", "wls_lambda", self.wls_lambda, 100.0, 20000.0)
        check_range("stereo", "wls_sigma", self.wls_sigma, 0.1, 5.0)
        for name in ("wls", "half_resolution"):
            if not isinstance(getattr(self, name), bool):
                raise SettingsError(f"stereo.{name} = {getattr(self, name)!r} must be true or false")


@dataclass(frozen=True)
class LissajousParams:
    """Lissajous trajectory: p(t) = centre + amplitude · sin(2π·f·t + phase), per axis."""

    centre: tuple[float, float, float] = (0.0, 0.15, 0.10)  # m, in robot_base
    amplitude: tuple[float, float, float] = (0.06, 0.03, 0.03)  # m, 0 … 0.5
    frequency_hz: tuple[float, float, float] = (0.10, 0.20, 0.15)  # Hz, 0 … 2
    phase_rad: tuple[float, float, float] = (0.0, math.pi / 2, 0.0)  # rad, -π … π

    def __post_init__(self) -> None:
        for axis, a, f, ph in zip("xyz", self.amplitude, self.frequency_hz, self.phase_rad):
            check_range("lissajous", f"amplitude_{axis}", a, 0.0, 0.5)
            check_range("lissajous", f"frequency_{axis}", f, 0.0, 2.0)
            check_range("lissajous", f"phase_{axis}", ph, -math.pi - 1e-9, math.pi + 1e-9)
        for axis, c in zip("xyz", self.centre):
            check_range("lissajous", f"centre_{axis}", c, -1.0, 1.0)

    def point(self, t: float) -> tuple[float, float, float]:
        """The curve's point at time t (s), in robot_base (m)."""
        return tuple(  # type: ignore[return-value]
            c + a * math.sin(2 * math.pi * f * t + ph)
            for c, a, f, ph in zip(self.centre, self.amplitude, self.frequency_hz, self.phase_rad)
        )

    def period_s(self) -> float:
        """A time span covering the whole curve (up to 60 s for incommensurate frequencies)."""
        fs = [f for f, a in zip(self.frequency_hz, self.amplitude) if f > 0 and a > 0]
        if not fs:
            return 1.0
        # the curve repeats after the lcm of the periods; with frequencies on a 0.01 Hz grid
        # that is 1/gcd(f) — cap it so a preview never needs thousands of points
        cents = [max(1, round(f * 100)) for f in fs]
        g = cents[0]
        for c in cents[1:]:
            g = math.gcd(g, c)
        return min(100.0 / g, 60.0)


def replace_field(obj, **changes):
    """dataclasses.replace that keeps validation (re-runs __post_init__)."""
    values = {f.name: getattr(obj, f.name) for f in fields(obj)}
    values.update(changes)
    return type(obj)(**values)
