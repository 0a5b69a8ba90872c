"""The Stereo tab: matcher choice (StereoSGBM in every mode, StereoBM), their parameters as
trackbars, the WLS filter, half resolution, presets per camera pair and the depth readout."""
from __future__ import annotations

from typing import Optional, Sequence

from PySide6 import QtCore, QtWidgets

from core.settings import (
    BM_PREFILTERS,
    STEREO_MATCHERS,
    SettingsError,
    SgbmParams,
    StereoMatchParams,
)
from widgets._style import (
    ERROR_COLOUR,
    OK_COLOUR,
    TOUCH_PX,
    Coalescer,
    LabeledDoubleSlider,
    LabeledSlider,
    coloured_label_style,
    touch_button,
    touch_combo,
    touch_slider,
)
from widgets.camera_controls import (
    CHECKBOX_STYLE,
    HORIZONTAL,
    THROTTLE_MS,
    SgbmPanel,
    _row_label,
)

MATCHER_TEXT = {"SGBM": "SGBM (semi-global)", "BM": "BM (block matching, ~3× faster)"}
PREFILTER_TEXT = {"XSOBEL": "x-Sobel", "NORMALIZED_RESPONSE": "normalised response"}
DEPTH_HINT = "Turn on Disparity in a camera view, then tap it to measure depth there."


def _odd(v: int, lo: int, hi: int) -> int:
    v = int(round(v))
    if v % 2 == 0:
        v = v + 1 if v + 1 <= hi else v - 1
    return min(max(v, lo), hi)


