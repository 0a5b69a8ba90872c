"""Gamepad (evdev) and GPIO (gpiozero) switch sources against fake modules injected into sys.modules:
press/release reach the handler; a missing library or device gives a message naming the fix."""
import queue
import sys
import types

import pytest

from core.devices.switches import (GamepadSwitch, GpioSwitch, is_device_switch_name, make_switch_source,
                                   parse_switch_spec)

EV_KEY, BTN_SOUTH, BTN_EAST = 1, 304, 305


class FakeEvent:
    def __init__(self, code, value, type_=EV_KEY):
        self.type, self.code, self.value = type_, code, value


class FakeInputDevice:
    def __init__(self, module, path):
        self.module, self.path = module, path
        self.events = module.events

    def capabilities(self):
        return {EV_KEY: [BTN_SOUTH, BTN_EAST]}

    def read_one(self):
        if self.module.unplugged:
            raise OSError(19, "No such device")
        try:
            return self.events.get_nowait()
        except queue.Empty:
            return None

    def close(self):
        pass


def fake_evdev(devices=("/dev/input/event7",)):
    m = types.ModuleType("evdev")
    m.events, m.unplugged = queue.SimpleQueue(), False
    m.ecodes = types.SimpleNamespace(EV_KEY=EV_KEY, BTN_SOUTH=BTN_SOUTH, BTN_EAST=BTN_EAST)
    m.list_devices = lambda: list(devices)
    m.InputDevice = lambda path: FakeInputDevice(m, path)
    return m


class FakeButton:
    instances = []

    def __init__(self, pin, pull_up=True, bounce_time=None):
        self.pin, self.closed = pin, False
        self.when_pressed = self.when_released = None
        FakeButton.instances.append(self)

    def close(self):
        self.closed = True


def fake_gpiozero():
    m = types.ModuleType("gpiozero")
    FakeButton.instances = []
    m.Button = FakeButton
    return m


def collect():
    got = queue.SimpleQueue()
    return got, lambda name, pressed: got.put((name, pressed))


def test_a_gamepad_button_reports_press_and_release_and_ignores_other_buttons(monkeypatch):
    evdev = fake_evdev()
    monkeypatch.setitem(sys.modules, "evdev", evdev)
    got, handler = collect()
    source = GamepadSwitch("gamepad:BTN_SOUTH", handler, retry_interval_s=0.05)
    source.start()
    try:
        assert source.wait_for(lambda s: s.connected)
        for event in (FakeEvent(BTN_EAST, 1), FakeEvent(BTN_SOUTH, 1), FakeEvent(BTN_SOUTH, 2),
                      FakeEvent(BTN_SOUTH, 0)):
            evdev.events.put(event)
        assert got.get(timeout=5) == ("gamepad:BTN_SOUTH", True)
        assert got.get(timeout=5) == ("gamepad:BTN_SOUTH", False)
        evdev.unplugged = True
        assert source.wait_for(lambda s: "unplugged" in s.status_message)
    finally:
        source.stop()
    assert got.empty()


def test_a_gpio_pin_reports_press_and_release(monkeypatch):
    monkeypatch.setitem(sys.modules, "gpiozero", fake_gpiozero())
    got, handler = collect()
    source = GpioSwitch("gpio:17", handler)
    source.start()
    try:
        assert source.wait_for(lambda s: s.connected)
        button = FakeButton.instances[0]
        assert button.pin == 17
        button.when_pressed()
        button.when_released()
        assert [got.get(timeout=5), got.get(timeout=5)] == [("gpio:17", True), ("gpio:17", False)]
    finally:
        source.stop()
    assert button.closed


@pytest.mark.parametrize("name, module, fix", [("gamepad:BTN_SOUTH", "evdev", "pip install evdev"),
                                               ("gpio:17", "gpiozero", "pip install gpiozero")])
def test_a_missing_library_gives_a_message_naming_the_fix(monkeypatch, name, module, fix):
    monkeypatch.setitem(sys.modules, module, None)  # import raises ImportError
    source = make_switch_source(name, lambda *a: None, retry_interval_s=0.05)
    source.start()
    try:
        assert source.wait_for(lambda s: fix in s.status_message)
        assert not source.connected
    finally:
        source.stop()


def test_no_gamepad_names_the_input_group(monkeypatch):
    monkeypatch.setitem(sys.modules, "evdev", fake_evdev(devices=()))
    source = GamepadSwitch("gamepad:BTN_SOUTH", lambda *a: None, retry_interval_s=0.05)
    source.start()
    try:
        assert source.wait_for(lambda s: "`input` group" in s.status_message)
    finally:
        source.stop()


def test_switch_specs():
    spec = parse_switch_spec("gamepad:BTN_SOUTH=confirm")
    assert (spec.name, spec.role) == ("gamepad:BTN_SOUTH", "confirm")
    assert parse_switch_spec("gpio:17=single").role == "single"
    for bad in ("gpio:17", "gpio:99=single", "gamepad:A=next", "gpio:17=press"):
        with pytest.raises(ValueError):
            parse_switch_spec(bad)
    assert is_device_switch_name("gamepad:304") and not is_device_switch_name("key:Space")
