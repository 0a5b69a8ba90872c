"""Serial ports for the port picker: what is plugged in, with stable names, likely boards first.

``list_ports()`` wraps ``serial.tools.list_ports.comports()`` and adds, on Linux, the
``/dev/serial/by-id/…`` link of each port: that name stays the same across replugs and
reboots, while ``/dev/ttyACM0`` may become ``/dev/ttyACM1``. ``comports()`` lists no
pseudo-terminals (and no socket or loop URLs), so the picker must also accept a typed path:
``validate_typed_path`` checks one and says what is wrong in plain words.
"""
from __future__ import annotations

import importlib.util
import os
import re
import stat
from dataclasses import dataclass
from typing import Optional

from core.devices.bridge import SERIAL_URL_SCHEMES

BY_ID_DIR = "/dev/serial/by-id"

# USB vendor ids -> (rank, what it usually is); lower rank sorts first in the picker
KNOWN_VENDORS: dict[int, tuple[int, str]] = {
    0x2047: (0, "TI MSP430 LaunchPad (eZ-FET)"),  # the MSP-EXP430FR5969's debugger, 2047:0013
    0x0451: (0, "Texas Instruments LaunchPad"),  # older LaunchPads (e.g. 0451:F432) and XDS110
    0x2341: (1, "Arduino"),
    0x0403: (2, "FTDI USB-serial"),
    0x1A86: (2, "CH340 USB-serial"),
    0x10C4: (2, "CP210x USB-serial"),
}
RANK_OTHER_USB = 3  # some other USB device with a vendor id
RANK_NO_USB = 4  # built-in UARTs, Bluetooth: rarely the arm

URL_EXAMPLES = "/dev/ttyACM0, /dev/serial/by-id/…, COM3, loop://"


@dataclass(frozen=True)
class PortInfo:
    """One serial port as the picker shows it."""

    device: str  # what the OS calls it now, e.g. /dev/ttyACM0 or COM3
    stable_path: Optional[str]  # /dev/serial/by-id/… link to it (Linux, USB), else None
    description: str  # e.g. "MSP Tools Driver - MSP Application UART1"
    vid: Optional[int]  # USB vendor id
    pid: Optional[int]  # USB product id
    serial_number: Optional[str]  # USB serial number: tells two identical boards apart
    manufacturer: Optional[str]  # e.g. "Texas Instruments"
    interface: Optional[str] = None  # USB interface name, when the device has several

    @property
    def rank(self) -> int:
        """0 for TI LaunchPads, 1 Arduino, 2 common USB-serial chips, 3 other USB, 4 the rest."""
        if self.vid is None:
            return RANK_NO_USB
        return KNOWN_VENDORS.get(self.vid, (RANK_OTHER_USB, ""))[0]

    @property
    def is_debug_interface(self) -> bool:
        """True for a LaunchPad's debug port (its other port is the back-channel UART we want)."""
        text = f"{self.description} {self.interface or ''}".lower()
        return "debug" in text and "uart" not in text

    @property
    def label(self) -> str:
        """One line for the picker: description, ids, serial number, then the name to open."""
        parts = [self.description if self.description and self.description != "n/a" else self.device]
        if self.vid is not None and self.pid is not None:
            ids = f"{self.vid:04X}:{self.pid:04X}"
            if self.serial_number:
                ids += f", SN {self.serial_number}"
            parts.append(f"({ids})")
        name = preferred_name(self)
        parts.append(f"— {name}" + (f" → {self.device}" if name != self.device else ""))
        return " ".join(parts)


def preferred_name(info: PortInfo) -> str:
    """The name to open and to save in settings: the stable by-id link when there is one."""
    return info.stable_path or info.device


