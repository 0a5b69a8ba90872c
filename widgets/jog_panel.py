"""The Jog tab: move the arm by hand, in x/y/z or one joint at a time, with big ± buttons.

The panel owns no model: it shows what it is told (``show_state``) and says what the user does.
A ± button held down jogs continuously until it is let go (the window feeds the presses and
releases to ``core.motion.jog.Jogger``), so touch and keys behave the same.

Signals (all emitted in the GUI thread):

- ``sigPressed(int channel, int direction)``: a ± button went down (channel: 0 x, 1 y, 2 z in
  Cartesian space, else the joint index; direction +1 or -1).
- ``sigReleased(int channel)``: that button came up.
- ``sigSpaceChanged(str)``: "cartesian" or "joint" chosen.
- ``sigStepChanged(int)``: the step size index chosen (0 smallest).

``jog_key_action`` and ``is_text_field`` are the window's keyboard rules, kept here so they are
tested without a window.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

from PySide6 import QtCore, QtWidgets

from widgets._style import ACCENT_COLOUR, TOUCH_PX, WARN_COLOUR, coloured_label_style, touch_button

CARTESIAN = "cartesian"
JOINT = "joint"
AXIS_NAMES = ("x", "y", "z")
AXIS_KEYS = ("← →", "↓ ↑", "PgDn PgUp")  # the keys that jog each axis, shown beside it
KEY_HINT_CARTESIAN = "Keys: ← → x · ↓ ↑ y · PgDn PgUp z · [ ] step · J joints"
KEY_HINT_JOINT = "Keys: 1–9 joint · ← → or ↓ ↑ move it · [ ] step · J x/y/z"
# which angles the joint rows show: the arm model's joint angles, which a servo arm's Robot tab
# (servo angles) shows shifted by each servo's mounting offset
JOINT_CAPTION = "Joint angles, 0° = joint straight (the Robot tab shows servo angles)"
Key = QtCore.Qt.Key


@dataclass(frozen=True)
class KeyAction:
    """What a key does to jogging."""

    kind: str  # "jog" (channel, direction), "step" (direction ±1), "space" (toggle), "joint" (channel)
    channel: int = 0
    direction: int = 0


def jog_key_action(key: int, space: str, selected_joint: int = 0, joint_count: int = 0) -> Optional[KeyAction]:
    """The jog action of ``key`` (a ``Qt.Key``) in ``space``, None when the key is not a jog key.

    Cartesian: ← → x, ↓ ↑ y, Page Down / Page Up z. Joint: ← ↓ move the selected joint down,
    → ↑ up; 1–9 pick a joint. Both: [ or - smaller step, ] or + (=) bigger step, J switches space.
    """
    key = int(key)
    if key in (int(Key.Key_BracketRight), int(Key.Key_Plus), int(Key.Key_Equal)):
        return KeyAction("step", direction=+1)
    if key in (int(Key.Key_BracketLeft), int(Key.Key_Minus), int(Key.Key_Underscore)):
        return KeyAction("step", direction=-1)
    if key == int(Key.Key_J):
        return KeyAction("space")
    if space == CARTESIAN:
        table = {Key.Key_Left: (0, -1), Key.Key_Right: (0, +1), Key.Key_Down: (1, -1), Key.Key_Up: (1, +1),
                 Key.Key_PageDown: (2, -1), Key.Key_PageUp: (2, +1)}
        for k, (channel, direction) in table.items():
            if key == int(k):
                return KeyAction("jog", channel, direction)
        return None
    if int(Key.Key_1) <= key <= int(Key.Key_9):
        j = key - int(Key.Key_1)
        return KeyAction("joint", j) if j < joint_count else None
    if key in (int(Key.Key_Left), int(Key.Key_Down)):
        return KeyAction("jog", selected_joint, -1)
    if key in (int(Key.Key_Right), int(Key.Key_Up)):
        return KeyAction("jog", selected_joint, +1)
    return None


TEXT_WIDGETS = (QtWidgets.QLineEdit, QtWidgets.QAbstractSpinBox, QtWidgets.QTextEdit, QtWidgets.QPlainTextEdit)


def is_text_field(widget: Optional[QtWidgets.QWidget]) -> bool:
    """True when keys typed into ``widget`` edit text (a line edit, spin box, text box or an
    editable combo box, or something inside one): there the arrows move the cursor, not the arm."""
    w = widget
    while w is not None:
        if isinstance(w, TEXT_WIDGETS):
            return True
        if isinstance(w, QtWidgets.QComboBox) and w.isEditable():
            return True
        if w.isWindow():
            return False
        w = w.parentWidget()
    return False


class JogPanel(QtWidgets.QWidget):
    """Cartesian / joint switch, step sizes, a ± pair per axis or joint and a readout."""

    sigPressed = QtCore.Signal(int, int)
    sigReleased = QtCore.Signal(int)
    sigSpaceChanged = QtCore.Signal(str)
    sigStepChanged = QtCore.Signal(int)

    def __init__(self, parent: Optional[QtWidgets.QWidget] = None) -> None:
        super().__init__(parent)
        self.space = CARTESIAN
        self.selected_joint = 0
        self._cartesian_steps: list[str] = ["1 mm", "5 mm", "20 mm"]
        self._joint_steps: list[str] = ["1°", "5°", "15°"]
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.setSpacing(4)

        spaces = QtWidgets.QHBoxLayout()
        self.space_buttons = {CARTESIAN: touch_button("X Y Z", checkable=True),
                              JOINT: touch_button("Joints", checkable=True)}
        self._space_group = QtWidgets.QButtonGroup(self)
        for name, b in self.space_buttons.items():
            b.setToolTip("Jog the tool along x, y, z (J)" if name == CARTESIAN else "Jog one joint at a time (J)")
            self._space_group.addButton(b)
            spaces.addWidget(b)
            b.clicked.connect(lambda _=False, n=name: self._on_space_clicked(n))
        self.space_buttons[CARTESIAN].setChecked(True)
        layout.addLayout(spaces)

        steps = QtWidgets.QHBoxLayout()
        steps.addWidget(QtWidgets.QLabel("Step"))
        self.step_buttons: list[QtWidgets.QPushButton] = []
        self._step_group = QtWidgets.QButtonGroup(self)
        for i in range(3):
            b = touch_button("20 mm", checkable=True)  # the widest label sets the width
            b.setToolTip("Step size ([ smaller, ] bigger)")
            self._step_group.addButton(b)
            self.step_buttons.append(b)
            steps.addWidget(b)
            b.clicked.connect(lambda _=False, i=i: self._on_step_clicked(i))
        self.step_buttons[1].setChecked(True)
        layout.addLayout(steps)

        self.rows_box = QtWidgets.QWidget()
        self.rows = QtWidgets.QGridLayout(self.rows_box)
        self.rows.setContentsMargins(0, 0, 0, 0)
        self.rows.setHorizontalSpacing(4)
        self.rows.setVerticalSpacing(4)
        layout.addWidget(self.rows_box)
        self.minus_buttons: list[QtWidgets.QPushButton] = []
        self.plus_buttons: list[QtWidgets.QPushButton] = []
        self.name_labels: list[QtWidgets.QLabel] = []
        self.value_labels: list[QtWidgets.QLabel] = []
        self._joint_names: list[str] = []

        self.joint_caption = QtWidgets.QLabel(JOINT_CAPTION)
        self.joint_caption.setWordWrap(True)
        self.joint_caption.hide()  # joint space only
        layout.addWidget(self.joint_caption)
        self.readout = QtWidgets.QLabel("")
        self.readout.setWordWrap(True)
        layout.addWidget(self.readout)
        self.note_label = QtWidgets.QLabel("")
        self.note_label.setWordWrap(True)
        self.note_label.setStyleSheet(coloured_label_style(WARN_COLOUR))
        self.note_label.hide()
        layout.addWidget(self.note_label)
        self.hint = QtWidgets.QLabel(KEY_HINT_CARTESIAN)
        self.hint.setWordWrap(True)
        layout.addWidget(self.hint)
        layout.addStretch(1)
        self.set_joints(["joint 1", "joint 2", "joint 3"])

    # --- configuration -------------------------------------------------------------------------
    def set_joints(self, names: Sequence[str]) -> None:
        """The arm's joint names (the joint rows)."""
        self._joint_names = [str(n) for n in names]
        self._rebuild_rows()

    def set_joint_caption(self, text: str) -> None:
        """Say which angles the joint rows show (default: the model's joint angles, not servo
        angles); "" hides the caption."""
        self.joint_caption.setText(text)
        self.joint_caption.setVisible(bool(text) and self.space == JOINT)

    def set_step_labels(self, cartesian: Sequence[str], joint: Sequence[str]) -> None:
        """The step sizes' labels in each space, e.g. ["1 mm", "5 mm", "20 mm"], ["1°", "5°", "15°"]."""
        self._cartesian_steps, self._joint_steps = list(cartesian), list(joint)
        self._label_steps()

    def channel_names(self) -> list[str]:
        return list(AXIS_NAMES) if self.space == CARTESIAN else list(self._joint_names)

    def _rebuild_rows(self) -> None:
        while self.rows.count():
            item = self.rows.takeAt(0)
            if item.widget() is not None:
                item.widget().deleteLater()
        self.minus_buttons, self.plus_buttons, self.name_labels, self.value_labels = [], [], [], []
        for i, name in enumerate(self.channel_names()):
            label = QtWidgets.QLabel(name if self.space == JOINT else f"{name}  {AXIS_KEYS[i]}")
            label.setMinimumHeight(TOUCH_PX)
            minus, plus = self._hold_button("−", i, -1), self._hold_button("+", i, +1)
            value = QtWidgets.QLabel("–")
            value.setAlignment(QtCore.Qt.AlignmentFlag.AlignRight | QtCore.Qt.AlignmentFlag.AlignVCenter)
            value.setMinimumWidth(64)
            self.rows.addWidget(label, i, 0)
            self.rows.addWidget(minus, i, 1)
            self.rows.addWidget(value, i, 2)
            self.rows.addWidget(plus, i, 3)
            self.minus_buttons.append(minus)
            self.plus_buttons.append(plus)
            self.name_labels.append(label)
            self.value_labels.append(value)
        self.rows.setColumnStretch(0, 1)
        self._label_steps()
        self.set_selected_joint(min(self.selected_joint, max(len(self._joint_names) - 1, 0)))

    def _hold_button(self, text: str, channel: int, direction: int) -> QtWidgets.QPushButton:
        b = touch_button(text)
        b.setMinimumSize(TOUCH_PX + 8, TOUCH_PX)
        b.setToolTip("Tap: one step · hold: keep moving")
        b.pressed.connect(lambda: self.sigPressed.emit(channel, direction))
        b.released.connect(lambda: self.sigReleased.emit(channel))
        return b

    def _label_steps(self) -> None:
        labels = self._cartesian_steps if self.space == CARTESIAN else self._joint_steps
        for b, text in zip(self.step_buttons, labels):
            b.setText(text)
        self.hint.setText(KEY_HINT_CARTESIAN if self.space == CARTESIAN else KEY_HINT_JOINT)
        self.joint_caption.setVisible(self.space == JOINT and bool(self.joint_caption.text()))

    # --- state shown ---------------------------------------------------------------------------
    def set_space(self, space: str) -> None:
        """Show ``space``'s rows (no signal)."""
        if space not in (CARTESIAN, JOINT):
            raise ValueError(f"jog space {space!r} must be {CARTESIAN!r} or {JOINT!r}")
        self.space_buttons[space].setChecked(True)
        if space != self.space:
            self.space = space
            self._rebuild_rows()

    def set_step_index(self, index: int) -> None:
        """Check step button ``index`` (no signal)."""
        self.step_buttons[max(0, min(int(index), len(self.step_buttons) - 1))].setChecked(True)

    @property
    def step_index(self) -> int:
        return next(i for i, b in enumerate(self.step_buttons) if b.isChecked())

    def set_selected_joint(self, index: int) -> None:
        """The joint the arrow keys move (joint space): its name is highlighted."""
        self.selected_joint = int(index)
        if self.space != JOINT:
            return
        for i, label in enumerate(self.name_labels):
            label.setStyleSheet(coloured_label_style(ACCENT_COLOUR) if i == self.selected_joint else "")
            label.setText(f"{i + 1} {self._joint_names[i]}" + ("  ◀" if i == self.selected_joint else ""))

    def show_state(self, base_p_target: Optional[Sequence[float]], joint_texts: Sequence[str],
                   note: str = "") -> None:
        """The Cartesian target (m) and the joints (already formatted) in the rows and the readout."""
        if base_p_target is not None:
            xyz = [f"{float(v) * 1e3:.1f}" for v in base_p_target]
            target = f"target x {xyz[0]} y {xyz[1]} z {xyz[2]} mm"
        else:
            xyz, target = ["–"] * 3, "target –"
        values = xyz if self.space == CARTESIAN else list(joint_texts)
        for label, text in zip(self.value_labels, values):
            label.setText(text)
        self.readout.setText(f"{target}\njoints {', '.join(joint_texts) or '–'}")
        self.note_label.setText(note)
        self.note_label.setVisible(bool(note))

    # --- user input ----------------------------------------------------------------------------
    def _on_space_clicked(self, space: str) -> None:
        self.set_space(space)
        self.sigSpaceChanged.emit(space)

    def _on_step_clicked(self, index: int) -> None:
        self.sigStepChanged.emit(index)
