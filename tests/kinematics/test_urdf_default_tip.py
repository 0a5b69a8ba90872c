"""The tip a URDF gets without --tip is one deskarm accepts: never a finger behind a mimic whose
mimicked joint is off its chain (`deskarm ik --robot urdf:…umi_rtx.urdf` exited 2 on its own default)."""
from __future__ import annotations

import io
import json
from pathlib import Path

from app.cli_kinematics import run_ik
from core.kinematics.urdf import read_urdf_chain

ROOT = Path(__file__).resolve().parents[2]
UMI_URDF = ROOT / "resources" / "robots" / "umi_rtx.urdf"

# the arm ends at a fixed tool; two fingers hang off the last link, the right one mimics the left
# (the right finger is listed last, so "the deepest link, the last on ties" picked it)
GRIPPER_ONLY = """<?xml version="1.0"?>
<robot name="gripper_arm">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="tool"/>
  <link name="finger_a"/><link name="finger_b"/>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="l1"/><child link="l2"/><origin xyz="0.2 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/>
  </joint>
  <joint name="tool_joint" type="fixed">
    <parent link="l2"/><child link="tool"/><origin xyz="0.1 0 0"/>
  </joint>
  <joint name="finger_a_joint" type="prismatic">
    <parent link="l2"/><child link="finger_a"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.05" effort="1" velocity="0.1"/>
  </joint>
  <joint name="finger_b_joint" type="prismatic">
    <parent link="l2"/><child link="finger_b"/><axis xyz="0 -1 0"/>
    <limit lower="0" upper="0.05" effort="1" velocity="0.1"/>
    <mimic joint="finger_a_joint"/>
  </joint>
</robot>
"""


def test_the_umi_rtx_urdf_defaults_to_its_tool_and_the_ik_command_solves():
    assert read_urdf_chain(UMI_URDF).tip == "tool"
    out, err = io.StringIO(), io.StringIO()
    code = run_ik(["--robot", f"urdf:{UMI_URDF}", "--target", "0.2,0,0.3", "--json"], out=out, err=err)
    assert code == 0, err.getvalue()
    assert json.loads(out.getvalue())["success"] is True


def test_a_urdf_whose_last_deepest_link_is_a_mimic_finger_defaults_to_a_tip_it_accepts(tmp_path):
    path = tmp_path / "gripper_arm.urdf"
    path.write_text(GRIPPER_ONLY)
    chain = read_urdf_chain(path)
    assert chain.tip == "tool" and [j.name for j in chain.joints] == ["shoulder", "elbow"]
    # the fingers stay reachable as explicit tips where the chain allows it
    assert read_urdf_chain(path, tip="finger_a").tip == "finger_a"
