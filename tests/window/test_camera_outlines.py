"""A camera view's outlines cost the GUI thread less per frame (issue 28, a Pi 4 core's budget)
and look the same (pytest-qt, offscreen): all the objects' outlines (and all the markers') are
one graphics item per view, painting the very pixels one PlotCurveItem per outline painted, and
a marker lying still is not drawn again when another one moves.

Views are driven through their public calls in the GUI thread; waits are on conditions.
"""
from __future__ import annotations

import numpy as np
import pytest
from PySide6 import QtCore, QtWidgets

import widgets  # noqa: F401  (sets pyqtgraph's row-major image order)
from widgets._pyqtgraph import pg
from widgets.camera_overlays import LOST_COLOUR, FOUND_COLOUR, MARKER_Z, OBJECT_Z
from widgets.camera_view import CameraView, MarkerOverlay, ObjectOverlay

TIMEOUT_MS = 5000


def drain() -> None:
    for _ in range(3):
        QtWidgets.QApplication.processEvents()


def objects(shift: float = 0.0) -> list[ObjectOverlay]:
    """Eight objects in a row: seen, one lost (dashed), one unsure (dotted), outlines not boxes."""
    out = []
    for k in range(8):
        x, y = 40 + 70 * k + shift, 100 + 30 * (k % 4)
        outline = np.array([[x, y], [x + 50.3, y + 2.2], [x + 48, y + 47.5], [x - 1.5, y + 45]])
        out.append(ObjectOverlay(k + 1, (x - 1.5, y, 51.8, 47.5), outline, f"#{k + 1} {'ball' if k % 2 else 'cup'}",
                                 seen=k != 3, unsure=k == 5))
    return out


def markers(shift: float = 0.0) -> list[MarkerOverlay]:
    """Three markers: 23 found, 7 lost (dashed), 50 found; ``shift`` moves only 50."""
    square = np.array([[0, 0], [30, 2], [28, 31], [-1, 29]], float)
    return [MarkerOverlay(23, square + (300, 300), True, "23: x 1.0 y 2.0 z 3.0 cm"),
            MarkerOverlay(7, square + (100, 380), False, ""),
            MarkerOverlay(50, square + (500 + shift, 60), True, "")]


@pytest.fixture
def make_view(qtbot):
    made = []

    def make(width: int = 390, height: int = 300) -> CameraView:
        view = CameraView("Left")
        qtbot.addWidget(view)
        view.resize(width, height)
        view.show()
        qtbot.waitExposed(view)
        view.show_image(np.random.default_rng(1).integers(0, 255, (480, 640, 3), dtype=np.uint8))
        drain()
        made.append(view)
        return view

    yield make
    for view in made:
        view.close()


def scene_items(view: CameraView) -> set:
    return set(view.graphics_view.scene().items())


def test_a_views_object_outlines_are_one_graphics_item_however_many_objects(make_view):
    view = make_view()
    before = scene_items(view)
    view.set_objects(objects())
    drain()
    added = scene_items(view) - before
    labels = [item for item in added if isinstance(item, pg.TextItem)]
    assert len(labels) == 8  # a label per object …
    # … and one item for all eight outlines (with the label's own text child: 8 + 8 + 1)
    assert len(added) == 2 * len(labels) + 1
    assert not any(isinstance(item, pg.PlotCurveItem) for item in added)
    view.set_objects(objects(shift=3.0))  # every object moved: still the same items
    drain()
    assert scene_items(view) - before == added
    assert set(view.object_colours()) == set(range(1, 9))


def test_outlines_paint_the_pixels_a_plot_curve_item_per_outline_paints(make_view):
    """Solid, dashed (lost) and dotted (unsure) objects and found and lost markers, against a
    view with the same image and one antialiased PlotCurveItem per outline at the same z."""
    drawn, reference = make_view(), make_view()
    shown_objects, shown_markers = objects(), markers()
    drawn.set_overlays(shown_markers, shown_objects)
    drain()
    for slot in drawn._objects + drawn._markers:  # outlines only: the labels are the same items in both
        for item in (getattr(slot, "id_text", None), slot.label_text):
            if item is not None:
                item.setVisible(False)
    colours = drawn.object_colours()
    box = reference._view_box
    for o in shown_objects:
        style = (QtCore.Qt.PenStyle.DotLine if o.unsure else
                 QtCore.Qt.PenStyle.SolidLine if o.seen else QtCore.Qt.PenStyle.DashLine)
        closed = np.vstack([o.outline, o.outline[:1]])
        curve = pg.PlotCurveItem(closed[:, 0], closed[:, 1], antialias=True,
                                 pen=pg.mkPen(colours[o.object_id], width=2 if o.unsure else 3, style=style))
        curve.setZValue(OBJECT_Z)
        box.addItem(curve, ignoreBounds=True)
    for m in shown_markers:
        closed = np.vstack([m.corners, m.corners[:1]])
        style = QtCore.Qt.PenStyle.SolidLine if m.found else QtCore.Qt.PenStyle.DashLine
        curve = pg.PlotCurveItem(closed[:, 0], closed[:, 1], antialias=True,
                                 pen=pg.mkPen(FOUND_COLOUR if m.found else LOST_COLOUR, width=3, style=style))
        curve.setZValue(MARKER_Z)
        box.addItem(curve, ignoreBounds=True)
    drain()
    a, b = drawn.graphics_view.grab().toImage(), reference.graphics_view.grab().toImage()
    assert a.size() == b.size() and a == b
    drawn.set_display_mode("disparity")  # outlines are hidden over the disparity map …
    drawn.set_display_mode("image")  # … and back
    for slot in drawn._objects + drawn._markers:
        for item in (getattr(slot, "id_text", None), slot.label_text):
            if item is not None:
                item.setVisible(False)
    drain()
    assert drawn.graphics_view.grab().toImage() == b


