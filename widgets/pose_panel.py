"""Manual pose panel for 6-DOF arms: X/Y/Z, yaw/pitch/roll and the gripper, as in the UMI-RTX GUI.

The panel edits a tool pose in robot_base and emits it as a frozen :class:`PoseTarget` in SI
units (m, rad); centimetres, degrees and millimetres exist only in its fields. Orientation is
roll, pitch, yaw about robot_base's fixed x, y, z axes, ``R = Rz(yaw) · Ry(pitch) · Rx(roll)``
— the URDF/ROS convention of ``core.kinematics.base.rpy_to_matrix`` (Pinocchio's
``pin.rpy.rpyToMatrix``), which :func:`pose_target_to_matrix` uses, so its matrix goes straight
to ``ClikKinematics.ik_pose``.

Yaw can be typed relative to the arm's radial direction, as in the UMI-RTX GUI: the absolute
yaw is then ``atan2(y, x) + relative yaw``, so the hand keeps pointing the same way relative to
the arm when X or Y change.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Optional, Sequence

import numpy as np
from PySide6 import QtCore, QtWidgets

from core.kinematics.base import matrix_to_rpy, pose_matrix, rpy_to_matrix
from widgets._style import TOUCH_PX, TouchDoubleSpinBox

M_TO_CM = 100.0
M_TO_MM = 1000.0
DECIMALS = 2  # every field keeps two typed decimals: 12.34 cm, 12.34°, 12.34 mm
DEFAULT_XY_M = (-1.0, 1.0)
DEFAULT_Z_M = (0.0, 1.0)
DEFAULT_GRIP_M = (0.0, 0.05)
ANGLE_LIMIT_DEG = 180.0
RANGE_ROUND_CM = 1.0  # configure_for rounds the workspace's ranges outwards to whole cm
CHECKBOX_STYLE = (f"QCheckBox {{ min-height: {TOUCH_PX}px; }}"
                  " QCheckBox::indicator { width: 28px; height: 28px; }")


@dataclass(frozen=True)
class PoseTarget:
    """A tool pose in robot_base, as the pose panel emits it (SI units)."""

    base_p: tuple[float, float, float]  # tool point in robot_base, m
    rpy: tuple[float, float, float]  # roll, pitch, yaw of the tool in robot_base, rad, absolute
    grip_m: Optional[float] = None  # gripper opening per finger, m; None: the arm has no gripper

    def __post_init__(self) -> None:
        for name, value in (("base_p", self.base_p), ("rpy", self.rpy)):
            if len(value) != 3 or not all(math.isfinite(float(v)) for v in value):
                raise ValueError(f"PoseTarget.{name} = {value!r}: expected 3 finite numbers")
        object.__setattr__(self, "base_p", tuple(float(v) for v in self.base_p))
        object.__setattr__(self, "rpy", tuple(float(v) for v in self.rpy))
        if self.grip_m is not None:
            if not (math.isfinite(self.grip_m) and self.grip_m >= 0.0):
                raise ValueError(f"PoseTarget.grip_m = {self.grip_m!r}: expected a finite opening ≥ 0 m or None")
            object.__setattr__(self, "grip_m", float(self.grip_m))


def pose_target_to_matrix(pose: PoseTarget) -> np.ndarray:
    """``base_T_tool`` (4x4) of a pose: R = Rz(yaw) · Ry(pitch) · Rx(roll), as ClikKinematics."""
    roll, pitch, yaw = pose.rpy
    return pose_matrix(pose.base_p, rpy_to_matrix(roll, pitch, yaw))


def pose_target_from_matrix(base_T_tool: np.ndarray, grip_m: Optional[float] = None) -> PoseTarget:
    """The PoseTarget of a 4x4 ``base_T_tool`` (e.g. ``ClikKinematics.fk_pose(q)``)."""
    T = np.asarray(base_T_tool, dtype=float)
    if T.shape != (4, 4):
        raise ValueError(f"base_T_tool must be a 4x4 matrix, got shape {T.shape}")
    return PoseTarget(tuple(T[:3, 3]), matrix_to_rpy(T[:3, :3]), grip_m)


def wrap_pi(angle_rad: float) -> float:
    """An angle wrapped into (-π, π]."""
    a = math.remainder(angle_rad, 2.0 * math.pi)
    return math.pi if a == -math.pi else a


def radial_yaw(x_m: float, y_m: float) -> float:
    """Azimuth (rad) of the arm's radial direction towards (x, y); 0 on the base axis."""
    return math.atan2(y_m, x_m) if (x_m or y_m) else 0.0


def absolute_yaw(relative_yaw_rad: float, x_m: float, y_m: float) -> float:
    """Absolute yaw (rad, in (-π, π]) for a yaw relative to the radial direction at (x, y)."""
    return wrap_pi(radial_yaw(x_m, y_m) + relative_yaw_rad)


