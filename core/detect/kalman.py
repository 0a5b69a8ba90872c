"""A constant-velocity Kalman filter for one object's position in robot_base.

Six states (x, y, z, vx, vy, vz), a 3-D position measurement, variable time steps (frames
arrive when they arrive). The process noise is white acceleration of spectral density
``process_noise`` ((m/s²)²·s): per axis Q = q·[[dt³/3, dt²/2], [dt²/2, dt]]. A frame without a
measurement only predicts. A measurement far from the prediction (``jump_m``, or beyond
``jump_sigma`` standard deviations of the innovation) restarts the filter there: an object picked
up and put down elsewhere, or a detection switched to another object, must not be smeared into
a velocity.
"""
from __future__ import annotations

import collections
from typing import Optional

import cv2
import numpy as np


class ConstantVelocityKalman:
    """Filtered position and velocity of one object (robot_base, m and m/s).

    ``update(t, p)`` with a measured point ``p`` (3 numbers, m) or None (not seen this frame)
    returns ``(p_filtered, v)`` as float arrays of 3, or ``(None, None)`` before the first
    measurement. ``t`` must not go backwards (ValueError).
    """

    def __init__(self, process_noise: float = 0.5, measurement_noise: float = 0.002,
                 jump_m: float = 0.10, jump_sigma: float = 8.0, initial_speed_sigma: float = 0.5):
        if not (process_noise > 0 and measurement_noise > 0 and jump_m > 0 and jump_sigma > 0):
            raise ValueError("process_noise, measurement_noise, jump_m and jump_sigma must be > 0")
        self.process_noise = float(process_noise)  # (m/s²)²·s
        self.measurement_noise = float(measurement_noise)  # m, std of one measured coordinate
        self.jump_m = float(jump_m)
        self.jump_sigma = float(jump_sigma)
        self.initial_speed_sigma = float(initial_speed_sigma)  # m/s, velocity std at (re)start
        self._kf = cv2.KalmanFilter(6, 3, 0, cv2.CV_64F)
        self._kf.measurementMatrix = np.hstack([np.eye(3), np.zeros((3, 3))])
        self._kf.measurementNoiseCov = np.eye(3) * self.measurement_noise ** 2
        self.t: Optional[float] = None  # time of the last update
        self.t_measured: Optional[float] = None  # time of the last measurement
        self.resets = 0  # restarts on a jump (not counting the first measurement)
        self.history_s = 5.0  # how far back is_stopped can look
        self._speeds: collections.deque = collections.deque()  # (t, filtered speed) per update

    @property
    def started(self) -> bool:
        return self.t is not None

    @property
    def position(self) -> Optional[np.ndarray]:
        return None if self.t is None else self._kf.statePost[:3, 0].copy()

    @property
    def velocity(self) -> Optional[np.ndarray]:
        return None if self.t is None else self._kf.statePost[3:, 0].copy()

    @property
    def speed(self) -> Optional[float]:
        v = self.velocity
        return None if v is None else float(np.linalg.norm(v))

    def reset(self) -> None:
        """Forget everything: the next measurement starts afresh."""
        self.t = self.t_measured = None
        self._speeds.clear()

    def _start(self, t: float, p: np.ndarray) -> None:
        self._kf.statePost = np.concatenate([p, np.zeros(3)]).reshape(6, 1)
        self._kf.errorCovPost = np.diag([self.measurement_noise ** 2] * 3 + [self.initial_speed_sigma ** 2] * 3)
        self.t = self.t_measured = t
        self._speeds.clear()

    def _predict(self, dt: float) -> None:
        F = np.eye(6)
        F[:3, 3:] = np.eye(3) * dt
        q = self.process_noise
        Q = np.zeros((6, 6))
        Q[:3, :3] = np.eye(3) * q * dt ** 3 / 3.0
        Q[:3, 3:] = Q[3:, :3] = np.eye(3) * q * dt ** 2 / 2.0
        Q[3:, 3:] = np.eye(3) * q * dt
        self._kf.transitionMatrix = F
        self._kf.processNoiseCov = Q
        self._kf.predict()  # also copies the prediction into statePost / errorCovPost

    def update(self, t: float, p=None) -> tuple[Optional[np.ndarray], Optional[np.ndarray]]:
        t = float(t)
        if self.t is not None and t < self.t:
            raise ValueError(f"time went backwards: {t} after {self.t}")
        z = None
        if p is not None:
            z = np.asarray(p, dtype=float).reshape(-1)
            if z.shape != (3,) or not np.all(np.isfinite(z)):
                z = None  # a broken measurement is no measurement
        if self.t is None:
            if z is None:
                return None, None
            self._start(t, z)
        else:
            dt = t - self.t
            if dt > 0:
                self._predict(dt)
            self.t = t
            if z is not None:
                predicted = self._kf.statePost[:3, 0]
                innovation = z - predicted
                S = self._kf.errorCovPost[:3, :3] + self._kf.measurementNoiseCov
                d2 = float(innovation @ np.linalg.solve(S, innovation))
                if np.linalg.norm(innovation) > self.jump_m or d2 > self.jump_sigma ** 2:
                    self.resets += 1
                    self._start(t, z)
                else:
                    self._kf.correct(z.reshape(3, 1))
                    self.t_measured = t
        self._note_speed()
        return self.position, self.velocity

    def _note_speed(self) -> None:
        hist = self._speeds
        hist.append((self.t, self.speed))
        while len(hist) > 2 and hist[1][0] <= self.t - self.history_s:
            hist.popleft()

    def is_stopped(self, speed_threshold: float = 0.02, hold_s: float = 0.3) -> bool:
        """True when the filtered speed has stayed below ``speed_threshold`` (m/s) over the last
        ``hold_s`` up to the last update (measured or predicted; at most ``history_s``).
        False before the first measurement and right after a restart on a jump."""
        run_start = None
        for t, speed in reversed(self._speeds):
            if speed >= speed_threshold:
                break
            run_start = t
        return run_start is not None and self.t - run_start >= min(float(hold_s), self.history_s) - 1e-9
