"""One camera's live view: the image or its disparity map, marker overlays, fps and a banner."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

import cv2
import numpy as np
import pyqtgraph as pg
from PySide6 import QtCore, QtGui, QtWidgets

from core.messages import MarkerObservation
from widgets._style import TOUCH_PX, touch_button
from widgets.status import Banner

DISPLAY_MODES = ("image", "disparity")
DISPARITY_COLORMAP = "turbo"
FOUND_COLOUR = (40, 220, 60)
LOST_COLOUR = (255, 150, 0)


@dataclass(frozen=True, eq=False)
class MarkerOverlay:
    """What to draw for one marker in one camera image.

    ``corners`` are the marker's 4 corners in this camera's raw image (pixels, OpenCV
    convention: pixel centres at integer coordinates). ``found`` False means the corners are a
    prediction or the last known position (drawn dashed orange). ``label`` is free text, e.g.
    "23: x 3.1 y 15.2 z 0.0 cm".
    """

    marker_id: int
    corners: np.ndarray  # (4, 2) px
    found: bool = True
    label: str = ""

    def __post_init__(self) -> None:
        corners = np.asarray(self.corners, dtype=float)
        if corners.shape != (4, 2):
            raise ValueError(f"MarkerOverlay.corners has shape {corners.shape}; expected (4, 2)")
        object.__setattr__(self, "corners", corners)

    @classmethod
    def from_observation(cls, obs: MarkerObservation, side: str = "left",
                         label: Optional[str] = None) -> Optional["MarkerOverlay"]:
        """The overlay of a perception observation in the ``side`` ("left"/"right") image.

        Returns None when the marker has no corners in that image. Without ``label``, the label
        is the id plus the robot_base position in cm when known.
        """
        corners = obs.left_corners if side == "left" else obs.right_corners
        if len(corners) != 4:
            return None
        if label is None:
            label = marker_label(obs.marker_id, obs.base_p_centre)
        return cls(obs.marker_id, np.asarray(corners, dtype=float), obs.found, label)


def same_overlays(a: Sequence[MarkerOverlay], b: Sequence[MarkerOverlay]) -> bool:
    """True when two overlay lists draw the same: ids, corners, found and labels, in order."""
    return len(a) == len(b) and all(
        x is y or (x.marker_id == y.marker_id and x.found == y.found and x.label == y.label
                   and np.array_equal(x.corners, y.corners))
        for x, y in zip(a, b))


def marker_label(marker_id: int, base_p: Optional[Sequence[float]]) -> str:
    """"23: x 3.1 y 15.2 z 0.0 cm" from a position in metres (just "23" when unknown)."""
    if base_p is None:
        return str(marker_id)
    x_cm, y_cm, z_cm = (round(100.0 * float(v), 1) + 0.0 for v in base_p)  # + 0.0: no "-0.0"
    return f"{marker_id}: x {x_cm:.1f} y {y_cm:.1f} z {z_cm:.1f} cm"


def disparity_to_index(disp_px: np.ndarray, max_disparity: float) -> np.ndarray:
    """Map disparities to uint8 colour-table indices: ≤ 0 or NaN → 0 (black), (0, max] → 1…255."""
    disp = np.asarray(disp_px, dtype=np.float32)
    scale = 254.0 / max(float(max_disparity), 1e-6)
    # saturating |d·scale + 1| in one OpenCV pass (~0.06 ms at 640×480, 7× numpy), then zero
    # the invalid pixels: NaN > 0 is False, so NaN ends up black too
    index = cv2.convertScaleAbs(disp, alpha=scale, beta=1.0)
    np.multiply(index, disp > 0, out=index)
    return index


def disparity_lut() -> np.ndarray:
    """The (256, 3) colour table used by :func:`disparity_to_index`: black, then the colormap."""
    cmap = pg.colormap.get(DISPARITY_COLORMAP)
    table = cmap.getLookupTable(nPts=255, alpha=False).astype(np.uint8)
    return np.vstack([np.zeros((1, 3), np.uint8), table])


class _MarkerGraphics:
    """The reusable graphics items of one marker slot (outline, id, label)."""

    def __init__(self, view_box: pg.ViewBox) -> None:
        self.outline = pg.PlotCurveItem(antialias=True)
        self.id_text = pg.TextItem(anchor=(0.5, 0.5), color="w", fill=pg.mkBrush(0, 0, 0, 150))
        font = QtGui.QFont()
        font.setPointSize(12)
        font.setBold(True)
        self.id_text.setFont(font)
        self.label_text = pg.TextItem(anchor=(0.5, 1.0), color="w",
                                      fill=pg.mkBrush(0, 0, 0, 150))
        for item in (self.outline, self.id_text, self.label_text):
            item.setZValue(10)
            view_box.addItem(item, ignoreBounds=True)
        self.marker_id: Optional[int] = None
        self.polygon = QtGui.QPolygonF()
        self._found: Optional[bool] = None  # the outline's pen and the id's colour are for this

    def show(self, m: MarkerOverlay) -> None:
        closed = np.vstack([m.corners, m.corners[:1]])
        colour = FOUND_COLOUR if m.found else LOST_COLOUR
        if m.found != self._found:  # a marker moving in view: only its place changes
            style = QtCore.Qt.PenStyle.SolidLine if m.found else QtCore.Qt.PenStyle.DashLine
            self.outline.setPen(pg.mkPen(colour, width=3, style=style))
            self.id_text.setColor(colour)
            self._found = m.found
        self.outline.setData(closed[:, 0], closed[:, 1])
        centre = m.corners.mean(axis=0)
        if m.marker_id != self.marker_id:
            self.id_text.setText(str(m.marker_id))
        self.id_text.setPos(float(centre[0]), float(centre[1]))
        if m.label != self.label_text.toPlainText():
            self.label_text.setText(m.label)
        if m.label:  # small views show ids only: no label to place
            top = m.corners[np.argmin(m.corners[:, 1])]  # smallest row = highest on screen
            self.label_text.setPos(float(centre[0]), float(top[1]) - 2.0)
        _set_visible(self.label_text, bool(m.label))
        self.outline.setVisible(True)
        _set_visible(self.id_text, True)
        self.marker_id = m.marker_id
        self.polygon = QtGui.QPolygonF([QtCore.QPointF(float(x), float(y)) for x, y in m.corners])

    def hide(self) -> None:
        for item in (self.outline, self.id_text, self.label_text):
            item.setVisible(False)
        self.marker_id = None
        self.polygon = QtGui.QPolygonF()

    def set_visible(self, visible: bool) -> None:
        if self.marker_id is None:
            return
        self.outline.setVisible(visible)
        _set_visible(self.id_text, visible)
        _set_visible(self.label_text, visible and bool(self.label_text.toPlainText()))


def _set_visible(item: pg.TextItem, visible: bool) -> None:
    """TextItem.setVisible(True) re-computes the item's transform even when it is shown: skip
    it when the visibility does not change (every frame of a moving marker)."""
    if item.isVisible() != visible:
        item.setVisible(visible)


class CameraView(QtWidgets.QWidget):
    """One camera's live image (or disparity map) with marker overlays, fps and a banner.

    Coordinates everywhere are the raw image's pixels in the OpenCV convention (x right,
    y down, pixel centres at integers). Mouse pan/zoom and the context menu are off so taps
    are only taps. Marker overlays are shown in image mode only: their corners are raw-image
    pixels while the disparity map lives in the rectified image. In disparity mode the colour
    bar can carry depth labels (``set_depth_legend``) and a tapped pixel a depth probe
    (``set_probe``).

    Signals (all emitted from the GUI thread):
        sigClicked(float x_px, float y_px): the user clicked/tapped the image at that pixel
            (in disparity mode: a pixel of the rectified left view, where the window measures depth).
        sigMarkerClicked(int marker_id): the click was inside a drawn marker outline
            (emitted after sigClicked).
        sigDisplayModeChanged(str mode): the user switched the toggle; "image" or "disparity".
    """

    sigClicked = QtCore.Signal(float, float)
    sigMarkerClicked = QtCore.Signal(int)
    sigDisplayModeChanged = QtCore.Signal(str)

    # True: show_image/show_disparity/set_markers redraw even what is already shown (the
    # window's redraw-all mode, the baseline of bench/bench_window.py). False: the very array
    # already on screen, or the same overlays, are not set again.
    redraw_unchanged = False

    def __init__(self, title: str = "Left", parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._mode = "image"
        self._shape: Optional[tuple[int, int]] = None  # (rows, cols) of what is displayed
        self._last_image: Optional[np.ndarray] = None
        self._last_disparity: Optional[tuple[np.ndarray, float]] = None
        # what the image items show now: a source re-delivers the very same array for a
        # frame that did not change, so identity (no pixel hashing) tells a frame to skip
        self._shown_image: Optional[np.ndarray] = None
        self._shown_disparity: Optional[tuple[np.ndarray, float]] = None
        self._shown_overlays: list[MarkerOverlay] = []
        self._frames_drawn = 0
        self._max_disparity = 64.0
        self._markers: list[_MarkerGraphics] = []

        self._title = QtWidgets.QLabel(title)
        font = self._title.font()
        font.setBold(True)
        font.setPointSizeF(font.pointSizeF() * 1.25)
        self._title.setFont(font)
        self.toggle_button = touch_button("Disparity", checkable=True)
        self.toggle_button.setToolTip("Image / Disparity: show the camera image or the "
                                      "stereo disparity map")
        self.toggle_button.toggled.connect(self._on_toggled)

        self._graphics = pg.GraphicsLayoutWidget()
        self._graphics.setMinimumSize(160, 120)
        self._graphics.ci.setContentsMargins(0, 0, 0, 0)
        self._view_box = self._graphics.addViewBox(row=0, col=0, lockAspect=True, invertY=True,
                                                   enableMouse=False, enableMenu=False)
        self._view_box.disableAutoRange()
        self._view_box.setDefaultPadding(0.0)
        # Shift by half a pixel so view coordinates are OpenCV pixel coordinates.
        self._image_item = pg.ImageItem()
        self._disparity_item = pg.ImageItem()
        for item in (self._image_item, self._disparity_item):
            item.setPos(-0.5, -0.5)
            self._view_box.addItem(item)
        self._disparity_item.setLookupTable(disparity_lut())
        self._disparity_item.setVisible(False)
        self._colour_bar = pg.ColorBarItem(values=(0.0, self._max_disparity),
                                           colorMap=DISPARITY_COLORMAP,
                                           interactive=False, width=14, colorMapMenu=False)
        self._colour_bar.setContentsMargins(0, 14, 0, 14)  # room for the end marks' labels
        self._graphics.addItem(self._colour_bar, row=0, col=1)
        self._colour_bar.setVisible(False)
        # the depth probe: a cross at the tapped pixel (in the scene) and its depth as an overlay
        # label (a scene text would be scaled with a small view and run out of it)
        self._probe_mark = pg.ScatterPlotItem(size=26, symbol="+", pen=pg.mkPen("k", width=1.5),
                                              brush=pg.mkBrush("w"))
        self._probe_mark.setZValue(20)
        self._probe_mark.setVisible(False)
        self._view_box.addItem(self._probe_mark, ignoreBounds=True)
        self._probe: Optional[tuple[float, float, str]] = None
        self._legend: list[tuple[float, str]] = []
        self._graphics.scene().sigMouseClicked.connect(self._on_scene_clicked)

        # Overlays are child widgets of the graphics view, placed on resize.
        self._banner = Banner(self._graphics)
        self._fps_label = QtWidgets.QLabel("— fps", self._graphics)
        self._fps_label.setStyleSheet("QLabel { background: rgba(0,0,0,150); color: white;"
                                      " padding: 2px 6px; }")
        self._fps_label.setAttribute(QtCore.Qt.WidgetAttribute.WA_TransparentForMouseEvents)
        self._probe_label = QtWidgets.QLabel("", self._graphics)
        self._probe_label.setStyleSheet("QLabel { background: rgba(0,0,0,190); color: white;"
                                        " font-weight: bold; padding: 2px 6px; }")
        self._probe_label.setAttribute(QtCore.Qt.WidgetAttribute.WA_TransparentForMouseEvents)
        self._probe_label.hide()
        self._graphics.installEventFilter(self)

        header = QtWidgets.QHBoxLayout()
        header.setContentsMargins(4, 0, 0, 0)
        header.addWidget(self._title)
        header.addStretch(1)
        header.addWidget(self.toggle_button)
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(2)
        layout.addLayout(header)
        layout.addWidget(self._graphics, 1)
        self._set_range(480, 640)

    # ----------------------------------------------------------------------------- public API
    @property
    def display_mode(self) -> str:
        """"image" or "disparity"."""
        return self._mode

    @property
    def title(self) -> str:
        """The view's title ("Left", "Right")."""
        return self._title.text()

    def set_title(self, title: str) -> None:
        """Change the title shown above the image."""
        self._title.setText(title)

    def set_display_mode(self, mode: str) -> None:
        """Show "image" or "disparity" without emitting sigDisplayModeChanged."""
        if mode not in DISPLAY_MODES:
            raise ValueError(f"display mode {mode!r}; allowed: {', '.join(DISPLAY_MODES)}")
        blocked = self.toggle_button.blockSignals(True)
        self.toggle_button.setChecked(mode == "disparity")
        self.toggle_button.blockSignals(blocked)
        self._apply_mode(mode)

    @property
    def frames_drawn(self) -> int:
        """How many images (camera or disparity) were handed to the image items so far."""
        return self._frames_drawn

    def show_image(self, bgr: np.ndarray) -> None:
        """Display a BGR, BGRA or grey uint8 image (kept to re-show after disparity mode).

        The array already on screen (the same object) is not drawn again.
        """
        self._last_image = bgr
        if self._mode != "image":
            return
        if bgr is self._shown_image and not self.redraw_unchanged:
            return
        # cv2 swaps channels in ~0.1 ms; a reversed numpy view makes pyqtgraph copy slowly
        if bgr.ndim == 3 and bgr.shape[2] == 3:
            rgb = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
        elif bgr.ndim == 3 and bgr.shape[2] == 4:
            rgb = cv2.cvtColor(bgr, cv2.COLOR_BGRA2RGBA)
        else:
            rgb = bgr
        # no levels: a uint8 image then becomes a QImage as is; levels=(0, 255) made
        # pyqtgraph rescale every pixel (~0.6 ms a frame at 640x480)
        self._image_item.setImage(rgb, autoLevels=False)
        self._shown_image = bgr
        self._frames_drawn += 1
        self._ensure_range(bgr.shape[0], bgr.shape[1])

    def show_disparity(self, disp_px: np.ndarray, max_disparity: float) -> None:
        """Display a float32 disparity map (px) colour-mapped over 0…max; ≤ 0 shows black."""
        self._last_disparity = (disp_px, max_disparity)
        if max_disparity != self._max_disparity:
            self._max_disparity = float(max_disparity)
            self._colour_bar.setLevels((0.0, self._max_disparity))
        if self._mode != "disparity":
            return
        shown = self._shown_disparity
        if (shown is not None and shown[0] is disp_px and shown[1] == max_disparity
                and not self.redraw_unchanged):
            return
        index = disparity_to_index(disp_px, max_disparity)
        self._disparity_item.setImage(index, autoLevels=False, levels=(0, 255))
        self._shown_disparity = (disp_px, max_disparity)
        self._frames_drawn += 1
        self._ensure_range(index.shape[0], index.shape[1])

    def set_depth_legend(self, ticks: Sequence[tuple[float, str]]) -> None:
        """Label the disparity colour bar: (disparity px, text) marks, e.g. (32.0, "32 px\n41 cm")."""
        self._legend = [(float(d), str(t)) for d, t in ticks]
        self._colour_bar.axis.setTicks([self._legend])
        self._colour_bar.axis.setWidth(58 if any("\n" in str(t) for _, t in ticks) else 45)

    @property
    def depth_legend(self) -> list[tuple[float, str]]:
        """The colour bar's marks as last set by :meth:`set_depth_legend`."""
        return list(self._legend)

    def set_probe(self, x_px: float, y_px: float, text: str) -> None:
        """Mark pixel (x, y) of the disparity map with a cross and ``text`` (shown in disparity mode)."""
        self._probe = (float(x_px), float(y_px), text)
        self._probe_mark.setData([float(x_px)], [float(y_px)])
        self._probe_label.setText(text)
        self._update_probe_visibility()

    def clear_probe(self) -> None:
        """Remove the depth probe."""
        self._probe = None
        self._update_probe_visibility()

    @property
    def probe(self) -> Optional[tuple[float, float, str]]:
        """(x px, y px, text) of the depth probe, or None."""
        return self._probe

    def probe_text(self) -> str:
        """The depth probe's text as shown ("" when hidden)."""
        return "" if self._probe_label.isHidden() else self._probe_label.text()

    def _update_probe_visibility(self) -> None:
        visible = self._probe is not None and self._mode == "disparity"
        self._probe_mark.setVisible(visible)
        self._probe_label.setVisible(visible)
        self._place_overlays()

    def set_markers(self, markers: Sequence[MarkerOverlay]) -> None:
        """Draw these marker outlines (replacing the previous ones); the same again is skipped."""
        if same_overlays(markers, self._shown_overlays) and not self.redraw_unchanged:
            return
        self._shown_overlays = list(markers)
        while len(self._markers) < len(markers):
            self._markers.append(_MarkerGraphics(self._view_box))
        for slot, marker in zip(self._markers, markers):
            slot.show(marker)
            slot.set_visible(self._mode == "image")
        for slot in self._markers[len(markers):]:
            slot.hide()

    def set_fps(self, fps: float) -> None:
        """Show the frame rate in the view's bottom-left corner (NaN or ≤ 0: "— fps")."""
        text = f"{fps:.1f} fps" if math.isfinite(fps) and fps > 0 else "— fps"
        if text == self._fps_label.text():
            return  # no resize, no re-placing of the overlays
        self._fps_label.setText(text)
        self._fps_label.adjustSize()
        self._place_overlays()

    def set_banner(self, text: Optional[str], level: str = "warn") -> None:
        """Show a coloured banner over the top of the image; None or "" removes it."""
        if text:
            self._banner.show_message(text, level)
        else:
            self._banner.clear()
        self._place_overlays()

    def banner_text(self) -> str:
        """The banner's text ("" when hidden)."""
        return "" if self._banner.isHidden() else self._banner.text()

    def marker_at(self, x_px: float, y_px: float) -> Optional[int]:
        """The id of the drawn marker whose outline contains (x, y) px, else None."""
        point = QtCore.QPointF(x_px, y_px)
        for slot in reversed(self._markers):  # last drawn is on top
            if slot.marker_id is not None and slot.outline.isVisible() and \
                    slot.polygon.containsPoint(point, QtCore.Qt.FillRule.OddEvenFill):
                return slot.marker_id
        return None

    def image_to_widget(self, x_px: float, y_px: float) -> QtCore.QPoint:
        """Where image pixel (x, y) is in this widget's coordinates (tests, overlays)."""
        scene_pos = self._view_box.mapViewToScene(QtCore.QPointF(x_px, y_px))
        view_pos = self._graphics.mapFromScene(scene_pos)
        return self._graphics.viewport().mapTo(self, view_pos)

    @property
    def graphics_view(self) -> pg.GraphicsView:
        """The pyqtgraph view (tests send mouse events to its viewport)."""
        return self._graphics

    def sizeHint(self) -> QtCore.QSize:  # noqa: N802 (Qt override)
        """A 320×240 image plus the header; pyqtgraph's own hint is far larger."""
        return QtCore.QSize(320, 240 + TOUCH_PX + 4)

    # ----------------------------------------------------------------------------- internals
    def _on_toggled(self, checked: bool) -> None:
        mode = "disparity" if checked else "image"
        self._apply_mode(mode)
        self.sigDisplayModeChanged.emit(mode)

    def _apply_mode(self, mode: str) -> None:
        if mode == self._mode:
            return
        self._mode = mode
        disparity = mode == "disparity"
        self._image_item.setVisible(not disparity)
        self._disparity_item.setVisible(disparity)
        self._colour_bar.setVisible(disparity)
        for slot in self._markers:
            slot.set_visible(not disparity)
        self._update_probe_visibility()
        if disparity and self._last_disparity is not None:
            self.show_disparity(*self._last_disparity)
        elif not disparity and self._last_image is not None:
            self.show_image(self._last_image)

    def _ensure_range(self, rows: int, cols: int) -> None:
        if self._shape != (rows, cols):
            self._set_range(rows, cols)

    def _set_range(self, rows: int, cols: int) -> None:
        # Fixed range, set only when the image size changes: no auto-range per frame.
        self._shape = (rows, cols)
        self._view_box.setRange(xRange=(-0.5, cols - 0.5), yRange=(-0.5, rows - 0.5),
                                padding=0.0)

    def _on_scene_clicked(self, event) -> None:
        if event.button() != QtCore.Qt.MouseButton.LeftButton:
            return
        if not self._view_box.sceneBoundingRect().contains(event.scenePos()):
            return  # on the colour bar, not the image
        pos = self._view_box.mapSceneToView(event.scenePos())
        x_px, y_px = float(pos.x()), float(pos.y())
        self.sigClicked.emit(x_px, y_px)
        marker_id = self.marker_at(x_px, y_px)
        if marker_id is not None:
            self.sigMarkerClicked.emit(marker_id)

    def eventFilter(self, watched: QtCore.QObject, event: QtCore.QEvent) -> bool:  # noqa: N802
        if watched is self._graphics and event.type() == QtCore.QEvent.Type.Resize:
            self._place_overlays()
        return super().eventFilter(watched, event)

    def _place_overlays(self) -> None:
        width = self._graphics.width()
        if not self._banner.isHidden():
            height = max(TOUCH_PX - 8, self._banner.heightForWidth(width))
            self._banner.setGeometry(0, 0, width, height)
            self._banner.raise_()
        self._fps_label.adjustSize()
        self._fps_label.move(4, self._graphics.height() - self._fps_label.height() - 4)
        self._fps_label.raise_()
        if not self._probe_label.isHidden():
            self._probe_label.setMaximumWidth(max(60, width - 8))
            self._probe_label.adjustSize()
            # bottom-left above the fps label: clear of the colour bar on the right
            y = self._fps_label.y() - self._probe_label.height() - 2
            self._probe_label.move(4, max(0, y))
            self._probe_label.raise_()
