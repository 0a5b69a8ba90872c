"""The main window's frame on the screen, as pure functions where possible: a size that fits the
screen (window-manager frame included), where a window must move to stay on it, the version
shown in Help, starting the simulated scene when the window is up, and what waits for the first
frame.
"""
from __future__ import annotations

from typing import Optional

from PySide6 import QtCore, QtGui, QtWidgets

# a title bar and borders a window manager adds around the window (a guess until the window
# manager reports its frame; fit_to_screen corrects it once the window is shown)
FRAME_GUESS_PX = (16, 48)


def fit_window_size(requested: tuple[int, int], available: tuple[int, int],
                    frame: tuple[int, int] = FRAME_GUESS_PX) -> tuple[tuple[int, int], bool]:
    """(size, maximise) for a window asked to be ``requested`` on a screen whose free area is
    ``available``, with a window-manager frame of ``frame`` (w, h) around it: never larger than
    the screen (STOP and the status bar must stay on it), and maximised when window plus frame
    do not fit — a 1280x800 default on a 1280x800 screen (title bar) or an 800x480 touch display."""
    (rw, rh), (aw, ah), (fw, fh) = requested, available, frame
    if aw <= 0 or ah <= 0:  # no screen geometry known
        return (rw, rh), False
    fits = rw + fw <= aw and rh + fh <= ah
    return (min(rw, aw - fw), min(rh, ah - fh)) if fits else (min(rw, aw), min(rh, ah)), not fits


def fitted_geometry(frame: QtCore.QRect, inner: QtCore.QRect, available: QtCore.QRect) -> Optional[QtCore.QRect]:
    """Where a window must go (its inner geometry) so that its frame — title bar included —
    lies inside ``available``; None when it already does. Pure: tested without a screen."""
    if available.isEmpty() or available.contains(frame):
        return None
    left, top = inner.x() - frame.x(), inner.y() - frame.y()
    right, bottom = frame.right() - inner.right(), frame.bottom() - inner.bottom()
    w = min(inner.width(), available.width() - left - right)
    h = min(inner.height(), available.height() - top - bottom)
    x = min(max(frame.x(), available.x()), available.right() + 1 - (w + left + right))
    y = min(max(frame.y(), available.y()), available.bottom() + 1 - (h + top + bottom))
    return QtCore.QRect(x + left, y + top, max(1, w), max(1, h))


def fit_to_screen(window: QtWidgets.QWidget) -> bool:
    """Move/shrink a shown, normal (not maximised or full-screen) window so all of it, frame
    included, is on its screen's available area. True when it had to change."""
    screen = window.screen()
    if screen is None or window.isFullScreen() or window.isMaximized() or not window.isVisible():
        return False
    target = fitted_geometry(window.frameGeometry(), window.geometry(), screen.availableGeometry())
    if target is None:
        return False
    window.setGeometry(target)
    return True


def deskarm_version() -> str:
    try:
        from importlib.metadata import version

        return version("deskarm")
    except Exception:  # noqa: BLE001 - a source checkout without metadata
        return "(source checkout)"


def start_scene_now(session) -> None:
    """Start the simulated desk's scenario (or the replayed recording) over, now that the window
    is up: it began when the session opened the camera, and building the window takes a while —
    on a slow machine the teleop scenario's first calibration corner (held from 1.5 s to 3.5 s)
    was over before the first frame was looked at, and teleop waited for a corner that never came.
    Call it before the workers start (nothing else reads the camera then)."""
    if getattr(session.camera, "kind", "") in ("sim", "replay"):
        session.camera.connect()  # both restart their timeline at the clock's now


def pause_scene(session) -> None:
    """Stop the simulated desk's camera while the window is built: its frames would be thrown
    away (:func:`start_scene_now` starts it over), and on a Pi-class core its renders, 30 a
    second, would take half the CPU the window's start-up needs."""
    if getattr(session.camera, "kind", "") == "sim":
        session.camera.disconnect()


FIRST_FRAME_POLL_MS = 50  # after_first_frame: how often it looks (a Pi takes ~0.5 s from show to frame)
FIRST_FRAME_SETTLE_MS = 250  # … and how long it then waits: the frame is painted, the next ones flow


