"""Camera → robot (hand-eye) solves: ``base_T_camera`` from matched points.

Three ways to get matched points, one rigid solve:

- ``sweep``: the arm carries a marker to spread poses; its centre is known in robot_base (FK of
  the measured joints + the marker's offset) and triangulated in camera_left;
- ``touch_points``: the user touches the centres of K ≥ 4 desk markers with the tool tip;
- ``planar``: one camera looking down, pixel → robot X/Y (a homography) plus a Z relation.

The rigid solve is Kabsch/Umeyama without scale, with outlier rejection (the worst pair is
dropped while its residual exceeds max(3 × median, 5 mm)). Pure numpy; no Qt, no simulated desk.
"""
from __future__ import annotations

import datetime as _dt
import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

MIN_POINTS = 4  # a rigid solve needs 3 non-collinear pairs; 4 leaves one to check the others
MAX_RMS_MM = 5.0  # a solve with a larger RMS residual is refused (ok = False)
OUTLIER_FLOOR_MM = 5.0  # residuals below this are never outliers
OUTLIER_FACTOR = 3.0  # … nor those below this × the median residual
MIN_EXTENT_M = 0.03  # smallest principal extent of the points before a warning
METHODS = ("sweep", "touch_points", "planar")


@dataclass(frozen=True)
class ToolMarker:
    """The marker the arm carries for the sweep (or the profile's ``tool_marker`` table)."""

    marker_id: int = 7  # DICT_6X6_250 id, not one of the desk's markers (23, 50)
    offset_m: tuple[float, float, float] = (0.0, 0.0, 0.012)  # marker centre − tool point, robot_base axes
    size_m: float = 0.03  # black square's side

    def __post_init__(self) -> None:
        if not 0 <= int(self.marker_id) < 250:
            raise ValueError(f"tool_marker.marker_id = {self.marker_id} is outside 0…249 (DICT_6X6_250)")
        if len(self.offset_m) != 3 or not all(math.isfinite(float(v)) and abs(float(v)) <= 0.3
                                               for v in self.offset_m):
            raise ValueError(f"tool_marker.offset_m = {self.offset_m!r}: need 3 finite values within ±0.3 m")
        if not 0.01 <= float(self.size_m) <= 0.2:
            raise ValueError(f"tool_marker.size_m = {self.size_m} is outside 0.01…0.2 m")


DEFAULT_TOOL_MARKER = ToolMarker()


def tool_marker_of(profile) -> ToolMarker:
    """The profile's ``tool_marker`` (any object with marker_id, offset_m, size_m), else the default."""
    tm = getattr(profile, "tool_marker", None)
    if tm is None:
        return DEFAULT_TOOL_MARKER
    if isinstance(tm, ToolMarker):
        return tm
    return ToolMarker(int(tm.marker_id), tuple(float(v) for v in tm.offset_m), float(tm.size_m))


@dataclass(frozen=True)
class HandEyeResult:
    """A solved camera → robot transform and how well the points agreed."""

    base_T_camera: np.ndarray = field(repr=False)  # 4x4, pose of camera_left in robot_base
    method: str  # sweep | touch_points | planar
    poses_used: int  # pairs in the final solve
    residuals_mm: tuple[float, ...]  # per input pair (rejected ones included), mm
    rms_mm: float  # over the pairs used
    max_mm: float  # over the pairs used
    worst_index: int  # input index of the largest residual among those used (-1: none)
    rejected: tuple[int, ...] = ()  # input indices dropped as outliers
    warnings: tuple[str, ...] = ()
    camera_pair: str = ""  # the camera pair id the points came from
    created: str = ""  # ISO 8601 date and time
    ok: bool = True
    problem: str = ""  # why not ok, with the fix ("" when ok)
    name: str = "camera→robot"

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"hand-eye method {self.method!r}; valid: {', '.join(METHODS)}")

    def summary(self) -> str:
        """One line for people: "sweep: 12 poses, 0.8 mm RMS (max 1.6 mm)" or the problem."""
        if not self.ok:
            return f"{self.method}: NOT OK — {self.problem}"
        return (f"{self.method}: {self.poses_used} poses, {self.rms_mm:.1f} mm RMS "
                f"(max {self.max_mm:.1f} mm)")


def now_iso() -> str:
    return _dt.datetime.now().astimezone().isoformat(timespec="seconds")


