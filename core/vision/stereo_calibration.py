"""Stereo calibration from pictures of a board: board specs, robust detection, calibration with
outlier rejection and per-pair errors, and the capture gating / coverage of the wizard.

The flow, for the command line and the GUI wizard alike::

    board = parse_board("chessboard:9x6", square_m=0.025)
    session = CalibrationSession(board, folder=...)     # the wizard's state, Qt-free
    det = session.detect(left, right, fast=True)         # live overlay (draw_detection)
    gate = session.gate(det, skew_s, previous=last_det)  # may this pair be captured?
    session.add(left, right)                             # full detection, saved in the folder
    report = session.calibrate(progress)                 # CalibrationReport
    session.remove(report.worst(2)); session.calibrate() # drop the worst pairs, again

Detection is built for cheap webcams: tiny images are upscaled first, the classic detector runs
with adaptive threshold + normalisation + fast check, then on a contrast-equalised copy, then
``findChessboardCornersSB`` as a last resort; a failure says why (too dark, blurred, board partly
out of view). ChArUco boards may be partly out of view: corners are matched by id between views.
"""
from __future__ import annotations

import functools
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, ClassVar, Iterable, Optional, Sequence, Union

import cv2
import numpy as np

from core.vision.calibration import CalibrationError, StereoCalibration

# ----------------------------------------------------------------------------------------------
# boards


class BoardError(ValueError):
    """A board description is malformed or out of range; the message shows the valid form."""


BOARD_FORMS = ("chessboard:COLSxROWS (inner corners, e.g. chessboard:9x6) | "
               "charuco:COLSxROWS:MARKER_METRES:DICT[:legacy] (squares, e.g. charuco:5x7:0.022:DICT_4X4_50)")

ARUCO_DICTIONARY_NAMES = tuple(sorted(n for n in dir(cv2.aruco) if n.startswith("DICT_")))


@dataclass(frozen=True)
class ChessboardSpec:
    """A printed chessboard, counted by its inner corners (OpenCV's patternSize)."""

    cols: int  # inner corners along a row (board x), 3 … 40
    rows: int  # inner corners along a column (board y), 3 … 40 (= cols: a square pattern, settled in pairs)
    square_m: float  # side of one square (m), 0.002 … 0.5

    kind: ClassVar[str] = "chessboard"

    def __post_init__(self) -> None:
        for name in ("cols", "rows"):
            v = getattr(self, name)
            if not (isinstance(v, (int, np.integer)) and 3 <= v <= 40):
                raise BoardError(f"chessboard {name} = {v!r}: need 3 … 40 inner corners")
        if not (0.002 <= self.square_m <= 0.5):
            raise BoardError(f"square size {self.square_m!r} m is outside 0.002 … 0.5 m (give metres: 25 mm = 0.025)")

    @property
    def n_corners(self) -> int:
        return self.cols * self.rows

    @property
    def grid(self) -> tuple[int, int]:
        """(columns, rows) of the inner-corner grid."""
        return self.cols, self.rows

    @property
    def colour_oriented(self) -> bool:
        """The squares' colours settle a half turn: the outer corner squares at the first and the
        last inner corner differ in colour (cols + rows odd, e.g. 9x6), and the board is not square."""
        return self.cols != self.rows and (self.cols + self.rows) % 2 == 1

    def object_points(self) -> np.ndarray:
        """Board-frame corners (N,3) float32 in detection order: x fastest, origin at corner 0."""
        return _grid_points(self.cols, self.rows, self.square_m, origin=0.0)

    def text(self) -> str:
        """The command-line form (without the square size)."""
        return f"chessboard:{self.cols}x{self.rows}"

    def describe(self) -> str:
        return f"chessboard {self.cols}x{self.rows} inner corners, {self.square_m * 1e3:g} mm squares"


@dataclass(frozen=True)
class CharucoSpec:
    """A ChArUco board (OpenCV 5 CharucoBoard), counted by its squares; may be seen in part."""

    squares_x: int  # squares along x, 3 … 40
    squares_y: int  # squares along y, 3 … 40
    square_m: float  # side of one square (m), 0.002 … 0.5
    marker_m: float  # side of one ArUco marker (m), smaller than square_m
    dictionary: str = "DICT_4X4_50"  # one of cv2.aruco's DICT_* names, or a dictionary file's path
    legacy: bool = False  # the layout of OpenCV < 4.6 (boards printed by older tools, even squares_y)

    kind: ClassVar[str] = "charuco"

    def __post_init__(self) -> None:
        for name in ("squares_x", "squares_y"):
            v = getattr(self, name)
            if not (isinstance(v, (int, np.integer)) and 3 <= v <= 40):
                raise BoardError(f"charuco {name} = {v!r}: need 3 … 40 squares")
        if not (0.002 <= self.square_m <= 0.5):
            raise BoardError(f"square size {self.square_m!r} m is outside 0.002 … 0.5 m (give metres: 30 mm = 0.03)")
        if not (0.2 * self.square_m <= self.marker_m < self.square_m):
            raise BoardError(
                f"charuco marker size {self.marker_m!r} m must be smaller than the square "
                f"({self.square_m:g} m) and at least a fifth of it"
            )
        from core.vision.perception import is_dictionary_file

        if self.dictionary not in ARUCO_DICTIONARY_NAMES and not is_dictionary_file(self.dictionary):
            raise BoardError(f"unknown ArUco dictionary {self.dictionary!r}; valid: {', '.join(ARUCO_DICTIONARY_NAMES)} "
                             f"or a dictionary file (cv2.aruco writeDictionary's YAML)")
        markers = self.squares_x * self.squares_y // 2
        try:
            size = _dictionary(self.dictionary).bytesList.shape[0]
        except ValueError as exc:  # a dictionary file that cannot be read: its own one-line message
            raise BoardError(str(exc)) from None
        if markers > size:
            raise BoardError(
                f"charuco {self.squares_x}x{self.squares_y} needs {markers} markers but {self.dictionary} "
                f"has only {size} — use a larger dictionary"
            )

    @property
    def n_corners(self) -> int:
        return (self.squares_x - 1) * (self.squares_y - 1)

    @property
    def grid(self) -> tuple[int, int]:
        """(columns, rows) of the inner-corner grid (corner id = row · columns + column)."""
        return self.squares_x - 1, self.squares_y - 1

    def cv_board(self) -> "cv2.aruco.CharucoBoard":
        return _charuco_board(self.squares_x, self.squares_y, self.square_m, self.marker_m,
                              self.dictionary, self.legacy)

    def object_points(self) -> np.ndarray:
        """Board-frame corners (N,3) float32 indexed by ChArUco corner id (origin: board's corner)."""
        return np.asarray(self.cv_board().getChessboardCorners(), np.float32).reshape(-1, 3)

    def text(self) -> str:
        return (f"charuco:{self.squares_x}x{self.squares_y}:{self.marker_m:g}:{self.dictionary}"
                + (":legacy" if self.legacy else ""))

    def describe(self) -> str:
        return (f"ChArUco {self.squares_x}x{self.squares_y} squares of {self.square_m * 1e3:g} mm, "
                f"{self.marker_m * 1e3:g} mm {self.dictionary} markers" + (" (legacy layout)" if self.legacy else ""))


BoardSpec = Union[ChessboardSpec, CharucoSpec]


def _grid_points(cols: int, rows: int, square: float, origin: float) -> np.ndarray:
    xs, ys = np.meshgrid(np.arange(cols), np.arange(rows))
    pts = np.zeros((cols * rows, 3), np.float32)
    pts[:, 0] = (xs.ravel() + origin) * square
    pts[:, 1] = (ys.ravel() + origin) * square
    return pts


@functools.lru_cache(maxsize=32)
def _dictionary(name: str):
    """A predefined dictionary (DICT_* name) or a dictionary file's (cv2.aruco writeDictionary)."""
    from core.vision.perception import aruco_dictionary

    return aruco_dictionary(name)


@functools.lru_cache(maxsize=16)
def _charuco_board(sx, sy, square, marker, dictionary, legacy):
    board = cv2.aruco.CharucoBoard((sx, sy), float(square), float(marker), _dictionary(dictionary))
    if legacy:
        board.setLegacyPattern(True)
    return board


def _parse_grid(text: str, what: str) -> tuple[int, int]:
    try:
        a, b = text.lower().split("x")
        return int(a), int(b)
    except ValueError:
        raise BoardError(f"{what} {text!r} is not COLSxROWS, e.g. 9x6; valid boards: {BOARD_FORMS}") from None


def parse_board(text: str, square_m: float) -> BoardSpec:
    """A board from its command-line form and the square size in metres (BoardError if malformed)."""
    parts = (text or "").strip().split(":")
    kind = parts[0].lower()
    if kind == "chessboard" and len(parts) == 2:
        cols, rows = _parse_grid(parts[1], "chessboard size")
        return ChessboardSpec(cols, rows, float(square_m))
    if kind == "charuco" and len(parts) in (4, 5):
        sx, sy = _parse_grid(parts[1], "charuco size")
        try:
            marker = float(parts[2])
        except ValueError:
            raise BoardError(f"charuco marker size {parts[2]!r} is not a number of metres, e.g. 0.022") from None
        legacy = len(parts) == 5
        if legacy and parts[4].lower() != "legacy":
            raise BoardError(f"unknown charuco option {parts[4]!r}; valid: legacy")
        return CharucoSpec(sx, sy, float(square_m), marker, parts[3].upper(), legacy)
    raise BoardError(f"unknown board {text!r}; valid: {BOARD_FORMS}")


# ----------------------------------------------------------------------------------------------
# detection


@dataclass(frozen=True)
class DetectOptions:
    """How hard to look for the board."""

    fast: bool = False  # live preview: classic detector on a ≤ 640 px copy, no fallback, no sub-pixel
    min_detect_width: int = 640  # smaller images are upscaled to at least this width first (px)
    use_sb: bool = True  # fall back to findChessboardCornersSB (slow, ~50 ms, but robust)
    diagnose: bool = True  # on failure, look for a partly visible board to say so (~40 ms)
    min_charuco_corners: int = 8  # fewer common ChArUco corners is not a usable view


@dataclass(frozen=True, eq=False)
class BoardDetection:
    """The board as found in one image."""

    ok: bool
    corners: Optional[np.ndarray] = None  # (N,2) float32 px in the original image
    ids: Optional[np.ndarray] = None  # (N,) int32 corner ids (row · cols + col of the inner grid)
    reason: str = ""  # why not ok, for the user
    method: str = ""  # classic | classic+clahe | sb | charuco
    image_size: tuple[int, int] = (0, 0)  # (width, height) px
    square_px: float = 0.0  # median distance between neighbouring corners (px)
    grid_seen: Optional[tuple[int, int]] = None  # when not ok: (cols, rows) of a whole, smaller chessboard in view

    @property
    def n(self) -> int:
        return 0 if self.corners is None else len(self.corners)


@dataclass(frozen=True, eq=False)
class PairDetection:
    """The board in both views, with the corners both views share."""

    left: BoardDetection
    right: BoardDetection
    object_points: Optional[np.ndarray] = None  # (M,3) float32, board frame (m)
    left_points: Optional[np.ndarray] = None  # (M,2) float32 px
    right_points: Optional[np.ndarray] = None  # (M,2) float32 px
    ids: Optional[np.ndarray] = None  # (M,) corner ids
    reasons: tuple[str, ...] = ()  # why the pair is not usable

    @property
    def ok(self) -> bool:
        return self.object_points is not None and not self.reasons

    @property
    def reason(self) -> str:
        return "; ".join(self.reasons)

    @property
    def image_size(self) -> tuple[int, int]:
        return self.left.image_size


_CLASSIC_FLAGS = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_FAST_CHECK
_SB_FLAGS = cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY
_SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 40, 0.001)


def _grey(image: np.ndarray) -> np.ndarray:
    if image is None or not hasattr(image, "ndim"):
        raise ValueError("not an image")
    if image.ndim == 3:
        return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY if image.shape[2] == 3 else cv2.COLOR_BGRA2GRAY)
    return image


def _square_px(corners: np.ndarray, cols: int) -> float:
    """Side of a square in the image (px): the smaller of the median corner spacings along the
    grid's rows and columns, so an oblique board gets a window that fits its narrow squares."""
    c = corners.reshape(-1, cols, 2)
    along = np.linalg.norm(np.diff(c, axis=1), axis=2)
    across = np.linalg.norm(np.diff(c, axis=0), axis=2)
    meds = [float(np.median(d)) for d in (along, across) if d.size]
    return min(meds) if meds else 0.0


