"""Printable calibration boards: the board at true size in pixels, PNG with its dpi, page layout.

Pure and Qt-free: the wizard (``widgets/calibration_wizard.py``) writes the PNG with these
functions and draws the same image into a PDF page chosen by ``choose_page``.

Sizes are millimetres at the edges (``*_mm``). At 300 dpi a millimetre is 11.81 px, so square
edges are placed at rounded multiples of the exact pitch: every square is within one pixel
(0.085 mm) of its size and the error never adds up along the board.
"""
from __future__ import annotations

import struct
import zlib
from pathlib import Path
from typing import Optional, Union

import cv2
import numpy as np

from core.vision.stereo_calibration import BoardSpec, ChessboardSpec

PRINT_DPI = 300  # what printers print at 100 % without resampling surprises
MM_PER_INCH = 25.4
QUIET_ZONE_MM = 5.0  # white paper around the squares inside the image (the page margin adds more)
QUIET_ZONE_SQUARES = 0.2  # … or this share of a square, if more
PAGE_MARGIN_MM = 8.0  # most printers cannot print the outer ~5 mm of a sheet
CAPTION_MM = 8.0  # the caption line under the board
# ISO 216 sheets, smallest first (portrait width × height, mm)
PAGES_MM = (("A4", 210.0, 297.0), ("A3", 297.0, 420.0), ("A2", 420.0, 594.0), ("A1", 594.0, 841.0),
            ("A0", 841.0, 1189.0))


def px_per_mm(dpi: float = PRINT_DPI) -> float:
    """Pixels per millimetre at ``dpi``."""
    return float(dpi) / MM_PER_INCH


def board_squares(board: BoardSpec) -> tuple[int, int]:
    """(columns, rows) of squares on the print (a chessboard has one more than inner corners)."""
    if isinstance(board, ChessboardSpec):
        return board.cols + 1, board.rows + 1
    return board.squares_x, board.squares_y


def quiet_zone_mm(board: BoardSpec) -> float:
    """The white margin around the squares inside the printed image (mm)."""
    return max(QUIET_ZONE_MM, QUIET_ZONE_SQUARES * board.square_m * 1e3)


def squares_size_mm(board: BoardSpec) -> tuple[float, float]:
    """(width, height) of the squares alone (mm)."""
    nx, ny = board_squares(board)
    square_mm = board.square_m * 1e3
    return nx * square_mm, ny * square_mm


def printed_size_mm(board: BoardSpec) -> tuple[float, float]:
    """(width, height) of the printable image: the squares and their white quiet zone (mm)."""
    w, h = squares_size_mm(board)
    q = quiet_zone_mm(board)
    return w + 2 * q, h + 2 * q


def board_print_image(board: BoardSpec, dpi: float = PRINT_DPI) -> np.ndarray:
    """The board at ``dpi`` (grey uint8, white quiet zone included): printed at 100 % every square
    measures ``board.square_m``. ChArUco markers come from OpenCV's own ``generateImage``."""
    ppmm = px_per_mm(dpi)
    w_mm, h_mm = printed_size_mm(board)
    w, h = int(round(w_mm * ppmm)), int(round(h_mm * ppmm))
    q_mm = quiet_zone_mm(board)
    square_mm = board.square_m * 1e3
    nx, ny = board_squares(board)
    # square edges at rounded multiples of the exact pitch (no error builds up along the board)
    xs = [int(round((q_mm + i * square_mm) * ppmm)) for i in range(nx + 1)]
    ys = [int(round((q_mm + j * square_mm) * ppmm)) for j in range(ny + 1)]
    img = np.full((h, w), 255, np.uint8)
    if isinstance(board, ChessboardSpec):
        for j in range(ny):
            for i in range(nx):
                if (i + j) % 2 == 0:  # corner square black, as OpenCV's pattern
                    img[ys[j]:ys[j + 1], xs[i]:xs[i + 1]] = 0
        return img
    inner = board.cv_board().generateImage((xs[-1] - xs[0], ys[-1] - ys[0]), marginSize=0, borderBits=1)
    img[ys[0]:ys[-1], xs[0]:xs[-1]] = inner
    return img


# ----------------------------------------------------------------------------------------------
# PNG with its resolution


