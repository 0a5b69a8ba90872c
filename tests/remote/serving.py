"""A `deskarm serve` subprocess on a free loopback port (scouting off), shared by the remote tests."""
from __future__ import annotations

import os
import queue
import signal
import socket
import subprocess
import sys
import threading
from contextlib import contextmanager
from pathlib import Path

from core.remote.link import LinkOptions

ROOT = Path(__file__).resolve().parents[2]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def zenoh_loopback_problem() -> str:
    """"" when Zenoh opens a listening session on loopback here, else why not."""
    try:
        import zenoh  # noqa: F401

        from core.remote.link import open_session

        session = open_session(LinkOptions(listen=(f"tcp/127.0.0.1:{free_port()}",), scouting=False))
        session.close()
        return ""
    except Exception as exc:  # ImportError, LinkError: the reason is the skip message
        return f"zenoh cannot open a loopback session on this machine: {exc}"


class Served:
    """A running `deskarm serve`: its endpoint and every line it printed (stdout and stderr)."""

    def __init__(self, endpoint: str, proc, lines: "queue.Queue", output: list):
        self.endpoint = endpoint
        self.proc = proc
        self._lines = lines
        self.output = output

    def wait_line(self, text: str, timeout: float = 30.0) -> str:
        """The first line from now on containing ``text`` (AssertionError after ``timeout`` s)."""
        import time

        deadline = time.monotonic() + timeout
        while True:
            try:
                line = self._lines.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                raise AssertionError(f"deskarm serve printed no line with {text!r}:\n" + "".join(self.output)) from None
            assert line is not None, "deskarm serve exited:\n" + "".join(self.output)
            if text in line:
                return line


@contextmanager
def serve(home: Path, scenario: str, *args: str, proto: str = "tcp"):
    """`python -m app.cli serve --camera sim --scenario SCENARIO ARGS…` on a free loopback port;
    yields a ``Served`` once it serves, stops it with Ctrl+C (SIGINT) and checks it stopped cleanly."""
    endpoint = f"{proto}/127.0.0.1:{free_port()}"
    env = dict(os.environ, DESKARM_HOME=str(home), PYTHONUNBUFFERED="1")
    proc = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "serve", "--camera", "sim", "--scenario", scenario,
         "--listen", endpoint, *args],
        cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines: queue.Queue = queue.Queue()
    output: list[str] = []

    def pump():
        for line in proc.stdout:
            output.append(line)
            lines.put(line)
        lines.put(None)

    threading.Thread(target=pump, daemon=True).start()
    served = Served(endpoint, proc, lines, output)
    try:
        served.wait_line("Ctrl+C stops", timeout=60)
        yield served
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
        try:
            rc = proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
            raise AssertionError("deskarm serve did not stop on Ctrl+C (SIGINT):\n" + "".join(output))
    assert rc == 0, f"deskarm serve exit code {rc}:\n" + "".join(output)
    assert any("stopped after" in line for line in output), "".join(output)


@contextmanager
def served_desk(home: Path, scenario: str):
    """`deskarm serve --camera sim --scenario SCENARIO` on a free loopback port (no credentials:
    loopback only); yields its endpoint once it serves, stops it afterwards."""
    with serve(home, scenario) as served:
        yield served.endpoint
