"""A CPU budget for a child process: a cgroup v1 ``cpu`` controller group with a CFS quota.

``CpuQuota(0.29)`` makes a group under /sys/fs/cgroup/cpu whose processes together get at most
0.29 of one core's time (``cpu.cfs_quota_us`` / ``cpu.cfs_period_us``), ``command(argv)`` wraps
a command so that the process joins the group before it ``exec``s (start-up is throttled too),
``stats()`` reads the kernel's throttling counters and ``close()`` removes the group (after its
processes have exited). ``CpuQuota(None)`` makes a group without a quota: the unthrottled runs go
through the same wrapper, so they differ from the budgeted ones only by the quota.

The period is short (PERIOD_US, 10 ms) so that a quarter core looks like a slower core (a few ms
of run, then a few ms of wait) rather than 25 ms of full speed and a 75 ms freeze in every 100 ms,
which would put freezes into every latency figure. ``shares`` (``cpu.shares``; 1024 is one busy
task's weight) makes the group win against other busy processes on the host, so a budget is
actually obtained on a loaded machine; the quota still caps it.

Needs root and cgroup v1 with the ``cpu`` controller mounted (``available()`` says why not).
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Optional, Sequence

CPU_ROOT = Path("/sys/fs/cgroup/cpu")
PERIOD_US = 10_000  # CFS period: see the module docstring
MIN_QUOTA_US = 1_000  # the kernel refuses a quota below 1 ms
DEFAULT_SHARES = 8192  # eight busy tasks' weight: a budget is obtained on a loaded host
GROUP_PREFIX = "deskarm-bench-"


class CpuQuotaError(RuntimeError):
    """The cgroup could not be made or written (not root, no cgroup v1 ``cpu`` controller)."""


class CpuQuotaUnavailable(ImportError):
    """This machine cannot make a CPU quota group (see ``available``). An ImportError so that
    ``make bench`` skips a bench needing one as it skips a missing extra (bench/__main__ OPTIONAL)."""


def available(root: Path = CPU_ROOT) -> str:
    """"" when a quota group can be made under ``root``, else why not (one line)."""
    if not (root / "cpu.cfs_quota_us").is_file():
        return (f"{root}/cpu.cfs_quota_us is missing: no cgroup v1 'cpu' controller mounted there "
                "(a cgroup v2-only system needs cpu.max instead)")
    if not os.access(root, os.W_OK):
        return f"{root} is not writable: run as root to make a CPU quota group"
    return ""


def quota_us(fraction: float, period_us: int = PERIOD_US) -> int:
    """The ``cpu.cfs_quota_us`` that holds a group to ``fraction`` of one core per ``period_us``."""
    if not (fraction > 0):
        raise ValueError(f"CPU fraction {fraction!r}: must be > 0 (of one core)")
    q = int(round(fraction * period_us))
    if q < MIN_QUOTA_US:
        raise ValueError(f"CPU fraction {fraction:g} of a {period_us} µs period is {q} µs; "
                         f"the kernel's minimum quota is {MIN_QUOTA_US} µs: use a longer period")
    return q


class CpuQuota:
    """One cgroup v1 ``cpu`` group holding its processes to ``fraction`` of one core (None: no quota)."""

    def __init__(self, fraction: Optional[float], name: str = "", period_us: int = PERIOD_US,
                 shares: int = DEFAULT_SHARES, root: Path = CPU_ROOT):
        why = available(root)
        if why:
            raise CpuQuotaError(why)
        self.fraction = fraction
        self.period_us = int(period_us)
        q = -1 if fraction is None else quota_us(fraction, self.period_us)
        label = "".join(c if c.isalnum() or c in "-_" else "-" for c in name)[:40]
        self.path = root / f"{GROUP_PREFIX}{os.getpid()}-{label or 'group'}-{id(self):x}"
        try:
            self.path.mkdir()
            (self.path / "cpu.cfs_period_us").write_text(str(self.period_us))
            (self.path / "cpu.cfs_quota_us").write_text(str(q))
            (self.path / "cpu.shares").write_text(str(int(shares)))
        except OSError as exc:
            self._remove()
            raise CpuQuotaError(f"could not set up the CPU quota group {self.path}: {exc}") from exc

    # ----------------------------------------------------------------------------------------
    def command(self, argv: Sequence[str]) -> list[str]:
        """``argv`` wrapped so that its process joins this group before it starts (``exec``)."""
        return ["/bin/sh", "-c", 'echo $$ > "$0" && exec "$@"', str(self.path / "cgroup.procs"), *map(str, argv)]

    def add(self, pid: int) -> None:
        """Move a running process (all its threads) into this group."""
        (self.path / "cgroup.procs").write_text(str(int(pid)))

    def pids(self) -> list[int]:
        """The processes in this group now."""
        text = (self.path / "cgroup.procs").read_text()
        return [int(x) for x in text.split()]

    def settings(self) -> dict:
        """What the kernel holds for this group: period and quota (µs, -1: none) and shares."""
        read = lambda f: int((self.path / f).read_text())  # noqa: E731
        return {"period_us": read("cpu.cfs_period_us"), "quota_us": read("cpu.cfs_quota_us"),
                "shares": read("cpu.shares")}

    def stats(self) -> dict:
        """``cpu.stat``: nr_periods, nr_throttled, throttled_time (ns) as ints."""
        out = {}
        for line in (self.path / "cpu.stat").read_text().splitlines():
            key, _, value = line.partition(" ")
            if value.strip().lstrip("-").isdigit():
                out[key] = int(value)
        return out

    def describe(self) -> str:
        """"0.29 core (2900/10000 µs)" or "no quota"."""
        if self.fraction is None:
            return "no quota"
        return f"{self.fraction:g} core ({quota_us(self.fraction, self.period_us)}/{self.period_us} µs)"

    # ----------------------------------------------------------------------------------------
    def close(self) -> None:
        """Remove the group; processes still in it are moved back to the root group first."""
        if not self.path.exists():
            return
        try:
            for pid in self.pids():
                try:
                    (self.path.parent / "cgroup.procs").write_text(str(pid))
                except OSError:  # exited meanwhile
                    pass
        except OSError:
            pass
        self._remove()

    def _remove(self) -> None:
        try:
            self.path.rmdir()
        except FileNotFoundError:
            pass

    def __enter__(self) -> "CpuQuota":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def leftover_groups(root: Path = CPU_ROOT) -> list[Path]:
    """Groups this module made whose process has gone (an interrupted bench): safe to remove."""
    out = []
    for p in root.glob(f"{GROUP_PREFIX}*"):
        try:
            owner = int(p.name[len(GROUP_PREFIX):].split("-", 1)[0])
        except ValueError:
            continue
        if not Path(f"/proc/{owner}").exists():
            out.append(p)
    return out
