"""A simulated rig mounted off its nominal pose; the tool marker plate; the session's camera→arm state."""
import math

import numpy as np
import pytest

from core.handeye import save_hand_eye, solve_rigid
from core.session import DeskSession, SessionOptions
from core.sim.rig import SimRig, SimRigConfig

OFFSET = (0.03, -0.02, 0.01, math.radians(3), math.radians(-2), math.radians(4))


def test_offset_rig_renders_from_the_true_mount_and_keeps_the_nominal_one():
    nominal, moved = SimRig(), SimRig(SimRigConfig(mount_offset=OFFSET))
    assert np.allclose(moved.nominal_base_T_camera, nominal.base_T_camera)
    assert not np.allclose(moved.base_T_camera, nominal.base_T_camera)
    p = np.array([[0.0, 0.15, 0.0]])
    assert np.linalg.norm(moved.project("left", p) - nominal.project("left", p)) > 10  # px
    # a rigid move of both cameras leaves the stereo calibration alone
    assert np.allclose(moved.calibration().T, nominal.calibration().T)


@pytest.mark.parametrize("bad", [(0.3, 0, 0, 0, 0, 0), (0, 0, 0, math.radians(31), 0, 0), (math.nan,) * 6, (1, 2)])
def test_offsets_out_of_range_are_refused(bad):
    with pytest.raises(ValueError, match="rig-offset"):
        SessionOptions(camera="sim", rig_offset=bad).validate()


def _session(**kw):
    return DeskSession.create(SessionOptions(camera="sim", simulated_clock=True, **kw))


def test_camera_to_robot_state_texts(tmp_path):
    s = _session()
    try:
        assert s.camera_to_robot_state() == "camera→arm: simulated rig (exact)"
        assert np.allclose(s.perception.base_T_camera, s.camera.true_base_T_camera())
    finally:
        s.close()
    s = _session(rig_offset=OFFSET)
    try:
        assert s.camera_to_robot_state() == "camera→arm: NOMINAL — run calibration"
        assert np.allclose(s.perception.base_T_camera, s.camera.base_T_camera())  # nominal
        pair, true_T = s.hand_eye_pair_id, s.camera.true_base_T_camera()
    finally:
        s.close()
    B = np.random.default_rng(0).uniform(-0.2, 0.2, (8, 3))
    C = (B - true_T[:3, 3]) @ true_T[:3, :3]
    path = save_hand_eye(solve_rigid(C, B, camera_pair=pair), tmp_path / "he.toml")
    s = _session(rig_offset=OFFSET, hand_eye=str(path))
    try:
        assert s.camera_to_robot_state().startswith("camera→arm: calibrated, 0.0 mm RMS")
        assert np.allclose(s.perception.base_T_camera, true_T, atol=1e-9)
    finally:
        s.close()


def test_a_default_file_for_another_pair_gives_a_banner_and_the_nominal_mount(tmp_path, monkeypatch):
    monkeypatch.setenv("DESKARM_HOME", str(tmp_path))
    B = np.random.default_rng(0).uniform(-0.2, 0.2, (8, 3))
    save_hand_eye(solve_rigid(B, B, camera_pair="webcam:0,1"))
    s = _session(rig_offset=OFFSET)
    try:
        assert any("another camera pair" in b for b in s.banners)
        assert "NOMINAL" in s.camera_to_robot_state()
    finally:
        s.close()


def test_the_simulated_arm_carries_the_tool_marker_in_both_views():
    from core.vision.perception import StereoMarkerPerception

    s = _session()
    try:
        q = s.kinematics.ik((0.0, 0.15, 0.10)).q
        s.camera.set_arm_points(s.kinematics.chain_points(q))
        frame = s.camera.read()
        perception = StereoMarkerPerception(s.calibration, s.camera.true_base_T_camera(), marker_ids=(23, 50, 7))
        obs = perception.process(frame).marker(7)
        assert obs is not None and obs.found
        expected = np.asarray(s.kinematics.fk(q)) + np.array(s.tool_marker.offset_m)
        assert np.linalg.norm(np.subtract(obs.base_p_centre, expected)) < 0.002
    finally:
        s.close()
