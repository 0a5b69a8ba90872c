"""Stereo calibration: the one YAML file (cv2.FileStorage, OpenCV sample keys) and its loader.

The simulated rig writes its exact calibration through ``save_calibration`` and the app reads it
back through ``load_calibration`` — the same path a real calibration takes.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping, Optional, Union

import cv2
import numpy as np

from core.paths import os_error_reason, user_dir, write_file_atomically


class CalibrationError(ValueError):
    """A calibration file is missing, corrupt or does not fit the cameras.

    ``path`` is the file (when one is concerned), ``key`` the offending key when one is to blame,
    and ``missing`` tells "there is no file there at all" (the usual first start) apart from a
    file that is there but cannot be used.
    """

    def __init__(self, message: str, *, path: Optional[Union[str, os.PathLike]] = None,
                 key: Optional[str] = None, missing: bool = False) -> None:
        super().__init__(message)
        self.path = None if path is None else Path(path)
        self.key = key
        self.missing = missing


MAX_IMAGE_SIDE_PX = 8192  # larger "calibrated sizes" are corrupt files: their rectify maps alone need GBs
MIN_BASELINE_M = 1e-4  # 0.1 mm: below this the two views are one camera and rectification is undefined


@dataclass(frozen=True, eq=False)
class StereoCalibration:
    """Intrinsics of both cameras, the right camera's pose and the rectification derived from it.

    ``R``, ``T`` map a point from camera_left to camera_right: ``X_right = R @ X_left + T``
    (OpenCV's stereoCalibrate convention). Metres.
    """

    M1: np.ndarray  # 3x3 left camera matrix (px)
    D1: np.ndarray  # left distortion coefficients (1xN)
    M2: np.ndarray  # 3x3 right camera matrix
    D2: np.ndarray
    R: np.ndarray  # 3x3 rotation camera_left -> camera_right
    T: np.ndarray  # (3,1) translation camera_left -> camera_right (m)
    image_size: tuple[int, int]  # (width, height) px
    rms_stereo: float = 0.0  # stereo reprojection RMS of the calibration (px)
    epipolar_error_px: float = 0.0  # mean epipolar error of the calibration pairs (px)
    source: str = ""  # file it was read from, for messages
    notes: tuple[str, ...] = ()  # e.g. "intrinsics rescaled from 1280x960"
    rect: dict = field(default_factory=dict, repr=False)  # filled in __post_init__

    def __post_init__(self) -> None:
        T = np.asarray(self.T, dtype=np.float64).reshape(3, 1)  # OpenCV 5 needs (3,1)
        object.__setattr__(self, "T", T)
        w, h = self.image_size
        R1, R2, P1, P2, Q, roi1, roi2 = cv2.stereoRectify(
            self.M1, self.D1, self.M2, self.D2, (w, h), self.R, T,
            flags=cv2.CALIB_ZERO_DISPARITY, alpha=0,
        )
        tx = T.reshape(3)
        E = _skew(tx) @ self.R
        F = np.linalg.inv(self.M2).T @ E @ np.linalg.inv(self.M1)
        self.rect.update(R1=R1, R2=R2, P1=P1, P2=P2, Q=Q, E=E, F=F / F[2, 2] if abs(F[2, 2]) > 1e-12 else F)

    # Rectification products (as stereoRectify computes them)
    @property
    def R1(self) -> np.ndarray:
        return self.rect["R1"]

    @property
    def R2(self) -> np.ndarray:
        return self.rect["R2"]

    @property
    def P1(self) -> np.ndarray:
        return self.rect["P1"]

    @property
    def P2(self) -> np.ndarray:
        return self.rect["P2"]

    @property
    def Q(self) -> np.ndarray:
        return self.rect["Q"]

    @property
    def E(self) -> np.ndarray:
        return self.rect["E"]

    @property
    def F(self) -> np.ndarray:
        return self.rect["F"]

    @property
    def baseline_m(self) -> float:
        return float(np.linalg.norm(self.T))

    def rectify_maps(self, m1type: int = cv2.CV_16SC2):
        """(left_maps, right_maps) for cv2.remap into the rectified pair."""
        size = self.image_size
        left = cv2.initUndistortRectifyMap(self.M1, self.D1, self.R1, self.P1, size, m1type)
        right = cv2.initUndistortRectifyMap(self.M2, self.D2, self.R2, self.P2, size, m1type)
        return left, right


def _skew(v: np.ndarray) -> np.ndarray:
    x, y, z = (float(a) for a in v)
    return np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]], dtype=np.float64)


_MATRIX_KEYS = ("M1", "D1", "M2", "D2", "R", "T", "E", "F", "R1", "R2", "P1", "P2", "Q")


def save_calibration(path: str | os.PathLike, calib: StereoCalibration,
                     extra: Optional[Mapping[str, Union[int, float, str]]] = None) -> Path:
    """Write ``calib`` as one YAML file with the keys of OpenCV's stereo_calib sample.

    ``extra`` adds scalar keys (e.g. rms_left, pairs_used, board) that the loader ignores.
    """
    path = Path(path)
    for key in extra or {}:
        if key in _MATRIX_KEYS or key in ("image_width", "image_height", "rms_stereo", "epipolar_error_px"):
            raise ValueError(f"extra key {key!r} would overwrite a calibration key")
        if not key.isidentifier():
            raise ValueError(f"extra key {key!r} is not a valid YAML/FileStorage name")
    # Composed in memory and written by Python: one place turns a read-only folder into
    # "…: permission denied — …" (an OSError), and a half-written calibration is never left behind.
    fs = cv2.FileStorage(".yaml", cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_MEMORY)
    for key in _MATRIX_KEYS:
        fs.write(key, np.asarray(getattr(calib, key), dtype=np.float64))
    fs.write("image_width", int(calib.image_size[0]))
    fs.write("image_height", int(calib.image_size[1]))
    fs.write("rms_stereo", float(calib.rms_stereo))
    fs.write("epipolar_error_px", float(calib.epipolar_error_px))
    for key, value in (extra or {}).items():
        fs.write(key, value if isinstance(value, str) else float(value) if isinstance(value, float) else int(value))
    text = fs.releaseAndGetString()
    return write_file_atomically(path, text.encode("utf-8"))


_EXPECTED_SHAPES = {"M1": (3, 3), "M2": (3, 3), "R": (3, 3)}
_FIX = "run `deskarm calibrate` again or pick another file"


def load_calibration(
    path: str | os.PathLike, expected_size: Optional[tuple[int, int]] = None
) -> StereoCalibration:
    """Read a stereo calibration YAML; validate shapes and values; fit it to ``expected_size`` if given.

    A file for another resolution with the same aspect ratio has its intrinsics rescaled (and
    says so in ``notes``); any other problem raises CalibrationError naming the file, the key
    and the fix — never an OpenCV traceback, and nothing of a bad file is used.
    """
    path = Path(path)
    fix = _FIX

    def bad(message: str, key: Optional[str] = None, **kw) -> CalibrationError:
        return CalibrationError(f"{path}: {message}", path=path, key=key, **kw)

    if not path.exists():
        raise bad(f"calibration file not found — {fix}", missing=True)
    if path.is_dir():
        raise bad(f"is a folder, expected a calibration YAML file — {fix}")
    try:  # OpenCV says only "cannot open": ask the OS why first
        with open(path, "rb"):
            pass
    except PermissionError:
        raise bad(f"cannot read: permission denied — make it readable for your user "
                  f"(chmod u+r '{path}')") from None
    except OSError as exc:
        raise bad(f"cannot read: {os_error_reason(exc)} — {fix}") from None
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as exc:  # OpenCV 5 raises SystemError on parse errors
        first = str(exc).strip().splitlines()[-1] if str(exc).strip() else "unreadable"
        raise bad(f"not a readable OpenCV YAML/XML file ({first}) — {fix}") from None
    try:
        if not fs.isOpened():
            raise bad(f"not a readable OpenCV YAML/XML file — {fix}")
        values = {}
        for key in ("M1", "D1", "M2", "D2", "R", "T"):
            node = fs.getNode(key)
            mat = None if node.empty() else node.mat()
            if mat is None:
                raise bad(f"key '{key}' is missing or not a matrix — {fix}", key)
            values[key] = np.asarray(mat, dtype=np.float64)
        scalars = {key: fs.getNode(key).real()
                   for key in ("image_width", "image_height", "rms_stereo", "epipolar_error_px")}
    finally:
        fs.release()
    for key, shape in _EXPECTED_SHAPES.items():
        if values[key].shape != shape:
            raise bad(f"'{key}' has shape {values[key].shape}, expected {shape} — {fix}", key)
    if values["T"].size != 3:
        raise bad(f"'T' has {values['T'].size} values, expected 3 — {fix}", "T")
    for key in ("D1", "D2"):
        if values[key].size not in (4, 5, 8, 12, 14):
            raise bad(f"'{key}' has {values[key].size} coefficients, expected 4, 5, 8, 12 or 14 — {fix}", key)
        values[key] = values[key].reshape(1, -1)
    for key, mat in values.items():
        if not np.all(np.isfinite(mat)):
            raise bad(f"'{key}' contains NaN or infinity — {fix}", key)
    for key in ("image_width", "image_height"):
        side = scalars[key]
        if not (16 <= side <= MAX_IMAGE_SIDE_PX and side == int(side)):
            raise bad(f"'{key}' = {side:g} px is missing or invalid (expected a whole number "
                      f"16…{MAX_IMAGE_SIDE_PX}) — {fix}", key)
    for key in ("rms_stereo", "epipolar_error_px"):  # absent keys read as 0: fine
        if not (math.isfinite(scalars[key]) and scalars[key] >= 0):
            raise bad(f"'{key}' = {scalars[key]:g} px must be a finite value ≥ 0 — {fix}", key)
    for key in ("M1", "M2"):
        problem = _camera_matrix_problem(values[key])
        if problem:
            raise bad(f"'{key}' {problem}; a camera matrix is [[fx, s, cx], [0, fy, cy], [0, 0, 1]] "
                      f"with fx, fy > 0 (px) — {fix}", key)
    file_size = (int(scalars["image_width"]), int(scalars["image_height"]))
    for mkey, dkey in (("M1", "D1"), ("M2", "D2")):
        problem = distortion_problem(values[mkey], values[dkey], file_size)
        if problem:
            shown = ", ".join(f"{v:g}" for v in values[dkey].ravel())
            raise bad(f"'{dkey}' = [{shown}] {problem} — not a plausible lens; {fix}", dkey)
    R = values["R"]
    if abs(np.linalg.det(R) - 1.0) > 1e-3:
        raise bad(f"'R' is not a rotation matrix (det ≠ 1) — {fix}", "R")
    if np.max(np.abs(R @ R.T - np.eye(3))) > 1e-3:
        raise bad(f"'R' is not a rotation matrix (R·Rᵀ ≠ I) — {fix}", "R")
    baseline_m = float(np.linalg.norm(values["T"]))
    if baseline_m < MIN_BASELINE_M:
        raise bad(f"'T': baseline |T| = {baseline_m:g} m — the two cameras cannot be the same; "
                  f"recalibrate (run `deskarm calibrate`) or pick another file", "T")
    size = (int(scalars["image_width"]), int(scalars["image_height"]))
    notes: list[str] = []
    if expected_size is not None and tuple(expected_size) != size:
        ew, eh = expected_size
        if not math.isclose(ew / eh, size[0] / size[1], rel_tol=1e-3):
            raise bad(
                f"calibrated for {size[0]}x{size[1]} but the cameras deliver {ew}x{eh} "
                f"(another aspect ratio) — calibrate at {ew}x{eh} or set the cameras to {size[0]}x{size[1]}"
            )
        scale = ew / size[0]
        for key in ("M1", "M2"):
            m = values[key].copy()
            m[:2, :] *= scale
            values[key] = m
        notes.append(f"intrinsics rescaled from {size[0]}x{size[1]} to {ew}x{eh}")
        size = (int(ew), int(eh))
    try:
        return StereoCalibration(
            M1=values["M1"], D1=values["D1"], M2=values["M2"], D2=values["D2"], R=values["R"],
            T=values["T"].reshape(3, 1), image_size=size, rms_stereo=float(scalars["rms_stereo"]),
            epipolar_error_px=float(scalars["epipolar_error_px"]), source=str(path), notes=tuple(notes),
        )
    except (cv2.error, np.linalg.LinAlgError) as exc:  # a combination the checks above did not foresee
        last = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
        raise bad(f"rectification failed ({last}) — {fix}") from None


def _camera_matrix_problem(m: np.ndarray) -> str:
    """Why ``m`` is not a usable 3x3 camera matrix, or "" (it is upper triangular, fx, fy > 0)."""
    if not np.any(m):
        return "is all zeros (singular)"
    fx, fy = float(m[0, 0]), float(m[1, 1])
    if not (fx > 0 and fy > 0):
        return f"has fx = {fx:g}, fy = {fy:g} (both must be > 0; singular or mirrored)"
    if not (np.allclose(m[2], (0.0, 0.0, 1.0), atol=1e-9) and abs(m[1, 0]) <= 1e-9 * max(fx, fy)):
        return (f"has last row [{m[2, 0]:g} {m[2, 1]:g} {m[2, 2]:g}] and [1][0] = {m[1, 0]:g} "
                f"(expected [0 0 1] and 0)")
    return ""


# A plausible lens maps the image border to a closed ring around the principal point, in the same
# order, neither shrunk to a point nor blown up far beyond the image (wide lenses reach ~2–3×).
MAX_BORDER_STRETCH = 4.0  # undistorted border radius / distorted radius, at most
MIN_BORDER_STRETCH = 0.5  # … and at least (a lens never "zooms in" twice at its edges)
BORDER_ROUND_TRIP_PX = 1.0  # undistort then distort again must come back this close
BORDER_POINTS_PER_SIDE = 16
RAY_STEPS = 24  # samples from the principal point to each corner and edge midpoint


def _border_ring(w: int, h: int) -> np.ndarray:
    """Points around the image border in order (clockwise in image coordinates), shape (N, 2)."""
    t = np.linspace(0.0, 1.0, BORDER_POINTS_PER_SIDE, endpoint=False)
    x1, y1 = w - 1.0, h - 1.0
    return np.concatenate([
        np.stack([t * x1, np.zeros_like(t)], 1), np.stack([np.full_like(t, x1), t * y1], 1),
        np.stack([(1 - t) * x1, np.full_like(t, y1)], 1), np.stack([np.zeros_like(t), (1 - t) * y1], 1),
    ])


def distortion_problem(M: np.ndarray, D: np.ndarray, image_size: tuple[int, int]) -> str:
    """Why ``D`` is not a plausible lens distortion for camera ``M`` at ``image_size``, or "".

    The image border is undistorted (``cv2.undistortPoints``) and must stay a ring around the
    principal point in the same order, within MIN_BORDER_STRETCH…MAX_BORDER_STRETCH of where it
    was, and distort back to where it was; rays from the principal point to the border must stay
    monotonic (a lens model that folds back has no inverse there: every point past the fold is
    triangulated somewhere else). ``D1 = [1e6, 0, 0, 0, 0]`` shrinks the border 100-fold: refused.
    """
    w, h = image_size
    M = np.asarray(M, np.float64)
    D = np.asarray(D, np.float64).reshape(1, -1)
    if not np.any(D):
        return ""
    centre = np.array([M[0, 2], M[1, 2]])
    ring = _border_ring(w, h)
    corners_mid = np.array([[0, 0], [w - 1, 0], [w - 1, h - 1], [0, h - 1],
                            [(w - 1) / 2, 0], [w - 1, (h - 1) / 2], [(w - 1) / 2, h - 1], [0, (h - 1) / 2]], float)
    s = np.linspace(0.05, 1.0, RAY_STEPS)
    rays = centre + (corners_mid - centre)[:, None, :] * s[None, :, None]  # (8, RAY_STEPS, 2)
    pts = np.concatenate([ring, rays.reshape(-1, 2)])
    try:
        # OpenCV's default 5 iterations do not converge at the border of a strong (real) lens
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-12)
        norm = cv2.undistortPoints(pts.reshape(-1, 1, 2), M, D, None, None, None, criteria).reshape(-1, 2)
        und = norm @ M[:2, :2].T + M[:2, 2]
        rvec = tvec = np.zeros(3)
        back = cv2.projectPoints(np.column_stack([norm, np.ones(len(norm))]), rvec, tvec, M, D)[0].reshape(-1, 2)
    except cv2.error as exc:
        return f"cannot be applied to the image ({str(exc).strip().splitlines()[-1]})"
    if not (np.all(np.isfinite(und)) and np.all(np.isfinite(back))):
        return "sends the image border to infinity"
    r_before = np.linalg.norm(pts - centre, axis=1)
    r_after = np.linalg.norm(und - centre, axis=1)
    far = r_before > 0.25 * min(w, h)  # the stretch of points near the centre says little
    stretch = r_after[far] / r_before[far]
    if stretch.max() > MAX_BORDER_STRETCH or stretch.min() < MIN_BORDER_STRETCH:
        worst = stretch.max() if stretch.max() > MAX_BORDER_STRETCH else stretch.min()
        return (f"moves the image border to {worst:.3g}× its distance from the image centre (a real lens: "
                f"{MIN_BORDER_STRETCH:g}…{MAX_BORDER_STRETCH:g}×)")
    round_trip = float(np.max(np.linalg.norm(back - pts, axis=1)))
    if round_trip > BORDER_ROUND_TRIP_PX:
        return (f"cannot be undone at the image border (a point comes back {round_trip:.3g} px away: the lens "
                f"model folds back inside the image)")
    ring_und = und[:len(ring)] - centre
    turn = np.diff(np.unwrap(np.arctan2(ring_und[:, 1], ring_und[:, 0])))
    ring_raw = ring - centre
    turn_raw = np.diff(np.unwrap(np.arctan2(ring_raw[:, 1], ring_raw[:, 0])))
    if np.any(np.sign(turn) != np.sign(turn_raw)):
        return "scrambles the order of the points around the image border"
    ray_r = r_after[len(ring):].reshape(len(corners_mid), RAY_STEPS)
    if np.any(np.diff(ray_r, axis=1) <= 0):
        return "folds the image back on itself between its centre and its border"
    return ""


def ros_distortion(D) -> tuple[str, np.ndarray]:
    """(distortion model, coefficients) as ROS writes them: plumb_bob for 4–5 coefficients (a
    missing k3 is 0), rational_polynomial for 8; ROS has no thin-prism/tilted model, so 12 or 14
    coefficients keep their rational part."""
    d = np.asarray(D, np.float64).reshape(-1)
    if d.size == 4:
        d = np.append(d, 0.0)
    if d.size > 8:
        d = d[:8]
    return ("plumb_bob" if d.size == 5 else "rational_polynomial"), d


def ros_camera_info_yaml(calib: StereoCalibration, side: str, camera_name: str = "") -> str:
    """One camera of the pair as a ROS ``camera_info`` YAML (camera_calibration_parsers format):
    K, D (plumb_bob, or rational_polynomial for 8 coefficients), the rectifying R and projection P."""
    if side not in ("left", "right"):
        raise ValueError(f"side {side!r}; valid: left, right")
    M, D, R, P = ((calib.M1, calib.D1, calib.R1, calib.P1) if side == "left"
                  else (calib.M2, calib.D2, calib.R2, calib.P2))
    model, d = ros_distortion(D)

    def mat(name: str, m: np.ndarray) -> str:
        m = np.asarray(m, np.float64)
        rows, cols = (1, m.size) if m.ndim == 1 else m.shape
        data = ", ".join(f"{v:.10g}" for v in m.reshape(-1))
        return f"{name}:\n  rows: {rows}\n  cols: {cols}\n  data: [{data}]\n"

    w, h = calib.image_size
    return (f"image_width: {w}\nimage_height: {h}\ncamera_name: {camera_name or side}\n"
            + mat("camera_matrix", M) + f"distortion_model: {model}\n" + mat("distortion_coefficients", d)
            + mat("rectification_matrix", R) + mat("projection_matrix", P))


def export_ros_camera_info(calib: StereoCalibration, folder: str | os.PathLike,
                           names: tuple[str, str] = ("left", "right")) -> list[Path]:
    """Write ``left.yaml`` and ``right.yaml`` (ROS camera_info) into ``folder``; returns the paths.

    The right camera's P carries Tx = −fx'·baseline (m), as ROS stereo_image_proc expects.
    """
    folder = Path(folder)
    return [write_file_atomically(folder / f"{name}.yaml", ros_camera_info_yaml(calib, side, name).encode())
            for side, name in zip(("left", "right"), names)]


INSTALLED_NAME = "calibration.yaml"
PREVIOUS_NAME = "calibration.previous.yaml"
SIMULATED_FOLDER = "simulated_desk"  # in the config folder: calibrations made on the simulated desk
SIMULATED_PAIR_ID = "sim"  # the simulated desk's camera pair id (also a replay of it)


def is_simulated_pair(pair_id: str) -> bool:
    """True for the simulated desk's cameras (``SimStereoCamera.pair_id``, and a replay of them)."""
    return str(pair_id) == SIMULATED_PAIR_ID


def installed_calibration_path(simulated: bool = False) -> Path:
    """Where the app looks for the stereo calibration at start (``<config>/calibration.yaml``).

    ``simulated``: where a calibration made on the simulated desk goes instead
    (``<config>/simulated_desk/calibration.yaml``): trying the wizard there must not replace the
    real cameras' calibration, and no session loads that file unless given with ``--calibration``.
    """
    folder = user_dir("config")
    return (folder / SIMULATED_FOLDER if simulated else folder) / INSTALLED_NAME


def install_calibration(calib: StereoCalibration,
                        extra: Optional[Mapping[str, Union[int, float, str]]] = None,
                        simulated: bool = False) -> Path:
    """Make ``calib`` the app's calibration; the one it replaces is kept as calibration.previous.yaml.

    ``simulated``: a calibration of the simulated desk's cameras, written to its own file
    (``installed_calibration_path(simulated=True)``), never to the one real cameras load.
    An OSError (read-only config folder, full disk) names the file and the fix and leaves the
    installed calibration as it was.
    """
    target = installed_calibration_path(simulated)
    if target.is_file():  # a copy, not a move: a failed write below must not leave none installed
        try:
            current = target.read_bytes()
        except OSError as exc:  # unreadable: it cannot be kept, and replacing it may hide why
            raise type(exc)(f"{target}: cannot keep the current calibration: {os_error_reason(exc)} — "
                            f"make it readable for your user or remove it") from None
        write_file_atomically(target.with_name(PREVIOUS_NAME), current)
    return save_calibration(target, calib, extra)
