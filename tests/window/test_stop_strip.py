"""STOP that no finger can miss (issue 22, items 1–5): one fixed place, over every popup, Esc everywhere.

Every STOP test here drives real input events (QTest presses at STOP's coordinates, real key
presses) with a menu, a drop-down list, a tooltip or a dialog open — never a method call.
"""
import pytest
from PySide6 import QtCore, QtGui, QtWidgets
from PySide6.QtTest import QTest

from app.gui import MainWindow
from core.session import DeskSession, SessionOptions
from widgets.estop import StopGuard
from widgets.file_dialog import FileDialogWithStop

LEFT = QtCore.Qt.MouseButton.LeftButton
SIZES = [(800, 480), (1280, 800)]
NO_REARM_NEAR_STOP_PX = 40


def make_window(qtbot, size=(800, 480), scenario="static", camera="sim"):
    session = DeskSession.create(SessionOptions(camera=camera, scenario=scenario))
    w = MainWindow(session)
    qtbot.addWidget(w)
    # the offscreen screen is 800x800: a 1280x800 window would be shrunk onto it — keep the size
    w._fit_timer.timeout.disconnect(w.fit_to_screen)
    w.resize(*size)
    w.show()
    qtbot.waitExposed(w)
    settle(qtbot, w)
    return w


@pytest.fixture
def window(qtbot):
    w = make_window(qtbot)
    yield w
    w.stop()


def stop_rect(w) -> QtCore.QRect:
    """STOP's rectangle in the window's coordinates."""
    b = w.estop_button
    return QtCore.QRect(b.mapTo(w, QtCore.QPoint(0, 0)), b.size())


def global_stop_rect(w) -> QtCore.QRect:
    return QtCore.QRect(w.estop_button.mapToGlobal(QtCore.QPoint(0, 0)), w.estop_button.size())


def press_stop_spot(w, where="centre"):
    """A real press and release at STOP's place, sent to the window as the platform would."""
    r = stop_rect(w)
    point = {"centre": r.center(), "corner": r.topLeft() + QtCore.QPoint(3, 3),
             "edge": QtCore.QPoint(r.right() - 2, r.bottom() - 2)}[where]
    QTest.mousePress(w.windowHandle(), LEFT, QtCore.Qt.KeyboardModifier.NoModifier, point)
    QTest.mouseRelease(w.windowHandle(), LEFT, QtCore.Qt.KeyboardModifier.NoModifier, point)


def settle(qtbot, w):
    """Let queued layout requests run (a banner set, a button shown) and the window's fit to
    the screen happen (it may shrink a window that does not fit), then return."""
    QtWidgets.QApplication.processEvents()
    qtbot.waitUntil(lambda: not w._fit_timer.isActive())
    w.centralWidget().layout().activate()
    QtWidgets.QApplication.processEvents()


# --- 1 + 2. STOP keeps one place and size; RE-ARM is never near it ---------------------------
@pytest.mark.parametrize("size", SIZES)
def test_stop_keeps_one_place_in_every_state_and_rearm_stays_away(qtbot, tmp_path, monkeypatch, size):
    w = make_window(qtbot, size)
    try:
        settle(qtbot, w)
        assert (w.width(), w.height()) == size
        normal = stop_rect(w)
        rects = {"normal": normal}
        press_stop_spot(w)
        assert not w.session.controller.armed
        settle(qtbot, w)
        rects["stopped"] = stop_rect(w)
        rearm = QtCore.QRect(w.rearm_button.mapTo(w, QtCore.QPoint(0, 0)), w.rearm_button.size())
        assert w.rearm_button.isVisible()
        near = normal.adjusted(-NO_REARM_NEAR_STOP_PX, -NO_REARM_NEAR_STOP_PX,
                               NO_REARM_NEAR_STOP_PX, NO_REARM_NEAR_STOP_PX)
        assert not rearm.intersects(near), f"RE-ARM {rearm} within {NO_REARM_NEAR_STOP_PX} px of STOP {normal}"
        w.banner.show_message("a long banner " * 40, "warn")  # many lines
        settle(qtbot, w)
        rects["three-line banner"] = stop_rect(w)
        assert w.banner.height() > 3 * w.banner.fontMetrics().height()
        w.target_panel.set_reach_status("out of reach by 81 mm — going to the nearest point " * 3, False)
        settle(qtbot, w)
        rects["long target status"] = stop_rect(w)
        monkeypatch.setenv("DESKARM_HOME", str(tmp_path))
        w.record_button.setChecked(True)
        settle(qtbot, w)
        rects["recording"] = stop_rect(w)
        w.record_button.setChecked(False)
        w.on_estop(False)
        settle(qtbot, w)
        rects["re-armed"] = stop_rect(w)
        assert not w.rearm_button.isVisible()
    finally:
        w.stop()
    assert all(r == normal for r in rects.values()), rects


