"""How the target is chosen: a mode switch and a page per mode (manual, follow, Lissajous, cups,
a marker-less object, teleoperation by hand)."""
from __future__ import annotations

import math
from typing import Optional, Sequence

from PySide6 import QtCore, QtWidgets

from core.messages import TargetMode
from core.settings import LissajousParams
from widgets._style import (
    ERROR_COLOUR,
    OK_COLOUR,
    TOUCH_PX,
    WARN_COLOUR,
    TouchDoubleSpinBox,
    touch_button,
    touch_combo,
    touch_scroll_area,
    touch_slider,
)
from widgets.teleop_panel import TeleopPanel

M_TO_CM = 100.0
CM_TO_SLIDER = 10  # the manual sliders count millimetres: one step per 0.1 cm shown

MODE_LABELS = (
    (TargetMode.MANUAL, "Manual"),
    (TargetMode.FOLLOW, "Follow marker"),
    (TargetMode.LISSAJOUS, "Lissajous"),
    (TargetMode.CUPS, "Cups game"),
    (TargetMode.OBJECT, "Object"),
    (TargetMode.TELEOP, "Teleop"),
)
MODE_BAR_SPACING_PX = 2

# Lissajous spin boxes: (row label, lo, hi, decimals, step) in what the user sees.
LISSAJOUS_ROWS = (
    ("Centre (cm)", -50.0, 50.0, 1, 0.5),
    ("Amplitude (cm)", 0.0, 50.0, 1, 0.5),
    ("Frequency (Hz)", 0.0, 2.0, 2, 0.01),
    ("Phase (°)", -180.0, 180.0, 0, 15.0),
)


class _AxisControl:
    """A slider (integer millimetres) and a spin box (cm, 1 decimal) for one manual axis.

    The spin box is the source of truth: the slider follows it (rounded to its step) but
    never writes back, so a typed 12.3 stays 12.3.
    """

    def __init__(self, lo_cm: float, hi_cm: float, on_change) -> None:
        self._on_change = on_change
        self.slider = QtWidgets.QSlider(QtCore.Qt.Orientation.Horizontal)
        touch_slider(self.slider)
        self.slider.setSingleStep(5)  # 0.5 cm per arrow key
        self.slider.setPageStep(20)
        self.spin = TouchDoubleSpinBox(lo_cm, hi_cm, decimals=1, step=0.5)
        self.set_range(lo_cm, hi_cm)
        self.slider.valueChanged.connect(self._slider_moved)
        self.spin.valueChanged.connect(self._spin_changed)

    def set_range(self, lo_cm: float, hi_cm: float) -> None:
        blocked = (self.slider.blockSignals(True), self.spin.blockSignals(True))
        self.spin.setRange(lo_cm, hi_cm)
        self.slider.setRange(round(lo_cm * CM_TO_SLIDER), round(hi_cm * CM_TO_SLIDER))
        self.slider.setValue(round(self.spin.value() * CM_TO_SLIDER))
        self.slider.blockSignals(blocked[0])
        self.spin.blockSignals(blocked[1])

    def value_cm(self) -> float:
        return float(self.spin.value())

    def set_value_cm(self, value_cm: float) -> None:
        """Set both controls silently (the spin box clamps to its range)."""
        blocked = (self.slider.blockSignals(True), self.spin.blockSignals(True))
        self.spin.setValue(value_cm)
        self.slider.setValue(round(self.spin.value() * CM_TO_SLIDER))
        self.slider.blockSignals(blocked[0])
        self.spin.blockSignals(blocked[1])

    def _slider_moved(self, value: int) -> None:
        blocked = self.spin.blockSignals(True)
        self.spin.setValue(value / CM_TO_SLIDER)
        self.spin.blockSignals(blocked)
        self._on_change()

    def _spin_changed(self, value_cm: float) -> None:
        blocked = self.slider.blockSignals(True)
        self.slider.setValue(round(value_cm * CM_TO_SLIDER))
        self.slider.blockSignals(blocked)
        self._on_change()


