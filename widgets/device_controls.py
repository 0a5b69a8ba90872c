"""Trackbars for a real camera's image controls, built from what the device reports.

One labelled slider per control (exposure, gain, brightness, contrast, saturation, white balance,
focus — whatever ``CameraSource.controls()`` lists, with the device's range and step) and an
"auto" checkbox for the controls that have an automatic mode. The panel only requests: the
perception worker sets the control (clamped by the device) and the panel then shows the value
the device really took.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from types import MappingProxyType

from PySide6 import QtCore, QtWidgets

from core.vision.cameras import CameraControl
from widgets._style import TOUCH_PX, WARN_COLOUR, Coalescer, LabeledDoubleSlider, touch_button, touch_slider

THROTTLE_MS = 50
HORIZONTAL = QtCore.Qt.Orientation.Horizontal
CHECKBOX_STYLE = f"""
QCheckBox {{ min-height: {TOUCH_PX}px; spacing: 6px; }}
QCheckBox::indicator {{ width: 26px; height: 26px; }}
"""


def _decimals(step: float) -> int:
    """Decimals that show a step exactly enough (1 → 0, 0.5 → 1, 0.05 → 2)."""
    if step <= 0 or step >= 1:
        return 0
    return min(4, int(math.ceil(-math.log10(step) - 1e-9)))


class _ControlRow:
    """The widgets of one control: label, slider, optional auto checkbox, its own coalescer."""

    def __init__(self, panel: DeviceControlsPanel, control: CameraControl) -> None:
        self.control = control
        text = control.label + ("" if control.range_known else " *")
        self.label = QtWidgets.QLabel(text)
        self.label.setMinimumHeight(TOUCH_PX)
        self.label.setWordWrap(True)
        if not control.range_known:
            self.label.setToolTip("the camera did not report this range: a typical webcam range is used")
        self.slider = LabeledDoubleSlider(HORIZONTAL)
        self.slider.setDecimals(_decimals(control.step))
        self.slider.setRange(control.minimum, control.maximum)
        self.slider.setSingleStep(control.step)
        self.slider.setPageStep(control.step * 10)
        touch_slider(self.slider)
        self.auto: QtWidgets.QCheckBox | None = None
        if control.auto is not None:
            self.auto = QtWidgets.QCheckBox("auto")
            self.auto.setStyleSheet(CHECKBOX_STYLE)
        self.coalescer = Coalescer(THROTTLE_MS, lambda: panel._emit_value(self), panel)
        self.last_sent = control.value
        self.show(control)
        self.slider.valueChanged.connect(self.coalescer.poke)
        if self.auto is not None:
            self.auto.toggled.connect(lambda on: panel._emit_auto(self, on))

    def show(self, control: CameraControl) -> None:
        """Show ``control``'s value and auto state without emitting."""
        self.control = control
        blocked = self.slider.blockSignals(True)
        self.slider.setValue(control.value)
        self.slider.blockSignals(blocked)
        self.last_sent = control.value
        if self.auto is not None and control.auto is not None:
            blocked = self.auto.blockSignals(True)
            self.auto.setChecked(bool(control.auto))
            self.auto.blockSignals(blocked)
        # a manual value while automatic would be overridden by the camera: show it disabled
        self.slider.setEnabled(not (self.auto is not None and self.auto.isChecked()))

    def value(self) -> float:
        return self.control.clamp(float(self.slider.value()))


