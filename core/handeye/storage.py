"""The camera → robot file: a HandEyeResult (or a PlanarMap) as TOML, written whole or not at all.

Errors name the file and the key; ``load_hand_eye`` warns when the file belongs to another
camera pair (a stale calibration: the cameras were swapped or moved to another machine).
"""
from __future__ import annotations

import math
import reprlib
from pathlib import Path
from typing import Optional

import numpy as np

from core.handeye.solve import METHODS, HandEyeResult, PlanarMap
from core.paths import UserFileError, read_user_toml, user_dir, write_file_atomically

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


FIX = "run `deskarm calibrate-hand-eye` again"


def _short(value) -> str:
    """``repr(value)`` cut to a line (a value nested hundreds of levels deep stays one line)."""
    short = reprlib.Repr()
    short.maxlevel, short.maxlist, short.maxdict, short.maxstring, short.maxother = 2, 4, 4, 40, 40
    return short.repr(value)


def _read(path: Path) -> dict:
    try:
        return read_user_toml(path, "a hand-eye file", FIX)
    except FileNotFoundError:
        raise HandEyeFileError(f"{path}: no such hand-eye file — run `deskarm calibrate-hand-eye`") from None
    except UserFileError as exc:
        raise HandEyeFileError(str(exc)) from None


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _get(data: dict, path: Path, key: str, kind, where: str = ""):
    src = data
    for part in key.split("."):
        if not isinstance(src, dict) or part not in src:
            raise HandEyeFileError(f"{path}: key {where}{key!r} is missing — {FIX}")
        src = src[part]
    if kind is float and _number(src):
        src = float(src)
    if not isinstance(src, kind) or (kind is int and isinstance(src, bool)):
        expected = {float: "a number", int: "a whole number", str: "a string", list: "a list"}.get(kind, kind.__name__)
        raise HandEyeFileError(f"{path}: key {key!r} = {_short(src)} is not {expected} — {FIX}")
    return src


def _optional_list(data: dict, path: Path, key: str, check, expected: str) -> list:
    """The list at ``quality.<key>`` ([] when absent), each item passing ``check``, or HandEyeFileError."""
    quality = data.get("quality", {})
    items = quality.get(key, []) if isinstance(quality, dict) else []
    if not isinstance(items, list) or not all(check(v) for v in items):
        raise HandEyeFileError(f"{path}: key 'quality.{key}' = {_short(items)} must be a list of {expected} — {FIX}")
    return items


def _matrix(data: dict, path: Path, key: str, n: int) -> np.ndarray:
    rows = _get(data, path, key, list)
    ok = len(rows) == n and all(isinstance(r, list) and len(r) == n and all(_number(v) for v in r) for r in rows)
    M = np.array(rows, dtype=float) if ok else None
    if M is None or not np.all(np.isfinite(M)):
        raise HandEyeFileError(f"{path}: key {key!r} must be a {n}x{n} table of finite numbers — {FIX}")
    return M


def _finite_at_least_zero(value) -> bool:
    return _number(value) and math.isfinite(value) and value >= 0


def load_hand_eye(path=None, expected_pair: Optional[str] = None) -> tuple[HandEyeResult, str]:
    """(result, warning) from a hand-eye file; warning is "" or says the file is for another pair.

    HandEyeFileError naming the file, the key and what is expected for a missing, unreadable or
    invalid file (any bad value: nothing of the file is used).
    """
    path = Path(path) if path is not None else default_hand_eye_path()
    data = _read(path)
    method = _get(data, path, "method", str)
    if method not in METHODS:
        raise HandEyeFileError(f"{path}: key 'method' = {_short(method)}; valid: {', '.join(METHODS)}")
    T = _matrix(data, path, "base_T_camera", 4)
    R = T[:3, :3]
    if np.linalg.norm(R.T @ R - np.eye(3)) > 1e-4 or np.linalg.det(R) < 0 or np.any(T[3] != (0, 0, 0, 1)):
        raise HandEyeFileError(f"{path}: key 'base_T_camera' is not a rigid transform (rotation + translation)")
    values = {}
    for key in ("rms_mm", "max_mm"):
        values[key] = _get(data, path, f"quality.{key}", float)
        if not _finite_at_least_zero(values[key]):
            raise HandEyeFileError(f"{path}: key 'quality.{key}' = {values[key]!r} is not a finite number ≥ 0 — {FIX}")
    poses_used = _get(data, path, "quality.poses_used", int)
    if poses_used < 0:
        raise HandEyeFileError(f"{path}: key 'quality.poses_used' = {poses_used} must be ≥ 0 — {FIX}")
    worst_index = _get(data, path, "quality.worst_index", int)
    residuals = _get(data, path, "quality.residuals_mm", list)
    if not all(_finite_at_least_zero(v) for v in residuals):
        raise HandEyeFileError(f"{path}: key 'quality.residuals_mm' = {_short(residuals)} must be a list of "
                               f"finite numbers ≥ 0 (mm) — {FIX}")
    rejected = _optional_list(data, path, "rejected", lambda v: isinstance(v, int) and not isinstance(v, bool)
                              and v >= 0, "whole numbers ≥ 0 (pair indices)")
    warnings = _optional_list(data, path, "warnings", lambda v: isinstance(v, str), "strings")
    text = {}
    for key, default in (("created", ""), ("name", "camera→robot")):
        text[key] = data.get(key, default)
        if not isinstance(text[key], str):
            raise HandEyeFileError(f"{path}: key {key!r} = {_short(text[key])} is not a string — {FIX}")
    result = HandEyeResult(
        base_T_camera=T, method=method, poses_used=poses_used,
        residuals_mm=tuple(float(v) for v in residuals),
        rms_mm=values["rms_mm"], max_mm=values["max_mm"], worst_index=worst_index,
        rejected=tuple(rejected), warnings=tuple(warnings),
        camera_pair=_get(data, path, "camera_pair", str),
        created=text["created"], name=text["name"],
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
