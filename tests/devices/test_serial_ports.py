"""The port picker's list and typed-path check, with a faked comports() and fake by-id links."""
from __future__ import annotations

import os

import pytest
from serial.tools import list_ports as lp
from serial.tools.list_ports_common import ListPortInfo

from core.devices.ports import PortInfo, list_ports, preferred_name, validate_typed_path


def fake_port(device, description="n/a", vid=None, pid=None, serial_number=None, manufacturer=None,
              interface=None) -> ListPortInfo:
    info = ListPortInfo(device, skip_link_detection=True)
    info.description, info.vid, info.pid = description, vid, pid
    info.serial_number, info.manufacturer, info.interface = serial_number, manufacturer, interface
    return info


@pytest.fixture
def dev(tmp_path):
    """A fake /dev: device nodes are plain files here (list_ports only resolves links)."""
    d = tmp_path / "dev"
    d.mkdir()
    for name in ("ttyS0", "ttyUSB0", "ttyACM0", "ttyACM1", "ttyACM10", "ttyACM2", "ttyUSB1"):
        (d / name).write_text("")
    by_id = d / "serial" / "by-id"
    by_id.mkdir(parents=True)
    os.symlink("../../ttyACM1", by_id / "usb-Texas_Instruments_MSP_Tools_Driver_1A2B3C4D-if02")
    os.symlink("../../ttyACM0", by_id / "usb-Texas_Instruments_MSP_Tools_Driver_1A2B3C4D-if00")
    os.symlink("../../ttyUSB0", by_id / "usb-FTDI_FT232R_USB_UART_A9XYZ-if00-port0")
    return d


@pytest.fixture
def ports(dev, monkeypatch):
    d = str(dev)
    fakes = [
        fake_port(f"{d}/ttyS0"),
        fake_port(f"{d}/ttyUSB1", "Some USB gadget", 0x1234, 0x0001),
        fake_port(f"{d}/ttyUSB0", "FT232R USB UART", 0x0403, 0x6001, "A9XYZ", "FTDI"),
        fake_port(f"{d}/ttyACM10", "Arduino Uno", 0x2341, 0x0043, "7563", "Arduino"),
        fake_port(f"{d}/ttyACM2", "USB2.0-Serial", 0x1A86, 0x7523),
        fake_port(f"{d}/ttyACM0", "MSP Tools Driver - MSP Debug Interface", 0x2047, 0x0013, "1A2B3C4D",
                  "Texas Instruments", "MSP Debug Interface"),
        fake_port(f"{d}/ttyACM1", "MSP Tools Driver - MSP Application UART1", 0x2047, 0x0013, "1A2B3C4D",
                  "Texas Instruments", "MSP Application UART1"),
    ]
    monkeypatch.setattr(lp, "comports", lambda *a, **k: list(fakes))
    return list_ports(by_id_dir=str(dev / "serial" / "by-id"))


def test_launchpad_uart_first_then_arduino_then_usb_serial_chips_then_the_rest(ports, dev):
    names = [os.path.basename(p.device) for p in ports]
    assert names == ["ttyACM1", "ttyACM0", "ttyACM10", "ttyACM2", "ttyUSB0", "ttyUSB1", "ttyS0"]


def test_each_port_carries_description_ids_serial_number_and_its_stable_link(ports, dev):
    uart = ports[0]
    assert uart.description == "MSP Tools Driver - MSP Application UART1"
    assert (uart.vid, uart.pid, uart.serial_number, uart.manufacturer) == (0x2047, 0x0013, "1A2B3C4D",
                                                                           "Texas Instruments")
    assert uart.stable_path == str(dev / "serial/by-id/usb-Texas_Instruments_MSP_Tools_Driver_1A2B3C4D-if02")
    assert preferred_name(uart) == uart.stable_path
    assert "2047:0013, SN 1A2B3C4D" in uart.label and uart.label.endswith(f"→ {uart.device}")


def test_a_port_without_a_by_id_link_is_named_by_its_device(ports):
    gadget = next(p for p in ports if p.device.endswith("ttyUSB1"))
    assert gadget.stable_path is None
    assert preferred_name(gadget) == gadget.device
    legacy = ports[-1]
    assert legacy.vid is None and legacy.label.endswith(legacy.device)


def test_no_by_id_folder_and_no_ports_give_an_empty_list(monkeypatch, tmp_path):
    monkeypatch.setattr(lp, "comports", lambda *a, **k: [])
    assert list_ports(by_id_dir=str(tmp_path / "missing")) == []


def test_a_broken_comports_does_not_break_the_picker(monkeypatch, tmp_path):
    def boom(*a, **k):
        raise OSError("sysfs went away")

    monkeypatch.setattr(lp, "comports", boom)
    assert list_ports(by_id_dir=str(tmp_path)) == []


def test_a_typed_pty_is_accepted_though_comports_never_lists_it():
    master, slave = os.openpty()
    try:
        path = os.ttyname(slave)
        assert validate_typed_path(f"  {path} ") == path
        assert validate_typed_path(f"v2:{path}") == f"v2:{path}"
    finally:
        os.close(master)
        os.close(slave)


def test_a_by_id_link_to_a_pty_is_accepted(tmp_path):
    master, slave = os.openpty()
    try:
        link = tmp_path / "usb-board-if00"
        os.symlink(os.ttyname(slave), link)
        assert validate_typed_path(str(link)) == str(link)
    finally:
        os.close(master)
        os.close(slave)


@pytest.mark.parametrize("text, expected", [
    ("COM3", "COM3"), ("com12", "COM12"), ("loop://", "loop://"),
    ("socket://192.168.1.20:7777", "socket://192.168.1.20:7777"), ("rfc2217://host:2217", "rfc2217://host:2217"),
])
def test_com_names_and_pyserial_urls_are_accepted(text, expected):
    assert validate_typed_path(text) == expected


@pytest.mark.parametrize("make, words", [
    (lambda d: "", "no port given"),
    (lambda d: str(d / "ttyNOPE0"), "no such port — is the board plugged in?"),
    (lambda d: str(d), "is a folder, not a serial port"),
    (lambda d: str(d / "ttyACM0"), "is a regular file, not a serial port"),
    (lambda d: "bluetooth://arm", "unknown URL scheme 'bluetooth://'"),
])
def test_bad_typed_paths_say_what_is_wrong(dev, make, words):
    with pytest.raises(ValueError, match=words):
        validate_typed_path(make(dev))


def test_a_dangling_link_says_the_device_is_gone(tmp_path):
    link = tmp_path / "usb-gone-if00"
    os.symlink(tmp_path / "ttyACM9", link)
    with pytest.raises(ValueError, match="device that is gone"):
        validate_typed_path(str(link))


def test_port_info_is_frozen():
    info = PortInfo("/dev/ttyACM0", None, "x", None, None, None, None)
    with pytest.raises(AttributeError):
        info.device = "/dev/ttyACM1"
