"""Object and marker labels on the camera views (issue 22, item 16): at 800x480 the labels of the
simulated desk's objects and markers never cover each other, and each object's label (and outline)
is drawn in the colour its name says — "#8 orange" in orange, not in its track's cyan
(pytest-qt, offscreen; the ``objects`` scenario as tests/window/test_objects_window.py starts it).

The colours are checked against hue ranges written here, not against the view's own table, and
in the pixels of a grab as well as in the items' pens.
"""
import math

import numpy as np
import pytest
from PySide6 import QtCore, QtGui

from app.gui import MainWindow
from tests.window.test_touch_window import make_window
from widgets.camera_view import CameraView, ObjectOverlay, object_label

SMALL = (800, 480)
TIMEOUT_MS = 10_000  # two cores shared with other test runs: frames can be slow
FRAMES = 6  # successive frames checked while the red ball, the blue ball and the plush move
# what each colour word must look like (HSV hue in degrees, from QColor)
HUES = {"red": [(0, 15), (345, 360)], "orange": [(16, 45)], "yellow": [(46, 70)], "green": [(80, 160)],
        "blue": [(190, 250)], "purple": [(255, 300)], "pink": [(300, 344)]}
TEXT_MIN_PIXELS = 6  # a label's text has at least this many pixels in its colour


def objects_window(qtbot, size=SMALL) -> MainWindow:
    return make_window(qtbot, scenario="objects", size=size, detectors=("hsv",))


@pytest.fixture
def window(qtbot):
    w = objects_window(qtbot)
    w.start()
    yield w
    w.stop()
    for worker in (w.workers.perception, w.workers.control, w.workers.bridge):
        assert worker.isFinished() and not worker.isRunning(), worker.objectName()


def draw(window) -> None:
    window._dirty = True
    window.redraw()


def colour_word(text: str):
    """The colour word of a label as the HSV detector names its colours ("#8 orange" -> "orange")."""
    return next((w for w in text.split() if w in HUES or w == "white"), None)


def looks(colour: QtGui.QColor, word: str) -> bool:
    """Whether ``colour`` is what ``word`` says (hue ranges above; white: pale and bright)."""
    if word == "white":
        return colour.saturation() < 50 and colour.value() > 200
    if colour.saturation() < 90 or colour.value() < 120:
        return False
    hue = colour.hsvHue()
    return any(lo <= hue <= hi for lo, hi in HUES[word])


def text_pixels(image: QtGui.QImage, rect: QtCore.QRectF, word: str) -> tuple[int, int]:
    """(pixels of the label's text in ``word``'s colour, bright pixels in another colour) inside
    ``rect`` of a grab: the text is the bright part of a label on its dark background."""
    right, wrong = 0, 0
    # whole pixels only: a pixel the rectangle's edge cuts shows the desk beside it
    xs = range(max(0, math.ceil(rect.left())), min(image.width(), math.floor(rect.right())))
    ys = range(max(0, math.ceil(rect.top())), min(image.height(), math.floor(rect.bottom())))
    for y in ys:
        for x in xs:
            c = image.pixelColor(x, y)
            if c.value() < 150 or (word != "white" and c.saturation() < 90):
                continue  # the background, the desk seen through it, anti-aliased edges
            if looks(c, word):
                right += 1
            elif word != "white":
                wrong += 1
    return right, wrong


def assert_labels_apart_and_inside(view: CameraView) -> list:
    labels = view.drawn_labels()
    area = QtCore.QRectF(view.graphics_view.geometry()).adjusted(-0.01, -0.01, 0.01, 0.01)
    for i, a in enumerate(labels):
        assert area.contains(a.rect), (a.kind, a.key, a.text, a.rect, area)
        for b in labels[i + 1:]:
            assert not a.rect.intersects(b.rect), (view.title, (a.kind, a.key, a.text, a.rect),
                                                   (b.kind, b.key, b.text, b.rect))
    return labels


def assert_labels_in_their_colours(view: CameraView, labels) -> int:
    """Every object label naming a colour is drawn in it (its text, its outline, its pixels)."""
    image = view.grab().toImage()
    outlines = view.object_colours()
    checked = 0
    for label in labels:
        word = colour_word(label.text) if label.kind == "object" else None
        if word is None:
            continue
        assert looks(label.colour, word), (label.text, label.colour.name())
        assert looks(QtGui.QColor(*outlines[label.key]), word), (label.text, outlines[label.key])
        right, wrong = text_pixels(image, label.rect, word)
        assert right >= TEXT_MIN_PIXELS and right > 4 * wrong, (label.text, right, wrong)
        checked += 1
    return checked


# ----------------------------------------------------------------------------------------------
def test_at_800x480_no_label_covers_another_and_each_is_in_the_colour_it_names(qtbot, window):
    qtbot.waitUntil(lambda: window._result is not None and len(window._result.objects) >= 5
                    and sum(m.found for m in window._result.markers) >= 2, timeout=TIMEOUT_MS)
    assert window.view_left.width() < 260  # the small views this is about (~185 px wide)
    seen_words, object_labels = set(), 0
    for _ in range(FRAMES):
        seq = window._result.seq
        qtbot.waitUntil(lambda: window._result.seq > seq + 1, timeout=TIMEOUT_MS)
        draw(window)
        for view in (window.view_left, window.view_right):
            labels = assert_labels_apart_and_inside(view)
            kinds = [label.kind for label in labels]
            assert kinds.count("marker id") >= 2, kinds
            # every object drawn has its label: full, as the compact view words it
            shown = view.object_labels()
            assert shown and all(text.startswith(f"#{key} ") for key, text in shown.items()), shown
            object_labels += len(shown)
            assert_labels_in_their_colours(view, labels)
            seen_words |= {colour_word(label.text) for label in labels if label.kind == "object"}
    assert {"red", "green", "yellow", "purple", "pink"} <= seen_words, seen_words
    assert object_labels >= 2 * FRAMES * 5


