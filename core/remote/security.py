"""Who may reach a served desk and what each may do: Zenoh's own authentication and access control.

Identity comes from the transport, permission from rules by key expression (Zenoh 1.x config):

- user/password (``transport/auth/usrpwd``): the server holds a dictionary of ``user:password``
  lines; a client names one user. Users are roles: ``controller`` drives the arm, ``viewer``
  watches and may press STOP.
- TLS and mutual TLS (``transport/link/tls`` on ``tls/HOST:PORT`` endpoints): a CA made by
  ``deskarm serve --pair`` signs the server's certificate and one client certificate per role,
  whose common name is the role.
- access control (``access_control``): deny by default; everyone authenticated may subscribe,
  receive data and declare graph tokens; a viewer may put only on ``/deskarm/cmd/estop``; a
  controller may put on every command key (goal, settings, re-arm, control, heartbeat and the
  ROS interface's ``/target_position``).

A connection without the right credential never opens (Zenoh refuses the handshake), so it
cannot even subscribe. Refusals are said in one line on both sides: the client by probing the
port after Zenoh gave up (a port that answers but refused us = a credential problem), the
server by reading Zenoh's own accept log (``RefusalLog``).

Files live in the config folder's ``remote/`` (``pairing_dir()``), the folder 0700 and every
file 0600: the server's ``server.toml`` and ``users.txt``, the CA and certificates, and one
``<role>.toml`` per role that the other machine copies (user, password and its TLS files inline,
base64) into its own ``remote/client.toml``.
"""
from __future__ import annotations

import base64
import math
import os
import re
import secrets
import socket
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Optional

CONTROLLER, VIEWER = "controller", "viewer"
ROLES = (CONTROLLER, VIEWER)
SERVER_USER = "deskarm-server"
CLIENT_FILE = "client.toml"  # on the other machine: the credential it uses by default

# Command topics a viewer may put on (STOP from anyone who can see the arm) and the ones only a
# controller may: everything that moves, re-arms or hands over the arm.
VIEWER_COMMANDS = ("/deskarm/cmd/estop",)
CONTROLLER_COMMANDS = ("/deskarm/cmd/goal", "/deskarm/cmd/settings", "/deskarm/cmd/heartbeat",
                       "/deskarm/cmd/rearm", "/deskarm/cmd/control", "/target_position", "/target_pitch",
                       "/target_roll")

# Per-connection rates above which Zenoh itself drops commands before they reach Python (Hz).
# Zenoh's downsampling drops any sample closer than 1/freq to the previous one on that key, so
# only streams that are sent periodically are cut here (a flood of goals costs Python nothing);
# sparse commands (settings, control) keep every sample and meet the server's token buckets.
COMMAND_RATE_HZ = {"/deskarm/cmd/goal": 200.0, "/target_position": 200.0, "/target_pitch": 200.0,
                   "/target_roll": 200.0, "/deskarm/cmd/heartbeat": 50.0,
                   "/deskarm/cmd/rearm": 50.0, "/deskarm/cmd/estop": 100.0}


class CredentialError(RuntimeError):
    """A credential file is missing or unusable; the message says what to do."""


def pairing_dir() -> Path:
    """The config folder's ``remote/`` (``DESKARM_HOME`` moves it, e.g. in tests)."""
    from core.paths import user_dir

    return user_dir("config") / "remote"


def _private_folder(path: Path) -> Path:
    path.mkdir(parents=True, exist_ok=True)
    os.chmod(path, 0o700)
    return path


