"""The window's physical STOP and RE-ARM (app.estop_switches): real key events (auto-repeat included)
through the application filter, and fake gpiozero / evdev devices read in their own threads.
The hold runs on an injected clock; the tests wait for the controller's own timer (waitUntil)."""
import sys
import threading

import pytest
from PySide6 import QtCore, QtGui, QtWidgets
from PySide6.QtTest import QTest

from app.estop_switches import EStopSwitches, check_estop_switch_names
from core.motion.estop_switches import REARM_HOLD_S
from tests.devices.test_switch_sources import (BTN_EAST, BTN_SOUTH, FakeButton, FakeEvent, FakeInputDevice,
                                               fake_evdev, fake_gpiozero)
from widgets.estop import REARM_HOLD_MS

F12, F9, A = QtCore.Qt.Key.Key_F12, QtCore.Qt.Key.Key_F9, QtCore.Qt.Key.Key_A
TIMEOUT_MS = 5000


class Clock:
    """Seconds that move only when the test says so."""

    def __init__(self, t=100.0):
        self.t = t

    def __call__(self):
        return self.t


class Arm:
    """What the window's on_stop_requested / on_rearm_requested / controller.armed do."""

    def __init__(self):
        self.armed, self.calls = True, []

    def stop(self):
        self.calls.append("stop")
        self.armed = False

    def rearm(self):
        self.calls.append("rearm")
        self.armed = True


@pytest.fixture
def rig(qtbot):
    """A bare window with a focused text field, an arm, a clock and a factory of EStopSwitches
    (started; stopped after the test, their device threads joined)."""
    widget = QtWidgets.QWidget()
    field = QtWidgets.QLineEdit(widget)
    qtbot.addWidget(widget)
    widget.show()
    field.setFocus()
    arm, clock, made = Arm(), Clock(), []

    def make(stop=(), rearm=(), retry_interval_s=0.05):
        e = EStopSwitches(widget, stop, rearm, stop=arm.stop, rearm=arm.rearm, armed=lambda: arm.armed,
                          clock=clock, retry_interval_s=retry_interval_s)
        made.append(e)
        e.start()
        return e

    yield widget, field, arm, clock, make
    for e in made:
        threads = [s._thread for s in e.sources.values() if s._thread is not None]
        e.stop()
        assert not any(t.is_alive() for t in threads)


def send_key(widget, kind, key, clock, auto=False):
    """A key event stamped (ms) with the test's clock, through the application as X11 delivers one."""
    event = QtGui.QKeyEvent(kind, key, QtCore.Qt.KeyboardModifier.NoModifier, "", auto)
    event.setTimestamp(int(round(clock.t * 1000)))
    QtWidgets.QApplication.sendEvent(widget, event)


def press(widget, key, clock):
    send_key(widget, QtCore.QEvent.Type.KeyPress, key, clock)


def release(widget, key, clock):
    send_key(widget, QtCore.QEvent.Type.KeyRelease, key, clock)


def auto_repeat(widget, key, clock, flagged=True):
    """What a held key sends now and then: a release and a press with one timestamp — flagged as
    auto-repeat by Qt, or not (X11 under Xvfb: none of them was flagged)."""
    for kind in (QtCore.QEvent.Type.KeyRelease, QtCore.QEvent.Type.KeyPress):
        send_key(widget, kind, key, clock, auto=flagged)


def tap_stop_key(qtbot, field, e):
    """F12 pressed and released; its release counts once no auto-repeat press followed it."""
    QTest.keyClick(field, F12)
    qtbot.waitUntil(lambda: e.status_text().startswith("STOP switch key:F12: ready"), timeout=TIMEOUT_MS)


def ticks(qtbot, e, n=2):
    """Wait until the controller's own timer has run ``n`` more times."""
    count = []
    e.poll_timer.timeout.connect(lambda: count.append(1))
    qtbot.waitUntil(lambda: len(count) >= n, timeout=TIMEOUT_MS)


def test_the_hold_is_the_on_screen_rearm_hold():
    assert REARM_HOLD_S == REARM_HOLD_MS / 1000


# -- keys ------------------------------------------------------------------------------------------

