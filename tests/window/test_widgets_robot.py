"""E-stop button and bridge picker (pytest-qt, offscreen)."""
from widgets.bridge_picker import BridgePicker, bridge_url
from widgets.estop import EStopButton


def test_estop_button_stops_then_rearms(qtbot):
    b = EStopButton()
    qtbot.addWidget(b)
    with qtbot.waitSignal(b.sigEstopChanged, check_params_cb=lambda engaged: engaged):
        b.click()
    assert b.text() == "RE-ARM"
    b.engage()  # a second stop request does not re-arm
    assert b.engaged
    with qtbot.waitSignal(b.sigEstopChanged, check_params_cb=lambda engaged: not engaged):
        b.click()
    assert b.text() == "STOP" and b.height() >= 44 or b.minimumSizeHint().height() >= 44


def test_bridge_urls():
    assert bridge_url("v2", "/dev/ttyACM0") == "v2:/dev/ttyACM0"
    assert bridge_url("v1", "/dev/ttyUSB0") == "v1:/dev/ttyUSB0"
    assert bridge_url("v1", "loop://") == "loop://"
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
    p = BridgePicker(lambda: [])
    qtbot.addWidget(p)
    with qtbot.assertNotEmitted(p.sigConnectRequested):
        p.connect_button.click()
    assert "port" in p.status_label.text()