def _write_private(path: Path, data: bytes) -> Path:
    """Write ``path`` readable by its owner only (created 0600, never world-readable for an instant)."""
    tmp = path.with_name(path.name + ".tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    try:
        os.write(fd, data)
        os.fsync(fd)
    finally:
        os.close(fd)
    os.chmod(tmp, 0o600)
    tmp.replace(path)
    return path


# ---- credentials ----------------------------------------------------------------------------

@dataclass(frozen=True)
class Credential:
    """What a client presents: a user and password, and optionally TLS material (PEM bytes)."""

    user: str = ""
    password: str = ""
    ca_pem: bytes = b""  # the server's CA (TLS: the client checks the server with it)
    cert_pem: bytes = b""  # this client's certificate (mutual TLS)
    key_pem: bytes = b""
    source: str = ""  # the file it came from, for messages

    @property
    def role(self) -> str:
        return self.user if self.user in ROLES else ""

    def zenoh_keys(self) -> dict:
        """Zenoh config keys (json5 path -> value) presenting this credential."""
        keys: dict = {}
        if self.user:
            keys["transport/auth/usrpwd"] = {"user": self.user, "password": self.password}
        if self.ca_pem:
            tls = {"root_ca_certificate_base64": _b64(self.ca_pem), "verify_name_on_connect": True}
            if self.cert_pem and self.key_pem:
                tls.update({"connect_certificate_base64": _b64(self.cert_pem),
                            "connect_private_key_base64": _b64(self.key_pem), "enable_mtls": True})
            keys["transport/link/tls"] = tls
        return keys

    def to_toml(self) -> str:
        lines = [f'user = "{self.user}"', f'password = "{self.password}"']
        for name in ("ca_pem", "cert_pem", "key_pem"):
            value = getattr(self, name)
            if value:
                lines.append(f'{name}_base64 = "{_b64(value)}"')
        return "\n".join(lines) + "\n"


def _b64(data: bytes) -> str:
    return base64.b64encode(bytes(data)).decode("ascii")


def load_credential(path: str | os.PathLike) -> Credential:
    """The credential of a ``<role>.toml`` made by ``deskarm serve --pair`` (CredentialError if unusable)."""
    import tomllib

    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise CredentialError(f"{path}: no such credential file — run `deskarm serve --pair` on the serving "
                              "machine and copy the file it names here") from None
    except (OSError, ValueError) as exc:
        raise CredentialError(f"{path}: cannot read this credential file ({exc}) — copy it again from the "
                              "serving machine (`deskarm serve --pair` prints it)") from None
    user, password = str(data.get("user", "")), str(data.get("password", ""))
    if not re.fullmatch(r"[A-Za-z0-9_.-]{1,64}", user) or not password:
        raise CredentialError(f"{path}: needs user = \"controller\" or \"viewer\" and a password")
    try:
        pems = {k: base64.b64decode(str(data.get(f"{k}_base64", "")), validate=True)
                for k in ("ca_pem", "cert_pem", "key_pem")}
    except ValueError:
        raise CredentialError(f"{path}: its certificates are not valid base64 — copy the file again") from None
    return Credential(user, password, source=str(path), **pems)


def default_credential() -> Optional[Credential]:
    """This machine's ``remote/client.toml`` when there is one (what ``--remote`` and ``--client`` use)."""
    path = pairing_dir() / CLIENT_FILE
    return load_credential(path) if path.exists() else None


@dataclass(frozen=True)
class ServerSecurity:
    """The serving side: the password dictionary and, with TLS, the CA and the server's certificate."""

    folder: Path
    password: str  # the server's own password (Zenoh authenticates both ends)
    tls: bool  # certificates exist: tls/ endpoints work, with mutual TLS

    @property
    def users_file(self) -> Path:
        return self.folder / "users.txt"

    def zenoh_keys(self, domain_id: int = 0, tls_endpoints: bool = False) -> dict:
        """Config keys: usrpwd with the dictionary, mutual TLS, access control."""
        keys = {
            "transport/auth/usrpwd": {"user": SERVER_USER, "password": self.password,
                                      "dictionary_file": str(self.users_file)},
            "access_control": access_control(domain_id),
        }
        if tls_endpoints:
            if not self.tls:
                raise CredentialError(f"{self.folder}: no certificates for tls/ endpoints — run `deskarm serve --pair` again")
            keys["transport/link/tls"] = {
                "root_ca_certificate": str(self.folder / "ca.pem"),
                "listen_certificate": str(self.folder / "server.pem"),
                "listen_private_key": str(self.folder / "server.key"),
                "enable_mtls": True,
            }
        return keys


def load_server_security(folder: Optional[Path] = None) -> Optional[ServerSecurity]:
    """The pairing ``deskarm serve --pair`` made here, or None when there is none."""
    import tomllib

    folder = Path(folder) if folder is not None else pairing_dir()
    conf = folder / "server.toml"
    if not conf.exists():
        return None
    try:
        data = tomllib.loads(conf.read_text())
    except (OSError, ValueError) as exc:
        raise CredentialError(f"{conf}: unreadable ({exc}) — run `deskarm serve --pair` again") from None
    if not (folder / "users.txt").exists():
        raise CredentialError(f"{folder / 'users.txt'}: missing — run `deskarm serve --pair` again")
    mode = folder.stat().st_mode & 0o077
    if mode:
        raise CredentialError(f"{folder}: readable by other users (mode {oct(folder.stat().st_mode & 0o777)}) — "
                              f"chmod 700 {folder}, or run `deskarm serve --pair` again")
    return ServerSecurity(folder, str(data.get("password", "")), (folder / "server.pem").exists())


def pair(folder: Optional[Path] = None, hosts: tuple[str, ...] = ("localhost", "127.0.0.1"),
         tls: bool = True) -> dict[str, Path]:
    """Create (or replace) the server's credentials, one password and one certificate per role.

    Returns {role: path of the file the other machine needs}. Old credentials stop working.
    """
    folder = _private_folder(Path(folder) if folder is not None else pairing_dir())
    passwords = {role: secrets.token_urlsafe(18) for role in ROLES}
    server_password = secrets.token_urlsafe(18)
    pems: dict[str, tuple[bytes, bytes]] = {}
    ca = b""
    if tls:
        ca, pems = make_certificates(folder, hosts)
    _write_private(folder / "users.txt", "".join(f"{r}:{p}\n" for r, p in passwords.items()).encode())
    _write_private(folder / "server.toml", f'user = "{SERVER_USER}"\npassword = "{server_password}"\n'.encode())
    out = {}
    for role in ROLES:
        cert, key = pems.get(role, (b"", b""))
        cred = Credential(role, passwords[role], ca, cert, key)
        out[role] = _write_private(folder / f"{role}.toml", cred.to_toml().encode())
    return out


def make_certificates(folder: Path, hosts: tuple[str, ...]) -> tuple[bytes, dict[str, tuple[bytes, bytes]]]:
    """A CA, the server's certificate (for ``hosts``) and one client certificate per role (CN =
    role), with the ``openssl`` command; keys 0600. Returns (CA PEM, {role: (cert, key)})."""
    def run(*args: str) -> None:
        try:
            subprocess.run(args, check=True, capture_output=True, cwd=folder, timeout=60)
        except FileNotFoundError:
            raise CredentialError("the `openssl` command is missing — install it (apt install openssl) or pair "
                                  "without TLS (--pair --no-tls)") from None
        except subprocess.CalledProcessError as exc:
            raise CredentialError(f"openssl failed: {exc.stderr.decode(errors='replace').strip()[:200]}") from None

    ec = ("-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:P-256", "-nodes")
    old = os.umask(0o077)
    try:
        run("openssl", "req", "-x509", *ec, "-keyout", "ca.key", "-out", "ca.pem", "-days", "3650",
            "-subj", "/CN=deskarm-ca")
        out = {}
        for name in ("server", *ROLES):
            san = ",".join((f"IP:{h}" if re.fullmatch(r"[0-9.]+|[0-9a-fA-F:]+:[0-9a-fA-F:]*", h) else f"DNS:{h}")
                           for h in hosts)
            (folder / f"{name}.ext").write_text(f"subjectAltName={san}\nbasicConstraints=CA:FALSE\n")
            run("openssl", "req", *ec, "-keyout", f"{name}.key", "-out", f"{name}.csr", "-subj", f"/CN={name}")
            run("openssl", "x509", "-req", "-in", f"{name}.csr", "-CA", "ca.pem", "-CAkey", "ca.key",
                "-CAcreateserial", "-out", f"{name}.pem", "-days", "3650", "-extfile", f"{name}.ext")
            for leftover in (f"{name}.csr", f"{name}.ext"):
                (folder / leftover).unlink(missing_ok=True)
            out[name] = ((folder / f"{name}.pem").read_bytes(), (folder / f"{name}.key").read_bytes())
    finally:
        os.umask(old)
    for p in folder.iterdir():
        os.chmod(p, 0o600)
    return (folder / "ca.pem").read_bytes(), {r: out[r] for r in ROLES}


# ---- access control -------------------------------------------------------------------------

def _keys(topics, domain_id: int) -> list[str]:
    return [f"{int(domain_id)}/{t.strip('/')}/**" for t in topics]


def access_control(domain_id: int = 0) -> dict:
    """Zenoh ``access_control``: deny by default, see for everyone, STOP for viewers, drive for controllers."""
    see = ["declare_subscriber", "declare_queryable", "query", "reply", "liveliness_token",
           "declare_liveliness_subscriber", "liveliness_query"]
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": [
            {"id": "see", "messages": see, "flows": ["ingress", "egress"], "permission": "allow",
             "key_exprs": ["**", "@ros2_lv/**", "@adv/**"]},
            {"id": "receive", "messages": ["put", "delete"], "flows": ["egress"], "permission": "allow",
             "key_exprs": ["**"]},
            {"id": "stop", "messages": ["put"], "flows": ["ingress"], "permission": "allow",
             "key_exprs": _keys(VIEWER_COMMANDS, domain_id)},
            {"id": "drive", "messages": ["put"], "flows": ["ingress"], "permission": "allow",
             "key_exprs": _keys(CONTROLLER_COMMANDS, domain_id)},
        ],
        "subjects": [
            {"id": "viewer_user", "usernames": [VIEWER]},
            {"id": "viewer_cert", "cert_common_names": [VIEWER]},
            {"id": "controller_user", "usernames": [CONTROLLER]},
            {"id": "controller_cert", "cert_common_names": [CONTROLLER]},
        ],
        "policies": [
            {"rules": ["see", "receive", "stop"], "subjects": ["viewer_user", "viewer_cert"]},
            {"rules": ["see", "receive", "stop", "drive"], "subjects": ["controller_user", "controller_cert"]},
        ],
    }