def test_a_stop_key_stops_before_any_widget_and_while_held_nothing_rearms(qtbot, rig):
    widget, field, arm, clock, make = rig
    e = make(stop=["key:F12"], rearm=["key:F9"])
    assert e.status_text() == "STOP switch key:F12: ready · RE-ARM switch key:F9: ready"
    QTest.keyPress(field, F12)
    assert arm.calls == ["stop"] and field.text() == ""  # taken before the text field
    for _ in range(3):  # held: auto-repeat is not a release, nor a new press
        clock.t += 0.04
        auto_repeat(field, F12, clock, flagged=False)
    assert arm.calls == ["stop"] and "held down" in e.status_text() and e.rearm_blocked()
    clock.t += 1
    press(field, F9, clock)  # RE-ARM pressed while STOP is latched down
    clock.t += 10 * REARM_HOLD_S
    ticks(qtbot, e)
    assert arm.calls == ["stop"] and "a STOP switch is down" in e.status_text()
    QTest.keyRelease(field, F12)
    qtbot.waitUntil(lambda: "held since before the stop" in e.status_text(), timeout=TIMEOUT_MS)
    clock.t += 10 * REARM_HOLD_S  # F9 still held since before STOP was released: never
    ticks(qtbot, e)
    assert arm.calls == ["stop"]
    release(field, F9, clock)
    clock.t += 1
    press(field, F9, clock)  # fresh
    clock.t += REARM_HOLD_S / 2
    ticks(qtbot, e)
    assert arm.calls == ["stop"] and "keep holding (0.5 of 1 s)" in e.status_text()
    clock.t += REARM_HOLD_S / 2
    qtbot.waitUntil(lambda: arm.calls == ["stop", "rearm"], timeout=TIMEOUT_MS)
    release(field, F9, clock)
    QTest.keyClick(field, A)
    assert field.text() == "a"  # other keys are left alone


@pytest.mark.parametrize("flagged", [True, False], ids=["flagged", "x11-unflagged"])
def test_key_auto_repeat_counts_as_held_and_a_bounce_restarts_the_hold(qtbot, rig, flagged):
    widget, field, arm, clock, make = rig
    e = make(stop=["key:F12"], rearm=["key:F9"])
    tap_stop_key(qtbot, field, e)
    clock.t += 1
    press(field, F9, clock)
    pressed_at = clock.t
    clock.t += 0.66
    while clock.t < pressed_at + 0.98:  # held, repeating every 40 ms after 660 ms (as X11 does)
        auto_repeat(field, F9, clock, flagged)
        clock.t += 0.04
    ticks(qtbot, e)
    assert arm.calls == ["stop"] and "keep holding" in e.status_text()
    clock.t = pressed_at + REARM_HOLD_S
    qtbot.waitUntil(lambda: arm.calls == ["stop", "rearm"], timeout=TIMEOUT_MS)
    release(field, F9, clock)

    clock.t += 1
    press(field, F12, clock)
    clock.t += 0.1
    release(field, F12, clock)
    qtbot.waitUntil(lambda: e.status_text().startswith("STOP switch key:F12: ready"), timeout=TIMEOUT_MS)
    clock.t += 1
    press(field, F9, clock)
    clock.t += 0.8
    release(field, F9, clock)  # a bounce: released, pressed again 10 ms later
    clock.t += 0.01
    press(field, F9, clock)
    bounced_at = clock.t
    clock.t += 0.5  # 1.31 s since the first press, 0.5 s since the bounce
    ticks(qtbot, e, n=4)
    assert arm.calls == ["stop", "rearm", "stop"]
    clock.t = bounced_at + REARM_HOLD_S
    qtbot.waitUntil(lambda: arm.calls == ["stop", "rearm", "stop", "rearm"], timeout=TIMEOUT_MS)


def test_a_release_just_before_the_hold_ends_is_not_missed(qtbot, rig):
    widget, field, arm, clock, make = rig
    e = make(stop=["key:F12"], rearm=["key:F9"])
    tap_stop_key(qtbot, field, e)
    clock.t += 1
    press(field, F9, clock)
    clock.t += REARM_HOLD_S - 0.01
    release(field, F9, clock)  # let go 10 ms early …
    clock.t += 0.02  # … and the clock passes the full hold before the release is known to be real
    qtbot.waitUntil(lambda: e.status_text().endswith("key:F9: ready"), timeout=TIMEOUT_MS)
    ticks(qtbot, e)
    assert arm.calls == ["stop"]