def _subpix_window(square_px: float) -> int:
    """cornerSubPix half-window: the full window stays inside one square."""
    return int(max(2, min(11, math.floor(0.4 * square_px))))


def _image_hints(grey: np.ndarray) -> list[str]:
    """Exposure and focus problems that stop any detector."""
    hints = []
    mean = float(grey.mean())
    if mean < 35:
        hints.append(f"image too dark (mean level {mean:.0f}/255)")
    elif float((grey >= 250).mean()) > 0.25:
        hints.append("image overexposed (a quarter of it is saturated)")
    elif float(cv2.Laplacian(grey, cv2.CV_32F).var()) < 15:
        hints.append("image blurred")
    return hints


@dataclass(frozen=True)
class _Probe:
    """What a search for any chessboard grid found."""

    n: int  # corners
    at_edge: bool  # the grid touches the image border (board partly out of view)
    grid: Optional[tuple[int, int]]  # (columns, rows) when the corners form a clean grid
    corners: Optional[np.ndarray] = None  # (n,2) px in the searched image, row by row


def _grid_shape(c: np.ndarray) -> Optional[tuple[int, int]]:
    """(columns, rows) of corners listed row by row, from the jumps between rows."""
    d = np.linalg.norm(np.diff(c, axis=0), axis=1)
    if len(d) < 3:
        return None
    breaks = np.flatnonzero(d > 1.8 * np.median(d))
    if len(breaks) == 0:
        return None
    cols = int(breaks[0]) + 1
    if cols < 2 or len(c) % cols or not np.array_equal(breaks, np.arange(cols - 1, len(c) - 1, cols)):
        return None
    return cols, len(c) // cols


def _probe_partial(work: np.ndarray) -> Optional[_Probe]:
    """Look for any chessboard grid (≥ 3x3 corners), or None when there is none.
    ~40 ms at 640x480: only after the normal detection failed."""
    ok, c = cv2.findChessboardCornersSB(work, (3, 3), flags=cv2.CALIB_CB_LARGER | cv2.CALIB_CB_NORMALIZE_IMAGE)
    if not ok or c is None:
        return None
    c = c.reshape(-1, 2)
    h, w = work.shape[:2]
    d = np.sort(np.linalg.norm(c[:, None] - c[None], axis=2), axis=1)[:, 1]
    edge = 1.5 * float(np.median(d))  # about one square from the image border
    at_edge = bool(c[:, 0].min() < edge or c[:, 1].min() < edge or c[:, 0].max() > w - 1 - edge
                   or c[:, 1].max() > h - 1 - edge)
    return _Probe(len(c), at_edge, _grid_shape(c), c)


def _checked_grid(work: np.ndarray, probe: _Probe) -> Optional[tuple[int, int]]:
    """The probe's grid without outer rows / columns that are not chessboard-like (a tray or frame
    edge taken for a row of corners)."""
    cols, rows = probe.grid
    bad = _foreign_lines(work, probe.corners, cols, rows)
    cols -= bad["first col"] + bad["last col"]
    rows -= bad["first row"] + bad["last row"]
    return (cols, rows) if cols >= 3 and rows >= 3 else None


def _box_mean(grey: np.ndarray, p: np.ndarray, r: int) -> float:
    x, y = int(round(float(p[0]))), int(round(float(p[1])))
    h, w = grey.shape[:2]
    if not (r <= x < w - r and r <= y < h - r):
        return math.nan
    return float(grey[y - r:y + r + 1, x - r:x + r + 1].mean())


def _saddle_misfit(grey: np.ndarray, c: np.ndarray, cols: int, rows: int) -> np.ndarray:
    """Per corner (rows, cols): how unlike a chessboard corner it is. The four squares around a
    true corner alternate (the two on each diagonal alike, the diagonals unlike): the ratio of the
    larger within-diagonal difference to the between-diagonal contrast, ~0.05 on real webcam
    photos and ~1 where an edge of the board's tray or frame was taken for a row of corners
    (NaN where a square falls outside the image)."""
    g = c.reshape(rows, cols, 2).astype(np.float64)
    out = np.full((rows, cols), math.nan)
    for i in range(rows):
        for j in range(cols):
            p = g[i, j]
            u = g[i, j + 1] - p if j + 1 < cols else p - g[i, j - 1]
            v = g[i + 1, j] - p if i + 1 < rows else p - g[i - 1, j]
            r = max(1, int(0.15 * min(np.linalg.norm(u), np.linalg.norm(v))))
            a, b, cc, d = (_box_mean(grey, p + 0.4 * (s1 * u + s2 * v), r)
                           for s1, s2 in ((1, 1), (1, -1), (-1, -1), (-1, 1)))
            contrast = abs((a + cc) - (b + d)) / 2
            out[i, j] = max(abs(a - cc), abs(b - d)) / max(contrast, 1e-6)
    return out


FOREIGN_LINE_MISFIT = 0.5  # an outer row / column whose corners' median misfit exceeds this is no chessboard row
INNER_MISFIT = 0.25  # … when the rest of the grid is clearly a chessboard (median below this)


def _foreign_lines(grey: np.ndarray, c: np.ndarray, cols: int, rows: int) -> dict[str, int]:
    """Which outer rows / columns of a found grid are not chessboard-like (1 = foreign)."""
    m = _saddle_misfit(grey, c, cols, rows)
    lines = {"first row": m[0], "last row": m[-1], "first col": m[:, 0], "last col": m[:, -1]}
    inner = m[1:-1, 1:-1] if rows > 2 and cols > 2 else m
    inner_med = float(np.nanmedian(inner)) if np.isfinite(inner).any() else math.nan
    out = {k: 0 for k in lines}
    if not inner_med < INNER_MISFIT:
        return out
    for k, line in lines.items():
        if np.isfinite(line).sum() >= 2 and float(np.nanmedian(line)) > FOREIGN_LINE_MISFIT:
            out[k] = 1
    return out


def _miscounted(probe: Optional[_Probe], board: ChessboardSpec) -> Optional[tuple[int, int]]:
    """The grid found when it is the given one off by one in both directions (squares counted
    instead of inner corners, or the reverse), else None."""
    if probe is None or probe.grid is None or probe.at_edge:
        return None
    a, b = sorted(probe.grid)
    for d in (-1, 1):
        if (a, b) == tuple(sorted((board.cols + d, board.rows + d))):
            cols, rows = board.cols + d, board.rows + d
            return cols, rows
    return None


def _smaller_whole_grid(probe: Optional[_Probe], board: ChessboardSpec) -> Optional[tuple[int, int]]:
    """The grid found when it is a clean, whole grid (not cut by the image border) that is smaller
    than the given board, in the board's orientation (cols >= rows as given), else None: the board
    in view is likely that size, not the one described."""
    if probe is None or probe.grid is None or probe.at_edge:
        return None
    a, b = sorted(probe.grid)
    lo, hi = sorted((board.cols, board.rows))
    if a < 3 or not (a <= lo and b <= hi) or (a, b) == (lo, hi):
        return None
    return (b, a) if board.cols >= board.rows else (a, b)


def _not_found(grey: np.ndarray, board: BoardSpec, probe: Optional[_Probe] = None) -> str:
    """Why the board was not found, as specific as we can tell."""
    if isinstance(board, ChessboardSpec):
        wrong = _miscounted(probe, board)
        if wrong is not None:
            return (f"board not found: the board in view has {wrong[0]}x{wrong[1]} inner corners, not "
                    f"{board.cols}x{board.rows} — count the inner corners (where four squares meet)")
        smaller = _smaller_whole_grid(probe, board)
        if smaller is not None:
            return (f"board not found: the chessboard in view has {smaller[0]}x{smaller[1]} inner corners, not "
                    f"{board.cols}x{board.rows} (the whole grid is in view, nothing cut off) — if that is your "
                    f"board, use --board chessboard:{smaller[0]}x{smaller[1]}")
    if probe is not None and probe.n < board.n_corners:
        if probe.at_edge:
            return (f"board not found: only {probe.n} of {board.n_corners} inner corners in view "
                    f"— board partly out of the image")
        return (f"board not found: only {probe.n} of {board.n_corners} inner corners recognised "
                f"— board too small, blurred, covered or unevenly lit; bring it closer")
    hints = _image_hints(grey)
    return "board not found" + (f": {', '.join(hints)}" if hints else
                                " (not in view, partly out of view, too small or too oblique)")


