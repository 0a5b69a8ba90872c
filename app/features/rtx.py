"""The UMI-RTX feature: its encoder initialisation, visible and stoppable, in the window.

``RtxFeature(session)`` does nothing for other arms (``page`` is None). On an ``rtx:`` bridge it
builds the ``RtxInitPanel`` (a progress bar per joint, Start / Cancel, the state) and runs
``RtxBridge.initialise`` in its own QThread (``RtxInitRunner``) when the user presses Start — only
then does the arm drive to its end stops. Until the bridge reports ready, motion is refused by
the bridge and the panel says why; after a controller restart the bridge marks its encoders lost
and the panel asks again. ``estop()`` (the window's STOP) cancels a running initialisation, which
stops every motor on both chips; ``poll()`` (the window's status tick) shows the bridge's state;
``stop()`` cancels and joins the thread before the window closes.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Optional

from PySide6 import QtCore

if TYPE_CHECKING:  # imported only for an RTX (start-up of every other arm)
    from app.rtx_init_worker import RtxInitRunner
    from widgets.rtx_init_panel import RtxInitPanel


def is_rtx_bridge(bridge) -> bool:
    return hasattr(bridge, "initialise") and hasattr(bridge, "init_reason")


class RtxFeature(QtCore.QObject):
    """The RTX initialisation panel of ``session``'s window (``page`` None for other bridges)."""

    sigReady = QtCore.Signal(bool)  # the encoders became ready (True) or were lost (False)

    def __init__(self, session, parent: Optional[QtCore.QObject] = None):
        super().__init__(parent)
        self.session = session
        self.page: Optional[RtxInitPanel] = None
        self.runner: Optional[RtxInitRunner] = None
        self._ready: Optional[bool] = None
        bridge = session.bridge
        if not is_rtx_bridge(bridge):
            return
        from app.rtx_init_worker import RtxInitRunner
        from widgets.rtx_init_panel import RtxInitPanel

        self.page = RtxInitPanel()
        self.runner = RtxInitRunner(bridge, self)
        self.page.sigStartRequested.connect(self.runner.start)
        self.page.sigCancelRequested.connect(self.runner.cancel)
        self.runner.sigProgress.connect(self.page.set_progress)
        self.runner.sigFinished.connect(self.on_finished)
        self.poll()

    @property
    def needs_init(self) -> bool:
        bridge = self.session.bridge
        return self.page is not None and not getattr(bridge, "ready", True)

    @QtCore.Slot(bool, str)
    def on_finished(self, ok: bool, text: str) -> None:
        self.poll()

    def poll(self) -> None:
        """Show the bridge's state (the window's status tick calls it)."""
        if self.page is None:
            return
        bridge = self.session.bridge
        ready = bool(getattr(bridge, "ready", False))
        self.page.set_state(ready, getattr(bridge, "init_reason", ""), bool(getattr(bridge, "initialising", False)))
        if ready != self._ready:
            self._ready = ready
            self.sigReady.emit(ready)

    def estop(self) -> None:
        """STOP: a running initialisation ends at once (the bridge stops every motor)."""
        if self.runner is not None:
            self.runner.cancel()

    def stop(self) -> None:
        if self.runner is not None:
            self.runner.stop()
