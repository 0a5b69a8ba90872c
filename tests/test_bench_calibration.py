"""bench/bench_calibration.py's disparity rows time the matcher itself (no timing asserts but > 0):
``DisparityComputer.compute`` returns its cached result for the same image objects, which made
every row print 0.000 ms; each timed call must run the matcher."""
from bench import bench_calibration
from core.vision.disparity import DisparityComputer


def test_every_timed_disparity_call_runs_the_matcher_and_takes_time(monkeypatch):
    calls = []
    real = DisparityComputer._compute

    def counted(self, left, right):
        calls.append(self)  # kept alive: no two computers share an entry
        return real(self, left, right)

    monkeypatch.setattr(DisparityComputer, "_compute", counted)
    rows = bench_calibration.stereo_rows(quick=True, sizes=((320, 240),))
    assert [r["name"] for r in rows][0] == "disparity 320x240 SGBM mode SGBM"
    for r in rows:
        assert len(r["samples"]) == 5 and all(s > 0 for s in r["samples"]), r
        assert f"{min(r['samples']):.3f}" != "0.000", r  # what the table prints
    # per variant: the warm-up and the 5 timed calls ran the matcher (the depth check may hit the cache)
    per_matcher = {id(k): sum(c is k for c in calls) for k in calls}
    assert len(per_matcher) == len(rows) and all(v >= 6 for v in per_matcher.values()), per_matcher
