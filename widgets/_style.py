"""Shared touch-friendly sizes, colours and small widget factories (private to ``widgets``)."""
from __future__ import annotations

import inspect
import weakref

from PySide6 import QtCore, QtGui, QtWidgets

# A fingertip is ~8-10 mm; on a 7" 800x480 panel that is ~40-45 px.
TOUCH_PX = 44

OK_COLOUR = "#2e9d44"
WARN_COLOUR = "#e08a00"
ERROR_COLOUR = "#d32f2f"
INFO_COLOUR = "#1e6fd0"
ACCENT_COLOUR = "#3a7bd5"

# The handle is the groove (8 px) plus 2 x 18 px negative margin = 44 px tall.
SLIDER_STYLE = f"""
QSlider {{ min-height: {TOUCH_PX}px; }}
QSlider::groove:horizontal {{
    height: 8px; border-radius: 4px; background: #9e9e9e;
}}
QSlider::sub-page:horizontal {{ height: 8px; border-radius: 4px; background: {ACCENT_COLOUR}; }}
QSlider::handle:horizontal {{
    width: 30px; margin: -18px 0; border-radius: 8px;
    background: #f4f4f4; border: 2px solid {ACCENT_COLOUR};
}}
QSlider::handle:horizontal:disabled {{ background: #d0d0d0; border: 2px solid #9e9e9e; }}
QSlider::sub-page:horizontal:disabled {{ background: #bdbdbd; }}
"""

SPIN_BUTTON_PX = 32
# Big up/down buttons on either side of the number instead of Qt's tiny stacked arrows:
# "−" on the left, "+" on the right, each a full-height touch target.
SPIN_STYLE = f"""
QAbstractSpinBox {{
    min-height: {TOUCH_PX - 4}px; padding-left: {SPIN_BUTTON_PX + 2}px;
    padding-right: {SPIN_BUTTON_PX + 2}px;
}}
QAbstractSpinBox::up-button {{
    subcontrol-origin: border; subcontrol-position: center right;
    width: {SPIN_BUTTON_PX}px; height: {TOUCH_PX - 6}px;
}}
QAbstractSpinBox::down-button {{
    subcontrol-origin: border; subcontrol-position: center left;
    width: {SPIN_BUTTON_PX}px; height: {TOUCH_PX - 6}px;
}}
"""

BUTTON_STYLE = f"""
QPushButton {{ min-height: {TOUCH_PX}px; padding: 0 12px; }}
QPushButton:checked {{
    background: {ACCENT_COLOUR}; color: white; font-weight: bold;
    border: 1px solid #245ea8; border-radius: 4px;
}}
"""


# Tabs drawn over their whole TOUCH_PX: Fusion draws an unselected tab 2 px below the top of
# its rect (a 44 px tab showed 42 px), and a bolder mark than Fusion's for the open one.
# min-height counts the content only: 1 px top border + 3 px bottom border + 40 = TOUCH_PX.
TAB_STYLE = f"""
QTabBar::tab {{
    min-height: {TOUCH_PX - 4}px; min-width: {TOUCH_PX}px; padding: 0 4px; margin: 0;
    border: 1px solid #a0a0a0; border-left: none; border-bottom: 3px solid #a0a0a0;
    background: palette(button); color: palette(button-text);
}}
QTabBar::tab:first {{ border-left: 1px solid #a0a0a0; }}
QTabBar::tab:selected {{ background: palette(base); color: palette(text); border-bottom-color: {ACCENT_COLOUR}; }}
QCheckBox {{ min-height: {TOUCH_PX}px; spacing: 8px; }}
QCheckBox::indicator {{ width: 26px; height: 26px; }}
"""


def touch_tabs(tabs: QtWidgets.QTabWidget) -> QtWidgets.QTabWidget:
    """Finger-sized tabs, drawn over their whole height, the open one underlined.

    The style sheet also gives every check box in the pages a TOUCH_PX row (unless the box has
    its own style sheet); a tap anywhere on that row toggles it (see :class:`DragScroll`).
    """
    tabs.setStyleSheet(TAB_STYLE)
    return tabs


def touch_slider(slider: QtWidgets.QWidget) -> QtWidgets.QWidget:
    """Give a horizontal slider (plain or a :class:`LabeledSlider`) a tall, finger-sized handle, and make it
    take the mouse wheel only when focused (see :class:`WheelWhenFocused`)."""
    slider.setStyleSheet(SLIDER_STYLE)
    slider.setMinimumHeight(TOUCH_PX)
    wheel_only_when_focused(slider)
    return slider