def kabsch(camera_points, base_points) -> np.ndarray:
    """The rigid ``base_T_camera`` (4x4) minimising Σ|R·c + t − b|² (no scale, det R = +1)."""
    C = np.asarray(camera_points, float).reshape(-1, 3)
    B = np.asarray(base_points, float).reshape(-1, 3)
    cc, bc = C.mean(axis=0), B.mean(axis=0)
    H = (C - cc).T @ (B - bc)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = bc - R @ cc
    return T


def residuals_mm(base_T_camera, camera_points, base_points) -> np.ndarray:
    """|base_T_camera · c − b| per pair, in mm."""
    C = np.asarray(camera_points, float).reshape(-1, 3)
    B = np.asarray(base_points, float).reshape(-1, 3)
    mapped = C @ base_T_camera[:3, :3].T + base_T_camera[:3, 3]
    return np.linalg.norm(mapped - B, axis=1) * 1e3


def spread_warning(base_points, min_extent_m: float = MIN_EXTENT_M) -> str:
    """A warning when the points span too little volume ("" otherwise)."""
    B = np.asarray(base_points, float).reshape(-1, 3)
    if len(B) < 2:
        return ""
    centred = B - B.mean(axis=0)
    _, _, Vt = np.linalg.svd(centred, full_matrices=False)
    extents = []
    for axis in Vt:
        proj = centred @ axis
        extents.append(float(proj.max() - proj.min()))
    while len(extents) < 3:
        extents.append(0.0)
    smallest = min(extents)
    if smallest >= min_extent_m:
        return ""
    k = int(np.argmin(extents))
    axis = Vt[k] if k < len(Vt) else np.zeros(3)
    names = "xyz"
    main = names[int(np.argmax(np.abs(axis)))] if np.any(axis) else "one direction"
    return (f"poses span too little volume — their smallest extent (mostly along {main}) is only "
            f"{smallest * 1e3:.0f} mm (want ≥ {min_extent_m * 1e3:.0f} mm); spread the poses")


def _not_finite_rows(*arrays) -> np.ndarray:
    bad = np.zeros(len(arrays[0]), bool)
    for a in arrays:
        bad |= ~np.all(np.isfinite(a), axis=1)
    return bad


def solve_rigid(camera_points, base_points, method: str = "sweep", camera_pair: str = "",
                min_points: int = MIN_POINTS, max_rms_mm: float = MAX_RMS_MM,
                skipped: int = 0, skipped_note: str = "") -> HandEyeResult:
    """``base_T_camera`` from matched points: camera_left (N,3) ↔ robot_base (N,3), metres.

    Kabsch without scale, then while the worst residual exceeds max(3 × median, 5 mm) and more
    than ``min_points`` remain, that pair is dropped and the solve repeated. Never raises on bad
    data: the result says ``ok = False`` and ``problem`` names the cause and the fix.
    """
    C = np.asarray(camera_points, float).reshape(-1, 3)
    B = np.asarray(base_points, float).reshape(-1, 3)
    if len(C) != len(B):
        raise ValueError(f"camera_points has {len(C)} points but base_points has {len(B)}: need pairs")
    n = len(C)
    created = now_iso()
    bad = _not_finite_rows(C, B) if n else np.zeros(0, bool)
    used = [i for i in range(n) if not bad[i]]
    warnings = []
    if skipped:
        warnings.append(skipped_note or f"{skipped} pose(s) skipped")
    if len(used) < min_points:
        why = (f"only {len(used)} usable pose(s), need at least {min_points}" if n or skipped
               else "no poses at all")
        fix = ("the marker was never seen — check that the tool marker (or the desk markers) is in both "
               "camera views and well lit" if len(used) == 0
               else "give more poses (--poses) spread over the part of the desk both cameras see")
        return HandEyeResult(np.eye(4), method, len(used), tuple(float("nan") for _ in range(n)), float("nan"),
                             float("nan"), -1, (), tuple(warnings), camera_pair, created, ok=False,
                             problem=f"{why} — {fix}")
    rejected: list[int] = []
    while True:
        T = kabsch(C[used], B[used])
        r = residuals_mm(T, C[used], B[used])
        k = int(np.argmax(r))
        limit = max(OUTLIER_FACTOR * float(np.median(r)), OUTLIER_FLOOR_MM)
        if r[k] > limit and len(used) > min_points:
            rejected.append(used.pop(k))
            continue
        break
    all_r = residuals_mm(T, np.where(bad[:, None], 0.0, C), np.where(bad[:, None], 0.0, B))
    all_r[bad] = float("nan")
    rms = float(np.sqrt(np.mean(r**2)))
    worst = used[int(np.argmax(r))]
    if rejected:
        warnings.append(f"{len(rejected)} pose(s) rejected as outliers (indices {', '.join(map(str, sorted(rejected)))})")
    spread = spread_warning(B[used])
    if spread:
        warnings.append(spread)
    ok, problem = True, ""
    if not rms <= max_rms_mm:
        ok = False
        problem = (f"residuals too large: {rms:.1f} mm RMS (limit {max_rms_mm:g} mm, worst pose {worst} at "
                   f"{float(np.max(r)):.1f} mm) — the marker moved on the arm or the stereo calibration is off; "
                   "fix the marker firmly, check the stereo calibration (deskarm calibrate) and run again")
    return HandEyeResult(T, method, len(used), tuple(float(v) for v in all_r), rms, float(np.max(r)), worst,
                         tuple(sorted(rejected)), tuple(warnings), camera_pair, created, ok=ok, problem=problem)


