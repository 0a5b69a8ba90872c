"""The assistive view's input modes: the mode buttons and the scan period in the side column, and
the choosing they drive — a tap in touch mode, the highlight moved by "next" and chosen by
"confirm" with two switches, the timed highlight and its one switch (``core.motion.scanning``
holds the state machines; this module feeds them and shows their answers in the view)."""
from __future__ import annotations

from typing import Callable, Optional

from PySide6 import QtCore, QtGui, QtWidgets

from app.assist.settings import MODE_NAMES, MODES, AssistSettings
from core.motion.scanning import MAX_PERIOD_S, MIN_PERIOD_S, OneSwitchScanner, TouchSelector, TwoSwitchScanner
from widgets._style import BUTTON_STYLE, SPIN_STYLE


class ChoiceModes(QtCore.QObject):
    """The mode buttons, the scan period and the scanner of the current mode.

    Signals (GUI thread):
    - sigModeChosen(str): a mode button was clicked ("touch", "scan2", "scan1")
    - sigPeriodChanged(float): the 1-switch scan period was changed (s)

    ``view``: the ``AssistView`` (its highlight and the brief "not a button"); ``choosing()``: True
    while a choice may be made; ``choose(index)``: a box was chosen; ``highlight_moved(index)``: the
    highlight moved on by a switch or the timer (for the sound cue); ``clock``: the scan's time (s).
    """

    sigModeChosen = QtCore.Signal(str)
    sigPeriodChanged = QtCore.Signal(float)

    def __init__(self, view, choosing: Callable[[], bool], choose: Callable[[int], None],
                 highlight_moved: Callable[[int], None], clock: Callable[[], float], font: QtGui.QFont,
                 period_s: float, parent: Optional[QtCore.QObject] = None):
        super().__init__(parent)
        self.view = view
        self._choosing = choosing
        self._choose = choose
        self._highlight_moved = highlight_moved
        self._clock = clock
        self.scanner = None  # TwoSwitchScanner or OneSwitchScanner while a scan runs
        self.ignored_taps = 0  # taps beside every box (touch mode)
        self.buttons: dict[str, QtWidgets.QPushButton] = {}
        self.group = QtWidgets.QButtonGroup(self)
        self.group.setExclusive(True)
        for mode in MODES:
            b = QtWidgets.QPushButton(MODE_NAMES[mode])
            b.setCheckable(True)
            b.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)
            b.setStyleSheet(BUTTON_STYLE)
            b.setFont(font)
            b.clicked.connect(lambda _=False, m=mode: self.sigModeChosen.emit(m))
            self.group.addButton(b)
            self.buttons[mode] = b
        self.period_spin = QtWidgets.QDoubleSpinBox()
        self.period_spin.setRange(MIN_PERIOD_S, MAX_PERIOD_S)
        self.period_spin.setSingleStep(0.5)
        self.period_spin.setDecimals(1)
        self.period_spin.setPrefix("every ")  # the 1-switch scan period (no label: room for the hint)
        self.period_spin.setSuffix(" s")
        self.period_spin.setValue(period_s)
        self.period_spin.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)
        self.period_spin.setStyleSheet(SPIN_STYLE)
        self.period_spin.setFont(font)
        self.period_spin.valueChanged.connect(self.sigPeriodChanged.emit)

    def widgets(self) -> list[QtWidgets.QWidget]:
        """The side column's widgets, top to bottom."""
        return [*self.buttons.values(), self.period_spin]

    def show_mode(self, mode: str) -> None:
        """Check ``mode``'s button; the period is editable in the 1-switch mode only."""
        self.buttons[mode].setChecked(True)
        self.period_spin.setEnabled(mode == "scan1")

    def show_period(self, period_s: float) -> None:
        if abs(self.period_spin.value() - period_s) > 1e-9:
            self.period_spin.setValue(period_s)

    def restart(self, settings: AssistSettings, n_boxes: int) -> None:
        """The scan starts over on ``n_boxes`` boxes (none while no choice may be made, or in touch mode)."""
        self.cancel()
        if not self._choosing() or settings.mode == "touch":
            return
        if settings.mode == "scan2":
            self.scanner = TwoSwitchScanner(n_boxes)
            self.view.set_highlight(0)
        else:
            self.scanner = OneSwitchScanner(n_boxes, settings.scan_period_s, settings.long_press_s)
            self.view.set_highlight(self.scanner.start(self._clock()).index)

    def cancel(self) -> None:
        """No scan (a box was chosen, or STOP): no highlight."""
        self.scanner = None
        self.view.set_highlight(None)

    def press(self, role: str, now: float) -> None:
        """A switch with ``role`` went down: the one switch marks the box highlighted now."""
        if role == "single" and isinstance(self.scanner, OneSwitchScanner):
            self._events(self.scanner.press(now))

    def release(self, role: str, now: float, held_long: bool) -> None:
        """A switch with ``role`` came up (``held_long``: its hold already stopped or re-armed, so
        it does nothing else): "next" moves the highlight, "confirm" and a short single press choose."""
        scanner = self.scanner
        if isinstance(scanner, OneSwitchScanner) and role == "single":
            events = scanner.release(now)
            if not held_long:
                self._events(events)
            return
        if held_long or not self._choosing() or not isinstance(scanner, TwoSwitchScanner):
            return
        if role == "next":
            self._moved(scanner.next(now).index)
        elif role == "confirm":
            self._choose(scanner.confirm(now).index)

    def tick(self, now: float) -> None:
        """The timed scan moves on (the 1-switch mode, while a choice may be made)."""
        if isinstance(self.scanner, OneSwitchScanner) and self._choosing():
            self._events(self.scanner.tick(now))

    def tap(self, image_point: Optional[tuple[float, float]], box: Optional[int], hit_boxes: list) -> None:
        """Touch mode: a tap at an image point (None: beside the image); ``box``: the box the view
        found under the tap (its outline or its number badge — one target), which is then chosen;
        ``hit_boxes``: the boxes as drawn."""
        if not self._choosing():
            if image_point is not None:
                self.view.acknowledge(image_point)
            return
        if box is not None and 0 <= box < len(hit_boxes):
            self._choose(box)
            return
        if image_point is None:
            self.ignored_taps += 1
            return
        event = TouchSelector(hit_boxes).tap(image_point[0], image_point[1], self._clock())
        if event.kind == "select":
            self._choose(event.index)
        else:
            self.ignored_taps += 1
            self.view.acknowledge(image_point)

    def _moved(self, index: int) -> None:
        self.view.set_highlight(index)
        self._highlight_moved(index)

    def _events(self, events) -> None:
        for event in events:
            if event.kind == "highlight":
                self._moved(event.index)
            elif event.kind == "select":
                self._choose(event.index)
            # "stop": the switch input's hold does it, the same for every switch mode
