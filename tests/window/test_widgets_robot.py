"""E-stop button and bridge picker (pytest-qt, offscreen)."""
import pytest
from PySide6 import QtCore

from core.messages import BridgeStatus
from widgets._style import INFO_COLOUR, OK_COLOUR, TOUCH_PX, WARN_COLOUR
from widgets.bridge_picker import BridgePicker, bridge_url, same_bridge
from widgets.estop import EStopButton


def test_estop_button_stops_on_every_tap_and_never_rearms(qtbot):
    b = EStopButton()
    qtbot.addWidget(b)
    for _ in range(2):  # stopping twice is stopping
        with qtbot.waitSignal(b.sigStopRequested):
            b.click()
    b.set_engaged(True)
    assert b.text() == "STOPPED" and b.engaged
    with qtbot.waitSignal(b.sigStopRequested):
        b.click()
    assert b.engaged  # only the owner re-arms (RE-ARM button, held)
    b.set_engaged(False)
    assert b.text() == "STOP" and b.minimumSizeHint().height() >= TOUCH_PX


def test_bridge_urls():
    assert bridge_url("v2", "/dev/ttyACM0") == "v2:/dev/ttyACM0"
    assert bridge_url("v1", "/dev/ttyUSB0") == "v1:/dev/ttyUSB0"
    assert bridge_url("v1", "loop://") == "loop://"
    assert bridge_url("v2", "phidget://1234") == "phidget://1234"  # a Phidget board keeps its own URL
    assert bridge_url("sim", "whatever") == "sim://"


def test_picker_lists_ports_accepts_a_typed_path_and_emits_the_url(qtbot):
    p = BridgePicker(lambda: [("/dev/serial/by-id/usb-TI_LaunchPad — MSP430", "/dev/serial/by-id/usb-TI_LaunchPad")])
    qtbot.addWidget(p)
    assert p.port() == "/dev/serial/by-id/usb-TI_LaunchPad"
    p.port_combo.setEditText("/dev/pts/7")
    with qtbot.waitSignal(p.sigConnectRequested, check_params_cb=lambda url: url == "v2:/dev/pts/7"):
        p.connect_button.click()
    with qtbot.waitSignal(p.sigConnectRequested, check_params_cb=lambda url: url == "sim://"):
        p.sim_button.click()


def test_picker_without_a_port_says_so(qtbot):
    p = BridgePicker(list)
    qtbot.addWidget(p)
    with qtbot.assertNotEmitted(p.sigConnectRequested):
        p.connect_button.click()
    assert "port" in p.status_label.text()


LAUNCHPAD = ("/dev/serial/by-id/usb-TI_LaunchPad — MSP430", "/dev/serial/by-id/usb-TI_LaunchPad")


def combo_texts(combo):
    return [combo.itemText(i) for i in range(combo.count())]


def test_recent_ports_come_first_marked_recent_and_the_choice_is_kept(qtbot):
    p = BridgePicker(lambda: [LAUNCHPAD, ("/dev/ttyUSB0", "/dev/ttyUSB0")])
    qtbot.addWidget(p)
    p.set_recent_ports(["/dev/pts/5", "/dev/ttyUSB0", "/dev/pts/5"])
    assert combo_texts(p.port_combo) == ["/dev/pts/5 (recent)", "/dev/ttyUSB0 (recent)", LAUNCHPAD[0]]
    assert p.recent_ports() == ("/dev/pts/5", "/dev/ttyUSB0")
    assert p.port() == LAUNCHPAD[1]  # the choice made before stays chosen
    p.set_port("/dev/ttyUSB0")
    assert p.port() == "/dev/ttyUSB0" and p.port_combo.currentText() == "/dev/ttyUSB0 (recent)"
    p.refresh()
    assert p.port() == "/dev/ttyUSB0" and p.port_combo.count() == 3
    p.set_port("/dev/pts/9")  # not listed: typed
    assert p.port() == "/dev/pts/9"
    p.set_port("")
    assert p.port() == "/dev/pts/5"  # the first item
    with qtbot.waitSignal(p.sigConnectRequested, check_params_cb=lambda url: url == "v2:/dev/pts/5"):
        p.connect_button.click()