def _detect_chessboard(grey: np.ndarray, board: ChessboardSpec, options: DetectOptions) -> BoardDetection:
    h, w = grey.shape[:2]
    pattern = (board.cols, board.rows)
    if options.fast:
        scale = min(1.0, 640.0 / w)
        work = grey if scale == 1.0 else cv2.resize(grey, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        ok, c = cv2.findChessboardCorners(work, pattern, flags=_CLASSIC_FLAGS)
        if not ok:
            return BoardDetection(False, reason="board not found", image_size=(w, h), method="classic")
        c = (c.reshape(-1, 2) + 0.5) / scale - 0.5
        return _chessboard_result(c.astype(np.float32), board, (w, h), "classic", grey)
    # small images are upscaled (the detector needs a few px of white around each black square);
    # images up to 800 px get a second, larger scale for far boards
    up = 1 if w >= options.min_detect_width else min(4, math.ceil(options.min_detect_width / w))
    scales = [up] + ([up + 1] if w * up <= 1280 and w <= 800 else [])
    works: dict[int, np.ndarray] = {}

    def at(scale: int) -> np.ndarray:
        if scale not in works:
            works[scale] = grey if scale == 1 else cv2.resize(grey, None, fx=scale, fy=scale,
                                                              interpolation=cv2.INTER_CUBIC)
        return works[scale]

    def classic(scale: int) -> tuple[bool, Optional[np.ndarray], str]:
        for clahe in (False, True):
            img = at(scale)
            if clahe:  # uneven light: equalise locally
                img = cv2.createCLAHE(clipLimit=3.0, tileGridSize=(8, 8)).apply(img)
            found, corners = cv2.findChessboardCorners(img, pattern, flags=_CLASSIC_FLAGS)
            if found:
                return True, corners, "classic+clahe" if clahe else "classic"
        return False, None, "classic"

    ok, c, method = classic(scales[0])
    refine, probe = True, None
    if not ok:
        # a board cut by the image border will not be found at any scale: say so and stop early
        probe = _probe_partial(at(scales[0])) if options.diagnose else None
        if probe is not None and ((probe.n < board.n_corners and probe.at_edge) or _miscounted(probe, board)):
            return BoardDetection(False, reason=_not_found(grey, board, probe), image_size=(w, h), method=method)
        if probe is not None and probe.grid is not None:
            probe = _Probe(probe.n, probe.at_edge, _checked_grid(at(scales[0]), probe), probe.corners)
        for scale in scales[1:]:
            ok, c, method = classic(scale)
            if ok:
                up = scale
                break
    if not ok and options.use_sb:
        up = scales[-1] if w < options.min_detect_width else scales[0]
        ok, c = cv2.findChessboardCornersSB(at(up), pattern, flags=_SB_FLAGS)
        method, refine = "sb", False  # SB with ACCURACY is already sub-pixel
    if not ok or c is None:
        return BoardDetection(False, reason=_not_found(grey, board, probe), image_size=(w, h), method=method,
                              grid_seen=_smaller_whole_grid(probe, board))
    work = at(up)
    c = c.reshape(-1, 1, 2).astype(np.float32)
    if refine:
        win = _subpix_window(_square_px(c, board.cols))
        cv2.cornerSubPix(work, c, (win, win), (-1, -1), _SUBPIX_CRITERIA)
    c = c.reshape(-1, 2)
    if up != 1:
        c = (c + 0.5) / up - 0.5  # pixel centres: upscaled u' = up·(u + 0.5) − 0.5
    return _chessboard_result(c.astype(np.float32), board, (w, h), method, grey)


def grid_symmetries(cols: int, rows: int) -> list[tuple[str, np.ndarray]]:
    """The re-orderings of a cols x rows corner grid that leave its shape unchanged, as index
    arrays (``new = corners[perm]``): identity, half turn and the two mirrors, plus the quarter
    turns and diagonal mirrors when the grid is square. On the board plane each is a rigid motion,
    so every one of them is a valid view of the board: only a second view can tell them apart."""
    r, c = np.divmod(np.arange(cols * rows), cols)
    out = [("identity", r * cols + c), ("half turn", (rows - 1 - r) * cols + (cols - 1 - c)),
           ("mirror columns", r * cols + (cols - 1 - c)), ("mirror rows", (rows - 1 - r) * cols + c)]
    if cols == rows:
        n = cols
        out += [("quarter turn", (n - 1 - c) * n + r), ("three quarter turn", c * n + (n - 1 - r)),
                ("transpose", c * n + r), ("anti-transpose", (n - 1 - c) * n + (n - 1 - r))]
    return [(name, np.asarray(perm, np.int64)) for name, perm in out]


def _outer_square_level(grey: np.ndarray, c: np.ndarray, cols: int, corner: int) -> Optional[float]:
    """Mean grey level of the outer board square at the grid's first (0) or last (-1) corner."""
    if corner == 0:
        p, q = c[0], c[cols + 1]
    else:
        p, q = c[-1], c[-cols - 2]
    centre = p + 0.5 * (p - q)  # half a diagonal beyond the corner, away from the grid
    r = max(1, int(0.15 * np.linalg.norm(p - q)))
    x, y = int(round(centre[0])), int(round(centre[1]))
    h, w = grey.shape[:2]
    if not (r <= x < w - r and r <= y < h - r):
        return None
    return float(grey[y - r:y + r + 1, x - r:x + r + 1].mean())


def _canonical_order(c: np.ndarray, board: ChessboardSpec, grey: Optional[np.ndarray]) -> np.ndarray:
    """One view's corners in a canonical order that keeps what the board itself says.

    - colours settle the half turn (``colour_oriented`` boards, e.g. 9x6): corner 0 is the one at
      the dark outer corner square, whatever the camera's roll — an upside-down camera keeps it;
    - a square board (n x n): as ROS camera_calibration, the last corner lies right of and below
      the first (a quarter-turn between the two views of a pair is settled by the calibration);
    - otherwise (e.g. 7x5, whose colours repeat after a half turn): corner 0 nearer the image's
      top-left; the calibration settles a half turn between the views.
    """
    if board.cols == board.rows:
        n = board.cols
        turns = [np.rot90(c.reshape(n, n, 2), k) for k in range(4)]
        g = max(turns, key=lambda t: float((t[-1, -1] - t[0, 0]).sum()))
        return np.ascontiguousarray(g.reshape(-1, 2), dtype=c.dtype)
    if board.colour_oriented and grey is not None:
        first = _outer_square_level(grey, c, board.cols, 0)
        last = _outer_square_level(grey, c, board.cols, -1)
        if first is not None and last is not None and abs(first - last) > 20:
            return c if first < last else c[::-1].copy()
    return c[::-1].copy() if c[0].sum() > c[-1].sum() else c


def _chessboard_result(c: np.ndarray, board: ChessboardSpec, size, method,
                       grey: Optional[np.ndarray] = None) -> BoardDetection:
    if grey is not None:
        bad = _foreign_lines(grey, c, board.cols, board.rows)
        if any(bad.values()):
            # e.g. a 7x5 board in a tray described as 8x5: the tray's edge makes the extra column
            cols = board.cols - bad["first col"] - bad["last col"]
            rows = board.rows - bad["first row"] - bad["last row"]
            which = " and ".join(("a row" if "row" in k else "a column") for k, v in bad.items() if v)
            seen = (cols, rows) if cols >= 3 and rows >= 3 else None
            hint = (f"the chessboard in view has {cols}x{rows} inner corners, not {board.cols}x{board.rows} — "
                    f"if that is your board, use --board chessboard:{cols}x{rows}") if seen else \
                "check --board (count the inner corners, where four squares meet)"
            return BoardDetection(False, reason=f"board not found: {which} of the {board.cols}x{board.rows} corners "
                                  f"found lies off the chessboard (an edge of the board, its tray or frame) — {hint}",
                                  image_size=size, method=method, grid_seen=seen)
    c = _canonical_order(c, board, grey)
    return BoardDetection(True, c, np.arange(len(c), dtype=np.int32), method=method, image_size=size,
                          square_px=_square_px(c, board.cols))


@functools.lru_cache(maxsize=8)
def _charuco_detector(board: CharucoSpec):
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_NONE  # ChArUco refines the chessboard corners
    cparams = cv2.aruco.CharucoParameters()
    cparams.tryRefineMarkers = True
    return cv2.aruco.CharucoDetector(board.cv_board(), cparams, params, cv2.aruco.RefineParameters())


def _detect_charuco(grey: np.ndarray, board: CharucoSpec, options: DetectOptions) -> BoardDetection:
    h, w = grey.shape[:2]
    up = 1
    if not options.fast and w < options.min_detect_width:
        up = min(4, math.ceil(options.min_detect_width / w))
    work = grey if up == 1 else cv2.resize(grey, None, fx=up, fy=up, interpolation=cv2.INTER_CUBIC)
    detector = _charuco_detector(board)
    cc, ci, mc, mi = detector.detectBoard(work)
    n_markers = 0 if mi is None else len(mi)
    if cc is None or ci is None or len(ci) < 4:
        if n_markers == 0:
            reason = _not_found(grey, board)
        else:
            reason = f"board not found: {n_markers} markers but too few corners between them"
        return BoardDetection(False, reason=reason, image_size=(w, h), method="charuco")
    c = cc.reshape(-1, 2).astype(np.float32)
    ids = ci.reshape(-1).astype(np.int32)
    order = np.argsort(ids)
    c, ids = c[order], ids[order]
    if not options.fast:
        # refine in a window that stays inside the white gap between a corner and the markers
        # (measured on rendered boards: p95 corner error 0.30 px -> 0.13 px)
        gap_px = _charuco_square_px(c, ids, board) * (board.square_m - board.marker_m) / (2 * board.square_m)
        win = max(2, min(5, int(0.7 * gap_px)))
        c = c.reshape(-1, 1, 2)
        cv2.cornerSubPix(work, c, (win, win), (-1, -1), _SUBPIX_CRITERIA)
        c = c.reshape(-1, 2)
    if up != 1:
        c = (c + 0.5) / up - 0.5
    return BoardDetection(True, c, ids, method="charuco", image_size=(w, h), square_px=_charuco_square_px(c, ids, board))


def _charuco_square_px(c: np.ndarray, ids: np.ndarray, board: CharucoSpec) -> float:
    cols = board.grid[0]
    pos = {int(i): k for k, i in enumerate(ids)}
    along = [np.linalg.norm(c[pos[i + 1]] - c[k]) for k, i in enumerate(ids)
             if (i + 1) in pos and (i + 1) % cols != 0]
    across = [np.linalg.norm(c[pos[i + cols]] - c[k]) for k, i in enumerate(ids) if (i + cols) in pos]
    meds = [float(np.median(d)) for d in (along, across) if d]
    return min(meds) if meds else 0.0


def detect_board(image: np.ndarray, board: BoardSpec, options: DetectOptions = DetectOptions()) -> BoardDetection:
    """Find ``board`` in one image (BGR or grey); never raises on a missing board."""
    grey = _grey(image)
    if isinstance(board, ChessboardSpec):
        return _detect_chessboard(grey, board, options)
    return _detect_charuco(grey, board, options)


def match_views(left: BoardDetection, right: BoardDetection, board: BoardSpec,
                options: DetectOptions = DetectOptions()) -> PairDetection:
    """Pair two detections: common corner ids, consistent chessboard order, reasons if unusable."""
    reasons = []
    if not left.ok:
        reasons.append(f"left: {left.reason}")
    if not right.ok:
        reasons.append(f"right: {right.reason}")
    if left.image_size != right.image_size and left.image_size != (0, 0) and right.image_size != (0, 0):
        reasons.append(f"left is {left.image_size[0]}x{left.image_size[1]} but right is "
                       f"{right.image_size[0]}x{right.image_size[1]}")
    if reasons:
        return PairDetection(left, right, reasons=tuple(reasons))
    obj = board.object_points()
    if isinstance(board, ChessboardSpec):
        lc, rc = left.corners, right.corners
        if not board.colour_oriented:
            # the pattern cannot tell a half (or, square, a quarter) turn: start from the turn that
            # puts the outer corners of both views nearest each other; calibrate_stereo settles it
            # over all pairs (an upside-down camera is not "nearest")
            ends = np.array([0, board.cols - 1, board.n_corners - 1, board.n_corners - board.cols])
            turns = [perm for name, perm in grid_symmetries(board.cols, board.rows) if "turn" in name or name == "identity"]
            best = min(turns, key=lambda perm: float(np.linalg.norm(lc[ends] - rc[perm][ends], axis=1).sum()))
            rc = rc[best].copy()
            right = BoardDetection(True, rc, right.ids, method=right.method, image_size=right.image_size,
                                   square_px=right.square_px)
        ids = left.ids
        return PairDetection(left, right, obj.copy(), lc, rc, ids)
    common, li, ri = np.intersect1d(left.ids, right.ids, assume_unique=True, return_indices=True)
    if len(common) < options.min_charuco_corners:
        return PairDetection(left, right, reasons=(
            f"only {len(common)} board corners seen by both cameras (need {options.min_charuco_corners})",))
    if board.cv_board().checkCharucoCornersCollinear(common.reshape(-1, 1)):
        return PairDetection(left, right, reasons=("the corners both cameras see lie on one line",))
    return PairDetection(left, right, obj[common].copy(), left.corners[li], right.corners[ri], common.astype(np.int32))


def detect_pair(left: np.ndarray, right: np.ndarray, board: BoardSpec,
                options: DetectOptions = DetectOptions()) -> PairDetection:
    """Detect the board in both images and pair the corners."""
    return match_views(detect_board(left, board, options), detect_board(right, board, options), board, options)


def draw_detection(image: np.ndarray, detection: BoardDetection, board: Optional[BoardSpec] = None) -> np.ndarray:
    """A BGR copy of ``image`` with the detected corners drawn (green when found, else a red note)."""
    out = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image.copy()
    if detection.ok and detection.corners is not None:
        full = board is not None and isinstance(board, ChessboardSpec) and detection.n == board.n_corners
        if full:
            cv2.drawChessboardCorners(out, (board.cols, board.rows), detection.corners.reshape(-1, 1, 2), True)
        else:
            for p in detection.corners:
                cv2.circle(out, (int(round(p[0] * 4)), int(round(p[1] * 4))), 3 * 4, (0, 220, 0), 1,
                           cv2.LINE_AA, shift=2)
    else:
        cv2.putText(out, "no board", (8, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (0, 0, 255), 2, cv2.LINE_AA)
    return out


def _verified_size(board: ChessboardSpec, pairs: Sequence, greys: Sequence[np.ndarray]) -> bool:
    """Does ``board`` (a guessed size) really fit the pictures? With pairs: it must be found in at
    least 4 of them and give a calibration that passes every sanity check. Without pairs (one live
    frame): the largest grid in view must be exactly this size (not a part of a bigger board)."""
    if pairs:
        dets = []
        opts = DetectOptions(use_sb=False, diagnose=False)
        for left, right in list(pairs)[:12]:
            if isinstance(left, (str, os.PathLike)):
                left, right = cv2.imread(str(left)), cv2.imread(str(right))
            if left is None or right is None:
                continue
            dets.append(detect_pair(left, right, board, opts))
        if sum(d.ok for d in dets) < 4:
            return False
        try:
            return calibrate_stereo(dets, board=board).ok
        except CalibrationFailed:
            return False
    for g in greys:
        work = g if g.shape[1] >= 640 else cv2.resize(g, None, fx=2, fy=2, interpolation=cv2.INTER_CUBIC)
        probe = _probe_partial(work)
        if probe is not None and probe.grid is not None and sorted(probe.grid) == sorted(board.grid):
            return True
    return False


def seen_grid(detections: Sequence[PairDetection]) -> Optional[tuple[int, int]]:
    """The smaller whole chessboard every pair so far shows instead of the described one (each pair
    has a view that found it, no view found another), else None."""
    if not detections or any(d.ok for d in detections):
        return None
    grids = set()
    for d in detections:
        views = [v.grid_seen for v in (d.left, d.right) if v.grid_seen is not None]
        if not views:
            return None
        grids.update(views)
    return grids.pop() if len(grids) == 1 else None


def suggest_board(images: Sequence[np.ndarray], board: BoardSpec, pairs: Optional[Sequence] = None,
                  seen: Optional[tuple[int, int]] = None) -> Optional[str]:
    """When the board is never found: is it another size or kind? A hint for the user, or None.

    Tries ``seen`` first (the whole, smaller chessboard the detections found instead, see
    ``seen_grid``), then the chessboard counted by squares instead of inner corners (and the
    reverse, and one count off), and looks for ArUco markers (a ChArUco board described as a
    chessboard, or another dictionary). A size is only suggested when it is verified
    (``_verified_size``): with ``pairs`` (image arrays or paths, left and right) it must calibrate
    and pass the sanity checks.
    """
    greys = [_grey(im) for im in images[:3] if im is not None]
    if not greys:
        return None
    if isinstance(board, ChessboardSpec) and seen is not None and sorted(seen) != sorted(board.grid):
        if _verified_size(ChessboardSpec(seen[0], seen[1], board.square_m), pairs, greys):
            return (f"this looks like a {seen[0]}x{seen[1]} board: every picture so far shows a whole chessboard "
                    f"of {seen[0]}x{seen[1]} inner corners (and it calibrates) — use --board "
                    f"chessboard:{seen[0]}x{seen[1]}")
    if isinstance(board, ChessboardSpec):
        for dc, dr, why in ((-1, -1, "counted squares instead of inner corners?"),
                            (1, 1, "counted inner corners of a bigger board?"),
                            (-1, 0, "miscounted a row?"), (0, -1, "miscounted a column?"),
                            (1, 0, "miscounted a row?"), (0, 1, "miscounted a column?")):
            cols, rows = board.cols + dc, board.rows + dr
            if cols < 3 or rows < 3:
                continue
            for g in greys:
                work = g if g.shape[1] >= 640 else cv2.resize(g, None, fx=2, fy=2, interpolation=cv2.INTER_CUBIC)
                ok, _ = cv2.findChessboardCorners(work, (cols, rows), flags=_CLASSIC_FLAGS)
                if ok:
                    if _verified_size(ChessboardSpec(cols, rows, board.square_m), pairs, greys):
                        return (f"the images show a chessboard with {cols}x{rows} inner corners ({why}) — "
                                f"use --board chessboard:{cols}x{rows}")
                    break
    for name in ("DICT_4X4_50", "DICT_5X5_100", "DICT_6X6_250", "DICT_7X7_250", "DICT_ARUCO_ORIGINAL",
                 "DICT_APRILTAG_36h11"):
        det = cv2.aruco.ArucoDetector(_dictionary(name), cv2.aruco.DetectorParameters(), cv2.aruco.RefineParameters())
        for g in greys:
            _, ids, _ = det.detectMarkers(g)
            if ids is not None and len(ids) >= 4:
                if isinstance(board, CharucoSpec) and name == board.dictionary:
                    return (f"{len(ids)} {name} markers found but no board corners — check the squares "
                            f"count and the marker size (and ':legacy' for boards made by older tools)")
                return (f"the images show {name} markers — a ChArUco board? use e.g. "
                        f"--board charuco:COLSxROWS:MARKER_METRES:{name}")
    return None


# ----------------------------------------------------------------------------------------------
# calibration

DISTORTION_MODELS = ("auto", "k1", "k1k2", "k1k2p", "k1k2pk3", "rational")
_MODEL_FLAGS = {
    "k1": cv2.CALIB_FIX_K2 | cv2.CALIB_FIX_K3 | cv2.CALIB_ZERO_TANGENT_DIST,
    "k1k2": cv2.CALIB_FIX_K3 | cv2.CALIB_ZERO_TANGENT_DIST,
    "k1k2p": cv2.CALIB_FIX_K3,
    "k1k2pk3": 0,
    "rational": cv2.CALIB_RATIONAL_MODEL,
}
_MODEL_TEXT = {
    "k1": "k1 only", "k1k2": "k1, k2", "k1k2p": "k1, k2, p1, p2", "k1k2pk3": "k1, k2, p1, p2, k3",
    "rational": "rational model (8 coefficients)",
}


def auto_distortion_model(n_pairs: int) -> str:
    """Fewer pairs, fewer distortion terms: k1 below 6 pairs, k1+k2 below 10, then k1 k2 p1 p2.

    k3 stays fixed: with webcam lenses it mostly fits noise at the image corners.
    """
    if n_pairs < 6:
        return "k1"
    if n_pairs < 10:
        return "k1k2"
    return "k1k2p"


@dataclass(frozen=True)
class CalibrationOptions:
    """How the calibration is solved and which pairs are thrown out."""

    distortion: str = "auto"  # auto | k1 | k1k2 | k1k2p | k1k2pk3 | rational
    max_pair_error_px: float = 0.0  # reject pairs above this RMS (px); 0 = automatic (see below)
    outlier_factor: float = 3.0  # automatic threshold: outlier_factor × the median pair error …
    outlier_floor_px: float = 0.5  # … but never below this (px)
    max_rejected_fraction: float = 0.3  # never reject more than this share of the detected pairs as outliers
    max_rounds: int = 3  # calibrate / reject / recalibrate rounds
    min_pairs: int = 4  # fewer usable pairs is an error
    wide: bool = False  # wide-angle / fisheye lenses: allow a horizontal field of view up to 170° (else 20 … 120°)
    max_rms_px: float = 1.0  # a stereo RMS or epipolar error above this is a failed check (px)
    min_tilt_spread_deg: float = 15.0  # the board's facing direction must vary this much over the pairs (°)
    max_fx_sigma: float = 0.03  # the focal length's relative 1-sigma uncertainty must stay below this

    min_pairs_install: int = 6  # fewer used pairs is a failed check: a calibration to install needs this many

    def __post_init__(self) -> None:
        if self.distortion not in DISTORTION_MODELS:
            raise ValueError(f"distortion model {self.distortion!r}; valid: {', '.join(DISTORTION_MODELS)}")
        if not (self.max_pair_error_px == 0 or 0.05 <= self.max_pair_error_px <= 50):
            raise ValueError(f"max_pair_error_px = {self.max_pair_error_px} is outside 0.05 … 50 px (0 = automatic)")
        if not (1.0 <= self.outlier_factor <= 20.0):
            raise ValueError(f"outlier_factor = {self.outlier_factor} is outside 1 … 20")
        if not (0.0 <= self.max_rejected_fraction <= 0.9):
            raise ValueError(f"max_rejected_fraction = {self.max_rejected_fraction} is outside 0 … 0.9")
        if not (3 <= self.min_pairs <= 100):
            raise ValueError(f"min_pairs = {self.min_pairs} is outside 3 … 100")
        if not (self.min_pairs <= self.min_pairs_install <= 100):
            raise ValueError(f"min_pairs_install = {self.min_pairs_install} is outside min_pairs … 100")
        if not (0.1 <= self.max_rms_px <= 50):
            raise ValueError(f"max_rms_px = {self.max_rms_px} is outside 0.1 … 50 px")


@dataclass(frozen=True)
class PairResult:
    """One pair's part in the calibration (for the per-pair error plot)."""

    index: int  # position in the input
    name: str  # file name or capture number
    used: bool  # part of the final calibration
    reason: str = ""  # why it was rejected ("" when used)
    n_points: int = 0  # corners both views share
    error_px: Optional[float] = None  # reprojection RMS over both views (px)
    error_left_px: Optional[float] = None
    error_right_px: Optional[float] = None
    epipolar_px: Optional[float] = None  # mean distance of a corner to its epipolar line (px)


@dataclass(frozen=True, eq=False)
class CalibrationReport:
    """What a calibration found, and how each pair fared."""

    calibration: StereoCalibration
    rms_left: float  # reprojection RMS of the left camera over the used pairs (px)
    rms_right: float
    rms_stereo: float  # stereoCalibrate's RMS (px)
    epipolar_error_px: float  # mean corner-to-epipolar-line distance over the used pairs (px)
    pairs: tuple[PairResult, ...]
    distortion_model: str  # k1 | k1k2 | k1k2p | k1k2pk3 | rational
    notes: tuple[str, ...] = ()
    duration_s: float = 0.0
    board: str = ""
    problems: tuple[str, ...] = ()  # failed sanity checks, each naming the problem and the fix; install only if empty
    checks: dict = field(default_factory=dict)  # the measured values the checks looked at (fov, distances, tilt …)
    consequences: tuple[str, ...] = ()  # checks that failed only because of the problem above (said after it)

    @property
    def ok(self) -> bool:
        """Every sanity check passed: the calibration may be installed (else only with --force)."""
        return not self.problems

    @property
    def pairs_total(self) -> int:
        return len(self.pairs)

    @property
    def pairs_used(self) -> int:
        return sum(p.used for p in self.pairs)

    @property
    def pairs_rejected(self) -> int:
        return self.pairs_total - self.pairs_used

    @property
    def rejected(self) -> tuple[PairResult, ...]:
        return tuple(p for p in self.pairs if not p.used)

    def worst(self, n: int = 3) -> list[int]:
        """Indices of the ``n`` used pairs with the largest error (for highlight / removal)."""
        used = sorted((p for p in self.pairs if p.used and p.error_px is not None), key=lambda p: -p.error_px)
        return [p.index for p in used[:n]]

    def summary(self, out: Optional[str] = None) -> dict:
        """The JSON summary of ``deskarm calibrate --json``."""
        c = self.calibration
        return {
            "pairs_total": self.pairs_total,
            "pairs_used": self.pairs_used,
            "pairs_rejected": self.pairs_rejected,
            "rms_left": round(self.rms_left, 4),
            "rms_right": round(self.rms_right, 4),
            "rms_stereo": round(self.rms_stereo, 4),
            "epipolar_error_px": round(self.epipolar_error_px, 4),
            "baseline_m": round(c.baseline_m, 6),
            "fx_left": round(float(c.M1[0, 0]), 3),
            "fy_left": round(float(c.M1[1, 1]), 3),
            "fx_right": round(float(c.M2[0, 0]), 3),
            "fy_right": round(float(c.M2[1, 1]), 3),
            "image_width": c.image_size[0],
            "image_height": c.image_size[1],
            "distortion_model": self.distortion_model,
            "board": self.board,
            "rejected": [{"pair": p.name, "reason": p.reason} for p in self.rejected],
            "ok": self.ok,
            "problems": list(self.problems),
            "consequences": list(self.consequences),
            "checks": {k: (round(v, 4) if isinstance(v, float) else v) for k, v in self.checks.items()},
            "out": out,
        }

    def file_extras(self) -> dict:
        """Extra scalar keys worth keeping in the calibration YAML (``save_calibration(extra=…)``)."""
        extras = {"rms_left": float(self.rms_left), "rms_right": float(self.rms_right),
                  "pairs_used": int(self.pairs_used), "pairs_total": int(self.pairs_total),
                  "distortion_model": self.distortion_model,
                  "calibrated_at": time.strftime("%Y-%m-%dT%H:%M:%S")}
        if self.board:
            extras["board"] = self.board
        return extras

    def summary_lines(self) -> list[str]:
        """A few human lines: errors, focal lengths, baseline, what was rejected and why."""
        c = self.calibration
        lines = [
            f"pairs: {self.pairs_used} used of {self.pairs_total} ({self.pairs_rejected} rejected)",
            f"RMS left {self.rms_left:.3f} px, right {self.rms_right:.3f} px, stereo {self.rms_stereo:.3f} px; "
            f"epipolar error {self.epipolar_error_px:.3f} px",
            f"fx/fy left {c.M1[0, 0]:.1f}/{c.M1[1, 1]:.1f} px, right {c.M2[0, 0]:.1f}/{c.M2[1, 1]:.1f} px; "
            f"baseline {c.baseline_m * 1e3:.2f} mm; distortion {_MODEL_TEXT.get(self.distortion_model, self.distortion_model)}",
        ]
        for p in self.rejected:
            lines.append(f"  rejected {p.name}: {p.reason}")
        lines += [f"note: {n}" for n in self.notes]
        lines += [f"problem: {p}" for p in self.problems]
        if self.consequences:
            lines.append("  which also explains: " + "; ".join(self.consequences))
        verdict = rms_verdict(self.rms_stereo, self.epipolar_error_px)
        if verdict:
            lines.append(verdict)
        return lines


def rms_verdict(rms_stereo: float, epipolar_px: float) -> str:
    """A one-line judgement a user can act on ("" when the calibration looks good)."""
    if rms_stereo > 1.0 or epipolar_px > 1.0:
        return ("warning: errors above 1 px — depth will be off; check the square size, hold the board "
                "still, keep it flat and capture more varied poses")
    if rms_stereo > 0.5:
        return "fair: errors above 0.5 px — more pairs (tilted, near the image corners) would help"
    return ""


class CalibrationFailed(CalibrationError):
    """Calibration could not run or did not converge; ``pairs`` says what happened to each pair."""

    def __init__(self, message: str, pairs: Sequence[PairResult] = ()):
        super().__init__(message)
        self.pairs = tuple(pairs)


ProgressFn = Callable[[float, str], None]


def epipolar_errors(calib_F: np.ndarray, M1, D1, M2, D2, left_pts, right_pts) -> np.ndarray:
    """Per corner: mean distance (px) of each view's point to the epipolar line of its partner."""
    pl = cv2.undistortPoints(np.asarray(left_pts, np.float64).reshape(-1, 1, 2), M1, D1, P=M1)
    pr = cv2.undistortPoints(np.asarray(right_pts, np.float64).reshape(-1, 1, 2), M2, D2, P=M2)
    lines_r = cv2.computeCorrespondEpilines(pl, 1, calib_F).reshape(-1, 3)  # in the right image
    lines_l = cv2.computeCorrespondEpilines(pr, 2, calib_F).reshape(-1, 3)  # in the left image
    pl, pr = pl.reshape(-1, 2), pr.reshape(-1, 2)
    dr = np.abs(np.sum(lines_r[:, :2] * pr, axis=1) + lines_r[:, 2])
    dl = np.abs(np.sum(lines_l[:, :2] * pl, axis=1) + lines_l[:, 2])
    return 0.5 * (dl + dr)


ORIENT_TOLERANCE_DEG = 20.0  # a pair's right-view order fits the rig when its camera-to-camera rotation is this close
# (a wrong order is off by 90° or 180°; webcam poses from a rough one-camera calibration by a few degrees)


def _rotation_deg(R: np.ndarray) -> float:
    return math.degrees(math.acos(max(-1.0, min(1.0, (float(np.trace(R)) - 1.0) / 2.0))))


def _orient_pairs(detections: Sequence[PairDetection], active: list[int], board: ChessboardSpec,
                  image_size: tuple[int, int]) -> tuple[list[PairDetection], dict[int, str], str]:
    """Settle the chessboard's half / quarter turn between the two views of every pair.

    Each view alone cannot tell which physical corner its first one is (a 7x5 board looks the same
    after a half turn, a 7x7 after a quarter turn), but a rig is rigid: the rotation from the left
    camera to the right one is the same in every pair. Calibrate each camera on its own (the corner
    order does not matter there), then for every pair and every re-ordering of the right view's grid
    compute that rotation, and keep the re-ordering that agrees with the most pairs (ties: keep the
    order the board's colours gave, then the smaller rotation). An upside-down camera thus gets its
    180° right instead of a garbage calibration. Returns (detections, {index: reason} for pairs that
    fit no re-ordering, a note or "", how many pairs were re-matched by a mirror — a mirrored camera).
    """
    syms = grid_symmetries(board.cols, board.rows)
    obj = board.object_points().astype(np.float64)
    il = [detections[k].left_points.reshape(-1, 1, 2).astype(np.float32) for k in active]
    ir = [detections[k].right_points.reshape(-1, 1, 2).astype(np.float32) for k in active]
    objs = [obj.astype(np.float32)] * len(active)
    flags = _MODEL_FLAGS["k1"]
    try:
        _, K1, D1, rv1, tv1 = cv2.calibrateCamera(objs, il, image_size, None, None, flags=flags)
        _, K2, D2, _, _ = cv2.calibrateCamera(objs, ir, image_size, None, None, flags=flags)
    except cv2.error:
        return list(detections), {}, ""
    rel: dict[int, list[tuple[np.ndarray, np.ndarray]]] = {}
    for j, k in enumerate(active):
        RL, _ = cv2.Rodrigues(rv1[j])
        tl = np.asarray(tv1[j], np.float64).reshape(3)
        cands = []
        for _, perm in syms:
            ok, rv, tv = cv2.solvePnP(obj, ir[j].reshape(-1, 2)[perm].astype(np.float64), K2, D2,
                                      flags=cv2.SOLVEPNP_IPPE)
            if not ok:
                cands.append((np.full((3, 3), np.nan), np.full(3, np.nan)))
                continue
            RR, _ = cv2.Rodrigues(rv)
            Rrel = RR @ RL.T
            cands.append((Rrel, tv.reshape(3) - Rrel @ tl))
        rel[k] = cands

    def fits(Rh: np.ndarray, k: int) -> tuple[float, int]:
        diffs = [_rotation_deg(Rc @ Rh.T) if np.all(np.isfinite(Rc)) else 999.0 for Rc, _ in rel[k]]
        g = int(np.argmin(diffs))
        return diffs[g], g

    best = None
    for k0 in active:
        for g0, (Rh, _) in enumerate(rel[k0]):
            if not np.all(np.isfinite(Rh)):
                continue
            got = [fits(Rh, k) for k in active]
            inl = [g for d, g in got if d <= ORIENT_TOLERANCE_DEG]
            score = (len(inl), sum(g == 0 for g in inl), -_rotation_deg(Rh))
            if best is None or score > best[0]:
                best = (score, Rh)
    if best is None:
        return list(detections), {}, ""
    Rh = best[1]
    out = list(detections)
    odd: dict[int, str] = {}
    turned: list[str] = []
    for k in active:
        d, g = fits(Rh, k)
        if d > ORIENT_TOLERANCE_DEG:
            odd[k] = (f"the two views of the board do not fit the other pairs' camera-to-camera rotation in any "
                      f"orientation ({d:.0f}° off) — board moved between the shots, or corners misdetected")
            continue
        if g == 0:
            continue
        name, perm = syms[g]
        det = detections[k]
        rc = det.right_points[perm].copy()
        right = BoardDetection(True, rc, det.right.ids, method=det.right.method, image_size=det.right.image_size,
                               square_px=det.right.square_px)
        out[k] = PairDetection(det.left, right, det.object_points, det.left_points, rc, det.ids, det.reasons)
        turned.append(name)
    note = ""
    if turned:
        note = (f"the right view's corner order was re-matched ({', '.join(sorted(set(turned)))}) in "
                f"{len(turned)} pair(s) so both views agree on the board's corners")
    mirrored = sum(name in MIRROR_SYMMETRIES for name in turned)
    return out, odd, note, mirrored


# a re-ordering of the right view's grid that only a mirror image explains: a real board seen by two
# real cameras always shows the same face, so its corners match by a turn, never by a mirror
MIRROR_SYMMETRIES = ("mirror columns", "mirror rows", "transpose", "anti-transpose")


FOV_DEG = (20.0, 120.0)  # a plausible horizontal field of view for a desk webcam (°)
FOV_WIDE_DEG = (20.0, 170.0)  # with --wide
SAME_IMAGES_PX = 0.01  # left and right corners closer than this in every pair: the same camera twice
MIN_BASELINE_SQUARES = 0.05  # a baseline below this many squares is no stereo rig (nor is one above MAX_BASELINE_M)
MAX_BASELINE_M = 1.0
MAX_CAMERA_ROTATION_DEG = 45.0  # more between the two cameras' axes is not a side-by-side rig


def _percent(rel: float) -> str:
    return f"±{rel * 100:.1f} %" if math.isfinite(rel) else "an unknown amount (a calibration without some pair fails)"


def _sanity_problems(calib: StereoCalibration, rvecs, tvecs, fx_sigma: tuple[float, float],
                     used: Sequence[PairDetection], board: Optional[BoardSpec],
                     options: CalibrationOptions) -> tuple[list[str], dict]:
    """Physical sanity checks of a finished calibration: each failed one is a sentence naming the
    problem and the fix. Also returns the values looked at (for the report)."""
    problems: list[str] = []
    w, h = calib.image_size
    lo, hi = FOV_WIDE_DEG if options.wide else FOV_DEG
    checks: dict = {}
    # 1. the same picture twice (the camera index given for both sides)
    if used and all(np.abs(d.left_points - d.right_points).max() < SAME_IMAGES_PX for d in used):
        problems.append("the left and right images are the same — check the camera indices (both sides read "
                        "one camera) and capture again")
        return problems, {"same_images": True}
    # 2. focal length against a plausible field of view
    for side, M in (("left", calib.M1), ("right", calib.M2)):
        fx = float(M[0, 0])
        fov = math.degrees(2 * math.atan(w / (2 * fx))) if fx > 0 else 180.0
        checks[f"fov_{side}_deg"] = fov
        if not (lo <= fov <= hi):
            problems.append(
                f"{side} focal length fx = {fx:.0f} px means a {fov:.0f}° horizontal field of view at {w} px width "
                f"(plausible: {lo:.0f}–{hi:.0f}°{'' if options.wide else ', or use --wide for wide-angle lenses'}) — "
                f"the poses do not pin the focal length down: tilt the board more (±30° about both axes), "
                f"fill more of the image, and check the board size")
    # 2b. a lens distortion that folds or throws away the image border (D1 = [1e6, …]) — the same
    # check the calibration file gets when it is loaded, so nothing is installed that a start refuses
    from core.vision.calibration import distortion_problem

    for side, M, D in (("left", calib.M1, calib.D1), ("right", calib.M2, calib.D2)):
        why = distortion_problem(M, D, calib.image_size)
        if why:
            problems.append(f"the {side} lens distortion {why} — add pairs with the board near the image "
                            "corners, or use a simpler distortion model")
    # 3. the board's distances (a wrong focal length or square size puts it centimetres away)
    dist = np.array([float(np.linalg.norm(np.asarray(t).reshape(3))) for t in tvecs])
    if board is not None and len(dist):
        cols, rows = board.grid
        extent = board.square_m * math.hypot(cols - 1, rows - 1)
        checks["board_distance_m"] = [round(float(v), 4) for v in (dist.min(), np.median(dist), dist.max())]
        if dist.min() < max(0.02, 0.5 * extent):
            problems.append(
                f"the board would be only {dist.min() * 100:.1f} cm from the left camera in some pairs (it is "
                f"{extent * 100:.0f} cm across) — impossible for a board seen whole: the focal length is wrong "
                f"(tilt the board more) or --square is not the printed square size")
        elif dist.max() > 20.0:
            problems.append(f"the board would be {dist.max():.0f} m away — check --square (metres) and the board size")
    # 4. tilt variety: the same tilt in every pair leaves the focal length free
    normals = np.array([cv2.Rodrigues(np.asarray(r, np.float64).reshape(3, 1))[0][:, 2] for r in rvecs])
    if len(normals) >= 2:
        cosines = np.clip(normals @ normals.T, -1.0, 1.0)
        spread = float(np.degrees(np.arccos(np.abs(cosines))).max())
        checks["tilt_spread_deg"] = spread
        checks["fx_sigma_rel"] = max(fx_sigma)
        if spread < options.min_tilt_spread_deg:
            problems.append(
                f"the board is tilted alike in every pair (its facing direction varies by {spread:.0f}°, need "
                f"{options.min_tilt_spread_deg:.0f}°; focal length uncertain by {_percent(max(fx_sigma))}) — "
                f"tilt the board more, fx cannot be pinned down: add pairs tilted ±30° left/right and up/down")
        elif max(fx_sigma) > options.max_fx_sigma:
            problems.append(
                f"the focal length is uncertain by {_percent(max(fx_sigma))} (need ≤ {options.max_fx_sigma * 100:g} %: "
                f"it moves that much when one pair is left out) — the {len(used)} pairs do not pin fx down: add "
                f"pairs tilted ±30° left/right and up/down, near the image corners and at different distances")
    if 0 < len(used) < options.min_pairs_install:
        problems.append(
            f"only {len(used)} pairs used — a calibration to install needs at least {options.min_pairs_install} "
            f"(few pairs give a focal length off by several per cent): capture more pairs, tilted and spread over "
            f"the image")
    # 5. the rig: baseline, which side the right camera is on, cameras facing the same way
    R = np.asarray(calib.R, np.float64)
    centre = -(R.T @ calib.T.reshape(3))  # the right camera's centre in camera_left (m)
    baseline = float(np.linalg.norm(centre))
    rot = _rotation_deg(R)
    checks.update(baseline_m=baseline, camera_rotation_deg=rot, right_camera_x_m=float(centre[0]))
    min_baseline = MIN_BASELINE_SQUARES * (board.square_m if board is not None else 0.025)
    if baseline < min_baseline:
        problems.append(f"baseline {baseline * 1e3:.2f} mm: the left and right images are the same (or from one "
                        f"camera) — check the camera indices")
    elif baseline > MAX_BASELINE_M:
        problems.append(f"baseline {baseline:.2f} m is implausible for a desk rig — check --square and the board "
                        f"size, and that the pairs were taken at the same time")
    if rot > MAX_CAMERA_ROTATION_DEG:
        roll = abs(math.degrees(math.atan2(R[1, 0], R[0, 0])))
        what = ("the right camera is mounted upside down (turned 180° about its axis against the left one)"
                if roll > 135 else f"the cameras' axes differ by {rot:.0f}°")
        problems.append(f"{what} — mount both cameras the same way up, side by side and facing the same way, "
                        f"then calibrate again (rectification cannot pair rows of such a rig)")
    elif baseline >= min_baseline and centre[0] < 0 and abs(centre[0]) >= abs(centre[1]):
        problems.append(f"the right camera is to the left of the left one ({abs(centre[0]) * 1e3:.0f} mm) — the "
                        f"left and right images are swapped: run again with --swap (or swap the camera indices)")
    # 6. errors
    if calib.rms_stereo > options.max_rms_px or calib.epipolar_error_px > options.max_rms_px:
        problems.append(
            f"stereo RMS {calib.rms_stereo:.2f} px / epipolar error {calib.epipolar_error_px:.2f} px is above "
            f"{options.max_rms_px:g} px — the pairs were not taken at the same time, the board moved or bent, or the "
            f"board size is wrong: hold the board still, keep it flat, and check --board")
    return problems, checks


JACKKNIFE_GROUPS = 12  # more pairs are left out in this many groups (the cost stays ~12 calibrations a camera)


def _jackknife_fx_sigma(obj, il, ir, image_size, flags, K1, K2) -> tuple[float, float]:
    """Relative 1-sigma of each camera's fx from a (grouped) jackknife over the pairs: calibrate
    with each group of pairs left out; sigma² = (g−1)/g · Σ (fx_i − mean)²."""
    n = len(obj)
    g_count = min(n, JACKKNIFE_GROUPS)
    groups = [list(range(j, n, g_count)) for j in range(g_count)]  # pair j, j+g, j+2g … left out together
    out = []
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 60, 1e-6)
    for pts, K in ((il, K1), (ir, K2)):
        fxs = []
        for g in groups:
            keep = [k for k in range(n) if k not in g]
            try:
                _, Kj, _, _, _ = cv2.calibrateCamera([obj[k] for k in keep], [pts[k] for k in keep], image_size,
                                                     K.copy(), None, flags=flags | cv2.CALIB_USE_INTRINSIC_GUESS,
                                                     criteria=criteria)
                fxs.append(float(Kj[0, 0]))
            except cv2.error:
                fxs.append(math.inf)
        fxs = np.array(fxs)
        if len(fxs) < 2 or not np.all(np.isfinite(fxs)):
            out.append(math.inf)
            continue
        m = len(fxs)
        out.append(float(math.sqrt((m - 1) / m * float(((fxs - fxs.mean()) ** 2).sum()))) / max(1e-9, float(K[0, 0])))
    return out[0], out[1]


def _flipped(det: PairDetection, side: str, axis: int, image_size: tuple[int, int]) -> PairDetection:
    """The pair as if one view's image were flipped about ``axis`` (0: x, left–right; 1: y)."""
    size = image_size[axis]

    def flip(p):
        q = np.array(p, np.float32, copy=True)
        q[:, axis] = size - 1 - q[:, axis]
        return q

    lp, rp = (flip(det.left_points), det.right_points) if side == "left" else (det.left_points, flip(det.right_points))
    view = det.left if side == "left" else det.right
    v = BoardDetection(True, lp if side == "left" else rp, view.ids, method=view.method, image_size=view.image_size,
                       square_px=view.square_px)
    left, right = (v, det.right) if side == "left" else (det.left, v)
    return PairDetection(left, right, det.object_points, lp, rp, det.ids)


def _mirrored_side(dets: Sequence[PairDetection], board: ChessboardSpec, image_size,
                   options: CalibrationOptions) -> Optional[tuple[str, str]]:
    """(camera, 'left–right' | 'top–bottom') whose flip makes a plausible rig of mirrored views, or None."""
    for side in ("right", "left"):
        for axis, what in ((0, "left–right"), (1, "top–bottom")):
            try:
                r = calibrate_stereo([_flipped(d, side, axis, image_size) for d in dets], image_size,
                                     options=options, board=board, _diagnose=False)
            except CalibrationFailed:
                continue
            c = r.checks
            if (c.get("right_camera_x_m", -1.0) > 0 and c.get("camera_rotation_deg", 180.0) < MAX_CAMERA_ROTATION_DEG
                    and r.rms_stereo <= options.max_rms_px):
                return side, what
    return None


def _headline(problem: str) -> str:
    """A failed check's first clause (what was measured, without the advice)."""
    return problem.split(" — ")[0].split(" (")[0]


def _root_cause(given: Sequence[PairDetection], detections: Sequence[PairDetection], active: list[int],
                odd: dict, n_oriented: int, mirrored: int, board: ChessboardSpec, image_size,
                options: CalibrationOptions, checks: dict) -> Optional[str]:
    """A mistake that makes several sanity checks fail at once, said first and alone: one camera's
    picture mirrored, or the left and right pictures paired off by one."""
    if mirrored and mirrored * 2 >= len(active):
        side = _mirrored_side([detections[k] for k in active], board, image_size, options)
        who = (f"the {side[0]} camera's picture is mirrored ({side[1]})" if side else
               "one camera's picture is mirrored against the other's")
        ctrl = "vertical_flip" if side and side[1] == "top–bottom" else "horizontal_flip"
        fix = (f"turn its mirror / flip setting off (the camera's 'mirror' option, or e.g. "
               f"v4l2-ctl -d /dev/videoN -c {ctrl}=0)")
        also = ""
        if side and side[0] == "left":  # the same pictures as a mirrored right camera with the sides swapped
            also = " (if the left and right pictures are also swapped, it is the other camera: add --swap)"
        return (f"{who}: in {mirrored} of {len(active)} pairs the board's corners match between the views only "
                f"as a mirror image, which no real pair of cameras sees — {fix}, then capture again{also}")
    n = len(given)
    if len(odd) >= max(2, 0.25 * n_oriented) or checks.get("baseline_m", 0.0) > MAX_BASELINE_M:
        best = None
        for shift in (1, -1):
            ks = [k for k in range(n) if 0 <= k + shift < n and given[k].left.ok and given[k + shift].right.ok]
            if len(ks) < options.min_pairs:
                continue
            shifted = [match_views(given[k].left, given[k + shift].right, board) for k in ks]
            shifted_ok = [j for j, d in enumerate(shifted) if d.ok and d.image_size == image_size]
            if len(shifted_ok) < options.min_pairs:
                continue
            _, odd_s, _, _ = _orient_pairs(shifted, shifted_ok, board, image_size)
            fit = len(shifted_ok) - len(odd_s)
            if best is None or fit > best[1]:
                best = (shift, fit, len(shifted_ok))
        fit_now = n_oriented - len(odd)
        if best is not None and best[1] >= 0.8 * best[2] and best[1] >= fit_now + 2:
            shift, fit, total = best
            which = "next" if shift == 1 else "previous"
            return (f"the left and right pictures are paired off by one: each left picture fits the {which} pair's "
                    f"right picture ({fit} of {total} pairs fit the rig that way, {fit_now} of {n_oriented} as given) — "
                    f"a picture is missing or extra on one side, or the numbering differs: pair the files by "
                    f"capture time and calibrate again")
    return None


def calibrate_stereo(detections: Sequence[PairDetection], image_size: Optional[tuple[int, int]] = None,
                     names: Optional[Sequence[str]] = None, options: CalibrationOptions = CalibrationOptions(),
                     progress: Optional[ProgressFn] = None, board: Optional[BoardSpec] = None,
                     _diagnose: bool = True) -> CalibrationReport:
    """Calibrate both cameras and their pose from paired board detections.

    Pairs where a view failed are rejected with that view's reason; then calibrate, reject pairs
    whose reprojection RMS is an outlier (above ``max_pair_error_px``, or ``outlier_factor`` × the
    median and ``outlier_floor_px``), and calibrate again (``max_rounds``). Distortion terms are
    limited when there are few pairs. Raises CalibrationFailed when too few pairs remain.
    """
    t_start = time.perf_counter()
    report = progress or (lambda f, m: None)
    names = list(names) if names is not None else [f"pair {k + 1}" for k in range(len(detections))]
    if len(names) != len(detections):
        raise ValueError("names and detections differ in length")
    sizes = [d.image_size for d in detections if d.ok]
    if image_size is None:
        if not sizes:
            image_size = (0, 0)
        else:
            image_size = max(set(sizes), key=sizes.count)
    image_size = (int(image_size[0]), int(image_size[1]))
    reasons: dict[int, str] = {}
    for k, d in enumerate(detections):
        if not d.ok:
            reasons[k] = d.reason or "board not found"
        elif d.image_size != image_size:
            reasons[k] = f"image size {d.image_size[0]}x{d.image_size[1]} differs from {image_size[0]}x{image_size[1]}"
    active = [k for k in range(len(detections)) if k not in reasons]
    n_detected = len(active)

    def results(errors=None, epi=None, final: bool = False) -> list[PairResult]:
        out = []
        for k, d in enumerate(detections):
            e = (errors or {}).get(k)
            out.append(PairResult(
                index=k, name=names[k], used=final and k in active and k not in reasons, reason=reasons.get(k, ""),
                n_points=0 if d.object_points is None else len(d.object_points),
                error_px=None if e is None else e[0], error_left_px=None if e is None else e[1],
                error_right_px=None if e is None else e[2], epipolar_px=(epi or {}).get(k),
            ))
        return out

    mixed = [(d.left.image_size, d.right.image_size) for d in detections
             if d.left.image_size != d.right.image_size and (0, 0) not in (d.left.image_size, d.right.image_size)]
    if mixed and len(mixed) * 2 > len(detections):
        (lw, lh), (rw, rh) = mixed[0]
        raise CalibrationFailed(
            f"the left images are {lw}x{lh} but the right ones are {rw}x{rh} — both cameras must deliver the "
            f"same image size: set the same resolution for both and capture again", results())
    if n_detected < options.min_pairs:
        why = "; ".join(sorted({r.split(": ", 1)[-1] for r in reasons.values()})[:3])
        raise CalibrationFailed(
            f"only {n_detected} of {len(detections)} pairs show the board in both views (need at least "
            f"{options.min_pairs})" + (f" — {why}" if why else "") + " — check the board size "
            "(inner corners for a chessboard) and capture more pairs", results())
    notes: list[str] = []
    given, odd, mirrored, n_oriented = list(detections), {}, 0, n_detected
    if isinstance(board, ChessboardSpec):
        given = list(detections)
        detections, odd, note, mirrored = _orient_pairs(detections, active, board, image_size)
        n_oriented = len(active)
        for k, why in odd.items():
            reasons[k] = why
        active = [k for k in active if k not in odd]
        if note:
            notes.append(note)
        n_detected = len(active)
        if n_detected < options.min_pairs:
            raise CalibrationFailed(
                f"only {n_detected} of {len(detections)} pairs show the board the same way in both views (need at "
                f"least {options.min_pairs}) — mount both cameras the same way up and capture more pairs", results())
    max_reject = int(math.floor(options.max_rejected_fraction * n_detected))
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-7)
    rounds = max(1, options.max_rounds)
    errors: dict[int, tuple[float, float, float]] = {}
    for rnd in range(rounds + 1):
        model = options.distortion if options.distortion != "auto" else auto_distortion_model(len(active))
        flags = _MODEL_FLAGS[model]
        obj = [detections[k].object_points.astype(np.float32) for k in active]
        il = [detections[k].left_points.reshape(-1, 1, 2).astype(np.float32) for k in active]
        ir = [detections[k].right_points.reshape(-1, 1, 2).astype(np.float32) for k in active]
        report(0.1 + 0.8 * rnd / (rounds + 1), f"calibrating with {len(active)} pairs (round {rnd + 1})")
        try:
            K1 = cv2.initCameraMatrix2D(obj, il, image_size)
            K2 = cv2.initCameraMatrix2D(obj, ir, image_size)
            rms_l, K1, D1, _, _, std_l, _, _ = cv2.calibrateCameraExtended(
                obj, il, image_size, K1, None, flags=flags | cv2.CALIB_USE_INTRINSIC_GUESS, criteria=criteria)
            rms_r, K2, D2, _, _, std_r, _, _ = cv2.calibrateCameraExtended(
                obj, ir, image_size, K2, None, flags=flags | cv2.CALIB_USE_INTRINSIC_GUESS, criteria=criteria)
            # how well each camera's own poses pin its focal length down (relative 1-sigma)
            fx_sigma = (float(std_l.ravel()[0]) / max(1e-9, float(K1[0, 0])),
                        float(std_r.ravel()[0]) / max(1e-9, float(K2[0, 0])))
            mono = (K1.copy(), D1.copy(), K2.copy(), D2.copy())
            solved = cv2.stereoCalibrateExtended(
                obj, il, ir, K1, D1, K2, D2, image_size, None, None,
                flags=flags | cv2.CALIB_USE_INTRINSIC_GUESS, criteria=criteria,
            )
            rms_mono = math.sqrt((rms_l ** 2 + rms_r ** 2) / 2)
            if not np.isfinite(solved[0]) or solved[0] > 1.5 * rms_mono + 0.1:
                # the joint refinement wandered off (few or similar poses): keep each camera's own
                # intrinsics and solve only for the pose between them, if that is better
                fixed = cv2.stereoCalibrateExtended(
                    obj, il, ir, *mono, image_size, None, None, flags=flags | cv2.CALIB_FIX_INTRINSIC,
                    criteria=criteria,
                )
                if np.isfinite(fixed[0]) and (not np.isfinite(solved[0]) or fixed[0] < solved[0]):
                    solved = fixed
                    notes.append(f"round {rnd + 1}: joint refinement diverged, kept the per-camera intrinsics")
            rms, K1, D1, K2, D2, R, T, E, F, rvecs, tvecs, per_view = solved
        except cv2.error as exc:
            msg = str(exc).strip().splitlines()[-1] if str(exc).strip() else "OpenCV error"
            raise CalibrationFailed(f"calibration did not converge ({msg}) — capture more varied poses "
                                    f"and check the board description", results()) from None
        if not (np.all(np.isfinite(K1)) and np.all(np.isfinite(T)) and np.isfinite(rms)):
            raise CalibrationFailed("calibration diverged (NaN) — capture more varied poses", results())
        per_view = np.asarray(per_view, np.float64).reshape(-1, 2)
        errors = {}
        for j, k in enumerate(active):
            el, er = float(per_view[j, 0]), float(per_view[j, 1])
            errors[k] = (float(math.sqrt((el * el + er * er) / 2)), el, er)
        if rnd == rounds:
            break
        pair_err = np.array([errors[k][0] for k in active])
        med = float(np.median(pair_err))
        if options.max_pair_error_px > 0:
            thr = options.max_pair_error_px
        else:
            thr = max(options.outlier_factor * med, options.outlier_floor_px)
        already = n_detected - len(active)
        room = min(max_reject - already, len(active) - options.min_pairs)
        bad = sorted((k for k in active if errors[k][0] > thr), key=lambda k: -errors[k][0])[:max(0, room)]
        if not bad:
            break
        for k in bad:
            reasons[k] = (f"outlier: reprojection error {errors[k][0]:.2f} px > {thr:.2f} px "
                          f"(board moved, bent, or corners misdetected?)")
        active = [k for k in active if k not in bad]
        notes.append(f"round {rnd + 1}: rejected {len(bad)} outlier pair(s) above {thr:.2f} px and recalibrated")
    report(0.92, "measuring epipolar error")
    calib0 = StereoCalibration(M1=K1, D1=D1.reshape(1, -1), M2=K2, D2=D2.reshape(1, -1), R=R,
                               T=np.asarray(T).reshape(3, 1), image_size=image_size)
    Fm = calib0.F
    epi: dict[int, float] = {}
    all_epi = []
    sq_l, sq_r, n_pts = 0.0, 0.0, 0
    for j, k in enumerate(active):
        d = detections[k]
        e = epipolar_errors(Fm, K1, D1, K2, D2, d.left_points, d.right_points)
        epi[k] = float(e.mean())
        all_epi.append(e)
        n = len(d.object_points)
        sq_l += errors[k][1] ** 2 * n
        sq_r += errors[k][2] ** 2 * n
        n_pts += n
    epipolar = float(np.concatenate(all_epi).mean())
    centre = -(np.asarray(R).T @ np.asarray(T).reshape(3))  # the right camera's centre, in camera_left
    if abs(centre[1]) > abs(centre[0]):
        notes.append("the cameras sit one above the other: disparity assumes side by side")
    if options.distortion == "auto" and model != "k1k2p":
        notes.append(f"few pairs ({len(active)}): distortion limited to {_MODEL_TEXT[model]}")
    calib = StereoCalibration(
        M1=K1, D1=D1.reshape(1, -1), M2=K2, D2=D2.reshape(1, -1), R=R, T=np.asarray(T).reshape(3, 1),
        image_size=image_size, rms_stereo=float(rms), epipolar_error_px=epipolar,
    )
    if _diagnose and len(active) >= 3:
        # how much fx moves when pairs are left out: the honest uncertainty with few pairs, where
        # calibrateCamera's own sigma (which trusts the model) says ±1.5 % for a 10 % error
        fx_jack = _jackknife_fx_sigma(obj, il, ir, image_size, flags, K1, K2)
        fx_sigma = (max(fx_sigma[0], fx_jack[0]), max(fx_sigma[1], fx_jack[1]))
    problems, checks = _sanity_problems(calib, rvecs, tvecs, fx_sigma, [detections[k] for k in active], board,
                                        options)
    consequences: list[str] = []
    if problems and _diagnose and isinstance(board, ChessboardSpec):
        root = _root_cause(given, detections, active, odd, n_oriented, mirrored, board, image_size, options, checks)
        if root is None and checks.get("baseline_m", 1.0) < MIN_BASELINE_SQUARES * board.square_m:
            root = next((p for p in problems if p.startswith("baseline ")), None)
        if root is not None:
            consequences = [_headline(p) for p in problems if p != root]
            problems = [root]
    if problems:
        # where the cameras sit means nothing for a refused result (0 mm baseline, wrong pairs …)
        notes = [n for n in notes if not n.startswith("the cameras sit one above the other")]
    report(1.0, "done")
    return CalibrationReport(
        calibration=calib, rms_left=math.sqrt(sq_l / n_pts), rms_right=math.sqrt(sq_r / n_pts),
        rms_stereo=float(rms), epipolar_error_px=epipolar, pairs=tuple(results(errors, epi, final=True)),
        distortion_model=model, notes=tuple(notes), duration_s=time.perf_counter() - t_start,
        board=board.text() if board is not None else "", problems=tuple(problems), checks=checks,
        consequences=tuple(consequences),
    )


