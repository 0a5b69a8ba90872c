"""``GuardedArm``: the assistive loop's joint values reach an arm only through deskarm's safety
chain (joint limits, the per-frame speed limit, the desk, the e-stop), a board that goes away is
reported and reconnected, and the whole approach still presses its button through it."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.clock import SimClock
from core.devices.sim_arm import SimServoArm
from core.devices.bridge import BridgeError
from core.kinematics import build_kinematics, load_profile
from core.devices.guarded_arm import GuardedArm
from core.motion.safety import is_within_limits, workspace_violation

PROFILE = load_profile("assistive_5dof")
KIN = build_kinematics(PROFILE)
DT = 1.0 / 30.0


class RecordingArm(SimServoArm):
    """The simulated servo arm, keeping every command it was sent; ``fail`` makes connects and sends raise."""

    def __init__(self):
        super().__init__(PROFILE, clock=SimClock())
        self.sent: list = []
        self.fail = False
        self.connects = 0

    def connect(self):
        self.connects += 1
        if self.fail:
            raise BridgeError("no such port — is the board plugged in?")
        super().connect()

    def send(self, command):
        if self.fail:
            raise BridgeError("the board stopped answering")
        if not self.is_estopped:
            self.sent.append(command)
        return super().send(command)


def joint_value(lo, hi):
    span = hi - lo
    return st.one_of(st.floats(lo, hi), st.floats(lo - 2 * span, hi + 2 * span), st.floats(-1e9, 1e9),
                     st.sampled_from([math.nan, math.inf, -math.inf]))


def desk_clear(q) -> bool:
    margin = PROFILE.workspace.desk_margin_m
    pts = np.asarray(KIN.chain_points(q), dtype=float)[1:]  # the base's foot stands on the desk
    return bool(np.all(pts[:, 2] >= margin - 1e-9))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_no_loop_value_ever_reaches_the_arm_outside_the_limits_the_speed_or_above_the_desk(data):
    bridge = RecordingArm()
    arm = GuardedArm(bridge, KIN, DT, now=lambda: 0.0)
    assert arm.connect()
    t, previous = 0.0, None
    allowed = np.radians([j.max_speed_deg_s for j in PROFILE.joints]) * DT
    for _ in range(data.draw(st.integers(1, 12))):
        wanted = data.draw(st.tuples(*(joint_value(lo, hi) for lo, hi in zip(PROFILE.q_min, PROFILE.q_max))))
        t += DT
        if data.draw(st.booleans()) and data.draw(st.booleans()):
            arm.estop()
            assert arm.send(wanted, t) is None  # stopped: nothing goes out
            arm.estop()  # idempotent
            arm.rearm()
            previous = bridge.joint_state().q  # after a re-arm the arm starts from where it is
        command = arm.send(wanted, t)
        if command is None:  # a non-finite value with no command to hold (none yet, or just re-armed)
            assert not all(map(math.isfinite, wanted))
            continue
        assert is_within_limits(command.q, PROFILE)
        assert workspace_violation(command.q, PROFILE, KIN) == "" and desk_clear(command.q)
        if previous is not None:
            assert np.all(np.abs(np.subtract(command.q, previous)) <= allowed + 1e-9)
        previous = command.q


def test_an_e_stopped_arm_gets_nothing_until_re_armed_and_then_starts_from_where_it_is():
    bridge = RecordingArm()
    arm = GuardedArm(bridge, KIN, DT, now=lambda: 0.0)
    assert arm.connect()
    start = arm.start_pose()
    assert np.allclose(start, PROFILE.q_home, atol=math.radians(1.0))  # the simulated arm parks at home
    first = arm.send(start, DT)
    assert first is not None and len(bridge.sent) == 1
    arm.estop()
    arm.estop()
    assert bridge.is_estopped
    assert arm.send(np.add(start, 0.1), 2 * DT) is None
    assert len(bridge.sent) == 1
    arm.rearm()
    assert not bridge.is_estopped
    assert arm.send(np.add(start, 0.1), 3 * DT) is not None
    assert len(bridge.sent) == 2


def test_a_board_that_goes_away_is_reported_and_reconnected_on_the_backoff():
    clock = {"t": 0.0}
    bridge = RecordingArm()
    arm = GuardedArm(bridge, KIN, DT, now=lambda: clock["t"])
    assert arm.connect()
    q = arm.start_pose()
    assert arm.send(q, DT) is not None
    bridge.fail = True
    assert arm.send(q, 2 * DT) is None
    assert "went away" in arm.lost and "stopped answering" in arm.lost
    assert not bridge.is_connected
    assert arm.send(q, 3 * DT) is None  # the first reconnect is tried at once and fails
    assert "not connected" in arm.lost and "plugged in" in arm.lost
    tries = bridge.connects
    assert arm.send(q, 4 * DT) is None and bridge.connects == tries  # no retry before the backoff
    bridge.fail = False
    clock["t"] = 10.0
    assert arm.send(q, 5 * DT) is not None
    assert arm.lost == ""


@pytest.mark.parametrize("button_index", [0, 6])
def test_the_approach_presses_its_button_through_the_chain(button_index):
    from app.assist_window import build_sim_loop  # the window's simulated loop (Qt-free itself)

    loop, ready = build_sim_loop(0)
    bridge = RecordingArm()
    arm = GuardedArm(bridge, loop.kin, loop.frame_dt_s, now=lambda: 0.0)
    assert arm.connect()
    loop.q = arm.start_pose()
    loop.go_to(ready)
    frames = 0
    while loop.busy and frames < 300:
        loop.step()
        loop.q = arm.send(loop.q, loop.t).q
        frames += 1
    assert np.allclose(loop.q, ready, atol=1e-6)
    loop.offer()
    loop.select(button_index)
    while loop.busy and frames < 1200:
        loop.step()
        loop.q = arm.send(loop.q, loop.t).q
        frames += 1
    assert loop.fsm.outcome.startswith("pressed"), loop.fsm.outcome
    assert all(is_within_limits(c.q, PROFILE) and desk_clear(c.q) for c in bridge.sent)
    assert bridge.sent[-1].q == pytest.approx(loop.q)