def test_stop_keeps_its_place_in_a_replay(qtbot, tmp_path, monkeypatch):
    import subprocess
    import sys

    monkeypatch.setenv("DESKARM_HOME", str(tmp_path))
    path = tmp_path / "rec"
    done = subprocess.run([sys.executable, "-m", "app.cli", "--headless", "--fast", "--duration", "1",
                           "--record", str(path)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    live = make_window(qtbot)
    replay = make_window(qtbot, camera=f"replay:{path}")
    try:
        settle(qtbot, live)
        settle(qtbot, replay)
        assert replay.replay_bar is not None
        assert stop_rect(replay) == stop_rect(live)
    finally:
        live.stop()
        replay.stop()


def test_pressing_and_holding_stops_spot_again_never_rearms(qtbot, window):
    """The "make sure" reflex: tap STOP, then press and hold the same spot — and its corners."""
    window.rearm_button.hold_ms = 30
    press_stop_spot(window)
    assert not window.session.controller.armed
    for where in ("centre", "corner", "edge"):
        r = stop_rect(window)
        point = {"centre": r.center(), "corner": r.topLeft() + QtCore.QPoint(3, 3),
                 "edge": QtCore.QPoint(r.right() - 2, r.bottom() - 2)}[where]
        QTest.mousePress(window.windowHandle(), LEFT, QtCore.Qt.KeyboardModifier.NoModifier, point)
        # the press went to STOP (stopping again), not to RE-ARM: no hold can even begin
        assert not window.rearm_button.isDown() and not window.rearm_button.holding
        hit = window.childAt(point)
        assert hit is window.estop_button or window.estop_button.isAncestorOf(hit)
        QTest.mouseRelease(window.windowHandle(), LEFT, QtCore.Qt.KeyboardModifier.NoModifier, point)
        assert not window.session.controller.armed
    # RE-ARM still works where it is, held for its whole time
    with qtbot.waitSignal(window.rearm_button.sigHeld, timeout=3000):
        QTest.mousePress(window.rearm_button, LEFT)
    QTest.mouseRelease(window.rearm_button, LEFT)
    assert window.session.controller.armed


# --- 3. a press on STOP's area stops whatever is open; nothing covers STOP ----------------------
def test_stop_works_with_the_menu_open_and_the_menu_never_covers_it(qtbot, window):
    menu = window.menu_button.menu()
    opened = []

    def press_stop_while_the_menu_is_open():
        opened.append(QtWidgets.QApplication.activePopupWidget() is menu)
        assert not menu.frameGeometry().intersects(global_stop_rect(window))
        press_stop_spot(window)

    QtCore.QTimer.singleShot(200, press_stop_while_the_menu_is_open)
    QTest.mouseClick(window.menu_button, LEFT)  # InstantPopup: runs the menu until it closes
    qtbot.waitUntil(lambda: opened and not menu.isVisible())
    assert opened == [True]
    assert not window.session.controller.armed


def test_esc_stops_with_the_menu_open(qtbot, window):
    menu = window.menu_button.menu()
    menu.popup(window.menu_button.mapToGlobal(QtCore.QPoint(0, window.menu_button.height())))
    qtbot.waitUntil(lambda: QtWidgets.QApplication.activePopupWidget() is menu)
    QTest.keyClick(menu, QtCore.Qt.Key.Key_Escape)
    assert not window.session.controller.armed
    qtbot.waitUntil(lambda: not menu.isVisible())  # and the menu closes, as Esc does


def test_an_open_drop_down_list_does_not_cover_stop_and_a_press_there_picks_nothing(qtbot, window):
    panel = window.target_panel.teleop
    window.tabs.setCurrentIndex(0)
    window.target_panel.mode_buttons["teleop"].click()
    combo = panel.source_combo
    qtbot.waitUntil(combo.isVisible)
    before = combo.currentIndex()
    chosen = []
    combo.activated.connect(chosen.append)
    combo.showPopup()
    popup = combo.view().window()
    qtbot.waitUntil(popup.isVisible)
    assert popup is not window
    assert not popup.frameGeometry().intersects(global_stop_rect(window)), (popup.frameGeometry(),
                                                                             global_stop_rect(window))
    press_stop_spot(window)
    assert not window.session.controller.armed
    qtbot.waitUntil(lambda: not popup.isVisible())
    assert combo.currentIndex() == before and chosen == []


def test_a_list_opened_over_stop_is_moved_off_it(qtbot, window):
    """A popup placed right over STOP (as a long list near the top right would be) is moved."""
    combo = QtWidgets.QComboBox(window)
    combo.addItems([f"item {i}" for i in range(40)])
    combo.setGeometry(window.estop_button.geometry().translated(0, 0))
    combo.show()
    combo.showPopup()
    popup = combo.view().window()
    qtbot.waitUntil(popup.isVisible)
    assert not popup.frameGeometry().intersects(global_stop_rect(window))
    combo.hidePopup()


def test_a_tooltip_never_covers_stop(qtbot, window):
    QtWidgets.QToolTip.showText(global_stop_rect(window).center(), "a tooltip over STOP", window.estop_button)
    tips = [w for w in QtWidgets.QApplication.topLevelWidgets()
            if w.windowType() == QtCore.Qt.WindowType.ToolTip and w.isVisible()]
    assert tips
    assert not any(t.frameGeometry().intersects(global_stop_rect(window)) for t in tips)
    QtWidgets.QToolTip.hideText()


def test_a_dialog_never_covers_stop_and_stop_works_while_it_is_open(qtbot, window):
    dialog = window.show_help()
    qtbot.waitUntil(dialog.isVisible)
    dialog.move(window.mapToGlobal(QtCore.QPoint(window.width() - dialog.width(), 0)))  # dragged over STOP
    QtWidgets.QApplication.processEvents()
    assert not dialog.frameGeometry().intersects(global_stop_rect(window))
    press_stop_spot(window)
    assert not window.session.controller.armed


def test_esc_in_any_window_stops(qtbot, window):
    dialog = window.show_help()
    qtbot.waitUntil(dialog.isVisible)
    QTest.keyClick(dialog, QtCore.Qt.Key.Key_Escape)
    assert not window.session.controller.armed and dialog.isVisible()  # Esc is STOP, not Close


# --- 4. the keys come back after a dialog (no window manager) ----------------------------------
def test_the_window_takes_the_keyboard_back_when_a_dialog_closes(qtbot, window, monkeypatch):
    """With no window manager X11 gives the focus to the root window when a dialog closes; the
    guard asks for it back whenever no window of the application is active."""
    asked = []
    monkeypatch.setattr(window, "activateWindow", lambda: asked.append(True))
    dialog = window.show_help()
    qtbot.waitUntil(dialog.isVisible)
    monkeypatch.setattr(QtWidgets.QApplication, "activeWindow", staticmethod(lambda: None))  # the root has it
    close = next(b for b in dialog.findChildren(QtWidgets.QPushButton) if b.text().startswith("Close"))
    qtbot.mouseClick(close, LEFT)
    qtbot.waitUntil(lambda: bool(asked))


def test_the_window_asks_for_the_keyboard_when_it_shows(qtbot, monkeypatch):
    asked = []
    monkeypatch.setattr(MainWindow, "activateWindow", lambda self: asked.append(self))
    monkeypatch.setattr(QtWidgets.QApplication, "activeWindow", staticmethod(lambda: None))
    w = make_window(qtbot)
    try:
        qtbot.waitUntil(lambda: w in asked)
    finally:
        w.stop()


# --- 5. a file dialog: Qt's own, with STOP, Esc = STOP, not modal ------------------------------
def test_the_save_board_file_dialog_carries_stop_and_esc_stops(qtbot, window, tmp_path):
    window.on_open_calibration()
    wizard = window.calibration_controller.wizard
    qtbot.waitUntil(wizard.isVisible)
    wizard.fields["square_mm"].setValue(30.0)
    qtbot.mouseClick(wizard.print_button, LEFT)
    dialog = wizard.file_dialog
    assert isinstance(dialog, FileDialogWithStop) and dialog.isVisible()
    assert QtWidgets.QApplication.activeModalWidget() is None  # the window's STOP stays live
    assert not dialog.frameGeometry().intersects(global_stop_rect(window))
    name = dialog.files.findChild(QtWidgets.QLineEdit, "fileNameEdit")
    QTest.keyClick(name, QtCore.Qt.Key.Key_Escape)
    assert not window.session.controller.armed and dialog.isVisible()  # Esc stopped, did not cancel
    window.on_estop(False)
    press_stop_spot(window)  # the window's STOP, while the file dialog is open
    assert not window.session.controller.armed
    window.on_estop(False)
    qtbot.mouseClick(dialog.stop_button, LEFT)  # the dialog's own STOP
    assert not window.session.controller.armed
    # and it still saves where the user says
    dialog.files.setDirectory(str(tmp_path))
    name.setText("my board.png")
    QTest.keyClick(name, QtCore.Qt.Key.Key_Return)
    qtbot.waitUntil(lambda: wizard.last_printed == tmp_path / "my board.png")
    assert (tmp_path / "my board.png").is_file()


def test_guards_go_away_with_their_windows(qtbot):
    before = len(StopGuard._live)
    w = make_window(qtbot)
    assert len(StopGuard._live) == before + 1
    w.stop()
    assert len(StopGuard._live) == before


def test_a_key_that_reaches_an_inactive_window_still_triggers_its_action(qtbot, window, monkeypatch):
    """With no window manager, after a dialog closes X sometimes gives the window the keys while Qt
    counts no window as active (seen under Xvfb: Ctrl+Q then matched no shortcut): the guard
    triggers the window's action for the key and asks for the activation again."""
    asked = []
    monkeypatch.setattr(QtWidgets.QApplication, "activeWindow", staticmethod(lambda: None))
    monkeypatch.setattr(window, "activateWindow", lambda: asked.append(True))
    helped = []
    window.help_action.triggered.connect(lambda *_: helped.append(True))
    press = QtGui.QKeyEvent(QtCore.QEvent.Type.KeyPress, QtCore.Qt.Key.Key_F1, QtCore.Qt.KeyboardModifier.NoModifier)
    QtWidgets.QApplication.sendEvent(window.windowHandle(), press)
    assert helped == [True] and asked
    other = QtGui.QKeyEvent(QtCore.QEvent.Type.KeyPress, QtCore.Qt.Key.Key_A, QtCore.Qt.KeyboardModifier.NoModifier)
    QtWidgets.QApplication.sendEvent(window.windowHandle(), other)  # no action of the window: nothing
    assert helped == [True]
    window.help_dialog.close()
