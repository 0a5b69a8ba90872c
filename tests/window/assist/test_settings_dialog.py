"""The assistive view's "Switches…" on its own (app.assist.settings_dialog.SwitchSettingsEditor, no
AssistWindow): a click opens one dialog (not modal), a bad mapping is refused in words, OK gives
the edited settings, its STOP and Esc ask for a stop and leave it open (pytest-qt, offscreen)."""
import pytest
from PySide6 import QtCore, QtGui, QtWidgets

from app.assist.settings import AssistSettings
from app.assist.settings_dialog import SwitchSettingsEditor

LEFT = QtCore.Qt.MouseButton.LeftButton


@pytest.fixture
def editor(qtbot):
    host = QtWidgets.QWidget()
    layout = QtWidgets.QVBoxLayout(host)
    current = {"settings": AssistSettings(mode="scan2")}
    e = SwitchSettingsEditor(lambda: current["settings"], host, QtGui.QFont())
    layout.addWidget(e.button)
    qtbot.addWidget(host)
    host.show()
    qtbot.waitExposed(host)
    yield e, current
    if e.dialog is not None and e.dialog.isVisible():
        e.dialog.close()


def ok_button(dialog):
    return dialog.findChild(QtWidgets.QDialogButtonBox).button(QtWidgets.QDialogButtonBox.StandardButton.Ok)


def test_a_click_opens_one_dialog_that_refuses_a_switch_in_two_roles_and_ok_applies(editor, qtbot):
    e, current = editor
    qtbot.mouseClick(e.button, LEFT)
    dialog = e.dialog
    qtbot.waitUntil(lambda: dialog.isVisible())
    assert QtWidgets.QApplication.activeModalWidget() is None  # not modal: the window's STOP stays live
    qtbot.mouseClick(e.button, LEFT)
    assert e.dialog is dialog  # raised, not a second one
    assert dialog.edits["next_switch"].text() == "key:Space, mouse:right"
    dialog.edits["next_switch"].setText("key:Return")  # the same as confirm: refused
    qtbot.mouseClick(ok_button(dialog), LEFT)
    assert "both 'next' and 'confirm'" in dialog.error.text() and dialog.isVisible()
    dialog.edits["next_switch"].setText("key:N, mouse:right")
    with qtbot.waitSignal(e.sigApplied) as applied:
        qtbot.mouseClick(ok_button(dialog), LEFT)
    assert applied.args[0] == AssistSettings(mode="scan2", next_switch=("key:N", "mouse:right"))
    current["settings"] = applied.args[0]
    qtbot.mouseClick(e.button, LEFT)  # the next dialog starts from the settings now
    qtbot.waitUntil(lambda: e.dialog is not None and e.dialog.isVisible())
    assert e.dialog.edits["next_switch"].text() == "key:N, mouse:right"


def test_its_stop_and_esc_ask_for_a_stop_and_leave_it_open(editor, qtbot):
    e, _ = editor
    qtbot.mouseClick(e.button, LEFT)
    dialog = e.dialog
    qtbot.waitUntil(lambda: dialog.isVisible())
    with qtbot.waitSignal(e.sigStopRequested):
        qtbot.mouseClick(dialog.stop_button, LEFT)
    with qtbot.waitSignal(e.sigStopRequested):
        qtbot.keyClick(dialog.edits["next_switch"], QtCore.Qt.Key.Key_Escape)  # Esc = STOP, not Cancel
    assert dialog.isVisible()