def test_a_key_known_only_from_its_auto_repeat_was_held_before_and_never_rearms(qtbot, rig):
    widget, field, arm, clock, make = rig
    e = make(stop=["key:F12"], rearm=["key:F9"])
    tap_stop_key(qtbot, field, e)
    clock.t += 1
    for _ in range(2):  # the press went to another window: held since when?
        auto_repeat(field, F9, clock)
        clock.t += 0.04
    clock.t += 10 * REARM_HOLD_S
    ticks(qtbot, e)
    assert arm.calls == ["stop"] and "held since before the stop" in e.status_text()


def test_escape_as_a_stop_key_still_stops_and_the_window_shortcut_does_not_fire_twice(qtbot, rig):
    widget, field, arm, clock, make = rig
    shortcut_hits = []
    shortcut = QtGui.QShortcut(QtGui.QKeySequence(QtCore.Qt.Key.Key_Escape), widget)
    shortcut.setContext(QtCore.Qt.ShortcutContext.ApplicationShortcut)
    shortcut.activated.connect(lambda: shortcut_hits.append(1))
    make(stop=["key:Escape"], rearm=["key:F9"])
    QTest.keyClick(field, QtCore.Qt.Key.Key_Escape)
    assert arm.calls == ["stop"] and shortcut_hits == []


def test_a_screen_rearm_while_a_stop_switch_is_held_is_stopped_at_once(qtbot, rig):
    widget, field, arm, clock, make = rig
    e = make(stop=["key:F12"], rearm=["key:F9"])
    QTest.keyPress(field, F12)
    assert e.rearm_blocked() == "STOP switch key:F12 is down — release it to re-arm"
    arm.armed = True  # a window that re-armed anyway (the on-screen RE-ARM)
    qtbot.waitUntil(lambda: arm.calls == ["stop", "stop"] and not arm.armed, timeout=TIMEOUT_MS)
    QTest.keyRelease(field, F12)
    qtbot.waitUntil(lambda: e.rearm_blocked() == "", timeout=TIMEOUT_MS)


def test_a_stop_from_the_screen_during_a_hold_cancels_it(qtbot, rig):
    widget, field, arm, clock, make = rig
    e = make(stop=["key:F12"], rearm=["key:F9"])
    tap_stop_key(qtbot, field, e)
    clock.t += 1
    press(field, F9, clock)
    clock.t += 0.5
    e.note_stop()  # the STOP button tapped again
    clock.t += 10 * REARM_HOLD_S
    ticks(qtbot, e)
    assert arm.calls == ["stop"] and "held since before the stop" in e.status_text()


# -- gamepad and GPIO switches (fake evdev / gpiozero, in their own threads) ---------------------------

class FakeGamepadWithHeldKeys(FakeInputDevice):
    held = []

    def active_keys(self):
        return list(self.held)


def gamepad_module(held=()):
    evdev = fake_evdev()
    FakeGamepadWithHeldKeys.held = list(held)
    evdev.InputDevice = lambda path: FakeGamepadWithHeldKeys(evdev, path)
    return evdev


def from_another_thread(fn):
    thread = threading.Thread(target=fn)
    thread.start()
    thread.join()


def test_a_gpio_stop_and_a_gamepad_rearm(qtbot, rig, monkeypatch):
    widget, field, arm, clock, make = rig
    evdev = gamepad_module()
    monkeypatch.setitem(sys.modules, "evdev", evdev)
    monkeypatch.setitem(sys.modules, "gpiozero", fake_gpiozero())
    e = make(stop=["gpio:17"], rearm=["gamepad:BTN_EAST"])
    qtbot.waitUntil(lambda: e.status_text() == "STOP switch gpio:17: ready · RE-ARM switch gamepad:BTN_EAST: ready",
                    timeout=TIMEOUT_MS)
    button = FakeButton.instances[0]
    assert button.pin == 17
    from_another_thread(button.when_pressed)  # gpiozero calls back from its own thread
    qtbot.waitUntil(lambda: arm.calls == ["stop"], timeout=TIMEOUT_MS)
    clock.t += 1
    evdev.events.put(FakeEvent(BTN_EAST, 1))  # RE-ARM while the STOP pin is still down
    qtbot.waitUntil(lambda: "a STOP switch is down" in e.status_text(), timeout=TIMEOUT_MS)
    clock.t += 10 * REARM_HOLD_S
    ticks(qtbot, e)
    assert arm.calls == ["stop"]
    from_another_thread(button.when_released)
    qtbot.waitUntil(lambda: "held since before the stop" in e.status_text(), timeout=TIMEOUT_MS)
    clock.t += 10 * REARM_HOLD_S
    ticks(qtbot, e)
    assert arm.calls == ["stop"]
    evdev.events.put(FakeEvent(BTN_EAST, 0))
    clock.t += 1
    evdev.events.put(FakeEvent(BTN_EAST, 1))
    qtbot.waitUntil(lambda: "keep holding" in e.status_text(), timeout=TIMEOUT_MS)
    clock.t += REARM_HOLD_S
    qtbot.waitUntil(lambda: arm.calls == ["stop", "rearm"], timeout=TIMEOUT_MS)
    threads = [s._thread for s in e.sources.values()]
    assert len(threads) == 2 and all(t.is_alive() for t in threads)
    e.stop()
    assert not any(t.is_alive() for t in threads) and e.sources == {} and button.closed