def _by_id_links(by_id_dir: str) -> dict[str, str]:
    """realpath of each device -> its by-id link (the first in name order if several)."""
    links: dict[str, str] = {}
    try:
        names = sorted(os.listdir(by_id_dir))
    except OSError:  # no such folder: not Linux, or no USB serial device plugged in
        return links
    for name in names:
        path = os.path.join(by_id_dir, name)
        links.setdefault(os.path.realpath(path), path)
    return links


def _natural_key(text: str) -> tuple:
    return tuple(int(t) if t.isdigit() else t for t in re.split(r"(\d+)", text))


def list_ports(by_id_dir: str = BY_ID_DIR) -> list[PortInfo]:
    """Serial ports, likely boards first (TI, Arduino, USB-serial chips), then by name.

    Never raises: a machine without serial ports gives ``[]``.
    """
    from serial.tools import list_ports as lp

    try:
        raw = list(lp.comports())
    except Exception:  # noqa: BLE001 - a broken sysfs entry must not break the picker
        raw = []
    links = _by_id_links(by_id_dir)
    ports = []
    for p in raw:
        device = p.device
        ports.append(PortInfo(
            device=device,
            stable_path=links.get(os.path.realpath(device)),
            description=p.description or "",
            vid=p.vid,
            pid=p.pid,
            serial_number=p.serial_number,
            manufacturer=p.manufacturer,
            interface=getattr(p, "interface", None),
        ))
    ports.sort(key=lambda i: (i.rank, i.is_debug_interface, _natural_key(i.device)))
    return ports


def _pyserial_scheme_exists(scheme: str) -> bool:
    if not re.fullmatch(r"[a-z0-9_]+", scheme):
        return False
    return importlib.util.find_spec(f"serial.urlhandler.protocol_{scheme}") is not None


def validate_typed_path(text: str) -> str:
    """A port the user typed, checked: an existing device path (ptys included), ``COMn``, or a
    pyserial URL deskarm documents (``loop://``, ``socket://host:port``, ``rfc2217://host:port``);
    a ``v1:``/``v2:`` prefix is kept.

    Returns the cleaned-up name; raises ValueError saying what is wrong and what would work.
    """
    text = (text or "").strip()
    if not text:
        raise ValueError(f"no port given — choose one from the list or type one, e.g. {URL_EXAMPLES}")
    if text[:3].lower() in ("v1:", "v2:"):
        return text[:3].lower() + validate_typed_path(text[3:])
    if "://" in text:
        scheme = text.split("://", 1)[0].lower()
        if scheme in SERIAL_URL_SCHEMES and _pyserial_scheme_exists(scheme):
            return text
        known = "" if _pyserial_scheme_exists(scheme) else "unknown "
        raise ValueError(f"{text}: {known}URL scheme '{scheme}://' is not accepted — deskarm takes "
                         "loop://, socket://host:port and rfc2217://host:port (spy:// would overwrite "
                         "the file it logs to, hwgrep:// picks a device you did not name)")
    if re.fullmatch(r"(\\\\\.\\)?com\d+", text, re.IGNORECASE):
        return re.sub(r"(?i)com", "COM", text)
    path = os.path.expanduser(text)
    if not os.path.isabs(path) and os.path.exists(os.path.join("/dev", path)):
        path = os.path.join("/dev", path)  # "ttyACM0" typed for "/dev/ttyACM0"
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        if os.path.lexists(path):
            raise ValueError(f"{text}: the link points at a device that is gone — is the board "
                             "plugged in?") from None
        raise ValueError(f"{text}: no such port — is the board plugged in? Valid ports look like "
                         f"{URL_EXAMPLES}") from None
    except OSError as exc:
        raise ValueError(f"{text}: cannot check it ({exc.strerror or exc})") from None
    if stat.S_ISDIR(mode):
        raise ValueError(f"{text}: is a folder, not a serial port (e.g. {URL_EXAMPLES})")
    if not stat.S_ISCHR(mode):
        raise ValueError(f"{text}: is a regular file, not a serial port (e.g. {URL_EXAMPLES})")
    return path
