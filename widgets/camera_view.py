"""One camera's live view: the image or its disparity map, marker and object overlays, fps and a banner.

This module is the widget (``CameraView``). What it draws lives beside it: ``widgets.camera_overlays``
(the overlay records, label words, colours, the disparity colour table) and
``widgets.camera_overlay_items`` (each overlay's graphics items and where its labels go). Their
names are imported here too, so ``from widgets.camera_view import …`` keeps working.
"""
from __future__ import annotations

import math
import re
import time
from typing import Optional, Sequence

import cv2
import numpy as np
from widgets._pyqtgraph import pg
from PySide6 import QtCore, QtGui, QtWidgets

from widgets._style import TOUCH_PX, touch_button
from widgets.status import Banner

# also re-exported: the window, the hand-eye wizard, the arm twin and the tests import these from here
from widgets.camera_overlays import (
    DISPARITY_COLORMAP,
    disparity_lut,
    disparity_to_index,
    DISPLAY_MODES,
    DrawnLabel,
    FPS_STYLE,
    keep_together,
    LABEL_GAP_PX,
    LAYOUT_RETRIES,
    MARKER_ID_PT,
    marker_label,
    MarkerOverlay,
    object_label,
    OBJECT_LABEL_PT,
    ObjectOverlay,
    OVERLAY_INSET_PX,
    OVERLAY_MIN_PT,
    PLACEHOLDER_SCALE,
    same_objects,
    same_overlays,
    SMALL_FPS_SCALE,
    SMALL_MARKER_ID_PT,
    SMALL_OBJECT_LABEL_PT,
    SMALL_VIEW_PX,
    STARTING_TEXT,
)
from widgets.camera_overlay_items import (
    free_places,
    _MarkerGraphics,
    _ObjectGraphics,
    _plan_labels,
    _plan_score,
    Rect,
    _set_font_size,
    _set_visible,
    shorter_texts,
    _text_size,
)

# The fps label sits over the image: a new text repaints the image under it. While frames come
# (one drawn within FPS_WITH_FRAME_S), a new fps waits for the next frame's repaint instead of
# costing a repaint of its own (two a second per view, on a Pi 4 core ~1 ms each).
FPS_WITH_FRAME_S = 0.5


