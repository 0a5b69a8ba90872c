"""The Target tab's Teleop page: which hand source drives the arm, Restart (calibrate again), the
target box the hand volume maps to, and what teleoperation is doing.

The panel only shows and asks: the window builds the ``core.motion.teleop.TeleopController`` from
the chosen source, checks a target box against the arm's reach (``target_box_problem``) and tells
the panel what it accepted (``show_target_box``) or refused (``refuse_target_box``).
"""
from __future__ import annotations

from typing import Optional, Sequence

from PySide6 import QtCore, QtWidgets

from core.motion.teleop import CALIBRATING, ENDED, FOLLOWING, HOLDING, REACH_TOL_M, Box
from core.motion.teleop_choice import KEYBOARD_SOURCE
from widgets._style import (
    ERROR_COLOUR,
    OK_COLOUR,
    TOUCH_PX,
    WARN_COLOUR,
    TouchDoubleSpinBox,
    touch_button,
    touch_combo,
)
from widgets.file_dialog import open_file_dialog

M_TO_CM = 100.0
POSE_SOURCE = "pose:"  # a body pose model file (ONNX), "pose:PATH"
BOX_LIMIT_CM = 60.0  # the box spin boxes' range (±, and 0 … this for z): reach is checked on top
MIN_TARGET_BOX_M = 0.01  # a target box thinner than this along an axis is refused (nothing to map into)
REACH_GRID = 3  # a target box is reachable when IK reaches every point of this grid³ sample


def source_text(spec: str) -> str:
    """How a source spec reads in the list: "marker:23" → "Wristband marker 23"."""
    kind, _, arg = spec.partition(":")
    if spec == KEYBOARD_SOURCE:
        return "Keyboard (jog keys)"
    if kind == "marker":
        return f"Wristband marker {arg}"
    if kind == "hsv":
        return f"Glove: {arg}"
    if kind == "pose":
        return f"Pose model: {arg.replace(chr(92), '/').rsplit('/', 1)[-1]}" if arg else "Pose model (ONNX)…"
    return spec


def teleop_banner_text(status) -> tuple[str, bool]:
    """The top strip's line for a ``TeleopStatus`` and whether it is good news (True) or needs the
    user (False: the arm holds): "teleop: calibrating — hold still at a corner (1/2)",
    "teleop: following", "teleop: hand lost — holding", "teleop: ended — Restart to calibrate again"."""
    state, message = status.state, str(status.message or "")
    if state == CALIBRATING:
        if "too thin" in message:  # a refused second corner: the core's reason says what to do
            return message, False
        if status.corner_a is None:
            return "teleop: calibrating — hold still at a corner (1/2)", True
        return "teleop: calibrating — hold still at the opposite corner (2/2)", True
    if state == FOLLOWING:
        if status.source == KEYBOARD_SOURCE:
            return message or "teleop: keyboard", True
        return "teleop: following", True
    if state == HOLDING:
        return (message if "covered" in message else "teleop: hand lost — holding"), False
    if state == ENDED:
        return "teleop: ended — Restart to calibrate again", False
    return message or f"teleop: {state}", False


def target_box_problem(kinematics, box: Box, desk_margin_m: float = 0.0) -> str:
    """Why the arm cannot use ``box`` as the teleop target box ("" when it can): thinner than
    MIN_TARGET_BOX_M along an axis, below the desk margin, or a point of a REACH_GRID³ sample that
    IK does not reach within REACH_TOL_M (the message names the nearest fix)."""
    thin = [axis for axis, e in zip("xyz", box.extent) if e < MIN_TARGET_BOX_M]
    if thin:
        return (f"target box {box.describe_cm()} is too thin along {', '.join(thin)}: "
                f"make min and max at least {MIN_TARGET_BOX_M * M_TO_CM:.0f} cm apart")
    if box.lo[2] < desk_margin_m - 1e-9:
        return (f"target box bottom z = {box.lo[2] * M_TO_CM:.1f} cm is below the desk margin "
                f"({desk_margin_m * M_TO_CM:.1f} cm): raise z min")
    for p in box.grid(REACH_GRID):
        try:
            ik = kinematics.ik(tuple(float(v) for v in p))
            ok = bool(ik.reachable) and float(ik.error_m) <= REACH_TOL_M
        except (ValueError, ArithmeticError):
            ok = False
        if not ok:
            where = ", ".join(f"{v * M_TO_CM:.1f}" for v in p)
            return f"target box out of reach: the arm does not reach ({where}) cm — choose a smaller box"
    return ""