def test_the_system_s_ports_are_listed_once_at_start_up_and_again_on_refresh(qtbot):
    """Listing the ports scans the system's devices: the window's start-up (the picker, then the
    remembered recent ports) does it once; Refresh (a tap) lists them again, a new one included."""
    ports = [LAUNCHPAD]
    calls = []

    def list_ports():
        calls.append(1)
        return list(ports)

    p = BridgePicker(list_ports)
    qtbot.addWidget(p)
    p.set_recent_ports(["/dev/pts/5"])
    assert len(calls) == 1
    assert combo_texts(p.port_combo) == ["/dev/pts/5 (recent)", LAUNCHPAD[0]]
    ports.append(("/dev/ttyUSB0", "/dev/ttyUSB0"))
    qtbot.mouseClick(p.refresh_button, QtCore.Qt.MouseButton.LeftButton)
    assert len(calls) == 2
    assert combo_texts(p.port_combo) == ["/dev/pts/5 (recent)", LAUNCHPAD[0], "/dev/ttyUSB0"]


def test_protocol_getter_and_setter(qtbot):
    p = BridgePicker(lambda: [LAUNCHPAD])
    qtbot.addWidget(p)
    assert p.protocol() == "v2"
    assert p.set_protocol("v1") and p.protocol() == "v1"
    assert not p.set_protocol("sim") and p.protocol() == "v1"  # the Simulated arm button's
    with pytest.raises(ValueError, match="'v3'; allowed: sim, v2, v1"):
        p.set_protocol("v3")
    with qtbot.waitSignal(p.sigConnectRequested, check_params_cb=lambda url: url == f"v1:{LAUNCHPAD[1]}"):
        p.connect_button.click()


def test_status_colours_ok_neutral_and_warning(qtbot):
    p = BridgePicker(list)
    qtbot.addWidget(p)
    for ok, colour in ((True, OK_COLOUR), (None, INFO_COLOUR), (False, WARN_COLOUR)):
        p.set_status("sim://: connected <simulated arm>", ok)
        assert colour in p.status_label.text() and "&lt;simulated arm&gt;" in p.status_label.text()


def test_a_failed_switch_is_shown_in_the_warning_colour_not_green(qtbot):
    p = BridgePicker(list)
    qtbot.addWidget(p)
    p.show_bridge_status(BridgeStatus("sim://", True, "simulated arm"))
    assert OK_COLOUR in p.status_label.text()  # what the command line chose, before any request
    p.port_combo.setEditText("/dev/pts/7")
    with qtbot.waitSignal(p.sigConnectRequested):
        p.connect_button.click()
    assert INFO_COLOUR in p.status_label.text() and "connecting to v2:/dev/pts/7" in p.status_label.text()
    p.show_bridge_status(BridgeStatus("sim://", True, "simulated arm"))  # not switched yet
    assert INFO_COLOUR in p.status_label.text()
    p.show_bridge_status(BridgeStatus("sim://", True, "could not switch to v2:/dev/pts/7: no such port — "
                                                      "still on sim://"))
    assert WARN_COLOUR in p.status_label.text() and OK_COLOUR not in p.status_label.text()
    p.show_bridge_status(BridgeStatus("v2:/dev/pts/7", True, "protocol v2, 3 joints on the board"))
    assert OK_COLOUR in p.status_label.text()
    p.show_bridge_status(BridgeStatus("v2:/dev/pts/7", False, "unplugged — retrying in 1 s"))
    assert WARN_COLOUR in p.status_label.text()
    assert same_bridge("v1:/dev/ttyUSB0", "/dev/ttyUSB0") and not same_bridge("v1:/dev/x", "v2:/dev/x")


def test_drop_down_rows_are_finger_sized(qtbot):
    p = BridgePicker(lambda: [LAUNCHPAD])
    qtbot.addWidget(p)
    p.set_recent_ports(["/dev/pts/5"])
    p.show()
    for combo in (p.port_combo, p.protocol_combo):
        assert combo.height() >= TOUCH_PX
        assert combo.view().sizeHintForRow(0) >= TOUCH_PX
        combo.showPopup()
        qtbot.waitUntil(combo.view().isVisible)
        assert combo.view().visualRect(combo.model().index(0, 0)).height() >= TOUCH_PX
        combo.hidePopup()