def downsampling(domain_id: int = 0) -> list:
    """Zenoh ``downsampling`` of incoming commands: a flood is cut per connection before Python sees it."""
    return [{"id": "commands", "flows": ["ingress"], "messages": ["put"],
             "rules": [{"key_expr": f"{int(domain_id)}/{topic.strip('/')}/**", "freq": hz}
                       for topic, hz in COMMAND_RATE_HZ.items()]}]


# ---- refusals said in one line --------------------------------------------------------------

def port_answers(endpoint: str, timeout: float = 1.0) -> bool:
    """True when a TCP connection to the endpoint's host:port opens (something listens there)."""
    proto, _, rest = endpoint.partition("/")
    host, _, port = rest.split("#")[0].rpartition(":")
    host = host.strip("[]")
    try:
        with socket.create_connection((host, int(port)), timeout=timeout):
            return True
    except (OSError, ValueError):
        return False


def refusal_line(endpoints, credential: Optional[Credential]) -> str:
    """Why a session could not reach any of ``endpoints``: refused credentials, or nobody there."""
    answering = [ep for ep in endpoints if port_answers(ep)]
    if not answering:
        return (f"nothing answers at {', '.join(endpoints)} — is `deskarm serve` running there with "
                "--network, and is the port open in its firewall?")
    who = (f"user {credential.user!r} from {credential.source or 'the given credential'}" if credential and credential.user
           else "no credential")
    return (f"{', '.join(answering)} refused this machine ({who}) — copy the controller.toml or viewer.toml "
            f"that `deskarm serve --pair` printed there to {pairing_dir() / CLIENT_FILE}, or pass --credentials FILE")


