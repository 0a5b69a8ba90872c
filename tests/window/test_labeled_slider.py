"""The panels' slider-with-its-value rows (widgets._style.LabeledSlider), which replaced
superqt's: driven by taps, drags and typing, and the window no longer imports superqt."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from PySide6 import QtCore, QtWidgets

import widgets  # noqa: F401
from widgets._style import TOUCH_PX, LabeledDoubleSlider, LabeledSlider, touch_slider

ROOT = Path(__file__).resolve().parents[2]
LEFT = QtCore.Qt.MouseButton.LeftButton
TIMEOUT_MS = 3000


def shown(qtbot, slider):
    touch_slider(slider)
    slider.resize(360, TOUCH_PX + 8)
    qtbot.addWidget(slider)
    slider.show()
    qtbot.waitExposed(slider)
    return slider


def test_a_tap_at_the_groove_end_jumps_there_and_says_so_once(qtbot):
    row = LabeledDoubleSlider(QtCore.Qt.Orientation.Horizontal)
    row.setRange(0.0, 4.0)
    row.setSingleStep(0.1)
    row.setDecimals(1)
    shown(qtbot, row)
    inner = row.findChild(QtWidgets.QSlider)
    seen = []
    row.valueChanged.connect(seen.append)
    with qtbot.waitSignal(row.valueChanged, timeout=TIMEOUT_MS):
        qtbot.mouseClick(inner, LEFT, pos=QtCore.QPoint(inner.width() - 3, inner.height() // 2))
    assert row.value() == pytest.approx(4.0) and seen == [pytest.approx(4.0)]
    assert row.findChild(QtWidgets.QDoubleSpinBox).value() == pytest.approx(4.0)  # the value beside it


def test_a_value_typed_in_the_box_moves_the_slider_on_enter(qtbot):
    row = shown(qtbot, LabeledSlider(QtCore.Qt.Orientation.Horizontal))
    row.setRange(-64, 64)
    box, inner = row.findChild(QtWidgets.QSpinBox), row.findChild(QtWidgets.QSlider)
    assert box.height() >= TOUCH_PX  # a finger-sized row, value included
    box.setFocus()
    qtbot.waitUntil(box.hasFocus, timeout=TIMEOUT_MS)
    box.selectAll()
    qtbot.keyClicks(box, "-12")
    assert row.value() == 0  # nothing committed while typing
    with qtbot.waitSignal(row.valueChanged, timeout=TIMEOUT_MS) as blocker:
        qtbot.keyClick(box, QtCore.Qt.Key.Key_Return)
    assert blocker.args == [-12] and row.value() == -12 and inner.value() == -12


def test_set_range_clamps_and_blocked_signals_stay_silent(qtbot):
    row = shown(qtbot, LabeledDoubleSlider(QtCore.Qt.Orientation.Horizontal))
    row.setDecimals(2)
    row.setRange(0.1, 5.0)
    assert (row.minimum(), row.maximum(), row.value()) == (pytest.approx(0.1), pytest.approx(5.0), pytest.approx(0.1))
    seen = []
    row.valueChanged.connect(seen.append)
    held = row.blockSignals(True)
    row.setValue(1.23)
    row.blockSignals(held)
    assert seen == [] and row.value() == pytest.approx(1.23)
    assert row.findChild(QtWidgets.QSlider).value() == 123
    row.setValue(99.0)
    assert row.value() == pytest.approx(5.0) and seen == [pytest.approx(5.0)]


def test_the_window_and_the_command_line_import_neither_superqt_nor_the_headless_runner():
    code = "import sys, app.gui, app.cli; print('superqt' in sys.modules, 'app.headless' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120,
                         env={**__import__("os").environ, "QT_QPA_PLATFORM": "offscreen"})
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["False", "False"]
