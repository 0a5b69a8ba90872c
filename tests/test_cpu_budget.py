"""core.cpu_budget: the CPUs a process may use under a cgroup quota, and OpenCV's pool sized to it."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from core.cpu_budget import cgroup_cpu_limit, fit_opencv_threads, usable_cpus

ROOT = Path(__file__).resolve().parents[1]


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def test_cgroup_v1_quota_is_the_smallest_from_the_group_up(tmp_path):
    proc = tmp_path / "cgroup"
    _write(proc, "12:memory:/a\n4:cpu,cpuacct:/outer/inner\n0::/\n")
    top = tmp_path / "fs" / "cpu,cpuacct"
    _write(top / "cpu.cfs_quota_us", "-1\n")
    _write(top / "cpu.cfs_period_us", "100000\n")
    _write(top / "outer" / "cpu.cfs_quota_us", "150000\n")  # 1.5 CPUs
    _write(top / "outer" / "cpu.cfs_period_us", "100000\n")
    _write(top / "outer" / "inner" / "cpu.cfs_quota_us", "2900\n")  # 0.29 of one (the Pi 4 budget)
    _write(top / "outer" / "inner" / "cpu.cfs_period_us", "10000\n")
    assert cgroup_cpu_limit(proc, tmp_path / "fs") == pytest.approx(0.29)
    _write(top / "outer" / "inner" / "cpu.cfs_quota_us", "-1\n")  # the parent's quota still holds
    assert cgroup_cpu_limit(proc, tmp_path / "fs") == pytest.approx(1.5)


def test_cgroup_v2_cpu_max_and_no_quota(tmp_path):
    proc = tmp_path / "cgroup"
    _write(proc, "0::/user.slice/app.scope\n")
    fs = tmp_path / "fs"
    _write(fs / "user.slice" / "cpu.max", "max 100000\n")
    _write(fs / "user.slice" / "app.scope" / "cpu.max", "54000 100000\n")
    assert cgroup_cpu_limit(proc, fs) == pytest.approx(0.54)
    _write(fs / "user.slice" / "app.scope" / "cpu.max", "max 100000\n")
    assert cgroup_cpu_limit(proc, fs) is None


@pytest.mark.parametrize("text", ["", "garbage", "1:cpu:/x\n", "0::/missing\n"])
def test_unreadable_or_missing_cgroup_files_mean_no_limit(tmp_path, text):
    proc = tmp_path / "cgroup"
    _write(proc, text)
    _write(tmp_path / "fs" / "cpu" / "x" / "cpu.cfs_quota_us", "not a number\n")
    assert cgroup_cpu_limit(proc, tmp_path / "fs") is None
    assert cgroup_cpu_limit(tmp_path / "no-such-file", tmp_path / "fs") is None


@pytest.mark.parametrize("limit, affinity, cpus", [
    (None, 4, 4), (0.29, 4, 1), (0.54, 4, 1), (1.16, 4, 1), (1.6, 4, 2), (3.0, 2, 2), (0.01, 1, 1)])
def test_usable_cpus_rounds_the_quota_and_never_exceeds_the_affinity(limit, affinity, cpus):
    assert usable_cpus(limit if limit is not None else float("nan"), affinity) == cpus  # nan: no quota


def test_the_users_opencv_thread_count_stands():
    assert fit_opencv_threads({"OPENCV_FOR_THREADS_NUM": "3"}) is None


def test_a_process_in_a_pi4_quota_gives_opencv_one_thread():
    """A real cgroup (bench.cpu_quota, as the Pi budget makes): the child sees its quota and the
    session's start-up gives OpenCV one thread; outside a quota OpenCV keeps its pool."""
    from bench.cpu_quota import CpuQuota, available

    why = available()
    if why:
        pytest.skip(why)
    code = ("import cv2; from core.cpu_budget import cgroup_cpu_limit, fit_opencv_threads; "
            "before = cv2.getNumThreads(); set_to = fit_opencv_threads({}); "
            "print(cgroup_cpu_limit(), before, set_to, cv2.getNumThreads())")
    for fraction in (0.29, None):
        with CpuQuota(fraction, "cpu-budget-test") as quota:
            out = subprocess.run(quota.command([sys.executable, "-c", code]), cwd=ROOT, capture_output=True,
                                 text=True, timeout=120)
        assert out.returncode == 0, out.stderr
        limit, before, set_to, after = out.stdout.split()
        if fraction is None:
            assert limit == "None" and set_to == "None" and after == before
        else:
            assert float(limit) == pytest.approx(0.29) and set_to == "1" and after == "1"