def _png_chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def png_with_dpi(png: bytes, dpi: float) -> bytes:
    """``png`` (bytes of a PNG file) with a pHYs chunk saying ``dpi`` (any earlier one replaced):
    printers and viewers then print it at its true size. ``cv2.imwrite`` writes no resolution."""
    if png[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG file (bad signature)")
    ppm = int(round(float(dpi) / MM_PER_INCH * 1000.0))  # pixels per metre, the unit PNG knows
    phys = _png_chunk(b"pHYs", struct.pack(">IIB", ppm, ppm, 1))
    out, pos, inserted = [png[:8]], 8, False
    while pos < len(png):
        (length,) = struct.unpack(">I", png[pos:pos + 4])
        kind = png[pos + 4:pos + 8]
        end = pos + 12 + length
        if kind != b"pHYs":
            out.append(png[pos:end])
        if kind == b"IHDR" and not inserted:  # pHYs must come before the image data
            out.append(phys)
            inserted = True
        pos = end
    if not inserted:
        raise ValueError("PNG without an IHDR chunk")
    return b"".join(out)


def read_png_dpi(path: Union[str, Path]) -> Optional[tuple[float, float]]:
    """(x, y) dpi stored in a PNG's pHYs chunk, or None when it has none (or a unitless one)."""
    data = Path(path).read_bytes()
    pos = 8
    while pos + 8 <= len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind = data[pos + 4:pos + 8]
        if kind == b"pHYs":
            x, y, unit = struct.unpack(">IIB", data[pos + 8:pos + 17])
            return (x * MM_PER_INCH / 1000.0, y * MM_PER_INCH / 1000.0) if unit == 1 else None
        if kind == b"IDAT":
            return None
        pos += 12 + length
    return None


def save_board_png(board: BoardSpec, path: Union[str, Path], dpi: float = PRINT_DPI) -> Path:
    """Write the board as a PNG at ``dpi`` with the dpi stored in it; OSError when it cannot."""
    path = Path(path)
    ok, buf = cv2.imencode(".png", board_print_image(board, dpi))
    if not ok:
        raise OSError(f"{path}: PNG encoding failed")
    path.write_bytes(png_with_dpi(buf.tobytes(), dpi))
    return path


# ----------------------------------------------------------------------------------------------
# the page


def choose_page(board: BoardSpec, margin_mm: float = PAGE_MARGIN_MM,
                caption_mm: float = CAPTION_MM) -> tuple[str, float, float]:
    """The smallest ISO sheet (A4 … A0, either way round) holding the board, its margins and the
    caption: (name, width_mm, height_mm) as laid out. ValueError if even A0 is too small."""
    w, h = printed_size_mm(board)
    need_w, need_h = w + 2 * margin_mm, h + 2 * margin_mm + caption_mm
    for name, pw, ph in PAGES_MM:
        for sw, sh in ((pw, ph), (ph, pw)):  # portrait first
            if need_w <= sw and need_h <= sh:
                return name, sw, sh
    raise ValueError(f"{board.describe()}: the print is {w:.0f} × {h:.0f} mm, larger than an A0 sheet — "
                     f"choose a smaller square size")


def board_caption(board: BoardSpec) -> str:
    """The line printed under the board: what it is, its size and how to check the print."""
    nx, ny = board_squares(board)
    w, h = squares_size_mm(board)
    square = f"{board.square_m * 1e3:g} mm"
    return (f"{board.describe()} — {nx}×{ny} squares, {w:g} × {h:g} mm. "
            f"Print at 100 % / actual size (no 'fit to page'), then measure one square: it must be {square}.")


def default_file_stem(board: BoardSpec) -> str:
    """A file name (without suffix) naming the board, e.g. ``chessboard_9x6_25mm``."""
    if isinstance(board, ChessboardSpec):
        return f"chessboard_{board.cols}x{board.rows}_{board.square_m * 1e3:g}mm"
    return (f"charuco_{board.squares_x}x{board.squares_y}_{board.square_m * 1e3:g}mm_"
            f"{board.marker_m * 1e3:g}mm_{board.dictionary.lower()}" + ("_legacy" if board.legacy else ""))


__all__ = [
    "PRINT_DPI", "px_per_mm", "board_squares", "quiet_zone_mm", "squares_size_mm", "printed_size_mm",
    "board_print_image", "png_with_dpi", "read_png_dpi", "save_board_png", "choose_page", "board_caption",
    "default_file_stem", "PAGES_MM", "PAGE_MARGIN_MM", "CAPTION_MM",
]
