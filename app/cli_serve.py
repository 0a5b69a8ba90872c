"""``deskarm serve``: the desk on this machine, served over Zenoh; ``--client`` watches one.

Server: cameras, perception, the control step and the bridge run headless (as ``--headless``)
and every frame, result, command and state is published as ROS 2 messages (``core.remote``).
Blocks until Ctrl+C (or SIGTERM), then stops the loop, closes the devices and the session.

Local by default: ``tcp/127.0.0.1:7447``, no scouting. ``--network`` listens on every interface
and needs the credentials ``--pair`` made (a controller drives, a viewer watches and may STOP);
it prints who can now reach the arm. ``--pair`` creates them in the config folder (owner-only)
and prints what the other machine needs.

Client: ``deskarm serve --client tcp/HOST:7447 --duration 5 --json`` watches for DURATION
seconds and prints camera→client latency p50/p95 and frames received. It never claims or
re-arms the arm and listens nowhere; ``--estop-test`` adds the e-stop round trip (the arm stays
stopped unless ``--rearm``, which needs the controller credential and holds the re-arm).
"""
from __future__ import annotations

import argparse
import json
import math
import signal
import sys
import threading
import time

from core.remote.link import DEFAULT_PORT, LOCAL_LISTEN, LinkError, LinkOptions

USAGE_EXAMPLES = """examples:
  deskarm serve --camera sim                           # this machine only: tcp/127.0.0.1:7447
  deskarm serve --pair --pair-host 192.168.1.20        # credentials for the other machines (once)
  deskarm serve --network                              # every interface, credentials required
  deskarm serve --network --tls                        # the same over mutual TLS (tls/0.0.0.0:7447)
  deskarm serve --client tcp/192.168.1.20:7447 --duration 5 --json
"""
LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "::1", "[::1]")


