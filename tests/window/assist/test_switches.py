"""The assistive view's switches on their own (app.assist.switches.SwitchInput, no AssistWindow):
key events as X11 delivers them reach a plain widget that hands them on, a short press acts on its
release, a hold stops once (and, begun stopped, re-arms), auto-repeat pairs never act, the
pending-release timer ends a real release's wait, and a GPIO switch's presses arrive from its
thread (a fake gpiozero). Waits on events; every source is stopped and joined."""
import sys

import pytest
from PySide6 import QtCore, QtGui, QtWidgets

from app.assist.settings import AssistSettings, switch_role
from app.assist.switches import SwitchInput

SPACE = QtCore.Qt.Key.Key_Space
LONG_S = 1.5


class KeyTarget(QtWidgets.QWidget):
    """A focusable widget that hands its key events to the switch input, as the window does."""

    def __init__(self):
        super().__init__()
        self.switches = None
        self.setFocusPolicy(QtCore.Qt.FocusPolicy.StrongFocus)

    def keyPressEvent(self, event):  # noqa: N802 (Qt override)
        if not self.switches.key_press(event):
            super().keyPressEvent(event)

    def keyReleaseEvent(self, event):  # noqa: N802 (Qt override)
        if not self.switches.key_release(event):
            super().keyReleaseEvent(event)


@pytest.fixture
def rig(qtbot):
    made = []

    def make(settings: AssistSettings):
        r = type("Rig", (), {})()
        r.t, r.stopped, r.settings = 100.0, False, settings
        r.presses, r.releases, r.holds = [], [], []
        r.target = KeyTarget()
        r.switches = SwitchInput(lambda name: switch_role(r.settings, name), lambda: LONG_S, lambda: r.stopped,
                                 lambda: r.t, lambda role, now: r.presses.append(role),
                                 lambda role, now, held_long: r.releases.append((role, held_long)),
                                 r.holds.append, r.target)
        r.target.switches = r.switches
        qtbot.addWidget(r.target)
        r.target.show()
        qtbot.waitExposed(r.target)
        made.append(r)
        return r

    yield make
    for r in made:
        r.switches.stop_sources()
        assert r.switches.sources == {}


def send_key(widget, kind: str, stamp: int, autorepeat: bool = False) -> None:
    """A Space key event with the X server's timestamp (ms) and auto-repeat flag."""
    event_type = QtCore.QEvent.Type.KeyPress if kind == "press" else QtCore.QEvent.Type.KeyRelease
    event = QtGui.QKeyEvent(event_type, SPACE, QtCore.Qt.KeyboardModifier.NoModifier, " ", autorepeat)
    event.setTimestamp(stamp)
    QtWidgets.QApplication.sendEvent(widget, event)


def test_a_short_key_press_acts_on_release_and_keys_that_are_no_switch_are_left_alone(rig, qtbot):
    r = rig(AssistSettings(mode="scan2"))
    qtbot.keyClick(r.target, SPACE)  # synthetic: no timestamp, the release acts at once
    assert r.presses == ["next"] and r.releases == [("next", False)] and r.holds == []
    qtbot.keyClick(r.target, QtCore.Qt.Key.Key_A)
    assert r.presses == ["next"]
    r.settings = AssistSettings(mode="touch")  # no switches in touch mode
    qtbot.keyClick(r.target, SPACE)
    assert r.presses == ["next"]


def test_a_key_held_through_x11_auto_repeat_stops_once_and_its_real_release_waits_for_the_timer(rig, qtbot):
    r = rig(AssistSettings(mode="scan1"))
    stamp = 50_000
    send_key(r.target, "press", stamp)
    r.t += 0.66
    stamp += 660
    while r.t < 100.0 + 3.0:  # repeat pairs every 40 ms, some flagged by Qt, most not
        r.t += 0.04
        stamp += 40
        flagged = stamp % 160 == 0
        send_key(r.target, "release", stamp, autorepeat=flagged)
        send_key(r.target, "press", stamp, autorepeat=flagged)
        r.switches.tick(r.t)
    assert r.presses == ["single"] and r.releases == [] and r.holds == ["stop"]  # one hold, one action
    r.stopped = True
    send_key(r.target, "release", stamp + 30)  # the key really comes up: the window's timer ends the wait
    qtbot.waitUntil(lambda: r.switches.held is None, timeout=5_000)
    assert r.releases == [("single", True)]  # held long: the release does nothing else
    send_key(r.target, "press", stamp + 2_000)  # held again while stopped: re-arm
    r.t += 1.6
    r.switches.tick(r.t)
    assert r.holds == ["stop", "rearm"]


def test_a_real_release_acts_before_the_next_press(rig, qtbot):
    r = rig(AssistSettings(mode="scan2"))
    send_key(r.target, "press", 1_000)
    send_key(r.target, "release", 1_100)  # kept: it may be half of a repeat pair …
    assert r.releases == [] and r.switches.held is not None
    send_key(r.target, "press", 1_400)  # … another timestamp: it was a real release
    assert r.releases == [("next", False)] and r.presses == ["next", "next"]
    send_key(r.target, "release", 1_500)
    qtbot.waitUntil(lambda: len(r.releases) == 2, timeout=5_000)


def test_a_gpio_switch_presses_from_its_thread_and_its_source_is_stopped(rig, qtbot, monkeypatch):
    from tests.devices.test_switch_sources import FakeButton, fake_gpiozero

    monkeypatch.setitem(sys.modules, "gpiozero", fake_gpiozero())
    settings = AssistSettings(mode="scan1", single_switch=("gpio:17",))
    r = rig(settings)
    r.switches.start_sources(settings)
    source = r.switches.sources["gpio:17"]
    assert source.wait_for(lambda s: s.connected)
    button = FakeButton.instances[0]
    button.when_pressed()  # from gpiozero's thread in real life: queued to the GUI thread
    qtbot.waitUntil(lambda: r.presses == ["single"], timeout=5_000)
    r.t += 0.15
    button.when_released()
    qtbot.waitUntil(lambda: r.releases == [("single", False)], timeout=5_000)
    r.switches.start_sources(AssistSettings(mode="scan1"))  # no device switch left: its source stops
    assert r.switches.sources == {} and button.closed


def test_a_missing_switch_library_is_a_message(rig, monkeypatch):
    monkeypatch.setitem(sys.modules, "gpiozero", None)
    settings = AssistSettings(mode="scan1", single_switch=("key:Space", "gpio:17"))
    r = rig(settings)
    r.switches.start_sources(settings)
    assert r.switches.sources["gpio:17"].wait_for(lambda s: "pip install gpiozero" in s.status_message)
    assert any("pip install gpiozero" in m for m in r.switches.source_messages())
