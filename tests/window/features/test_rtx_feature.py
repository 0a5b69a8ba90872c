"""The RTX feature on its own (no MainWindow): nothing for other arms; on rtx:sim a panel whose
Start initialises the emulated arm, whose state follows the bridge, and which STOP cancels."""
from __future__ import annotations

import pytest
from PySide6 import QtCore

from app.features.rtx import RtxFeature
from core.devices import rtx_protocol as p
from core.session import DeskSession, SessionOptions
from tests.window.features.feature_rig import TIMEOUT_MS, show_page


def click(qtbot, button):
    qtbot.mouseClick(button, QtCore.Qt.MouseButton.LeftButton, pos=button.rect().center())


def test_other_arms_get_no_panel(qtbot, session):
    feature = RtxFeature(session)
    assert feature.page is None and not feature.needs_init
    feature.poll()
    feature.estop()
    feature.stop()


@pytest.fixture
def rtx_session():
    s = DeskSession.create(SessionOptions(camera="sim", scenario="static", robot="umi_rtx",
                                          bridge="rtx:sim?speedup=60"))
    s.bridge.connect()
    yield s
    s.close()
    if hasattr(s.bridge, "shutdown"):
        s.bridge.shutdown()


def test_start_initialises_and_the_state_follows_the_bridge(qtbot, rtx_session):
    feature = RtxFeature(rtx_session)
    host = show_page(qtbot, feature.page)  # noqa: F841 (keeps the page alive)
    assert feature.needs_init and not rtx_session.bridge.ready
    assert feature.page.start_button.isEnabled()
    with qtbot.waitSignal(feature.sigReady, timeout=TIMEOUT_MS, check_params_cb=lambda ok: ok):
        click(qtbot, feature.page.start_button)
    assert rtx_session.bridge.ready and not feature.needs_init
    assert "ready" in feature.page.state_label.text()
    feature.stop()
    assert feature.runner is not None and not feature.runner.running


def test_stop_during_the_initialisation_stops_every_motor(qtbot, rtx_session):
    feature = RtxFeature(rtx_session)
    host = show_page(qtbot, feature.page)  # noqa: F841 (keeps the page alive)
    click(qtbot, feature.page.start_button)
    qtbot.waitUntil(lambda: feature.page.bars["column"].value() > 0, timeout=TIMEOUT_MS)
    with qtbot.waitSignal(feature.runner.sigFinished, timeout=TIMEOUT_MS) as finished:
        feature.estop()  # the window's STOP
    assert finished.args[0] is False
    ctl = rtx_session.bridge.emulator.controller
    assert not any(ax.busy for ax in ctl.axes.values())
    assert {ip for _, ip, c in ctl.received if c == p.stop(p.StopMode.DEAD)} == {p.IP0, p.IP1}
    qtbot.waitUntil(lambda: feature.page.start_button.isEnabled(), timeout=TIMEOUT_MS)
    assert not rtx_session.bridge.ready and feature.needs_init
    feature.stop()
