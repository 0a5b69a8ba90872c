"""The assistive view's ☰ menu: quitting is for the carer, out of a switch user's reach.

The ☰ button sits in the top left corner, as far from STOP (top right) as the window allows; its
menu (Quit, Close menu) is a panel in the window, not a popup: nothing grabs the mouse or the keys
while it is open, so STOP and Esc stop as ever. In the switch modes a mouse button that is a
switch, pressed over ☰ or the menu's buttons, is that switch (``SwitchSafeButton``) and never
opens or triggers them. Ctrl+Q quits too (a carer's key, not a switch's).
"""
from __future__ import annotations

from typing import Callable

from PySide6 import QtCore, QtGui, QtWidgets

from widgets._style import BUTTON_STYLE
from widgets.assist_view import SwitchSafeButton

MENU_BUTTON_PX = 52  # the ☰ button: a fingertip target (≥ TOUCH_PX) beside the state line


class AssistMenu(QtCore.QObject):
    """The ☰ button, its panel over ``central`` (hidden until asked for) and Ctrl+Q on ``window``.

    Signals (GUI thread): sigQuit() — Quit in the menu, or Ctrl+Q.

    ``is_mouse_switch(name)``: True when mouse button ``name`` is a switch in the current mode;
    ``switch_down(name)`` / ``switch_up(name)``: where such a press over the menu's buttons goes."""

    sigQuit = QtCore.Signal()

    def __init__(self, window: QtWidgets.QWidget, central: QtWidgets.QWidget, is_mouse_switch: Callable[[str], bool],
                 switch_down: Callable[[str], object], switch_up: Callable[[str], object]):
        super().__init__(window)
        self.central = central
        self.button = SwitchSafeButton("☰", is_mouse_switch)
        self.button.setObjectName("assistMenuButton")
        self.button.setFixedSize(MENU_BUTTON_PX, MENU_BUTTON_PX)
        font = QtGui.QFont(window.font())
        font.setPixelSize(28)
        self.button.setFont(font)
        self.button.setToolTip("Menu: Quit (also Ctrl+Q). In the switch modes the mouse buttons are "
                               "switches here too: choose Touch first, or press Ctrl+Q.")
        self.button.clicked.connect(self.toggle)
        self.panel = QtWidgets.QFrame(central)
        self.panel.setObjectName("assistMenu")
        self.panel.setStyleSheet("#assistMenu { background: #303030; border: 2px solid #9e9e9e; "
                                 "border-radius: 8px; }")
        box = QtWidgets.QVBoxLayout(self.panel)
        box.setContentsMargins(8, 8, 8, 8)
        box.setSpacing(8)
        font = QtGui.QFont(window.font())
        font.setPointSize(14)
        self.quit_button = SwitchSafeButton("Quit  (Ctrl+Q)", is_mouse_switch)
        self.close_button = SwitchSafeButton("Close menu", is_mouse_switch)
        for button in (self.quit_button, self.close_button):
            button.setStyleSheet(BUTTON_STYLE)
            button.setFont(font)
            button.setMinimumWidth(200)
            box.addWidget(button)
        for button in (self.button, self.quit_button, self.close_button):
            button.sigSwitchPressed.connect(switch_down)
            button.sigSwitchReleased.connect(switch_up)
        self.quit_button.clicked.connect(lambda: self.sigQuit.emit())
        self.close_button.clicked.connect(lambda: self.close())
        self.panel.hide()
        self.quit_action = QtGui.QAction("Quit", window)  # Ctrl+Q: a carer's key, not a switch's
        self.quit_action.setShortcut(QtGui.QKeySequence("Ctrl+Q"))
        self.quit_action.triggered.connect(lambda: self.sigQuit.emit())
        window.addAction(self.quit_action)

    def toggle(self) -> None:
        """Open the menu under the ☰ button (or close it when open)."""
        if self.panel.isVisible():
            self.close()
            return
        self.panel.adjustSize()
        self.panel.move(self.button.mapTo(self.central, QtCore.QPoint(0, self.button.height() + 4)))
        self.panel.raise_()
        self.panel.show()

    def close(self) -> None:
        self.panel.hide()