# ----------------------------------------------------------------------------------------------
# pose parameters, coverage and gating (as ROS camera_calibration does it)

PARAM_NAMES = ("x", "y", "size", "skew")
PARAM_RANGES = (0.7, 0.7, 0.4, 0.5)  # spread of each parameter that counts as full coverage (ROS)


@dataclass(frozen=True)
class PoseParams:
    """Where the board is in the (left) image, each in 0 … 1 (ROS camera_calibration's X, Y, size, skew)."""

    x: float  # horizontal position of the board
    y: float  # vertical position
    size: float  # sqrt(board area / image area)
    skew: float  # how far the board's corner angle is from 90° (tilt)

    def as_tuple(self) -> tuple[float, float, float, float]:
        return (self.x, self.y, self.size, self.skew)

    def distance(self, other: "PoseParams") -> float:
        return float(sum(abs(a - b) for a, b in zip(self.as_tuple(), other.as_tuple())))


def board_outline(detection: BoardDetection, board: BoardSpec) -> Optional[np.ndarray]:
    """The four outer inner-corners of the whole board (4,2) in the image (via a homography when
    only part of a ChArUco board is visible): up-left, up-right, down-right, down-left."""
    if not detection.ok or detection.corners is None or detection.n < 4:
        return None
    cols, rows = board.grid
    obj = board.object_points()[detection.ids][:, :2]
    ends = np.array([0, cols - 1, cols * rows - 1, (rows - 1) * cols])
    full = board.object_points()[ends][:, :2]
    if isinstance(board, ChessboardSpec) and detection.n == board.n_corners:
        return detection.corners[ends].astype(np.float64)
    H, _ = cv2.findHomography(obj.astype(np.float64), detection.corners.astype(np.float64), 0)
    if H is None:
        return None
    return cv2.perspectiveTransform(full.reshape(-1, 1, 2).astype(np.float64), H).reshape(4, 2)


