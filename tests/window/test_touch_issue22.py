"""Touch and reading at 800x480 (issue 22, items 11-13): tabs drawn finger-tall, pages dragged
and flicked with a finger or the mouse while the controls on them keep their presses, check
boxes tappable over their whole row, a cut status item shown whole by a tap, and a help dialog
that fits the screen and scrolls under its STOP.

Every gesture is a real mouse event at coordinates (QTest), routed by Qt to whatever is there.
"""
from __future__ import annotations

import numpy as np
import pytest
from PySide6 import QtCore, QtGui, QtWidgets
from PySide6.QtTest import QTest

from widgets._style import TOUCH_PX
from widgets.help_dialog import SHORTCUTS, HelpDialog

from test_touch_window import SMALL, make_window

LEFT = QtCore.Qt.MouseButton.LeftButton
# what takes a press itself: a drag that starts on one of these is the control's, not the page's
CONTROLS = (QtWidgets.QAbstractButton, QtWidgets.QAbstractSlider, QtWidgets.QAbstractSpinBox,
            QtWidgets.QComboBox, QtWidgets.QLineEdit, QtWidgets.QTextEdit, QtWidgets.QAbstractScrollArea)
LABEL_TAKES_PRESSES = (QtCore.Qt.TextInteractionFlag.LinksAccessibleByMouse
                       | QtCore.Qt.TextInteractionFlag.TextSelectableByMouse)


@pytest.fixture
def small(qtbot):
    w = make_window(qtbot)
    yield w
    w.stop()


def settle() -> None:
    QtWidgets.QApplication.processEvents()
    QtWidgets.QApplication.processEvents()


def scroller_of(area: QtWidgets.QAbstractScrollArea) -> QtWidgets.QScroller:
    return QtWidgets.QScroller.scroller(area.viewport())


def drag(qtbot, widget: QtWidgets.QWidget, start: QtCore.QPoint, delta: QtCore.QPoint, steps: int = 8,
         before_release=None) -> None:
    """Press at ``start`` (``widget`` coordinates), move by ``delta`` in ``steps`` and release:
    real mouse events, delivered by Qt to whatever is under the pointer."""
    qtbot.mousePress(widget, LEFT, pos=start)
    for k in range(1, steps + 1):
        qtbot.mouseMove(widget, start + QtCore.QPoint(round(delta.x() * k / steps), round(delta.y() * k / steps)))
    if before_release is not None:
        before_release()
    qtbot.mouseRelease(widget, LEFT, pos=start + delta)


def quiet_spot(area: QtWidgets.QScrollArea) -> QtCore.QPoint | None:
    """A point of ``area``'s viewport (its coordinates) over no control, no link and no inner
    scroll area — a label, a margin, empty space — as low as possible, to drag up from."""
    viewport = area.viewport()
    for y in range(viewport.height() - 8, 8, -6):
        for x in range(8, viewport.width() - 8, 6):
            chain, widget = [], viewport.childAt(x, y)
            while widget is not None and widget is not viewport:
                chain.append(widget)
                widget = widget.parentWidget()
            if chain and not any(isinstance(w, CONTROLS) for w in chain) and not any(
                    isinstance(w, QtWidgets.QLabel) and w.textInteractionFlags() & LABEL_TAKES_PRESSES
                    for w in chain):
                return QtCore.QPoint(x, y)
    return None


def pages(window):
    """Show each page of the window in turn (each tab; on Target, each mode's page) and yield
    its name."""
    tabs = window.tabs
    for i in range(tabs.count()):
        tabs.setCurrentIndex(i)
        settle()
        if tabs.widget(i).widget() is window.target_panel:
            for mode, button in window.target_panel.mode_buttons.items():
                button.click()
                settle()
                yield f"{tabs.tabText(i)}/{mode}"
        else:
            yield tabs.tabText(i)


def visible_long_areas(window) -> list[QtWidgets.QScrollArea]:
    return [a for a in window.findChildren(QtWidgets.QScrollArea)
            if a.isVisible() and a.verticalScrollBar().maximum() > 0]


def drawn_rows(image: QtGui.QImage, x: int, background: QtGui.QColor) -> tuple[int, int]:
    """First and last row of column ``x`` whose pixel differs from ``background``."""
    rgb = image.convertToFormat(QtGui.QImage.Format.Format_RGB888)
    pixels = np.frombuffer(rgb.constBits(), np.uint8).reshape(rgb.height(), rgb.bytesPerLine())
    column = pixels[:, 3 * x:3 * x + 3].astype(int)
    differs = np.abs(column - np.array(background.getRgb()[:3])).sum(axis=1) > 12
    rows = np.flatnonzero(differs)
    return int(rows[0]), int(rows[-1])