def test_a_latched_gpio_stop_found_at_start_stops_and_blocks(qtbot, rig, monkeypatch):
    widget, field, arm, clock, make = rig
    gpiozero = fake_gpiozero()

    class LatchedButton(FakeButton):
        is_pressed = True

    gpiozero.Button = LatchedButton
    monkeypatch.setitem(sys.modules, "gpiozero", gpiozero)
    e = make(stop=["gpio:17"], rearm=["key:F9"])
    qtbot.waitUntil(lambda: arm.calls == ["stop"], timeout=TIMEOUT_MS)
    assert "held down" in e.status_text() and e.rearm_blocked()
    clock.t += 1
    press(field, F9, clock)
    clock.t += 10 * REARM_HOLD_S
    ticks(qtbot, e)
    assert arm.calls == ["stop"]


def test_a_rearm_button_found_down_or_unplugged_mid_hold_never_rearms(qtbot, rig, monkeypatch):
    widget, field, arm, clock, make = rig
    evdev = gamepad_module(held=[BTN_EAST])  # the foot is on the pedal when the gamepad appears
    monkeypatch.setitem(sys.modules, "evdev", evdev)
    e = make(stop=["key:F12"], rearm=["gamepad:BTN_EAST"])
    tap_stop_key(qtbot, field, e)
    qtbot.waitUntil(lambda: "held since before the stop" in e.status_text(), timeout=TIMEOUT_MS)
    clock.t += 10 * REARM_HOLD_S
    ticks(qtbot, e)
    assert arm.calls == ["stop"]
    evdev.events.put(FakeEvent(BTN_EAST, 0))
    qtbot.waitUntil(lambda: e.status_text().endswith("gamepad:BTN_EAST: ready"), timeout=TIMEOUT_MS)
    clock.t += 1
    evdev.events.put(FakeEvent(BTN_EAST, 1))  # a fresh press …
    qtbot.waitUntil(lambda: "keep holding" in e.status_text(), timeout=TIMEOUT_MS)
    evdev.unplugged = True  # … and the gamepad is pulled out mid-hold (no release ever comes)
    evdev.list_devices = lambda: []
    qtbot.waitUntil(lambda: "not found — plug it in (retrying)" in e.status_text(), timeout=TIMEOUT_MS)
    clock.t += 10 * REARM_HOLD_S
    ticks(qtbot, e)
    assert arm.calls == ["stop"] and e.status_level() == "error"


def test_a_missing_device_is_a_visible_state_until_it_is_plugged_in(qtbot, rig, monkeypatch):
    widget, field, arm, clock, make = rig
    evdev = fake_evdev(devices=())
    monkeypatch.setitem(sys.modules, "evdev", evdev)
    monkeypatch.setitem(sys.modules, "gpiozero", None)  # not installed
    e = make(stop=["gamepad:BTN_SOUTH", "gpio:17"])
    label = e.make_status_label()
    qtbot.addWidget(label)
    label.show()
    qtbot.waitUntil(lambda: "gpio:17: its library" in e.status_text(), timeout=TIMEOUT_MS)
    assert e.status_text() == ("STOP switch gamepad:BTN_SOUTH: not found — plug it in (retrying) · STOP switch "
                               "gpio:17: its library is missing — pip install gpiozero (on a Raspberry Pi)")
    assert e.status_level() == "error" and label.text() == e.status_text() and label.isVisible()
    assert "`input` group" in label.toolTip()  # the device's own message: how to fix it
    evdev.list_devices = lambda: ["/dev/input/event7"]  # plugged in
    qtbot.waitUntil(lambda: e.status_text().startswith("STOP switch gamepad:BTN_SOUTH: ready"), timeout=TIMEOUT_MS)
    evdev.events.put(FakeEvent(BTN_SOUTH, 1))
    qtbot.waitUntil(lambda: arm.calls == ["stop"], timeout=TIMEOUT_MS)


