"""The Teach tab (issue 27 item 3): the panel with real mouse and key events, and the teach feature
running a (short) teaching in its QThread, Cancel keeping the old model. The teaching itself
needs torch (the train extra): those tests skip without it."""
from __future__ import annotations

import numpy as np
import pytest
from PySide6 import QtCore
from PySide6.QtTest import QTest

from core.detect.learned.teach import Mark, TeachConfig
from widgets._style import TOUCH_PX
from widgets.teach_panel import TeachPanel

TIMEOUT_MS = 120_000
LEFT = QtCore.Qt.MouseButton.LeftButton


@pytest.fixture(scope="module")
def lesson():
    from bench.bench_teach import lesson as make

    return make(12)


def _show(qtbot, widget, size=(480, 520)):
    qtbot.addWidget(widget)
    widget.resize(*size)
    widget.show()
    qtbot.waitExposed(widget)
    return widget


def _point_of(canvas, x, y) -> QtCore.QPoint:
    p = canvas.to_widget(x, y)
    return QtCore.QPoint(int(round(p.x())), int(round(p.y())))


def _drag_box(canvas, box):
    a, b = _point_of(canvas, box[0], box[1]), _point_of(canvas, box[2], box[3])
    QTest.mousePress(canvas, LEFT, QtCore.Qt.KeyboardModifier.NoModifier, a)
    QTest.mouseMove(canvas, b)
    QTest.mouseRelease(canvas, LEFT, QtCore.Qt.KeyboardModifier.NoModifier, b)


def test_a_dragged_box_and_a_tap_mark_the_frame_in_image_pixels(qtbot, lesson):
    frames, truth = lesson
    panel = _show(qtbot, TeachPanel())
    assert not panel.teach_button.isEnabled() and not panel.cancel_button.isEnabled()
    panel.set_frames(frames)
    box = truth[0]
    _drag_box(panel.canvas, box)
    (mark,) = panel.mark_list()
    assert mark.frame == 0 and mark.box is not None
    scale = frames[0].shape[1] / panel.canvas._frame_rect().width()  # one screen pixel in image pixels
    assert np.allclose(mark.box, box, atol=2 * scale + 1)
    assert not panel.teach_button.isEnabled()  # no name yet
    qtbot.keyClicks(panel.name_edit, "mug")
    assert panel.teach_button.isEnabled()
    panel.frame_slider.setValue(5)
    cx, cy = (truth[5][0] + truth[5][2]) / 2, (truth[5][1] + truth[5][3]) / 2
    QTest.mouseClick(panel.canvas, LEFT, QtCore.Qt.KeyboardModifier.NoModifier, _point_of(panel.canvas, cx, cy))
    marks = panel.mark_list()
    assert [m.frame for m in marks] == [0, 5] and marks[1].tap is not None
    assert np.allclose(marks[1].tap, (cx, cy), atol=scale + 1)
    qtbot.mouseClick(panel.clear_button, LEFT)
    assert panel.mark_list() == [] and not panel.teach_button.isEnabled()


def test_teach_and_cancel_are_touch_sized_and_the_progress_shows_time_left(qtbot):
    panel = _show(qtbot, TeachPanel())
    for b in (panel.teach_button, panel.cancel_button, panel.capture_button):
        assert b.height() >= TOUCH_PX and b.width() >= TOUCH_PX
    panel.set_progress(0.4, 83.0, "step 4")
    assert panel.progress.value() == 400 and panel.time_left.text() == "1:23 left"
    assert panel.cancel_button.isEnabled() and not panel.teach_button.isEnabled()
    panel.set_done(False, "cancelled — the old model is kept")
    assert not panel.cancel_button.isEnabled()


def _feature(tmp_path, config):
    pytest.importorskip("torch", reason="teaching needs torch (the train extra)")
    pytest.importorskip("onnx", reason="teaching writes ONNX (the train extra)")
    from app.features.teach import TeachFeature

    return TeachFeature(config=config, out_dir=tmp_path)


def _take_frames(qtbot, feature, frames):
    from app.features.teach import FRAME_STRIDE

    qtbot.mouseClick(feature.page.capture_button, LEFT)
    assert feature.capturing
    for f in frames:
        for _ in range(FRAME_STRIDE):  # the camera's frames: every FRAME_STRIDE-th is kept
            feature.on_frame(f)
    feature.finish_capture()
    assert len(feature.page.frames) == len(frames)


def test_the_feature_teaches_from_the_frames_and_says_the_model_changed(qtbot, lesson, tmp_path):
    frames, truth = lesson
    feature = _feature(tmp_path, TeachConfig(steps=3, copies=8, batch_size=4))
    page = _show(qtbot, feature.page)
    _take_frames(qtbot, feature, frames)
    _drag_box(page.canvas, truth[0])
    qtbot.keyClicks(page.name_edit, "card")
    progress = []
    feature.runner.sigProgress.connect(lambda f, left, text: progress.append(f))
    with qtbot.waitSignal(feature.sigModelChanged, timeout=TIMEOUT_MS) as changed:
        qtbot.mouseClick(page.teach_button, LEFT)
    feature.stop()
    assert changed.args[0] == str(tmp_path / "desk_objects.onnx") and (tmp_path / "card.onnx").is_file()
    assert progress and not page.running and "taught 'card'" in page.time_left.text()


def test_cancel_stops_the_teaching_and_keeps_the_old_model(qtbot, lesson, tmp_path):
    frames, truth = lesson
    feature = _feature(tmp_path, TeachConfig(steps=100_000, max_seconds=600, copies=64, batch_size=4))
    page = _show(qtbot, feature.page)
    _take_frames(qtbot, feature, frames)
    _drag_box(page.canvas, truth[0])
    qtbot.keyClicks(page.name_edit, "card")
    qtbot.mouseClick(page.teach_button, LEFT)
    qtbot.waitUntil(lambda: page.progress.value() > 0, timeout=TIMEOUT_MS)
    assert page.cancel_button.isEnabled()
    with qtbot.waitSignal(feature.runner.sigFinished, timeout=TIMEOUT_MS) as finished:
        qtbot.mouseClick(page.cancel_button, LEFT)
    feature.stop()
    assert finished.args[0] is False and "cancelled" in finished.args[1]
    qtbot.waitUntil(lambda: not page.running, timeout=TIMEOUT_MS)
    assert list(tmp_path.iterdir()) == []
    assert [Mark(frame=0, box=page.mark_list()[0].box)] == page.mark_list()
