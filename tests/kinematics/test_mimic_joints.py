"""URDF mimic joints: derived from the joint they mimic (q = m·q_X + o), never a variable of their own."""
from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from checks import assert_close  # tests/ is on sys.path

from core.kinematics import ProfileError, build_kinematics, load_profile
from core.kinematics.base import pose_matrix, rpy_to_matrix

# A telescoping column (the upper stage follows the lower one at half speed, 2 cm ahead), a
# two-link arm whose last link is geared to the elbow (q3 = 0.5·q2 + 0.1), and a parallel
# gripper whose second finger mirrors the first (off the tool's chain).
URDF = """<?xml version="1.0"?>
<robot name="mimic_arm">
  <link name="base"/><link name="stage1"/><link name="stage2"/><link name="l1"/><link name="l2"/>
  <link name="l3"/><link name="tool"/><link name="finger_a"/><link name="finger_b"/>
  <joint name="column" type="prismatic">
    <parent link="base"/><child link="stage1"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="0.4" effort="1" velocity="0.1"/>
  </joint>
  <joint name="column_upper" type="prismatic">
    <parent link="stage1"/><child link="stage2"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="0.15" effort="1" velocity="0.1"/>
    <mimic joint="column" multiplier="0.5" offset="0.02"/>
  </joint>
  <joint name="shoulder" type="revolute">
    <parent link="stage2"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-2.5" upper="2.5" effort="1" velocity="1"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="l1"/><child link="l2"/><origin xyz="0.2 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-2.5" upper="2.5" effort="1" velocity="1"/>
  </joint>
  <joint name="hand" type="revolute">
    <parent link="l2"/><child link="l3"/><origin xyz="0.15 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/>
    <mimic joint="elbow" multiplier="0.5" offset="0.1"/>
  </joint>
  <joint name="tool_joint" type="fixed">
    <parent link="l3"/><child link="tool"/><origin xyz="0.1 0 0"/>
  </joint>
  <joint name="finger_a_joint" type="prismatic">
    <parent link="l3"/><child link="finger_a"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.05" effort="1" velocity="0.1"/>
  </joint>
  <joint name="finger_b_joint" type="prismatic">
    <parent link="l3"/><child link="finger_b"/><axis xyz="0 -1 0"/>
    <limit lower="0" upper="0.05" effort="1" velocity="0.1"/>
    <mimic joint="finger_a_joint"/>
  </joint>
</robot>
"""
MIMICS = {"column_upper": ("column", 0.5, 0.02), "hand": ("elbow", 0.5, 0.1)}


@pytest.fixture(scope="module")
def urdf_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("mimic") / "mimic_arm.urdf"
    path.write_text(URDF)
    return path


@pytest.fixture(scope="module")
def kin(urdf_path):
    return build_kinematics(load_profile(f"urdf:{urdf_path}", tip="tool"))


def independent_tool_pose(urdf_path, q, frame="tool"):
    """The frame's pose from a model in which every joint is independent (mimic tags ignored),
    with each mimic joint set to m·q_X + o by hand: what the real linkage does."""
    model = pin.buildModelFromUrdf(str(urdf_path))  # mimic=False: all joints are coordinates
    data = model.createData()
    values = dict(zip(("column", "shoulder", "elbow"), q))
    for name, (primary, m, o) in MIMICS.items():
        values[name] = m * values[primary] + o
    q_full = pin.neutral(model)
    for j in range(1, model.njoints):
        q_full[model.joints[j].idx_q] = values.get(model.names[j], 0.0)
    pin.framesForwardKinematics(model, data, q_full)
    return data.oMf[model.getFrameId(frame)].homogeneous.copy()


def test_mimic_joints_on_the_chain_are_not_profile_variables(kin):
    assert kin.profile.joint_names == ("column", "shoulder", "elbow")
    assert kin.n_joints == 3 and kin.jacobian(kin.q_home).shape == (3, 3)
    assert {m.name: (m.primary, m.multiplier, m.offset) for m in kin.mimic_joints} == MIMICS
    assert kin.mimic_values((0.2, 0.0, 0.6)) == pytest.approx({"column_upper": 0.12, "hand": 0.4})


def test_the_mimicked_joint_is_narrowed_so_its_mimic_stays_within_its_limits(kin):
    # column_upper = 0.5·column + 0.02 ≤ 0.15 m  →  column ≤ 0.26 m (the URDF allows 0.4)
    assert kin.profile.q_min[0] == 0.0 and kin.profile.q_max[0] == pytest.approx(0.26)
    # hand = 0.5·elbow + 0.1 within ±2 rad allows elbow −4.2 … 3.8: the elbow's ±2.5 stands
    assert (kin.profile.q_min[2], kin.profile.q_max[2]) == (-2.5, 2.5)


def test_fk_moves_each_mimic_with_the_joint_it_mimics(kin, urdf_path):
    for q in np.random.default_rng(3).uniform(kin.q_min, kin.q_max, (50, 3)):
        assert_close(kin.fk_pose(q), independent_tool_pose(urdf_path, q), 1e-12, f"tool pose at {q}")
        assert_close(kin.frame_pose(q, "l3"), independent_tool_pose(urdf_path, q, "l3"), 1e-12, "hand link")


def test_jacobian_includes_the_mimics_motion(kin):
    q = np.array([0.1, 0.4, -0.7])
    h = 1e-6
    fd = np.column_stack([(kin.fk(q + h * e) - kin.fk(q - h * e)) / (2 * h) for e in np.eye(3)])
    assert_close(kin.jacobian(q), fd, 1e-8, "Jacobian vs central differences")