def test_no_switches_no_threads_no_filter_no_status(qtbot, rig):
    widget, field, arm, clock, make = rig
    e = make()
    assert not e.enabled and not e.running and e.status_text() == ""
    label = e.make_status_label()
    qtbot.addWidget(label)
    assert label.isHidden()
    QTest.keyClick(field, F12)
    assert arm.calls == []


# -- names and the command line ---------------------------------------------------------------------

def test_switch_names_are_canonical_and_a_switch_is_never_both_stop_and_rearm():
    assert check_estop_switch_names(["key:escape", "gpio:017", "gpio:17"], ["gamepad:BTN_EAST", "key:F9"]) == (
        ("key:Esc", "gpio:17"), ("gamepad:BTN_EAST", "key:F9"))
    with pytest.raises(ValueError, match="--rearm-switch key:Esc: it is also a STOP switch"):
        check_estop_switch_names(["key:Escape"], ["key:Esc"])
    for bad in ("gpio:99", "mouse:left", "key:Ctrl+A", "key:NoSuchKey", "F12", "gamepad:A"):
        with pytest.raises(ValueError, match="not a switch — use gamepad:BTN_"):
            check_estop_switch_names([bad])


def test_the_cli_refuses_the_same_switch_twice_and_runs_without_a_window(capsys):
    from app.cli import main

    assert main(["--estop-switch", "gpio:17", "--rearm-switch", "gpio:17"]) == 2
    assert "--rearm-switch gpio:17: it is also a STOP switch" in capsys.readouterr().err
    assert main(["--estop-switch", "gpio:99"]) == 2
    assert "not a switch" in capsys.readouterr().err
    assert main(["--headless", "--estop-switch", "gpio:17"]) == 2
    assert "leave out --headless" in capsys.readouterr().err
    assert main(["--assist", "--estop-switch", "gpio:17"]) == 2
    assert "main window's" in capsys.readouterr().err


def test_the_cli_carries_the_switches_to_the_window(monkeypatch):
    import app.cli
    import app.gui
    import app.startup

    seen = {}

    def run_window(options, size, splash=None):
        seen["options"] = options
        return 0

    monkeypatch.setattr(app.startup, "show_splash", lambda: None)
    monkeypatch.setattr(app.gui, "run_window", run_window)
    assert app.cli.main(["--camera", "sim", "--estop-switch", "gpio:17", "--estop-switch", "key:escape",
                         "--rearm-switch", "gamepad:BTN_EAST"]) == 0
    assert seen["options"].estop_switches == ("gpio:17", "key:Esc")
    assert seen["options"].rearm_switches == ("gamepad:BTN_EAST",)


# -- the main window, wired as app/gui.py is asked to -------------------------------------------------

def test_the_main_window_stops_and_rearms_from_its_switches(qtbot):
    from app.gui import MainWindow
    from core.session import DeskSession, SessionOptions

    options = SessionOptions(camera="sim", scenario="static", estop_switches=("key:F12",), rearm_switches=("key:F9",))
    w = MainWindow(DeskSession.create(options))
    qtbot.addWidget(w)
    w.resize(800, 480)
    w.show()
    clock = Clock()
    e = EStopSwitches.for_window(w, clock=clock)
    e.start()
    try:
        label = e.make_status_label()
        w.statusBar().addPermanentWidget(label)
        assert label.text() == "STOP switch key:F12: ready · RE-ARM switch key:F9: ready"
        QTest.keyClick(w, F12)
        assert not w.session.controller.armed and w.estop_button.engaged
        qtbot.waitUntil(lambda: label.text().startswith("STOP switch key:F12: ready"), timeout=TIMEOUT_MS)
        clock.t += 1
        press(w, F9, clock)
        clock.t += REARM_HOLD_S
        qtbot.waitUntil(lambda: w.session.controller.armed, timeout=TIMEOUT_MS)
        assert not w.estop_button.engaged
        release(w, F9, clock)
        w.on_stop_requested()  # the on-screen STOP: noticed by the switches' timer
        qtbot.waitUntil(lambda: not e.logic.armed, timeout=TIMEOUT_MS)
    finally:
        e.stop()
        w.stop()
