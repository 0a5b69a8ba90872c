"""The simulated arm: every profile's twin, used when no board is plugged in and by the tests."""
from __future__ import annotations

import threading
from typing import Optional

from core.devices.bridge import BridgeError, MotorBridge, servo_deg_to_q
from core.devices.protocol_v1 import encode_v1
from core.messages import JointCommand, JointState
from core.motion.safety import clamp_to_limits


class SimServoArm(MotorBridge):
    """A simulated arm, for every profile; it starts at the profile's home pose.

    Servo profiles (desk_rrr, delta): hobby servos (MG996R-like). Each servo turns toward its
    commanded angle at ``speed_deg_s`` (~60° in 0.17 s), in whole degree steps, updated at
    ``rate_hz`` (the 50 Hz PWM frame); ``send`` returns the servo angles, as on the real link.

    Other profiles (umi_rtx, URDF arms): no servos. Each joint moves in joint space toward its
    command at its own velocity limit (``profile.velocity_limits``, rad/s or m/s), updated at
    ``rate_hz``. Commands are clamped into the joint limits; ``send`` returns ``()`` — there are
    no servo angles — and ``last_sent_q`` holds the joint values commanded.
    """

    has_feedback = True
    SETTLED_TOL = 1e-9  # joint-space mode: |position - target| below this is "arrived" (rad or m)

    def __init__(self, profile, clock=None, speed_deg_s: float = 60.0 / 0.17,
                 rate_hz: float = 50.0, url: str = "sim://"):
        super().__init__(url, profile, clock)
        self.speed_deg_s = float(speed_deg_s)
        self.period_s = 1.0 / float(rate_hz)
        self.servo_mode = bool(profile.has_servos)
        self.last_sent_q: Optional[tuple[float, ...]] = None
        if self.servo_mode:
            home = profile.to_servo_deg(profile.q_home)
            self.position_deg = [float(round(d)) for d in home]
            self.target_deg = list(self.position_deg)
        else:
            self.position_q = [float(v) for v in profile.q_home]
            self.target_q = list(self.position_q)
            self.joint_speeds = tuple(float(v) for v in profile.velocity_limits)  # rad/s or m/s
        self._connected = False
        self._last_tick: Optional[float] = None
        self._lock = threading.Lock()

    def connect(self) -> None:
        self._connected = True
        self._last_tick = self.clock.now()
        self.message = "simulated arm"

    def disconnect(self) -> None:
        self._connected = False

    @property
    def is_connected(self) -> bool:
        return self._connected

    def _advance(self) -> None:
        """Run the arm model's ticks (``rate_hz``) up to now."""
        now = self.clock.now()
        if self._last_tick is None:
            self._last_tick = now
        ticks = 0
        while now - self._last_tick >= self.period_s and ticks < 500:
            self._last_tick += self.period_s
            ticks += 1
            if self.servo_mode:
                max_step = self.speed_deg_s * self.period_s
                for k, (pos, tgt) in enumerate(zip(self.position_deg, self.target_deg)):
                    step = max(-max_step, min(max_step, tgt - pos))
                    self.position_deg[k] = float(round(pos + step))  # 1° resolution
            else:
                for k, (pos, tgt, v) in enumerate(zip(self.position_q, self.target_q, self.joint_speeds)):
                    max_step = v * self.period_s
                    self.position_q[k] = pos + max(-max_step, min(max_step, tgt - pos))
        if ticks >= 500:
            self._last_tick = now

    def send(self, command: JointCommand) -> tuple[int, ...]:
        """Clamp and command; servo angles sent (servo profiles) or () (joint-space profiles)."""
        if self._estopped:
            return ()
        if self.servo_mode:
            return super().send(command)
        if not self._connected:
            raise BridgeError("simulated arm is not connected")
        q_safe, _ = clamp_to_limits(command.q, self.profile)
        with self._lock:
            self._advance()
            self.target_q = list(q_safe)
        self.commands_sent += 1
        self.last_write_t = self.clock.now()
        self.last_source_t = command.source_t
        self.last_sent_q = q_safe
        return ()

    def _write_servo_deg(self, servo_deg: tuple[int, ...]) -> int:
        if not self._connected:
            raise BridgeError("simulated arm is not connected")
        with self._lock:
            self._advance()
            self.target_deg = [float(d) for d in servo_deg]
        self.last_sent_q = servo_deg_to_q(servo_deg, self.profile)
        return len(encode_v1(servo_deg)) if len(servo_deg) <= 3 else 0

    def joint_state(self) -> JointState:
        with self._lock:
            self._advance()
            if self.servo_mode:
                q = servo_deg_to_q(self.position_deg, self.profile)
            else:
                q = tuple(self.position_q)
        return JointState(seq=self._state_seq.next(), t=self.clock.now(), q=q, measured=True)

    def is_settled(self) -> bool:
        """True when every joint has reached its command."""
        with self._lock:
            self._advance()
            if self.servo_mode:
                return all(abs(p - t) < 0.5 for p, t in zip(self.position_deg, self.target_deg))
            return all(abs(p - t) <= self.SETTLED_TOL for p, t in zip(self.position_q, self.target_q))

    def _on_estop(self) -> None:
        # freeze where the joints are now, mid-move included (as the v2 board does)
        with self._lock:
            self._advance()
            if self.servo_mode:
                self.target_deg = list(self.position_deg)
            else:
                self.target_q = list(self.position_q)

    def _estop_text(self) -> str:
        return "E-STOP: simulated arm frozen; re-arm to resume"
