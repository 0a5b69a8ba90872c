"""The e-stop feature: STOP, RE-ARM, the StopGuard, dialogs that show the e-stop state, and the
arm's pause while a modal dialog without STOP is open.

``EStopFeature`` owns STOP (``estop_button``, fixed size, in the window's STOP strip), RE-ARM
(``rearm_button``, shown only while stopped, acts after a 1 s hold) and the StopGuard (a press
on STOP's area or Esc stops over every popup and dialog). ``set_engaged`` is the one place the
controller is stopped or re-armed; every open dialog registered with ``add_dialog`` (help,
recordings, wizards: anything with ``set_estop``) follows it, and so does the bridge.

Signals (GUI thread): ``sigStopRequested()`` — STOP tapped, Esc, or a registered dialog's STOP;
``sigRearmRequested()`` — RE-ARM held long enough.
"""
from __future__ import annotations

from PySide6 import QtCore, QtWidgets

from widgets._style import TOUCH_PX
from widgets.estop import EStopButton, RearmButton, StopGuard

MODAL_PAUSE = "a dialog is open"  # ArmController.pause reason while a modal dialog without STOP is up
STOP_STRIP_HEIGHT_PX = TOUCH_PX + 8  # the strip STOP sits in: its height never changes
STOP_WIDTH_PX = 150  # STOP's fixed width ("STOPPED" fits; wider than a fingertip by three)


class EStopFeature(QtCore.QObject):
    """STOP and RE-ARM for ``session``'s arm; ``window``: the top-level window STOP guards."""

    sigStopRequested = QtCore.Signal()
    sigRearmRequested = QtCore.Signal()

    def __init__(self, session, bridge_worker, window: QtWidgets.QWidget):
        super().__init__(window)
        self.session = session
        self.bridge_worker = bridge_worker  # request_estop(bool); None: no bridge (tests)
        self.window = window
        self.dialogs: list = []  # open dialogs that show the e-stop state (set_estop)
        self.rearm_button = RearmButton()  # only while stopped; acts after a 1 s hold
        self.rearm_button.sigHeld.connect(self.sigRearmRequested)
        self.rearm_button.hide()
        self.estop_button = EStopButton()
        self.estop_button.setFixedSize(self.estop_button.sizeHint().expandedTo(
            QtCore.QSize(STOP_WIDTH_PX, STOP_STRIP_HEIGHT_PX)))
        self.estop_button.sigStopRequested.connect(self.sigStopRequested)
        # a press on STOP's area stops over every popup, list, tooltip and dialog; Esc stops in
        # every window; nothing covers STOP; the keys come back after a dialog with no window manager
        self.stop_guard = StopGuard(self.estop_button, window)
        self.stop_guard.sigStopRequested.connect(self.sigStopRequested)

    @property
    def engaged(self) -> bool:
        return not self.session.controller.armed

    def add_dialog(self, dialog) -> None:
        """A dialog with its own STOP (``sigStopRequested``) that shows the e-stop state (``set_estop``)."""
        if dialog in self.dialogs:
            return
        self.dialogs.append(dialog)
        signal = getattr(dialog, "sigStopRequested", None)
        if signal is not None:
            signal.connect(self.sigStopRequested)
        dialog.set_estop(self.engaged)

    def set_engaged(self, engaged: bool) -> None:
        """Stop (the control worker refuses commands, the bridge stops the arm) or re-arm; STOP,
        RE-ARM and every registered dialog show it."""
        if engaged:
            self.session.controller.estop()
        else:
            self.session.controller.rearm()
        self.estop_button.set_engaged(engaged)
        self.rearm_button.setVisible(engaged)
        for dialog in self.dialogs:
            dialog.set_estop(engaged)
        if self.bridge_worker is not None:
            self.bridge_worker.request_estop(engaged)

    def check_modal_dialog(self) -> bool:
        """Pause the arm while a modal dialog without its own STOP is open (a file dialog, a
        message box): it may cover STOP on a small screen. Dialogs that carry STOP and show
        the e-stop state (``set_estop``: the calibration wizard, help) do not pause it. True when
        the pause began or ended now."""
        modal = QtWidgets.QApplication.activeModalWidget()
        blocking = modal is not None and modal is not self.window and not hasattr(modal, "set_estop")
        controller = self.session.controller
        if blocking == (MODAL_PAUSE in controller.paused_by):
            return False
        if blocking:
            controller.pause(MODAL_PAUSE)
        else:
            controller.resume(MODAL_PAUSE)
        return True

    def remove(self) -> None:
        """The window closes: the StopGuard's filters go."""
        self.stop_guard.remove()
