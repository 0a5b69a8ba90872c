"""Devices: motor bridges (simulated arm, serial v1/v2, Phidget servo boards, the UMI-RTX
controller), their protocols and the serial ports.

``open_bridge(url, profile)`` is the front door: it parses the URL (``core.devices.bridge``)
and imports only the implementation it hands out.
"""
from __future__ import annotations

from core.devices.bridge import (
    BRIDGE_CHOICES,
    BridgeError,
    MotorBridge,
    parse_bridge_url,
    split_bridge_url,
)


def open_bridge(url: str, profile, clock=None) -> "MotorBridge":
    """The bridge named by ``url`` (not yet connected)."""
    protocol, port = split_bridge_url(url)
    if protocol == "sim":
        from core.devices.sim_arm import SimServoArm

        return SimServoArm(profile, clock=clock)
    if protocol == "v2":
        from core.devices.serial_v2 import SerialV2Bridge

        return SerialV2Bridge(url, profile, clock=clock)
    if protocol == "rtx":
        from core.devices.rtx_bridge import RtxBridge

        return RtxBridge(url, profile, clock=clock)
    if protocol == "phidget":
        from core.devices.phidget import PhidgetServoBridge  # imports Phidget22 only on connect()

        return PhidgetServoBridge(port, profile, clock=clock)
    from core.devices.serial_v1 import SerialV1Bridge

    return SerialV1Bridge(port, profile, clock=clock)


__all__ = ["open_bridge", "parse_bridge_url", "split_bridge_url", "BRIDGE_CHOICES", "BridgeError", "MotorBridge"]
