"""ChArUco boards and ChArUco diamonds as ``Detection`` objects (OpenCV 5's ``CharucoDetector``).

``charuco``: one detection per board seen (kind "board", label "COLSxROWS"): its ``points`` are
the chessboard corners found, ``point_ids`` their ids on the board, score = the share of the
board's inner corners found (a board seen in part still counts). The board is counted by its
squares, as the calibration wizard's ``charuco:COLSxROWS:…`` (a 7x5 board has 6x4 inner corners
and 17 markers).

``diamond``: one detection per ChArUco diamond (a 3x3 board of four markers; kind "diamond",
label its four marker ids "a,b,c,d"), ``corners`` its outer corners in OpenCV's order.

The dictionary is a predefined name or a custom dictionary file, as for ``aruco``. Only the
ratio of ``square_m`` to ``marker_m`` matters for finding a board (sizes in metres are kept so
the same settings can later give poses).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import cv2
import numpy as np

from core.detect.base import BaseDetector, Detection, box_of_points, options_factory
from core.settings import SettingsError
from core.vision.perception import aruco_dictionary, dictionary_name, dictionary_size, quad_centre

DEFAULT_BOARD_DICTIONARY = "DICT_4X4_50"  # the calibration wizard's ChArUco example (charuco:5x7:0.022:DICT_4X4_50)
SQUARES_MIN, SQUARES_MAX = 3, 40  # as the wizard's board check


def _check_dictionary(what: str, value) -> str:
    try:
        return dictionary_name(value)
    except ValueError as exc:
        raise SettingsError(f"{what}.dictionary: {exc}") from None


def _check_lengths(what: str, square_m, marker_m) -> tuple[float, float]:
    for name, v in (("square_m", square_m), ("marker_m", marker_m)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not 0 < v <= 1:
            raise SettingsError(f"{what}.{name} = {v!r} must be a length in metres, 0 … 1 (3 cm = 0.03)")
    if marker_m >= square_m:
        raise SettingsError(f"{what}.marker_m = {marker_m!r} must be smaller than square_m = {square_m!r} "
                            "(the marker sits inside its white square)")
    return float(square_m), float(marker_m)


@dataclass(frozen=True)
class CharucoParams:
    """Settings of ``CharucoDetector``."""

    squares_x: int = 7  # squares across the board (columns)
    squares_y: int = 5  # squares down the board (rows)
    square_m: float = 0.03  # side of one chessboard square, m
    marker_m: float = 0.022  # side of one marker (its black border included), m; < square_m
    dictionary: str = DEFAULT_BOARD_DICTIONARY  # predefined name or dictionary file path
    legacy: bool = False  # boards drawn by OpenCV < 4.6 (even row counts start with a marker)
    min_corners: int = 4  # fewer chessboard corners found is no board

    def __post_init__(self) -> None:
        for name in ("squares_x", "squares_y"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or not SQUARES_MIN <= v <= SQUARES_MAX:
                raise SettingsError(f"charuco.{name} = {v!r} must be a whole number of squares, "
                                    f"{SQUARES_MIN} … {SQUARES_MAX}")
        square_m, marker_m = _check_lengths("charuco", self.square_m, self.marker_m)
        object.__setattr__(self, "square_m", square_m)
        object.__setattr__(self, "marker_m", marker_m)
        name = _check_dictionary("charuco", self.dictionary)
        object.__setattr__(self, "dictionary", name)
        markers = self.squares_x * self.squares_y // 2
        if markers > dictionary_size(name):
            raise SettingsError(f"charuco {self.squares_x}x{self.squares_y} needs {markers} markers but "
                                f"{name} has only {dictionary_size(name)}")
        if not isinstance(self.legacy, bool):
            raise SettingsError(f"charuco.legacy = {self.legacy!r} must be true or false")
        inner = (self.squares_x - 1) * (self.squares_y - 1)
        if isinstance(self.min_corners, bool) or not isinstance(self.min_corners, int) \
                or not 1 <= self.min_corners <= inner:
            raise SettingsError(f"charuco.min_corners = {self.min_corners!r} must be 1 … {inner} "
                                f"(the inner corners of a {self.squares_x}x{self.squares_y} board)")

    @property
    def inner_corners(self) -> int:
        """How many chessboard corners the board has: (columns - 1) x (rows - 1)."""
        return (self.squares_x - 1) * (self.squares_y - 1)


def _board(size: tuple[int, int], square_m: float, marker_m: float, dictionary: str,
           legacy: bool = False) -> "cv2.aruco.CharucoBoard":
    board = cv2.aruco.CharucoBoard(size, square_m, marker_m, aruco_dictionary(dictionary))
    board.setLegacyPattern(legacy)
    return board


def _detector(board: "cv2.aruco.CharucoBoard") -> "cv2.aruco.CharucoDetector":
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_NONE  # the chessboard corners are refined instead
    charuco = cv2.aruco.CharucoParameters()
    charuco.tryRefineMarkers = True  # recover markers the board's layout predicts
    return cv2.aruco.CharucoDetector(board, charuco, params, cv2.aruco.RefineParameters())


def _grey(image: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image


class CharucoDetector(BaseDetector):
    """One ChArUco board (of ``CharucoParams``' size and dictionary): kind "board", label
    "COLSxROWS", ``points`` (N, 2) px and ``point_ids`` of the chessboard corners found, score =
    N / the board's inner corners, centre = the points' mean, radius None."""

    name = "charuco"
    params_type = CharucoParams

    def __init__(self, params: Optional[CharucoParams] = None):
        super().__init__(params)
        p = self._params
        self._detector = _detector(_board((p.squares_x, p.squares_y), p.square_m, p.marker_m, p.dictionary,
                                          p.legacy))

    def _detect(self, image: np.ndarray) -> list[Detection]:
        corners, ids, _, _ = self._detector.detectBoard(_grey(image))
        if ids is None or len(ids) < self._params.min_corners:
            return []
        points = np.asarray(corners, dtype=np.float64).reshape(-1, 2)
        point_ids = np.asarray(ids).reshape(-1).astype(int)
        p = self._params
        return [Detection(kind="board", label=f"{p.squares_x}x{p.squares_y}",
                          score=min(1.0, len(point_ids) / p.inner_corners), box=box_of_points(points),
                          centre_px=tuple(points.mean(axis=0)), points=points,
                          point_ids=tuple(int(i) for i in point_ids))]


@dataclass(frozen=True)
class DiamondParams:
    """Settings of ``DiamondDetector``."""

    square_m: float = 0.03  # side of one of the diamond's chessboard squares, m
    marker_m: float = 0.022  # side of one of its four markers, m; < square_m (only the ratio matters)
    dictionary: str = DEFAULT_BOARD_DICTIONARY  # predefined name or dictionary file path

    def __post_init__(self) -> None:
        square_m, marker_m = _check_lengths("diamond", self.square_m, self.marker_m)
        object.__setattr__(self, "square_m", square_m)
        object.__setattr__(self, "marker_m", marker_m)
        object.__setattr__(self, "dictionary", _check_dictionary("diamond", self.dictionary))


class DiamondDetector(BaseDetector):
    """ChArUco diamonds (``CharucoDetector.detectDiamonds``): kind "diamond", label the four
    marker ids "a,b,c,d", ``corners`` (4, 2) px in OpenCV's order, centre at the diagonals'
    intersection, radius = half the mean side, score 1.0."""

    name = "diamond"
    params_type = DiamondParams

    def __init__(self, params: Optional[DiamondParams] = None):
        super().__init__(params)
        p = self._params
        self._detector = _detector(_board((3, 3), p.square_m, p.marker_m, p.dictionary))

    def _detect(self, image: np.ndarray) -> list[Detection]:
        diamond_corners, diamond_ids, _, _ = self._detector.detectDiamonds(_grey(image))
        if diamond_ids is None or len(diamond_ids) == 0:
            return []
        out = []
        for quad, ids in zip(diamond_corners, np.asarray(diamond_ids).reshape(-1, 4)):
            c = np.asarray(quad, dtype=np.float64).reshape(4, 2)
            sides = np.linalg.norm(c - np.roll(c, -1, axis=0), axis=1)
            out.append(Detection(kind="diamond", label=",".join(str(int(i)) for i in ids), score=1.0,
                                 box=box_of_points(c), centre_px=tuple(quad_centre(c)),
                                 radius_px=float(sides.mean()) / 2, corners=c))
        return out


make_charuco = options_factory(CharucoDetector, CharucoParams, "charuco")
make_diamond = options_factory(DiamondDetector, DiamondParams, "diamond")