def _angle(a, b, c) -> float:
    ab, cb = a - b, c - b
    cosv = float(np.dot(ab, cb) / (np.linalg.norm(ab) * np.linalg.norm(cb) + 1e-12))
    return math.acos(max(-1.0, min(1.0, cosv)))


def pose_params(detection: BoardDetection, board: BoardSpec) -> Optional[PoseParams]:
    """ROS camera_calibration's (x, y, size, skew) of a detection, or None if not found."""
    quad = board_outline(detection, board)
    if quad is None:
        return None
    w, h = detection.image_size
    x, y = quad[:, 0], quad[:, 1]
    area = 0.5 * abs(float(np.dot(x, np.roll(y, 1)) - np.dot(y, np.roll(x, 1))))
    border = math.sqrt(area)
    pts = detection.corners
    mx, my = float(pts[:, 0].mean()), float(pts[:, 1].mean())
    px = min(1.0, max(0.0, (mx - border / 2) / max(1e-9, w - border)))
    py = min(1.0, max(0.0, (my - border / 2) / max(1e-9, h - border)))
    size = min(1.0, math.sqrt(area / (w * h)))
    skew = min(1.0, 2.0 * abs(math.pi / 2 - _angle(quad[0], quad[1], quad[2])))
    return PoseParams(px, py, size, skew)


