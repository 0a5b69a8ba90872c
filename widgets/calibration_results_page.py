"""The calibration wizard's third page: RMS per camera, stereo RMS and the epipolar error, the
per-pair error plot with the worst pairs in red, one-tap removal and recalibration, the rectified
preview and Save and use.

``ResultsPage`` holds the page's code; ``CalibrationWizard`` (``widgets.calibration_wizard``) mixes it
in, owns the signals it emits (``sigRemoveRequested``, ``sigSaveRequested``) and keeps the worker's
slots (``on_report`` and ``on_saved`` hand over to ``_show_report`` and ``_show_saved`` here).
"""
from __future__ import annotations

import math

import numpy as np
from PySide6 import QtCore, QtGui, QtWidgets

from core.vision.stereo_calibration import rms_verdict
from widgets._pyqtgraph import pg
from widgets._plots import static_bar_plot
from widgets._style import ERROR_COLOUR, OK_COLOUR, TOUCH_PX, WARN_COLOUR, touch_button
from widgets.calibration_wizard_parts import (
    REJECTED_BRUSH,
    SELECTED_PEN,
    USED_BRUSH,
    WORST_BRUSH,
    ImagePane,
    _bold,
    _short,
    _status_style,
    worst_count,
)


class ResultsPage:
    """The results page of ``CalibrationWizard`` (a mix-in: the wizard's attributes and signals)."""

    def _build_results_page(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(page)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(4)
        self.progress_bar = QtWidgets.QProgressBar()
        self.progress_bar.setRange(0, 1000)
        self.progress_bar.setMinimumHeight(24)
        layout.addWidget(self.progress_bar)
        numbers = QtWidgets.QGridLayout()
        numbers.setHorizontalSpacing(12)
        numbers.setVerticalSpacing(0)
        self.rms_labels: dict[str, QtWidgets.QLabel] = {}
        for col, (key, title) in enumerate((("left", "RMS left"), ("right", "RMS right"),
                                            ("stereo", "Stereo RMS"), ("epipolar", "Epipolar error"))):
            name = QtWidgets.QLabel(title)
            value = _bold(QtWidgets.QLabel("—"), 1.3)
            numbers.addWidget(name, 0, col)
            numbers.addWidget(value, 1, col)
            self.rms_labels[key] = value
        layout.addLayout(numbers)
        self.summary_label = QtWidgets.QLabel()
        self.summary_label.setWordWrap(True)
        layout.addWidget(self.summary_label)

        body = QtWidgets.QHBoxLayout()
        body.setSpacing(6)
        left = QtWidgets.QVBoxLayout()
        left.setSpacing(4)
        self.error_plot, self._bars = static_bar_plot("error (px)", "capture")
        self.error_plot.scene().sigMouseClicked.connect(self._on_plot_clicked)
        left.addWidget(self.error_plot, 3)
        self.pair_list = QtWidgets.QListWidget()
        self.pair_list.setSelectionMode(QtWidgets.QAbstractItemView.SelectionMode.MultiSelection)
        self.pair_list.setMinimumHeight(TOUCH_PX + 8)
        self.pair_list.verticalScrollBar().setStyleSheet("QScrollBar:vertical { width: 26px; }")
        self.pair_list.itemSelectionChanged.connect(self._on_selection_changed)
        QtWidgets.QScroller.grabGesture(self.pair_list.viewport(), QtWidgets.QScroller.ScrollerGestureType.TouchGesture)
        left.addWidget(self.pair_list, 2)
        body.addLayout(left, 1)
        right = QtWidgets.QVBoxLayout()
        right.setSpacing(2)
        self.preview_pane = ImagePane("rectified: features must sit on the same line")
        right.addWidget(self.preview_pane, 1)
        self.saved_label = QtWidgets.QLabel()
        self.saved_label.setWordWrap(True)
        self.saved_label.setTextInteractionFlags(QtCore.Qt.TextInteractionFlag.TextSelectableByMouse)
        self.saved_label.hide()
        right.addWidget(self.saved_label)
        body.addLayout(right, 1)
        layout.addLayout(body, 1)

        buttons = QtWidgets.QHBoxLayout()
        self.more_button = touch_button("◀ Capture more")
        self.more_button.clicked.connect(lambda: self.set_page("capture"))
        self.remove_worst_button = touch_button("Remove worst (#000)")
        self.remove_worst_button.setToolTip("Drop the pair with the largest error and calibrate again")
        self.remove_worst_button.clicked.connect(self._on_remove_worst)
        self.remove_selected_button = touch_button("Remove selected")
        self.remove_selected_button.setToolTip("Drop the pairs selected in the list (or tapped in the plot)")
        self.remove_selected_button.clicked.connect(self._on_remove_selected)
        self.save_button = touch_button("Save and use")
        self.save_button.setToolTip("Make this the app's calibration: perception and disparity switch to it now")
        self.save_button.clicked.connect(self._on_save)
        for b in (self.more_button, self.remove_worst_button, self.remove_selected_button):
            buttons.addWidget(b)
        buttons.addStretch(1)
        buttons.addWidget(self.save_button)
        layout.addLayout(buttons)
        self._update_result_buttons()
        return page

    def _start_busy(self, text: str) -> None:
        self._busy = True
        self.progress_bar.setValue(0)
        self.progress_bar.setFormat(text)
        self.progress_bar.show()
        self._update_result_buttons()
        self._update_calibrate_button()

    def _update_result_buttons(self) -> None:
        ok = self.report_update is not None and not self._busy
        self.remove_worst_button.setEnabled(ok and bool(self._worst))
        self.remove_worst_button.setText(f"Remove worst (#{self._worst[0]})" if self._worst else "Remove worst")
        self.remove_selected_button.setEnabled(ok and bool(self.pair_list.selectedItems()))
        report = self.report_update.report if self.report_update is not None else None
        self.save_button.setEnabled(ok and bool(getattr(report, "ok", True)))  # never install a failed check
        self.more_button.setEnabled(not self._busy)

    def _on_selection_changed(self) -> None:
        self._update_result_buttons()
        self._colour_bars()

    def _on_plot_clicked(self, event) -> None:
        """A tap on the plot selects (or unselects) the nearest bar's pair in the list."""
        if not self._bar_numbers or event.button() != QtCore.Qt.MouseButton.LeftButton:
            return
        vb = self.error_plot.getPlotItem().vb
        if not vb.sceneBoundingRect().contains(event.scenePos()):
            return
        x = vb.mapSceneToView(event.scenePos()).x()
        k = int(round(x))
        if 0 <= k < len(self._bar_numbers):
            self.select_pair(self._bar_numbers[k], toggle=True)

    def select_pair(self, number: int, toggle: bool = False) -> None:
        """Select the list row of capture ``number`` (toggle: unselect if selected)."""
        for i in range(self.pair_list.count()):
            item = self.pair_list.item(i)
            if item.data(QtCore.Qt.ItemDataRole.UserRole) == number:
                item.setSelected(not item.isSelected() if toggle else True)
                self.pair_list.scrollToItem(item)

    def selected_numbers(self) -> tuple[int, ...]:
        return tuple(sorted(int(i.data(QtCore.Qt.ItemDataRole.UserRole)) for i in self.pair_list.selectedItems()))

    def _on_remove_worst(self) -> None:
        if self._worst:
            self._request_remove((self._worst[0],))

    def _on_remove_selected(self) -> None:
        numbers = self.selected_numbers()
        if numbers:
            self._request_remove(numbers)

    def _request_remove(self, numbers: tuple[int, ...]) -> None:
        self._start_busy(f"removing #{', #'.join(map(str, numbers))} and calibrating again …")
        self.saved_label.hide()
        self.sigRemoveRequested.emit(tuple(numbers))

    def _on_save(self) -> None:
        if self.report_update is not None:
            self.sigSaveRequested.emit(self.report_update)

    def _colour_bars(self) -> None:
        if not self._bar_numbers or self.report_update is None:
            return
        selected = set(self.selected_numbers())
        brushes, pens = [], []
        rep, numbers = self.report_update.report, self.report_update.numbers
        for p in rep.pairs:
            n = numbers[p.index]
            brushes.append(REJECTED_BRUSH if not p.used else WORST_BRUSH if n in self._worst else USED_BRUSH)
            pens.append(SELECTED_PEN if n in selected else pg.mkPen(None))
        self._bars.setOpts(brushes=brushes, pens=pens)

    def _show_report(self, update) -> None:
        """A finished calibration (ReportUpdate) of the session shown: numbers, plot, list, preview."""
        self._busy = False
        self.report_update = update
        rep = update.report
        self.rms_labels["left"].setText(f"{rep.rms_left:.3f} px")
        self.rms_labels["right"].setText(f"{rep.rms_right:.3f} px")
        self.rms_labels["stereo"].setText(f"{rep.rms_stereo:.3f} px")
        self.rms_labels["epipolar"].setText(f"{rep.epipolar_error_px:.3f} px")
        c = rep.calibration
        verdict = rms_verdict(rep.rms_stereo, rep.epipolar_error_px)
        summary = (f"{rep.pairs_used} of {rep.pairs_total} pairs used · baseline {c.baseline_m * 1e3:.1f} mm · "
                   f"fx {c.M1[0, 0]:.0f} / {c.M2[0, 0]:.0f} px · {rep.duration_s:.1f} s")
        problems = list(getattr(rep, "problems", ()) or ())
        notes = [verdict] if verdict else ["good: errors below 0.5 px"]
        if problems:  # a sanity check failed: said first, and Save and use stays off
            notes = [f"NOT INSTALLABLE — {p}" for p in problems] + notes
            consequences = list(getattr(rep, "consequences", ()) or ())
            if consequences:  # checks that failed only because of the problem above, after it
                notes.insert(len(problems), "which also explains: " + "; ".join(consequences))
        notes += list(rep.notes)
        self.summary_label.setText(summary + "\n" + "\n".join(notes))
        bad = problems or "warning" in verdict
        self.summary_label.setStyleSheet(f"QLabel {{ color: {ERROR_COLOUR if bad else WARN_COLOUR if verdict else OK_COLOUR}; }}")
        used = sum(p.used for p in rep.pairs)
        self._worst = [update.numbers[k] for k in rep.worst(worst_count(used))]
        self._fill_pairs(update)
        self.preview_pane.set_image(update.preview)
        if update.preview_number is not None:
            self.preview_pane.set_caption(f"#{update.preview_number} rectified: features must sit on the same line")
        self.progress_bar.setValue(1000)
        self.progress_bar.setFormat("calibrated")
        self.progress_bar.hide()  # the numbers say it all; the row is worth more on a small screen
        self._update_result_buttons()
        self._update_calibrate_button()

    def _fill_pairs(self, update) -> None:
        rep, numbers = update.report, update.numbers
        self.pair_list.blockSignals(True)
        self.pair_list.clear()
        order = sorted(rep.pairs, key=lambda p: (not p.used, -(p.error_px or 0.0)))
        for p in order:
            n = numbers[p.index]
            if p.used:
                text = f"#{n}   {p.error_px:.3f} px   (epipolar {p.epipolar_px or 0:.3f} px)"
                if n in self._worst:
                    text += "   ◀ worst"
            else:
                text = f"#{n}   rejected: {p.reason}"
            item = QtWidgets.QListWidgetItem(text)
            item.setData(QtCore.Qt.ItemDataRole.UserRole, int(n))
            item.setSizeHint(QtCore.QSize(0, TOUCH_PX))
            if not p.used or n in self._worst:
                item.setForeground(QtGui.QBrush(QtGui.QColor(ERROR_COLOUR if n in self._worst else "#777777")))
            self.pair_list.addItem(item)
        self.pair_list.blockSignals(False)
        # the plot: one bar per pair in capture order; rejected pairs grey, the worst red
        xs = np.arange(len(rep.pairs), dtype=float)
        heights = [p.error_px if p.error_px is not None else 0.0 for p in rep.pairs]
        self._bar_numbers = [numbers[p.index] for p in rep.pairs]
        self._bars.setOpts(x=xs, height=heights, width=0.7)
        self._colour_bars()
        top = max([h for h in heights if math.isfinite(h)] + [0.1]) * 1.15
        self.error_plot.setXRange(-0.6, len(rep.pairs) - 0.4, padding=0)
        self.error_plot.setYRange(0, top, padding=0)
        step = max(1, int(math.ceil(len(rep.pairs) / 12)))
        ticks = [(float(k), str(n)) for k, n in enumerate(self._bar_numbers) if k % step == 0]
        self.error_plot.getAxis("bottom").setTicks([ticks])

    def _show_saved(self, path: str, ros_folder: str = "") -> None:
        """Say that the calibration was installed at ``path`` (and exported for ROS to ``ros_folder``)."""
        self.saved_label.setText(f"✓ Saved and in use: {_short(path)}"
                                 + (f" · ROS camera_info and pairs in {_short(self.folder)}" if self.folder else ""))
        details = [f"calibration: {path}"]
        if ros_folder:
            details.append(f"ROS camera_info (left.yaml, right.yaml): {ros_folder}")
        if self.folder:
            details.append(f"captured pairs: {self.folder} — `deskarm calibrate --folder` redoes the calibration")
        self.saved_label.setToolTip("\n".join(details))
        self.saved_label.setStyleSheet(_status_style("ok"))
        self.saved_label.show()