# --- 11. tabs -----------------------------------------------------------------------------------
def test_every_tab_is_at_least_44_px_tall_as_drawn(qtbot, small):
    """The tabs one taps to switch (the unselected ones) look 44 px tall: Fusion drew them 2 px
    below the top of their 44 px rect, 42 px on screen."""
    bar = small.tabs.tabBar()
    assert bar.count() >= 6
    for current in (0, bar.count() - 1):  # each tab at least once unselected
        small.tabs.setCurrentIndex(current)
        settle()
        image = bar.grab().toImage()
        background = bar.palette().color(QtGui.QPalette.ColorRole.Window)
        for i in range(bar.count()):
            rect = bar.tabRect(i)
            assert rect.height() >= TOUCH_PX, (bar.tabText(i), rect)
            if i == current:
                continue
            top, bottom = drawn_rows(image, rect.center().x(), background)
            assert bottom - top + 1 >= TOUCH_PX, (bar.tabText(i), top, bottom)


# --- 11. drag the page, flick it; the controls on it keep their presses ------------------------
@pytest.mark.parametrize("robot, must_scroll", [
    ("desk_rrr", {"Objects", "Stereo", "Robot", "Target/lissajous", "Target/teleop"}),
    ("umi_rtx", {"Pose", "Stereo"}),
])
def test_dragging_any_long_page_by_its_content_scrolls_it(qtbot, robot, must_scroll):
    window = make_window(qtbot, robot=robot)
    try:
        scrolled = set()
        for name in pages(window):
            for area in visible_long_areas(window):
                spot = quiet_spot(area)
                assert spot is not None, name
                bar = area.verticalScrollBar()
                bar.setValue(0)
                drag(qtbot, area.viewport(), spot, QtCore.QPoint(0, -120),
                     before_release=lambda: qtbot.waitUntil(lambda: bar.value() > 0, timeout=3000))
                qtbot.waitUntil(lambda: scroller_of(area).state() == QtWidgets.QScroller.State.Inactive,
                                timeout=5000)
                assert bar.value() > 0, name
                bar.setValue(0)
                scrolled.add(name)
        assert must_scroll <= scrolled, must_scroll - scrolled
    finally:
        window.stop()


def stereo_area(window) -> QtWidgets.QScrollArea:
    index = [window.tabs.tabText(i) for i in range(window.tabs.count())].index("Stereo")
    window.tabs.setCurrentIndex(index)
    settle()
    return window.tabs.widget(index)


def slider_handle_centre(slider: QtWidgets.QSlider) -> QtCore.QPoint:
    option = QtWidgets.QStyleOptionSlider()
    slider.initStyleOption(option)
    return slider.style().subControlRect(QtWidgets.QStyle.ComplexControl.CC_Slider, option,
                                         QtWidgets.QStyle.SubControl.SC_SliderHandle, slider).center()


def finger_drag(window: QtWidgets.QWidget, device, start: QtCore.QPoint, delta: QtCore.QPoint,
                steps: int = 8) -> None:
    """A finger on a touch screen: press at ``start`` (``window`` coordinates), move, lift."""
    QTest.touchEvent(window, device).press(0, start, window).commit()
    for k in range(1, steps + 1):
        step = QtCore.QPoint(round(delta.x() * k / steps), round(delta.y() * k / steps))
        QTest.touchEvent(window, device).move(0, start + step, window).commit()
    QTest.touchEvent(window, device).release(0, start + delta, window).commit()