_ACCEPT_REASONS = (
    ("Invalid password", "a wrong password"),
    ("Invalid user", "an unknown user"),
    ("Expected extension", "no credential"),
    ("sent no certificates", "no client certificate (mutual TLS)"),
    ("certificate", "a certificate this desk did not issue"),
    ("Tls", "a TLS handshake that failed (no or a foreign certificate)"),
)


def refusal_reason(zenoh_log_line: str) -> Optional[str]:
    """The reason in words of one line of Zenoh's accept log, or None when it is no refusal."""
    text = re.sub(r"\x1b\[[0-9;]*m", "", zenoh_log_line)
    if "establishment::accept" not in text and "zenoh_link" not in text:
        return None
    for needle, reason in _ACCEPT_REASONS:
        if needle in text:
            return reason
    return None


class RefusalLog:
    """Turns Zenoh's connection-accept log into one clear line per refused connection.

    Zenoh (Rust ``tracing``) logs refused handshakes at debug level to this process's standard
    output. ``start`` routes file descriptor 1 through a pipe read by a thread: a refusal becomes
    ``"deskarm serve: refused a connection: <reason> …"`` (``emit``), Zenoh's other debug lines
    are dropped, everything else (this program's own output) is passed through unchanged.
    """

    FILTER = "error,zenoh_transport::unicast::establishment::accept=debug,zenoh_link_tls=warn"
    FD = 1  # tracing_subscriber's fmt writer is stdout
    REPEAT_S = 10.0  # the same refusal again within this long is counted, not said again

    def __init__(self, emit: Callable[[str], None]):
        self.emit = emit
        self.refused = 0
        self._thread: Optional[threading.Thread] = None
        self._saved_fd: Optional[int] = None

    def start(self) -> "RefusalLog":
        import zenoh

        read_fd, write_fd = os.pipe()
        sys.stdout.flush()
        self._saved_fd = os.dup(self.FD)
        os.dup2(write_fd, self.FD)
        os.close(write_fd)
        self._thread = threading.Thread(target=self._pump, args=(read_fd, self._saved_fd),
                                        name="deskarm-zenoh-log", daemon=True)
        self._thread.start()
        try:
            zenoh.init_log_from_env_or(self.FILTER)
        except Exception:  # logging initialised already (a second server in one process): no refusal lines
            pass
        return self

    def stop(self) -> None:
        """Give standard output back (Zenoh's later log lines, if any, are passed through)."""
        if self._saved_fd is None:
            return
        sys.stdout.flush()
        os.dup2(self._saved_fd, self.FD)  # the pipe's last writer closes: the pump ends
        self._saved_fd = None
        if self._thread is not None:
            self._thread.join(timeout=2.0)

    def _pump(self, read_fd: int, out: int) -> None:
        last_said: dict[str, float] = {}
        with os.fdopen(read_fd, "r", errors="replace") as pipe:
            for line in pipe:
                reason = refusal_reason(line)
                if reason is not None:
                    self.refused += 1
                    now = time.monotonic()
                    if now - last_said.get(reason, -math.inf) >= self.REPEAT_S:  # a client retries every second
                        last_said[reason] = now
                        self.emit(f"deskarm serve: refused a connection: {reason} — give that machine the "
                                  "controller.toml or viewer.toml `deskarm serve --pair` made")
                    continue
                if "zenoh" in line and ("DEBUG" in line or "TRACE" in line):
                    continue
                try:
                    os.write(out, line.encode())
                except OSError:
                    pass
        try:
            os.close(out)
        except OSError:
            pass


def reachable_from(listen: tuple[str, ...]) -> str:
    """Who can reach these endpoints, in words (printed when going on the network)."""
    hosts = []
    for ep in listen:
        host = ep.partition("/")[2].rpartition(":")[0].strip("[]")
        hosts.append(host)
    if all(h in ("127.0.0.1", "localhost", "::1") for h in hosts):
        return "only programs on this machine"
    if any(h in ("0.0.0.0", "::", "") for h in hosts):
        return "every machine that can route to this one (all interfaces)"
    return "machines that can reach " + ", ".join(hosts)
