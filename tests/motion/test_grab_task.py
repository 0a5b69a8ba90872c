"""The pick-and-place grab task: phases in order, moving on only on arrival, clean failures."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core.clock import SimClock
from core.devices.sim_arm import SimServoArm
from core.kinematics import build_kinematics, load_profile
from core.messages import JointCommand
from core.motion.grab_task import PHASES, GrabParams, GrabPhase, GrabTask
from core.motion.safety import is_within_limits

RATE_S = 0.02  # 50 Hz control


def run(name, params, max_s=60.0, stuck=False):
    """Step a task against the simulated arm; returns (task, commands, arrivals checked)."""
    profile = load_profile(name)
    kin = build_kinematics(profile)
    clock = SimClock()
    arm = SimServoArm(profile, clock=clock)
    arm.connect()
    q0 = arm.joint_state().q
    task = GrabTask(kin, profile, params, q0, clock.now())
    commands, transitions = [], []
    phase = task.phase
    seq = 0
    while not (task.done or task.failed) and clock.now() < max_s:
        q_meas = q0 if stuck else arm.joint_state().q
        cmd = task.step(clock.now(), q_meas)
        if cmd.phase is not phase:
            transitions.append((phase, np.asarray(kin.fk(q_meas))))
            phase = cmd.phase
        commands.append(cmd)
        seq += 1
        arm.send(JointCommand(seq, clock.now(), cmd.q))
        clock.advance(RATE_S)
    return task, commands, transitions, profile


@pytest.mark.parametrize("name, pick, drop", [
    ("umi_rtx", (0.1, 0.4, 0.1), (-0.2, 0.35, 0.15)),
    ("desk_rrr", (0.05, 0.12, 0.03), (-0.08, 0.1, 0.05)),
    ("assistive_5dof", (0.1, 0.35, 0.1), (-0.15, 0.3, 0.1)),
    ("delta", (0.02, 0.03, 0.02), (-0.03, -0.02, 0.03)),
])
def test_grab_goes_through_every_phase_in_order_and_finishes(name, pick, drop):
    params = GrabParams(pick, drop, hover_m=0.04)
    task, commands, transitions, profile = run(name, params)
    assert task.done and not task.failed and task.message == "done", task.message
    assert [p for _, p in task.history] == list(PHASES) + [GrabPhase.DONE]
    for cmd in commands:
        assert is_within_limits(cmd.q, profile, tol=0.0)
    # each phase ended only when the measured tool was within tolerance of its waypoint
    targets = {GrabPhase.APPROACH: np.add(pick, (0, 0, 0.04)), GrabPhase.OPEN: np.add(pick, (0, 0, 0.04)),
               GrabPhase.DESCEND: pick, GrabPhase.CLOSE: pick, GrabPhase.LIFT: np.add(pick, (0, 0, 0.04)),
               GrabPhase.CARRY: drop, GrabPhase.RELEASE: drop, GrabPhase.RETREAT: np.add(drop, (0, 0, 0.04))}
    for phase, tool in transitions:
        assert np.linalg.norm(tool - targets[phase]) <= params.tolerance_m, (phase, tool)
    # the gripper opens before descending, closes on the object, opens to release it
    by_phase = {}
    for cmd in commands:
        by_phase.setdefault(cmd.phase, []).append(cmd.gripper_m)
    open_m = profile.gripper.max_m if profile.gripper else 0.05
    assert by_phase[GrabPhase.DESCEND][-1] == pytest.approx(open_m)
    assert by_phase[GrabPhase.CARRY][-1] == pytest.approx(profile.gripper.min_m if profile.gripper else 0.0)
    assert by_phase[GrabPhase.RETREAT][-1] == pytest.approx(open_m)


def test_an_unreachable_drop_point_fails_cleanly_before_anything_moves():
    params = GrabParams((0.1, 0.4, 0.1), (0.0, 0.3, 2.5))
    task, commands, _, profile = run("umi_rtx", params)
    assert task.failed and not task.done and task.phase is GrabPhase.FAILED
    assert "drop point" in task.message and "out of reach by" in task.message and "nothing was moved" in task.message
    assert commands == []  # failed when planned: the loop never had to send anything
    kin = build_kinematics(profile)
    again = GrabTask(kin, profile, params, profile.q_home)
    cmd = again.step(0.0, profile.q_home)
    assert cmd.failed and cmd.phase is GrabPhase.FAILED and cmd.message == again.message
    assert cmd.q == pytest.approx(profile.q_home)  # holds the start pose


def test_an_unreachable_pick_point_fails_the_same_way():
    task, _, _, _ = run("desk_rrr", GrabParams((0.0, 0.5, 0.0), (0.05, 0.1, 0.05)))
    assert task.failed and "pick point" in task.message and "out of reach" in task.message


def test_an_arm_that_never_arrives_times_out_as_a_failure():
    params = GrabParams((0.1, 0.4, 0.1), (-0.2, 0.35, 0.15), timeout_s=1.0)
    task, commands, _, profile = run("umi_rtx", params, stuck=True)
    assert task.failed and task.message.startswith("timeout in phase 'approach'")
    assert "from its target" in task.message
    assert commands[-1].q == pytest.approx(profile.q_home)  # holds where the arm is


def test_a_gripper_that_does_not_close_times_out_in_the_close_phase():
    profile = load_profile("umi_rtx")
    kin = build_kinematics(profile)
    clock = SimClock()
    arm = SimServoArm(profile, clock=clock)
    arm.connect()
    task = GrabTask(kin, profile, GrabParams((0.1, 0.4, 0.1), (-0.2, 0.35, 0.15), timeout_s=0.5),
                    arm.joint_state().q, clock.now())
    seq = 0
    while not (task.done or task.failed) and clock.now() < 60:
        # the gripper follows its command except that it jams at 20 mm while closing
        grip = task.gripper_cmd if task.phase is not GrabPhase.CLOSE else max(task.gripper_cmd, 0.02)
        cmd = task.step(clock.now(), arm.joint_state().q, grip)
        seq += 1
        arm.send(JointCommand(seq, clock.now(), cmd.q))
        clock.advance(RATE_S)
    assert task.failed and task.message.startswith("timeout in phase 'close'"), task.message
    assert "gripper at 20.0 mm instead of 0.0 mm" in task.message


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError, match="grab.base_p_drop"):
        GrabParams((0, 0, 0), (0, math.nan, 0))
    with pytest.raises(ValueError, match="grab.tolerance_m = 0"):
        GrabParams((0, 0, 0), (0, 0, 0), tolerance_m=0)