class TargetPanel(QtWidgets.QWidget):
    """Target mode switch with pages for manual, follow-marker, Lissajous, cups, object and teleop modes.

    Positions are metres in robot_base in the API; the controls show centimetres, Hz and
    degrees. Long pages scroll so the panel fits an 800×480 screen. The Lissajous "Run"
    button is not reset on a mode change: the owner decides (``set_lissajous_running``).

    Signals (GUI thread):
        sigModeChanged(str): the user picked a mode; a ``TargetMode`` value
            ("manual", "follow", "lissajous", "cups", "object", "teleop").
        sigManualTargetChanged(object): (x, y, z) tuple in metres, after a slider move, a
            committed spin-box edit or :meth:`set_manual_target`.
        sigFollowIdChanged(int): the marker id to follow changed (user pick, ``set_follow_id``
            or the first id appearing when none was selected).
        sigLissajousChanged(object): a valid :class:`LissajousParams` after an edit.
        sigLissajousRunning(bool): the Run button was switched on (True) or off (False).
        sigFollowObjectChanged(str label, object object_id): the marker-less object to follow
            (Object mode): a track id (int) with its label, or None to follow any object of
            that label; a user pick in the list or ``set_follow_object``.

    The Teleop page is a ``widgets.teleop_panel.TeleopPanel`` (``self.teleop``) with its own signals.
    """

    sigModeChanged = QtCore.Signal(str)
    sigManualTargetChanged = QtCore.Signal(object)
    sigFollowIdChanged = QtCore.Signal(int)
    sigLissajousChanged = QtCore.Signal(object)
    sigLissajousRunning = QtCore.Signal(bool)
    sigFollowObjectChanged = QtCore.Signal(str, object)

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._mode = TargetMode.MANUAL
        self._marker_ids: tuple[int, ...] = ()
        self._objects_seen: tuple[tuple[str, int], ...] = ()  # (label, track id), sorted
        self._follow_object: Optional[tuple[str, Optional[int]]] = None  # (label, id) chosen
        self._mode_columns = 0

        # --- mode switch (segmented, exclusive)
        self.mode_buttons: dict[str, QtWidgets.QPushButton] = {}
        self._mode_group = QtWidgets.QButtonGroup(self)
        self._mode_group.setExclusive(True)
        self._mode_bar = QtWidgets.QGridLayout()
        self._mode_bar.setSpacing(MODE_BAR_SPACING_PX)
        for index, (mode, text) in enumerate(MODE_LABELS):
            button = touch_button(text, checkable=True)
            button.setSizePolicy(QtWidgets.QSizePolicy.Policy.Expanding,
                                 QtWidgets.QSizePolicy.Policy.Fixed)
            self._mode_group.addButton(button, index)
            self.mode_buttons[mode.value] = button
        self.mode_buttons[TargetMode.MANUAL.value].setChecked(True)
        self._mode_group.idClicked.connect(self._on_mode_clicked)
        self._layout_mode_bar(2)  # narrow first; resizeEvent widens it when there is room

        # --- pages
        self.stack = QtWidgets.QStackedWidget()
        self.stack.addWidget(touch_scroll_area(self._build_manual_page()))
        self.stack.addWidget(touch_scroll_area(self._build_follow_page()))
        self.stack.addWidget(touch_scroll_area(self._build_lissajous_page()))
        self.stack.addWidget(touch_scroll_area(self._build_cups_page()))
        self.stack.addWidget(touch_scroll_area(self._build_object_page()))
        self.teleop = TeleopPanel()  # source, Restart, target box, state
        self.stack.addWidget(touch_scroll_area(self.teleop))

        # --- reach status, visible on every page
        self.reach_label = QtWidgets.QLabel("")
        self.reach_label.setWordWrap(True)
        self.reach_label.setMinimumHeight(28)
        self.set_reach_status("", True)

        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.setSpacing(4)
        layout.addLayout(self._mode_bar)
        layout.addWidget(self.stack, 1)
        layout.addWidget(self.reach_label)

    # ----------------------------------------------------------------------------- pages
    def _build_manual_page(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        grid = QtWidgets.QGridLayout(page)
        grid.setContentsMargins(2, 2, 2, 2)
        grid.setColumnStretch(1, 1)
        self.axes: dict[str, _AxisControl] = {}
        defaults = {"x": (-25.0, 25.0, 0.0), "y": (-25.0, 25.0, 15.0), "z": (0.0, 30.0, 10.0)}
        for row, (axis, (lo, hi, value)) in enumerate(defaults.items()):
            control = _AxisControl(lo, hi, self._emit_manual)
            control.set_value_cm(value)
            label = QtWidgets.QLabel(f"{axis.upper()} cm")
            label.setMinimumHeight(TOUCH_PX)
            grid.addWidget(label, row, 0)
            grid.addWidget(control.slider, row, 1)
            grid.addWidget(control.spin, row, 2)
            self.axes[axis] = control
        hint = QtWidgets.QLabel("Tip: tap a marker in a camera view to go there.")
        hint.setWordWrap(True)
        hint.setEnabled(False)
        grid.addWidget(hint, 3, 0, 1, 3)
        grid.setRowStretch(4, 1)
        return page

    def _build_follow_page(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(page)
        layout.setContentsMargins(2, 2, 2, 2)
        row = QtWidgets.QHBoxLayout()
        row.addWidget(QtWidgets.QLabel("Marker id"))
        self.follow_combo = touch_combo(QtWidgets.QComboBox())
        self.follow_combo.setMinimumHeight(TOUCH_PX)
        self.follow_combo.setMinimumWidth(120)
        self.follow_combo.setPlaceholderText("no marker seen")
        self.follow_combo.currentIndexChanged.connect(self._on_follow_index)
        row.addWidget(self.follow_combo, 1)
        layout.addLayout(row)
        hint = QtWidgets.QLabel("The arm follows this marker; when it is lost the arm holds "
                                "its position. Tap a marker in a camera view to pick it.")
        hint.setWordWrap(True)
        hint.setEnabled(False)
        layout.addWidget(hint)
        layout.addStretch(1)
        return page

    def _build_lissajous_page(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        grid = QtWidgets.QGridLayout(page)
        grid.setContentsMargins(2, 2, 2, 2)
        grid.setHorizontalSpacing(4)
        grid.setVerticalSpacing(2)
        # Run first: what the user taps right after choosing the mode is never below the fold
        self.run_button = touch_button("▶ Run", checkable=True)
        self.run_button.toggled.connect(self._on_run_toggled)
        grid.addWidget(self.run_button, 0, 0, 1, 3)
        # Each quantity's name is a header row above its X, Y, Z boxes: three finger-sized
        # spin boxes then fit side by side in a ~360 px wide panel.
        for col, axis in enumerate("XYZ"):
            header = QtWidgets.QLabel(axis)
            header.setAlignment(QtCore.Qt.AlignmentFlag.AlignCenter)
            font = header.font()
            font.setBold(True)
            header.setFont(font)
            grid.addWidget(header, 1, col)
        self.lissajous_spins: list[list[TouchDoubleSpinBox]] = []
        row = 2
        for text, lo, hi, decimals, step in LISSAJOUS_ROWS:
            grid.addWidget(QtWidgets.QLabel(text), row, 0, 1, 3)
            spins = []
            for col in range(3):
                spin = TouchDoubleSpinBox(lo, hi, decimals=decimals, step=step)
                spin.valueChanged.connect(self._emit_lissajous)
                grid.addWidget(spin, row + 1, col)
                spins.append(spin)
            self.lissajous_spins.append(spins)
            row += 2
        grid.setRowStretch(row, 1)
        self.set_lissajous(LissajousParams())
        return page

    def _build_cups_page(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(page)
        text = QtWidgets.QLabel("Cups game: hide the ball under one of the marked cups and "
                                "shuffle them. The arm points at the cup hiding the ball.")
        text.setWordWrap(True)
        layout.addWidget(text)
        self.cups_hint = QtWidgets.QLabel("")
        self.cups_hint.setWordWrap(True)
        self.cups_hint.setStyleSheet(f"QLabel {{ color: {WARN_COLOUR}; font-weight: bold; }}")
        self.cups_hint.hide()
        layout.addWidget(self.cups_hint)
        layout.addStretch(1)
        return page

    def _build_object_page(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(page)
        layout.setContentsMargins(2, 2, 2, 2)
        row = QtWidgets.QHBoxLayout()
        row.addWidget(QtWidgets.QLabel("Object"))
        self.object_combo = touch_combo(QtWidgets.QComboBox())
        self.object_combo.setObjectName("object_combo")
        self.object_combo.setMinimumWidth(120)
        self.object_combo.setPlaceholderText("no object seen")
        self.object_combo.currentIndexChanged.connect(self._on_object_index)
        row.addWidget(self.object_combo, 1)
        layout.addLayout(row)
        self.object_hint = QtWidgets.QLabel("")
        self.object_hint.setWordWrap(True)
        self.object_hint.setStyleSheet(f"QLabel {{ color: {WARN_COLOUR}; font-weight: bold; }}")
        self.object_hint.hide()
        layout.addWidget(self.object_hint)
        hint = QtWidgets.QLabel("The arm follows this object; when it is not seen the arm holds "
                                "its position. Tap an object's box in a camera view to pick it. "
                                "Detectors and colours: the Objects tab.")
        hint.setWordWrap(True)
        hint.setEnabled(False)
        layout.addWidget(hint)
        layout.addStretch(1)
        return page

    def set_cups_hint(self, text: str) -> None:
        """What the cups game needs here (e.g. a scene with a ball); "" hides it."""
        self.cups_hint.setText(text)
        self.cups_hint.setVisible(bool(text))

    # ----------------------------------------------------------------------------- mode
    @property
    def mode(self) -> str:
        """The current mode's ``TargetMode`` value."""
        return self._mode.value

    def set_mode(self, mode: str) -> None:
        """Select a mode (button and page) without emitting sigModeChanged."""
        self._mode = TargetMode(mode)
        index = [m for m, _ in MODE_LABELS].index(self._mode)
        self._mode_group.button(index).setChecked(True)
        self.stack.setCurrentIndex(index)

    def _on_mode_clicked(self, index: int) -> None:
        mode = MODE_LABELS[index][0]
        self.stack.setCurrentIndex(index)
        if mode != self._mode:
            self._mode = mode
            self.sigModeChanged.emit(mode.value)

    def _layout_mode_bar(self, columns: int) -> None:
        if columns == self._mode_columns:
            return
        self._mode_columns = columns
        for index in range(len(MODE_LABELS)):
            button = self._mode_group.button(index)
            self._mode_bar.removeWidget(button)
            self._mode_bar.addWidget(button, index // columns, index % columns)

    def _widest_mode_button(self) -> int:
        return max(b.minimumSizeHint().width() for b in self._mode_group.buttons())

    def minimumSizeHint(self) -> QtCore.QSize:  # noqa: N802 (Qt override)
        """As narrow as the pages allow: the mode bar wraps to two columns when squeezed."""
        hint = super().minimumSizeHint()
        margins = self.layout().contentsMargins()
        two_columns = 2 * self._widest_mode_button() + MODE_BAR_SPACING_PX
        pages = max(self.stack.minimumSizeHint().width(), self.reach_label.minimumWidth())
        hint.setWidth(max(two_columns, pages) + margins.left() + margins.right())
        return hint

    def mode_bar_columns(self, width: int) -> int:
        """How many mode buttons fit side by side in a panel ``width`` px wide: all in one row
        when there is room, else as many as fit (at least two), in as few rows as that allows."""
        margins = self.layout().contentsMargins()
        room = width - margins.left() - margins.right()
        fit = max(2, (room + MODE_BAR_SPACING_PX) // (self._widest_mode_button() + MODE_BAR_SPACING_PX))
        n = len(MODE_LABELS)
        if fit >= n:
            return n
        rows = -(-n // fit)
        return -(-n // rows)  # the same rows, filled evenly (5 buttons: 3 + 2, not 4 + 1; 6: 3 + 3)

    def resizeEvent(self, event) -> None:  # noqa: N802 (Qt override)
        """All mode buttons in a row when there is room, else wrapped into even rows."""
        self._layout_mode_bar(self.mode_bar_columns(event.size().width()))
        super().resizeEvent(event)

    # ----------------------------------------------------------------------------- manual
    def manual_target(self) -> tuple[float, float, float]:
        """The manual target (x, y, z) in metres, as the spin boxes show it."""
        return tuple(self.axes[a].value_cm() / M_TO_CM for a in "xyz")  # type: ignore[return-value]

    def set_manual_ranges(self, xmin: float, xmax: float, ymin: float, ymax: float,
                          zmin: float, zmax: float) -> None:
        """Limits of the manual X, Y, Z controls, in metres (values are clamped, no signal)."""
        for axis, lo, hi in (("x", xmin, xmax), ("y", ymin, ymax), ("z", zmin, zmax)):
            if not lo < hi:
                raise ValueError(f"manual range {axis}: min {lo} m must be below max {hi} m")
            self.axes[axis].set_range(lo * M_TO_CM, hi * M_TO_CM)

    def set_manual_target(self, p_m: Sequence[float]) -> None:
        """Move the manual controls to p (metres, clamped to the ranges) and emit once."""
        for axis, value in zip("xyz", p_m):
            self.axes[axis].set_value_cm(float(value) * M_TO_CM)
        self._emit_manual()

    def show_manual_target(self, p_m: Sequence[float]) -> None:
        """Show p (metres, clamped to the ranges) without emitting: the target was set elsewhere
        (e.g. the Pose tab) and this panel shows the same state."""
        for axis, value in zip("xyz", p_m):
            self.axes[axis].set_value_cm(float(value) * M_TO_CM)

    def _emit_manual(self) -> None:
        self.sigManualTargetChanged.emit(self.manual_target())

    # ----------------------------------------------------------------------------- follow
    @property
    def follow_id(self) -> Optional[int]:
        """The selected marker id, or None when there is none."""
        data = self.follow_combo.currentData()
        return None if data is None else int(data)

    def set_marker_ids(self, ids: Sequence[int]) -> None:
        """Offer these marker ids; the selected id stays selected (shown "not seen" if absent)."""
        new_ids = tuple(sorted({int(i) for i in ids}))
        if new_ids == self._marker_ids:
            return  # called every frame: leave an open popup alone
        self._marker_ids = new_ids
        self._fill_follow_combo(self.follow_id)

    def set_follow_id(self, marker_id: int) -> None:
        """Select a marker id to follow (e.g. tapped in a camera view); emits if it changed."""
        self._fill_follow_combo(int(marker_id))

    def _fill_follow_combo(self, selected: Optional[int]) -> None:
        """Rebuild the list, select ``selected`` (else the first id); emit if that changed."""
        before = self.follow_id
        entries = list(self._marker_ids)
        if selected is not None and selected not in entries:
            entries = sorted(entries + [selected])
        if selected is None and entries:
            selected = entries[0]
        blocked = self.follow_combo.blockSignals(True)
        self.follow_combo.clear()
        for marker_id in entries:
            seen = marker_id in self._marker_ids
            self.follow_combo.addItem(str(marker_id) if seen else f"{marker_id} (not seen)",
                                      marker_id)
        if selected is not None:
            self.follow_combo.setCurrentIndex(entries.index(selected))
        self.follow_combo.blockSignals(blocked)
        after = self.follow_id
        if after is not None and after != before:
            self.sigFollowIdChanged.emit(after)

    def _on_follow_index(self, _index: int) -> None:
        marker_id = self.follow_id
        if marker_id is not None:
            self.sigFollowIdChanged.emit(marker_id)

    # ----------------------------------------------------------------------------- object
    @property
    def follow_object(self) -> Optional[tuple[str, Optional[int]]]:
        """The chosen object as (label, track id or None for "any of that label"), or None."""
        data = self.object_combo.currentData()
        return None if data is None else (str(data[0]), None if data[1] is None else int(data[1]))

    def set_objects_seen(self, objects: Sequence[tuple[str, int]]) -> None:
        """Offer these (label, track id) objects, and each label as "any <label>"; the chosen
        entry stays chosen (shown "not seen" when absent), the first one is chosen when none was
        (emitting, as the marker list does). Called with every frame: it leaves an open popup
        alone unless the objects seen changed."""
        seen = tuple(sorted({(str(label), int(i)) for label, i in objects}, key=lambda o: (o[1], o[0])))
        if seen == self._objects_seen:
            return
        self._objects_seen = seen
        self._fill_object_combo(self._follow_object)

    def set_follow_object(self, label: str, object_id: Optional[int]) -> None:
        """Choose an object to follow (e.g. tapped in a camera view); emits if it changed."""
        self._fill_object_combo((str(label), None if object_id is None else int(object_id)))

    def set_object_hint(self, text: str) -> None:
        """What Object mode needs here (e.g. a detector turned on); "" hides it."""
        self.object_hint.setText(text)
        self.object_hint.setVisible(bool(text))

    @staticmethod
    def object_text(label: str, object_id: Optional[int]) -> str:
        return f"any {label}" if object_id is None else f"{label} #{object_id}"

    def _fill_object_combo(self, selected: Optional[tuple[str, Optional[int]]]) -> None:
        """Rebuild the list, choose ``selected`` (else the first entry); emit if that changed."""
        before = self.follow_object
        entries: list[tuple[str, Optional[int]]] = list(self._objects_seen)
        entries += [(label, None) for label in sorted({label for label, _ in self._objects_seen})]
        if selected is not None and selected not in entries:
            entries.append(selected)
        if selected is None and entries:
            selected = entries[0]
        blocked = self.object_combo.blockSignals(True)
        self.object_combo.clear()
        for label, object_id in entries:
            available = object_id is None or (label, object_id) in self._objects_seen
            text = self.object_text(label, object_id)
            self.object_combo.addItem(text if available else f"{text} (not seen)", (label, object_id))
        self.object_combo.setCurrentIndex(entries.index(selected) if selected is not None else -1)
        self.object_combo.blockSignals(blocked)
        self._follow_object = selected
        after = self.follow_object
        if after is not None and after != before:
            self.sigFollowObjectChanged.emit(after[0], after[1])

    def _on_object_index(self, _index: int) -> None:
        chosen = self.follow_object
        if chosen is not None:
            self._follow_object = chosen
            self.sigFollowObjectChanged.emit(chosen[0], chosen[1])

    # ----------------------------------------------------------------------------- Lissajous
    def lissajous(self) -> LissajousParams:
        """The Lissajous parameters the spin boxes show, in metres, Hz and radians."""
        centre, amplitude, frequency, phase = (
            [spin.value() for spin in row] for row in self.lissajous_spins)
        return LissajousParams(
            centre=tuple(v / M_TO_CM for v in centre),
            amplitude=tuple(v / M_TO_CM for v in amplitude),
            frequency_hz=tuple(float(v) for v in frequency),
            phase_rad=tuple(max(-math.pi, min(math.pi, math.radians(v))) for v in phase),
        )

    def set_lissajous(self, params: LissajousParams) -> None:
        """Show ``params`` in the spin boxes without emitting."""
        values = (
            [v * M_TO_CM for v in params.centre],
            [v * M_TO_CM for v in params.amplitude],
            list(params.frequency_hz),
            [math.degrees(v) for v in params.phase_rad],
        )
        for spins, row in zip(self.lissajous_spins, values):
            for spin, value in zip(spins, row):
                blocked = spin.blockSignals(True)
                spin.setValue(value)
                spin.blockSignals(blocked)

    @property
    def lissajous_running(self) -> bool:
        """True while the Run button is on."""
        return self.run_button.isChecked()

    def set_lissajous_running(self, running: bool) -> None:
        """Switch the Run button without emitting sigLissajousRunning."""
        blocked = self.run_button.blockSignals(True)
        self.run_button.setChecked(running)
        self.run_button.blockSignals(blocked)
        self._update_run_text()

    def _emit_lissajous(self, *_args) -> None:
        self.sigLissajousChanged.emit(self.lissajous())

    def _on_run_toggled(self, running: bool) -> None:
        self._update_run_text()
        self.sigLissajousRunning.emit(running)

    def _update_run_text(self) -> None:
        self.run_button.setText("■ Stop" if self.run_button.isChecked() else "▶ Run")

    # ----------------------------------------------------------------------------- status
    def detach_reach_label(self) -> QtWidgets.QLabel:
        """Take the reach status out of the panel, for the owner to show where it is always in
        view (the window's top strip); ``set_reach_status`` keeps updating it."""
        self.layout().removeWidget(self.reach_label)
        self.reach_label.setParent(None)
        return self.reach_label

    def set_reach_status(self, text: str, ok: bool) -> None:
        """Show a reach message, e.g. "out of reach by 23 mm — going to the nearest point"."""
        if text == self.reach_label.text() and self.reach_label.property("reach_ok") == bool(ok):
            return  # the usual frame: a style sheet set again re-polishes and re-lays out
        self.reach_label.setText(text)
        if ok:
            style = f"QLabel {{ color: {OK_COLOUR}; padding: 2px 4px; }}"
        else:
            style = (f"QLabel {{ background: {ERROR_COLOUR}; color: white; font-weight: bold;"
                     f" padding: 2px 4px; }}")
        self.reach_label.setStyleSheet(style)
        self.reach_label.setProperty("reach_ok", ok)
