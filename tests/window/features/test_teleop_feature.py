"""The teleop feature on its own (app/features/teleop.py): choosing a hand source on the Teleop
page gives the targeter a controller (the keyboard's JogTeleopSource here) and TELEOP mode;
Restart puts the keyboard back where it started; an impossible target box is refused with the
reason and a preset is taken. A real session, the Target tab's Teleop page shown, no MainWindow."""
from types import SimpleNamespace

import pytest
from PySide6 import QtCore

from app.features.teleop import TeleopFeature
from core.messages import TargetMode
from core.motion.jog import JogTeleopSource
from widgets.target_panel import TargetPanel
from feature_rig import show_page

LEFT = QtCore.Qt.MouseButton.LeftButton


@pytest.fixture
def teleop(qtbot, session):
    calls = SimpleNamespace(modes=[], notes=[])
    panel = TargetPanel()

    def set_mode(mode):
        calls.modes.append(mode)
        session.targeter.set_mode(TargetMode(mode))

    feature = TeleopFeature(session, panel.teleop, set_mode, lambda: None, lambda: [])
    feature.sigNote.connect(calls.notes.append)
    feature.calls = calls
    feature.host = show_page(qtbot, panel, size=(420, 700))  # kept: qtbot holds it weakly
    panel.set_mode(TargetMode.TELEOP.value)  # the Teleop page shows
    return feature


def choose_with_keys(qtbot, combo, data):
    """Arrow keys on the focused source list until ``data`` is chosen (each key emits activated)."""
    combo.setFocus()
    for _ in range(combo.count()):
        if combo.currentData() == data:
            return
        qtbot.keyClick(combo, QtCore.Qt.Key.Key_Down)
    assert combo.currentData() == data, [combo.itemData(i) for i in range(combo.count())]


def test_choosing_the_keyboard_drives_teleop_with_a_jog_source(qtbot, teleop, session):
    choose_with_keys(qtbot, teleop.teleop_panel.source_combo, "keyboard")
    assert isinstance(session.targeter.teleop, JogTeleopSource) and teleop.keyboard is session.targeter.teleop
    assert session.targeter.mode is TargetMode.TELEOP and teleop.calls.modes[-1] == "teleop"


def test_restart_puts_the_keyboard_source_back_where_it_started(qtbot, teleop, session):
    choose_with_keys(qtbot, teleop.teleop_panel.source_combo, "keyboard")
    keyboard = teleop.keyboard
    start = tuple(keyboard.jogger.base_p_target)
    keyboard.press(0, +1, 0.0)
    keyboard.release(0, 0.0)
    assert tuple(keyboard.jogger.base_p_target) != start
    qtbot.mouseClick(teleop.teleop_panel.restart_button, LEFT)
    assert tuple(keyboard.jogger.base_p_target) == pytest.approx(start)


def test_a_source_that_cannot_be_made_is_said_and_the_old_one_stays(qtbot, teleop, session):
    choose_with_keys(qtbot, teleop.teleop_panel.source_combo, "keyboard")
    before = session.targeter.teleop

    def broken(spec):
        raise OSError(f"{spec}: no such device")

    teleop.source_factory = broken
    combo = teleop.teleop_panel.source_combo
    combo.setFocus()
    qtbot.keyClick(combo, QtCore.Qt.Key.Key_Up)  # a marker or colour source above the keyboard
    assert session.targeter.teleop is before
    assert teleop.calls.notes and "no such device" in teleop.calls.notes[-1]
    assert combo.currentData() == "keyboard"  # the list shows the source in use again


def test_a_target_box_inside_out_is_refused_with_the_axis_and_a_preset_is_taken(qtbot, teleop):
    panel = teleop.teleop_panel
    before = panel.accepted_box
    x_min = panel.box_spins["x"][0]
    x_min.setFocus()
    x_min.selectAll()
    qtbot.keyClicks(x_min, "9")  # 9 cm: beyond the box's x max
    qtbot.keyClick(x_min, QtCore.Qt.Key.Key_Return)
    qtbot.waitUntil(lambda: "min must be below max along x" in panel.box_message.text(), timeout=5000)
    assert panel.accepted_box == before
    combo = panel.preset_combo
    combo.setFocus()
    qtbot.keyClick(combo, QtCore.Qt.Key.Key_Down)  # "Every arm reaches": the box in use
    assert panel.accepted_box == before
    qtbot.keyClick(combo, QtCore.Qt.Key.Key_Down)  # "Half size"
    assert panel.accepted_box != before and panel.accepted_box.extent[0] == pytest.approx(before.extent[0] / 2)
