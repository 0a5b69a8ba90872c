"""The Objects tab: which marker-less object detectors run, and their settings, changed live.

ArUco markers are found by the marker perception on every frame whatever runs here: the tab
says so at the top, and the "aruco" detector's toggle reads "markers as objects" — what it adds
is the markers in the objects' list too, not marker detection (an "aruco" toggle left off while
the views outline markers read as "markers are off").

Detectors are switched on and off with finger-sized toggles (every name the detector registry
knows, plus a user's ONNX model chosen with a file dialog). One detector's settings are shown at
a time ("Settings of"): the HSV detector's named colours (add, rename, remove, pick from a camera
view) with low/high hue, saturation and value, morphology and minimum area; the Hough circles'
dp, minimum distance, param1/param2 and radius range; a learned detector's confidence and NMS
overlap. The panel never builds a detector: it describes what it wants as a list of
(registry name, {settings field: value}) and the perception worker builds or re-tunes them
(``with_params``), reporting back what runs (``set_running``) and what failed (``set_message``).

Signals (GUI thread):
    sigDetectorsChanged(object): the wanted detectors, a list of (name, options dict), after a
        toggle (at once) or a slider (coalesced, at most one per THROTTLE_MS); [] = all off.
    sigPickToggled(bool): "Pick colour" was switched on (the next tap on a camera view is a
        colour sample: the window calls ``add_picked_colour``) or off.
    sigThresholdsChanged(object): the per-class score thresholds ("Sure above", a
        ``core.detect.thresholds.ClassThresholds``) after the user moved the slider: an object
        scoring below its class's is unsure — drawn grey, never followed.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, replace
from typing import Any, Optional, Sequence

from PySide6 import QtCore, QtWidgets

from core.detect.circles import CircleParams
from core.detect.colour import HUE_MAX, HsvParams, HsvRange
from core.detect.thresholds import ClassThresholds
from core.settings import SettingsError
from widgets._style import (
    ERROR_COLOUR,
    OK_COLOUR,
    TOUCH_PX,
    Coalescer,
    touch_button,
    touch_combo,
    touch_slider,
)
from widgets.file_dialog import open_file_dialog

THROTTLE_MS = 80  # a dragged slider re-tunes the detector at most this often
HORIZONTAL = QtCore.Qt.Orientation.Horizontal
ONNX = "onnx"  # the registry prefix of a user's model file ("onnx:PATH")
HSV, CIRCLES, ARUCO = "hsv", "circles", "aruco"
TOGGLE_COLUMNS = 3
ONNX_TEXT_CHARS = 10  # a model file's toggle shows this much of its name (the tooltip has the path)
LEARNED_DEFAULTS = {"score_threshold": 0.25, "nms_iou": 0.45}  # OnnxYoloParams' defaults
MARKERS_ON_TEXT = "✓ ArUco markers: on, in every frame (Markers tab)"
TOGGLE_TEXTS = {ARUCO: "markers as objects"}  # a detector's toggle when its name would mislead
LEARNED_CLASSES, OTHER_CLASSES = "*learned", "*other"  # the threshold combo's two default rows (data)
THRESHOLD_DEFAULT_TEXTS = {LEARNED_CLASSES: "any learned class", OTHER_CLASSES: "any colour or circle"}


@dataclass(frozen=True)
class _Slider:
    field: str  # settings dataclass field
    label: str  # what the user reads
    lo: float
    hi: float
    step: float = 1.0
    decimals: int = 0  # 0: a whole-number slider


HSV_CHANNELS = (("H", "h", HUE_MAX), ("S", "s", 255), ("V", "v", 255))  # label, field prefix, max
HSV_SHAPE = (
    _Slider("open_px", "Open (px)", 0, 31),
    _Slider("close_px", "Close (px)", 0, 31),
    _Slider("min_area_px", "Min area (px²)", 0, 5000, 10),
)
CIRCLE_SLIDERS = (
    _Slider("min_aspect", "Roundness (minor/major)", 0.05, 1.0, 0.05, 2),
    _Slider("min_score", "Edge support", 0.0, 1.0, 0.01, 2),
    _Slider("param1", "param1 (edges)", 1, 500),
    _Slider("dp", "dp (Hough)", 1.0, 4.0, 0.1, 1),
    _Slider("min_dist_px", "Min distance (px, Hough)", 1, 400),
    _Slider("param2", "param2 (votes, Hough)", 1, 200),
    _Slider("min_radius_px", "Min radius (px)", 0, 200),
    _Slider("max_radius_px", "Max radius (px, 0 = any)", 0, 400),
)
LEARNED_SLIDERS = (
    _Slider("score_threshold", "Confidence", 0.0, 1.0, 0.01, 2),
    _Slider("nms_iou", "NMS overlap", 0.0, 1.0, 0.01, 2),
)


def available_detectors() -> tuple[list[str], list[str]]:
    """(plain names, prefixes) the detector registry accepts now: ["aruco", "hsv", "circles",
    …] and ["onnx"] (a prefix takes an argument, e.g. "onnx:PATH")."""
    from core.detect import registry

    names = registry.detector_names() if hasattr(registry, "detector_names") else registry.DETECTORS
    plain = [n for n in names if ":" not in n]
    prefixes = [n.split(":", 1)[0] for n in names if ":" in n]
    return plain, prefixes


class ValueSlider(QtWidgets.QWidget):
    """A finger-sized slider with its value written beside it (a label, not a tiny edit box).

    Whole numbers, or ``decimals`` places on an integer slider scaled by 10^decimals.

    Signals (GUI thread):
        valueChanged(float): the user moved the slider (not on ``setValue``).
    """

    valueChanged = QtCore.Signal(float)

    def __init__(self, spec: _Slider, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._scale = 10 ** spec.decimals
        self._decimals = spec.decimals
        self.slider = QtWidgets.QSlider(HORIZONTAL)
        self.slider.setRange(round(spec.lo * self._scale), round(spec.hi * self._scale))
        self.slider.setSingleStep(max(1, round(spec.step * self._scale)))
        self.slider.setPageStep(max(1, round(spec.step * self._scale)) * 10)
        touch_slider(self.slider)
        self.value_label = QtWidgets.QLabel()
        self.value_label.setAlignment(QtCore.Qt.AlignmentFlag.AlignRight | QtCore.Qt.AlignmentFlag.AlignVCenter)
        widest = max((self._text(spec.lo), self._text(spec.hi)), key=len)
        self.value_label.setMinimumWidth(self.value_label.fontMetrics().horizontalAdvance(widest) + 4)
        row = QtWidgets.QHBoxLayout(self)
        row.setContentsMargins(0, 0, 0, 0)
        row.setSpacing(4)
        row.addWidget(self.slider, 1)
        row.addWidget(self.value_label)
        self.slider.valueChanged.connect(self._moved)
        self._moved(self.slider.value(), emit=False)

    def _text(self, value: float) -> str:
        return f"{value:.{self._decimals}f}" if self._decimals else str(int(round(value)))

    def value(self) -> float:
        """The value shown (a whole number when the slider has no decimals)."""
        v = self.slider.value() / self._scale
        return round(v, self._decimals) if self._decimals else int(self.slider.value())

    def setValue(self, value: float) -> None:  # noqa: N802 (Qt style, as QSlider)
        """Show ``value`` (clamped to the range) without emitting valueChanged."""
        blocked = self.slider.blockSignals(True)
        self.slider.setValue(round(float(value) * self._scale))
        self.slider.blockSignals(blocked)
        self._moved(self.slider.value(), emit=False)

    def _moved(self, _raw: int, emit: bool = True) -> None:
        self.value_label.setText(self._text(self.value()))
        if emit:
            self.valueChanged.emit(float(self.value()))


def _row_label(text: str) -> QtWidgets.QLabel:
    label = QtWidgets.QLabel(text)
    label.setMinimumHeight(TOUCH_PX)
    label.setWordWrap(True)
    return label


def _set_quietly(widget, value) -> None:
    blocked = widget.blockSignals(True)
    widget.setValue(value)
    widget.blockSignals(blocked)


class DetectorPanel(QtWidgets.QWidget):
    """Detector toggles and the chosen detector's settings (see the module docstring)."""

    sigDetectorsChanged = QtCore.Signal(object)
    sigPickToggled = QtCore.Signal(bool)
    sigThresholdsChanged = QtCore.Signal(object)

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._plain, self._prefixes = available_detectors()
        self._enabled: list[str] = []  # spec names, in the order they were switched on
        self._hsv = HsvParams()
        self._circles = CircleParams()
        self._learned: dict[str, dict[str, float]] = {}  # name -> confidence / NMS
        self._onnx_path: Optional[str] = None
        self._colour_index = 0
        self._coalescer = Coalescer(THROTTLE_MS, self._emit_now, self)
        self._last_sent: Optional[list] = None
        self._thresholds = ClassThresholds()
        self._class_kinds: dict[str, str] = {}  # class label -> its detector's kind (for its default)

        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.setSpacing(4)

        # markers: always on (the marker perception), whatever the toggles below say
        self.markers_label = QtWidgets.QLabel(MARKERS_ON_TEXT)
        self.markers_label.setWordWrap(True)
        self.markers_label.setStyleSheet(f"QLabel {{ color: {OK_COLOUR}; font-weight: bold; }}")
        self.markers_label.setToolTip("The marker perception finds the ArUco markers in both views on every "
                                      "frame; the Target tab follows them and the Markers tab lists them")
        layout.addWidget(self.markers_label)

        # --- detector toggles (first: what the user comes here for)
        toggles = QtWidgets.QGridLayout()
        toggles.setSpacing(2)
        self.toggles: dict[str, QtWidgets.QPushButton] = {}
        for index, name in enumerate(self._plain):
            button = touch_button(TOGGLE_TEXTS.get(name, name), checkable=True)
            button.setToolTip(f"run the {name} detector on both camera views" if name != ARUCO else
                              "list the ArUco markers among the objects too (Object mode can follow them); "
                              "the markers are found either way")
            button.toggled.connect(lambda on, n=name: self._on_toggle(n, on))
            toggles.addWidget(button, index // TOGGLE_COLUMNS, index % TOGGLE_COLUMNS)
            self.toggles[name] = button
        self.onnx_button: Optional[QtWidgets.QPushButton] = None
        self.onnx_toggle: Optional[QtWidgets.QPushButton] = None
        if ONNX in self._prefixes:  # in the same grid: a model file is one more detector
            index = len(self._plain)
            self.onnx_button = touch_button("ONNX file…")
            self.onnx_button.setToolTip("choose a YOLO model exported to ONNX (v5, v8/v11 or end-to-end)")
            self.onnx_button.clicked.connect(self.choose_onnx_file)
            toggles.addWidget(self.onnx_button, index // TOGGLE_COLUMNS, index % TOGGLE_COLUMNS)
            index += 1
            self.onnx_toggle = touch_button("onnx", checkable=True)
            self.onnx_toggle.hide()  # until a file is chosen
            self.onnx_toggle.toggled.connect(self._on_onnx_toggle)
            toggles.addWidget(self.onnx_toggle, index // TOGGLE_COLUMNS, index % TOGGLE_COLUMNS)
        for col in range(TOGGLE_COLUMNS):
            toggles.setColumnStretch(col, 1)
        layout.addLayout(toggles)

        self.message_label = QtWidgets.QLabel("")
        self.message_label.setWordWrap(True)
        self.message_label.hide()
        layout.addWidget(self.message_label)

        # --- per-class score thresholds: below its class's, an object is unsure (grey, not followed)
        sure = QtWidgets.QHBoxLayout()
        sure.setSpacing(4)
        sure.addWidget(QtWidgets.QLabel("Sure above"))
        self.class_combo = touch_combo(QtWidgets.QComboBox())
        self.class_combo.setObjectName("threshold_class_combo")
        self.class_combo.setToolTip("the class whose threshold the slider sets; classes are added as they are seen")
        for data, text in THRESHOLD_DEFAULT_TEXTS.items():
            self.class_combo.addItem(text, data)
        self.class_combo.currentIndexChanged.connect(self._show_threshold)
        sure.addWidget(self.class_combo, 1)
        self.threshold_slider = ValueSlider(_Slider("threshold", "Sure above", 0.0, 1.0, 0.01, 2))
        self.threshold_slider.setToolTip("an object scoring below this is unsure: drawn grey and dotted, "
                                         "and the arm does not follow it")
        self.threshold_slider.valueChanged.connect(self._on_threshold)
        sure.addWidget(self.threshold_slider, 1)
        layout.addLayout(sure)
        self._show_threshold()

        # --- one detector's settings at a time
        chooser = QtWidgets.QHBoxLayout()
        chooser.addWidget(QtWidgets.QLabel("Settings of"))
        self.settings_combo = touch_combo(QtWidgets.QComboBox())
        self.settings_combo.setObjectName("detector_settings_combo")
        self.settings_combo.currentIndexChanged.connect(self._on_settings_choice)
        chooser.addWidget(self.settings_combo, 1)
        layout.addLayout(chooser)
        self.pages = QtWidgets.QStackedWidget()
        self.hsv_page = self._build_hsv_page()
        self.circles_page = self._build_slider_page(CIRCLE_SLIDERS, "circles")
        self.learned_page = self._build_slider_page(LEARNED_SLIDERS, "learned")
        self.aruco_page = QtWidgets.QLabel("ArUco markers as objects: no settings here (the markers "
                                           "file chooses the dictionaries).")
        self.aruco_page.setWordWrap(True)
        self.aruco_page.setAlignment(QtCore.Qt.AlignmentFlag.AlignTop)
        for page in (self.hsv_page, self.circles_page, self.learned_page, self.aruco_page):
            self.pages.addWidget(page)
        layout.addWidget(self.pages)
        layout.addStretch(1)
        self._fill_settings_combo()
        self._show_hsv()
        self._show_circles()

    # ------------------------------------------------------------------ building
    def _build_hsv_page(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        grid = QtWidgets.QGridLayout(page)
        grid.setContentsMargins(0, 0, 0, 0)
        grid.setHorizontalSpacing(4)
        grid.setVerticalSpacing(2)
        self.colour_combo = touch_combo(QtWidgets.QComboBox())
        self.colour_combo.setObjectName("colour_combo")
        self.colour_combo.currentIndexChanged.connect(self._on_colour_chosen)
        self.remove_colour_button = touch_button("Remove")
        self.remove_colour_button.setToolTip("remove this colour (one must stay)")
        self.remove_colour_button.clicked.connect(self.remove_colour)
        grid.addWidget(_row_label("Colour"), 0, 0)
        grid.addWidget(self.colour_combo, 0, 1, 1, 2)
        grid.addWidget(self.remove_colour_button, 0, 3)
        self.name_edit = QtWidgets.QLineEdit()
        self.name_edit.setMinimumHeight(TOUCH_PX)
        self.name_edit.setPlaceholderText("colour name")
        self.name_edit.setMaxLength(40)
        self.rename_button = touch_button("Rename")
        self.rename_button.clicked.connect(self.rename_colour)
        self.add_colour_button = touch_button("Add")
        self.add_colour_button.setToolTip("a new colour with this name (the ranges of the one shown)")
        self.add_colour_button.clicked.connect(self.add_colour)
        grid.addWidget(_row_label("Name"), 1, 0)
        grid.addWidget(self.name_edit, 1, 1)
        grid.addWidget(self.rename_button, 1, 2)
        grid.addWidget(self.add_colour_button, 1, 3)
        self.pick_button = touch_button("Pick colour: tap an object", checkable=True)
        self.pick_button.setToolTip("the next tap on a camera view sets the colour named above from the "
                                    "tapped pixels (a new name adds a colour)")
        self.pick_button.toggled.connect(self._on_pick_toggled)
        grid.addWidget(self.pick_button, 2, 0, 1, 4)
        # low | high side by side: half the height of one row each
        for col, span, text in ((1, 1, "low"), (2, 2, "high")):
            head = QtWidgets.QLabel(text)
            head.setAlignment(QtCore.Qt.AlignmentFlag.AlignCenter)
            grid.addWidget(head, 3, col, 1, span)
        self.hsv_sliders: dict[str, QtWidgets.QWidget] = {}
        row = 4
        for text, prefix, hi in HSV_CHANNELS:
            grid.addWidget(_row_label(text), row, 0)
            for side, col, span in (("lo", 1, 1), ("hi", 2, 2)):
                field = f"{prefix}_{side}"
                slider = ValueSlider(_Slider(field, text, 0, hi))
                slider.valueChanged.connect(lambda _v, f=field: self._on_hsv_range(f))
                grid.addWidget(slider, row, col, 1, span)
                self.hsv_sliders[field] = slider
            row += 1
        for spec in HSV_SHAPE:
            slider = ValueSlider(spec)
            slider.valueChanged.connect(lambda _v, f=spec.field: self._on_hsv_shape(f))
            grid.addWidget(_row_label(spec.label), row, 0, 1, 2)
            grid.addWidget(slider, row, 2, 1, 2)
            self.hsv_sliders[spec.field] = slider
            row += 1
        grid.setColumnStretch(1, 2)
        grid.setColumnStretch(2, 1)
        grid.setColumnStretch(3, 1)
        grid.setRowStretch(row, 1)
        return page

    def _build_slider_page(self, specs: Sequence[_Slider], what: str) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        grid = QtWidgets.QGridLayout(page)
        grid.setContentsMargins(0, 0, 0, 0)
        grid.setVerticalSpacing(2)
        sliders = {}
        for row, spec in enumerate(specs):
            slider = ValueSlider(spec)
            slider.valueChanged.connect(lambda _v, f=spec.field, w=what: self._on_slider(w, f))
            grid.addWidget(_row_label(spec.label), row, 0)
            grid.addWidget(slider, row, 1)
            sliders[spec.field] = slider
        grid.setColumnStretch(1, 1)
        grid.setRowStretch(len(specs), 1)  # rows packed at the top of the (taller) page stack
        if what == "circles":
            self.circle_sliders = sliders
        else:
            self.learned_sliders = sliders
        return page

    # ------------------------------------------------------------------ public API
    def specs(self) -> list[tuple[str, dict[str, Any]]]:
        """What the panel wants to run: (registry name, {settings field: value}) per detector on."""
        out = []
        for name in self._enabled:
            if name == HSV:
                p = self._hsv
                options = {"colours": p.colours, "open_px": p.open_px, "close_px": p.close_px,
                           "min_area_px": p.min_area_px}
            elif name == CIRCLES:
                options = {f: getattr(self._circles, f) for f in (s.field for s in CIRCLE_SLIDERS)}
            elif name == ARUCO:
                options = {}
            else:
                options = dict(self._learned.get(name, LEARNED_DEFAULTS))
            out.append((name, options))
        return out

    @property
    def enabled(self) -> list[str]:
        """The names of the detectors switched on, in order."""
        return list(self._enabled)

    @property
    def hsv_params(self) -> HsvParams:
        """The HSV detector's settings as shown."""
        return self._hsv

    @property
    def circle_params(self) -> CircleParams:
        """The circle detector's settings as shown."""
        return self._circles

    def set_detectors(self, running: Sequence[tuple[str, Any]]) -> None:
        """Show these running detectors, (name, settings dataclass) each, with their settings
        (at start: ``--detector``); emits nothing."""
        for name, params in running:
            self._take_params(name, params)
        self.set_running([name for name, _ in running])
        self._last_sent = self.specs()
        self._show_hsv()
        self._show_circles()
        self._show_learned()
        if self._enabled:
            self.show_settings_of(self._enabled[0])

    def set_running(self, names: Sequence[str]) -> None:
        """Tick exactly the detectors the worker runs (a failed one goes off); emits nothing."""
        names = [str(n) for n in names]
        for name in names:
            if name.startswith(ONNX + ":"):
                self._set_onnx_path(name.split(":", 1)[1])
        self._enabled = names
        for name, button in self.toggles.items():
            blocked = button.blockSignals(True)
            button.setChecked(name in names)
            button.blockSignals(blocked)
        if self.onnx_toggle is not None:
            blocked = self.onnx_toggle.blockSignals(True)
            self.onnx_toggle.setChecked(self._onnx_name() in names)
            self.onnx_toggle.blockSignals(blocked)

    def set_message(self, text: str, error: bool = False) -> None:
        """A line under the toggles ("" hides it): a detector's problem (error) or a note."""
        self.message_label.setText(text)
        colour = ERROR_COLOUR if error else OK_COLOUR
        self.message_label.setStyleSheet(f"QLabel {{ color: {colour}; font-weight: bold; }}")
        self.message_label.setVisible(bool(text))

    def message(self) -> str:
        return self.message_label.text() if not self.message_label.isHidden() else ""

    def show_settings_of(self, name: str) -> None:
        """Show one detector's settings page ("hsv", "circles", "onnx:…", …)."""
        index = self.settings_combo.findData(name)
        if index >= 0:
            self.settings_combo.setCurrentIndex(index)

    def set_detector_on(self, name: str, on: bool = True) -> None:
        """Switch a detector on or off as its toggle would (emits at once)."""
        if name.startswith(ONNX + ":"):
            self.add_onnx(name.split(":", 1)[1]) if on else self.onnx_toggle.setChecked(False)
            return
        self.toggles[name].setChecked(on)

    # --- per-class thresholds
    @property
    def thresholds(self) -> ClassThresholds:
        """The per-class score thresholds as shown."""
        return self._thresholds

    def set_known_classes(self, classes: Sequence[tuple[str, str]]) -> None:
        """Offer these classes, (label, detector kind) each — those seen so far —, in the
        threshold's class list; a label already there stays where it is; emits nothing."""
        for label, kind in classes:
            label = str(label)
            if label and label not in self._class_kinds and label not in THRESHOLD_DEFAULT_TEXTS:
                self._class_kinds[label] = str(kind)
                self.class_combo.addItem(label, label)

    @property
    def known_classes(self) -> list[str]:
        """The class labels the threshold's list offers (after its two defaults)."""
        return list(self._class_kinds)

    def set_threshold(self, label: str, value: float, kind: str = "object") -> None:
        """Set ``label``'s threshold (LEARNED_CLASSES / OTHER_CLASSES: a default) as the slider
        would, and show it; emits sigThresholdsChanged."""
        self.set_known_classes([(label, kind)])
        self.class_combo.setCurrentIndex(self.class_combo.findData(label))
        self.threshold_slider.setValue(value)
        self._on_threshold(self.threshold_slider.value())

    def _threshold_of(self, data: str) -> float:
        t = self._thresholds
        if data == LEARNED_CLASSES:
            return t.learned_default
        if data == OTHER_CLASSES:
            return t.other_default
        return t.threshold(self._class_kinds.get(data, ""), data)

    def _show_threshold(self, *_: object) -> None:
        data = self.class_combo.currentData()
        if data is not None:
            self.threshold_slider.setValue(self._threshold_of(data))

    def _on_threshold(self, value: float) -> None:
        data = self.class_combo.currentData()
        t = self._thresholds
        if data == LEARNED_CLASSES:
            t = ClassThresholds(t.per_class, value, t.other_default)
        elif data == OTHER_CLASSES:
            t = ClassThresholds(t.per_class, t.learned_default, value)
        elif data is not None:
            t = t.with_class(data, value)
        self._thresholds = t
        self.sigThresholdsChanged.emit(t)

    # --- HSV colours
    @property
    def picking(self) -> bool:
        """True while "Pick colour" waits for a tap on a camera view."""
        return self.pick_button.isChecked()

    def pick_name(self) -> str:
        """The name a picked colour gets: the Name field, else "picked"."""
        return self._clean_name(self.name_edit.text()) or "picked"

    def add_picked_colour(self, colour: HsvRange) -> None:
        """Set the colour of that name from a sample (``colour_from_pixel``) — added when new —,
        show it, switch the HSV detector on and "Pick colour" off; emits at once."""
        colours = list(self._hsv.colours)
        names = [c.name for c in colours]
        if colour.name in names:
            index = names.index(colour.name)
            colours[index] = colour
        else:
            colours.append(colour)
            index = len(colours) - 1
        if not self._set_hsv(lambda: replace(self._hsv, colours=tuple(colours))):
            return
        self._colour_index = index
        self._show_hsv()
        self.pick_button.setChecked(False)
        self.show_settings_of(HSV)
        if HSV not in self._enabled:
            self.toggles[HSV].setChecked(True)  # emits
        else:
            self._emit_at_once()

    def add_colour(self) -> None:
        """Add a colour named as the Name field says, with the ranges of the one shown."""
        name = self._clean_name(self.name_edit.text())
        names = [c.name for c in self._hsv.colours]
        if not name or name in names:
            self.set_message(f"type a new colour name first ({name!r} is {'taken' if name else 'empty'})",
                             error=True)
            return
        base = self._hsv.colours[self._colour_index]
        if self._set_hsv(lambda: replace(self._hsv, colours=self._hsv.colours + (replace(base, name=name),))):
            self._colour_index = len(self._hsv.colours) - 1
            self._show_hsv()
            self._changed()

    def rename_colour(self) -> None:
        """Rename the colour shown to what the Name field says."""
        name = self._clean_name(self.name_edit.text())
        colours = list(self._hsv.colours)
        if not name or name in [c.name for i, c in enumerate(colours) if i != self._colour_index]:
            self.set_message(f"cannot rename to {name!r}: empty or taken", error=True)
            return
        index = self._colour_index
        if self._set_hsv(lambda: replace(self._hsv, colours=tuple(
                replace(c, name=name) if i == index else c for i, c in enumerate(colours)))):
            self._show_hsv()
            self._changed()

    def remove_colour(self) -> None:
        """Remove the colour shown (the last one stays: the HSV detector needs one)."""
        colours = list(self._hsv.colours)
        if len(colours) <= 1:
            return
        del colours[self._colour_index]
        if self._set_hsv(lambda: replace(self._hsv, colours=tuple(colours))):
            self._colour_index = min(self._colour_index, len(colours) - 1)
            self._show_hsv()
            self._changed()

    # --- ONNX
    def choose_onnx_file(self) -> None:
        """"ONNX file…": a file dialog, then ``add_onnx`` with the chosen file."""
        start = os.path.dirname(self._onnx_path) if self._onnx_path else os.path.expanduser("~")
        self.file_dialog = open_file_dialog(self, "Choose a YOLO model (ONNX)", lambda path, _f: self.add_onnx(path),
                                            start, "ONNX models (*.onnx);;All files (*)")

    def add_onnx(self, path: str) -> None:
        """Run the YOLO model in ``path`` (replacing a previous model file); emits at once."""
        old = self._onnx_name()
        if old in self._enabled:
            self._enabled.remove(old)
        self._set_onnx_path(str(path))
        self.onnx_toggle.setChecked(True)
        if self._onnx_name() not in self._enabled:  # the toggle was on already
            self._on_onnx_toggle(True)
        self.show_settings_of(self._onnx_name())

    # ------------------------------------------------------------------ internals
    @staticmethod
    def _clean_name(text: str) -> str:
        return str(text).strip().replace("=", " ").replace(",", " ")

    def _onnx_name(self) -> str:
        return f"{ONNX}:{self._onnx_path}" if self._onnx_path else ""

    def _set_onnx_path(self, path: str) -> None:
        if path == self._onnx_path:
            return
        self._onnx_path = path
        if self.onnx_toggle is not None:
            self.onnx_toggle.show()
            base = os.path.splitext(os.path.basename(path) or path)[0]
            self.onnx_toggle.setText(base if len(base) <= ONNX_TEXT_CHARS else base[:ONNX_TEXT_CHARS - 1] + "…")
            self.onnx_toggle.setToolTip(f"run the YOLO model {path}")
        self._fill_settings_combo()

    def _take_params(self, name: str, params) -> None:
        if isinstance(params, HsvParams):
            self._hsv = params
            self._colour_index = min(self._colour_index, len(params.colours) - 1)
        elif isinstance(params, CircleParams):
            self._circles = params
        elif params is not None and all(hasattr(params, f) for f in LEARNED_DEFAULTS):
            self._learned[name] = {f: float(getattr(params, f)) for f in LEARNED_DEFAULTS}

    def _learned_names(self) -> list[str]:
        names = [n for n in self._plain if n not in (HSV, CIRCLES, ARUCO)]
        if self._onnx_path:
            names.append(self._onnx_name())
        return names

    def _fill_settings_combo(self) -> None:
        current = self.settings_combo.currentData()
        blocked = self.settings_combo.blockSignals(True)
        self.settings_combo.clear()
        for name in [n for n in (HSV, CIRCLES) if n in self._plain] + self._learned_names() + \
                [n for n in (ARUCO,) if n in self._plain]:
            text = name if not name.startswith(ONNX + ":") else "onnx: " + os.path.basename(name[len(ONNX) + 1:])
            self.settings_combo.addItem(text, name)
        index = self.settings_combo.findData(current)
        self.settings_combo.setCurrentIndex(max(0, index))
        self.settings_combo.blockSignals(blocked)
        self._on_settings_choice()

    def _on_settings_choice(self, *_args) -> None:
        name = self.settings_combo.currentData()
        if name == HSV:
            self.pages.setCurrentWidget(self.hsv_page)
        elif name == CIRCLES:
            self.pages.setCurrentWidget(self.circles_page)
        elif name == ARUCO:
            self.pages.setCurrentWidget(self.aruco_page)
        elif name is not None:
            self._show_learned()
            self.pages.setCurrentWidget(self.learned_page)

    def _on_toggle(self, name: str, on: bool) -> None:
        if on and name not in self._enabled:
            self._enabled.append(name)
            self.show_settings_of(name)
        elif not on and name in self._enabled:
            self._enabled.remove(name)
        self._emit_at_once()

    def _on_onnx_toggle(self, on: bool) -> None:
        name = self._onnx_name()
        if not name:
            return
        self._on_toggle(name, on)

    def _on_pick_toggled(self, on: bool) -> None:
        if on:
            self.set_message(f"tap the object in a camera view: it sets the colour “{self.pick_name()}”")
        elif self.message_label.text().startswith("tap the object"):
            self.set_message("")
        self.sigPickToggled.emit(on)

    def _on_colour_chosen(self, index: int) -> None:
        if 0 <= index < len(self._hsv.colours):
            self._colour_index = index
            self._show_hsv()

    def _on_hsv_range(self, field: str) -> None:
        value = int(self.hsv_sliders[field].value())
        colours = list(self._hsv.colours)
        c = colours[self._colour_index]
        changes = {field: value}
        prefix, side = field.split("_")
        if prefix in ("s", "v"):  # low above high: the other end follows (hue may wrap)
            other = f"{prefix}_{'hi' if side == 'lo' else 'lo'}"
            lo, hi = (value, getattr(c, other)) if side == "lo" else (getattr(c, other), value)
            if lo > hi:
                changes[other] = value
                _set_quietly(self.hsv_sliders[other], value)
        index = self._colour_index
        if self._set_hsv(lambda: replace(self._hsv, colours=tuple(
                replace(c, **changes) if i == index else old for i, old in enumerate(colours)))):
            self._changed()

    def _on_hsv_shape(self, field: str) -> None:
        raw = self.hsv_sliders[field].value()
        value = float(raw) if field == "min_area_px" else int(raw)
        if self._set_hsv(lambda: replace(self._hsv, **{field: value})):
            self._changed()

    def _on_slider(self, what: str, field: str) -> None:
        if what == "circles":
            spec = next(s for s in CIRCLE_SLIDERS if s.field == field)
            raw = self.circle_sliders[field].value()
            value = round(float(raw), spec.decimals) if spec.decimals or isinstance(
                getattr(self._circles, field), float) else int(raw)
            changes = {field: value}
            lo, hi = self._circles.min_radius_px, self._circles.max_radius_px
            if field == "min_radius_px" and hi and value > hi:  # the range stays a range
                changes["max_radius_px"] = value
                _set_quietly(self.circle_sliders["max_radius_px"], value)
            elif field == "max_radius_px" and value and value < max(1, lo):
                changes["min_radius_px"] = value
                _set_quietly(self.circle_sliders["min_radius_px"], value)
            try:
                self._circles = replace(self._circles, **changes)
            except SettingsError as exc:
                self.set_message(str(exc), error=True)
                return
        else:
            name = self.settings_combo.currentData()
            values = dict(self._learned.get(name, LEARNED_DEFAULTS))
            values[field] = round(float(self.learned_sliders[field].value()), 2)
            self._learned[name] = values
        self._changed()

    def _set_hsv(self, make) -> bool:
        """``self._hsv = make()`` unless that raises a SettingsError (then a message, False)."""
        try:
            self._hsv = make()
        except (SettingsError, ValueError) as exc:
            self.set_message(str(exc), error=True)
            return False
        return True

    def _show_hsv(self) -> None:
        colours = self._hsv.colours
        self._colour_index = max(0, min(self._colour_index, len(colours) - 1))
        blocked = self.colour_combo.blockSignals(True)
        if [self.colour_combo.itemText(i) for i in range(self.colour_combo.count())] != [c.name for c in colours]:
            self.colour_combo.clear()
            self.colour_combo.addItems([c.name for c in colours])
        self.colour_combo.setCurrentIndex(self._colour_index)
        self.colour_combo.blockSignals(blocked)
        self.remove_colour_button.setEnabled(len(colours) > 1)
        c = colours[self._colour_index]
        self.name_edit.setText(c.name)
        for field in ("h_lo", "h_hi", "s_lo", "s_hi", "v_lo", "v_hi"):
            _set_quietly(self.hsv_sliders[field], getattr(c, field))
        for spec in HSV_SHAPE:
            _set_quietly(self.hsv_sliders[spec.field], getattr(self._hsv, spec.field))

    def _show_circles(self) -> None:
        for spec in CIRCLE_SLIDERS:
            _set_quietly(self.circle_sliders[spec.field], getattr(self._circles, spec.field))

    def _show_learned(self) -> None:
        name = self.settings_combo.currentData()
        values = self._learned.get(name, LEARNED_DEFAULTS)
        for spec in LEARNED_SLIDERS:
            _set_quietly(self.learned_sliders[spec.field], values[spec.field])

    def _changed(self) -> None:
        """A setting changed: tell the worker soon (only about detectors that are on)."""
        if self._enabled:
            self._coalescer.poke()

    def _emit_at_once(self) -> None:
        self._coalescer.cancel()
        self._emit_now(force=True)

    def flush(self) -> None:
        """Send a pending change now instead of at the end of the throttle interval."""
        self._coalescer.flush()

    def _emit_now(self, force: bool = False) -> None:
        specs = self.specs()
        if force or specs != self._last_sent:
            self._last_sent = specs
            self.sigDetectorsChanged.emit(specs)
