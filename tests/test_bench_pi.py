"""The Pi budget bench (bench/bench_pi.py, bench/cpu_quota.py): a cgroup v1 ``cpu`` group holds a
child to its quota from its first instruction (the kernel's own throttling counters say so), is
removed afterwards, and the children report what the table needs on a short run. No timing
asserts: figures belong in ``make bench``."""
import subprocess
import sys
from pathlib import Path

import pytest

from bench import bench_pi, cpu_quota

WHY = cpu_quota.available()
needs_cgroup = pytest.mark.skipif(bool(WHY), reason=f"no writable cgroup v1 cpu controller: {WHY}")


def test_quota_is_the_fraction_of_one_core_per_period_and_refuses_what_the_kernel_would():
    assert cpu_quota.quota_us(0.29, 10_000) == 2900
    assert cpu_quota.quota_us(1.0, 100_000) == 100_000
    with pytest.raises(ValueError, match="must be > 0"):
        cpu_quota.quota_us(0.0)
    with pytest.raises(ValueError, match="minimum quota"):
        cpu_quota.quota_us(0.05, 10_000)  # 500 µs: below the kernel's 1 ms


def test_the_pi_budgets_are_fractions_of_one_core_slower_for_the_pi_4():
    budgets = dict(bench_pi.PI_BUDGETS)
    assert budgets["unthrottled"] is None
    assert 0 < budgets["Pi 4"] < budgets["Pi 5"] < 1
    for fraction in (f for f in budgets.values() if f is not None):
        cpu_quota.quota_us(fraction)  # each one is a quota the kernel takes


@needs_cgroup
def test_a_wrapped_command_runs_inside_its_group_with_the_quota_set_and_the_group_is_removed_after():
    with cpu_quota.CpuQuota(0.29, "test group") as q:
        assert q.settings() == {"period_us": cpu_quota.PERIOD_US, "quota_us": 2900,
                                "shares": cpu_quota.DEFAULT_SHARES}
        out = subprocess.run(q.command([sys.executable, "-c", "print(open('/proc/self/cgroup').read())"]),
                             capture_output=True, text=True, check=True).stdout
        cpu_line = next(ln for ln in out.splitlines() if ln.split(":")[1] == "cpu")
        assert cpu_line.split(":", 2)[2] == "/" + q.path.name  # joined before python started
        path = q.path
        assert path.is_dir()
    assert not path.exists()


@needs_cgroup
def test_a_busy_child_over_its_quota_is_throttled_by_the_kernel_and_an_unlimited_one_is_not():
    busy = [sys.executable, "-c", "x = 0\nfor i in range(3_000_000): x += i"]  # ~0.1 s of one core here
    with cpu_quota.CpuQuota(0.1, "busy") as q:
        subprocess.run(q.command(busy), check=True)
        throttled = q.stats()
    assert throttled["nr_throttled"] > 0 and throttled["throttled_time"] > 0
    with cpu_quota.CpuQuota(None, "free") as q:
        assert q.settings()["quota_us"] == -1 and q.describe() == "no quota"
        subprocess.run(q.command(busy), check=True)
        assert q.stats()["nr_throttled"] == 0


@needs_cgroup
def test_closing_a_group_with_a_process_still_inside_moves_it_out_first():
    sleeper = subprocess.Popen([sys.executable, "-c", "import sys; sys.stdin.read()"], stdin=subprocess.PIPE)
    try:
        q = cpu_quota.CpuQuota(0.5, "leftover")
        q.add(sleeper.pid)
        assert q.pids() == [sleeper.pid]
        q.close()
        assert not q.path.exists()
        assert Path(f"/proc/{sleeper.pid}").exists()  # moved, not killed
    finally:
        sleeper.communicate(b"")


@needs_cgroup
def test_the_window_child_reports_first_frame_cpu_loop_rate_and_latency_and_rows_follow():
    w = bench_pi.measure_window("markers", None, 1.0)
    assert w["kind"] == "main" and not w["timed_out"]
    assert 0 < w["window_s"] <= w["first_frame_s"]
    assert len(w["cpu_pct"]) == len(w["loop_fps"]) == len(w["drawn_fps"]) == 1
    assert w["cpu_pct"][0] > 0 and w["loop_fps"][0] > 0
    assert w["latency_ms"] and all(x >= 0 for x in w["latency_ms"])  # the arm follows: commands carry frames
    h = bench_pi.measure_headless("markers", 0.54, 1.0)
    assert h["frames"] > 0 and h["fps"] > 0 and h["latency_ms_p50"] is not None
    assert h["throttled"]["nr_periods"] > 0  # it ran under the quota
    results = [{"case": "markers", "budget": "unthrottled", "fraction": None, "window": w, "headless": h, "load": 1.0},
               {"case": "markers", "budget": "Pi 4", "fraction": 0.29, "window": w, "headless": h, "load": 1.0}]
    rows = bench_pi.results_to_rows(results)
    names = {r["name"] for r in rows}
    assert all(r["baseline"] in names for r in rows if r["baseline"])  # each budget against its unthrottled run
    assert {"pi markers, Pi 4: loop fps (window)", "pi markers, Pi 4: start-up to first frame",
            "pi markers, Pi 4: loop fps (headless)"} <= names
    table = bench_pi.pi_table(results)
    assert "Pi 4" in table and "first frame" in table


