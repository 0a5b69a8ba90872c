"""The emulated RTX counts as a simulated arm (the simulated desk may stand in for missing
cameras); a real RTX port does not. The device panel offers the RTX protocol."""
from __future__ import annotations

import pytest

from core.devices.bridge import is_simulated_bridge


@pytest.mark.parametrize("url, simulated", [
    ("sim://", True), ("sim", True), ("rtx:sim", True), ("rtx:sim?speedup=10", True),
    ("rtx:/dev/ttyUSB0", False), ("rtx:/dev/ttyUSB0?init=auto", False), ("v2:/dev/ttyACM0", False),
    ("/dev/ttyACM0", False), ("phidget://", False),
])
def test_which_bridges_are_simulated(url, simulated):
    assert is_simulated_bridge(url) is simulated


def test_the_device_panel_builds_rtx_urls():
    from widgets.bridge_picker import PROTOCOLS, bridge_url

    assert "rtx" in [key for key, _ in PROTOCOLS]
    assert bridge_url("rtx", "/dev/ttyUSB0") == "rtx:/dev/ttyUSB0"
    assert bridge_url("rtx", "rtx:sim") == "rtx:sim"


def test_a_session_on_the_emulated_rtx_sees_the_simulated_desk_without_camera_sim():
    from core.session import DeskSession, SessionOptions

    session = DeskSession.create(SessionOptions(camera="auto", robot="umi_rtx", bridge="rtx:sim",
                                                scenario="static"))
    try:
        assert session.is_simulated_camera  # no webcam here: the simulated desk stands in
        assert session.real_arm_refusal("rtx:sim") == "" and session.real_arm_refusal("rtx:/dev/ttyUSB0") != ""
    finally:
        session.close()
