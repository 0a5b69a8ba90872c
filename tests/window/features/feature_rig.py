"""Helpers of the feature tests (their fixtures are in conftest.py beside this file): a shown
top-level widget holding a feature's page — no MainWindow."""
from PySide6 import QtWidgets

TIMEOUT_MS = 20_000


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
