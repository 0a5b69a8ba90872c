"""The calibration wizard's own STOP: full screen on a 800×480 panel it hides the window's STOP
while the arm keeps moving, so it carries one (and takes Esc as STOP) on every page."""
from __future__ import annotations

import pytest
import shiboken6
from PySide6 import QtCore, QtWidgets

import widgets  # noqa: F401  (row-major images)
from app.calibration_worker import CalibrationController
from widgets.calibration_wizard import ESTOP_TEXT, STOP_PX, CalibrationWizard

TIMEOUT_MS = 5000
LEFT = QtCore.Qt.MouseButton.LeftButton


@pytest.fixture
def controller(qtbot, tmp_path, monkeypatch):
    """An open wizard with its worker; closed and joined at the end."""
    monkeypatch.setenv("DESKARM_HOME", str(tmp_path / "home"))
    ctl = CalibrationController(sessions_root=tmp_path / "sessions", min_interval_s=0.0)
    ctl.open()
    worker = ctl.worker
    qtbot.waitExposed(ctl.wizard)
    yield ctl
    ctl.close()
    assert ctl.worker is None
    # (a wizard closed in the test has had its worker stopped, joined and deleted already)
    assert not shiboken6.isValid(worker) or worker.isFinished(), "the worker must be stopped and joined"


def test_tapping_stop_in_the_wizard_asks_the_window_to_stop_the_arm(qtbot, controller):
    wizard = controller.wizard
    assert wizard.stop_button.isEnabled() and wizard.estop_label.text() == "Arm moving — STOP stops it"
    with qtbot.waitSignal(controller.sigStopRequested, timeout=TIMEOUT_MS):
        qtbot.mouseClick(wizard.stop_button, LEFT)
    # a second tap (panic, a bouncing touch screen) stops again: stopping twice is stopping
    with qtbot.waitSignal(controller.sigStopRequested, timeout=TIMEOUT_MS):
        qtbot.mouseClick(wizard.stop_button, LEFT)
    assert wizard.isVisible()  # STOP never closes the wizard


def test_the_stopped_state_shows_and_stop_is_greyed_out_until_the_window_re_arms(qtbot, controller):
    wizard = controller.wizard
    controller.set_estop(True)
    assert wizard.estop_label.text() == "ARM STOPPED (e-stop) — re-arm in the main window after closing this"
    assert not wizard.stop_button.isEnabled() and wizard.stop_button.text() == "STOPPED"
    assert not any(b.text().upper().startswith("RE-ARM") for b in wizard.findChildren(QtWidgets.QPushButton))
    controller.set_estop(False)  # re-armed in the main window
    assert wizard.stop_button.isEnabled() and wizard.estop_label.text() == ESTOP_TEXT[False]


def test_esc_requests_stop_and_does_not_close_the_wizard(qtbot, controller):
    wizard = controller.wizard
    wizard.activateWindow()
    for page in ("board", "capture"):
        wizard.set_page(page)
        with qtbot.waitSignal(controller.sigStopRequested, timeout=TIMEOUT_MS):
            qtbot.keyClick(wizard, QtCore.Qt.Key.Key_Escape)
        assert wizard.isVisible() and controller.wizard is wizard and controller.worker.isRunning()
    # also with the focus in a field of the board page
    wizard.set_page("board")
    field = wizard.fields["square_mm"]
    field.setFocus()
    with qtbot.waitSignal(controller.sigStopRequested, timeout=TIMEOUT_MS):
        qtbot.keyClick(field, QtCore.Qt.Key.Key_Escape)
    assert wizard.isVisible()
    worker = controller.worker
    qtbot.mouseClick(wizard.close_button, LEFT)  # closing stays on Close
    qtbot.waitUntil(lambda: controller.wizard is None, timeout=TIMEOUT_MS)
    assert controller.worker is None and (not shiboken6.isValid(worker) or worker.isFinished())


def test_a_wizard_opened_while_the_arm_is_stopped_shows_it(qtbot, tmp_path, monkeypatch):
    monkeypatch.setenv("DESKARM_HOME", str(tmp_path / "home"))
    ctl = CalibrationController(sessions_root=tmp_path / "sessions", min_interval_s=0.0)
    ctl.set_estop(True)  # before any wizard exists
    wizard = ctl.open()
    worker = ctl.worker
    try:
        assert not wizard.stop_button.isEnabled() and "ARM STOPPED" in wizard.estop_label.text()
    finally:
        ctl.close()
    assert worker.isFinished()
    again = ctl.open()  # the state outlives the wizard
    worker = ctl.worker
    try:
        assert not again.stop_button.isEnabled()
    finally:
        ctl.close()
    assert worker.isFinished()


@pytest.mark.parametrize("page", ["board", "capture", "results"])
def test_stop_is_on_screen_and_big_on_every_page_at_800x480(qtbot, page):
    wizard = CalibrationWizard()
    qtbot.addWidget(wizard)
    wizard.set_page(page)
    hint = wizard.minimumSizeHint()
    assert hint.width() <= 800 and hint.height() <= 480, hint
    wizard.resize(800, 480)
    wizard.show()
    qtbot.waitExposed(wizard)
    stop = wizard.stop_button
    assert stop.isVisible() and stop.height() >= STOP_PX >= 52 and stop.width() >= 100
    rect = QtCore.QRect(stop.mapTo(wizard, QtCore.QPoint(0, 0)), stop.size())
    assert wizard.rect().contains(rect), (rect, wizard.rect())
    assert wizard.estop_label.isVisible() and wizard.close_button.height() >= 44
    # STOP and Close are apart: a finger aiming at one does not land on the other
    close = QtCore.QRect(wizard.close_button.mapTo(wizard, QtCore.QPoint(0, 0)), wizard.close_button.size())
    assert close.left() - rect.right() >= 10