class _JumpSlider(QtWidgets.QSlider):
    """A QSlider whose handle jumps to where the groove is pressed (and can be dragged on from
    there), as superqt's did: a finger taps the value it wants instead of paging towards it."""

    def mousePressEvent(self, event: QtGui.QMouseEvent) -> None:  # noqa: N802 (Qt override)
        if event.button() == QtCore.Qt.MouseButton.LeftButton:
            option = QtWidgets.QStyleOptionSlider()
            self.initStyleOption(option)
            style, cc = self.style(), QtWidgets.QStyle.ComplexControl.CC_Slider
            handle = style.subControlRect(cc, option, QtWidgets.QStyle.SubControl.SC_SliderHandle, self)
            if not handle.contains(event.position().toPoint()):
                groove = style.subControlRect(cc, option, QtWidgets.QStyle.SubControl.SC_SliderGroove, self)
                x = int(event.position().x() - groove.x() - handle.width() / 2)
                self.setValue(QtWidgets.QStyle.sliderValueFromPosition(
                    self.minimum(), self.maximum(), x, max(1, groove.width() - handle.width()), option.upsideDown))
        super().mousePressEvent(event)


class LabeledSlider(QtWidgets.QWidget):
    """A horizontal QSlider with its value in a QSpinBox beside it (typing a value moves the
    slider), in place of superqt's QLabeledSlider (whose import cost a Pi ~1 s of start-up).

    The same calls the panels made on superqt's: ``value``, ``setValue``, ``setRange``,
    ``minimum``/``maximum``, ``setSingleStep``, ``setPageStep``; ``blockSignals`` silences
    ``valueChanged``. Make it finger-sized with :func:`touch_slider`.

    Signals: ``valueChanged(int)`` (GUI thread) when the value changes — dragged, typed or set.
    """

    valueChanged = QtCore.Signal(int)
    _SCALED = False  # the slider's positions are value × 10**decimals (LabeledDoubleSlider)

    def __init__(self, orientation: QtCore.Qt.Orientation = QtCore.Qt.Orientation.Horizontal,
                 parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        del orientation  # horizontal only: every panel row is one
        self._decimals = 2 if self._SCALED else 0  # superqt's defaults: 0…99, 2 decimals
        self._min, self._max, self._step, self._page, self._value = map(self._cast, (0, 99, 1, 10, 0))
        self._slider = _JumpSlider(QtCore.Qt.Orientation.Horizontal)
        self._box = QtWidgets.QDoubleSpinBox() if self._SCALED else QtWidgets.QSpinBox()
        self._box.setButtonSymbols(QtWidgets.QAbstractSpinBox.ButtonSymbols.NoButtons)
        self._box.setKeyboardTracking(False)  # "123" commits once, on Enter or focus loss
        self._box.setAlignment(QtCore.Qt.AlignmentFlag.AlignRight | QtCore.Qt.AlignmentFlag.AlignVCenter)
        self._box.setFrame(False)
        self._box.setMinimumHeight(TOUCH_PX)
        row = QtWidgets.QHBoxLayout(self)
        row.setContentsMargins(0, 0, 0, 0)
        row.setSpacing(4)
        row.addWidget(self._slider, 1)
        row.addWidget(self._box)
        self._slider.valueChanged.connect(self._on_slider)
        self._box.valueChanged.connect(self.setValue)
        self._sync()

    def _scale(self) -> float:
        return 10.0 ** self._decimals if self._SCALED else 1.0

    def _position(self, value) -> int:
        return int(round(value * self._scale()))

    def _sync(self) -> None:
        """Show the range, steps and value in the slider and the box (their signals held)."""
        s, b = self._slider, self._box
        held = s.blockSignals(True), b.blockSignals(True)
        try:
            s.setRange(self._position(self._min), self._position(self._max))
            s.setSingleStep(max(1, self._position(self._step)))
            s.setPageStep(max(1, self._position(self._page)))
            s.setValue(self._position(self._value))
            if self._SCALED:
                b.setDecimals(self._decimals)
            b.setRange(self._min, self._max)
            b.setSingleStep(self._step)
            b.setValue(self._value)
            widest = max(b.textFromValue(self._min), b.textFromValue(self._max), key=len)
            b.setFixedWidth(b.fontMetrics().horizontalAdvance(widest + "0") + 8)
        finally:
            s.blockSignals(held[0])
            b.blockSignals(held[1])

    def _on_slider(self, position: int) -> None:
        self.setValue(position / self._scale() if self._SCALED else position)

    def _cast(self, value):
        return float(value) if self._SCALED else int(round(value))

    def value(self):
        return self._value

    def setValue(self, value) -> None:  # noqa: N802 (Qt naming)
        value = self._cast(min(max(value, self._min), self._max))
        if value == self._value:
            return
        self._value = value
        self._sync()
        self.valueChanged.emit(value)

    def minimum(self):
        return self._min

    def maximum(self):
        return self._max

    def setRange(self, minimum, maximum) -> None:  # noqa: N802 (Qt naming)
        self._min, self._max = self._cast(minimum), self._cast(max(minimum, maximum))
        self._sync()
        self.setValue(self._value)  # clamped into the new range (and announced) like QSlider

    def setMinimum(self, minimum) -> None:  # noqa: N802 (Qt naming)
        self.setRange(minimum, max(minimum, self._max))

    def setMaximum(self, maximum) -> None:  # noqa: N802 (Qt naming)
        self.setRange(min(self._min, maximum), maximum)

    def singleStep(self):  # noqa: N802 (Qt naming)
        return self._step

    def setSingleStep(self, step) -> None:  # noqa: N802 (Qt naming)
        self._step = self._cast(step)
        self._sync()

    def pageStep(self):  # noqa: N802 (Qt naming)
        return self._page

    def setPageStep(self, step) -> None:  # noqa: N802 (Qt naming)
        self._page = self._cast(step)
        self._sync()


class LabeledDoubleSlider(LabeledSlider):
    """:class:`LabeledSlider` for floats, shown with ``decimals`` (setDecimals) in a
    QDoubleSpinBox; the slider moves in steps of 10**-decimals.

    Signals: ``valueChanged(float)`` (GUI thread) when the value changes — dragged, typed or set.
    """

    valueChanged = QtCore.Signal(float)
    _SCALED = True

    def decimals(self) -> int:
        return self._decimals

    def setDecimals(self, decimals: int) -> None:  # noqa: N802 (Qt naming)
        self._decimals = int(decimals)
        self._sync()


class WheelWhenFocused(QtCore.QObject):
    """Event filter: a control under the pointer takes the wheel only when it has the focus.

    Otherwise the wheel scrolls the panel around it, as the spin boxes already do — scrolling
    a page must never change Min disparity from 0 to −45 on the way (and save it in a preset).
    A tap or a drag on the control gives it the focus, so the wheel works once it is chosen.
    """

    def __init__(self, owner: QtWidgets.QWidget) -> None:
        super().__init__(owner)
        self._owner = owner

    def _focused(self) -> bool:
        focus = QtWidgets.QApplication.focusWidget()
        return focus is not None and (focus is self._owner or self._owner.isAncestorOf(focus))

    def eventFilter(self, obj: QtCore.QObject, event: QtCore.QEvent) -> bool:  # noqa: N802 (Qt override)
        if event.type() != QtCore.QEvent.Type.Wheel or self._focused():
            return False
        # hand the wheel to the scroll area holding the control (if any): it scrolls the page
        parent = self._owner.parentWidget()
        while parent is not None and not isinstance(parent, QtWidgets.QAbstractScrollArea):
            parent = parent.parentWidget()
        if parent is not None:
            QtWidgets.QApplication.sendEvent(parent.verticalScrollBar(), event)
        return True


def wheel_only_when_focused(control: QtWidgets.QWidget) -> QtWidgets.QWidget:
    """Install :class:`WheelWhenFocused` on ``control`` and on its sliders and spin boxes
    (a :class:`LabeledSlider` is a slider and a spin box inside a widget)."""
    guard = WheelWhenFocused(control)
    control.setFocusPolicy(QtCore.Qt.FocusPolicy.StrongFocus)
    for widget in [control, *control.findChildren(QtWidgets.QAbstractSlider),
                   *control.findChildren(QtWidgets.QAbstractSpinBox)]:
        widget.installEventFilter(guard)
        if widget is not control:
            widget.setFocusPolicy(QtCore.Qt.FocusPolicy.StrongFocus)
    return control


def touch_button(text: str, checkable: bool = False,
                 parent: QtWidgets.QWidget | None = None) -> QtWidgets.QPushButton:
    """A QPushButton at least TOUCH_PX tall (checked state clearly highlighted)."""
    button = QtWidgets.QPushButton(text, parent)
    button.setCheckable(checkable)
    button.setMinimumHeight(TOUCH_PX)
    button.setStyleSheet(BUTTON_STYLE)
    button.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)
    # room for the bold text of the checked state, so it is never clipped
    bold = QtGui.QFont(button.font())
    bold.setBold(True)
    button.setMinimumWidth(QtGui.QFontMetrics(bold).horizontalAdvance(text) + 28)
    return button


