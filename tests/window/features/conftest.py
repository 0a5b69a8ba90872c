"""Shared set-up of the feature tests: a real session on the simulated desk, its workers (not
started unless a test starts one), and a shown top-level widget holding a feature's page — no
MainWindow."""
import pytest
from PySide6 import QtWidgets

from app.workers import WorkerSet
from core.session import DeskSession, SessionOptions

TIMEOUT_MS = 20_000


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


def show_page(qtbot, *widgets, size=(400, 480)) -> QtWidgets.QWidget:
    """A shown top-level widget with ``widgets`` stacked in it (a feature's page and its helpers)."""
    host = QtWidgets.QWidget()
    layout = QtWidgets.QVBoxLayout(host)
    for w in widgets:
        if isinstance(w, QtWidgets.QLayout):
            layout.addLayout(w)
        else:
            layout.addWidget(w)
    qtbot.addWidget(host)
    host.resize(*size)
    host.show()
    qtbot.waitExposed(host)
    return host
