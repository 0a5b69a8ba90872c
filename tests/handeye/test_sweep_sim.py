"""The hand-eye sweep on the simulated desk: a rig mounted off its nominal pose is recovered."""
import math

import numpy as np
import pytest

from app.cli_handeye import run_sweep
from core.handeye import HandEyeSweep, pose_error
from core.kinematics import build_kinematics, load_profile
from core.session import DeskSession, SessionOptions


def session_with(offset, marker_ids=(23, 50, 7)):
    return DeskSession.create(SessionOptions(camera="sim", simulated_clock=True, rig_offset=offset,
                                             marker_ids=marker_ids))


def random_offset(rng):
    """At least 3 cm and 3° off (each way the largest component), at most 5 cm and 5°."""
    d = rng.uniform(-0.05, 0.05, 3)
    d[np.argmax(np.abs(d))] = math.copysign(rng.uniform(0.03, 0.05), d[np.argmax(np.abs(d))])
    a = rng.uniform(-5, 5, 3)
    a[np.argmax(np.abs(a))] = math.copysign(rng.uniform(3, 5), a[np.argmax(np.abs(a))])
    return (*d, *np.radians(a))


@pytest.mark.parametrize("seed", [11, 12, 13])
def test_sweep_recovers_a_randomly_offset_rig(seed):
    offset = random_offset(np.random.default_rng(seed))
    s = session_with(offset)
    try:
        nominal_t, nominal_r = pose_error(s.camera.base_T_camera(), s.camera.true_base_T_camera())
        assert nominal_t > 30.0 or nominal_r > 3.0  # the nominal mount really is off
        res, sweep = run_sweep(s, n_poses=12, seed=seed)
    finally:
        s.close()
    assert res.ok, res.problem
    assert res.poses_used >= 8 and res.camera_pair == s.hand_eye_pair_id
    t_mm, r_deg = pose_error(res.base_T_camera, s.camera.true_base_T_camera())
    assert t_mm < 2.0 and r_deg < 0.3, (offset, t_mm, r_deg)


def test_a_marker_never_seen_is_not_ok():
    s = session_with((0.03, 0, 0, 0, 0, math.radians(3)))
    s.camera.set_tool_marker(None)  # a bare tool: nothing to see
    try:
        res, sweep = run_sweep(s, n_poses=5, hold_s=0.3, settle_s=0.1)
    finally:
        s.close()
    assert not res.ok and "never seen" in res.problem and "marker 7" in res.problem.replace("marker 7", "marker 7")
    assert len(sweep.unseen) == 5 and res.poses_used == 0


def test_fewer_poses_than_needed_is_not_ok():
    s = session_with((0.03, 0, 0, 0, 0, math.radians(3)))
    try:
        res, _ = run_sweep(s, n_poses=3, hold_s=0.3, settle_s=0.1)
    finally:
        s.close()
    assert not res.ok and "need at least 4" in res.problem


def test_planned_poses_are_reachable_above_the_desk_and_spread():
    profile = load_profile("desk_rrr")
    kin = build_kinematics(profile)
    sweep = HandEyeSweep(profile, kin, n_poses=12, seed=0)
    P = np.array(sweep.points)
    assert len(P) == 12 and np.all(P[:, 2] >= 0.04)
    assert all(kin.ik(tuple(p)).reachable for p in P)
    assert np.ptp(P, axis=0).min() > 0.05  # spread in x, y and z


def test_step_walks_through_the_phases_and_skips_an_unseen_pose():
    profile = load_profile("desk_rrr")
    kin = build_kinematics(profile)
    sweep = HandEyeSweep(profile, kin, n_poses=2, hold_s=0.2, settle_s=0.1, seed=1)
    q_goal = [kin.ik(tuple(p)).q for p in sweep.points]
    t, phases = 0.0, []
    while not sweep.done and t < 10:
        q = q_goal[min(sweep.index, 1)]
        seen = None if sweep.index == 1 else (0.0, 0.0, 0.5)
        phases.append(sweep.step(t, seen, q).phase)
        t += 1 / 30
    assert sweep.done and {"settling", "sampling"} <= set(phases)
    assert sweep.unseen == [1] and len(sweep.camera_points) == 1
