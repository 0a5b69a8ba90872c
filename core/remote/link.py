"""How a remote desk reaches its peers: Zenoh configuration from a few options.

Local by default: a server listens on ``tcp/127.0.0.1:7447`` without scouting; a client listens
nowhere (it only connects). Going on the network is the server's ``--network`` (see
``app.cli_serve``). Credentials and access control come from ``core.remote.security``.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Optional

DEFAULT_PORT = 7447
LOCAL_LISTEN = f"tcp/127.0.0.1:{DEFAULT_PORT}"  # the server's default: this machine only
NETWORK_LISTEN = f"tcp/0.0.0.0:{DEFAULT_PORT}"  # --network: every interface
CONNECT_TIMEOUT_MS = 3000  # a strict client gives up on its endpoints after this long
MODES = ("peer", "client")


class LinkError(RuntimeError):
    """Zenoh is missing or a session could not open; the message says what to do."""


@dataclass(frozen=True)
class LinkOptions:
    """Where a session listens and what it connects to."""

    listen: tuple[str, ...] = ()  # endpoints to listen on, e.g. ("tcp/127.0.0.1:7447",); () listens nowhere
    connect: tuple[str, ...] = ()  # endpoints (a router, the server) to connect to
    mode: str = "peer"  # peer (default) | client (through a router only)
    scouting: bool = False  # multicast scouting: find peers on the LAN without naming them (off unless asked)
    domain_id: int = 0  # ROS_DOMAIN_ID: the first chunk of every key expression
    extra: dict = field(default_factory=dict)  # raw Zenoh config keys (json5 path -> value)
    credential: Optional[object] = None  # security.Credential this session presents (client side)
    security: Optional[object] = None  # security.ServerSecurity: usrpwd dictionary, mTLS, access control
    strict_connect: bool = False  # opening fails (one clear line) when no connect endpoint accepts us

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
        for key, value in self.config_keys().items():
            cfg.insert_json5(key, json.dumps(value))
        return cfg

    def config_keys(self) -> dict:
        """The Zenoh config keys (json5 path -> value) of these options, without importing zenoh."""
        keys: dict = {"mode": self.mode, "scouting/multicast/enabled": bool(self.scouting),
                      "scouting/gossip/enabled": bool(self.scouting),
                      "listen/endpoints": list(self.listen)}  # [] = listen nowhere (Zenoh's peer default is every interface)
        if self.connect:
            keys["connect/endpoints"] = list(self.connect)
        if self.strict_connect and self.connect:
            keys["connect/timeout_ms"] = CONNECT_TIMEOUT_MS
            keys["connect/exit_on_failure"] = True
        if self.listen:  # a server: a flood of commands is cut per connection before Python sees it
            from core.remote.security import downsampling

            keys["downsampling"] = downsampling(self.domain_id)
        if self.credential is not None:
            keys.update(self.credential.zenoh_keys())
        if self.security is not None:
            tls = any(ep.startswith(("tls/", "quic/")) for ep in self.listen)
            keys.update(self.security.zenoh_keys(self.domain_id, tls_endpoints=tls))
        keys.update(self.extra)
        return keys

    def describe(self) -> str:
        parts = [self.mode]
        if self.listen:
            parts.append("listening on " + ", ".join(self.listen))
        if self.connect:
            parts.append("connecting to " + ", ".join(self.connect))
        parts.append("multicast scouting " + ("on" if self.scouting else "off"))
        if self.security is not None:
            parts.append("credentials required (controller drives, viewer watches and may STOP)")
        elif self.listen:
            parts.append("no credentials (anyone who reaches it drives the arm)")
        if self.credential is not None and getattr(self.credential, "user", ""):
            parts.append(f"as {self.credential.user}")
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
    except Exception as exc:  # zenoh raises ZError for a busy port, a bad locator, a refused handshake …
        if options.strict_connect and options.connect and "Unable to connect" in str(exc):
            from core.remote.security import refusal_line

            raise LinkError(refusal_line(options.connect, options.credential)) from None
        raise LinkError(f"could not open a Zenoh session ({options.describe()}): {exc}") from None
