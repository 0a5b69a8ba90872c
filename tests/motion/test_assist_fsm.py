"""The approach state machine: align → approach → act → idle, drift, lost target, timeouts."""
import math

import numpy as np
import pytest

from core.kinematics.clik import ClikKinematics
from core.kinematics.profile import load_profile
from core.motion.assist import ApproachFsm, AssistConfig, AssistState, TargetObservation
from core.motion.servoing import IbvsConfig, IbvsController
from core.sim.scenarios import Panel, PanelScenario

K = np.array([[525.0, 0.0, 319.5], [0.0, 525.0, 239.5], [0.0, 0.0, 1.0]])
DT = 1.0 / 30.0


@pytest.fixture(scope="module")
def servo():
    return IbvsController(ClikKinematics(load_profile("assistive_5dof")), K,
                          IbvsConfig(axis_tilt_rad=math.radians(30.0)))


def _observe(kin, q, point, offset=(0.0, 0.0)):
    camera_p = np.linalg.inv(kin.camera_pose(q)) @ np.append(point, 1.0)
    uv = (K @ camera_p[:3])[:2] / camera_p[2] + np.asarray(offset)
    return TargetObservation(tuple(uv), float(camera_p[2]))


def _run(fsm, servo, point, until, t=0.0, q=None, offset_fn=None, hide_fn=None):
    kin = servo.kinematics
    q = tuple(kin.q_home) if q is None else q
    while t < until and fsm.state != AssistState.IDLE:
        obs = None if hide_fn and hide_fn(t) else _observe(kin, q, point, offset_fn(t) if offset_fn else (0, 0))
        q = fsm.step(t, q, obs, DT).q
        t += DT
    return t, q


def test_align_approach_act_idle_presses_the_button(servo):
    point = np.array(Panel(*PanelScenario.PANEL_XY, yaw=PanelScenario.PANEL_YAW).button_centre(5))
    fsm = ApproachFsm(servo)
    fsm.start(0.0, "button 5")
    _run(fsm, servo, point, 30.0)
    assert [e.to_state for e in fsm.events] == [AssistState.ALIGN, AssistState.APPROACH, AssistState.ACT,
                                                 AssistState.IDLE]
    assert fsm.outcome.startswith("pressed")
    deepest = fsm.deepest_tool
    assert np.hypot(*(deepest[:2] - point[:2])) < 0.004  # along a 30° tilted axis, 4 mm past the top
    assert deepest[2] < point[2] - 0.002
    assert all(e.reason for e in fsm.events)


def test_a_drift_in_approach_goes_back_to_align(servo):
    point = np.array(Panel(*PanelScenario.PANEL_XY, yaw=PanelScenario.PANEL_YAW).button_centre(2))
    fsm2 = ApproachFsm(servo)
    fsm2.start(0.0, "button 2")
    jumped = {}

    def offset(t):  # once approaching, the target jumps 60 px (as if bumped)
        if fsm2.state == AssistState.APPROACH and "t" not in jumped:
            jumped["t"] = t
        return (60.0, 0.0) if "t" in jumped and t - jumped["t"] < 0.3 else (0.0, 0.0)

    _run(fsm2, servo, point, 30.0, offset_fn=offset)
    states = [e.to_state for e in fsm2.events]
    assert states[:3] == [AssistState.ALIGN, AssistState.APPROACH, AssistState.ALIGN]
    assert "drifted" in fsm2.events[2].reason
    assert fsm2.outcome.startswith("pressed")


def test_lost_target_returns_to_idle(servo):
    point = np.array(Panel(*PanelScenario.PANEL_XY, yaw=PanelScenario.PANEL_YAW).button_centre(5))
    fsm = ApproachFsm(servo, AssistConfig(lost_after_s=0.5))
    fsm.start(0.0, "button 5")
    _run(fsm, servo, point, 10.0, hide_fn=lambda t: t > 0.3)
    assert fsm.state == AssistState.IDLE and fsm.outcome.startswith("lost target")


def test_align_timeout(servo):
    point = np.array(Panel(*PanelScenario.PANEL_XY, yaw=PanelScenario.PANEL_YAW).button_centre(5))
    fsm = ApproachFsm(servo, AssistConfig(align_timeout_s=0.3))
    fsm.start(0.0, "button 5")
    _run(fsm, servo, point, 10.0, offset_fn=lambda t: (200.0, 0.0))  # a target that never comes near
    assert fsm.outcome.startswith("timeout")
    assert fsm.events[-1].from_state == AssistState.ALIGN


def test_stop_from_any_state_and_busy_start_is_refused(servo):
    fsm = ApproachFsm(servo)
    fsm.start(0.0, "x")
    with pytest.raises(ValueError, match="busy"):
        fsm.start(0.1, "y")
    fsm.stop(0.2)
    assert fsm.state == AssistState.IDLE and fsm.event_log()[-1]["reason"] == "stopped by the user"


def test_a_depth_outlier_is_dropped_with_its_observation(servo):
    fsm = ApproachFsm(servo)
    fsm.start(0.0, "x")
    q = tuple(servo.kinematics.q_home)
    t = 0.0
    for _ in range(4):
        status = fsm.step(t, q, TargetObservation((300.0, 200.0), 0.20), DT)
        t += DT
    assert status.depth_m == pytest.approx(0.20)
    status = fsm.step(t, q, TargetObservation((340.0, 200.0), 0.16), DT)  # a mis-fitted ellipse
    assert status.depth_m == pytest.approx(0.20)
    assert status.filtered_px[0] == pytest.approx(300.0, abs=1.0)  # its centre was dropped too
