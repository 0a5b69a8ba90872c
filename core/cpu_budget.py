"""How many CPUs this process may really use, and OpenCV's thread pool sized to it.

OpenCV sizes its pool from the cores it sees (``cv2.getNumberOfCPUs``): the machine's, or its
affinity mask, but not the CPU quota of the process's own cgroup — a systemd unit's
``CPUQuota=``, a container's ``--cpus``, the Pi budget of ``bench.bench_pi``. Held to less than
one core, the pool's worker threads only add CPU: they spin waiting for work and wake for every
small ``parallel_for``. Measured on the recorded objects frames (``bench.bench_perception_loop``)
the desk detector's perception took 9.7-10.0 ms of CPU a frame with OpenCV's two threads and 7.7
with one, for the same wall time at a full core (markers 0.9 → 0.56, hsv 5.2 → 4.3).

``usable_cpus`` = the affinity mask's size, capped by every cgroup quota above the process
(cgroup v1 ``cpu.cfs_quota_us`` / ``cpu.cfs_period_us``, v2 ``cpu.max``, each level of the
hierarchy, the smallest wins), rounded to the nearest whole CPU and at least 1 (as Go's runtime
and the JVM size their pools in a container). ``fit_opencv_threads`` gives OpenCV that many
threads when it is fewer than OpenCV would take, unless the user chose (``OPENCV_FOR_THREADS_NUM``).
"""
from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Optional

__all__ = ["cgroup_cpu_limit", "usable_cpus", "fit_opencv_threads"]

CGROUP_ROOT = Path("/sys/fs/cgroup")
USER_THREADS_ENV = "OPENCV_FOR_THREADS_NUM"  # OpenCV's own override: the user's choice stands


def _read(path: Path) -> Optional[str]:
    try:
        return path.read_text().strip()
    except (OSError, UnicodeDecodeError):
        return None


def _v1_limit(directory: Path) -> Optional[float]:
    quota, period = _read(directory / "cpu.cfs_quota_us"), _read(directory / "cpu.cfs_period_us")
    try:
        q, p = int(quota), int(period)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None
    return q / p if q > 0 and p > 0 else None  # -1: no quota


def _v2_limit(directory: Path) -> Optional[float]:
    text = _read(directory / "cpu.max")  # "max 100000" or "29000 100000"
    if not text:
        return None
    parts = text.split()
    try:
        return int(parts[0]) / int(parts[1]) if parts[0] != "max" and int(parts[1]) > 0 else None
    except (IndexError, ValueError):
        return None


def _smallest_up(top: Path, relative: str, limit_of) -> Optional[float]:
    """The smallest limit from the group ``relative`` (under ``top``) up to ``top`` itself."""
    best = None
    directory = top / relative.strip("/") if relative.strip("/") else top
    while True:
        limit = limit_of(directory)
        if limit is not None:
            best = limit if best is None else min(best, limit)
        if directory == top or top not in directory.parents:
            return best
        directory = directory.parent


def cgroup_cpu_limit(proc_cgroup: Path = Path("/proc/self/cgroup"), root: Path = CGROUP_ROOT) -> Optional[float]:
    """The CPUs' worth of time the cgroups above this process allow (0.29: 29 % of one core);
    None when no quota applies or the files cannot be read."""
    text = _read(proc_cgroup)
    if not text:
        return None
    limits = []
    for line in text.splitlines():
        fields = line.split(":", 2)
        if len(fields) != 3:
            continue
        _, controllers, relative = fields
        if controllers == "":  # cgroup v2's unified hierarchy: "0::/path"
            limit = _smallest_up(root, relative, _v2_limit)
        elif "cpu" in controllers.split(","):  # v1: "4:cpu,cpuacct:/path" (mounted as cpu, cpuacct or both)
            limit = None
            for mount in (controllers, "cpu", "cpu,cpuacct"):
                if (root / mount).is_dir():
                    limit = _smallest_up(root / mount, relative, _v1_limit)
                    break
        else:
            continue
        if limit is not None:
            limits.append(limit)
    return min(limits) if limits else None


def usable_cpus(limit: Optional[float] = None, affinity: Optional[int] = None) -> int:
    """Whole CPUs this process can keep busy: the affinity mask capped by the cgroup quota
    (``limit``, read when None), rounded to the nearest whole CPU, at least 1."""
    if affinity is None:
        try:
            affinity = len(os.sched_getaffinity(0))
        except (AttributeError, OSError):
            affinity = os.cpu_count() or 1
    if limit is None:
        limit = cgroup_cpu_limit()
    cpus = max(1, affinity)
    if limit is not None and math.isfinite(limit) and limit > 0:
        cpus = min(cpus, max(1, int(limit + 0.5)))
    return cpus


def fit_opencv_threads(environ=os.environ) -> Optional[int]:
    """Give OpenCV's pool ``usable_cpus()`` threads when that is fewer than it has; the count set,
    or None when nothing changed (enough CPUs, or the user set ``OPENCV_FOR_THREADS_NUM``)."""
    if environ.get(USER_THREADS_ENV):
        return None
    import cv2

    cpus = usable_cpus()
    if cpus >= cv2.getNumThreads():
        return None
    cv2.setNumThreads(cpus)
    return cpus