@needs_cgroup
def test_the_assistive_view_child_reports_its_hand_camera_frames():
    w = bench_pi.measure_window("assist", 0.54, 1.0)
    assert w["kind"] == "assist" and w["first_frame_s"] > 0
    assert w["loop_fps"][0] > 0 and w["latency_ms"] == []
    assert w["throttled"]["nr_periods"] > 0


def test_a_machine_without_a_cpu_controller_skips_the_bench_like_a_missing_extra(monkeypatch, tmp_path):
    monkeypatch.setattr(cpu_quota, "CPU_ROOT", tmp_path)  # an empty folder: no cpu.cfs_quota_us
    monkeypatch.setattr(cpu_quota.available, "__defaults__", (tmp_path,))
    assert "cpu.cfs_quota_us is missing" in cpu_quota.available()
    with pytest.raises(ImportError, match="pi budget bench unavailable"):  # make bench's OPTIONAL rule
        bench_pi.rows(quick=True)
    with pytest.raises(cpu_quota.CpuQuotaError):
        cpu_quota.CpuQuota(0.5, root=tmp_path)


def test_replay_cases_name_their_recording_and_the_table_says_which_camera_each_row_had():
    assert bench_pi.source_of("hsv") == "sim" and bench_pi.source_of("hsv-replay") == "replay"
    assert bench_pi.source_of("assist") == "hand sim"
    argv = bench_pi.case_argv("desk-replay", Path("/tmp/rec"))
    assert argv[argv.index("--camera") + 1] == "replay:/tmp/rec" and "--detector" in argv
    with pytest.raises(ValueError, match="make one first"):
        bench_pi.case_argv("hsv-replay")
    assert bench_pi.case_argv("hsv") == bench_pi.ALL_CASES["hsv"]
    with pytest.raises(ValueError, match="unknown"):
        bench_pi.measure_all(cases=["hsv-webcam"])


@needs_cgroup
def test_a_replay_case_runs_on_a_recording_made_in_the_same_run(tmp_path):
    """The replay cases stand for webcams: a recording of the objects scene, made first, is what
    the headless loop and the window read (JPEG pairs decoded instead of renders)."""
    recording = tmp_path / "objects"
    made = bench_pi.make_recording(recording, 25.0)  # outlasts the window's start-up, warm-up and sample
    assert made["frames_recorded"] > 0 and recording.is_dir()
    h = bench_pi.measure_headless("hsv-replay", None, 1.0, recording=recording)
    assert h["frames"] > 0 and h["fps"] > 0
    w = bench_pi.measure_window("hsv-replay", None, 1.0, recording=recording)
    assert w["kind"] == "main" and w["loop_fps"][0] > 0
    results = [{"case": "hsv-replay", "budget": "unthrottled", "fraction": None, "window": w, "headless": h,
                "load": 1.0, "source": "replay"}]
    table = bench_pi.pi_table(results)
    assert "replay" in table.splitlines()[2] and "camera" in table.splitlines()[0]


def test_repeated_window_runs_pool_their_samples_and_the_table_lists_each_runs_median():
    def run(fps, first):
        return {"kind": "main", "timed_out": False, "window_s": 1.0, "first_frame_s": first, "loop_fps": fps,
                "drawn_fps": [5.0] * len(fps), "latency_ms": [20.0], "cpu_pct": [29.0] * len(fps),
                "gui_pct": [8.0] * len(fps), "throttled": {"nr_periods": 100, "nr_throttled": 60}}

    runs = [run([10.0, 12.0, 11.0], 3.1), run([17.0, 18.0, 16.0], 2.9), run([15.0, 15.0, 16.0], 3.5)]
    pooled = bench_pi.pool_runs(runs)
    assert pooled["loop_fps"] == [10.0, 12.0, 11.0, 17.0, 18.0, 16.0, 15.0, 15.0, 16.0]
    assert pooled["run_fps"] == [11.0, 17.0, 15.0] and pooled["first_frame_s"] == 3.1
    assert pooled["throttled"] == {"nr_periods": 300, "nr_throttled": 180}
    assert bench_pi.pool_runs(runs[:1]) is runs[0]  # one run: as it was
    results = [{"case": "desk", "budget": "Pi 4", "fraction": 0.29, "window": pooled, "headless": None, "load": 1.0}]
    table = bench_pi.pi_table(results)
    assert "runs' loop fps 11.0 17.0 15.0; first frame 3.10 2.90 3.50 s" in table
    assert " 15.0 " in table.splitlines()[2] and "15 fps met" in table  # the pooled median