def test_a_page_drags_and_flicks_while_its_sliders_and_buttons_keep_their_presses(qtbot, small):
    area = stereo_area(small)
    bar = area.verticalScrollBar()
    assert bar.maximum() > 0
    viewport = area.viewport()

    # the mouse on a label: the page follows, and runs on after the release (a flick)
    at_release = []
    drag(qtbot, viewport, quiet_spot(area), QtCore.QPoint(0, -100), steps=5,
         before_release=lambda: (qtbot.waitUntil(lambda: bar.value() > 0, timeout=3000),
                                 at_release.append(bar.value())))
    assert scroller_of(area).state() == QtWidgets.QScroller.State.Scrolling  # kinetic, not stopped
    qtbot.waitUntil(lambda: scroller_of(area).state() == QtWidgets.QScroller.State.Inactive, timeout=5000)
    assert bar.value() > at_release[0]

    # a drag that starts on a slider's handle moves the slider, not the page
    slider = next(s for s in area.widget().findChildren(QtWidgets.QSlider) if s.isVisible()
                  and s.orientation() == QtCore.Qt.Orientation.Horizontal and s.value() < s.maximum())
    area.ensureWidgetVisible(slider)
    settle()
    scrolled_to, before = bar.value(), slider.value()
    drag(qtbot, slider, slider_handle_centre(slider), QtCore.QPoint(80, 30))  # sideways, a little down
    settle()
    assert slider.value() > before
    assert bar.value() == scrolled_to and scroller_of(area).state() == QtWidgets.QScroller.State.Inactive

    # a tap on a button clicks it
    button = small.sgbm_panel.reset_button
    area.ensureWidgetVisible(button)
    settle()
    with qtbot.waitSignal(button.clicked, timeout=2000):
        qtbot.mouseClick(button, LEFT)
    assert slider.value() == before  # Reset put it back

    # the same with a finger on a touch screen
    finger = QTest.createTouchDevice()
    bar.setValue(0)
    settle()
    finger_drag(small, finger, viewport.mapTo(small, quiet_spot(area)), QtCore.QPoint(0, -100))
    qtbot.waitUntil(lambda: bar.value() > 0, timeout=3000)
    qtbot.waitUntil(lambda: scroller_of(area).state() == QtWidgets.QScroller.State.Inactive, timeout=5000)
    area.ensureWidgetVisible(slider)
    settle()
    scrolled_to, before = bar.value(), slider.value()
    finger_drag(small, finger, slider.mapTo(small, slider_handle_centre(slider)), QtCore.QPoint(80, 30))
    settle()
    assert slider.value() > before and bar.value() == scrolled_to


