"""The desk across machines, on loopback: `deskarm serve --camera sim` in its own process and a
``DeskClient`` here, as two machines would run them (minus the network).

- camera -> client latency: receive wall time − the frame's capture stamp (one clock on
  loopback), against the in-process headless runner's frame -> bytes latency of the same
  scenario in the same run (what the pipeline costs before anything leaves the machine);
- the e-stop round trip: client sends e-stop -> server stops the arm and echoes on
  /deskarm/estop -> client receives the echo (this machine's clock only);
- the server's per-frame publishing cost (2 JPEG encodes + camera_info + markers) is in its
  status line, not measured here;
- a goal flood (issue 23): a paired server (credentials, access control, Zenoh downsampling,
  the server's token buckets), a peer with the controller's credential putting goals as fast as
  one Python process can for FLOOD_S; the served loop's frames per second (the server's own
  frame count in /deskarm/session, per second) in the same run without and with the flood.
"""
from __future__ import annotations

import os
import queue
import signal
import socket
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = "wander"
BASELINE = f"headless frame -> bytes, in-process ({SCENARIO})"
FLOOD_S = 5.0
LOOP_FPS = "served loop fps, no flood (paired server)"



def stop_server(proc) -> None:
    """Ctrl-C the served desk, as a user would; kill it if it does not end within 15 s."""
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(timeout=15)
    except subprocess.TimeoutExpired:
        proc.kill()