class StereoPanel(QtWidgets.QWidget):
    """Everything that shapes the disparity map, and the presets of the current camera pair.

    Widgets never read preset files: the window does, and calls :meth:`set_presets` /
    :meth:`set_all` with what it found.

    Signals (GUI thread):
        sigParamsChanged(object): new :class:`SgbmParams` (the block-matching trackbars, shared
            by SGBM and BM); coalesced to at most one per 50 ms.
        sigMatchParamsChanged(object): new :class:`StereoMatchParams` (matcher, BM pre-filter,
            WLS, half resolution); coalesced the same way, unchanged values not re-sent.
        sigPresetSaveRequested(str name): save the shown parameters under ``name``.
        sigPresetLoadRequested(str name): load the preset ``name``.
        sigPresetDeleteRequested(str name): delete the preset ``name``.
    """

    sigParamsChanged = QtCore.Signal(object)
    sigMatchParamsChanged = QtCore.Signal(object)
    sigPresetSaveRequested = QtCore.Signal(str)
    sigPresetLoadRequested = QtCore.Signal(str)
    sigPresetDeleteRequested = QtCore.Signal(str)

    def __init__(self, params: Optional[SgbmParams] = None, match: Optional[StereoMatchParams] = None,
                 parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._last_match = match or StereoMatchParams()
        self._coalescer = Coalescer(THROTTLE_MS, self._emit_match, self)
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.setSpacing(6)

        self.depth_label = QtWidgets.QLabel(DEPTH_HINT)
        self.depth_label.setWordWrap(True)
        self.depth_label.setMinimumHeight(TOUCH_PX)
        layout.addWidget(self.depth_label)
        self.timing_label = QtWidgets.QLabel("")
        self.timing_label.hide()
        layout.addWidget(self.timing_label)

        # matcher choice
        self.matcher_buttons: dict[str, QtWidgets.QPushButton] = {}
        row = QtWidgets.QHBoxLayout()
        row.setContentsMargins(4, 0, 4, 0)
        row.addWidget(_row_label("Matcher"))
        group = QtWidgets.QButtonGroup(self)
        for name in STEREO_MATCHERS:
            b = touch_button(name, checkable=True)
            b.setToolTip(MATCHER_TEXT[name])
            group.addButton(b)
            b.toggled.connect(self._on_matcher_toggled)
            row.addWidget(b)
            self.matcher_buttons[name] = b
        layout.addLayout(row)

        # block matching (shared) + SGBM-only parameters
        self.sgbm = SgbmPanel(params, scroll=False)
        self.sgbm.sigParamsChanged.connect(self.sigParamsChanged)
        layout.addWidget(self.sgbm)

        grid = QtWidgets.QGridLayout()
        grid.setContentsMargins(4, 0, 4, 0)
        grid.setColumnStretch(1, 1)
        r = 0
        self.bm_widgets: list[QtWidgets.QWidget] = []
        self.prefilter_combo = touch_combo(QtWidgets.QComboBox())
        for key in BM_PREFILTERS:
            self.prefilter_combo.addItem(PREFILTER_TEXT[key], key)
        self.prefilter_combo.setMinimumHeight(TOUCH_PX)
        self.prefilter_combo.currentIndexChanged.connect(self._coalescer.poke)
        self.prefilter_size = self._int_slider(5, 255, 2)
        self.texture_threshold = self._int_slider(0, 1000, 10)
        for label, w in (("BM pre-filter", self.prefilter_combo), ("Pre-filter size (px, odd)", self.prefilter_size),
                         ("Texture threshold", self.texture_threshold)):
            lab = _row_label(label)
            grid.addWidget(lab, r, 0)
            grid.addWidget(w, r, 1)
            self.bm_widgets += [lab, w]
            r += 1
        self.wls_box = QtWidgets.QCheckBox("WLS filter (edge-aware fill-in, ~+60 % time)")
        self.wls_box.setStyleSheet(CHECKBOX_STYLE)
        self.wls_box.toggled.connect(self._on_wls_toggled)
        grid.addWidget(self.wls_box, r, 0, 1, 2)
        r += 1
        self.wls_lambda = self._int_slider(100, 20000, 100)
        self.wls_sigma = LabeledDoubleSlider(HORIZONTAL)
        self.wls_sigma.setRange(0.1, 5.0)
        self.wls_sigma.setSingleStep(0.05)
        self.wls_sigma.setDecimals(2)
        touch_slider(self.wls_sigma)
        self.wls_sigma.valueChanged.connect(self._coalescer.poke)
        for label, w in (("WLS lambda (smoothness)", self.wls_lambda), ("WLS sigma (colour)", self.wls_sigma)):
            grid.addWidget(_row_label(label), r, 0)
            grid.addWidget(w, r, 1)
            r += 1
        self.half_box = QtWidgets.QCheckBox("Half resolution (~4× faster, for the Raspberry Pi)")
        self.half_box.setStyleSheet(CHECKBOX_STYLE)
        self.half_box.toggled.connect(self._coalescer.poke)
        grid.addWidget(self.half_box, r, 0, 1, 2)
        r += 1
        layout.addLayout(grid)

        # presets of this camera pair
        layout.addWidget(_row_label("Presets for this camera pair"))
        self.preset_combo = QtWidgets.QComboBox()
        self.preset_combo.setEditable(True)
        touch_combo(self.preset_combo)
        self.preset_combo.setInsertPolicy(QtWidgets.QComboBox.InsertPolicy.NoInsert)
        self.preset_combo.setMinimumHeight(TOUCH_PX)
        self.preset_combo.lineEdit().setPlaceholderText("preset name")
        layout.addWidget(self.preset_combo)
        buttons = QtWidgets.QHBoxLayout()
        self.save_preset_button = touch_button("Save")
        self.load_preset_button = touch_button("Load")
        self.delete_preset_button = touch_button("Delete")
        self.save_preset_button.clicked.connect(self._on_save_preset)
        self.load_preset_button.clicked.connect(self._on_load_preset)
        self.delete_preset_button.clicked.connect(self._on_delete_preset)
        for b in (self.save_preset_button, self.load_preset_button, self.delete_preset_button):
            buttons.addWidget(b)
        layout.addLayout(buttons)
        self.preset_status = QtWidgets.QLabel("")
        self.preset_status.setWordWrap(True)
        self.preset_status.hide()
        layout.addWidget(self.preset_status)
        layout.addStretch(1)
        self._show_match(self._last_match)

    def _int_slider(self, lo: int, hi: int, step: int) -> LabeledSlider:
        s = LabeledSlider(HORIZONTAL)
        s.setRange(lo, hi)
        s.setSingleStep(step)
        s.setPageStep(step * 4)
        touch_slider(s)
        s.valueChanged.connect(self._coalescer.poke)
        return s

    # ------------------------------------------------------------------ values
    def params(self) -> SgbmParams:
        """The block-matching parameters shown (always valid)."""
        return self.sgbm.params()

    def match_params(self) -> StereoMatchParams:
        """The matcher choice, BM pre-filter, WLS and resolution shown (always valid)."""
        matcher = next(n for n, b in self.matcher_buttons.items() if b.isChecked())
        return StereoMatchParams(
            matcher=matcher,
            bm_prefilter=self.prefilter_combo.currentData(),
            bm_prefilter_size=_odd(self.prefilter_size.value(), 5, 255),
            bm_texture_threshold=int(self.texture_threshold.value()),
            wls=self.wls_box.isChecked(),
            wls_lambda=float(round(self.wls_lambda.value() / 100.0) * 100),
            wls_sigma=round(float(self.wls_sigma.value()), 2),
            half_resolution=self.half_box.isChecked(),
        )

    def set_all(self, params: SgbmParams, match: StereoMatchParams) -> None:
        """Show both parameter sets without emitting (e.g. a loaded preset)."""
        self.sgbm.set_params(params)
        self._coalescer.cancel()
        self._last_match = match
        self._show_match(match)

    def flush(self) -> None:
        """Emit pending changes now."""
        self.sgbm.flush()
        self._coalescer.flush()

    def _show_match(self, m: StereoMatchParams) -> None:
        widgets = (list(self.matcher_buttons.values()) + [self.prefilter_combo, self.prefilter_size,
                   self.texture_threshold, self.wls_box, self.wls_lambda, self.wls_sigma, self.half_box])
        blocked = [w.blockSignals(True) for w in widgets]
        self.matcher_buttons[m.matcher].setChecked(True)
        self.prefilter_combo.setCurrentIndex(self.prefilter_combo.findData(m.bm_prefilter))
        self.prefilter_size.setValue(m.bm_prefilter_size)
        self.texture_threshold.setValue(m.bm_texture_threshold)
        self.wls_box.setChecked(m.wls)
        self.wls_lambda.setValue(int(m.wls_lambda))
        self.wls_sigma.setValue(m.wls_sigma)
        self.half_box.setChecked(m.half_resolution)
        for w, b in zip(widgets, blocked):
            w.blockSignals(b)
        self._update_visibility()

    def _update_visibility(self) -> None:
        bm = self.matcher_buttons["BM"].isChecked()
        for w in self.bm_widgets:
            w.setVisible(bm)
        self.sgbm.set_sgbm_controls_visible(not bm)
        wls = self.wls_box.isChecked()
        self.wls_lambda.setEnabled(wls)
        self.wls_sigma.setEnabled(wls)

    def _on_matcher_toggled(self, checked: bool) -> None:
        if checked:
            self._update_visibility()
            self._coalescer.poke()

    def _on_wls_toggled(self, _on: bool) -> None:
        self._update_visibility()
        self._coalescer.poke()

    def _emit_match(self) -> None:
        try:
            match = self.match_params()
        except SettingsError:  # cannot happen with snapped controls; never emit a bad one
            return
        if match != self._last_match:
            self._last_match = match
            self.sigMatchParamsChanged.emit(match)

    # ------------------------------------------------------------------ presets and readouts
    def preset_name(self) -> str:
        return self.preset_combo.currentText().strip()

    def set_presets(self, names: Sequence[str], current: Optional[str] = None) -> None:
        """The presets stored for this camera pair; ``current`` is shown selected."""
        blocked = self.preset_combo.blockSignals(True)
        self.preset_combo.clear()
        self.preset_combo.addItems(list(names))
        if current:
            self.preset_combo.setCurrentText(current)
        elif not names:
            self.preset_combo.setCurrentText("")
        self.preset_combo.blockSignals(blocked)
        has = bool(names)
        self.load_preset_button.setEnabled(has)
        self.delete_preset_button.setEnabled(has)

    def set_preset_status(self, text: str, ok: bool = True) -> None:
        """What the last preset action did ("" hides it)."""
        self.preset_status.setText(text)
        self.preset_status.setStyleSheet(coloured_label_style(OK_COLOUR if ok else ERROR_COLOUR, bold=False))
        self.preset_status.setVisible(bool(text))

    def set_depth_readout(self, text: str) -> None:
        """The depth under the last tap on the disparity view ("" shows the hint)."""
        self.depth_label.setText(text or DEPTH_HINT)
        self.depth_label.setStyleSheet("QLabel { font-weight: bold; }" if text else "")

    def set_timing(self, text: str) -> None:
        """How long the disparity took ("" hides it)."""
        self.timing_label.setText(text)
        self.timing_label.setVisible(bool(text))

    def _on_save_preset(self) -> None:
        name = self.preset_name()
        if not name:
            self.set_preset_status("type a name for the preset first", ok=False)
            return
        self.flush()
        self.sigPresetSaveRequested.emit(name)

    def _on_load_preset(self) -> None:
        if self.preset_name():
            self.sigPresetLoadRequested.emit(self.preset_name())

    def _on_delete_preset(self) -> None:
        if self.preset_name():
            self.sigPresetDeleteRequested.emit(self.preset_name())


__all__ = ["StereoPanel"]