@dataclass(frozen=True)
class Coverage:
    """How much of each pose range the captured pairs cover, each 0 … 1 (the wizard's meters)."""

    x: float
    y: float
    size: float
    skew: float
    count: int  # captured pairs
    good_enough: bool  # every meter full (or 40 pairs), as ROS decides

    def as_dict(self) -> dict[str, float]:
        return {"x": self.x, "y": self.y, "size": self.size, "skew": self.skew}


def coverage_of(params: Sequence[PoseParams]) -> Coverage:
    """Coverage of a set of poses (ROS: x/y by their spread, size and skew by their maximum)."""
    if not params:
        return Coverage(0.0, 0.0, 0.0, 0.0, 0, False)
    arr = np.array([p.as_tuple() for p in params])
    lo, hi = arr.min(axis=0), arr.max(axis=0)
    lo[2] = lo[3] = 0.0  # a small board or no tilt is no merit in itself
    prog = [float(min((b - a) / r, 1.0)) for a, b, r in zip(lo, hi, PARAM_RANGES)]
    good = len(params) >= 40 or all(p >= 1.0 for p in prog)
    return Coverage(*prog, count=len(params), good_enough=good)


@dataclass(frozen=True)
class GateParams:
    """When a live pair may be captured."""

    # left/right capture time difference allowed (s): a little above half a frame at 30 fps, so
    # unsynchronised webcams paired by timestamp pass and only stale or dropped frames fail (with
    # the board held still — < 2 px per frame — 20 ms of skew moves it < 1.5 px between the views)
    max_skew_s: float = 0.020
    max_motion_px: float = 2.0  # mean corner motion since the previous frame (px at 640 px width)
    min_novelty: float = 0.2  # the pose must differ this much from every captured one (ROS: 0.2)

    def __post_init__(self) -> None:
        if not (0.0 <= self.max_skew_s <= 1.0):
            raise ValueError(f"gate max_skew_s = {self.max_skew_s} is outside 0 … 1 s")
        if not (0.1 <= self.max_motion_px <= 100.0):
            raise ValueError(f"gate max_motion_px = {self.max_motion_px} is outside 0.1 … 100 px")
        if not (0.0 <= self.min_novelty <= 4.0):
            raise ValueError(f"gate min_novelty = {self.min_novelty} is outside 0 … 4")


