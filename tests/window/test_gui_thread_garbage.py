"""A running window collects Python's garbage only in the GUI thread, on a timer: the automatic
collector is off meanwhile (it could start in a camera thread and delete a Qt object there)."""
import gc

from app.startup import GuiThreadGarbage


def test_collections_run_on_the_gui_timer_and_stop_gives_the_collector_back(qtbot):
    from PySide6 import QtCore

    was_enabled = gc.isenabled()
    parent = QtCore.QObject()
    garbage = GuiThreadGarbage(parent, period_ms=10, full_every=3)
    try:
        assert not gc.isenabled()
        before = gc.get_stats()[2]["collections"]
        qtbot.waitUntil(lambda: garbage.collections >= 4, timeout=5_000)
        assert gc.get_stats()[2]["collections"] > before  # every 3rd tick is a full collection
    finally:
        garbage.stop()
    assert gc.isenabled()
    if not was_enabled:
        gc.disable()  # as tests/conftest.py runs Qt tests