class CameraView(QtWidgets.QWidget):
    """One camera's live image (or disparity map) with marker and object overlays, fps and a banner.

    Coordinates everywhere are the raw image's pixels in the OpenCV convention (x right,
    y down, pixel centres at integers). Mouse pan/zoom and the context menu are off so taps
    are only taps. Marker and object overlays are shown in image mode only: their corners are raw-image
    pixels while the disparity map lives in the rectified image. In disparity mode the colour
    bar can carry depth labels (``set_depth_legend``) and a tapped pixel a depth probe
    (``set_probe``).

    Signals (all emitted from the GUI thread):
        sigClicked(float x_px, float y_px): the user clicked/tapped the image at that pixel
            (in disparity mode: a pixel of the rectified left view, where the window measures depth).
        sigObjectClicked(int object_id): the click was on (or within a few px of) a drawn
            object's box (emitted after sigClicked, before sigMarkerClicked).
        sigMarkerClicked(int marker_id): the click was inside a drawn marker outline
            (emitted after sigClicked).
        sigDisplayModeChanged(str mode): the user switched the toggle; "image" or "disparity".
    """

    sigClicked = QtCore.Signal(float, float)
    sigMarkerClicked = QtCore.Signal(int)
    sigObjectClicked = QtCore.Signal(int)
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
        self._frame_drawn_t = -math.inf  # time.monotonic() of the last image handed to an image item
        self._fps_pending: Optional[str] = None  # an fps text waiting for the next frame (set_fps)
        self._max_disparity = 64.0
        self._markers: list[_MarkerGraphics] = []
        self._objects: list[_ObjectGraphics] = []
        self._shown_objects: list[ObjectOverlay] = []
        self._defer_layout = False  # set_overlays: the labels are laid out once, after both kinds
        self._layout_pending = False
        self._given_objects: list[ObjectOverlay] = []  # as set, before the thresholds judged them
        self._object_thresholds = None  # per-class score thresholds (set_object_thresholds)

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
        self._fps_label.setStyleSheet(FPS_STYLE.format(padding="2px 6px"))
        self._fps_pt = self._fps_label.font().pointSizeF()
        self._fps_small: Optional[bool] = None  # the fps label's size is for a small view
        self._fps_label.setAttribute(QtCore.Qt.WidgetAttribute.WA_TransparentForMouseEvents)
        # margins, not style-sheet padding, and a bold font, not font-weight: what heightForWidth
        # and the font metrics measure is then what is drawn
        self._probe_label = QtWidgets.QLabel("", self._graphics)
        self._probe_label.setStyleSheet("QLabel { background: rgba(0,0,0,190); color: white; }")
        self._probe_label.setContentsMargins(6, 2, 6, 2)
        self._probe_label.setWordWrap(True)
        self._probe_label.setAttribute(QtCore.Qt.WidgetAttribute.WA_TransparentForMouseEvents)
        self._probe_label.hide()
        probe_font = self._probe_label.font()
        probe_font.setBold(True)
        self._probe_label.setFont(probe_font)
        self._probe_pt = probe_font.pointSizeF()  # the size it shrinks from
        # "starting cameras…" until the first image: a black view looks broken
        self._placeholder = QtWidgets.QLabel("", self._graphics)
        self._placeholder.setStyleSheet("QLabel { background: transparent; color: #e0e0e0; }")
        self._placeholder.setContentsMargins(6, 6, 6, 6)
        self._placeholder.setWordWrap(True)
        self._placeholder.setAlignment(QtCore.Qt.AlignmentFlag.AlignCenter)
        self._placeholder.setAttribute(QtCore.Qt.WidgetAttribute.WA_TransparentForMouseEvents)
        placeholder_font = self._placeholder.font()
        placeholder_font.setBold(True)
        placeholder_font.setPointSizeF(placeholder_font.pointSizeF() * PLACEHOLDER_SCALE)
        self._placeholder.setFont(placeholder_font)
        self._placeholder_pt = placeholder_font.pointSizeF()
        self._placeholder_text = ""
        self._placeholder.hide()
        self._graphics.installEventFilter(self)
        # overlays that follow the image's place on screen: the colour bar's width, a resize
        self._view_box.sigTransformChanged.connect(self._on_view_transform)

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
        self.set_placeholder(STARTING_TEXT)

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

        The array already on screen (the same object) is not drawn again. The first image
        clears the placeholder (:meth:`set_placeholder`).
        """
        if self._placeholder_text:
            self.set_placeholder("")
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
        self._frame_drawn()
        self._ensure_range(bgr.shape[0], bgr.shape[1])

    def show_disparity(self, disp_px: np.ndarray, max_disparity: float) -> None:
        """Display a float32 disparity map (px) colour-mapped over 0…max; ≤ 0 shows black.

        The first map clears the placeholder (:meth:`set_placeholder`).
        """
        if self._placeholder_text:
            self.set_placeholder("")
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
        self._frame_drawn()
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
        """Mark pixel (x, y) of the disparity map with a cross and ``text`` (shown in disparity mode).

        The text sits in the image's bottom-left corner, wrapped and if need be in a smaller
        font so it stays inside the image and off the colour bar. The same probe again is
        skipped (the window sets it on every disparity frame).
        """
        probe = (float(x_px), float(y_px), text)
        if probe == self._probe and not self.redraw_unchanged:
            return
        if self._probe is None or probe[:2] != self._probe[:2] or self.redraw_unchanged:
            self._probe_mark.setData([probe[0]], [probe[1]])
        self._probe = probe
        shown = keep_together(text)
        if shown != self._probe_label.text():
            self._probe_label.setText(shown)
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
        return "" if self._probe_label.isHidden() or self._probe is None else self._probe[2]

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
            slot.show(marker, force=self.redraw_unchanged)
            slot.set_visible(self._mode == "image")
        for slot in self._markers[len(markers):]:
            slot.hide()
        self._layout_labels()

    def set_overlays(self, markers: Sequence[MarkerOverlay], objects: Sequence[ObjectOverlay]) -> None:
        """``set_markers`` and ``set_objects`` with one label layout instead of one each (a frame
        brings both; the layout depends only on what is shown, so the labels end where two
        layouts would have put them, at half the cost)."""
        self._defer_layout = True
        try:
            self.set_markers(markers)
            self.set_objects(objects)
        finally:
            self._defer_layout = False
        if self._layout_pending:
            self._layout_labels()

    def set_object_thresholds(self, thresholds) -> None:
        """Per-class score thresholds (``core.detect.thresholds.ClassThresholds``, None: none): an
        object scoring below its class's is drawn grey and dotted, "unsure" (``ObjectOverlay.judged``);
        the objects shown now are drawn again under the new thresholds."""
        self._object_thresholds = thresholds
        if self._given_objects:
            self.set_objects(self._given_objects)

    def set_objects(self, objects: Sequence[ObjectOverlay]) -> None:
        """Draw these marker-less objects (replacing the previous ones); the same again is
        skipped. Graphics items are reused between frames (only hidden when unused)."""
        self._given_objects = list(objects)
        if self._object_thresholds is not None:
            objects = [o.judged(self._object_thresholds) for o in objects]
        if same_objects(objects, self._shown_objects) and not self.redraw_unchanged:
            return
        self._shown_objects = list(objects)
        while len(self._objects) < len(objects):
            self._objects.append(_ObjectGraphics(self._view_box))
        changed = False
        for slot, overlay in zip(self._objects, objects):
            changed |= slot.show(overlay, force=self.redraw_unchanged)
            slot.set_visible(self._mode == "image")
        for slot in self._objects[len(objects):]:
            if slot.object_id is not None:
                slot.hide()
                changed = True
        if changed:
            self._layout_labels()

    @property
    def shown_objects(self) -> list[ObjectOverlay]:
        """The object overlays last set (drawn in image mode)."""
        return list(self._shown_objects)

    def object_labels(self) -> dict[int, str]:
        """The text each drawn object's label shows, by object id ("" when there was no room
        for it): the overlay's label, or a shorter form of it in a crowded view."""
        return {slot.object_id: slot.label_text.toPlainText() if slot.label_text.isVisible() else ""
                for slot in self._objects if slot.object_id is not None and slot.outline.isVisible()}

    def drawn_labels(self) -> list[DrawnLabel]:
        """Every label drawn over the image now (marker ids, marker labels, object labels) with
        where it is in this widget and its colours (tests, screenshots)."""
        out = []
        items = [("marker id", s.marker_id, s.id_text) for s in self._markers if s.marker_id is not None]
        items += [("marker", s.marker_id, s.label_text) for s in self._markers if s.marker_id is not None]
        items += [("object", s.object_id, s.label_text) for s in self._objects if s.object_id is not None]
        for kind, key, item in items:
            if not item.isVisible():
                continue
            view_rect = self._graphics.viewportTransform().mapRect(item.sceneBoundingRect())
            rect = view_rect.translated(QtCore.QPointF(self._graphics.viewport().mapTo(self, QtCore.QPoint(0, 0))))
            out.append(DrawnLabel(kind, int(key), item.toPlainText(), rect, QtGui.QColor(item.color),
                                  QtGui.QColor(item.fill.color())))
        return out

    def object_colours(self) -> dict[int, tuple[int, int, int]]:
        """The outline colour of each drawn object, by object id (the pen's, as drawn)."""
        out = {}
        for slot in self._objects:
            if slot.object_id is not None and slot.outline.isVisible():
                c = slot.outline.opts["pen"].color()
                out[slot.object_id] = (c.red(), c.green(), c.blue())
        return out

    def object_at(self, x_px: float, y_px: float) -> Optional[int]:
        """The id of the drawn object whose box (plus a small margin) holds (x, y) px, else None;
        the smallest box wins where boxes overlap."""
        hits = [(slot.box[2] * slot.box[3], slot.object_id) for slot in self._objects
                if slot.object_id is not None and slot.contains(x_px, y_px)]
        return min(hits)[1] if hits else None

    def set_fps(self, fps: float) -> None:
        """Show the frame rate in the view's bottom-left corner (NaN or ≤ 0: "— fps").

        While frames are being drawn (one within FPS_WITH_FRAME_S) the new text is shown with
        the next frame, in the repaint that frame makes anyway; otherwise (or at the latest
        FPS_WITH_FRAME_S later) at once."""
        text = f"{fps:.1f} fps" if math.isfinite(fps) and fps > 0 else "— fps"
        if text == self._fps_label.text():
            self._fps_pending = None
            return  # no resize, no re-placing of the overlays
        if time.monotonic() - self._frame_drawn_t < FPS_WITH_FRAME_S and self.isVisible():
            if self._fps_pending is None:  # frames stopping: shown anyway, a little later
                QtCore.QTimer.singleShot(int(FPS_WITH_FRAME_S * 1000), self, self._show_pending_fps)
            self._fps_pending = text
            return
        self._show_fps(text)

    def fps_text(self) -> str:
        """The frame rate as the label shows it now, e.g. "29.9 fps"."""
        return self._fps_label.text()

    def _frame_drawn(self) -> None:
        self._frames_drawn += 1
        self._frame_drawn_t = time.monotonic()
        self._show_pending_fps()

    def _show_pending_fps(self) -> None:
        if self._fps_pending is not None:
            text, self._fps_pending = self._fps_pending, None
            self._show_fps(text)

    def _show_fps(self, text: str) -> None:
        size = self._fps_label.size()
        self._fps_label.setText(text)
        self._fps_label.adjustSize()
        if self._fps_label.size() != size:  # same size, same place: the labels keep theirs
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

    def set_placeholder(self, text: str) -> None:
        """Show ``text`` large in the middle of the view until an image comes, e.g. "starting
        cameras…" (the default) or "CAMERA MISSING — plug it in"; "" removes it.

        The first :meth:`show_image` or :meth:`show_disparity` removes it too. The text wraps
        and, in a small view, takes a smaller font, so it is never cut.
        """
        text = str(text)
        if text == self._placeholder_text:
            return
        self._placeholder_text = text
        self._placeholder.setText(text)
        self._placeholder.setVisible(bool(text))
        self._place_overlays()

    def placeholder_text(self) -> str:
        """The placeholder's text ("" when none is shown)."""
        return self._placeholder_text

    def image_rect(self) -> QtCore.QRect:
        """Where the displayed image is in the graphics view's coordinates (px), within the
        view box: the area overlay text such as the depth probe must stay in."""
        rows, cols = self._shape if self._shape is not None else (480, 640)
        image = QtCore.QRectF(-0.5, -0.5, float(cols), float(rows))
        scene = self._view_box.mapViewToScene(image).boundingRect()
        scene = scene.intersected(self._view_box.sceneBoundingRect())
        return self._scene_rect_to_graphics(scene)

    def colour_bar_rect(self) -> QtCore.QRect:
        """Where the disparity colour bar (bar and labels) is in the graphics view's
        coordinates (px); empty when it is hidden."""
        if not self._colour_bar.isVisible():
            return QtCore.QRect()
        return self._scene_rect_to_graphics(self._colour_bar.sceneBoundingRect())

    def overlay_widgets(self) -> dict[str, QtWidgets.QLabel]:
        """The text overlays (children of :attr:`graphics_view`): "probe", "placeholder",
        "fps" (for tests that measure them)."""
        return {"probe": self._probe_label, "placeholder": self._placeholder,
                "fps": self._fps_label}

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
        for slot in (*self._markers, *self._objects):
            slot.set_visible(not disparity)
        self._layout_labels()
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
        object_id = self.object_at(x_px, y_px) if self._mode == "image" else None
        if object_id is not None:
            self.sigObjectClicked.emit(object_id)
        marker_id = self.marker_at(x_px, y_px)
        if marker_id is not None:
            self.sigMarkerClicked.emit(marker_id)

    def eventFilter(self, watched: QtCore.QObject, event: QtCore.QEvent) -> bool:  # noqa: N802
        if watched is self._graphics and event.type() == QtCore.QEvent.Type.Resize:
            self._place_overlays()
        return super().eventFilter(watched, event)

    def _on_view_transform(self, *_: object) -> None:
        """The image moved or was rescaled on screen: the labels and the probe follow."""
        self._layout_labels()
        if not self._probe_label.isHidden():
            self._place_probe()

    def _scene_rect_to_graphics(self, rect: QtCore.QRectF) -> QtCore.QRect:
        viewport = self._graphics.viewport()
        polygon = self._graphics.mapFromScene(rect)  # viewport coordinates
        return polygon.boundingRect().translated(viewport.mapTo(self._graphics, QtCore.QPoint(0, 0)))

    def _place_overlays(self) -> None:
        width = self._graphics.width()
        if not self._banner.isHidden():
            height = max(TOUCH_PX - 8, self._banner.heightForWidth(width))
            self._banner.setGeometry(0, 0, width, height)
            self._banner.raise_()
        small = width < SMALL_VIEW_PX
        if small != self._fps_small:  # a small view: a smaller fps label, more room for labels
            self._fps_small = small
            self._fps_label.setStyleSheet(FPS_STYLE.format(padding="1px 3px" if small else "2px 6px"))
            font = self._fps_label.font()
            font.setPointSizeF(self._fps_pt * (SMALL_FPS_SCALE if small else 1.0))
            self._fps_label.setFont(font)
        self._fps_label.adjustSize()
        self._fps_label.move(4, self._graphics.height() - self._fps_label.height() - 4)
        self._fps_label.raise_()
        if not self._placeholder.isHidden():
            area = self._graphics.rect().adjusted(OVERLAY_INSET_PX, OVERLAY_INSET_PX,
                                                  -OVERLAY_INSET_PX, -OVERLAY_INSET_PX)
            size = _fit_text(self._placeholder, area.width(), area.height(), self._placeholder_pt)
            self._placeholder.setGeometry(QtWidgets.QStyle.alignedRect(
                QtCore.Qt.LayoutDirection.LeftToRight, QtCore.Qt.AlignmentFlag.AlignCenter,
                size, area))
            self._placeholder.raise_()
        if not self._probe_label.isHidden():
            self._place_probe()
        self._layout_labels()  # the banner and the fps label are places no label may take

    def _image_rect_of(self, widget: QtWidgets.QWidget) -> Rect:
        """Where an overlay widget (a child of the graphics view) is, in image px."""
        geometry = widget.geometry()
        offset = self._graphics.viewport().pos()
        rect = QtCore.QRectF(geometry.translated(-offset))
        view = self._view_box.mapSceneToView(self._graphics.mapToScene(rect.toRect())).boundingRect()
        return view.left(), view.top(), view.right(), view.bottom()

    def _layout_labels(self) -> None:
        """Place every marker id, marker label and object label so that none covers another,
        nor the fps label or the banner: each at the nearest free place around its thing (a
        marker's id on the marker), preferring places that cover no other thing; in a shorter
        form when no place near it is free (:func:`shorter_texts`); left out when even that
        has no room near its thing (never drawn far away, where it would name a neighbour).
        Fonts are smaller in a small view."""
        if self._defer_layout:
            self._layout_pending = True
            return
        self._layout_pending = False
        if self._mode != "image":
            return
        (x0, x1), (y0, y1) = self._view_box.viewRange()
        px_w, px_h = self._view_box.viewPixelSize()  # image px per screen px
        if not all(math.isfinite(v) and v > 0 for v in (px_w, px_h)):
            return
        markers = sorted((s for s in self._markers if s.marker_id is not None and s.outline.isVisible()),
                         key=lambda s: s.marker_id)
        objects = [s for s in self._objects if s.object_id is not None and s.outline.isVisible()]
        small = self._graphics.width() < SMALL_VIEW_PX
        object_pt = SMALL_OBJECT_LABEL_PT if small else OBJECT_LABEL_PT
        marker_pt = SMALL_MARKER_ID_PT if small else MARKER_ID_PT
        for s in markers:
            _set_font_size(s.id_text, marker_pt)
            if not s.label:
                _set_visible(s.label_text, False)
        for s in objects:
            _set_font_size(s.label_text, object_pt)
            if not s.label:
                _set_visible(s.label_text, False)
        boxes = [s.box for s in markers] + [(x, y, x + w, y + h) for x, y, w, h in (s.box for s in objects)]
        bounds = (x0, y0, x1, y1)
        taken = [self._image_rect_of(w) for w in (self._fps_label, self._banner) if not w.isHidden()]
        gap = LABEL_GAP_PX * px_w
        # (item, index of its thing in boxes, centred on it, texts to try)
        requests = [(s.id_text, k, True, [str(s.marker_id)]) for k, s in enumerate(markers)]
        requests += [(s.label_text, k, False, [s.label]) for k, s in enumerate(markers) if s.label]
        # objects: the followed one (with its position) first, then those with the fewest free
        # places near them, before the others take those
        order = []
        for k, s in enumerate(objects):
            if not s.label:
                continue
            i = len(markers) + k
            w, h = _text_size(s.label, s.label_text.textItem.font())
            free = free_places((w * px_w, h * px_h), boxes[i], bounds, taken, boxes[:i] + boxes[i + 1:], gap)
            order.append(("\n" not in s.label, free, s.object_id, s, i))
        objects_first = [(s.label_text, i, False, shorter_texts(s.label, s.object_id)) for *_, s, i in sorted(order)]
        plan, cut = _plan_labels(requests + objects_first, boxes, bounds, taken, gap, (px_w, px_h))
        # some had to say less: again with those first (and those of the tries before), the
        # best plan wins — the fewest left out, then the fewest shortened
        score, first = _plan_score(plan, cut), []
        for _ in range(LAYOUT_RETRIES):
            if not cut:
                break
            first += [r for r in objects_first if r[0] in cut and r not in first]
            again = first + [r for r in objects_first if r not in first]
            plan_b, cut = _plan_labels(requests + again, boxes, bounds, taken, gap, (px_w, px_h))
            if _plan_score(plan_b, cut) < score:
                plan, score = plan_b, _plan_score(plan_b, cut)
        for item, place in plan.items():
            if place is None:  # no room near it, not even shortened: left out rather than over another
                _set_visible(item, False)
                continue
            text, spot = place
            if item.toPlainText() != text:
                item.setText(text)
            pos = item.pos()
            if (pos.x(), pos.y()) != spot:
                item.setPos(*spot)
            _set_visible(item, True)

    def _place_probe(self) -> None:
        """The depth probe's text in the image's bottom-left corner, above the fps label,
        inside the image (never on the colour bar to its right)."""
        area = self.image_rect().adjusted(OVERLAY_INSET_PX, OVERLAY_INSET_PX,
                                          -OVERLAY_INSET_PX, -OVERLAY_INSET_PX)
        bar = self.colour_bar_rect()
        if not bar.isEmpty() and area.right() >= bar.left():
            area.setRight(bar.left() - OVERLAY_INSET_PX)
        if area.width() <= 0 or area.height() <= 0:
            return
        bottom = area.bottom() + 1
        fps = self._fps_label.geometry()
        if fps.top() < bottom and fps.right() >= area.left():  # the fps label is in the image
            above_fps = fps.top() - 2
            if above_fps - area.top() >= self._probe_label.fontMetrics().height() * 2:
                bottom = above_fps  # else the image is too short: over the fps label
        size = _fit_text(self._probe_label, area.width(), bottom - area.top(), self._probe_pt)
        y = max(area.top(), bottom - size.height())
        self._probe_label.setGeometry(area.left(), y, size.width(), size.height())
        self._probe_label.raise_()