def relative_yaw(absolute_yaw_rad: float, x_m: float, y_m: float) -> float:
    """Yaw relative to the radial direction at (x, y) (rad, in (-π, π]); inverse of the above."""
    return wrap_pi(absolute_yaw_rad - radial_yaw(x_m, y_m))


def pose_panel_applies(profile: Any) -> bool:
    """True for arms that can take a full 6D pose: URDF profiles with 6 joints or more."""
    return getattr(profile, "kind", None) == "urdf" and len(profile.joints) >= 6


def _check_range(name: str, lo: float, hi: float) -> tuple[float, float]:
    lo, hi = float(lo), float(hi)
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(f"pose range {name} = ({lo!r}, {hi!r}): expected finite numbers, low < high")
    return lo, hi


class PosePanel(QtWidgets.QWidget):
    """Big touch fields for a tool pose: X, Y, Z (cm), yaw, pitch, roll (deg), grip (mm).

    Typed values keep their decimals (12.34 stays 12.34) and commit on Enter or when the
    field loses focus; the −/+ buttons step. "Yaw relative to the arm's radial direction"
    shows yaw as ``absolute − atan2(y, x)``; ticking it converts the shown value and emits
    nothing (the pose is unchanged). The grip row is hidden for arms without a gripper.

    Signals (GUI thread):
        sigPoseChanged(object): a :class:`PoseTarget` (m, rad, absolute yaw), each time the
            user commits a field; never from :meth:`set_pose` or :meth:`set_ranges`.
    """

    sigPoseChanged = QtCore.Signal(object)

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._updating = False
        self._has_grip = True
        xy_cm = tuple(v * M_TO_CM for v in DEFAULT_XY_M)
        z_cm = tuple(v * M_TO_CM for v in DEFAULT_Z_M)
        grip_mm = tuple(v * M_TO_MM for v in DEFAULT_GRIP_M)
        a = ANGLE_LIMIT_DEG
        specs = (  # key, label, lo, hi, step
            ("x", "X (cm)", *xy_cm, 0.5),
            ("y", "Y (cm)", *xy_cm, 0.5),
            ("z", "Z (cm)", *z_cm, 0.5),
            ("yaw", "Yaw (°)", -a, a, 1.0),
            ("pitch", "Pitch (°)", -a, a, 1.0),
            ("roll", "Roll (°)", -a, a, 1.0),
            ("grip", "Grip (mm per finger)", *grip_mm, 1.0),
        )
        grid = QtWidgets.QGridLayout(self)
        grid.setContentsMargins(4, 4, 4, 4)
        grid.setHorizontalSpacing(8)
        grid.setVerticalSpacing(4)
        grid.setColumnStretch(1, 1)
        self.spins: dict[str, TouchDoubleSpinBox] = {}
        self.labels: dict[str, QtWidgets.QLabel] = {}
        row = 0
        for key, text, lo, hi, step in specs:
            if key == "yaw":
                self.relative_yaw_box = QtWidgets.QCheckBox("Yaw relative to the arm's radial direction")
                self.relative_yaw_box.setStyleSheet(CHECKBOX_STYLE)
                self.relative_yaw_box.setMinimumHeight(TOUCH_PX)
                self.relative_yaw_box.toggled.connect(self._on_relative_toggled)
                grid.addWidget(self.relative_yaw_box, row, 0, 1, 2)
                row += 1
            label = QtWidgets.QLabel(text)
            spin = TouchDoubleSpinBox(lo, hi, decimals=DECIMALS, step=step)
            if key in ("yaw", "pitch", "roll"):
                spin.setWrapping(True)  # −180° and 180° are one angle: the buttons go round
            spin.setValue(0.0)
            spin.valueChanged.connect(self._on_edit)
            label.setBuddy(spin)
            grid.addWidget(label, row, 0)
            grid.addWidget(spin, row, 1)
            self.spins[key] = spin
            self.labels[key] = label
            row += 1
        self.convention_label = QtWidgets.QLabel(
            "Roll, pitch, yaw turn the tool about the base's fixed x, y, z axes.")
        self.convention_label.setWordWrap(True)
        font = self.convention_label.font()
        font.setPointSizeF(max(7.0, font.pointSizeF() * 0.85))
        self.convention_label.setFont(font)
        grid.addWidget(self.convention_label, row, 0, 1, 2)
        grid.setRowStretch(row + 1, 1)

    # ----------------------------------------------------------------------------- public API
    @property
    def relative_yaw(self) -> bool:
        """True when the yaw field is relative to the arm's radial direction."""
        return self.relative_yaw_box.isChecked()

    def set_relative_yaw(self, relative: bool) -> None:
        """Show yaw relative to the radial direction (True) or absolute; emits nothing."""
        self.relative_yaw_box.setChecked(bool(relative))

    def pose(self) -> PoseTarget:
        """The pose the fields show, in SI units with the absolute yaw."""
        x, y, z = (self.spins[k].value() / M_TO_CM for k in ("x", "y", "z"))
        yaw = math.radians(self.spins["yaw"].value())
        if self.relative_yaw:
            yaw = absolute_yaw(yaw, x, y)
        roll = math.radians(self.spins["roll"].value())
        pitch = math.radians(self.spins["pitch"].value())
        grip = self.spins["grip"].value() / M_TO_MM if self._has_grip else None
        return PoseTarget((x, y, z), (roll, pitch, wrap_pi(yaw)), grip)

    def set_pose(self, pose: PoseTarget) -> None:
        """Show ``pose`` (clamped to the fields' ranges) without emitting sigPoseChanged."""
        x, y, z = pose.base_p
        roll, pitch, yaw = pose.rpy
        if self.relative_yaw:
            yaw = relative_yaw(yaw, x, y)
        values = {"x": x * M_TO_CM, "y": y * M_TO_CM, "z": z * M_TO_CM,
                  "yaw": math.degrees(wrap_pi(yaw)), "pitch": math.degrees(wrap_pi(pitch)),
                  "roll": math.degrees(wrap_pi(roll))}
        if pose.grip_m is not None:
            values["grip"] = pose.grip_m * M_TO_MM
        self._set_values(values)

    def set_ranges(self, x_m: Sequence[float], y_m: Sequence[float], z_m: Sequence[float],
                   grip_m: Optional[Sequence[float]] = DEFAULT_GRIP_M) -> None:
        """Ranges of the position fields (m) and of the grip (m per finger; None: no gripper,
        the grip row is hidden and poses carry ``grip_m = None``). Emits nothing."""
        ranges = {"x": _check_range("x", *x_m), "y": _check_range("y", *y_m),
                  "z": _check_range("z", *z_m)}
        self._has_grip = grip_m is not None
        if grip_m is not None:
            ranges["grip"] = _check_range("grip", *grip_m)
        self._updating = True
        try:
            for key, (lo, hi) in ranges.items():
                scale = M_TO_MM if key == "grip" else M_TO_CM
                spin = self.spins[key]
                spin.setRange(lo * scale, hi * scale)
                spin.setMinimumWidth(spin._width_for(lo * scale, hi * scale, DECIMALS, ""))
        finally:
            self._updating = False
        for widget in (self.spins["grip"], self.labels["grip"]):
            widget.setVisible(self._has_grip)

    def configure_for(self, profile: Any, kinematics: Any = None) -> None:
        """Ranges from a robot profile: X, Y within the horizontal reach, Z over the reachable
        heights (from the desk up), the grip from the profile's gripper (hidden without one)."""
        r_max = 1.0
        z_lo, z_hi = DEFAULT_Z_M
        if kinematics is not None and hasattr(kinematics, "workspace_radius_range"):
            r_max = float(kinematics.workspace_radius_range()[1])
        if kinematics is not None and hasattr(kinematics, "workspace_outline_side"):
            outline = np.asarray(kinematics.workspace_outline_side(), dtype=float).reshape(-1, 2)
            finite = outline[np.isfinite(outline).all(axis=1)]
            if len(finite):
                r_max = max(r_max, float(np.max(np.abs(finite[:, 0]))))
                z_lo, z_hi = max(0.0, float(finite[:, 1].min())), float(finite[:, 1].max())

        def up(v: float) -> float:
            return math.ceil(v * M_TO_CM / RANGE_ROUND_CM) * RANGE_ROUND_CM / M_TO_CM

        r = up(r_max)
        gripper = getattr(profile, "gripper", None)
        grip = None if gripper is None else (gripper.min_m, gripper.max_m)
        self.set_ranges((-r, r), (-r, r), (math.floor(z_lo * M_TO_CM) / M_TO_CM, up(z_hi)), grip)

    # ----------------------------------------------------------------------------- internals
    def _set_values(self, values: dict[str, float]) -> None:
        self._updating = True
        try:
            for key, value in values.items():
                self.spins[key].setValue(value)
        finally:
            self._updating = False

    def _on_edit(self, _value: float) -> None:
        if not self._updating:
            self.sigPoseChanged.emit(self.pose())

    def _on_relative_toggled(self, relative: bool) -> None:
        """Convert the shown yaw so the pose stays the same."""
        x, y = self.spins["x"].value() / M_TO_CM, self.spins["y"].value() / M_TO_CM
        shown = math.radians(self.spins["yaw"].value())
        converted = relative_yaw(shown, x, y) if relative else absolute_yaw(shown, x, y)
        self._set_values({"yaw": math.degrees(converted)})
        self.labels["yaw"].setText("Yaw, relative (°)" if relative else "Yaw (°)")
