"""Assertion helpers shared by the test modules (tests/ is on sys.path, like host_board)."""
import numpy as np


def assert_close(actual, expected, tol, what=""):
    """Fail, printing both values and the gap, when ``actual`` and ``expected`` differ by > tol."""
    a = np.asarray(actual, dtype=float)
    e = np.asarray(expected, dtype=float)
    gap = float(np.max(np.abs(a - e))) if a.size else 0.0
    assert a.shape == e.shape and gap <= tol, (
        f"{what}: |actual - expected| = {gap:.3g} > {tol:.3g}\n  actual   = {a.tolist()}\n"
        f"  expected = {e.tolist()}"
    )
