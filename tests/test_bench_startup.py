"""bench/bench_startup.py measures (one repetition, no timing asserts): finite times in order."""
import math

import pytest

from bench import bench_startup

HUNG_S = 600.0  # the children wait this long for the window and its first frame (a loaded machine is slow)


def test_one_repetition_gives_finite_ordered_times():
    m = bench_startup.measure(1, warmup=False, timeout_s=HUNG_S)
    for key in ("bare_window", "app_python", "app_visible", "app_window", "app_frame"):
        assert len(m[key]) == 1, key
        assert math.isfinite(m[key][0]) and m[key][0] > 0, (key, m[key])
    # the spawn comes first, then the interpreter, something on screen, the window, its first frame
    assert m["app_python"][0] <= m["app_visible"][0] <= m["app_window"][0] <= m["app_frame"][0]
    for key in ("app_import_app_gui", "app_session_create", "app_main_window_init"):
        assert m[key][0] is None or (math.isfinite(m[key][0]) and m[key][0] > 0), (key, m[key])
    # the session is timed also where app.cli imports it only when the run needs it
    assert m["app_session_create"][0] is not None


def test_rows_name_their_baseline(monkeypatch):
    fake = {"bare_window": [0.1, 0.2], "app_python": [0.03, 0.03], "app_visible": [0.5, 0.6],
            "app_window": [2.0, 2.1], "app_frame": [2.1, 2.2], "app_import_app_gui": [0.6, None],
            "app_session_create": [None, None], "app_main_window_init": [0.2, 0.2],
            "app_show_splash": [1.0, 1.0]}
    monkeypatch.setattr(bench_startup, "measure", lambda *a, **k: fake)
    rows = bench_startup.rows(quick=True)
    names = {r["name"] for r in rows}
    for r in rows:
        assert r["samples"] and all(math.isfinite(v) for v in r["samples"]), r
        assert r["baseline"] is None or r["baseline"] in names
    window = next(r for r in rows if "MainWindow shown" in r["name"])
    assert window["samples"] == [2000.0, 2100.0]
    assert "import app.gui 600 ms" in window["extra"] and "DeskSession.create n/a" in window["extra"]


def test_unknown_child_kind_is_refused():
    with pytest.raises(ValueError, match="allowed: app, bare"):
        bench_startup.run_child("nonsense")
