"""``deskarm serve``: the desk on this machine, served over Zenoh; ``--client`` watches one.

Server: cameras, perception, the control step and the bridge run headless (as ``--headless``)
and every frame, result, command and state is published as ROS 2 messages (``core.remote``).
Blocks until Ctrl+C (or SIGTERM), then stops the loop, closes the devices and the session.

Client: ``deskarm serve --client tcp/HOST:7447 --duration 5 --json`` subscribes for DURATION
seconds and prints camera→client latency p50/p95, frames received and the e-stop round trip
(it e-stops the arm at the end, then re-arms it unless ``--leave-estopped``).
"""
from __future__ import annotations

import argparse
import json
import math
import signal
import sys
import threading
import time

from core.remote.link import DEFAULT_PORT, LinkError, LinkOptions

USAGE_EXAMPLES = """examples:
  deskarm serve --camera sim                           # peer on the LAN, listening on tcp/0.0.0.0:7447
  deskarm serve --connect tcp/192.168.1.2:7447         # through a Zenoh router
  deskarm serve --client tcp/192.168.1.20:7447 --duration 5 --json
"""


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
                   help=f"Zenoh endpoint to listen on (default for the server: tcp/0.0.0.0:{DEFAULT_PORT}; repeatable)")
    p.add_argument("--connect", action="append", default=None, metavar="ROUTER",
                   help="Zenoh endpoint to connect to: a router or the other machine (repeatable)")
    p.add_argument("--router-only", action="store_true", help="Zenoh client mode: talk only through --connect")
    p.add_argument("--no-scouting", action="store_true", help="no multicast scouting (only the endpoints given)")
    p.add_argument("--domain", type=int, default=0, help="ROS_DOMAIN_ID, the first chunk of each key (default: 0)")
    p.add_argument("--humble-keys", action="store_true",
                   help="publish keys with rmw_zenoh's Humble 'TypeHashNotSupported' instead of RIHS01 hashes")
    p.add_argument("--jpeg-quality", type=int, default=80, help="JPEG quality of the images, 1…100 (default: 80)")
    p.add_argument("--client", metavar="ENDPOINT", default=None,
                   help="watch a served desk at ENDPOINT instead of serving (e.g. tcp/192.168.1.20:7447)")
    p.add_argument("--duration", type=float, default=None,
                   help="seconds to run (client default: 5; server default: until Ctrl+C)")
    p.add_argument("--json", action="store_true", help="client: end with one JSON object of figures")
    p.add_argument("--leave-estopped", action="store_true", help="client: do not re-arm after the e-stop test")
    return p


def link_options(args, server: bool) -> LinkOptions:
    listen = tuple(args.listen or ((f"tcp/0.0.0.0:{DEFAULT_PORT}",) if server else ()))
    connect = tuple(args.connect or ())
    if not server:
        connect = (args.client, *connect)
    return LinkOptions(listen=listen, connect=connect, mode="client" if args.router_only else "peer",
                       scouting=not args.no_scouting, domain_id=args.domain)


def run(command: str, argv: list[str]) -> int:
    """Entry point of ``deskarm serve``; returns the exit code."""
    args = build_parser().parse_args(argv)
    try:
        if args.duration is not None and not (math.isfinite(args.duration) and args.duration > 0):
            raise ValueError(f"--duration {args.duration!r}: a finite number of seconds > 0")
        link = link_options(args, server=args.client is None)
        if args.client is not None:
            return run_client(args, link)
        return run_server(args, link)
    except KeyboardInterrupt:
        return 130
    except (LinkError, OSError, RuntimeError, ValueError) as exc:
        print(f"deskarm serve: {exc}", file=sys.stderr)
        return 1 if isinstance(exc, (LinkError, OSError, RuntimeError)) else 2


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
    server = DeskServer(session, server_options, status=lambda line: print(line, flush=True))
    try:
        server.open()
    except LinkError:
        session.close()
        raise
    for banner in session.banners:
        print(f"deskarm: {banner}", flush=True)

    def on_signal(signum, frame) -> None:
        server.stop()

    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    print(f"deskarm serve: camera {session.camera.name}, bridge {session.bridge.url}, robot {session.profile.name}, "
          f"scenario {options.scenario}; zenoh {link.describe()}, domain {link.domain_id}; Ctrl+C stops",
          flush=True)
    freeze_startup_objects()
    try:
        stats = server.run(args.duration if args.duration is not None else math.inf)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
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
        with DeskClient(link) as client:
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
            round_trip = client.estop_round_trip(timeout=2.0)
            if not args.leave_estopped:
                client.send_estop(False)
            session = client.session() or {}
            summary = {
                "endpoint": args.client, "frames": frames, "fps": round(frames / elapsed, 2) if elapsed > 0 else 0.0,
                "latency_ms_p50": percentile_ms(lat, 50), "latency_ms_p95": percentile_ms(lat, 95),
                "estop_round_trip_ms": None if round_trip is None else round(round_trip * 1e3, 3),
                "markers": {str(k): [round(c, 4) for c in v] for k, v in client.markers().items()},
                "server_mode": session.get("mode"), "server_link": session.get("link"),
            }
    finally:
        signal.signal(signal.SIGINT, previous)
    if args.json:
        print(json.dumps(summary), flush=True)
    else:
        print(f"{summary['frames']} frames ({summary['fps']} fps), latency p50 {summary['latency_ms_p50']} ms "
              f"p95 {summary['latency_ms_p95']} ms (server clock vs this one), e-stop round trip "
              f"{summary['estop_round_trip_ms']} ms", flush=True)
    return 0 if round_trip is not None else 1
