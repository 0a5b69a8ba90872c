"""How a remote desk reaches its peers: Zenoh configuration from a few options."""
from __future__ import annotations

import json
from dataclasses import dataclass, field

DEFAULT_PORT = 7447
MODES = ("peer", "client")


class LinkError(RuntimeError):
    """Zenoh is missing or a session could not open; the message says what to do."""


@dataclass(frozen=True)
class LinkOptions:
    """Where a session listens and what it connects to."""

    listen: tuple[str, ...] = ()  # endpoints to listen on, e.g. ("tcp/0.0.0.0:7447",)
    connect: tuple[str, ...] = ()  # endpoints (a router, the server) to connect to
    mode: str = "peer"  # peer (LAN, default) | client (through a router only)
    scouting: bool = True  # multicast scouting: find peers on the LAN without naming them
    domain_id: int = 0  # ROS_DOMAIN_ID: the first chunk of every key expression
    extra: dict = field(default_factory=dict)  # raw Zenoh config keys (json5 path -> value)

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"link mode {self.mode!r}: expected one of {', '.join(MODES)}")
        if not (0 <= int(self.domain_id) <= 232):
            raise ValueError(f"--domain {self.domain_id}: outside 0…232 (ROS_DOMAIN_ID)")
        for ep in (*self.listen, *self.connect):
            check_endpoint(ep)
        if self.mode == "client" and not self.connect and not self.scouting:
            raise ValueError("client mode needs --connect ROUTER (or scouting on to find one)")

    def zenoh_config(self):
        """A ``zenoh.Config`` for these options (imports zenoh)."""
        zenoh = import_zenoh()
        cfg = zenoh.Config()
        cfg.insert_json5("mode", json.dumps(self.mode))
        cfg.insert_json5("scouting/multicast/enabled", json.dumps(bool(self.scouting)))
        if self.listen:
            cfg.insert_json5("listen/endpoints", json.dumps(list(self.listen)))
        if self.connect:
            cfg.insert_json5("connect/endpoints", json.dumps(list(self.connect)))
        for key, value in self.extra.items():
            cfg.insert_json5(key, json.dumps(value))
        return cfg

    def describe(self) -> str:
        parts = [self.mode]
        if self.listen:
            parts.append("listening on " + ", ".join(self.listen))
        if self.connect:
            parts.append("connecting to " + ", ".join(self.connect))
        parts.append("multicast scouting " + ("on" if self.scouting else "off"))
        return ", ".join(parts)


def check_endpoint(endpoint: str) -> str:
    """``endpoint`` when it looks like a Zenoh locator (``tcp/HOST:PORT``, ``udp/…``, ``quic/…``),
    else ValueError with an example."""
    proto, sep, rest = str(endpoint).partition("/")
    if not sep or proto not in ("tcp", "udp", "tls", "quic", "ws", "unixsock-stream") or not rest:
        raise ValueError(f"endpoint {endpoint!r} is not a Zenoh locator; expected e.g. tcp/192.168.1.20:7447")
    if proto in ("tcp", "udp", "tls", "quic", "ws"):
        host, colon, port = rest.rpartition(":")
        if not colon or not host or not port.split("#")[0].isdigit() or not (0 <= int(port.split("#")[0]) <= 65535):
            raise ValueError(f"endpoint {endpoint!r} needs HOST:PORT with a port 0…65535, e.g. tcp/0.0.0.0:7447")
    return endpoint


def import_zenoh():
    try:
        import zenoh
    except ImportError as exc:
        raise LinkError(f"eclipse-zenoh is not installed ({exc}) — pip install 'deskarm[remote]'") from None
    return zenoh


def open_session(options: LinkOptions):
    """An open ``zenoh.Session``, or LinkError naming the endpoints and the cause."""
    zenoh = import_zenoh()
    try:
        return zenoh.open(options.zenoh_config())
    except Exception as exc:  # zenoh raises ZError for a busy port, a bad locator …
        raise LinkError(f"could not open a Zenoh session ({options.describe()}): {exc}") from None
