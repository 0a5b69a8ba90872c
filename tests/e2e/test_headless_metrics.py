"""Headless metrics stay bounded on a run of any length; --duration must be a finite positive time."""
from __future__ import annotations

import json
import math
import random

import numpy as np
import pytest

import app.headless as headless
from app.cli import main
from app.headless import HeadlessRunner, Reservoir, RunMetrics, check_duration, run_headless
from core.session import DeskSession, SessionOptions

PER_FRAME = ("perception_ms", "latency_ms", "error_3d_mm", "reach_error_mm")


def test_a_reservoir_keeps_at_most_its_capacity_and_its_percentiles_stay_accurate():
    rng = random.Random(7)
    values = [rng.lognormvariate(0.0, 0.5) for _ in range(200_000)]  # a skewed, latency-like spread
    kept = Reservoir(capacity=20_000, seed=1)
    for v in values:
        kept.append(v)
    assert len(kept) == 20_000 and kept.seen == 200_000
    for q in (50, 95, 99):
        exact = float(np.percentile(values, q))
        # the quantile of 20,000 uniform draws: within ~0.3 percentile points, far inside 3 %
        assert float(np.percentile(kept, q)) == pytest.approx(exact, rel=0.03), q


def test_a_reservoir_is_every_sample_until_full_and_a_list_for_numpy_and_json():
    kept = Reservoir(capacity=5, seed=0)
    kept.extend([1.0, 2.0, 3.0])
    kept += [4.0]
    assert kept == [1.0, 2.0, 3.0, 4.0] and isinstance(kept, list)
    kept.extend(range(100))
    assert len(kept) == 5 and kept.seen == 104
    assert json.loads(json.dumps(kept)) == list(kept)
    assert np.asarray(kept, dtype=float).shape == (5,)


def test_the_same_seed_keeps_the_same_samples():
    a, b = Reservoir(10, seed=3), Reservoir(10, seed=3)
    for k in range(1000):
        a.append(k)
        b.append(k)
    assert a == b


def test_run_metrics_per_frame_samples_are_bounded_and_the_summary_keeps_its_keys():
    m = RunMetrics(scenario="static")
    before = set(m.summary())
    for k in range(3 * headless.MAX_SAMPLES):
        for name in PER_FRAME:
            getattr(m, name).append(float(k % 1000))
    for name in PER_FRAME:
        samples = getattr(m, name)
        assert len(samples) == headless.MAX_SAMPLES and samples.seen == 3 * headless.MAX_SAMPLES
    s = m.summary()
    assert set(s) == before
    assert s["latency_ms_p50"] == pytest.approx(500.0, abs=15.0)  # uniform 0…999
    assert s["perception_ms_p95"] == pytest.approx(950.0, abs=15.0)


def test_a_long_run_keeps_no_more_samples_than_the_cap(monkeypatch):
    # a soak in miniature: the caps are hit within seconds (raising=False: the test also runs
    # against code without a cap, where it must fail on the lengths)
    monkeypatch.setattr(headless, "MAX_SAMPLES", 40, raising=False)
    session = DeskSession.create(SessionOptions(camera="sim", scenario="wander", simulated_clock=True))
    m = HeadlessRunner(session, 6.0).run()
    assert m.frames > 150
    for name in PER_FRAME:
        assert len(getattr(m, name)) <= 40, name
    assert m.latency_ms.seen > 40 and m.error_3d_mm.seen > 40  # the caps were hit
    s = m.summary()
    assert s["error_3d_mm_p95"] <= 3.0 and s["limit_violations"] == 0


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, 0.0, -1.0])
def test_a_duration_that_is_not_a_finite_positive_time_is_refused_naming_the_option(bad):
    with pytest.raises(ValueError, match=r"--duration .* a finite number of seconds > 0"):
        check_duration(bad)
    session = DeskSession.create(SessionOptions(camera="sim", scenario="static", simulated_clock=True))
    try:
        with pytest.raises(ValueError, match="--duration"):
            HeadlessRunner(session, bad)
    finally:
        session.close()


def test_run_headless_refuses_a_nan_duration_before_opening_anything(monkeypatch):
    def no_session(options):
        raise AssertionError("a session was created for a run that cannot run")

    monkeypatch.setattr(DeskSession, "create", staticmethod(no_session))
    with pytest.raises(ValueError, match=r"--duration nan is outside the valid range"):
        run_headless(SessionOptions(camera="sim", simulated_clock=True), math.nan, as_json=True)


def test_the_cli_with_duration_nan_fails_with_one_line_naming_it(capsys):
    code = main(["--headless", "--camera", "sim", "--fast", "--duration", "nan", "--json"])
    captured = capsys.readouterr()
    assert code == 2  # a usage error, like every other bad option
    err = captured.err.strip()
    assert "--duration nan" in err and "finite" in err and "\n" not in err
    assert "{" not in captured.out  # no summary of a run that did not happen
