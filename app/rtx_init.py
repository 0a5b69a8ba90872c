"""The UMI-RTX's encoder initialisation from the command line, with progress on stderr.

``python -m app.rtx_init --bridge rtx:/dev/ttyUSB0`` (``deskarm rtx-init`` once ``app.cli`` lists it) connects to the controller, drives each joint
to its end stops (``RtxBridge.initialise``) and prints one line per step and per 10 % of a joint;
Ctrl-C stops every motor. Exit 0 when the arm is ready, 1 when it failed, 130 when stopped.

``attach_status(bridge, status)`` is the headless runner's hook (one line before it connects the
bridge): an RTX bridge then reports its initialisation (``rtx:PORT?init=auto``) through ``status``,
or says that motion waits for one. ``ensure_ready(bridge, status)`` initialises an RTX that needs it
now, with the same progress lines; other bridges are left alone by both.
"""
from __future__ import annotations

import argparse
import signal
import sys
import threading
from typing import Callable, Optional

from core.devices.bridge import BridgeError


def progress_printer(status: Callable[[str], None]) -> Callable[[object], None]:
    """A progress callback that says each joint's step once per 10 % and every state change."""
    last: dict[str, int] = {}
    last_text = [""]

    def show(ev) -> None:
        tenth = int(ev.fraction * 10)
        if ev.joint and last.get(ev.joint) == tenth and ev.text == last_text[0]:
            return
        if ev.joint:
            last[ev.joint] = tenth
        last_text[0] = ev.text
        bars = " ".join(f"{name} {frac * 100:3.0f}%" for name, frac in ev.fractions)
        status(f"rtx init: {ev.text}" + (f"  [{bars}]" if bars and not ev.done else ""))

    return show


def attach_status(bridge, status: Callable[[str], None]) -> None:
    """Let an RTX bridge say its initialisation's progress (``?init=auto``: on connect, and again
    after a controller restart) — or that motion waits for one — through ``status``; other
    bridges are left alone. The headless runner calls it before ``bridge.connect()``."""
    if hasattr(bridge, "progress_sink"):
        bridge.progress_sink = progress_printer(status)


def ensure_ready(bridge, status: Callable[[str], None], cancel: Optional[threading.Event] = None) -> bool:
    """Initialise ``bridge`` if it is an RTX that needs it (progress through ``status``); True when
    the arm may move (also for every other bridge). A failure is said through ``status``."""
    if not hasattr(bridge, "initialise") or getattr(bridge, "ready", True) or not bridge.is_connected:
        return True
    try:
        return bool(bridge.initialise(progress=progress_printer(status), cancel=cancel))
    except BridgeError as exc:
        status(f"rtx init: failed — {exc}")
    except Exception as exc:  # InitCancelled
        status(f"rtx init: {type(exc).__name__} — every motor stopped")
    return False


def run(name: str, argv: list[str]) -> int:
    """``deskarm rtx-init …`` (``app.cli``'s SUBCOMMANDS dispatch)."""
    return main(argv, prog=f"deskarm {name}")


def main(argv: Optional[list[str]] = None, prog: str = "python -m app.rtx_init") -> int:
    parser = argparse.ArgumentParser(prog=prog,
                                     description="Initialise a UMI-RTX's encoders: each joint to its end stops.")
    parser.add_argument("--bridge", required=True, help="rtx:<port> (e.g. rtx:/dev/ttyUSB0) or rtx:sim")
    args = parser.parse_args(argv)
    from core.devices import open_bridge
    from core.devices.rtx_bridge import InitCancelled, RtxBridge
    from core.kinematics.profile import load_profile

    try:
        bridge = open_bridge(args.bridge, load_profile("umi_rtx"))
    except (ValueError, BridgeError) as exc:
        print(f"deskarm rtx-init: {exc}", file=sys.stderr)
        return 2
    if not isinstance(bridge, RtxBridge):
        print(f"deskarm rtx-init: {args.bridge} is not a UMI-RTX controller (use rtx:<port>)", file=sys.stderr)
        return 2
    say = lambda line: print(line, file=sys.stderr, flush=True)  # noqa: E731
    cancel = threading.Event()

    def on_sigint(*_):
        # the initialisation sees it at its next poll (tens of ms) and stops every motor; sending
        # from the handler could cut into a command the main thread is in the middle of
        cancel.set()

    old = signal.signal(signal.SIGINT, on_sigint)
    try:
        bridge.connect()
        say(f"rtx init: {bridge.status().message}")
        try:
            bridge.initialise(progress=progress_printer(say), cancel=cancel)
        except InitCancelled:
            say("rtx init: stopped — every motor stopped; the arm is not initialised")
            return 130
        say("rtx init: the arm is ready")
        return 0
    except BridgeError as exc:
        say(f"deskarm rtx-init: {exc}")
        return 1
    finally:
        signal.signal(signal.SIGINT, old)
        bridge.shutdown()


if __name__ == "__main__":
    sys.exit(main())