def after_first_frame(window, callback) -> QtCore.QTimer:
    """Call ``callback()`` once, shortly after ``window`` has drawn its first camera frame: work
    that can wait (a full garbage collection, the hidden tabs' pages) then no longer delays what
    the user waits for. Looks every FIRST_FRAME_POLL_MS on a timer owned by ``window`` (returned),
    then calls FIRST_FRAME_SETTLE_MS later."""
    poll = QtCore.QTimer(window)
    poll.setInterval(FIRST_FRAME_POLL_MS)

    def check() -> None:
        drawn = getattr(window, "_drawn_result", None)
        if drawn is not None and drawn.frame is not None:
            poll.timeout.disconnect(check)
            poll.setSingleShot(True)
            poll.timeout.connect(callback)
            poll.start(FIRST_FRAME_SETTLE_MS)

    poll.timeout.connect(check)
    poll.start()
    return poll


def menu_button(parent: QtWidgets.QWidget, entries) -> tuple[QtWidgets.QToolButton, list]:
    """☰ with a touch-sized menu of ``entries`` — (text, slot, shortcut or "", checkable), or None
    for a separator — and the actions made for them (separators left out). Each action's
    shortcut works with the menu closed: the action is added to ``parent`` (a window) too."""
    from widgets._style import TOUCH_PX

    button = QtWidgets.QToolButton()
    button.setText("☰")
    button.setToolTip("Menu: full screen, help, quit")
    button.setMinimumSize(TOUCH_PX + 8, TOUCH_PX + 8)
    button.setStyleSheet("QToolButton { font-size: 20pt; } QToolButton::menu-indicator { image: none; }")
    button.setPopupMode(QtWidgets.QToolButton.ToolButtonPopupMode.InstantPopup)
    menu = QtWidgets.QMenu(button)
    menu.setStyleSheet(f"QMenu::item {{ min-height: {TOUCH_PX}px; padding: 0 28px 0 16px; }}")
    actions = []
    for entry in entries:
        if entry is None:
            menu.addSeparator()
            continue
        text, slot, shortcut, checkable = entry
        action = menu.addAction(text, slot)
        action.setCheckable(checkable)
        if shortcut:
            action.setShortcut(QtGui.QKeySequence(shortcut))
            # F11, F1 and Ctrl+Q act even when the menu is closed (its actions' shortcuts alone
            # would need the menu in a widget tree); Esc is the StopGuard's, before any widget
            action.setShortcutContext(QtCore.Qt.ShortcutContext.WindowShortcut)
            parent.addAction(action)
        actions.append(action)
    button.setMenu(menu)
    return button, actions


def timer(parent: QtCore.QObject, slot, interval_ms: int = 0, single_shot: bool = True) -> QtCore.QTimer:
    """A timer of ``parent`` calling ``slot`` (single-shot unless told), not started."""
    t = QtCore.QTimer(parent)
    t.setSingleShot(single_shot)
    t.setInterval(interval_ms)
    t.timeout.connect(slot)
    return t


def stop_strip(left: list, messages: QtWidgets.QWidget, stop: QtWidgets.QWidget) -> QtWidgets.QWidget:
    """The STOP strip: the ``left`` widgets (menu, ● REC, RE-ARM), the ``messages`` taking the
    room between, and STOP alone at the right end. Its height is STOP's and never changes, so
    STOP keeps one place and size in every state (stopped, recording, replay, any banner)."""
    strip = QtWidgets.QWidget()
    strip.setObjectName("stop_strip")
    row = QtWidgets.QHBoxLayout(strip)
    row.setContentsMargins(0, 0, 0, 0)
    row.setSpacing(4)
    for widget in left:
        row.addWidget(widget)
    row.addWidget(messages, 1)
    row.addWidget(stop)
    strip.setFixedHeight(stop.height())  # STOP's style may ask for more than the strip's default
    return strip


EAGER_TABS = 2  # touch_tab_widget: the pages in their tabs at once (Target, and Jog or Pose)