def _fit_text(label: QtWidgets.QLabel, width: int, height: int, max_pt: float) -> QtCore.QSize:
    """Size a word-wrapped label to fit ``width`` × ``height`` px: the largest font size from
    ``max_pt`` down to OVERLAY_MIN_PT in which every word fits the width and the wrapped text
    the height. Returns the label's size (as small as its text allows)."""
    margins = label.contentsMargins()
    extra_w = margins.left() + margins.right() + 2 * label.margin()
    text = label.text()
    words = [w for w in re.split(r"[ \n]+", text) if w] or [""]  # non-breaking spaces stay
    lines = text.split("\n")
    font = QtGui.QFont(label.font())
    pt = max_pt
    while True:
        font.setPointSizeF(pt)
        metrics = QtGui.QFontMetricsF(font)
        natural = max(metrics.horizontalAdvance(line) for line in lines) + extra_w
        longest = max(metrics.horizontalAdvance(word) for word in words) + extra_w
        w = math.ceil(min(natural + 1.0, float(width)))
        if longest <= w or pt <= OVERLAY_MIN_PT:
            if label.font().pointSizeF() != pt:
                label.setFont(font)
            h = label.heightForWidth(w)
            if h <= height or pt <= OVERLAY_MIN_PT:
                return QtCore.QSize(w, min(h, height))
        pt = max(OVERLAY_MIN_PT, pt - 1.0)
