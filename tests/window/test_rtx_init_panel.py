"""The UMI-RTX initialisation panel (pytest-qt, offscreen): Start and Cancel by real clicks, per-joint
bars fed by the runner from an emulated RTX (rtx:sim), Cancel stopping every motor."""
from __future__ import annotations

import os

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import pytest  # noqa: E402
from PySide6 import QtCore  # noqa: E402

import widgets  # noqa: E402,F401
from app.rtx_init_worker import RtxInitRunner  # noqa: E402
from core.devices import open_bridge  # noqa: E402
from core.devices import rtx_protocol as p  # noqa: E402
from core.devices.rtx_bridge import InitProgress  # noqa: E402
from core.kinematics.profile import load_profile  # noqa: E402
from widgets._style import TOUCH_PX  # noqa: E402
from widgets.rtx_init_panel import JOINT_LABELS, RtxInitPanel  # noqa: E402

TIMEOUT_MS = 60000  # an emulated initialisation on a loaded machine
SCREEN_W, SCREEN_H = 800, 480


@pytest.fixture
def panel(qtbot) -> RtxInitPanel:
    widget = RtxInitPanel()
    qtbot.addWidget(widget)
    widget.resize(SCREEN_W // 2, SCREEN_H)
    widget.show()
    qtbot.waitExposed(widget)
    return widget


@pytest.fixture
def rig(qtbot, panel):
    """The panel wired to a runner on a connected rtx:sim bridge (the emulated arm 60× faster)."""
    bridge = open_bridge("rtx:sim?speedup=60", load_profile("umi_rtx"))
    bridge.connect()
    runner = RtxInitRunner(bridge)
    panel.sigStartRequested.connect(runner.start)
    panel.sigCancelRequested.connect(runner.cancel)
    runner.sigProgress.connect(panel.set_progress)
    yield panel, runner, bridge
    runner.stop()
    assert not runner.running
    bridge.shutdown()


def click(qtbot, button):
    qtbot.mouseClick(button, QtCore.Qt.MouseButton.LeftButton, pos=button.rect().center())


def test_start_and_cancel_are_touch_sized_and_only_one_is_live(qtbot, panel):
    assert panel.start_button.height() >= TOUCH_PX and panel.cancel_button.height() >= TOUCH_PX
    assert panel.start_button.isEnabled() and not panel.cancel_button.isEnabled()
    with qtbot.waitSignal(panel.sigStartRequested, timeout=1000):
        click(qtbot, panel.start_button)
    assert not panel.start_button.isEnabled() and panel.cancel_button.isEnabled()
    with qtbot.waitSignal(panel.sigCancelRequested, timeout=1000):
        click(qtbot, panel.cancel_button)
    fractions = tuple((name, 0.5) for name, _ in JOINT_LABELS)
    panel.set_progress(InitProgress("", 0.0, "initialisation stopped", fractions=fractions, done=True))
    assert panel.start_button.isEnabled() and not panel.cancel_button.isEnabled()
    assert all(bar.value() == 50 for bar in panel.bars.values())


def test_start_initialises_the_emulated_arm_and_fills_every_bar(qtbot, rig):
    panel, runner, bridge = rig
    assert "restarted" in bridge.status().message  # a fresh emulator: the encoders mean nothing yet
    with qtbot.waitSignal(runner.sigFinished, timeout=TIMEOUT_MS) as finished:
        click(qtbot, panel.start_button)
    assert finished.args[0] is True
    qtbot.waitUntil(lambda: not panel.running, timeout=TIMEOUT_MS)
    assert all(bar.value() == 100 for bar in panel.bars.values())
    assert "ready" in panel.state_label.text() and bridge.ready


def test_cancel_during_the_initialisation_stops_every_motor(qtbot, rig):
    panel, runner, bridge = rig
    click(qtbot, panel.start_button)
    qtbot.waitUntil(lambda: panel.bars["column"].value() > 0, timeout=TIMEOUT_MS)
    with qtbot.waitSignal(runner.sigFinished, timeout=TIMEOUT_MS) as finished:
        click(qtbot, panel.cancel_button)
    assert finished.args[0] is False and "every motor stopped" in finished.args[1]
    ctl = bridge.emulator.controller
    assert not any(ax.busy for ax in ctl.axes.values())
    last = [ip for _, ip, c in ctl.received if c == p.stop(p.StopMode.DEAD)][-2:]
    assert set(last) == {p.IP0, p.IP1}
    qtbot.waitUntil(lambda: not panel.running, timeout=TIMEOUT_MS)
    assert panel.start_button.isEnabled() and not bridge.ready
