"""Runs a UMI-RTX's encoder initialisation in a QThread for the window (``RtxInitPanel``).

``RtxInitRunner(bridge)`` lives in the GUI thread; ``start()`` runs ``bridge.initialise`` in its
own QThread. Signals (emitted from the worker thread; connect them to slot methods of GUI-thread
QObjects, e.g. ``RtxInitPanel.set_progress``, so they run in the GUI thread):

- sigProgress(object): each ``core.devices.rtx_bridge.InitProgress``.
- sigFinished(bool, str): done — True when the arm is ready; else why not (stopped, refused, lost).

``cancel()`` ends the initialisation at its next poll (tens of ms); the bridge then stops every
motor. ``stop()`` cancels and joins the thread (call it before the window closes).
"""
from __future__ import annotations

import threading

from PySide6 import QtCore


class _InitThread(QtCore.QThread):
    """A QThread that runs one function."""

    def __init__(self, fn):
        super().__init__()
        self._fn = fn

    def run(self) -> None:
        self._fn()


class RtxInitRunner(QtCore.QObject):
    """One initialisation at a time, in a QThread (see the module docstring)."""

    sigProgress = QtCore.Signal(object)
    sigFinished = QtCore.Signal(bool, str)

    def __init__(self, bridge, parent: QtCore.QObject | None = None):
        super().__init__(parent)
        self.bridge = bridge
        self._cancel = threading.Event()
        self._thread: QtCore.QThread | None = None

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.isRunning()

    def start(self) -> bool:
        """Start the initialisation; False when one is already running."""
        if self.running:
            return False
        self._cancel.clear()
        thread = _InitThread(self._run)  # runs the function; no QObject moves threads
        self._thread = thread
        thread.start()
        return True

    def _run(self) -> None:
        from core.devices.bridge import BridgeError
        from core.devices.rtx_bridge import InitCancelled

        try:
            self.bridge.initialise(progress=self.sigProgress.emit, cancel=self._cancel)
        except InitCancelled:
            self.sigFinished.emit(False, "initialisation stopped: every motor stopped; initialise again")
        except BridgeError as exc:
            self.sigFinished.emit(False, f"initialisation failed: {exc}")
        else:
            self.sigFinished.emit(True, "initialised: the arm is ready")

    @QtCore.Slot()
    def cancel(self) -> None:
        """Stop the running initialisation (every motor stops)."""
        self._cancel.set()

    def stop(self, timeout_ms: int = 10000) -> None:
        """Cancel and join the worker thread."""
        self._cancel.set()
        if self._thread is not None:
            self._thread.wait(timeout_ms)
            self._thread = None