class TouchDoubleSpinBox(QtWidgets.QDoubleSpinBox):
    """A QDoubleSpinBox with big −/+ buttons, no wheel surprises and commit-on-Enter.

    ``keyboardTracking`` is off: typing "12.3" commits once (on Enter or focus loss), not as
    1, 12, 12.3. The mouse wheel only acts when the box has focus, so scrolling a page on a
    touch pad does not change values under the pointer.
    """

    def __init__(self, lo: float, hi: float, decimals: int = 1, step: float = 0.5,
                 suffix: str = "", parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setRange(lo, hi)
        self.setDecimals(decimals)
        self.setSingleStep(step)
        if suffix:
            self.setSuffix(suffix)
        self.setKeyboardTracking(False)
        self.setAccelerated(True)
        self.setButtonSymbols(QtWidgets.QAbstractSpinBox.ButtonSymbols.PlusMinus)
        self.setAlignment(QtCore.Qt.AlignmentFlag.AlignCenter)
        self.setFocusPolicy(QtCore.Qt.FocusPolicy.StrongFocus)
        self.setStyleSheet(SPIN_STYLE)
        self.setMinimumHeight(TOUCH_PX - 4)
        self.setMinimumWidth(self._width_for(lo, hi, decimals, suffix))

    def _width_for(self, lo: float, hi: float, decimals: int, suffix: str) -> int:
        fm = self.fontMetrics()
        text = max(f"{lo:.{decimals}f}", f"{hi:.{decimals}f}", key=len) + suffix
        return fm.horizontalAdvance(text) + 2 * (SPIN_BUTTON_PX + 2) + 8

    def wheelEvent(self, event: QtGui.QWheelEvent) -> None:  # noqa: N802 (Qt override)
        if self.hasFocus():
            super().wheelEvent(event)
        else:
            event.ignore()


def coloured_label_style(colour: str, bold: bool = True) -> str:
    """Stylesheet for a label with a coloured background and white text."""
    weight = "bold" if bold else "normal"
    return (f"QLabel {{ background: {colour}; color: white; font-weight: {weight};"
            f" padding: 4px 8px; border-radius: 3px; }}")


SCROLL_STYLE = """
QScrollBar:vertical { width: 26px; }
QScrollBar::handle:vertical { min-height: 44px; }
"""


def touch_scroll_area(content: QtWidgets.QWidget | None,
                      parent: QtWidgets.QWidget | None = None) -> QtWidgets.QScrollArea:
    """A vertical-only scroll area with a finger-wide scroll bar around ``content``, whose page
    a finger or the mouse drags and flicks (see :class:`DragScroll`). ``content`` None: an empty
    area, filled later with :func:`set_scroll_content`."""
    area = QtWidgets.QScrollArea(parent)
    area.setWidgetResizable(True)
    area.setFrameShape(QtWidgets.QFrame.Shape.NoFrame)
    area.setHorizontalScrollBarPolicy(QtCore.Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
    area.verticalScrollBar().setStyleSheet(SCROLL_STYLE)
    if content is not None:
        set_scroll_content(area, content)
    DragScroll(area)
    return area


def set_scroll_content(area: QtWidgets.QScrollArea, content: QtWidgets.QWidget) -> None:
    """Put ``content`` in a :func:`touch_scroll_area`, which is then never narrower than it (plus
    the scroll bar): vertical-only, it would clip."""
    area.setWidget(content)
    area.setMinimumWidth(content.minimumSizeHint().width()
                         + area.verticalScrollBar().sizeHint().width() + 2)


_MOUSE_EVENTS = (QtCore.QEvent.Type.MouseButtonPress, QtCore.QEvent.Type.MouseButtonDblClick,
                 QtCore.QEvent.Type.MouseMove, QtCore.QEvent.Type.MouseButtonRelease)


class DragScroll(QtCore.QObject):
    """Drag a scroll area's page with a finger or the mouse, and flick it (kinetic, as a phone).

    An event filter on the viewport, which sees only the presses no control took: a slider,
    spin box, combo box or button under the finger keeps its press (dragging a slider's handle
    moves the slider, a tap on a button clicks it), while a press on a label, a margin or empty
    space feeds the area's QScroller, which drags, flicks and decelerates the page. A finger on
    a touch screen arrives as the mouse events Qt makes from touches nobody accepts, so the same
    rule holds for it. (QScroller.grabGesture with LeftMouseButtonGesture would also take drags
    that start on a slider, and delays every press to a button by its MousePressEventDelay.)

    A tap (no drag) on a check box outside its small click rect — the text's line and the
    indicator, ~26 px of its 44 px row — toggles it: the whole row is its tap target.

    A page with nothing to scroll lets the press go on to an outer scroll area. Where the owner
    also grabbed QScroller's touch gesture on the viewport, fingers are left to that gesture.

    Signals: none.
    """

    def __init__(self, area: QtWidgets.QAbstractScrollArea) -> None:
        super().__init__(area)
        self._area = area
        self._viewport = area.viewport()
        self.scroller = QtWidgets.QScroller.scroller(self._viewport)
        props = self.scroller.scrollerProperties()
        metric = QtWidgets.QScrollerProperties.ScrollMetric
        props.setScrollMetric(metric.HorizontalOvershootPolicy,
                              QtWidgets.QScrollerProperties.OvershootPolicy.OvershootAlwaysOff)
        self.scroller.setScrollerProperties(props)
        self._origin: QtCore.QPointF | None = None  # the viewport's global top-left at the press
        self._fed = False  # the scroller got the press
        self._dragged = False
        self._tap_box: QtWidgets.QAbstractButton | None = None
        self._viewport.installEventFilter(self)

    def eventFilter(self, obj: QtCore.QObject, event: QtCore.QEvent) -> bool:  # noqa: N802 (Qt override)
        kind = event.type()
        left = QtCore.Qt.MouseButton.LeftButton
        if kind in _MOUSE_EVENTS and self._gesture_has_touch(event):
            return False
        if kind in (QtCore.QEvent.Type.MouseButtonPress, QtCore.QEvent.Type.MouseButtonDblClick):
            return event.button() == left and self._press(event)
        if self._origin is None:
            return False
        if kind == QtCore.QEvent.Type.MouseMove:
            if self._fed:
                self.scroller.handleInput(QtWidgets.QScroller.Input.InputMove, self._local(event),
                                          event.timestamp())
                if self.scroller.state() == QtWidgets.QScroller.State.Dragging:
                    self._dragged = True
            return True
        if kind == QtCore.QEvent.Type.MouseButtonRelease and event.button() == left:
            if self._fed:
                self.scroller.handleInput(QtWidgets.QScroller.Input.InputRelease, self._local(event),
                                          event.timestamp())
            box, self._tap_box, self._origin = self._tap_box, None, None
            if box is not None and not self._dragged and box.isEnabled() and box.rect().contains(
                    box.mapFromGlobal(event.globalPosition().toPoint())):
                box.click()
            return True
        return False

    def _gesture_has_touch(self, event: QtGui.QMouseEvent) -> bool:
        """A mouse event Qt made from a touch, on a viewport whose owner also grabbed QScroller's
        touch gesture: the gesture scrolls with that finger (fed twice, the scroller stalls)."""
        if event.source() == QtCore.Qt.MouseEventSource.MouseEventNotSynthesized:
            return False
        # none grabbed reads 0 or CustomGesture; a grabbed one is a registered type above it
        return QtWidgets.QScroller.grabbedGesture(self._viewport).value > QtCore.Qt.GestureType.CustomGesture.value

    def _press(self, event: QtGui.QMouseEvent) -> bool:
        scrollable = self._area.verticalScrollBar().maximum() > 0
        moving = self.scroller.state() != QtWidgets.QScroller.State.Inactive
        self._tap_box = self._missed_box_at(event.position().toPoint())
        if not (scrollable or moving or self._tap_box is not None):
            return False  # nothing to scroll here: an outer scroll area may take the drag
        # overshooting moves the viewport: one origin for the whole drag keeps it steady
        self._origin = QtCore.QPointF(self._viewport.mapToGlobal(QtCore.QPoint(0, 0)))
        self._dragged = False
        self._fed = scrollable or moving
        if self._fed:
            self.scroller.handleInput(QtWidgets.QScroller.Input.InputPress, self._local(event),
                                      event.timestamp())
        return True

    def _local(self, event: QtGui.QMouseEvent) -> QtCore.QPointF:
        return event.globalPosition() - self._origin

    def _missed_box_at(self, pos: QtCore.QPoint) -> QtWidgets.QAbstractButton | None:
        """The check box (or radio button) under ``pos`` (viewport coordinates), if any: its
        press reached the viewport, so it fell outside the box's own click rect."""
        widget = self._viewport.childAt(pos)
        while widget is not None and widget is not self._viewport:
            if isinstance(widget, (QtWidgets.QCheckBox, QtWidgets.QRadioButton)):
                return widget
            widget = widget.parentWidget()
        return None


class Coalescer(QtCore.QObject):
    """Coalesce bursts of changes into at most one call per ``interval_ms``.

    ``poke()`` arms a single-shot timer unless it is already armed, so a slider dragged
    continuously reports every interval (live feedback) instead of on every pixel, and a
    single click reports once, ``interval_ms`` later.

    A bound method of the parent is held weakly: a strong one makes a reference cycle (parent →
    coalescer → method → parent) whose collection crashes PySide6 6.8.0.2 (the newest wheel for
    Raspberry Pi OS Bookworm): the parent's C++ object deletes its child while the collector
    frees the child's wrapper.
    """

    def __init__(self, interval_ms: int, callback, parent: QtCore.QObject | None = None) -> None:
        super().__init__(parent)
        self._callback = weak_callable(callback)
        self._timer = QtCore.QTimer(self)
        self._timer.setSingleShot(True)
        self._timer.setInterval(interval_ms)
        self._timer.timeout.connect(self._fire)

    def poke(self) -> None:
        """Schedule a call unless one is already pending."""
        if not self._timer.isActive():
            self._timer.start()

    def cancel(self) -> None:
        """Drop the pending call, if any."""
        self._timer.stop()

    def flush(self) -> None:
        """Make the pending call now (no-op when nothing is pending)."""
        if self._timer.isActive():
            self._timer.stop()
            self._fire()

    @property
    def pending(self) -> bool:
        """True while a call is scheduled."""
        return self._timer.isActive()

    def _fire(self) -> None:
        callback = self._callback()
        if callback is not None:
            callback()


def bold_label(label: QtWidgets.QLabel, scale: float = 1.0) -> QtWidgets.QLabel:
    """``label`` in bold, its font scaled by ``scale``."""
    font = label.font()
    font.setBold(True)
    if scale != 1.0:
        font.setPointSizeF(font.pointSizeF() * scale)
    label.setFont(font)
    return label


def weak_callable(callback):
    """A zero-argument function returning ``callback`` (None once a bound method's object is gone)."""
    if inspect.ismethod(callback):
        return weakref.WeakMethod(callback)
    return lambda: callback


COMBO_STYLE = f"""
QComboBox {{ min-height: {TOUCH_PX}px; }}
QComboBox QAbstractItemView::item {{ min-height: {TOUCH_PX}px; padding: 0 8px; }}
"""


def touch_combo(combo: QtWidgets.QComboBox) -> QtWidgets.QComboBox:
    """A drop-down whose list rows are finger-sized (≥ TOUCH_PX; Qt's default is ~20 px) and
    that takes the mouse wheel only when focused."""
    # the style's own popup ignores item style sheets: a plain list view honours them
    combo.setView(QtWidgets.QListView())
    combo.setStyleSheet(COMBO_STYLE)
    combo.setMinimumHeight(TOUCH_PX)
    wheel_only_when_focused(combo)
    return combo


SMALL_SCREEN = (1024, 640)  # at or below this a wizard takes the whole screen


def show_adaptive(dialog: QtWidgets.QWidget, desktop_size: tuple[int, int]) -> None:
    """Show a wizard full screen on small screens (a 7" panel), else as a roomy dialog of at
    most ``desktop_size`` that leaves a margin around it."""
    screen = dialog.screen() or QtGui.QGuiApplication.primaryScreen()
    avail = screen.availableGeometry() if screen is not None else QtCore.QRect(0, 0, 1280, 800)
    if avail.width() <= SMALL_SCREEN[0] or avail.height() <= SMALL_SCREEN[1]:
        dialog.setGeometry(avail)
        dialog.showFullScreen()
    else:
        dialog.resize(min(desktop_size[0], avail.width() - 80), min(desktop_size[1], avail.height() - 80))
        dialog.show()
