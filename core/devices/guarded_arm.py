"""The assistive loop's joint values to a real (or simulated) arm, through deskarm's safety chain.

``AssistLoop`` (core/motion/assist_loop.py) computes the joint values it wants each frame (IBVS,
the press, the way back to the ready pose). On the simulated desk those values *are* the arm. A
window driving an arm — a v1/v2 serial board, a Phidget servo board, or the simulated servo arm
(``sim://``) — sends them with ``GuardedArm.send``:

- each one becomes a joint goal (``Goal.joint_target``) for an ``ArmController``, so it passes
  the same chain as every other command in deskarm: joint clamps, the per-tick speed limit, the
  clamps again, the whole-arm desk and keep-out check, and the e-stop (nothing is sent while
  stopped). A non-finite value holds the last command;
- the command actually sent is returned and the loop continues from it (``AssistLoop.q`` is set
  to it), so the loop's idea of where the camera is never runs ahead of the arm;
- the bridge is (re)connected with the same backoff as the main window's bridge worker
  (``core.devices.reconnect.Reconnector``); a board that goes away makes ``send`` return None
  and ``lost`` say why — the caller stops the approach (the loop must not go on servoing a
  camera whose arm no longer moves).

Starting: ``start_pose()`` is where the arm is — its measured joint state (v2, Phidget, the
simulated arm), else the profile's home pose (a v1 board cannot tell; the seed firmware parks
there at power-up) — and the loop moves from there to the ready pose at a bounded speed.
"""
from __future__ import annotations

import math
import time
from typing import Callable, Optional, Sequence

from core.devices.bridge import BridgeError, MotorBridge
from core.devices.reconnect import Reconnector
from core.messages import Goal, JointCommand, TargetMode
from core.motion.control import ArmController


class GuardedArm:
    """Sends an ``AssistLoop``'s joint values to ``bridge`` through an ``ArmController`` (see the
    module docstring). ``frame_dt_s``: the loop's frame period — the controller's tick, so each
    frame may move each joint by its speed limit × one frame. Not thread-safe: one thread (the
    loop's) calls everything except ``message``."""

    def __init__(self, bridge: MotorBridge, kinematics, frame_dt_s: float,
                 now: Callable[[], float] = time.monotonic):
        if not 0 < frame_dt_s <= 1.0:
            raise ValueError(f"frame_dt_s = {frame_dt_s} s: need 0 < dt ≤ 1 s")
        self.bridge = bridge
        self.kinematics = kinematics
        self.controller = ArmController(kinematics.profile, kinematics, rate_hz=1.0 / frame_dt_s)
        self.reconnector = Reconnector(now=now)
        self.lost: str = ""  # why the last send reached no arm ("" when it did)
        self.commands_sent = 0
        self._seq = 0

    # -- the link ------------------------------------------------------------------------------

    def connect(self) -> bool:
        """True when the bridge is connected (a connect is tried when its retry time has come)."""
        return self.reconnector.ensure(self.bridge)

    @property
    def connected(self) -> bool:
        return bool(self.bridge.is_connected)

    @property
    def message(self) -> str:
        """The bridge's own words on its state (why it is not connected, an e-stop, …)."""
        return str(self.bridge.status().message or "")

    def start_pose(self) -> tuple[float, ...]:
        """Where the arm is now: its measured joint state, else the last command, else the home pose."""
        state = None
        if self.connected:
            try:
                state = self.bridge.joint_state()
            except BridgeError as exc:
                self.reconnector.lost(self.bridge, exc)
        q = self.controller.start_pose(state)
        if not all(math.isfinite(float(v)) for v in q):
            q = tuple(self.kinematics.profile.q_home)
        return tuple(float(v) for v in q)

    def disconnect(self) -> None:
        try:
            self.bridge.disconnect()
        except BridgeError:
            pass

    # -- commands --------------------------------------------------------------------------------

    def send(self, q_wanted: Sequence[float], t: float) -> Optional[JointCommand]:
        """One frame: ``q_wanted`` through the safety chain to the arm. Returns the command sent
        (its ``q`` is where the arm is told to be), or None when nothing reached an arm — stopped,
        or the board is not connected (``lost`` says why)."""
        if self.bridge.is_estopped or not self.controller.armed:
            return None
        if not self.connect():
            self.lost = f"the arm's board is not connected: {self.message or 'no answer'}"
            return None
        self._seq += 1
        goal = Goal(seq=self._seq, t=float(t), base_p_target=(0.0, 0.0, 0.0), mode=TargetMode.MANUAL,
                    joint_target=tuple(float(v) for v in q_wanted), note="assistive approach")
        q_now = self.controller.last.q if self.controller.last is not None else self.start_pose()
        command = self.controller.step(goal, q_now, float(t))
        if command is None:
            return None
        try:
            self.bridge.send(command)
        except BridgeError as exc:
            self.reconnector.lost(self.bridge, exc)
            self.lost = f"the arm's board went away: {exc}"
            return None
        self.lost = ""
        self.commands_sent += 1
        return command

    @property
    def note(self) -> str:
        """Why the last command differs from what the loop wanted ("" when it does not)."""
        return self.controller.note

    def estop(self) -> None:
        """Stop now: the bridge's e-stop (a v2 board switches its pulses off) and the controller
        refuses commands until ``rearm``. Idempotent."""
        self.controller.estop()
        self.bridge.estop()

    def rearm(self) -> None:
        """Commands are sent again (the next one moves the arm, at the speed limits, from where it was)."""
        self.bridge.rearm()
        self.controller.rearm()
        self.controller.last = None  # the next step starts from the arm's state as the bridge reports it
