"""Printable boards: true size in pixels at 300 dpi, the dpi stored in the PNG, a PDF page that
holds the board, and a print the project's own detector finds."""
import re
import struct
import zlib

import cv2
import numpy as np
import pytest

from core.vision.board_print import (
    PAGE_MARGIN_MM,
    board_caption,
    board_print_image,
    choose_page,
    default_file_stem,
    png_with_dpi,
    printed_size_mm,
    read_png_dpi,
    save_board_png,
)
from core.vision.stereo_calibration import CharucoSpec, ChessboardSpec, DetectOptions, detect_board

CHESS = ChessboardSpec(9, 6, 0.025)  # the wizard's default: 10 x 7 squares of 25 mm
CHARUCO = CharucoSpec(5, 7, 0.03, 0.022, "DICT_4X4_50")
PX_PER_MM = 300 / 25.4


def _phys_chunks(data: bytes) -> list[tuple[int, int, int]]:
    """Every pHYs chunk of a PNG, read independently of board_print's own reader."""
    out, pos = [], 8
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos:pos + 4])
        kind = data[pos + 4:pos + 8]
        body = data[pos + 8:pos + 8 + n]
        (crc,) = struct.unpack(">I", data[pos + 8 + n:pos + 12 + n])
        assert crc == zlib.crc32(kind + body) & 0xFFFFFFFF, f"bad CRC in {kind!r}"
        if kind == b"pHYs":
            out.append(struct.unpack(">IIB", body))
        pos += 12 + n
    return out


@pytest.mark.parametrize("board", [CHESS, CHARUCO], ids=["chessboard", "charuco"])
def test_the_png_has_the_boards_true_size_at_300_dpi_and_says_so(tmp_path, board):
    path = save_board_png(board, tmp_path / "board.png")
    img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    w_mm, h_mm = printed_size_mm(board)
    assert abs(img.shape[1] - w_mm * PX_PER_MM) <= 1 and abs(img.shape[0] - h_mm * PX_PER_MM) <= 1, img.shape
    # the resolution is in the file: one pHYs chunk, pixels per metre, 300 dpi
    phys = _phys_chunks(path.read_bytes())
    assert phys == [(11811, 11811, 1)]
    assert read_png_dpi(path) == pytest.approx((300.0, 300.0), abs=0.01)
    # white paper all round (the detector needs a quiet zone)
    assert (img[:5] == 255).all() and (img[-5:] == 255).all() and (img[:, :5] == 255).all()


@pytest.mark.parametrize("board", [CHESS, CHARUCO], ids=["chessboard", "charuco"])
def test_the_project_detector_finds_the_printed_board_with_squares_of_the_chosen_size(board):
    img = board_print_image(board)
    det = detect_board(img, board, DetectOptions(fast=True))
    assert det.ok and det.n == board.n_corners, det.reason
    # a square measures square_m on paper: 295.3 px at 300 dpi for 25 mm (within a pixel)
    assert det.square_px == pytest.approx(board.square_m * 1e3 * PX_PER_MM, abs=1.5)
    # and far from the image's own scale: the same at a quarter of the size, the full detector
    small = cv2.resize(img, None, fx=0.25, fy=0.25, interpolation=cv2.INTER_AREA)
    assert detect_board(small, board).ok


def test_squares_do_not_drift_along_the_board():
    img = board_print_image(ChessboardSpec(9, 6, 0.0237))  # 279.9 px a square: not a whole number
    det = detect_board(img, ChessboardSpec(9, 6, 0.0237), DetectOptions(fast=True))
    corners = det.corners.reshape(6, 9, 2)
    span = np.linalg.norm(corners[:, -1] - corners[:, 0], axis=1)  # 8 squares along each row
    assert np.allclose(span, 8 * 23.7 * PX_PER_MM, atol=1.5), span


def test_an_earlier_resolution_is_replaced_and_a_non_png_is_refused():
    ok, buf = cv2.imencode(".png", np.zeros((4, 4), np.uint8))
    once = png_with_dpi(buf.tobytes(), 72)
    twice = png_with_dpi(once, 300)
    assert _phys_chunks(twice) == [(11811, 11811, 1)]
    assert cv2.imdecode(np.frombuffer(twice, np.uint8), cv2.IMREAD_UNCHANGED).shape == (4, 4)
    with pytest.raises(ValueError, match="not a PNG"):
        png_with_dpi(b"GIF89a....", 300)


def test_the_page_is_the_smallest_a_sheet_that_holds_board_margins_and_caption():
    assert choose_page(CHESS) == ("A4", 297.0, 210.0)  # 260 x 185 mm: A4 landscape
    assert choose_page(CharucoSpec(5, 7, 0.025, 0.018)) == ("A4", 210.0, 297.0)  # portrait
    name, w, h = choose_page(ChessboardSpec(9, 6, 0.035))  # 364 x 259 mm
    assert name == "A3" and (w, h) == (420.0, 297.0)
    with pytest.raises(ValueError, match="larger than an A0 sheet — choose a smaller square size"):
        choose_page(ChessboardSpec(30, 20, 0.2))


def test_the_caption_says_how_to_check_the_print():
    text = board_caption(CHESS)
    assert "chessboard 9x6" in text and "10×7 squares" in text and "250 × 175 mm" in text
    assert "100 % / actual size" in text and "measure one square: it must be 25 mm" in text
    assert default_file_stem(CHESS) == "chessboard_9x6_25mm"
    assert default_file_stem(CHARUCO) == "charuco_5x7_30mm_22mm_dict_4x4_50"


# ------------------------------------------------------------------------------ the widget layer
def _media_box_mm(pdf: bytes) -> tuple[float, float]:
    m = re.search(rb"/MediaBox\s*\[\s*0\s+0\s+([\d.]+)\s+([\d.]+)\s*\]", pdf)
    assert m, "no /MediaBox in the PDF"
    return float(m.group(1)) * 25.4 / 72, float(m.group(2)) * 25.4 / 72


@pytest.mark.parametrize("board", [CHESS, CHARUCO, ChessboardSpec(9, 6, 0.035)], ids=["a4", "charuco", "a3"])
def test_the_pdf_page_fits_the_board_at_true_size(qapp, tmp_path, board):
    from widgets.calibration_wizard import save_printable_board

    path = save_printable_board(board, tmp_path / "board.pdf")
    data = path.read_bytes()
    assert data.startswith(b"%PDF")
    page_w, page_h = _media_box_mm(data)
    name, w, h = choose_page(board)
    assert page_w == pytest.approx(w, abs=1.0) and page_h == pytest.approx(h, abs=1.0)
    board_w, board_h = printed_size_mm(board)
    assert board_w + 2 * PAGE_MARGIN_MM <= page_w and board_h + 2 * PAGE_MARGIN_MM <= page_h


def test_save_printable_board_writes_a_png_qt_reads_at_300_dpi_and_refuses_other_types(qapp, tmp_path):
    from PySide6 import QtGui

    from widgets.calibration_wizard import save_printable_board

    path = save_printable_board(CHARUCO, tmp_path / "board.PNG")
    image = QtGui.QImage(str(path))
    assert not image.isNull() and image.dotsPerMeterX() == 11811 and image.dotsPerMeterY() == 11811
    with pytest.raises(ValueError, match=r"name it \.pdf \(true size\) or \.png \(300 dpi\)"):
        save_printable_board(CHESS, tmp_path / "board.jpg")
    with pytest.raises(OSError, match="no such folder"):
        save_printable_board(CHESS, tmp_path / "missing" / "board.pdf")
