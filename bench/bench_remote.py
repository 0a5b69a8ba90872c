"""The desk across machines, on loopback: `deskarm serve --camera sim` in its own process and a
``DeskClient`` here, as two machines would run them (minus the network).

- camera -> client latency: receive wall time − the frame's capture stamp (one clock on
  loopback), against the in-process headless runner's frame -> bytes latency of the same
  scenario in the same run (what the pipeline costs before anything leaves the machine);
- the e-stop round trip: client sends e-stop -> server stops the arm and echoes on
  /deskarm/estop -> client receives the echo (this machine's clock only);
- the server's per-frame publishing cost (2 JPEG encodes + camera_info + markers) is in its
  status line, not measured here.
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


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start_server(endpoint: str, home: str):
    env = dict(os.environ, DESKARM_HOME=home, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen([sys.executable, "-m", "app.cli", "serve", "--camera", "sim", "--scenario", SCENARIO,
                             "--listen", endpoint, "--no-scouting"], cwd=ROOT, env=env,
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
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                proc.kill()
    return latency_ms, round_trips, frames


def rows(quick: bool = False) -> list[dict]:
    from bench.bench_pipeline import headless_run

    duration = 3.0 if quick else 10.0
    baseline = list(headless_run(SCENARIO, True, duration).latency_ms)
    latency_ms, round_trips, frames = remote_figures(duration, 5 if quick else 30)
    return [
        {"name": BASELINE, "unit": "ms", "samples": baseline, "baseline": None, "extra": ""},
        {"name": f"camera -> remote client, loopback ({SCENARIO})", "unit": "ms", "samples": latency_ms,
         "baseline": BASELINE,
         "extra": f"{frames} frames; capture stamp -> client receive (2 JPEG 80 + CDR + zenoh tcp)"},
        {"name": "e-stop round trip, client -> server -> echo", "unit": "ms", "samples": round_trips or [float("nan")],
         "baseline": None, "extra": f"{len(round_trips)} e-stops answered"},
    ]


if __name__ == "__main__":
    from bench.__main__ import format_table

    print(format_table(rows(quick="--quick" in sys.argv)))