def solve_touch_points(camera_points, tool_points, camera_pair: str = "",
                       max_rms_mm: float = MAX_RMS_MM) -> HandEyeResult:
    """Manual method: K ≥ 4 desk markers' triangulated centres (camera_left) and the tool tip's
    FK position (robot_base) while the user touched each centre."""
    return solve_rigid(camera_points, tool_points, method="touch_points", camera_pair=camera_pair,
                       max_rms_mm=max_rms_mm)


# ----------------------------------------------------------------------------------------------
# planar: one camera looking down


@dataclass(frozen=True)
class PlanarMap:
    """Pixel → robot_base for one camera looking down: a homography for X/Y and Z = a·u + b·v + c."""

    H: np.ndarray = field(repr=False)  # 3x3, pixel (u, v, 1) → (X, Y, 1) up to scale
    z_coeffs: tuple[float, float, float]  # Z = a·u + b·v + c (m); a = b = 0: a constant desk height
    residuals_mm: tuple[float, ...]
    rms_mm: float
    max_mm: float
    camera_pair: str = ""
    created: str = ""
    ok: bool = True
    problem: str = ""
    method: str = "planar"

    def apply(self, px) -> tuple[float, float, float]:
        """(x, y, z) in robot_base (m) of pixel (u, v)."""
        u, v = float(px[0]), float(px[1])
        h = self.H @ np.array([u, v, 1.0])
        a, b, c = self.z_coeffs
        return (float(h[0] / h[2]), float(h[1] / h[2]), float(a * u + b * v + c))

    def apply_many(self, pixels) -> np.ndarray:
        P = np.asarray(pixels, float).reshape(-1, 2)
        return np.array([self.apply(p) for p in P]).reshape(-1, 3)

    def save(self, path):
        """Write the map as TOML (whole or not at all); returns the path."""
        import tomli_w

        from core.paths import write_file_atomically

        data = {
            "format": "deskarm-hand-eye-1", "method": "planar", "created": self.created,
            "camera_pair": self.camera_pair, "H": [[float(v) for v in row] for row in np.asarray(self.H)],
            "z_coeffs": [float(v) for v in self.z_coeffs],
            "quality": {"rms_mm": float(self.rms_mm), "max_mm": float(self.max_mm),
                        "residuals_mm": [float(v) for v in self.residuals_mm]},
        }
        return write_file_atomically(path, tomli_w.dumps(data).encode("utf-8"))

    @classmethod
    def load(cls, path) -> "PlanarMap":
        """Read a map ``save`` wrote; ValueError naming the file and the key when it cannot be used."""
        try:
            import tomllib
        except ImportError:  # pragma: no cover - Python 3.10
            import tomli as tomllib
        try:
            data = tomllib.loads(open(path, "rb").read().decode("utf-8"))
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
            raise ValueError(f"{path}: cannot read the planar map: {exc}") from None
        key = "method"
        try:
            if data["method"] != "planar":
                raise ValueError
            key = "H"
            H = np.array(data["H"], float)
            if H.shape != (3, 3) or not np.all(np.isfinite(H)):
                raise ValueError
            key = "z_coeffs"
            z = tuple(float(v) for v in data["z_coeffs"])
            if len(z) != 3:
                raise ValueError
            key = "quality"
            q = data["quality"]
            return cls(H, z, tuple(float(v) for v in q["residuals_mm"]), float(q["rms_mm"]), float(q["max_mm"]),
                       str(data.get("camera_pair", "")), str(data.get("created", "")))
        except (KeyError, TypeError, ValueError):
            raise ValueError(f"{path}: key {key!r} is missing or invalid in this planar map — solve it again") from None