def test_the_followed_objects_three_line_label_covers_no_other_label(qtbot, window):
    """Live: the followed object's label carries its position and speed lines, or — where the
    crowded small view has no room for three lines this frame — a shorter form of the same label;
    never over another label. The scene moves with the wall clock, so on a loaded machine the
    room differs: the three-line case is also checked on a fixed scene below."""
    qtbot.waitUntil(lambda: window._result is not None and len(window._result.objects) >= 5,
                    timeout=TIMEOUT_MS)
    green = next(o for o in window._result.objects if o.label == "green")
    window.target_panel.mode_buttons["object"].click()
    window.target_panel.set_follow_object("green", green.object_id)
    qtbot.waitUntil(lambda: (o := window._result.object_observation(green.object_id)) is not None
                    and o.velocity_base is not None, timeout=TIMEOUT_MS)
    for _ in range(3):
        seq = window._result.seq
        qtbot.waitUntil(lambda: window._result.seq > seq + 1, timeout=TIMEOUT_MS)
        draw(window)
        drawn = window._drawn_result.object_observation(green.object_id)
        full = object_label(drawn, True) if drawn is not None else ""
        for view in (window.view_left, window.view_right):
            labels = assert_labels_apart_and_inside(view)
            followed = [label for label in labels if label.kind == "object" and label.key == green.object_id]
            if drawn is not None and followed:
                text = followed[0].text
                assert full.startswith(text) or text == f"#{green.object_id}", (text, full)
            assert_labels_in_their_colours(view, labels)


def small_view(qtbot) -> CameraView:
    """A camera view the size of the 800x480 window's, showing a grey 640x480 image."""
    view = CameraView("Left")
    qtbot.addWidget(view)
    view.resize(185, 190)  # the 800x480 window's view
    view.show()
    qtbot.waitExposed(view)
    view.show_image(np.full((480, 640, 3), 90, np.uint8))
    return view


def test_a_three_line_label_in_a_small_crowded_view_covers_no_other(qtbot):
    view = small_view(qtbot)
    followed = square(4, 330, 250, "#4 green 0.98\nx 12.0 y -3.5 z 2.0 cm\nv 1.2 cm/s")
    others = [square(k, x, y, f"#{k} {w}") for k, x, y, w in
              ((1, 150, 120, "red"), (2, 480, 120, "blue"), (3, 150, 380, "yellow"), (5, 480, 380, "pink"))]
    view.set_objects([followed, *others])
    view.grab()
    labels = assert_labels_apart_and_inside(view)
    shown = {label.key: label.text for label in labels if label.kind == "object"}
    assert shown.get(4, "").count("\n") == 2, shown  # all three lines, over no other label
    assert len(shown) == 5, shown


def square(object_id: int, x: float, y: float, label: str, r: float = 22.0) -> ObjectOverlay:
    return ObjectOverlay(object_id, (x - r, y - r, 2 * r, 2 * r),
                         np.array([[x - r, y - r], [x + r, y - r], [x + r, y + r], [x - r, y + r]]), label)


def test_a_crowded_small_view_keeps_labels_apart_and_beside_their_objects(qtbot):
    view = small_view(qtbot)
    words = ["red", "green", "blue", "yellow", "orange", "purple", "pink"]
    # 14 balls in two tight rows in the middle of the image
    overlays = [square(k + 1, 200 + 45 * (k % 7), 220 + 60 * (k // 7), f"#{k + 1} {words[k % 7]}")
                for k in range(14)]
    view.set_objects(overlays)
    view.grab()
    labels = assert_labels_apart_and_inside(view)
    assert len(labels) >= 10, [label.text for label in labels]  # of 14: the rest had no room
    for label in labels:  # a shortened label still names its object ("#12")
        assert label.text.startswith(f"#{label.key}"), label.text
    assert_labels_in_their_colours(view, labels)
    # each label touches its object or sits one label's height from it at most: never across
    # the view, where it would read as another object's
    boxes = {o.object_id: QtCore.QRectF(QtCore.QPointF(view.image_to_widget(o.box[0], o.box[1])),
                                        QtCore.QPointF(view.image_to_widget(o.box[0] + o.box[2],
                                                                            o.box[1] + o.box[3])))
             for o in overlays}
    for label in labels:
        box, r = boxes[label.key], label.rect
        dx = max(box.left() - r.right(), 0.0, r.left() - box.right())
        dy = max(box.top() - r.bottom(), 0.0, r.top() - box.bottom())
        assert max(dx, dy) <= r.height() + 6, (label.text, dx, dy, r, box)


def test_a_name_that_is_no_colour_keeps_its_track_colour_and_a_dark_one_gets_a_light_background(qtbot):
    view = CameraView("Left")
    qtbot.addWidget(view)
    view.resize(640, 520)
    view.show()
    view.show_image(np.zeros((480, 640, 3), np.uint8))
    view.set_objects([square(8, 120, 120, "#8 orange"), square(3, 400, 300, "#3 circle 0.90"),
                      square(5, 300, 100, "#5 navy")])
    view.grab()
    by_key = {label.key: label for label in view.drawn_labels()}
    assert looks(by_key[8].colour, "orange")  # track 8's own colour is cyan: the name wins
    circle = by_key[3].colour
    assert (circle.red(), circle.green(), circle.blue()) == view.object_colours()[3]  # the track's
    navy, fill = by_key[5].colour, by_key[5].fill
    assert navy.lightness() < 90 and fill.lightness() > 180, (navy.name(), fill.name())
