"""The camera → robot file: a HandEyeResult (or a PlanarMap) as TOML, written whole or not at all.

Errors name the file and the key; ``load_hand_eye`` warns when the file belongs to another
camera pair (a stale calibration: the cameras were swapped or moved to another machine).
"""
from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Optional

import numpy as np

from core.handeye.solve import METHODS, HandEyeResult, PlanarMap
from core.paths import user_dir, write_file_atomically

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

FORMAT = "deskarm-hand-eye-1"


class HandEyeFileError(ValueError):
    """A hand-eye file that cannot be used; the message names the file, the key and the fix."""


def default_hand_eye_path() -> Path:
    """Where ``deskarm calibrate-hand-eye`` saves and the session looks by default."""
    return user_dir("config") / "hand_eye.toml"


def _dump(data: dict) -> bytes:
    import tomli_w

    return tomli_w.dumps(data).encode("utf-8")


def save_hand_eye(result: HandEyeResult, path=None) -> Path:
    """Write ``result`` to ``path`` (default: ``default_hand_eye_path()``); returns the path."""
    path = Path(path) if path is not None else default_hand_eye_path()
    data = {
        "format": FORMAT,
        "name": result.name,
        "created": result.created,
        "method": result.method,
        "camera_pair": result.camera_pair,
        "base_T_camera": [[float(v) for v in row] for row in np.asarray(result.base_T_camera)],
        "quality": {
            "poses_used": int(result.poses_used),
            "rms_mm": float(result.rms_mm),
            "max_mm": float(result.max_mm),
            "worst_index": int(result.worst_index),
            "residuals_mm": [float(v) for v in result.residuals_mm],
            "rejected": [int(i) for i in result.rejected],
            "warnings": list(result.warnings),
        },
    }
    return write_file_atomically(path, _dump(data))


def _read(path: Path) -> dict:
    try:
        text = path.read_bytes().decode("utf-8")
    except FileNotFoundError:
        raise HandEyeFileError(f"{path}: no such hand-eye file — run `deskarm calibrate-hand-eye`") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise HandEyeFileError(f"{path}: cannot read: {exc}") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise HandEyeFileError(f"{path}: not valid TOML ({exc}) — run `deskarm calibrate-hand-eye` again") from None


def _get(data: dict, path: Path, key: str, kind, where: str = ""):
    src = data
    for part in key.split("."):
        if not isinstance(src, dict) or part not in src:
            raise HandEyeFileError(f"{path}: key {where}{key!r} is missing — run `deskarm calibrate-hand-eye` again")
        src = src[part]
    if kind is float and isinstance(src, int) and not isinstance(src, bool):
        src = float(src)
    if not isinstance(src, kind):
        raise HandEyeFileError(f"{path}: key {key!r} = {src!r} is not a {kind.__name__}")
    return src


def _matrix(data: dict, path: Path, key: str, n: int) -> np.ndarray:
    rows = _get(data, path, key, list)
    try:
        M = np.array(rows, dtype=float)
    except (TypeError, ValueError):
        M = None
    if M is None or M.shape != (n, n) or not np.all(np.isfinite(M)):
        raise HandEyeFileError(f"{path}: key {key!r} must be a {n}x{n} table of finite numbers")
    return M


def load_hand_eye(path=None, expected_pair: Optional[str] = None) -> tuple[HandEyeResult, str]:
    """(result, warning) from a hand-eye file; warning is "" or says the file is for another pair.

    HandEyeFileError naming the file and the key for a missing, unreadable or invalid file.
    """
    path = Path(path) if path is not None else default_hand_eye_path()
    data = _read(path)
    method = _get(data, path, "method", str)
    if method not in METHODS:
        raise HandEyeFileError(f"{path}: key 'method' = {method!r}; valid: {', '.join(METHODS)}")
    T = _matrix(data, path, "base_T_camera", 4)
    R = T[:3, :3]
    if np.linalg.norm(R.T @ R - np.eye(3)) > 1e-4 or np.linalg.det(R) < 0 or np.any(T[3] != (0, 0, 0, 1)):
        raise HandEyeFileError(f"{path}: key 'base_T_camera' is not a rigid transform (rotation + translation)")
    rms = _get(data, path, "quality.rms_mm", float)
    if not (math.isfinite(rms) and rms >= 0):
        raise HandEyeFileError(f"{path}: key 'quality.rms_mm' = {rms!r} is not a finite number ≥ 0")
    result = HandEyeResult(
        base_T_camera=T, method=method,
        poses_used=_get(data, path, "quality.poses_used", int),
        residuals_mm=tuple(float(v) for v in _get(data, path, "quality.residuals_mm", list)),
        rms_mm=rms, max_mm=_get(data, path, "quality.max_mm", float),
        worst_index=_get(data, path, "quality.worst_index", int),
        rejected=tuple(int(v) for v in data.get("quality", {}).get("rejected", [])),
        warnings=tuple(str(v) for v in data.get("quality", {}).get("warnings", [])),
        camera_pair=_get(data, path, "camera_pair", str),
        created=str(data.get("created", "")), name=str(data.get("name", "camera→robot")),
    )
    warning = ""
    if expected_pair is not None and result.camera_pair != expected_pair:
        warning = (f"{path} is for another camera pair ({result.camera_pair!r}, these are {expected_pair!r}) — "
                   "stale camera→arm calibration ignored; run `deskarm calibrate-hand-eye`")
    return result, warning


def save_planar(m: PlanarMap, path) -> Path:
    """``m.save(path)``: a PlanarMap as TOML."""
    return m.save(path)


def load_planar(path) -> PlanarMap:
    """``PlanarMap.load(path)``."""
    return PlanarMap.load(path)
