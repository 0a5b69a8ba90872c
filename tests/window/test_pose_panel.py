"""The manual pose panel (pytest-qt, offscreen): typed decimals, relative yaw, the signal's
payload, ranges from a profile, and the pose → matrix → IK → FK round trip on the UMI-RTX."""
from __future__ import annotations

import math
import os

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402
import pytest  # noqa: E402
from PySide6 import QtCore, QtWidgets  # noqa: E402

import widgets  # noqa: E402,F401
from core.kinematics import build_kinematics, load_profile  # noqa: E402
from widgets.pose_panel import (  # noqa: E402
    PosePanel,
    PoseTarget,
    absolute_yaw,
    pose_panel_applies,
    pose_target_from_matrix,
    pose_target_to_matrix,
    relative_yaw,
)

TIMEOUT_MS = 1000
SCREEN_W, SCREEN_H = 800, 480
TOUCH_MIN_PX = 40


def close(a, b, tol=1e-9) -> bool:
    """Compare floats or sequences; pytest prints both sides on failure."""
    return np.allclose(np.asarray(a, dtype=float), np.asarray(b, dtype=float), atol=tol, rtol=0)


@pytest.fixture(scope="module")
def umi():
    profile = load_profile("umi_rtx")
    return profile, build_kinematics(profile)


