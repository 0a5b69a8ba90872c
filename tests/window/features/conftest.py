"""Fixtures of the feature tests: a real session on the simulated desk and its workers (not
started unless a test starts one). Helpers are in feature_rig.py."""
import pytest

from app.workers import WorkerSet
from core.session import DeskSession, SessionOptions


@pytest.fixture
def session():
    s = DeskSession.create(SessionOptions(camera="sim", scenario="static", robot="desk_rrr"))
    yield s
    s.close()


@pytest.fixture
def workers(session):
    """The session's three workers, made but not started; any a test starts is stopped and joined."""
    w = WorkerSet(session)
    yield w
    for worker in (w.perception, w.control, w.bridge):
        if worker.isRunning():
            worker.stop()
        assert not worker.isRunning()
