"""Stereo matching and calibration timings: SGBM (every mode), BM, WLS and half resolution at
544x288 and 640x480 on the simulated desk 50 cm below the rig (with the median depth error as the
extra), and a 20-pair chessboard calibration (detection per image, calibrate_stereo alone)."""
from __future__ import annotations

import itertools
import time

import numpy as np

from core.settings import SgbmParams, StereoMatchParams
from core.sim.board_render import default_rig, render_set
from core.sim.desk import SimDesk
from core.sim.rig import SimRig, SimRigConfig
from core.vision.disparity import DisparityComputer
from core.vision.stereo_calibration import ChessboardSpec, calibrate_stereo, detect_pair

SIZES = ((544, 288), (640, 480))
DISTANCE_M = 0.50


def _desk(size):
    w, h = size
    rig = SimRig(SimRigConfig(width=w, height=h, focal_px=430.0 * w / 640, position=(0.0, 0.15, DISTANCE_M),
                              look_at=(0.0, 0.15, 0.0)))
    left, right, _ = SimDesk(rig, scenario="static").render(0.0)
    calib = rig.calibration()
    uu, vv = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    rays = rig.base_T_left[:3, :3] @ calib.R1.T @ np.linalg.inv(calib.P1[:3, :3]) @ np.stack(
        [uu.ravel(), vv.ravel(), np.ones(uu.size)])
    z_true = (-rig.base_T_left[2, 3] / rays[2]).reshape(h, w)
    return calib, left, right, z_true


def _time(fn, n: int) -> list[float]:
    fn()  # warm-up (allocations, thread pool)
    out = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        out.append((time.perf_counter() - t0) * 1e3)
    return out


def time_disparity(dc: DisparityComputer, left: np.ndarray, right: np.ndarray, n: int) -> list[float]:
    """ms per ``dc.compute`` of the pair, n times. ``compute`` returns its last result again for the
    same image objects (the window asks twice per frame), so the calls alternate between the pair
    and a copy of it: every timed call matches."""
    pairs = itertools.cycle(((left, right), (left.copy(), right.copy())))
    return _time(lambda: dc.compute(*next(pairs)), n)


def stereo_rows(quick: bool = False, sizes=SIZES) -> list[dict]:
    n = 5 if quick else 30
    variants = [(f"SGBM mode {m}", SgbmParams(mode=m), StereoMatchParams()) for m in ("SGBM", "HH", "SGBM_3WAY", "HH4")]
    variants += [
        ("StereoBM", SgbmParams(), StereoMatchParams(matcher="BM")),
        ("SGBM_3WAY + WLS", SgbmParams(), StereoMatchParams(wls=True)),
        ("StereoBM + WLS", SgbmParams(), StereoMatchParams(matcher="BM", wls=True)),
        ("SGBM_3WAY half resolution", SgbmParams(), StereoMatchParams(half_resolution=True)),
    ]
    rows = []
    for size in sizes:
        calib, left, right, z_true = _desk(size)
        tag = f"{size[0]}x{size[1]}"
        for label, params, match in variants:
            dc = DisparityComputer(calib, params, match)
            samples = time_disparity(dc, left, right, n)
            z = dc.depth_map_m(dc.compute(left, right))
            ok = np.isfinite(z)
            ok[:, : params.num_disparities] = False
            rel = np.abs(z[ok] / z_true[ok] - 1)
            base = None if label == "SGBM mode SGBM" else f"disparity {tag} SGBM mode SGBM"
            rows.append({
                "name": f"disparity {tag} {label}", "unit": "ms", "samples": samples, "baseline": base,
                "extra": (f"nd64 bs5 incl. rectify; depth error at 50 cm: median {np.median(rel) * 100:.2f} %, "
                          f"valid {ok.mean() * 100:.0f} % of pixels"),
            })
    return rows


def calibration_rows(quick: bool = False) -> list[dict]:
    board = ChessboardSpec(9, 6, 0.025)
    rig = default_rig(distortion=True)
    pairs = render_set(board, rig, 20, seed=1)
    detect_ms, dets = [], []
    for p in pairs:
        t0 = time.perf_counter()
        dets.append(detect_pair(p.left, p.right, board))
        detect_ms.append((time.perf_counter() - t0) * 1e3 / 2)
    n = 3 if quick else 10
    calib_ms = _time(lambda: calibrate_stereo(dets, board=board), n)

    def everything():
        calibrate_stereo([detect_pair(p.left, p.right, board) for p in pairs], board=board)

    total_ms = _time(everything, 1 if quick else 3)
    r = calibrate_stereo(dets, board=board)
    c = r.calibration
    fx_err = (c.M1[0, 0] / rig.K1[0, 0] - 1) * 100
    b_err = (c.baseline_m / rig.baseline_m - 1) * 100
    return [
        {"name": "calibration: detect chessboard, one 640x480 image", "unit": "ms", "samples": detect_ms,
         "baseline": None, "extra": "findChessboardCorners (adaptive|normalize|fast check) + cornerSubPix; SB only as fallback"},
        {"name": "calibration: calibrate_stereo, 20 pairs", "unit": "ms", "samples": calib_ms, "baseline": None,
         "extra": (f"2 mono + stereo solves, outlier round; stereo RMS {r.rms_stereo:.3f} px, "
                   f"fx error {fx_err:+.2f} %, baseline error {b_err:+.2f} %")},
        {"name": "calibration: detect + calibrate, 20 pairs", "unit": "ms", "samples": total_ms, "baseline": None,
         "extra": "what `deskarm calibrate` spends on 20 rendered 640x480 pairs, image reading excluded"},
    ]


def rows(quick: bool = False) -> list[dict]:
    """Every row of this bench (``quick``: fewer samples)."""
    return stereo_rows(quick) + calibration_rows(quick)


if __name__ == "__main__":  # pragma: no cover
    from bench.__main__ import format_table

    print(format_table(rows(quick=False)))
