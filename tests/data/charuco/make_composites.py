"""Regenerate this folder's photos: a ChArUco pattern drawn onto the real chessboard of
``../stereo_7x5_320x240`` (8x6 squares), on the board's own plane.

The homography comes from the 35 inner corners OpenCV finds in the real photo; the pattern's
dark cells take the photo's own black level (``min(photo, pattern)``), so the lighting, blur,
noise and JPEG artefacts around and on the board stay the real camera's. Run from the project
root: ``.venv/bin/python tests/data/charuco/make_composites.py``.
"""
from pathlib import Path

import cv2
import numpy as np

HERE = Path(__file__).resolve().parent
SOURCE = HERE.parent / "stereo_7x5_320x240"
PX = 40  # pattern pixels per square before warping
DICTIONARY = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50)


def board_homography(grey):
    """Board plane (in squares, the 8x6 board's top-left outer corner at 0,0) -> image px."""
    found, corners = cv2.findChessboardCorners(grey, (7, 5))
    assert found
    corners = cv2.cornerSubPix(grey, corners, (5, 5), (-1, -1),
                               (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.01))
    plane = np.array([[(i + 1), (j + 1)] for j in range(5) for i in range(7)], np.float32)
    H, _ = cv2.findHomography(plane, corners.reshape(-1, 2))
    return H


def square_is_white(grey, H, x, y):
    p = cv2.perspectiveTransform(np.array([[[x + 0.5, y + 0.5]]], np.float32), H)[0, 0]
    return grey[int(round(p[1])), int(round(p[0]))] > 128


def paste(photo, pattern, H, origin):
    """``pattern`` (grey, PX per square) laid on the board from square ``origin``; dark = photo's black."""
    grey = cv2.cvtColor(photo, cv2.COLOR_BGR2GRAY)
    black = float(np.percentile(grey, 3))
    S = np.array([[1 / PX, 0, origin[0]], [0, 1 / PX, origin[1]], [0, 0, 1]])
    h, w = photo.shape[:2]
    warped = cv2.warpPerspective(pattern, H @ S, (w, h), flags=cv2.INTER_AREA, borderValue=255)
    warped = cv2.GaussianBlur(warped, (0, 0), 0.6).astype(np.float32)
    level = black + (255 - black) * warped / 255
    return np.minimum(photo.astype(np.float32), level[..., None]).round().astype(np.uint8)


def charuco(name):
    photo = cv2.imread(str(SOURCE / name))
    grey = cv2.cvtColor(photo, cv2.COLOR_BGR2GRAY)
    H = board_homography(grey)
    legacy = square_is_white(grey, H, 0, 0)  # OpenCV >= 4.6 boards start with a black square
    board = cv2.aruco.CharucoBoard((8, 6), 0.03, 0.022, DICTIONARY)
    board.setLegacyPattern(bool(legacy))
    return paste(photo, board.generateImage((8 * PX, 6 * PX), marginSize=0), H, (0, 0)), legacy


def diamond(name, ids=(5, 6, 7, 8)):
    photo = cv2.imread(str(SOURCE / name))
    grey = cv2.cvtColor(photo, cv2.COLOR_BGR2GRAY)
    H = board_homography(grey)
    x0 = 0 if not square_is_white(grey, H, 0, 1) else 1  # a diamond's corner squares are black
    board = cv2.aruco.CharucoBoard((3, 3), 0.03, 0.022, DICTIONARY, np.array(ids, np.int32))
    return paste(photo, board.generateImage((3 * PX, 3 * PX), marginSize=0), H, (x0, 1))


if __name__ == "__main__":
    for name in ("left01.jpg", "left05.jpg"):
        image, legacy = charuco(name)
        out = HERE / f"charuco_8x6{'_legacy' if legacy else ''}_{name}"
        cv2.imwrite(str(out), image, [cv2.IMWRITE_JPEG_QUALITY, 90])
        print(out.name)
    out = HERE / "diamond_5_6_7_8_left03.jpg"
    cv2.imwrite(str(out), diamond("left03.jpg"), [cv2.IMWRITE_JPEG_QUALITY, 90])
    print(out.name)