# --- 11. check boxes: the whole 44 px row is the tap target -------------------------------------
@pytest.mark.parametrize("robot", ["desk_rrr", "umi_rtx"])
def test_every_check_box_toggles_from_anywhere_on_its_44_px_row(qtbot, robot):
    window = make_window(qtbot, robot=robot)
    try:
        seen = set()
        for name in pages(window):
            for box in window.findChildren(QtWidgets.QCheckBox):
                if not box.isVisible() or id(box) in seen:
                    continue
                seen.add(id(box))
                area = next(a for a in window.findChildren(QtWidgets.QScrollArea)
                            if a.widget() is not None and a.widget().isAncestorOf(box) and a.isVisible())
                area.ensureWidgetVisible(box)
                settle()
                assert box.height() >= TOUCH_PX, (name, box.text(), box.height())
                for y in (2, box.height() // 2, box.height() - 3):  # the row's top, middle, bottom
                    before = box.isChecked()
                    qtbot.mouseClick(box, LEFT, pos=QtCore.QPoint(12, y))
                    assert box.isChecked() is not before, (name, box.text(), y)
        assert len(seen) >= (4 if robot == "desk_rrr" else 5)
    finally:
        window.stop()


# --- 12. a tap shows a cut status item whole ----------------------------------------------------
def visible_tips() -> list[QtWidgets.QWidget]:
    return [w for w in QtWidgets.QApplication.topLevelWidgets()
            if w.windowType() == QtCore.Qt.WindowType.ToolTip and w.isVisible()]


def test_a_tap_on_a_cut_status_item_shows_its_whole_text(qtbot, small):
    long_bridge = ("E-STOP · serial:///dev/ttyUSB0 ✗ could not open /dev/ttyUSB0: permission "
                   "denied — add your user to the 'dialout' group and log in again")
    items = small.status_items
    items.update("sim://desk (static scene, simulated stereo pair)", long_bridge, 29.9, 48.0)
    settle()
    qtbot.waitUntil(items.bridge_label.is_elided)
    QtWidgets.QToolTip.hideText()
    qtbot.waitUntil(lambda: not visible_tips())
    label = items.bridge_label
    qtbot.mouseClick(label, LEFT, pos=label.rect().center())
    qtbot.waitUntil(lambda: bool(visible_tips()))
    assert QtWidgets.QToolTip.text() == f"bridge: {long_bridge}"
    screen = label.screen().availableGeometry()
    for tip in visible_tips():
        assert screen.contains(tip.frameGeometry()), (tip.frameGeometry(), screen)
    QtWidgets.QToolTip.hideText()
    # a label shown whole needs no tap: nothing pops up
    qtbot.waitUntil(lambda: not visible_tips())
    fps = items.fps_label
    qtbot.mouseClick(fps, LEFT, pos=fps.rect().center())
    settle()
    assert not visible_tips()


# --- 13. help: fits 800x480, STOP on top, the rest scrolls by dragging -----------------------------
def needed_height(label: QtWidgets.QLabel) -> float:
    """The height ``label``'s text takes at the label's width (rich or plain, wrapped or not)."""
    doc = QtGui.QTextDocument()
    doc.setDefaultFont(label.font())
    doc.setDocumentMargin(0)
    rich = label.textFormat() == QtCore.Qt.TextFormat.RichText or (
        label.textFormat() == QtCore.Qt.TextFormat.AutoText and QtCore.Qt.mightBeRichText(label.text()))
    if rich:
        doc.setHtml(label.text())
    else:
        doc.setPlainText(label.text())
    doc.setTextWidth(label.contentsRect().width() if rich or label.wordWrap() else -1)
    return doc.size().height()


def scroll_into_view_by_dragging(qtbot, widget: QtWidgets.QWidget) -> QtWidgets.QScrollArea:
    """Drag the scroll area holding ``widget`` until all of ``widget`` is in its viewport."""
    area = widget.parentWidget()
    while area is not None and not isinstance(area, QtWidgets.QScrollArea):
        area = area.parentWidget()
    assert area is not None, "no scroll area: what does not fit is cut"
    viewport = area.viewport()

    def in_view() -> bool:
        top = widget.mapTo(viewport, QtCore.QPoint(0, 0)).y()
        return 0 <= top and top + widget.height() <= viewport.height()

    for _ in range(20):
        if in_view():
            break
        value = area.verticalScrollBar().value()
        drag(qtbot, viewport, quiet_spot(area), QtCore.QPoint(0, -100))
        qtbot.waitUntil(lambda: scroller_of(area).state() == QtWidgets.QScroller.State.Inactive, timeout=5000)
        assert area.verticalScrollBar().value() > value, "the drag did not scroll"
    assert in_view()
    return area


def test_the_help_dialog_fits_800x480_and_every_shortcut_can_be_read(qtbot, small):
    """On a 480 px panel the help was cut and did not scroll: Qt opens a new dialog at 2/3 of
    the screen's height at most (320 px), which squeezed the shortcut list under the Reset button."""
    dialog = small.show_help()
    qtbot.waitExposed(dialog)
    settle()
    frame = dialog.frameGeometry()
    assert frame.width() <= SMALL[0] and frame.height() <= SMALL[1], frame
    dialog.resize(dialog.width(), max(SMALL[1] * 2 // 3, dialog.minimumSizeHint().height()))
    settle()
    stop = dialog.estop_strip.stop_button
    stop_at = stop.mapTo(dialog, QtCore.QPoint(0, 0))
    for key, what in SHORTCUTS:
        holders = [label for label in dialog.findChildren(QtWidgets.QLabel) if what in label.text()]
        assert holders, what
        for label in holders:  # no line of it squeezed out of its label
            assert needed_height(label) <= label.contentsRect().height() + 1, (what, label.size())
    last = next(label for label in dialog.findChildren(QtWidgets.QLabel) if SHORTCUTS[-1][1] in label.text())
    scroll_into_view_by_dragging(qtbot, last)
    assert stop.mapTo(dialog, QtCore.QPoint(0, 0)) == stop_at and stop.isVisible()  # never scrolled away
    assert dialog.rect().contains(QtCore.QRect(stop_at, stop.size()))


def test_a_long_shortcut_list_scrolls_by_dragging_under_a_stop_that_stays(qtbot, small):
    """More shortcuts than 480 px hold: the dialog still fits, the list scrolls by dragging and
    STOP stays where it was, at the top."""
    shortcuts = tuple(SHORTCUTS) + tuple((f"Ctrl+{c}", f"an example shortcut number {n}")
                                         for n, c in enumerate("ABCDEFGHIJKLMNOPRST"))
    dialog = HelpDialog("test", "/tmp/settings.toml", shortcuts=shortcuts, parent=small)
    dialog.show()
    qtbot.waitExposed(dialog)
    settle()
    try:
        frame = dialog.frameGeometry()
        assert frame.width() <= SMALL[0] and frame.height() <= SMALL[1], frame
        stop = dialog.estop_strip.stop_button
        stop_at = stop.mapToGlobal(QtCore.QPoint(0, 0))
        assert dialog.rect().contains(QtCore.QRect(stop.mapTo(dialog, QtCore.QPoint(0, 0)), stop.size()))
        area = dialog.scroll_area
        bar = area.verticalScrollBar()
        assert bar.maximum() > 0 and bar.value() == 0
        last = dialog.shortcut_rows[-1][1]
        viewport = area.viewport()
        assert last.mapTo(viewport, QtCore.QPoint(0, 0)).y() >= viewport.height()  # out of sight
        scroll_into_view_by_dragging(qtbot, last)
        assert stop.mapToGlobal(QtCore.QPoint(0, 0)) == stop_at and stop.isVisible()
        with qtbot.waitSignal(dialog.sigStopRequested, timeout=2000):  # and it still stops
            qtbot.mouseClick(stop, LEFT)
    finally:
        dialog.close()
