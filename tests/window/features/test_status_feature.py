"""The status feature on its own (app/features/status.py): the banner shows the most important
message (camera lost over e-stop over a note), a note that does not fit the STOP strip moves to
the row below it and back, and the status bar says E-STOP first. A real session, the strip and
the status bar shown, no MainWindow."""
import pytest
from PySide6 import QtWidgets

from app.features.status import StatusFeature


@pytest.fixture
def status(qtbot, session):
    feature = StatusFeature(session)
    window = QtWidgets.QMainWindow()
    central = QtWidgets.QWidget()
    outer = QtWidgets.QVBoxLayout(central)
    outer.addWidget(feature.build_strip(QtWidgets.QLabel("on target")))
    outer.addLayout(feature.banner_row)
    outer.addStretch(1)
    window.setCentralWidget(central)
    feature.status_items.add_to(window.statusBar())
    qtbot.addWidget(window)
    window.resize(500, 300)
    window.show()
    qtbot.waitExposed(window)
    feature.window = window  # kept: qtbot holds it weakly
    return feature


def test_the_most_important_message_wins(status, session):
    status.show_note("new calibration in use")
    assert status.banner.text() == "new calibration in use"
    session.controller.estop()
    try:
        status.restore()
        assert status.banner.text().startswith("E-STOP")
        status.set_camera_error("/dev/video0 unplugged")
        assert status.banner.text() == "camera lost — /dev/video0 unplugged — retrying"
        status.set_camera_error(None)
        assert status.banner.text().startswith("E-STOP")
    finally:
        session.controller.rearm()
    status.restore()
    assert status.banner.text() == "new calibration in use"
    status.clear_note()
    assert status.banner.text() != "new calibration in use"


def test_a_long_note_moves_below_the_strip_and_a_short_one_comes_back(qtbot, status):
    status.show_note("a very long note " * 12)
    qtbot.waitUntil(lambda: status.banner.parentWidget() is not status.strip_messages)
    qtbot.waitUntil(status.banner.isVisible)  # shown again once re-parented (a queued show)
    status.show_note("short")
    qtbot.waitUntil(lambda: status.banner.parentWidget() is status.strip_messages)


def test_the_status_bar_says_e_stop_before_the_bridge(status, session):
    session.controller.estop()
    try:
        status.refresh(29.9, 40.0, None)
        assert "E-STOP" in status.status_items.bridge_label.text()
    finally:
        session.controller.rearm()
    status.refresh(29.9, 40.0, None)
    assert "E-STOP" not in status.status_items.bridge_label.text()