@pytest.fixture
def panel(qtbot) -> PosePanel:
    widget = PosePanel()
    qtbot.addWidget(widget)
    widget.resize(SCREEN_W // 2, SCREEN_H)
    widget.show()
    qtbot.waitExposed(widget)
    return widget


def type_into(qtbot, spin, text: str):
    spin.setFocus()
    spin.selectAll()
    qtbot.keyClicks(spin, text)


# ------------------------------------------------------------------------------- typing
@pytest.mark.parametrize("key, text, field, expected", [
    ("x", "12.34", lambda p: p.base_p[0], 0.1234),
    ("z", "7.05", lambda p: p.base_p[2], 0.0705),
    ("pitch", "-12.34", lambda p: p.rpy[1], math.radians(-12.34)),
    ("grip", "12.34", lambda p: p.grip_m, 0.01234),
])
def test_typing_a_value_with_decimals_keeps_it_and_emits_it_in_si_units(
        qtbot, panel, key, text, field, expected):
    spin = panel.spins[key]
    type_into(qtbot, spin, text)
    with qtbot.waitSignal(panel.sigPoseChanged, timeout=TIMEOUT_MS) as blocker:
        qtbot.keyClick(spin, QtCore.Qt.Key.Key_Return)
    pose = blocker.args[0]
    assert isinstance(pose, PoseTarget)
    assert close(field(pose), expected)
    assert spin.value() == pytest.approx(float(text))
    assert spin.text() == text


def test_typing_emits_once_on_enter_not_per_keystroke(qtbot, panel):
    received = []
    panel.sigPoseChanged.connect(received.append)
    type_into(qtbot, panel.spins["y"], "23.45")
    assert received == []
    qtbot.keyClick(panel.spins["y"], QtCore.Qt.Key.Key_Return)
    assert len(received) == 1 and close(received[0].base_p[1], 0.2345)


def test_the_payload_is_a_frozen_pose_with_the_absolute_yaw(qtbot, panel):
    with qtbot.waitSignal(panel.sigPoseChanged, timeout=TIMEOUT_MS) as blocker:
        panel.spins["yaw"].setValue(30.0)
    pose = blocker.args[0]
    assert close(pose.rpy[2], math.radians(30.0))
    with pytest.raises(AttributeError):
        pose.grip_m = 0.0  # type: ignore[misc]
    with pytest.raises(ValueError, match="base_p"):
        PoseTarget((0.0, float("nan"), 0.0), (0.0, 0.0, 0.0))


# ------------------------------------------------------------------------------- relative yaw
def test_relative_yaw_adds_the_arms_radial_direction(qtbot, panel):
    panel.set_pose(PoseTarget((0.3, 0.3, 0.2), (0.0, 0.0, 0.0)))
    panel.set_relative_yaw(True)
    with qtbot.waitSignal(panel.sigPoseChanged, timeout=TIMEOUT_MS) as blocker:
        panel.spins["yaw"].setValue(10.0)
    assert close(blocker.args[0].rpy[2], math.atan2(0.3, 0.3) + math.radians(10.0))
    # moving the arm round keeps the hand at 10° from the radial direction
    with qtbot.waitSignal(panel.sigPoseChanged, timeout=TIMEOUT_MS) as blocker:
        panel.spins["x"].setValue(-30.0)
    assert close(blocker.args[0].rpy[2], math.atan2(0.3, -0.3) + math.radians(10.0))


def test_ticking_relative_yaw_converts_the_field_and_keeps_the_pose(qtbot, panel):
    panel.set_pose(PoseTarget((0.0, 0.25, 0.1), (0.0, 0.2, math.radians(100.0)), 0.02))
    before = panel.pose()
    with qtbot.assertNotEmitted(panel.sigPoseChanged):
        panel.relative_yaw_box.click()
    assert panel.relative_yaw
    assert panel.spins["yaw"].value() == pytest.approx(10.0)  # 100° − atan2(0.25, 0) = 10°
    assert close(panel.pose().rpy, before.rpy, tol=1e-4)
    assert "relative" in panel.labels["yaw"].text()
    with qtbot.assertNotEmitted(panel.sigPoseChanged):
        panel.relative_yaw_box.click()
    assert panel.spins["yaw"].value() == pytest.approx(100.0)


def test_relative_and_absolute_yaw_are_inverse_and_wrap_into_plus_minus_pi():
    for yaw in (-3.0, -0.5, 0.0, 1.0, 3.1):
        for x, y in ((0.3, 0.1), (-0.2, -0.4), (0.0, 0.0)):
            assert close(absolute_yaw(relative_yaw(yaw, x, y), x, y), yaw)
    assert -math.pi < absolute_yaw(3.0, -0.1, 0.1) <= math.pi


# ------------------------------------------------------------------------------- set / ranges
def test_set_pose_shows_the_pose_without_emitting(qtbot, panel):
    pose = PoseTarget((0.1234, -0.05, 0.3), (0.1, -0.2, 0.3), 0.0125)
    with qtbot.assertNotEmitted(panel.sigPoseChanged):
        panel.set_pose(pose)
    assert panel.spins["x"].value() == pytest.approx(12.34)
    assert panel.spins["grip"].value() == pytest.approx(12.5)
    got = panel.pose()
    assert close(got.base_p, pose.base_p) and close(got.rpy, pose.rpy, tol=1e-4)
    assert close(got.grip_m, pose.grip_m)


def test_set_ranges_checks_its_input_and_hides_the_grip_without_a_gripper(qtbot, panel):
    with pytest.raises(ValueError, match="pose range x"):
        panel.set_ranges((0.5, -0.5), (-1, 1), (0, 1))
    with qtbot.assertNotEmitted(panel.sigPoseChanged):
        panel.set_ranges((-0.2, 0.2), (-0.2, 0.2), (0.0, 0.3), None)
    assert panel.spins["x"].maximum() == pytest.approx(20.0)
    assert not panel.spins["grip"].isVisible() and panel.pose().grip_m is None


def test_configure_for_takes_ranges_and_the_grip_from_the_profile(qtbot, panel, umi):
    profile, kin = umi
    panel.configure_for(profile, kin)
    grip = panel.spins["grip"]
    assert grip.isVisible()
    assert (grip.minimum(), grip.maximum()) == pytest.approx((0.0, 50.0))  # mm per finger
    r_max_cm = kin.workspace_radius_range()[1] * 100
    assert panel.spins["x"].maximum() >= r_max_cm and panel.spins["y"].minimum() <= -r_max_cm
    assert panel.spins["z"].minimum() >= 0.0 and panel.spins["z"].maximum() >= 100.0
    rrr = load_profile("desk_rrr")
    panel.configure_for(rrr, build_kinematics(rrr))
    assert not panel.spins["grip"].isVisible()


def test_the_panel_applies_to_six_joint_arms_only(umi):
    assert pose_panel_applies(umi[0])
    assert not pose_panel_applies(load_profile("assistive_5dof"))
    assert not pose_panel_applies(load_profile("desk_rrr"))


# ------------------------------------------------------------------------------- matrices
def test_pose_matrix_uses_pinocchios_roll_pitch_yaw():
    pose = PoseTarget((0.1, 0.2, 0.3), (0.4, -0.7, 2.5))
    T = pose_target_to_matrix(pose)
    assert close(T[:3, :3], pin.rpy.rpyToMatrix(0.4, -0.7, 2.5))
    assert close(T[:3, 3], pose.base_p) and close(T[3], (0, 0, 0, 1))
    back = pose_target_from_matrix(T, 0.01)
    assert close(back.rpy, pose.rpy) and back.grip_m == 0.01


def test_pose_matrix_is_the_one_the_controller_solves_for():
    from core.motion.control import goal_pose_matrix

    pose = PoseTarget((0.2, -0.1, 0.4), (-1.1, 0.3, -2.9), 0.01)
    # the controller takes Goal(base_p_target, orientation_rpy=(roll, pitch, yaw)):
    # targeter.set_manual_pose(pose.base_p, pose.rpy, pose.grip_m)
    assert close(pose_target_to_matrix(pose), goal_pose_matrix(pose.base_p, pose.rpy))


def test_a_pose_round_trips_through_umi_rtx_ik_and_fk(umi):
    profile, kin = umi
    q_true = (0.35, -0.6, 1.2, 0.4, 0.3, -0.9)
    assert kin.within_limits(q_true)
    pose = pose_target_from_matrix(kin.fk_pose(q_true))
    oMdes = pose_target_to_matrix(pose)
    assert close(oMdes, kin.fk_pose(q_true))
    result = kin.ik_pose(oMdes, kin.q_home)
    assert result.success, result.message
    assert close(kin.fk_pose(result.q), oMdes, tol=1e-5)


def test_the_panels_payload_drives_umi_rtx_ik_to_the_typed_pose(qtbot, panel, umi):
    profile, kin = umi
    panel.configure_for(profile, kin)
    q_true = (0.3, -0.4, 1.0, 0.2, -0.3, -1.0)
    panel.set_relative_yaw(True)
    panel.set_pose(pose_target_from_matrix(kin.fk_pose(q_true), 0.02))
    with qtbot.waitSignal(panel.sigPoseChanged, timeout=TIMEOUT_MS) as blocker:
        panel.spins["z"].setValue(panel.spins["z"].value() + 2.0)  # 2 cm higher
    pose = blocker.args[0]
    want = kin.fk_pose(q_true)
    want[2, 3] += 0.02
    oMdes = pose_target_to_matrix(pose)
    # the fields keep two decimals: 0.1 mm and 0.01°
    assert close(oMdes[:3, 3], want[:3, 3], tol=1e-4)
    assert close(oMdes[:3, :3], want[:3, :3], tol=5e-4)
    result = kin.ik_pose(oMdes, q_true)
    assert result.success, result.message
    assert close(kin.fk_pose(result.q), oMdes, tol=1e-5)
    assert pose.grip_m == pytest.approx(0.02)


# ------------------------------------------------------------------------------- sizes
def test_panel_fits_800x480_and_has_finger_sized_controls(qtbot):
    panel = PosePanel()
    hint = panel.minimumSizeHint()
    assert hint.width() <= SCREEN_W and hint.height() <= SCREEN_H, hint
    area = QtWidgets.QScrollArea()
    area.setWidgetResizable(True)
    area.setWidget(panel)
    qtbot.addWidget(area)
    area.resize(SCREEN_W // 2, SCREEN_H)
    area.show()
    qtbot.waitExposed(area)
    controls = [c for c in panel.findChildren(QtWidgets.QWidget)
                if isinstance(c, (QtWidgets.QAbstractSpinBox, QtWidgets.QCheckBox))]
    assert len(controls) == 8
    for control in controls:
        assert control.height() >= TOUCH_MIN_PX, (type(control).__name__, control.height())