def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start_server(endpoint: str, home: str):
    env = dict(os.environ, DESKARM_HOME=home, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen([sys.executable, "-m", "app.cli", "serve", "--camera", "sim", "--scenario", SCENARIO,
                             "--listen", endpoint], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines: queue.Queue = queue.Queue()
    threading.Thread(target=lambda: [lines.put(line) for line in proc.stdout] + [lines.put(None)], daemon=True).start()
    while True:
        line = lines.get(timeout=60)
        if line is None:
            raise RuntimeError("deskarm serve exited before it was ready")
        if "Ctrl+C stops" in line:
            return proc


def remote_figures(duration_s: float, estops: int) -> tuple[list[float], list[float], int]:
    """(latency ms per left image, e-stop round trips ms, frames) from a served desk."""
    from core.remote import ros
    from core.remote.client import DeskClient
    from core.remote.link import LinkOptions

    endpoint = f"tcp/127.0.0.1:{_free_port()}"
    with tempfile.TemporaryDirectory() as home:
        proc = _start_server(endpoint, home)
        try:
            with DeskClient(LinkOptions(connect=(endpoint,), scouting=False)) as client:
                left = ros.IMAGE_TOPICS["left"]
                if client.wait_for(left, timeout=10.0) is None:
                    raise RuntimeError("no image from the server")
                skip = client.count(left) + 15  # the first half second: connection set-up
                client.wait_for(left, timeout=10.0, after=skip)
                n0 = len(client.latencies_s["left"])
                end = client.count(left) + int(duration_s * 30)
                client.wait_for(left, timeout=duration_s * 3 + 10, after=end - 1)
                latency_ms = [v * 1e3 for v in client.latencies_s["left"][n0:]]
                frames = len(latency_ms)
                round_trips = []
                for _ in range(estops):
                    rt = client.estop_round_trip(timeout=2.0)
                    if rt is not None:
                        round_trips.append(rt * 1e3)
                    client.rearm(timeout=5.0)
                    client.wait_for("/deskarm/estop", lambda r: not r.msg.data, timeout=2.0,
                                    after=client.count("/deskarm/estop"))
        finally:
            stop_server(proc)
    return latency_ms, round_trips, frames


def flood(endpoint: str, credential_file: str, seconds: float) -> None:
    """The flooding peer (its own process): goals as fast as it can put them; prints 'puts N'."""
    import time

    import zenoh

    from core.remote import ros
    from core.remote.link import LinkOptions, open_session
    from core.remote.security import load_credential

    session = open_session(LinkOptions(connect=(endpoint,), credential=load_credential(credential_file),
                                       strict_connect=True))
    pub = session.declare_publisher(ros.key_expr("/deskarm/cmd/goal"), congestion_control=zenoh.CongestionControl.DROP)
    payload = ros.serialize(ros.point_stamped((0.15, 0.0, 0.1), 0.0), "geometry_msgs/msg/PointStamped")
    attachment = ros.Attachment(1, 0, b"flood-gid-16byte").encode()
    print("flooding", flush=True)
    n, end = 0, time.monotonic() + seconds
    while time.monotonic() < end:
        for _ in range(1000):
            pub.put(payload, attachment=attachment)
        n += 1000
    print(f"puts {n}", flush=True)
    session.close()


def _loop_fps(client, seconds: float) -> list[float]:
    """The server's frames per second, one sample per second, from its /deskarm/session counts."""
    import json
    import time

    samples = []
    r = client.wait_for("/deskarm/session", timeout=5.0, after=client.count("/deskarm/session"))
    frames0, t0 = json.loads(r.msg.data)["frames"], r.received_mono
    end = t0 + seconds
    while True:
        r = client.wait_for("/deskarm/session", timeout=5.0, after=r.index)
        if r is None:
            break
        frames, t = json.loads(r.msg.data)["frames"], r.received_mono
        if t - t0 >= 1.0:
            samples.append((frames - frames0) / (t - t0))
            frames0, t0 = frames, t
        if t >= end:
            break
    return samples


def flood_figures(seconds: float = FLOOD_S) -> tuple[list[float], list[float], float]:
    """(loop fps samples without, with the flood; the flooder's puts per second)."""
    from core.remote import security
    from core.remote.client import DeskClient
    from core.remote.link import LinkOptions

    endpoint = f"tcp/127.0.0.1:{_free_port()}"
    with tempfile.TemporaryDirectory() as home:
        files = security.pair(folder=Path(home) / "config" / "remote", tls=False)
        proc = _start_server(endpoint, home)
        try:
            viewer = security.load_credential(files[security.VIEWER])
            with DeskClient(LinkOptions(connect=(endpoint,), credential=viewer), heartbeat=False, control=False) as client:
                if client.wait_for(ROS_LEFT, timeout=10.0) is None:
                    raise RuntimeError("no image from the server")
                quiet = _loop_fps(client, seconds)
                flooder = subprocess.Popen([sys.executable, "-m", "bench.bench_remote", "--flood", endpoint,
                                            str(files[security.CONTROLLER]), str(seconds + 1.0)], cwd=ROOT,
                                           stdout=subprocess.PIPE, text=True)
                try:
                    assert flooder.stdout.readline().startswith("flooding")
                    flooded = _loop_fps(client, seconds)
                    out, _ = flooder.communicate(timeout=60)
                finally:
                    if flooder.poll() is None:
                        flooder.kill()
                        flooder.wait()
                puts = int(out.split()[-1]) / (seconds + 1.0)
        finally:
            stop_server(proc)
    return quiet, flooded, puts


ROS_LEFT = "/deskarm/camera/left/image/compressed"


def rows(quick: bool = False) -> list[dict]:
    from bench.bench_pipeline import headless_run

    duration = 3.0 if quick else 10.0
    baseline = list(headless_run(SCENARIO, True, duration).latency_ms)
    latency_ms, round_trips, frames = remote_figures(duration, 5 if quick else 30)
    quiet, flooded, puts = flood_figures(FLOOD_S)
    return [
        {"name": BASELINE, "unit": "ms", "samples": baseline, "baseline": None, "extra": ""},
        {"name": f"camera -> remote client, loopback ({SCENARIO})", "unit": "ms", "samples": latency_ms,
         "baseline": BASELINE,
         "extra": f"{frames} frames; capture stamp -> client receive (2 JPEG 80 + CDR + zenoh tcp)"},
        {"name": "e-stop round trip, client -> server -> echo", "unit": "ms", "samples": round_trips or [float("nan")],
         "baseline": None, "extra": f"{len(round_trips)} e-stops answered"},
        {"name": LOOP_FPS, "unit": "fps", "samples": quiet or [float("nan")], "baseline": None,
         "extra": f"{FLOOD_S:g} s, the server's own frame count"},
        {"name": "served loop fps, goal flood from a controller peer", "unit": "fps",
         "samples": flooded or [float("nan")], "baseline": LOOP_FPS,
         "extra": f"{puts:,.0f} puts/s for {FLOOD_S:g} s (one Python peer, loopback)"},
    ]


if __name__ == "__main__":
    if "--flood" in sys.argv:
        i = sys.argv.index("--flood")
        flood(sys.argv[i + 1], sys.argv[i + 2], float(sys.argv[i + 3]))
    else:
        from bench.__main__ import format_table

        print(format_table(rows(quick="--quick" in sys.argv)))