def test_a_still_marker_is_not_drawn_again_when_another_one_moves(qtbot, monkeypatch, make_view):
    view = make_view()
    view.set_markers(markers())
    drain()
    calls = {}
    for slot in view._markers:
        original = slot.outline.setData

        def counting(*args, _id=slot.marker_id, _original=original, **kwargs):
            calls[_id] = calls.get(_id, 0) + 1
            return _original(*args, **kwargs)

        slot.outline.setData = counting
    import widgets.camera_overlay_items as items

    polygons = []  # hit-test polygons are made when a tap asks, not at every frame a marker moves
    real_polygon = items.QtGui.QPolygonF
    monkeypatch.setattr(items.QtGui, "QPolygonF", lambda *a: (polygons.append(a), real_polygon(*a))[1])
    view.set_markers(markers(shift=12.0))  # 50 moves, 23 and 7 lie still
    drain()
    assert calls == {50: 1}
    assert polygons == []
    # a tap on the moved marker finds it where it is drawn now, one on a still one finds that one
    point = view.image_to_widget(512 + 14, 75)
    with qtbot.waitSignal(view.sigMarkerClicked, timeout=TIMEOUT_MS) as moved:
        qtbot.mouseClick(view.graphics_view.viewport(), QtCore.Qt.MouseButton.LeftButton,
                         pos=view.graphics_view.viewport().mapFrom(view, point))
    assert moved.args == [50]
    assert len(polygons) >= 1
    point = view.image_to_widget(315, 315)
    with qtbot.waitSignal(view.sigMarkerClicked, timeout=TIMEOUT_MS) as still:
        qtbot.mouseClick(view.graphics_view.viewport(), QtCore.Qt.MouseButton.LeftButton,
                         pos=view.graphics_view.viewport().mapFrom(view, point))
    assert still.args == [23]


def test_labels_moved_by_the_layout_call_no_python_back(monkeypatch, make_view):
    """A frame that moves every object moves every label (seen in drawn_labels) without Qt calling
    a label's Python itemChange for the move (pyqtgraph's bounds notice, for an auto-range that
    ignores labels anyway)."""
    view = make_view()
    view.set_objects(objects())
    drain()
    before = {label.key: label.rect for label in view.drawn_labels()}
    moves = []  # what pyqtgraph's itemChange does on a move: tell the view box the bounds changed
    original = pg.ViewBox.itemBoundsChanged
    monkeypatch.setattr(pg.ViewBox, "itemBoundsChanged",
                        lambda box, item: (moves.append(item), original(box, item))[1])
    view.set_objects(objects(shift=5.0))
    drain()
    after = {label.key: label.rect for label in view.drawn_labels()}
    assert set(after) == set(before) == set(range(1, 9))
    assert all(after[k].left() > before[k].left() for k in after)  # every label followed its object
    assert [item for item in moves if isinstance(item, pg.TextItem)] == []


def test_a_new_frame_repaints_the_labels_without_asking_each_for_its_transform(qtbot, monkeypatch, make_view):
    """pyqtgraph's TextItem asks for its transform at every repaint of its scene; a camera view's
    labels follow the view's scale when it changes instead (and look the same: the pixel tests)."""
    asked = []
    original = pg.TextItem.updateTransform
    monkeypatch.setattr(pg.TextItem, "updateTransform",
                        lambda self, *a, **k: (asked.append(self), original(self, *a, **k))[1])
    view = make_view()
    view.set_overlays(markers(), objects())
    drain()
    paints = []
    viewport = view.graphics_view.viewport()

    class PaintCount(QtCore.QObject):
        def eventFilter(self, obj, event):  # noqa: N802 (Qt override)
            if event.type() == QtCore.QEvent.Type.Paint:
                paints.append(obj)
            return False

    counter = PaintCount()
    viewport.installEventFilter(counter)
    try:
        asked.clear()
        view.show_image(np.zeros((480, 640, 3), np.uint8))  # a new frame: the view repaints
        qtbot.waitUntil(lambda: len(paints) >= 1, timeout=TIMEOUT_MS)
        assert asked == []
        labels = [label for label in view.drawn_labels() if label.kind == "object"]
        assert len(labels) == 8
        view.resize(300, 240)  # another scale: the labels follow it
        qtbot.waitUntil(lambda: len(asked) > 0, timeout=TIMEOUT_MS)
    finally:
        viewport.removeEventFilter(counter)