class TeleopPanel(QtWidgets.QWidget):
    """Source, Restart, target box (x/y/z min–max in cm, and presets) and the teleop state.

    Signals (GUI thread):
        sigSourceChanged(str): the user chose a hand source: "marker:ID", "hsv:COLOUR", "keyboard"
            or "pose:PATH" (a pose model picked with the file dialog or ``set_pose_model``).
        sigRestart(): Restart was tapped: calibrate again.
        sigTargetBoxChanged(object lo, object hi): the user edited the target box or chose a
            preset: two (x, y, z) tuples in metres; the owner answers with ``show_target_box``
            (accepted) or ``refuse_target_box`` (refused, the controls go back).
    """

    sigSourceChanged = QtCore.Signal(str)
    sigRestart = QtCore.Signal()
    sigTargetBoxChanged = QtCore.Signal(object, object)

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._sources: list[str] = []
        self._accepted: Optional[Box] = None  # the target box last accepted by the owner
        self._presets: list[tuple[str, Box]] = []
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(2, 2, 2, 2)
        layout.setSpacing(4)

        self.state_label = QtWidgets.QLabel("teleop: no hand source")
        self.state_label.setObjectName("teleop_state")
        self.state_label.setWordWrap(True)
        self.state_label.setMinimumHeight(28)
        layout.addWidget(self.state_label)

        row = QtWidgets.QHBoxLayout()
        row.addWidget(QtWidgets.QLabel("Hand"))
        self.source_combo = touch_combo(QtWidgets.QComboBox())
        self.source_combo.setObjectName("teleop_source")
        self.source_combo.setMinimumWidth(120)
        self.source_combo.activated.connect(self._on_source_activated)
        row.addWidget(self.source_combo, 1)
        layout.addLayout(row)
        self.restart_button = touch_button("↺ Restart (calibrate again)")
        self.restart_button.setObjectName("teleop_restart")
        self.restart_button.clicked.connect(self.sigRestart)
        layout.addWidget(self.restart_button)

        hint = QtWidgets.QLabel("Calibrate: hold the hand still 1 s at one corner of the space you "
                                "want to use, then 1 s at the opposite corner. End: hold still and "
                                "cover the band. Keyboard: the jog keys move the target.")
        hint.setWordWrap(True)
        hint.setEnabled(False)
        layout.addWidget(hint)

        box_title = QtWidgets.QLabel("<b>Target box</b> (cm, where the hand's space maps to)")
        box_title.setWordWrap(True)
        layout.addWidget(box_title)
        self.preset_combo = touch_combo(QtWidgets.QComboBox())
        self.preset_combo.setObjectName("teleop_preset")
        self.preset_combo.setPlaceholderText("presets")
        self.preset_combo.activated.connect(self._on_preset)
        layout.addWidget(self.preset_combo)
        grid = QtWidgets.QGridLayout()
        grid.setHorizontalSpacing(4)
        grid.setVerticalSpacing(2)
        for col, text in enumerate(("", "min", "max")):
            header = QtWidgets.QLabel(text)
            header.setAlignment(QtCore.Qt.AlignmentFlag.AlignCenter)
            grid.addWidget(header, 0, col)
        self.box_spins: dict[str, tuple[TouchDoubleSpinBox, TouchDoubleSpinBox]] = {}
        for row_index, axis in enumerate("xyz", start=1):
            lo_cm = 0.0 if axis == "z" else -BOX_LIMIT_CM
            label = QtWidgets.QLabel(axis.upper())
            label.setMinimumHeight(TOUCH_PX)
            grid.addWidget(label, row_index, 0)
            spins = (TouchDoubleSpinBox(lo_cm, BOX_LIMIT_CM, decimals=1, step=0.5),
                     TouchDoubleSpinBox(lo_cm, BOX_LIMIT_CM, decimals=1, step=0.5))
            for col, spin in enumerate(spins, start=1):
                spin.setObjectName(f"teleop_box_{axis}_{'min' if col == 1 else 'max'}")
                spin.valueChanged.connect(self._on_box_edited)
                grid.addWidget(spin, row_index, col)
            self.box_spins[axis] = spins
        grid.setColumnStretch(1, 1)
        grid.setColumnStretch(2, 1)
        layout.addLayout(grid)
        self.box_message = QtWidgets.QLabel("")
        self.box_message.setObjectName("teleop_box_message")
        self.box_message.setWordWrap(True)
        self.box_message.hide()
        layout.addWidget(self.box_message)
        self.volume_label = QtWidgets.QLabel("")
        self.volume_label.setWordWrap(True)
        layout.addWidget(self.volume_label)
        layout.addStretch(1)

    # ----------------------------------------------------------------------------- source
    @property
    def source(self) -> Optional[str]:
        """The chosen source spec, or None."""
        data = self.source_combo.currentData()
        return None if data is None else str(data)

    def set_sources(self, marker_ids: Sequence[int], colours: Sequence[str] = (), pose: bool = True) -> None:
        """Offer wristband markers, glove colours, the keyboard and (``pose``) a pose model file;
        the chosen source stays chosen. No signal."""
        chosen = self.source
        specs = [f"marker:{int(i)}" for i in marker_ids] + [f"hsv:{c}" for c in colours] + [KEYBOARD_SOURCE]
        if pose:
            specs.append(POSE_SOURCE)
        if chosen is not None and chosen not in specs:
            specs.insert(0, chosen)
        self._fill(specs, chosen)

    def set_source(self, spec: str) -> None:
        """Show ``spec`` as the chosen source (added to the list when missing). No signal."""
        spec = str(spec)
        specs = list(self._sources)
        if spec not in specs:
            specs.insert(0, spec)
        self._fill(specs, spec)

    def set_pose_model(self, path: str) -> None:
        """Choose a pose model file (as the file dialog would) and emit sigSourceChanged."""
        spec = f"{POSE_SOURCE}{path}"
        self.set_source(spec)
        self.sigSourceChanged.emit(spec)

    def _fill(self, specs: list[str], chosen: Optional[str]) -> None:
        self._sources = specs
        blocked = self.source_combo.blockSignals(True)
        self.source_combo.clear()
        for spec in specs:
            self.source_combo.addItem(source_text(spec), spec)
        self.source_combo.setCurrentIndex(specs.index(chosen) if chosen in specs else -1)
        self.source_combo.blockSignals(blocked)

    def _on_source_activated(self, _index: int) -> None:
        spec = self.source
        if spec is None:
            return
        if spec == POSE_SOURCE:  # the entry that asks for a file
            self.file_dialog = open_file_dialog(self, "Pose model (ONNX)", lambda path, _f: self.set_pose_model(path),
                                                "", "ONNX models (*.onnx)")
            return
        self.sigSourceChanged.emit(spec)

    # ----------------------------------------------------------------------------- target box
    def target_box(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """(lo, hi) in metres as the spin boxes show them (not necessarily accepted)."""
        lo = tuple(self.box_spins[a][0].value() / M_TO_CM for a in "xyz")
        hi = tuple(self.box_spins[a][1].value() / M_TO_CM for a in "xyz")
        return lo, hi  # type: ignore[return-value]

    @property
    def accepted_box(self) -> Optional[Box]:
        """The target box the owner last accepted."""
        return self._accepted

    def set_presets(self, presets: Sequence[tuple[str, Box]]) -> None:
        """Named target boxes to choose from (each already checked by the owner)."""
        self._presets = list(presets)
        blocked = self.preset_combo.blockSignals(True)
        self.preset_combo.clear()
        for name, box in self._presets:
            self.preset_combo.addItem(f"{name} ({box.describe_cm()})")
        self.preset_combo.setCurrentIndex(-1)
        self.preset_combo.blockSignals(blocked)

    def show_target_box(self, box: Box) -> None:
        """The owner accepted ``box``: show it, clear any refusal. No signal."""
        self._accepted = box
        self._set_spins(box)
        self.box_message.hide()
        self.box_message.setText("")

    def refuse_target_box(self, message: str) -> None:
        """The owner refused the edited box: back to the accepted box, and say why. No signal."""
        if self._accepted is not None:
            self._set_spins(self._accepted)
        self.box_message.setText(message)
        self.box_message.setStyleSheet(f"QLabel {{ color: {ERROR_COLOUR}; font-weight: bold; }}")
        self.box_message.show()

    def _set_spins(self, box: Box) -> None:
        for axis, lo, hi in zip("xyz", box.lo, box.hi):
            for spin, value in zip(self.box_spins[axis], (lo, hi)):
                blocked = spin.blockSignals(True)
                spin.setValue(float(value) * M_TO_CM)
                spin.blockSignals(blocked)

    def _on_box_edited(self, *_args) -> None:
        lo, hi = self.target_box()
        self.sigTargetBoxChanged.emit(lo, hi)

    def _on_preset(self, index: int) -> None:
        if 0 <= index < len(self._presets):
            box = self._presets[index][1]
            self.sigTargetBoxChanged.emit(tuple(box.lo), tuple(box.hi))

    # ----------------------------------------------------------------------------- state
    def set_status(self, status) -> None:
        """Show a ``TeleopStatus`` (or None: no hand source): the state line and the hand volume.
        Cheap when nothing changed (called with every draw)."""
        if status is None:
            text, ok, volume = "teleop: no hand source — choose one above", False, ""
        else:
            text, ok = teleop_banner_text(status)
            box = status.hand_box
            # the volume only: a hand position here would re-lay out the page with every frame
            volume = "" if box is None else f"hand volume {box.describe_cm()} (the twin shows it)"
        if text != self.state_label.text() or self.state_label.property("teleop_ok") != ok:
            colour = OK_COLOUR if ok else WARN_COLOUR
            self.state_label.setText(text)
            self.state_label.setStyleSheet(f"QLabel {{ color: {colour}; font-weight: bold; }}")
            self.state_label.setProperty("teleop_ok", ok)
        if volume != self.volume_label.text():
            self.volume_label.setText(volume)
