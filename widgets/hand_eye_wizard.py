"""The camera → arm calibration wizard (hand-eye, eye-to-hand): method → run → result.

A view only: it owns no thread and no calibration logic. The app starts the procedure when
``sigStartRequested`` arrives, feeds the run page (``show_live``, ``set_progress``,
``set_phase``, ``set_points_recorded``) and hands over the outcome (``show_result``); this
widget turns taps into requests. Three pages:

1. Method — automatic sweep (the arm visits N poses with a marker on its tool), touch points
   (the user jogs the tool onto 4 or more desk markers and records each), planar map (one camera
   looking down at the desk).
2. Run — the live camera view with the detected markers, the phase in plain words (moving /
   settling / sampling / skipped pose), the step (which pose) under it — never the same line
   twice —, progress, Cancel, and for touch points "Record this point" with the count so far.
3. Result — the verdict in one line (green when calibrated, red with the fix when not), the
   per-pose residuals as bars (the worst red, rejected grey), the warnings, Save and use, Run
   again.

The result is duck-typed (core/handeye's result object): ``ok``, ``problem``, ``method``,
``poses_used``, ``residuals_mm``, ``rms_mm``, ``max_mm``, ``worst_index``, ``rejected``,
``warnings`` and optionally ``translation_error_mm`` / ``rotation_error_deg`` (the simulated
desk's truth). ``worst_index`` and ``rejected`` are 0-based indices into ``residuals_mm``; the
user sees pose numbers from 1. A result without ``worst_index``, ``poses_used``, ``rejected`` or
``warnings`` (core/handeye's PlanarMap) gets them from its residuals; NaN residuals (a failed
fit) draw no bar.

Usable on a 800×480 touch screen (full screen there, every target ≥ 44 px, nothing below the
fold) and on desktops. During a sweep the arm moves by itself while the wizard may cover the
window's STOP, so the wizard carries its own STOP above every page and takes Esc as STOP,
never as "close"; it never re-arms.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from PySide6 import QtCore, QtWidgets

from widgets._pyqtgraph import pg
from widgets._style import (
    show_adaptive,
    ACCENT_COLOUR,
    ERROR_COLOUR,
    INFO_COLOUR,
    OK_COLOUR,
    TOUCH_PX,
    WARN_COLOUR,
    TouchDoubleSpinBox,
    touch_button,
    touch_scroll_area,
)
from widgets.camera_view import CameraView, MarkerOverlay
from widgets._plots import static_bar_plot
from widgets.estop import StopDialog
from widgets.help_dialog import EStopStrip
from widgets._style import bold_label as _bold

PAGES = ("method", "run", "result")
NAME = "Camera → arm calibration"  # what the window's button, this dialog and its messages call it
PAGE_TITLES = ("Camera → arm · 1 Method", "Camera → arm · 2 Run", "Camera → arm · 3 Result")
MIN_TOUCH_POINTS = 4  # markers the touch-point and planar methods need at least
# the methods, as sigStartRequested names them, with their two-line button texts
METHODS = ("sweep", "touch_points", "planar")
METHOD_TEXTS = {
    "sweep": "Automatic sweep\narm moves, tool marker on the tool",
    "touch_points": f"Touch points\njog the tool tip onto {MIN_TOUCH_POINTS} or more markers on the desk",
    "planar": "Planar map\none camera looking down",
}
METHOD_NAMES = {"sweep": "Automatic sweep", "touch_points": "Touch points", "planar": "Planar map"}
METHOD_HELP = {
    "sweep": "The arm visits the poses by itself and the cameras find the marker on its tool at each one. "
             "Clear the desk around the arm; STOP stops it at any time.",
    "touch_points": "Jog the tool tip onto the centre of each desk marker in turn and tap "
                    "'Record this point'. Spread at least 4 markers over the area the arm works in.",
    "planar": "One camera looks straight down at the desk: desk markers at known places map "
              "image pixels to the desk plane. The arm does not move.",
}
# what to do when a method failed and the problem does not say it already
METHOD_FIX = {
    "sweep": "check that the tool marker is seen in most poses (light, focus, marker size), then run again "
             "with more poses",
    "touch_points": "record at least 4 points on markers spread over the desk, each with the tool tip "
                    "exactly on the marker's centre",
    "planar": "make sure the camera looks down at the whole desk and sees at least 4 markers",
}
N_POSES_RANGE = (4, 40)
N_POSES_DEFAULT = 12
LIVE_REDRAW_MS = 15
CHOICE_PX = 64  # the method buttons: two lines of text, big targets
CHOICE_STYLE = f"""
QPushButton {{
    min-height: {CHOICE_PX}px; text-align: left; padding: 4px 14px; font-size: 12pt;
    border: 2px solid #9e9e9e; border-radius: 6px; background: #f4f4f4; color: black;
}}
QPushButton:checked {{ background: {ACCENT_COLOUR}; color: white; border: 2px solid #245ea8; }}
"""
RECORD_STYLE = f"""
QPushButton {{
    min-height: {TOUCH_PX + 12}px; font-size: 12pt; font-weight: bold; color: white;
    background: {OK_COLOUR}; border: 2px solid #1b5e20; border-radius: 6px; padding: 0 12px;
}}
QPushButton:pressed {{ background: #1b5e20; }}
QPushButton:disabled {{ background: #bdbdbd; color: #6d6d6d; border: 2px solid #9e9e9e; }}
"""
TOUCH_WAITING_TEXT = "jog the tool tip onto the centre of a desk marker (Target tab), then tap Record this point"
# phase → (colour level, default text)
PHASES = {
    "moving": ("info", "moving to the next pose …"),
    "settling": ("info", "settling: waiting for the arm to stand still …"),
    "sampling": ("ok", "sampling: measuring the marker …"),
    "skipped": ("warn", "skipped pose: the tool marker was not seen"),
    "waiting": ("info", "waiting for the cameras …"),
}
USED_COLOUR = "#3a7bd5"
WORST_COLOUR = ERROR_COLOUR
REJECTED_COLOUR = "#a0a0a0"


def _status_style(level: str) -> str:
    colour = {"ok": OK_COLOUR, "warn": WARN_COLOUR, "error": ERROR_COLOUR, "info": INFO_COLOUR}[level]
    return (f"QLabel {{ background: {colour}; color: white; font-weight: bold; padding: 4px 8px;"
            f" border-radius: 3px; }}")


def _short(path: str, keep: int = 2) -> str:
    """The last ``keep`` parts of a path, after "…/" when there are more (full paths go in tooltips)."""
    parts = [p for p in str(path).replace("\\", "/").split("/") if p]
    return str(path) if len(parts) <= keep else "…/" + "/".join(parts[-keep:])


def _finite(value) -> float | None:
    """``value`` as a float, or None when it is None, NaN or infinite."""
    if value is None:
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def worst_index(result) -> int:
    """The result's ``worst_index``; without one (a planar map), the largest finite residual
    among the poses not rejected; -1 when there is none."""
    worst = getattr(result, "worst_index", None)
    if worst is not None:
        return int(worst)
    rejected = {int(k) for k in (getattr(result, "rejected", None) or ())}
    candidates = [(v, k) for k, r in enumerate(getattr(result, "residuals_mm", None) or ())
                  if k not in rejected and (v := _finite(r)) is not None]
    return max(candidates)[1] if candidates else -1


def poses_used(result) -> int:
    """The result's ``poses_used``; without one, the residuals not rejected."""
    used = getattr(result, "poses_used", None)
    if used is not None:
        return int(used)
    rejected = {int(k) for k in (getattr(result, "rejected", None) or ())}
    return sum(1 for k in range(len(getattr(result, "residuals_mm", None) or ())) if k not in rejected)


def verdict_text(result) -> tuple[str, str]:
    """The result page's one-line verdict and its level ("ok", "warn" or "error").

    Calibrated: "calibrated: 1.8 mm RMS, worst pose #5 4.1 mm" (green; orange with the problem
    after it when ``ok`` comes with a problem). Not calibrated: "not calibrated: <problem>"
    and, when the problem does not say what to do (no " — "), the method's fix (red).
    """
    problem = str(getattr(result, "problem", "") or "").strip()
    if bool(getattr(result, "ok", False)):
        rms = _finite(getattr(result, "rms_mm", None))
        worst_mm = _finite(getattr(result, "max_mm", None))
        worst = worst_index(result)
        text = "calibrated" + (f": {rms:.1f} mm RMS" if rms is not None else "")
        if worst >= 0 and worst_mm is not None:
            text += f", worst pose #{int(worst) + 1} {worst_mm:.1f} mm"
        if problem:
            return f"{text} — {problem}", "warn"
        return text, "ok"
    text = f"not calibrated: {problem or 'no result'}"
    fix = METHOD_FIX.get(str(getattr(result, "method", "")))
    if fix and " — " not in problem:
        text += f" — {fix}"
    return text, "error"


class HandEyeWizard(StopDialog):
    """The camera → arm calibration wizard (see the module docstring); a view the app drives.

    Signals (all emitted from the GUI thread):
        sigStartRequested(str method, int n_poses): Start (or Run again) was tapped; ``method``
            is one of METHODS ("sweep", "touch_points", "planar"); ``n_poses`` is the poses spin
            box (4…40, used by the sweep). The wizard has switched to the run page.
        sigCancelRequested(): Cancel on the run page — stop the procedure (the wizard is back on
            the method page).
        sigRecordPointRequested(): "Record this point" (touch points): the tool is on a marker.
        sigSaveRequested(): "Save and use" on a calibrated result.
        sigStopRequested(): STOP tapped or Esc pressed — stop the arm (the wizard stays open;
            ``set_estop`` shows the state; nothing here re-arms).

    Closing (Close, the window manager) emits QDialog's ``finished``; an app running a
    procedure cancels it then.

    Slots for the app (GUI thread): ``set_estop``, ``set_tool_marker``, ``show_live``,
    ``set_progress``, ``set_phase``, ``set_points_recorded``, ``show_result``, ``on_saved``,
    ``on_failed``; ``set_page`` / ``page`` to move between pages.
    """

    sigStartRequested = QtCore.Signal(str, int)
    sigCancelRequested = QtCore.Signal()
    sigRecordPointRequested = QtCore.Signal()
    sigSaveRequested = QtCore.Signal()

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle(NAME)
        self.setModal(False)
        self.result = None  # the result shown on the result page
        self.verdict_level = ""  # "ok", "warn" or "error" once a result is shown
        self.estop_engaged = False
        self.run_method: str | None = None  # the method of the run started last
        self.run_n_poses = N_POSES_DEFAULT
        self._pending_live: tuple[np.ndarray, list[MarkerOverlay]] | None = None
        self._live_timer = QtCore.QTimer(self)
        self._live_timer.setSingleShot(True)
        self._live_timer.setInterval(LIVE_REDRAW_MS)
        self._live_timer.timeout.connect(self._draw_live)
        self._bar_colours: list[str] = []
        self._bar_heights: list[float] = []

        self.title = _bold(QtWidgets.QLabel(), 1.15)
        # the e-stop strip: above every page, never scrolled away
        self.estop_strip = EStopStrip()
        self.estop_strip.sigStopRequested.connect(self.request_stop)
        self.stop_button = self.estop_strip.stop_button
        self.estop_label = self.estop_strip.state_label
        self.estop_label.setMinimumWidth(120)
        self.close_button = touch_button("Close")
        self.close_button.clicked.connect(self.close)
        top = QtWidgets.QHBoxLayout()
        top.setSpacing(8)
        top.addWidget(self.title)
        top.addWidget(self.estop_strip, 1)
        top.addSpacing(12)  # a finger aiming at STOP must not land on Close
        top.addWidget(self.close_button)
        # one message line under the strip for every page: saved, failed, cancelled
        self.status_label = QtWidgets.QLabel()
        self.status_label.setWordWrap(True)
        self.status_label.setTextInteractionFlags(QtCore.Qt.TextInteractionFlag.TextSelectableByMouse)
        self.status_label.hide()

        self.stack = QtWidgets.QStackedWidget()
        self.stack.addWidget(self._build_method_page())
        self.stack.addWidget(self._build_run_page())
        self.stack.addWidget(self._build_result_page())
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(6, 4, 6, 6)
        layout.setSpacing(4)
        layout.addLayout(top)
        layout.addWidget(self.status_label)
        layout.addWidget(self.stack, 1)
        self.set_tool_marker("")
        self.set_page("method")
        self.set_estop(False)

    # ---------------------------------------------------------------------------- e-stop

    def set_estop(self, engaged: bool) -> None:
        """Show the arm's e-stop state (STOP reads "STOPPED" while stopped; this wizard never re-arms)."""
        self.estop_engaged = bool(engaged)
        self.estop_strip.set_estop(self.estop_engaged)


    # ---------------------------------------------------------------------------- pages
    def set_page(self, name: str) -> None:
        """Show "method", "run" or "result"."""
        if name not in PAGES:
            raise ValueError(f"page {name!r}; allowed: {', '.join(PAGES)}")
        k = PAGES.index(name)
        self.stack.setCurrentIndex(k)
        self.title.setText(PAGE_TITLES[k])

    def page(self) -> str:
        """The page shown: "method", "run" or "result"."""
        return PAGES[self.stack.currentIndex()]

    def show_adaptive(self) -> None:
        """Full screen on small screens (a 7" panel), a roomy dialog on desktops."""
        show_adaptive(self, (1100, 720))

    def _show_status(self, text: str, level: str, tooltip: str = "") -> None:
        self.status_label.setText(text)
        self.status_label.setToolTip(tooltip)
        self.status_label.setStyleSheet(_status_style(level))
        self.status_label.show()

    def _clear_status(self) -> None:
        self.status_label.clear()
        self.status_label.setToolTip("")
        self.status_label.hide()

    # ---------------------------------------------------------------------------- page 1: method
    def _build_method_page(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(page)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(6)
        grid = QtWidgets.QGridLayout()
        grid.setHorizontalSpacing(10)
        grid.setVerticalSpacing(6)
        grid.setColumnStretch(0, 1)
        self.method_group = QtWidgets.QButtonGroup(self)
        self.method_group.setExclusive(True)
        self.method_buttons: dict[str, QtWidgets.QPushButton] = {}
        for row, method in enumerate(METHODS):
            button = QtWidgets.QPushButton(METHOD_TEXTS[method])
            button.setCheckable(True)
            button.setStyleSheet(CHOICE_STYLE)
            button.setMinimumHeight(CHOICE_PX)
            button.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)
            button.setSizePolicy(QtWidgets.QSizePolicy.Policy.Expanding, QtWidgets.QSizePolicy.Policy.Fixed)
            self.method_group.addButton(button, row)
            self.method_buttons[method] = button
            grid.addWidget(button, row, 0)
        # the sweep's settings beside its button: the number of poses and the tool marker
        sweep_box = QtWidgets.QWidget()
        sweep_layout = QtWidgets.QVBoxLayout(sweep_box)
        sweep_layout.setContentsMargins(0, 0, 0, 0)
        sweep_layout.setSpacing(2)
        poses_row = QtWidgets.QHBoxLayout()
        poses_row.setSpacing(6)
        self.poses_label = QtWidgets.QLabel("Poses")
        self.poses_spin = TouchDoubleSpinBox(*N_POSES_RANGE, decimals=0, step=1)
        self.poses_spin.setValue(N_POSES_DEFAULT)
        self.poses_spin.setMinimumHeight(TOUCH_PX)
        self.poses_spin.setToolTip("How many poses the arm visits: more poses, a steadier result, a longer run")
        poses_row.addWidget(self.poses_label)
        poses_row.addWidget(self.poses_spin, 1)
        sweep_layout.addLayout(poses_row)
        self.tool_marker_label = QtWidgets.QLabel()
        self.tool_marker_label.setWordWrap(True)
        sweep_layout.addWidget(self.tool_marker_label)
        grid.addWidget(sweep_box, 0, 1)
        touch_note = QtWidgets.QLabel(f"records {MIN_TOUCH_POINTS} points or more,\n"
                                      "the arm moves only when you jog it")
        planar_note = QtWidgets.QLabel("the arm does not move;\nfor a camera above the desk")
        for row, note in ((1, touch_note), (2, planar_note)):
            note.setStyleSheet("QLabel { color: #555; }")
            grid.addWidget(note, row, 1)
        layout.addLayout(grid)
        self.method_help = QtWidgets.QLabel()
        self.method_help.setWordWrap(True)
        layout.addWidget(self.method_help)
        layout.addStretch(1)
        buttons = QtWidgets.QHBoxLayout()
        buttons.addStretch(1)
        self.start_button = touch_button("Start ▶")
        self.start_button.setMinimumWidth(self.start_button.minimumWidth() + 40)
        self.start_button.clicked.connect(self._on_start)
        buttons.addWidget(self.start_button)
        layout.addLayout(buttons)
        self.method_group.idToggled.connect(self._on_method_toggled)
        self.method_buttons["sweep"].setChecked(True)
        return page

    def method(self) -> str:
        """The method chosen on the method page (one of METHODS)."""
        return METHODS[max(0, self.method_group.checkedId())]

    def set_method(self, method: str) -> None:
        """Choose ``method`` on the method page (one of METHODS)."""
        if method not in METHODS:
            raise ValueError(f"method {method!r}; allowed: {', '.join(METHODS)}")
        self.method_buttons[method].setChecked(True)

    def n_poses(self) -> int:
        """The poses spin box (a typed, uncommitted number counts too)."""
        self.poses_spin.interpretText()
        return int(round(self.poses_spin.value()))

    def set_n_poses(self, n: int) -> None:
        """Set the poses spin box (clamped to 4…40)."""
        self.poses_spin.setValue(int(n))

    def set_tool_marker(self, text: str) -> None:
        """Show which marker the sweep looks for on the tool, e.g. "id 7, 30 mm" ("" = not set)."""
        text = str(text).strip()
        if text:
            self.tool_marker_label.setText(f"Tool marker: {text}")
            self.tool_marker_label.setStyleSheet("")
        else:
            self.tool_marker_label.setText("Tool marker: not set — fix a marker to the tool")
            self.tool_marker_label.setStyleSheet(f"QLabel {{ color: {WARN_COLOUR}; font-weight: bold; }}")

    def tool_marker_text(self) -> str:
        """The tool marker line as shown."""
        return self.tool_marker_label.text()

    def _on_method_toggled(self, _id: int, checked: bool) -> None:
        if not checked:
            return
        method = self.method()
        sweep = method == "sweep"
        self.poses_spin.setEnabled(sweep)
        self.poses_label.setEnabled(sweep)
        self.method_help.setText(METHOD_HELP[method])

    def _on_start(self) -> None:
        self.start(self.method(), self.n_poses())

    def start(self, method: str, n_poses: int) -> None:
        """Switch to the run page for ``method`` and emit sigStartRequested (Start, Run again)."""
        self.run_method = method
        self.run_n_poses = int(n_poses)
        self.result = None
        self._clear_status()
        self._prepare_run_page(method)
        self.set_page("run")
        self.sigStartRequested.emit(method, int(n_poses))

    # ---------------------------------------------------------------------------- page 2: run
    def _build_run_page(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        layout = QtWidgets.QHBoxLayout(page)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(8)
        self.camera_view = CameraView("Camera")
        self.camera_view.toggle_button.hide()  # no disparity here: the markers are what counts
        self.camera_view.overlay_widgets()["fps"].hide()  # nobody feeds it a frame rate here
        layout.addWidget(self.camera_view, 3)
        side = QtWidgets.QVBoxLayout()
        side.setSpacing(6)
        self.phase_label = QtWidgets.QLabel()
        self.phase_label.setWordWrap(True)
        self.phase_label.setMinimumHeight(28)
        side.addWidget(self.phase_label)
        self.step_label = QtWidgets.QLabel()
        self.step_label.setWordWrap(True)
        side.addWidget(self.step_label)
        self.progress_bar = QtWidgets.QProgressBar()
        self.progress_bar.setRange(0, 1000)
        self.progress_bar.setFormat("%p %")
        self.progress_bar.setMinimumHeight(24)
        side.addWidget(self.progress_bar)
        self.points_label = _bold(QtWidgets.QLabel())
        self.points_label.setWordWrap(True)
        side.addWidget(self.points_label)
        self.record_button = QtWidgets.QPushButton("Record this point")
        self.record_button.setStyleSheet(RECORD_STYLE)
        self.record_button.setMinimumHeight(TOUCH_PX + 12)
        self.record_button.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)
        self.record_button.setToolTip("The tool tip is on the centre of a desk marker: record where both see it")
        self.record_button.clicked.connect(self.sigRecordPointRequested)
        side.addWidget(self.record_button)
        side.addStretch(1)
        self.cancel_button = touch_button("Cancel")
        self.cancel_button.setToolTip("Stop the procedure and go back to the methods (STOP stops the arm)")
        self.cancel_button.clicked.connect(self._on_cancel)
        side.addWidget(self.cancel_button)
        side_box = QtWidgets.QWidget()
        side_box.setLayout(side)
        side_box.setMinimumWidth(220)
        side_box.setMaximumWidth(300)
        layout.addWidget(side_box, 2)
        self._prepare_run_page("sweep")
        return page

    def _prepare_run_page(self, method: str) -> None:
        touch = method == "touch_points"
        self.points_label.setVisible(touch)
        self.record_button.setVisible(touch)
        if touch:  # the phase line says what to do; no step line repeats it
            self.set_progress(0.0, "")
            self.set_phase("waiting", TOUCH_WAITING_TEXT)
        else:
            self.set_progress(0.0, f"{METHOD_NAMES.get(method, method)}: starting …")
            self.set_phase("waiting")
        if touch:
            self.set_points_recorded(0, MIN_TOUCH_POINTS)
        self._pending_live = None
        self._live_timer.stop()
        self.camera_view.set_markers([])

    def _on_cancel(self) -> None:
        self.set_page("method")
        self._show_status("Cancelled — choose a method and Start again", "info")
        self.sigCancelRequested.emit()

    @QtCore.Slot(object, object)
    def show_live(self, image_bgr: np.ndarray, marker_corners: Sequence | None = None,
                  marker_ids: Sequence[int] | None = None) -> None:
        """Show a camera image (BGR uint8) with the detected markers outlined.

        ``marker_corners``: a list of (4, 2) corner arrays in image px (or MarkerOverlay); None
        or empty: no marker seen. ``marker_ids`` names them (default: 1, 2, … in list order).
        Drawn at display rate: only the newest image waiting is drawn.
        """
        overlays: list[MarkerOverlay] = []
        for k, corners in enumerate(marker_corners or ()):
            if isinstance(corners, MarkerOverlay):
                overlays.append(corners)
                continue
            marker_id = int(marker_ids[k]) if marker_ids is not None and k < len(marker_ids) else k + 1
            overlays.append(MarkerOverlay(marker_id, np.asarray(corners, dtype=float).reshape(4, 2)))
        self._pending_live = (image_bgr, overlays)
        if not self._live_timer.isActive():
            self._live_timer.start()

    def _draw_live(self) -> None:
        pending, self._pending_live = self._pending_live, None
        if pending is None:
            return
        image, overlays = pending
        self.camera_view.show_image(image)
        self.camera_view.set_markers(overlays)

    def flush_live(self) -> None:
        """Draw a pending live image now (tests, screenshots)."""
        self._live_timer.stop()
        self._draw_live()

    @QtCore.Slot(float, str)
    def set_progress(self, fraction: float, text: str) -> None:
        """The run's progress 0 … 1 and what it is doing, e.g. "pose 3 of 12"."""
        f = _finite(fraction)
        self.progress_bar.setValue(int(round(1000 * min(1.0, max(0.0, f if f is not None else 0.0)))))
        self.step_label.setText(str(text))
        self._show_step()

    def progress_text(self) -> str:
        """The step text last set (shown under the phase unless it is empty or the same line)."""
        return self.step_label.text()

    def _show_step(self) -> None:
        """The step line shows only what the phase line does not say already."""
        text = self.step_label.text()
        self.step_label.setVisible(bool(text) and text != self.phase_text())

    @QtCore.Slot(str, str)
    def set_phase(self, phase: str, text: str = "") -> None:
        """Show the phase: "moving", "settling", "sampling", "skipped" (a pose without a marker) or
        "waiting", with ``text`` after it (or the phase's own words); "" and no text hides it."""
        level, default = PHASES.get(phase, ("info", phase))
        if phase == "skipped" and text:
            text = f"skipped pose: {text}"
        text = text or default
        self.phase_label.setText(text)
        self.phase_label.setStyleSheet(_status_style(level))
        self.phase_label.setVisible(bool(text))
        self._show_step()

    def phase_text(self) -> str:
        """The phase line as shown ("" when hidden)."""
        return self.phase_label.text() if not self.phase_label.isHidden() else ""

    @QtCore.Slot(int, int)
    def set_points_recorded(self, n: int, needed: int) -> None:
        """Touch points: ``n`` recorded of the ``needed`` ones."""
        n, needed = int(n), int(needed)
        if n >= needed:
            self.points_label.setText(f"{n} points recorded ✓ (≥ {needed})")
            self.points_label.setStyleSheet(f"QLabel {{ color: {OK_COLOUR}; }}")
        else:
            self.points_label.setText(f"{n} of {needed} points recorded")
            self.points_label.setStyleSheet("")

    # ---------------------------------------------------------------------------- page 3: result
    def _build_result_page(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(page)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(4)
        self.verdict_label = _bold(QtWidgets.QLabel(), 1.3)
        self.verdict_label.setWordWrap(True)
        layout.addWidget(self.verdict_label)
        self.details_label = QtWidgets.QLabel()
        self.details_label.setWordWrap(True)
        layout.addWidget(self.details_label)
        body = QtWidgets.QHBoxLayout()
        body.setSpacing(6)
        self.residual_plot, self._bars = static_bar_plot("residual (mm)", "pose")
        self._rms_line = pg.InfiniteLine(angle=0, movable=False,
                                         pen=pg.mkPen(OK_COLOUR, width=2, style=QtCore.Qt.PenStyle.DashLine),
                                         label="RMS", labelOpts={"position": 0.95, "color": OK_COLOUR})
        self._rms_line.setVisible(False)
        self.residual_plot.addItem(self._rms_line)
        body.addWidget(self.residual_plot, 3)
        warnings_box = QtWidgets.QWidget()
        warnings_layout = QtWidgets.QVBoxLayout(warnings_box)
        warnings_layout.setContentsMargins(0, 0, 0, 0)
        warnings_layout.setSpacing(2)
        warnings_layout.addWidget(_bold(QtWidgets.QLabel("Warnings")))
        self.warnings_label = QtWidgets.QLabel()
        self.warnings_label.setWordWrap(True)
        self.warnings_label.setAlignment(QtCore.Qt.AlignmentFlag.AlignTop | QtCore.Qt.AlignmentFlag.AlignLeft)
        self.warnings_label.setTextInteractionFlags(QtCore.Qt.TextInteractionFlag.TextSelectableByMouse)
        # many warnings scroll inside the box, never push the buttons below the fold
        self.warnings_area = touch_scroll_area(self.warnings_label)
        self.warnings_area.setMinimumWidth(160)
        QtWidgets.QScroller.grabGesture(self.warnings_area.viewport(),
                                        QtWidgets.QScroller.ScrollerGestureType.TouchGesture)
        warnings_layout.addWidget(self.warnings_area, 1)
        body.addWidget(warnings_box, 2)
        layout.addLayout(body, 1)
        buttons = QtWidgets.QHBoxLayout()
        self.method_button = touch_button("◀ Method")
        self.method_button.setToolTip("Back to the methods, e.g. to change the number of poses")
        self.method_button.clicked.connect(self._on_back_to_method)
        self.again_button = touch_button("Run again")
        self.again_button.setToolTip("Run the same method again with the same settings")
        self.again_button.clicked.connect(self._on_run_again)
        self.save_button = touch_button("Save and use")
        self.save_button.setToolTip("Make this the app's camera → arm calibration: the arm reaches with it now")
        self.save_button.clicked.connect(self._on_save)
        buttons.addWidget(self.method_button)
        buttons.addWidget(self.again_button)
        buttons.addStretch(1)
        buttons.addWidget(self.save_button)
        layout.addLayout(buttons)
        self.save_button.setEnabled(False)
        return page

    @QtCore.Slot(object)
    def show_result(self, result) -> None:
        """Show a finished calibration (duck-typed, see the module docstring) on the result page."""
        self.result = result
        self.run_method = str(getattr(result, "method", "") or self.run_method or "")
        text, level = verdict_text(result)
        self.verdict_label.setText(text)
        colour = {"ok": OK_COLOUR, "warn": WARN_COLOUR, "error": ERROR_COLOUR}[level]
        self.verdict_label.setStyleSheet(f"QLabel {{ color: {colour}; }}")
        self.verdict_level = level
        self.details_label.setText(self._details(result))
        self._show_residuals(result)
        warnings = [str(w) for w in (getattr(result, "warnings", None) or ())]
        if warnings:
            self.warnings_label.setText("\n".join(f"• {w}" for w in warnings))
            self.warnings_label.setStyleSheet(f"QLabel {{ color: {WARN_COLOUR}; }}")
        else:
            self.warnings_label.setText("none")
            self.warnings_label.setStyleSheet("QLabel { color: #555; }")
        ok = bool(getattr(result, "ok", False))
        self.save_button.setText("Save and use")
        self.save_button.setEnabled(ok)
        self.save_button.setToolTip("Make this the app's camera → arm calibration: the arm reaches with it now"
                                    if ok else "Nothing to save: the calibration failed — run again")
        self._clear_status()
        self.set_page("result")

    def _details(self, result) -> str:
        method = str(getattr(result, "method", "") or "")
        residuals = list(getattr(result, "residuals_mm", None) or ())
        rejected = sorted(int(k) for k in (getattr(result, "rejected", None) or ()))
        parts = [METHOD_NAMES.get(method, method or "?"),
                 f"{poses_used(result)} of {len(residuals)} {'points' if method != 'sweep' else 'poses'} used"]
        if rejected:
            parts.append("rejected " + ", ".join(f"#{k + 1}" for k in rejected))
        t_err = _finite(getattr(result, "translation_error_mm", None))
        r_err = _finite(getattr(result, "rotation_error_deg", None))
        if t_err is not None or r_err is not None:
            truth = []
            if t_err is not None:
                truth.append(f"{t_err:.1f} mm")
            if r_err is not None:
                truth.append(f"{r_err:.2f}°")
            parts.append("off the simulated desk's truth by " + " / ".join(truth))
        return " · ".join(parts)

    def _show_residuals(self, result) -> None:
        residuals = [_finite(r) for r in (getattr(result, "residuals_mm", None) or ())]
        heights = [r if r is not None else 0.0 for r in residuals]
        rejected = {int(k) for k in (getattr(result, "rejected", None) or ())}
        worst = worst_index(result)
        colours = [REJECTED_COLOUR if k in rejected else WORST_COLOUR if k == worst else USED_COLOUR
                   for k in range(len(heights))]
        self._bar_heights, self._bar_colours = heights, colours
        xs = np.arange(len(heights), dtype=float)
        self._bars.setOpts(x=xs, height=heights, width=0.7, brushes=[pg.mkBrush(c) for c in colours],
                           pens=[pg.mkPen(None)] * len(heights))
        top = max(heights + [0.1]) * 1.15
        rms = _finite(getattr(result, "rms_mm", None))
        if rms is not None and bool(getattr(result, "ok", False)):
            self._rms_line.setPos(rms)
            self._rms_line.setVisible(True)
            top = max(top, rms * 1.15)
        else:
            self._rms_line.setVisible(False)
        self.residual_plot.setXRange(-0.6, max(1, len(heights)) - 0.4, padding=0)
        self.residual_plot.setYRange(0, top, padding=0)
        step = max(1, int(math.ceil(len(heights) / 12)))
        ticks = [(float(k), str(k + 1)) for k in range(len(heights)) if k % step == 0]
        self.residual_plot.getAxis("bottom").setTicks([ticks])

    def bar_colours(self) -> list[str]:
        """The residual bars' colours in pose order ("#rrggbb"; worst red, rejected grey)."""
        return list(self._bar_colours)

    def bar_heights(self) -> list[float]:
        """The residual bars' heights in mm, in pose order (0 for a pose without a residual)."""
        return list(self._bar_heights)

    def _on_save(self) -> None:
        if self.result is not None and bool(getattr(self.result, "ok", False)):
            self.save_button.setEnabled(False)
            self.save_button.setText("Saving …")
            self.sigSaveRequested.emit()

    def _on_run_again(self) -> None:
        self.start(self.run_method if self.run_method in METHODS else self.method(), self.run_n_poses)

    def _on_back_to_method(self) -> None:
        self._clear_status()
        self.set_page("method")

    @QtCore.Slot(str)
    def on_saved(self, path: str) -> None:
        """The calibration was saved at ``path`` and is in use."""
        self.save_button.setText("Saved ✓")
        self.save_button.setEnabled(False)
        self._show_status(f"✓ Saved and in use: {_short(path)}", "ok", tooltip=str(path))

    @QtCore.Slot(str)
    def on_failed(self, message: str) -> None:
        """Something the user asked for failed (starting, recording, saving): say why on every page."""
        if self.result is not None:
            self.save_button.setText("Save and use")
            self.save_button.setEnabled(bool(getattr(self.result, "ok", False)))
        self._show_status(str(message), "error")

    def status_text(self) -> str:
        """The message line under the STOP strip ("" when hidden)."""
        return self.status_label.text() if not self.status_label.isHidden() else ""


__all__ = ["METHODS", "N_POSES_DEFAULT", "N_POSES_RANGE", "PAGES", "PHASES", "HandEyeWizard", "verdict_text"]
