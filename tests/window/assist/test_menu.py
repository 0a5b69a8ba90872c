"""The assistive view's ☰ menu on its own (app.assist.menu.AssistMenu, no AssistWindow): a click
opens the panel under ☰ and Close hides it, Quit and Ctrl+Q ask to quit, and a mouse button that is
a switch pressed over ☰ or Quit is handed on as that switch, never a click (pytest-qt, offscreen)."""
import pytest
from PySide6 import QtCore, QtWidgets

from app.assist.menu import MENU_BUTTON_PX, AssistMenu

LEFT, RIGHT = QtCore.Qt.MouseButton.LeftButton, QtCore.Qt.MouseButton.RightButton


@pytest.fixture
def menu(qtbot):
    window = QtWidgets.QWidget()
    central = QtWidgets.QWidget(window)
    QtWidgets.QVBoxLayout(window).addWidget(central)
    layout = QtWidgets.QVBoxLayout(central)
    switches = {"mouse:right"}  # the current mode's mouse switches
    downs, ups = [], []
    m = AssistMenu(window, central, lambda name: name in switches, downs.append, ups.append)
    layout.addWidget(m.button, 0, QtCore.Qt.AlignmentFlag.AlignLeft | QtCore.Qt.AlignmentFlag.AlignTop)
    layout.addStretch(1)
    qtbot.addWidget(window)
    window.resize(800, 480)
    window.show()
    qtbot.waitExposed(window)
    return m, window, switches, downs, ups


def test_a_click_opens_the_menu_under_the_button_and_close_hides_it(menu, qtbot):
    m, _, _, _, _ = menu
    assert m.button.width() == MENU_BUTTON_PX and not m.panel.isVisible()
    qtbot.mouseClick(m.button, LEFT)
    assert m.panel.isVisible() and m.quit_button.isVisible()
    assert m.panel.geometry().top() >= m.button.geometry().bottom()  # under ☰, not over it
    qtbot.mouseClick(m.close_button, LEFT)
    assert not m.panel.isVisible()
    qtbot.mouseClick(m.button, LEFT)
    qtbot.mouseClick(m.button, LEFT)  # ☰ again closes it
    assert not m.panel.isVisible()


def test_quit_and_ctrl_q_ask_to_quit(menu, qtbot):
    m, window, _, _, _ = menu
    qtbot.mouseClick(m.button, LEFT)
    with qtbot.waitSignal(m.sigQuit):
        qtbot.mouseClick(m.quit_button, LEFT)
    window.activateWindow()
    with qtbot.waitSignal(m.sigQuit):
        qtbot.keyClick(window, QtCore.Qt.Key.Key_Q, QtCore.Qt.KeyboardModifier.ControlModifier)


def test_a_mouse_switch_over_the_menu_s_buttons_is_the_switch(menu, qtbot):
    m, _, switches, downs, ups = menu
    qtbot.mouseClick(m.button, RIGHT)
    assert downs == ["mouse:right"] and ups == ["mouse:right"] and not m.panel.isVisible()
    qtbot.mouseClick(m.button, LEFT)  # not a switch now: a click
    assert m.panel.isVisible()
    switches.add("mouse:left")
    quits = []
    m.sigQuit.connect(lambda: quits.append(1))
    qtbot.mouseClick(m.quit_button, LEFT)  # a switch user's pointer resting on Quit
    assert quits == [] and downs[-1] == "mouse:left"
