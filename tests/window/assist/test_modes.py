"""The assistive view's input modes on their own (app.assist.modes.ChoiceModes, no AssistWindow):
its mode buttons and scan period answer real clicks and keys, a tap on the view chooses the box
under it, two switches move the highlight and confirm, the one-switch scan moves on the clock and a
short press chooses (pytest-qt, offscreen; real mouse and key events, a fake clock for the scan)."""
import numpy as np
from PySide6 import QtCore, QtGui, QtWidgets

from app.assist.modes import ChoiceModes
from app.assist.settings import AssistSettings
from widgets.assist_view import AssistView

LEFT = QtCore.Qt.MouseButton.LeftButton
BOXES = [(100.0, 100.0, 60.0, 60.0), (300.0, 100.0, 60.0, 60.0), (500.0, 100.0, 60.0, 60.0)]


class Rig:
    """A view and the column of mode buttons in a plain widget, the choice and the highlight moves kept."""

    def __init__(self, qtbot):
        self.t = 100.0
        self.chosen, self.moved = [], []
        self.choosing = True
        self.widget = QtWidgets.QWidget()
        layout = QtWidgets.QHBoxLayout(self.widget)
        self.view = AssistView()
        layout.addWidget(self.view, 1)
        self.modes = ChoiceModes(self.view, lambda: self.choosing, self.chosen.append, self.moved.append,
                                 lambda: self.t, QtGui.QFont(), 1.0, self.widget)
        column = QtWidgets.QVBoxLayout()
        for w in self.modes.widgets():
            column.addWidget(w)
        layout.addLayout(column)
        qtbot.addWidget(self.widget)
        self.widget.resize(800, 480)
        self.widget.show()
        qtbot.waitExposed(self.widget)
        self.view.set_image(np.zeros((480, 640, 3), np.uint8))
        self.view.set_boxes(BOXES)


def test_a_click_on_a_mode_button_asks_for_that_mode_and_the_period_answers_the_keyboard(qtbot):
    rig = Rig(qtbot)
    modes = rig.modes
    with qtbot.waitSignal(modes.sigModeChosen) as chosen:
        qtbot.mouseClick(modes.buttons["scan2"], LEFT)
    assert chosen.args == ["scan2"]
    modes.show_mode("scan1")
    assert modes.buttons["scan1"].isChecked() and not modes.buttons["scan2"].isChecked()
    assert modes.period_spin.isEnabled()
    modes.show_mode("touch")
    assert not modes.period_spin.isEnabled()
    modes.show_mode("scan1")
    with qtbot.waitSignal(modes.sigPeriodChanged) as changed:
        modes.period_spin.setFocus()
        qtbot.keyClick(modes.period_spin, QtCore.Qt.Key.Key_Up)  # one step: 0.5 s
    assert changed.args == [1.5]


def test_a_tap_on_a_box_chooses_it_and_a_tap_beside_every_box_is_acknowledged(qtbot):
    rig = Rig(qtbot)
    rig.view.sigPressed.connect(lambda name, point, box: rig.modes.tap(point, box, BOXES))
    qtbot.mouseClick(rig.view, LEFT, pos=rig.view.to_widget((20.0, 460.0)).toPoint())
    assert rig.modes.ignored_taps == 1 and rig.view.ack_visible and rig.chosen == []
    qtbot.mouseClick(rig.view, LEFT, pos=rig.view.to_widget((330.0, 130.0)).toPoint())
    assert rig.chosen == [1]
    rig.choosing = False  # the arm is on its way: a tap only shows it was seen
    qtbot.mouseClick(rig.view, LEFT, pos=rig.view.to_widget((530.0, 130.0)).toPoint())
    assert rig.chosen == [1]


def test_two_switches_move_the_highlight_and_confirm_on_release(qtbot):
    rig = Rig(qtbot)
    modes = rig.modes
    modes.restart(AssistSettings(mode="scan2"), len(BOXES))
    assert rig.view.highlight == 0
    for role in ("next", "next"):
        modes.press(role, rig.t)
        modes.release(role, rig.t + 0.1, held_long=False)
    assert rig.view.highlight == 2 and rig.moved == [1, 2]
    modes.press("confirm", rig.t)
    modes.release("confirm", rig.t + 2.0, held_long=True)  # its hold stopped the arm: nothing else
    assert rig.chosen == []
    modes.release("confirm", rig.t + 0.1, held_long=False)
    assert rig.chosen == [2]
    modes.cancel()
    assert rig.view.highlight is None and modes.scanner is None


def test_the_one_switch_scan_moves_on_its_clock_and_a_short_press_chooses(qtbot):
    rig = Rig(qtbot)
    modes = rig.modes
    modes.restart(AssistSettings(mode="scan1", scan_period_s=1.0), len(BOXES))
    assert rig.view.highlight == 0
    rig.t += 1.0
    modes.tick(rig.t)
    assert rig.view.highlight == 1 and rig.moved == [1]
    rig.t += 0.3
    modes.press("single", rig.t)
    modes.release("single", rig.t + 0.15, held_long=True)  # its hold already acted (a re-arm): no choice
    assert rig.chosen == []
    modes.press("single", rig.t + 0.2)
    modes.release("single", rig.t + 0.35, held_long=False)
    assert rig.chosen == [1]
    rig.choosing = False  # the arm is on its way
    rig.t += 5.0
    modes.tick(rig.t)  # nothing moves while no choice may be made
    assert rig.view.highlight == 1 and rig.moved == [1]


def test_touch_mode_and_no_choice_have_no_scan(qtbot):
    rig = Rig(qtbot)
    rig.modes.restart(AssistSettings(mode="touch"), len(BOXES))
    assert rig.modes.scanner is None and rig.view.highlight is None
    rig.choosing = False
    rig.modes.restart(AssistSettings(mode="scan2"), len(BOXES))
    assert rig.modes.scanner is None and rig.view.highlight is None