def test_ik_never_moves_a_mimic_joint_on_its_own(kin, urdf_path):
    """Targets the linkage can reach are reached, and the answer is a pose of the real linkage:
    the tool where the independent model puts it with every mimic at m·q_X + o."""
    rng = np.random.default_rng(7)
    for q_true in rng.uniform(kin.q_min, kin.q_max, (40, 3)):
        target = independent_tool_pose(urdf_path, q_true)[:3, 3]
        for q_cur in (None, kin.q_home):
            res = kin.ik(tuple(target), q_cur)
            assert res.success and len(res.q) == 3, res
            assert_close(independent_tool_pose(urdf_path, res.q)[:3, 3], target, 1e-6, f"IK of {q_true}")
    # a pose solve too: position and the hand's yaw (shoulder + 1.5·elbow + 0.1) together
    q_true = (0.2, 0.3, 0.8)
    T = independent_tool_pose(urdf_path, q_true)
    res = kin.ik_pose(T, kin.q_home)
    assert res.success, res
    assert_close(independent_tool_pose(urdf_path, res.q), T, 1e-5, "pose IK")


def test_a_point_only_an_independent_hand_could_reach_is_out_of_reach(kin, urdf_path):
    # with the hand free this pose is reachable (shoulder −0.60, elbow 0.73, hand 1.07 rad); with
    # the hand geared to the elbow it is not: the solver reports that instead of moving the hand alone
    T = pose_matrix((0.35, 0.0, 0.2), rpy_to_matrix(0.0, 0.0, 1.2))
    res = kin.ik_pose(T, kin.q_home)
    assert not res.success and res.message
    assert_close(kin.fk_pose(res.q), independent_tool_pose(urdf_path, res.q), 1e-12, "still the linkage")


def test_chain_points_include_the_mimic_joints(kin, urdf_path):
    q = (0.1, 0.5, -0.4)
    pts = kin.chain_points(q)
    assert pts.shape == (7, 3)  # origin, 5 joints (2 mimics), tool
    assert_close(pts[-1], kin.fk(q), 0.0, "ends at the tool")
    assert_close(pts[5], independent_tool_pose(urdf_path, q, "l3")[:3, 3], 1e-12, "the hand joint")


def test_mimic_fingers_off_the_chain_are_locked(kin):
    assert "finger_a_joint" not in kin.profile.joint_names and "finger_b_joint" not in kin.profile.joint_names


def test_a_tip_behind_a_mimic_of_a_joint_off_its_chain_is_refused(urdf_path):
    with pytest.raises(ProfileError, match=r"joint 'finger_b_joint' on the chain to 'finger_b' mimics"
                                           r" 'finger_a_joint', which is not on that chain"):
        load_profile(f"urdf:{urdf_path}", tip="finger_b")


def test_a_toml_override_of_a_mimic_joint_names_the_joint_to_set_instead(tmp_path, urdf_path):
    toml = tmp_path / "arm.toml"
    toml.write_text(f'name = "arm"\nkind = "urdf"\n[geometry]\nurdf = "{urdf_path}"\ntip = "tool"\n'
                    '[[joints]]\nname = "hand"\nupper = 1.0\n')
    with pytest.raises(ProfileError, match=r"joints\[0\]\.name = 'hand' is a mimic joint .*set 'elbow' instead"):
        load_profile(toml)


@pytest.mark.parametrize("mimic, expected", [
    ('<mimic joint="nope"/>', r"joint 'hand' mimics 'nope', which is not defined"),
    ('<mimic joint="hand"/>', r"joint 'hand' mimics itself"),
    ('<mimic joint="column_upper"/>', r"mimics 'column_upper', which itself mimics 'column'"),
    ('<mimic/>', r"joint 'hand': <mimic> needs joint="),
    ('<mimic joint="elbow" multiplier="two"/>', r"<mimic multiplier='two'> must be a finite number"),
    ('<mimic joint="elbow" offset="nan"/>', r"<mimic offset='nan'> must be a finite number"),
    ('<mimic joint="elbow" multiplier="0" offset="3"/>', r"multiplier 0: its value 3 .* outside its limits"),
    ('<mimic joint="elbow" multiplier="1" offset="10"/>', r"no value of 'elbow' within its limits keeps 'hand'"),
])
def test_malformed_mimics_are_refused_with_one_clear_line(tmp_path, mimic, expected):
    path = tmp_path / "bad.urdf"
    path.write_text(URDF.replace('<mimic joint="elbow" multiplier="0.5" offset="0.1"/>', mimic))
    with pytest.raises(ProfileError, match=rf"bad\.urdf: .*{expected}"):
        load_profile(f"urdf:{path}", tip="tool")


def test_a_joint_cannot_mimic_one_after_it_on_its_chain(tmp_path):
    path = tmp_path / "backwards.urdf"
    path.write_text(URDF.replace('<mimic joint="elbow" multiplier="0.5" offset="0.1"/>', "")
                    .replace('<joint name="shoulder" type="revolute">',
                             '<joint name="shoulder" type="revolute">\n    <mimic joint="hand"/>'))
    with pytest.raises(ProfileError, match=r"joint 'shoulder' mimics 'hand', which lies after it on the same chain"):
        load_profile(f"urdf:{path}", tip="tool")


def test_urdfs_without_mimics_are_unchanged():
    kin = build_kinematics(load_profile("umi_rtx"))
    assert kin.mimic_joints == () and kin.n_joints == 6 and kin.chain_points(kin.q_home).shape == (8, 3)
    assert math.isclose(kin.reach_bound_m, build_kinematics(load_profile("umi_rtx")).reach_bound_m)