class DeferredPages(QtCore.QObject):
    """Tab pages put into their (empty) scroll areas only when first needed: when their tab is
    first opened, by :meth:`insert_all`, or by :func:`show_tab_of`. Until then a page is built and
    works (its feature sets it, the preferences restore it) but is no child of the window: laying
    out and styling pages nobody sees yet is no longer part of the start-up."""

    def __init__(self, tabs: QtWidgets.QTabWidget):
        super().__init__(tabs)
        self._tabs = tabs
        self._pending: dict[QtWidgets.QScrollArea, QtWidgets.QWidget] = {}
        tabs.currentChanged.connect(self._on_current)

    def add(self, area: QtWidgets.QScrollArea, page: QtWidgets.QWidget) -> None:
        self._pending[area] = page

    @property
    def pending(self) -> list[QtWidgets.QWidget]:
        """The pages not in their tabs yet."""
        return list(self._pending.values())

    def insert(self, area: QtWidgets.QWidget) -> None:
        from widgets._style import set_scroll_content

        page = self._pending.pop(area, None)
        if page is not None:
            set_scroll_content(area, page)

    @QtCore.Slot()
    def insert_all(self) -> None:
        for area in list(self._pending):
            self.insert(area)

    def area_of(self, page: QtWidgets.QWidget) -> Optional[QtWidgets.QWidget]:
        """The scroll area waiting for ``page`` or for a page holding it (None: none waits)."""
        return next((a for a, p in self._pending.items() if p is page or p.isAncestorOf(page)), None)

    @QtCore.Slot(int)
    def _on_current(self, index: int) -> None:
        self.insert(self._tabs.widget(index))


def touch_tab_widget(pages, window: Optional[QtWidgets.QWidget] = None,
                     eager: int = EAGER_TABS) -> QtWidgets.QTabWidget:
    """Finger-sized tabs of ``pages`` ((widget, title) pairs), each page scrolling vertically
    only and never narrower than itself, so a splitter leaves the tabs room for it (no sideways
    scrolling, no clipped buttons at 800x480). With ``window``, the pages after the first
    ``eager`` go into their tabs when first opened or once ``window`` has drawn its first camera
    frame (``tabs.deferred``: :class:`DeferredPages`; a deferred page wider than the first ones
    would widen the tabs when it comes in — today the Target page is the widest)."""
    from widgets._style import touch_scroll_area, touch_tabs

    tabs = QtWidgets.QTabWidget()
    tabs.setDocumentMode(True)
    tabs.tabBar().setExpanding(True)
    touch_tabs(tabs)
    tabs.deferred = DeferredPages(tabs)
    for index, (widget, title) in enumerate(pages):
        later = window is not None and index >= eager
        area = touch_scroll_area(None if later else widget)
        tabs.addTab(area, title)
        if later:
            tabs.deferred.add(area, widget)
    if window is not None and tabs.deferred.pending:
        after_first_frame(window, tabs.deferred.insert_all)
    return tabs


def show_tab_of(tabs: QtWidgets.QTabWidget, page: QtWidgets.QWidget) -> None:
    """Open the tab holding ``page`` (inside its scroll area)."""
    deferred = getattr(tabs, "deferred", None)
    waiting = None if deferred is None else deferred.area_of(page)
    if waiting is not None:
        deferred.insert(waiting)
    for index in range(tabs.count()):
        if tabs.widget(index).isAncestorOf(page):
            tabs.setCurrentIndex(index)
            return


def two_panes(left: QtWidgets.QWidget, right: QtWidgets.QWidget) -> QtWidgets.QSplitter:
    """Views left (3 parts) and tabs right (2 parts), split by a handle wide enough to drag with a
    finger; neither side collapses."""
    splitter = QtWidgets.QSplitter(QtCore.Qt.Orientation.Horizontal)
    splitter.setHandleWidth(10)
    for index, (pane, stretch) in enumerate(((left, 3), (right, 2))):
        splitter.addWidget(pane)
        splitter.setStretchFactor(index, stretch)
        splitter.setCollapsible(index, False)
    return splitter