def _homography_dlt(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """Least-squares homography src → dst (normalised DLT)."""
    def normaliser(p):
        c = p.mean(axis=0)
        s = math.sqrt(2) / max(float(np.mean(np.linalg.norm(p - c, axis=1))), 1e-12)
        return np.array([[s, 0, -s * c[0]], [0, s, -s * c[1]], [0, 0, 1.0]])

    Ts, Td = normaliser(src), normaliser(dst)
    s = (np.column_stack([src, np.ones(len(src))]) @ Ts.T)[:, :2]
    d = (np.column_stack([dst, np.ones(len(dst))]) @ Td.T)[:, :2]
    rows = []
    for (x, y), (X, Y) in zip(s, d):
        rows.append([-x, -y, -1, 0, 0, 0, X * x, X * y, X])
        rows.append([0, 0, 0, -x, -y, -1, Y * x, Y * y, Y])
    _, _, Vt = np.linalg.svd(np.asarray(rows))
    Hn = Vt[-1].reshape(3, 3)
    H = np.linalg.inv(Td) @ Hn @ Ts
    return H / H[2, 2]


def solve_planar(pixels, base_xy, base_z, camera_pair: str = "", max_rms_mm: float = MAX_RMS_MM,
                 constant_z: Optional[bool] = None) -> PlanarMap:
    """Manual method for one camera looking down: pixels (N,2) of points at robot_base (N,2) X/Y
    and heights (N,) Z. X/Y by a least-squares homography; Z linear in the pixel (or constant
    when the heights are all equal, or ``constant_z``). Needs N ≥ 4; not ok above ``max_rms_mm``."""
    P = np.asarray(pixels, float).reshape(-1, 2)
    XY = np.asarray(base_xy, float).reshape(-1, 2)
    Z = np.asarray(base_z, float).reshape(-1)
    if not (len(P) == len(XY) == len(Z)):
        raise ValueError(f"pixels ({len(P)}), base_xy ({len(XY)}) and base_z ({len(Z)}) must have equal lengths")
    ok_rows = np.all(np.isfinite(P), axis=1) & np.all(np.isfinite(XY), axis=1) & np.isfinite(Z)
    P, XY, Z = P[ok_rows], XY[ok_rows], Z[ok_rows]
    created = now_iso()
    if len(P) < MIN_POINTS:
        return PlanarMap(np.eye(3), (0.0, 0.0, 0.0), (), float("nan"), float("nan"), camera_pair, created, ok=False,
                         problem=f"only {len(P)} usable point(s), need at least {MIN_POINTS} — touch more points "
                                 "spread over the camera's view")
    H = _homography_dlt(P, XY)
    if constant_z is None:
        constant_z = float(np.ptp(Z)) < 1e-4
    if constant_z:
        zc = (0.0, 0.0, float(np.mean(Z)))
    else:
        A = np.column_stack([P, np.ones(len(P))])
        coef, *_ = np.linalg.lstsq(A, Z, rcond=None)
        zc = tuple(float(v) for v in coef)
    m = PlanarMap(H, zc, (), 0.0, 0.0, camera_pair, created)
    pred = m.apply_many(P)
    r = np.linalg.norm(pred - np.column_stack([XY, Z]), axis=1) * 1e3
    rms = float(np.sqrt(np.mean(r**2)))
    ok, problem = True, ""
    if not rms <= max_rms_mm:
        ok, problem = False, (f"residuals too large: {rms:.1f} mm RMS (limit {max_rms_mm:g} mm) — points off the "
                              "desk plane or mismatched; touch the points again")
    return PlanarMap(H, zc, tuple(float(v) for v in r), rms, float(np.max(r)), camera_pair, created, ok, problem)


def pose_error(estimate, truth) -> tuple[float, float]:
    """(translation error mm, rotation error deg) between two 4x4 poses."""
    E, T = np.asarray(estimate, float), np.asarray(truth, float)
    t_mm = float(np.linalg.norm(E[:3, 3] - T[:3, 3])) * 1e3
    R = E[:3, :3].T @ T[:3, :3]
    # atan2 of the skew part and the trace stays exact near 0° (acos does not)
    skew = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    angle = math.degrees(math.atan2(float(np.linalg.norm(skew)) / 2.0, (float(np.trace(R)) - 1.0) / 2.0))
    return t_mm, angle