@dataclass(frozen=True)
class GateResult:
    """Whether a live pair may be captured, and why not."""

    accepted: bool
    reasons: tuple[str, ...]  # what stops the capture, each a sentence for the user
    params: Optional[PoseParams] = None  # the pose of this pair (left view)
    novelty: float = math.inf  # distance to the nearest captured pose (inf when none)
    nearest: Optional[int] = None  # index of that captured pair
    motion_px: Optional[float] = None  # board motion since the previous frame (px)
    coverage_gain: dict = field(default_factory=dict)  # how much each meter would grow

    @property
    def reason(self) -> str:
        return "; ".join(self.reasons)


def board_motion_px(current: BoardDetection, previous: Optional[BoardDetection]) -> Optional[float]:
    """Mean displacement of the corners both detections share (px), None if not comparable."""
    if previous is None or not (current.ok and previous.ok) or current.image_size != previous.image_size:
        return None
    common, a, b = np.intersect1d(current.ids, previous.ids, assume_unique=True, return_indices=True)
    if len(common) < 4:
        return None
    return float(np.linalg.norm(current.corners[a] - previous.corners[b], axis=1).mean())


def gate_capture(detection: PairDetection, board: BoardSpec, captured: Sequence[PoseParams],
                 skew_s: float = 0.0, previous: Optional[PairDetection] = None, manual: bool = False,
                 params: GateParams = GateParams()) -> GateResult:
    """Capture gating: both views see the board, it is held still, the pair is in sync, the pose is new.

    ``manual`` (the snapshot button) skips the stillness and novelty tests, not the others.
    """
    reasons = []
    for side, view in (("left", detection.left), ("right", detection.right)):
        if view.ok:
            continue
        if view.grid_seen is not None and isinstance(board, ChessboardSpec):
            c, r = view.grid_seen
            reasons.append(f"the {side} camera sees a chessboard of {c}x{r} inner corners, not {board.cols}x{board.rows} "
                           f"— if that is your board, choose {c}x{r}")
        else:
            reasons.append(f"the {side} camera does not see the whole board" if isinstance(board, ChessboardSpec)
                           else f"the {side} camera does not see the board")
    if detection.left.ok and detection.right.ok and not detection.ok:
        reasons.append(detection.reason)
    if skew_s > params.max_skew_s:
        reasons.append(f"cameras out of sync: {skew_s * 1e3:.0f} ms between the left and right images "
                       f"(allowed {params.max_skew_s * 1e3:.0f} ms)")
    pose = pose_params(detection.left, board) if detection.left.ok else None
    motion = None
    if detection.left.ok:
        motion = board_motion_px(detection.left, previous.left if previous is not None else None)
        if not manual:
            limit = params.max_motion_px * detection.left.image_size[0] / 640.0
            if motion is None:
                reasons.append("hold the board still")
            elif motion > limit:
                reasons.append(f"board moving ({motion:.1f} px since the last frame) — hold it still")
    novelty, nearest = math.inf, None
    gain: dict[str, float] = {}
    if pose is not None:
        if captured:
            dists = [pose.distance(p) for p in captured]
            nearest = int(np.argmin(dists))
            novelty = float(dists[nearest])
        before = coverage_of(captured).as_dict()
        after = coverage_of(list(captured) + [pose]).as_dict()
        gain = {k: max(0.0, after[k] - before[k]) for k in PARAM_NAMES}
        if not manual and novelty <= params.min_novelty:
            reasons.append(f"pose too close to capture #{nearest + 1} — move or tilt the board "
                           f"towards what the meters lack")
    return GateResult(not reasons, tuple(reasons), pose, novelty, nearest, motion, gain)


