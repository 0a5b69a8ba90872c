"""Trackbar panels: camera image controls and StereoSGBM parameters.

Both panels build a validated settings dataclass from their controls and report it through
one signal, coalesced to at most one emission per ``THROTTLE_MS`` while a slider is dragged.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from PySide6 import QtCore, QtWidgets

from core.settings import SGBM_MODES, CameraSettings, SettingsError, SgbmParams
from widgets._style import (
    TOUCH_PX,
    Coalescer,
    LabeledDoubleSlider,
    LabeledSlider,
    touch_button,
    touch_combo,
    touch_scroll_area,
    touch_slider,
)

THROTTLE_MS = 50
HORIZONTAL = QtCore.Qt.Orientation.Horizontal
CHECKBOX_STYLE = f"""
QCheckBox {{ min-height: {TOUCH_PX}px; spacing: 8px; }}
QCheckBox::indicator {{ width: 26px; height: 26px; }}
"""


@dataclass(frozen=True)
class _SliderSpec:
    name: str  # dataclass field
    label: str  # what the user reads
    lo: float
    hi: float
    step: float
    decimals: int = 0


CAMERA_SLIDERS = (
    _SliderSpec("exposure", "Exposure (EV)", -4.0, 4.0, 0.1, 1),
    _SliderSpec("gain", "Gain (dB)", 0.0, 24.0, 0.5, 1),
    _SliderSpec("brightness", "Brightness", -100.0, 100.0, 1.0, 0),
    _SliderSpec("contrast", "Contrast", 0.2, 3.0, 0.05, 2),
)


def _row_label(text: str) -> QtWidgets.QLabel:
    label = QtWidgets.QLabel(text)
    label.setMinimumHeight(TOUCH_PX)
    label.setWordWrap(True)
    return label


class CameraSettingsPanel(QtWidgets.QWidget):
    """Sliders for exposure, gain, brightness and contrast, and a Reset button.

    Signals (GUI thread):
        sigSettingsChanged(object): a new, valid :class:`CameraSettings` after the user moved a
            slider or pressed Reset; bursts are coalesced (at most one per 50 ms) and an
            unchanged value is not re-sent.
    """

    sigSettingsChanged = QtCore.Signal(object)

    def __init__(self, settings: Optional[CameraSettings] = None,
                 parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._last_sent = settings or CameraSettings()
        self._coalescer = Coalescer(THROTTLE_MS, self._emit_now, self)
        self.sliders: dict[str, LabeledDoubleSlider] = {}

        grid = QtWidgets.QGridLayout(self)
        grid.setContentsMargins(4, 4, 4, 4)
        grid.setColumnStretch(1, 1)
        for row, spec in enumerate(CAMERA_SLIDERS):
            slider = LabeledDoubleSlider(HORIZONTAL)
            slider.setRange(spec.lo, spec.hi)
            slider.setSingleStep(spec.step)
            slider.setPageStep(spec.step * 10)
            slider.setDecimals(spec.decimals)
            touch_slider(slider)
            slider.valueChanged.connect(self._coalescer.poke)
            grid.addWidget(_row_label(spec.label), row, 0)
            grid.addWidget(slider, row, 1)
            self.sliders[spec.name] = slider
        self.reset_button = touch_button("Reset")
        self.reset_button.setToolTip("Back to the default camera settings")
        self.reset_button.clicked.connect(self.reset)
        grid.addWidget(self.reset_button, len(CAMERA_SLIDERS), 0, 1, 2)
        grid.setRowStretch(len(CAMERA_SLIDERS) + 1, 1)
        self._show(self._last_sent)

    def settings(self) -> CameraSettings:
        """The settings the controls show now (valid by construction)."""
        values = {}
        for spec in CAMERA_SLIDERS:
            v = round(float(self.sliders[spec.name].value()), spec.decimals)
            values[spec.name] = min(max(v, spec.lo), spec.hi)
        return CameraSettings(**values)

    def set_settings(self, settings: CameraSettings) -> None:
        """Show ``settings`` without emitting (drops a pending emission)."""
        self._coalescer.cancel()
        self._last_sent = settings
        self._show(settings)

    def reset(self) -> None:
        """Back to the dataclass defaults; emits if that changes anything."""
        self._show(CameraSettings())
        self._coalescer.poke()

    def flush(self) -> None:
        """Emit a pending change now instead of at the end of the throttle interval."""
        self._coalescer.flush()

    def _show(self, settings: CameraSettings) -> None:
        for spec in CAMERA_SLIDERS:
            slider = self.sliders[spec.name]
            blocked = slider.blockSignals(True)
            slider.setValue(getattr(settings, spec.name))
            slider.blockSignals(blocked)

    def _emit_now(self) -> None:
        settings = self.settings()
        if settings != self._last_sent:
            self._last_sent = settings
            self.sigSettingsChanged.emit(settings)


# --------------------------------------------------------------------------------- SGBM
@dataclass(frozen=True)
class _IntSpec:
    name: str
    label: str
    lo: int
    hi: int
    step: int = 1
    snap: str = ""  # "", "mult16", "odd"
    auto: bool = False  # an "auto" checkbox stands for the value 0


SGBM_SLIDERS = (
    _IntSpec("min_disparity", "Min disparity (px)", -64, 64),
    _IntSpec("num_disparities", "Disparities (px, ×16)", 16, 256, 16, snap="mult16"),
    _IntSpec("block_size", "Block size (px, odd)", 1, 21, 2, snap="odd"),
    _IntSpec("p1", "P1 smoothness", 1, 10_000, 10, auto=True),
    _IntSpec("p2", "P2 smoothness", 1, 40_000, 10, auto=True),
    _IntSpec("disp12_max_diff", "L-R check (px, −1 off)", -1, 64),
    _IntSpec("pre_filter_cap", "Pre-filter cap", 1, 63),
    _IntSpec("uniqueness_ratio", "Uniqueness (%)", 0, 50),
    _IntSpec("speckle_window_size", "Speckle window (px)", 0, 300, 10),
    _IntSpec("speckle_range", "Speckle range (px)", 0, 16),
)


def snap_value(spec: _IntSpec, value: int) -> int:
    """The nearest allowed value of a slider: clamped, multiple of 16 or odd as required."""
    v = int(round(value))
    if spec.snap == "mult16":
        v = 16 * int(round(v / 16.0))
    elif spec.snap == "odd" and v % 2 == 0:
        v = v + 1 if v + 1 <= spec.hi else v - 1
    return min(max(v, spec.lo), spec.hi)


class SgbmPanel(QtWidgets.QWidget):
    """One slider per :class:`SgbmParams` field plus the matcher mode, in a scroll area.

    Sliders snap to allowed values (disparities in steps of 16, odd block sizes); P1 and P2
    have an "auto" checkbox meaning 0 (OpenCV's 8·cn·bs² / 32·cn·bs² rule).

    Signals (GUI thread):
        sigParamsChanged(object): a new, always valid :class:`SgbmParams` after a user edit;
            coalesced to at most one per 50 ms, unchanged values are not re-sent.
    """

    sigParamsChanged = QtCore.Signal(object)

    def __init__(self, params: Optional[SgbmParams] = None,
                 parent: QtWidgets.QWidget | None = None, scroll: bool = True) -> None:
        super().__init__(parent)
        self._last_sent = params or SgbmParams()
        self._coalescer = Coalescer(THROTTLE_MS, self._emit_now, self)
        self.sliders: dict[str, LabeledSlider] = {}
        self.auto_boxes: dict[str, QtWidgets.QCheckBox] = {}
        self._labels: dict[str, QtWidgets.QLabel] = {}
        self._specs = {spec.name: spec for spec in SGBM_SLIDERS}

        content = QtWidgets.QWidget()
        grid = QtWidgets.QGridLayout(content)
        grid.setContentsMargins(4, 4, 4, 4)
        grid.setColumnStretch(1, 1)
        row = 0
        self.mode_combo = touch_combo(QtWidgets.QComboBox())
        self.mode_combo.addItems(list(SGBM_MODES))
        self.mode_combo.setMinimumHeight(TOUCH_PX)
        self.mode_combo.currentIndexChanged.connect(self._coalescer.poke)
        grid.addWidget(_row_label("Mode"), row, 0)
        grid.addWidget(self.mode_combo, row, 1)
        row += 1
        for spec in SGBM_SLIDERS:
            slider = LabeledSlider(HORIZONTAL)
            slider.setRange(spec.lo, spec.hi)
            slider.setSingleStep(spec.step)
            slider.setPageStep(spec.step * 4)
            touch_slider(slider)
            slider.valueChanged.connect(lambda v, s=spec: self._on_slider(s, v))
            self.sliders[spec.name] = slider
            self._labels[spec.name] = _row_label(spec.label)
            grid.addWidget(self._labels[spec.name], row, 0)
            if spec.auto:
                box = QtWidgets.QCheckBox("auto")
                box.setStyleSheet(CHECKBOX_STYLE)
                box.toggled.connect(lambda checked, s=spec: self._on_auto(s, checked))
                self.auto_boxes[spec.name] = box
                cell = QtWidgets.QHBoxLayout()
                cell.addWidget(box)
                cell.addWidget(slider, 1)
                grid.addLayout(cell, row, 1)
            else:
                grid.addWidget(slider, row, 1)
            row += 1
        self.reset_button = touch_button("Reset")
        self.reset_button.setToolTip("Back to the default SGBM parameters")
        self.reset_button.clicked.connect(self.reset)
        grid.addWidget(self.reset_button, row, 0, 1, 2)
        grid.setRowStretch(row + 1, 1)
        self._mode_label = grid.itemAtPosition(0, 0).widget()

        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        # inside a page that scrolls already (the Stereo tab), a second scroll area only hurts
        layout.addWidget(touch_scroll_area(content) if scroll else content)
        self._show(self._last_sent)

    def params(self) -> SgbmParams:
        """The parameters the controls show now, snapped to allowed values (always valid)."""
        values: dict[str, object] = {}
        for name, spec in self._specs.items():
            if spec.auto and self.auto_boxes[name].isChecked():
                values[name] = 0
            else:
                values[name] = snap_value(spec, self.sliders[name].value())
        values["mode"] = self.mode_combo.currentText()
        return SgbmParams(**values)

    def set_params(self, params: SgbmParams) -> None:
        """Show ``params`` without emitting (drops a pending emission)."""
        self._coalescer.cancel()
        self._last_sent = params
        self._show(params)

    def reset(self) -> None:
        """Back to the dataclass defaults; emits if that changes anything."""
        self._show(SgbmParams())
        self._coalescer.poke()

    def flush(self) -> None:
        """Emit a pending change now instead of at the end of the throttle interval."""
        self._coalescer.flush()

    def set_sgbm_controls_visible(self, visible: bool) -> None:
        """Show or hide what only StereoSGBM uses (mode, P1, P2): hidden while StereoBM matches."""
        self.mode_combo.setVisible(visible)
        self._mode_label.setVisible(visible)
        for name in ("p1", "p2"):
            self.sliders[name].setVisible(visible)
            self.auto_boxes[name].setVisible(visible)
            self._labels[name].setVisible(visible)

    def _show(self, params: SgbmParams) -> None:
        auto_p1, auto_p2 = params.penalties(channels=1)
        auto_values = {"p1": auto_p1, "p2": auto_p2}
        for name, spec in self._specs.items():
            slider = self.sliders[name]
            value = getattr(params, name)
            blocked = slider.blockSignals(True)
            if spec.auto:
                box = self.auto_boxes[name]
                box_blocked = box.blockSignals(True)
                box.setChecked(value == 0)
                box.blockSignals(box_blocked)
                slider.setEnabled(value != 0)
                # while automatic, the slider shows the automatic value as a starting point
                value = value or auto_values[name]
            slider.setValue(snap_value(spec, value))
            slider.blockSignals(blocked)
        blocked = self.mode_combo.blockSignals(True)
        self.mode_combo.setCurrentText(params.mode)
        self.mode_combo.blockSignals(blocked)

    def _on_slider(self, spec: _IntSpec, value: int) -> None:
        snapped = snap_value(spec, value)
        if snapped != value:
            self.sliders[spec.name].setValue(snapped)  # re-enters with the snapped value
            return
        self._coalescer.poke()

    def _on_auto(self, spec: _IntSpec, checked: bool) -> None:
        self.sliders[spec.name].setEnabled(not checked)
        self._coalescer.poke()

    def _emit_now(self) -> None:
        try:
            params = self.params()
        except SettingsError:  # cannot happen with snapped sliders; never emit a bad one
            return
        if params != self._last_sent:
            self._last_sent = params
            self.sigParamsChanged.emit(params)


__all__ = ["CameraSettingsPanel", "SgbmPanel", "THROTTLE_MS", "snap_value"]