class DeviceControlsPanel(QtWidgets.QWidget):
    """One trackbar per device control, rebuilt by :meth:`set_controls`.

    Signals (GUI thread):
        sigControlRequested(str name, float value): the user moved a slider; coalesced to at
            most one per 50 ms per control, already clamped to the reported range and step.
        sigAutoRequested(str name, bool on): the user switched a control's "auto" checkbox.
        sigRefreshRequested(): the user asked to read the controls again (Refresh button).
        sigControlsRebuilt(): :meth:`set_controls` rebuilt the rows from the device's list (the
            first one, after a replug, after a refresh): saved values can be requested again.
    """

    sigControlRequested = QtCore.Signal(str, float)
    sigAutoRequested = QtCore.Signal(str, bool)
    sigRefreshRequested = QtCore.Signal()
    sigControlsRebuilt = QtCore.Signal()

    def __init__(self, controls: Sequence[CameraControl] = (), parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.rows: dict[str, _ControlRow] = {}
        self._grid = QtWidgets.QGridLayout()
        self._grid.setContentsMargins(0, 0, 0, 0)
        self._grid.setColumnStretch(1, 1)
        self.message = QtWidgets.QLabel("reading the camera controls …")
        self.message.setWordWrap(True)
        self.note = QtWidgets.QLabel("* range not reported by the camera: a typical webcam range is used")
        self.note.setWordWrap(True)
        self.note.hide()
        self.refresh_button = touch_button("Read again from the camera")
        self.refresh_button.clicked.connect(self._on_refresh)
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addWidget(self.message)
        layout.addLayout(self._grid)
        layout.addWidget(self.note)
        layout.addWidget(self.refresh_button)
        layout.addStretch(1)
        if controls:
            self.set_controls(controls)

    # ------------------------------------------------------------------ public API
    def set_controls(self, controls: Sequence[CameraControl]) -> None:
        """Rebuild the rows from the device's controls (an empty list says none are available)."""
        for row in self.rows.values():
            row.coalescer.cancel()
            for w in (row.label, row.slider, row.auto):
                if w is not None:
                    self._grid.removeWidget(w)
                    w.deleteLater()
        self.rows = {}
        for r, control in enumerate(c for c in controls if c.maximum > c.minimum):
            row = _ControlRow(self, control)
            self._grid.addWidget(row.label, r, 0)
            self._grid.addWidget(row.slider, r, 1)
            if row.auto is not None:
                self._grid.addWidget(row.auto, r, 2)
            self.rows[control.name] = row
        self.note.setVisible(any(not c.range_known for c in controls))
        if self.rows:
            self.set_message("")
        else:
            self.set_message("this camera reports no adjustable controls (or it is unplugged)")
        self.sigControlsRebuilt.emit()

    def values(self) -> dict[str, float]:
        """The value each control shows now (in its range, on its step), by control name."""
        return {name: row.value() for name, row in self.rows.items()}

    def auto_states(self) -> dict[str, bool]:
        """Whether each control that has an automatic mode is on automatic, by control name."""
        return {name: row.auto.isChecked() for name, row in self.rows.items() if row.auto is not None}

    def request_values(self, values: Mapping[str, float],
                       auto: Mapping[str, bool] = MappingProxyType({})) -> dict[str, float]:
        """Ask the device for (saved) values as a user would: automatic modes first, then each
        value that differs from what the device reports, unless the control is on automatic.

        Emits sigAutoRequested / sigControlRequested at once (not coalesced) and shows the
        requested values; names the device does not list are skipped. Returns the values
        requested, clamped to each control's range and step.
        """
        requested: dict[str, float] = {}
        for name, row in self.rows.items():
            on = auto.get(name)
            if row.auto is not None and on is not None and row.auto.isChecked() != bool(on):
                row.auto.setChecked(bool(on))  # toggled -> sigAutoRequested, frees or locks the slider
            if name not in values or (row.auto is not None and row.auto.isChecked()):
                continue
            value = row.control.clamp(values[name])
            if value == row.control.value:
                continue
            row.coalescer.cancel()
            blocked = row.slider.blockSignals(True)
            row.slider.setValue(value)
            row.slider.blockSignals(blocked)
            row.last_sent = value
            requested[name] = value
            self.sigControlRequested.emit(name, value)
        return requested

    def show_applied(self, control: CameraControl) -> None:
        """Show what the device took for one control (clamped), without emitting."""
        row = self.rows.get(control.name)
        if row is not None:
            row.coalescer.cancel()
            row.show(control)

    def set_message(self, text: str, warn: bool = False) -> None:
        """A line above the controls ("" hides it); ``warn`` colours it."""
        self.message.setText(text)
        self.message.setVisible(bool(text))
        self.message.setStyleSheet(f"QLabel {{ color: {WARN_COLOUR}; font-weight: bold; }}" if warn else "")

    def flush(self) -> None:
        """Emit pending slider changes now."""
        for row in self.rows.values():
            row.coalescer.flush()

    # ------------------------------------------------------------------ internals
    def _emit_value(self, row: _ControlRow) -> None:
        value = row.value()
        if value != row.last_sent:
            row.last_sent = value
            self.sigControlRequested.emit(row.control.name, value)

    def _emit_auto(self, row: _ControlRow, on: bool) -> None:
        row.slider.setEnabled(not on)
        self.sigAutoRequested.emit(row.control.name, bool(on))

    def _on_refresh(self) -> None:
        self.sigRefreshRequested.emit()


__all__ = ["DeviceControlsPanel"]