# ----------------------------------------------------------------------------------------------
# the wizard's session


@dataclass(eq=False)
class CapturedPair:
    """One captured pair of a CalibrationSession."""

    number: int  # 1-based, stable (file names use it), never reused after a removal
    detection: PairDetection
    params: Optional[PoseParams]
    left_path: Optional[Path] = None
    right_path: Optional[Path] = None
    manual: bool = False
    _images: Optional[tuple[np.ndarray, np.ndarray]] = field(default=None, repr=False)

    @property
    def name(self) -> str:
        return self.left_path.name if self.left_path is not None else f"capture {self.number}"

    def images(self) -> tuple[np.ndarray, np.ndarray]:
        """The pair's images (kept in memory, or read back from the session folder)."""
        if self._images is not None:
            return self._images
        if self.left_path is None or self.right_path is None:
            raise FileNotFoundError(f"capture {self.number}: images were not kept")
        left, right = cv2.imread(str(self.left_path)), cv2.imread(str(self.right_path))
        if left is None or right is None:
            raise FileNotFoundError(f"capture {self.number}: cannot read {self.left_path} / {self.right_path}")
        return left, right


SESSION_FILE = "session.toml"


class CalibrationSession:
    """The calibration wizard's state without Qt: detect, gate, capture, coverage, calibrate.

    Captured pairs are saved as ``left_NNNN.png`` / ``right_NNNN.png`` in ``folder`` (when given)
    with a ``session.toml`` naming the board, so ``deskarm calibrate --folder`` can redo the
    calibration later. Not thread-safe: the wizard calls it from one worker (or the GUI thread for
    ``gate`` / ``coverage``, which are cheap) — ``calibrate`` does not touch the pair list while it runs
    except reading it.
    """

    def __init__(self, board: BoardSpec, folder: Optional[Union[str, os.PathLike]] = None,
                 gate_params: GateParams = GateParams(), detect_options: DetectOptions = DetectOptions(),
                 calibration_options: CalibrationOptions = CalibrationOptions(),
                 keep_images: Optional[bool] = None):
        self.board = board
        self.folder = Path(folder) if folder is not None else None
        self.gate_params = gate_params
        self.detect_options = detect_options
        self.calibration_options = calibration_options
        self.keep_images = (self.folder is None) if keep_images is None else keep_images
        self.pairs: list[CapturedPair] = []
        self.last_report: Optional[CalibrationReport] = None
        self._next_number = 1
        if self.folder is not None:
            self.folder.mkdir(parents=True, exist_ok=True)
            self._write_session_file()

    # -- live -----------------------------------------------------------------------------
    def detect(self, left: np.ndarray, right: np.ndarray, fast: bool = True) -> PairDetection:
        """Detect the board in a live pair (``fast``: preview quality, a few ms)."""
        opts = DetectOptions(fast=True, min_charuco_corners=self.detect_options.min_charuco_corners) if fast \
            else self.detect_options
        return detect_pair(left, right, self.board, opts)

    def gate(self, detection: PairDetection, skew_s: float = 0.0, previous: Optional[PairDetection] = None,
             manual: bool = False) -> GateResult:
        """May this live pair be captured? (see ``gate_capture``)."""
        return gate_capture(detection, self.board, self.captured_params(), skew_s, previous, manual,
                            self.gate_params)

    def captured_params(self) -> list[PoseParams]:
        return [p.params for p in self.pairs if p.params is not None]

    def coverage(self) -> Coverage:
        """The meters: x, y, size, skew in 0 … 1 over the captured pairs."""
        return coverage_of(self.captured_params())

    @property
    def image_size(self) -> Optional[tuple[int, int]]:
        return self.pairs[0].detection.image_size if self.pairs else None

    # -- capture --------------------------------------------------------------------------
    def add(self, left: np.ndarray, right: np.ndarray, manual: bool = False) -> CapturedPair:
        """Capture a pair: detected again at full quality, saved to the folder; ValueError if unusable."""
        det = detect_pair(left, right, self.board, self.detect_options)
        if not det.ok:
            raise ValueError(f"pair not captured: {det.reason}")
        size = self.image_size
        if size is not None and det.image_size != size:
            raise ValueError(f"pair not captured: {det.image_size[0]}x{det.image_size[1]} differs from the "
                             f"session's {size[0]}x{size[1]}")
        number = self._next_number
        self._next_number += 1
        pair = CapturedPair(number, det, pose_params(det.left, self.board), manual=manual)
        if self.folder is not None:
            pair.left_path = self.folder / f"left_{number:04d}.png"
            pair.right_path = self.folder / f"right_{number:04d}.png"
            if not (cv2.imwrite(str(pair.left_path), left) and cv2.imwrite(str(pair.right_path), right)):
                raise OSError(f"cannot write the captured pair to {self.folder}")
        if self.keep_images or self.folder is None:
            pair._images = (left, right)
        self.pairs.append(pair)
        return pair

    def remove(self, indices: Iterable[int]) -> None:
        """Drop pairs by position in ``pairs`` (their files move to ``removed/``); recalibrate after."""
        drop = sorted(set(int(i) for i in indices), reverse=True)
        for i in drop:
            if not 0 <= i < len(self.pairs):
                raise IndexError(f"no captured pair at index {i} (have {len(self.pairs)})")
        for i in drop:
            pair = self.pairs.pop(i)
            for path in (pair.left_path, pair.right_path):
                if path is not None and path.exists():
                    removed = path.parent / "removed"
                    removed.mkdir(exist_ok=True)
                    os.replace(path, removed / path.name)

    # -- calibrate ------------------------------------------------------------------------
    def calibrate(self, progress: Optional[ProgressFn] = None) -> CalibrationReport:
        """Calibrate from the captured pairs (run it in a worker: ~0.1–2 s); CalibrationFailed if not enough."""
        dets = [p.detection for p in self.pairs]
        names = [p.name for p in self.pairs]
        self.last_report = calibrate_stereo(dets, None, names, self.calibration_options, progress, self.board)
        return self.last_report

    # -- files ----------------------------------------------------------------------------
    def _write_session_file(self) -> None:
        import tomli_w

        data = {"board": self.board.text(), "square_m": float(self.board.square_m)}
        (self.folder / SESSION_FILE).write_bytes(tomli_w.dumps(data).encode())

    @classmethod
    def from_folder(cls, folder: Union[str, os.PathLike], board: Optional[BoardSpec] = None,
                    progress: Optional[ProgressFn] = None, **kwargs) -> "CalibrationSession":
        """Resume a saved session: detect the board in every saved pair (unusable ones are skipped)."""
        from core.vision.cameras import find_image_pairs

        folder = Path(folder)
        if board is None:
            board = read_session_board(folder)
        session = cls(board, None, keep_images=False, **kwargs)
        session.folder = folder
        pairs = find_image_pairs(folder)
        for k, (lp, rp) in enumerate(pairs):
            if progress:
                progress(k / max(1, len(pairs)), f"detecting {lp.name}")
            left, right = cv2.imread(str(lp)), cv2.imread(str(rp))
            if left is None or right is None:
                continue
            det = detect_pair(left, right, board, session.detect_options)
            if not det.ok:
                continue
            number = _number_in(lp.name) or session._next_number
            session._next_number = max(session._next_number, number + 1)
            session.pairs.append(CapturedPair(number, det, pose_params(det.left, board), lp, rp))
        return session


def _number_in(name: str) -> Optional[int]:
    import re

    m = re.findall(r"\d+", name)
    return int(m[-1]) if m else None


def read_session_board(folder: Union[str, os.PathLike]) -> BoardSpec:
    """The board named in a session folder's session.toml (BoardError if absent or invalid)."""
    import tomllib

    path = Path(folder) / SESSION_FILE
    if not path.is_file():
        raise BoardError(f"{path}: no session file — give the board with --board and --square")
    try:
        data = tomllib.loads(path.read_text())
        return parse_board(str(data["board"]), float(data["square_m"]))
    except (tomllib.TOMLDecodeError, KeyError, TypeError, ValueError) as exc:
        raise BoardError(f"{path}: invalid session file ({exc}) — give the board with --board and --square") from None


# ----------------------------------------------------------------------------------------------
# results


def rectified_preview(left: np.ndarray, right: np.ndarray, calib: StereoCalibration,
                      line_every_px: int = 32, colour=(0, 255, 0)) -> np.ndarray:
    """Both images rectified side by side with horizontal lines: features must sit on the same line."""
    (lx, ly), (rx, ry) = calib.rectify_maps()
    rl = cv2.remap(left, lx, ly, cv2.INTER_LINEAR)
    rr = cv2.remap(right, rx, ry, cv2.INTER_LINEAR)
    if rl.ndim == 2:
        rl, rr = cv2.cvtColor(rl, cv2.COLOR_GRAY2BGR), cv2.cvtColor(rr, cv2.COLOR_GRAY2BGR)
    out = np.hstack([rl, rr])
    for y in range(line_every_px // 2, out.shape[0], max(4, int(line_every_px))):
        cv2.line(out, (0, y), (out.shape[1] - 1, y), colour, 1, cv2.LINE_AA)
    return out


__all__ = [
    "BoardError", "BOARD_FORMS", "ChessboardSpec", "CharucoSpec", "BoardSpec", "parse_board",
    "DetectOptions", "BoardDetection", "PairDetection", "detect_board", "detect_pair", "match_views",
    "draw_detection", "DISTORTION_MODELS", "CalibrationOptions", "PairResult", "CalibrationReport",
    "CalibrationFailed", "calibrate_stereo", "epipolar_errors", "PoseParams", "pose_params", "Coverage",
    "coverage_of", "GateParams", "GateResult", "gate_capture", "board_motion_px", "CapturedPair",
    "CalibrationSession", "read_session_board", "rectified_preview", "rms_verdict", "auto_distortion_model",
    "suggest_board", "seen_grid",
]