def build_parser() -> argparse.ArgumentParser:
    from core.devices.bridge import BRIDGE_CHOICES
    from core.session import SCENARIOS
    from core.vision.cameras import CAMERA_CHOICES

    p = argparse.ArgumentParser(prog="deskarm serve", description="Serve the desk over Zenoh (ROS 2 messages), "
                                "or watch a served desk with --client.", epilog=USAGE_EXAMPLES,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--camera", default="auto", help=f"camera source: {CAMERA_CHOICES} (default: auto)")
    p.add_argument("--bridge", default="sim://", help=f"motor bridge: {BRIDGE_CHOICES} (default: sim://)")
    p.add_argument("--robot", default="desk_rrr", help="robot profile name or TOML path (default: desk_rrr)")
    p.add_argument("--scenario", default="static", help=f"simulated desk scenario: {', '.join(SCENARIOS)}")
    p.add_argument("--calibration", default=None, help="stereo calibration YAML (default: the last saved one)")
    p.add_argument("--markers", default=None, metavar="FILE", help="markers file (default: the config folder's)")
    p.add_argument("--hand-eye", default=None, metavar="FILE", help="camera→arm calibration TOML")
    p.add_argument("--fps", type=float, default=30.0, help="camera frame rate (default: 30)")
    p.add_argument("--listen", action="append", default=None, metavar="ENDPOINT",
                   help=f"Zenoh endpoint to listen on (default for the server: {LOCAL_LISTEN}; repeatable; "
                        "anything but loopback needs --pair's credentials)")
    p.add_argument("--network", action="store_true",
                   help=f"listen on every interface (tcp/0.0.0.0:{DEFAULT_PORT}); needs the credentials --pair made")
    p.add_argument("--tls", action="store_true", help="server: listen on tls/ endpoints with mutual TLS (--pair's certificates)")
    p.add_argument("--scouting", action="store_true", help="multicast scouting on (off by default)")
    p.add_argument("--pair", action="store_true",
                   help="create the server's credentials (a controller and a viewer) in the config folder and "
                        "print what the other machine needs; old credentials stop working")
    p.add_argument("--pair-host", action="append", default=None, metavar="HOST",
                   help="--pair: a name or address the other machines use for this one (TLS certificate; repeatable)")
    p.add_argument("--no-tls", action="store_true", help="--pair: passwords only, no certificates")
    p.add_argument("--no-auth", action="store_true", help="server on loopback: ignore --pair's credentials")
    p.add_argument("--credentials", metavar="FILE", default=None,
                   help="client: the controller.toml or viewer.toml from the serving machine "
                        "(default: the config folder's remote/client.toml)")
    p.add_argument("--connect", action="append", default=None, metavar="ROUTER",
                   help="Zenoh endpoint to connect to: a router or the other machine (repeatable)")
    p.add_argument("--router-only", action="store_true", help="Zenoh client mode: talk only through --connect")
    p.add_argument("--no-scouting", action="store_true", help="no multicast scouting (the default; kept for scripts)")
    p.add_argument("--domain", type=int, default=0, help="ROS_DOMAIN_ID, the first chunk of each key (default: 0)")
    p.add_argument("--humble-keys", action="store_true",
                   help="publish keys with rmw_zenoh's Humble 'TypeHashNotSupported' instead of RIHS01 hashes")
    p.add_argument("--jpeg-quality", type=int, default=80, help="JPEG quality of the images, 1…100 (default: 80)")
    p.add_argument("--client", metavar="ENDPOINT", default=None,
                   help="watch a served desk at ENDPOINT instead of serving (e.g. tcp/192.168.1.20:7447)")
    p.add_argument("--duration", type=float, default=None,
                   help="seconds to run (client default: 5; server default: until Ctrl+C)")
    p.add_argument("--json", action="store_true", help="client: end with one JSON object of figures")
    p.add_argument("--estop-test", action="store_true",
                   help="client: end with an e-stop and measure its round trip (the arm stays stopped)")
    p.add_argument("--rearm", action="store_true",
                   help="client: after --estop-test, hold the re-arm (needs the controller credential)")
    p.add_argument("--leave-estopped", action="store_true", help=argparse.SUPPRESS)  # the default now
    p.add_argument("--record", metavar="FOLDER", default=None,
                   help="server: record the served session into a new rosbag2 folder (same stamps as the stream)")
    return p


def _is_loopback(endpoint: str) -> bool:
    host = endpoint.partition("/")[2].split("#")[0].rpartition(":")[0]
    return host in LOOPBACK_HOSTS


def link_options(args, server: bool) -> LinkOptions:
    """The Zenoh link of these arguments; ValueError when they would open the arm to the network
    without credentials."""
    from core.remote import security

    connect = tuple(args.connect or ())
    scouting = bool(args.scouting) and not args.no_scouting
    mode = "client" if args.router_only else "peer"
    if not server:
        credential = security.load_credential(args.credentials) if args.credentials else security.default_credential()
        return LinkOptions(listen=(), connect=(args.client, *connect), mode=mode, scouting=scouting,
                           domain_id=args.domain, credential=credential, strict_connect=True)
    proto = "tls" if args.tls else "tcp"
    if args.listen:
        listen = tuple(args.listen)
    elif args.network:
        listen = (f"{proto}/0.0.0.0:{DEFAULT_PORT}",)
    else:
        listen = (f"{proto}/127.0.0.1:{DEFAULT_PORT}",)
    local = all(_is_loopback(ep) for ep in listen) and not connect and not scouting
    sec = None if (args.no_auth and local) else security.load_server_security()
    if args.no_auth and not local:
        raise ValueError("--no-auth is for a server on loopback only: off this machine the arm needs credentials")
    if sec is None and not local:
        raise ValueError(f"{', '.join(listen + connect)} reaches beyond this machine, and this desk has no "
                         "credentials yet — run `deskarm serve --pair` first (then --network)")
    if args.tls and sec is None:
        raise ValueError("--tls needs the certificates `deskarm serve --pair` makes — run it first")
    return LinkOptions(listen=listen, connect=connect, mode=mode, scouting=scouting, domain_id=args.domain,
                       security=sec)


def run(command: str, argv: list[str]) -> int:
    """Entry point of ``deskarm serve``; returns the exit code."""
    args = build_parser().parse_args(argv)
    from core.remote.security import CredentialError

    try:
        if args.duration is not None and not (math.isfinite(args.duration) and args.duration > 0):
            raise ValueError(f"--duration {args.duration!r}: a finite number of seconds > 0")
        if args.pair:
            return run_pair(args)
        link = link_options(args, server=args.client is None)
        if args.client is not None:
            return run_client(args, link)
        return run_server(args, link)
    except KeyboardInterrupt:
        return 130
    except CredentialError as exc:
        print(f"deskarm serve: {exc}", file=sys.stderr)
        return 1
    except (LinkError, OSError, RuntimeError, ValueError) as exc:
        print(f"deskarm serve: {exc}", file=sys.stderr)
        return 1 if isinstance(exc, (LinkError, OSError, RuntimeError)) else 2


def run_pair(args) -> int:
    """``--pair``: create the credentials and print what each other machine needs."""
    import socket

    from core.paths import user_dir
    from core.remote import security

    hosts = tuple(dict.fromkeys((*(args.pair_host or ()), socket.gethostname(), "localhost", "127.0.0.1")))
    files = security.pair(hosts=hosts, tls=not args.no_tls)
    folder = security.pairing_dir()
    print(f"deskarm serve: new credentials in {folder} (owner-only; the old ones no longer work)")
    for role, path in files.items():
        what = "drives the arm" if role == security.CONTROLLER else "watches and may press STOP"
        print(f"  {role:10s} ({what}): copy {path} to the other machine as <its config folder>/remote/"
              f"{security.CLIENT_FILE} (on this one that folder is {user_dir('config')}), or pass --credentials FILE")
    proto = "tcp" if args.no_tls else "tls"
    print(f"then here: deskarm serve --network{'' if args.no_tls else ' --tls'}; there: deskarm --remote "
          f"{proto}/{hosts[0]}:{DEFAULT_PORT}" + ("" if args.no_tls else f"  (the certificate names {', '.join(hosts)})"))
    return 0


def run_server(args, link: LinkOptions) -> int:
    from core.remote.server import DeskServer, ServerOptions
    from core.session import DeskSession, SessionOptions, freeze_startup_objects

    options = SessionOptions(camera=args.camera, bridge=args.bridge, robot=args.robot, scenario=args.scenario,
                             fps=args.fps, calibration=args.calibration, hand_eye=args.hand_eye,
                             markers=args.markers)
    if not (1.0 <= args.fps <= 240.0):
        raise ValueError(f"--fps {args.fps:g} is outside 1…240")
    server_options = ServerOptions(link=link, jpeg_quality=args.jpeg_quality,
                                   hash_style="humble" if args.humble_keys else "rihs01")
    session = DeskSession.create(options)
    recorder = None
    if args.record:
        from core.record.recorder import Recorder

        recorder = Recorder.for_session(session, args.record)
    server = DeskServer(session, server_options, status=lambda line: print(line, flush=True), recorder=recorder)
    refusals = None
    if link.security is not None:
        from core.remote.security import RefusalLog

        refusals = RefusalLog(lambda line: print(line, file=sys.stderr, flush=True)).start()
    try:
        server.open()
    except LinkError:
        session.close()
        if refusals is not None:
            refusals.stop()
        raise
    for banner in session.banners:
        print(f"deskarm: {banner}", flush=True)

    def on_signal(signum, frame) -> None:
        server.stop()

    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    from core.remote.security import reachable_from

    print(f"deskarm serve: reachable by {reachable_from(link.listen)}"
          + (" and the peers of " + ", ".join(link.connect) if link.connect else "")
          + (" and any peer multicast scouting finds" if link.scouting else ""), flush=True)
    print(f"deskarm serve: camera {session.camera.name}, bridge {session.bridge.url}, robot {session.profile.name}, "
          f"scenario {options.scenario}; zenoh {link.describe()}, domain {link.domain_id}; Ctrl+C stops",
          flush=True)
    freeze_startup_objects()
    try:
        stats = server.run(args.duration if args.duration is not None else math.inf)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        if refusals is not None:
            refusals.stop()
    print(f"deskarm serve: stopped after {stats.frames} frames, {stats.commands_sent} commands, "
          f"{stats.published} messages published", flush=True)
    return 0


def percentile_ms(values, q):
    import numpy as np

    return None if not values else round(float(np.percentile(np.asarray(values) * 1e3, q)), 3)


def run_client(args, link: LinkOptions) -> int:
    from core.remote.client import DeskClient

    duration = args.duration if args.duration is not None else 5.0
    stop = threading.Event()
    previous = signal.signal(signal.SIGINT, lambda *a: stop.set())
    try:
        with DeskClient(link, heartbeat=False, control=False) as client:
            first = client.wait_for("/deskarm/camera/left/image/compressed", timeout=min(duration, 10.0))
            if first is None:
                print(f"deskarm serve --client: no image from {args.client} within {min(duration, 10.0):g} s — "
                      "is `deskarm serve` running there, and is the port open?", file=sys.stderr)
                return 1
            n0 = {side: len(v) for side, v in client.latencies_s.items()}
            frames0 = client.count("/deskarm/camera/left/image/compressed")
            t0 = time.monotonic()
            stop.wait(duration)
            elapsed = time.monotonic() - t0
            frames = client.count("/deskarm/camera/left/image/compressed") - frames0
            lat = client.latencies_s["left"][n0["left"]:]
            round_trip = rearmed = None
            if args.estop_test:
                round_trip = client.estop_round_trip(timeout=2.0)
                if args.rearm:  # a deliberate act: claim control, hold the re-arm, give control back on close
                    rearmed = client.wait_control() and client.rearm()
            session = client.session() or {}
            summary = {
                "endpoint": args.client, "frames": frames, "fps": round(frames / elapsed, 2) if elapsed > 0 else 0.0,
                "latency_ms_p50": percentile_ms(lat, 50), "latency_ms_p95": percentile_ms(lat, 95),
                "estop_round_trip_ms": None if round_trip is None else round(round_trip * 1e3, 3),
                "markers": {str(k): [round(c, 4) for c in v] for k, v in client.markers().items()},
                "server_mode": session.get("mode"), "server_link": session.get("link"),
                "rearmed": rearmed,
            }
    finally:
        signal.signal(signal.SIGINT, previous)
    if args.json:
        print(json.dumps(summary), flush=True)
    else:
        print(f"{summary['frames']} frames ({summary['fps']} fps), latency p50 {summary['latency_ms_p50']} ms "
              f"p95 {summary['latency_ms_p95']} ms (server clock vs this one)"
              + (f", e-stop round trip {summary['estop_round_trip_ms']} ms" if args.estop_test else ""), flush=True)
    if args.rearm and rearmed is False:
        print("deskarm serve --client: the server did not re-arm — a re-arm needs the controller credential "
              "and no other client in control", file=sys.stderr)
    if args.estop_test and round_trip is None:
        return 1
    return 0 if rearmed is not False else 1
