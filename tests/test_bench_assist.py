"""The assistive rows of ``make bench`` are built (quick mode): every row has samples, the loop
rows are compared with the render baseline measured in the same frames."""
from bench import bench_assist

HUNG_S = 600.0  # a child still running after this long has hung (a loaded 2-core machine is slow, not broken)


def test_assist_rows_have_samples_and_a_baseline():
    rows = bench_assist.rows(quick=True)
    names = [r["name"] for r in rows]
    assert names[0] == bench_assist.BASELINE and len(rows) == 4
    for r in rows:
        assert r["samples"] and all(s > 0 for s in r["samples"]), r["name"]
    assert all(r["baseline"] == bench_assist.BASELINE for r in rows[1:])
    assert len(rows[1]["samples"]) == len(rows[3]["samples"])  # the chain timed on the same frames as the loop


def test_the_assist_window_child_samples_cpu_and_frames():
    from bench import bench_assist_window

    # the child starts sampling after its first frames and each sample waits for a frame, however slow a
    # loaded machine is; the time-out only ends a hung child
    r = bench_assist_window.measure("choosing", 1.0, timeout_s=HUNG_S)
    assert len(r["cpu_pct"]) == 1 and r["cpu_pct"][0] > 0
    assert r["frames_fps"][0] > 0  # the live view kept coming while the user chooses
