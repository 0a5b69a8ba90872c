"""A simulated ultrasonic range sensor (HC-SR04-like) looking along the hand camera's axis.

An HC-SR04 reports the distance of the first echo: the nearest surface inside its beam (~15°
full cone), between 2 cm and 4 m, to a few millimetres, and now and then no echo at all.
``SimRangeSensor.measure(base_T_sensor, t)`` casts a bundle of rays over the cone (its axis the
frame's +z) against what the simulated desk holds — the desk plane, each lift panel's plate and
its buttons' top faces (lower while pressed), door handles (the rose and the bar's top, as
horizontal surfaces), the tops of cups and marker-less things — and returns the nearest hit plus
Gaussian noise, or None for a dropout or nothing within range.

Pure geometry (no rendering): surfaces are horizontal discs, rectangles and the desk plane, which
is what a sensor looking down at a desk sees; walls and the sides of objects are left out.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from core.sim.scenarios import CUP_HEIGHT_M, SceneState

RING_RAYS = 12  # rays per ring of the cone bundle
RINGS = 3  # rings at 1/3, 2/3 and the full half angle (plus the axis)


@dataclass(frozen=True)
class RangeSensorConfig:
    """Beam, range, noise and dropouts of the sensor."""

    min_range_m: float = 0.02  # nearer than this: no reading (HC-SR04: 2 cm)
    max_range_m: float = 4.0  # farther: no echo (HC-SR04: 4 m)
    cone_deg: float = 15.0  # full beam angle
    noise_sigma_m: float = 0.002  # Gaussian noise std of a reading
    dropout_probability: float = 0.03  # chance a reading is missing

    def __post_init__(self) -> None:
        if not 0.0 < self.min_range_m < self.max_range_m <= 20.0:
            raise ValueError(f"range sensor range {self.min_range_m}…{self.max_range_m} m: need 0 < min < max ≤ 20 m")
        if not 0.0 <= self.cone_deg <= 90.0:
            raise ValueError(f"range sensor cone_deg = {self.cone_deg}: need 0…90°")
        if not (0.0 <= self.noise_sigma_m <= 0.1 and 0.0 <= self.dropout_probability <= 1.0):
            raise ValueError("range sensor noise_sigma_m must be 0…0.1 m and dropout_probability 0…1")


def _cone_directions(half_angle: float) -> np.ndarray:
    """Unit ray directions (N, 3) in the sensor frame: the +z axis and RINGS rings around it."""
    dirs = [np.array([0.0, 0.0, 1.0])]
    for k in range(1, RINGS + 1):
        a = half_angle * k / RINGS
        for j in range(RING_RAYS):
            phi = 2 * math.pi * (j + 0.5 * (k % 2)) / RING_RAYS
            dirs.append(np.array([math.sin(a) * math.cos(phi), math.sin(a) * math.sin(phi), math.cos(a)]))
    return np.array(dirs)


def scene_surfaces(st: SceneState) -> tuple[list, list]:
    """Horizontal surfaces of a scene: (discs, rectangles). A disc is (x, y, z, radius); a
    rectangle is (x, y, z, yaw, half_u, half_v), all robot_base (m)."""
    discs, rects = [], []
    for panel in st.panels:
        rects.append((panel.x, panel.y, panel.top_z, panel.yaw, panel.width_m / 2, panel.length_m / 2))
        for n in panel.BUTTONS:
            bx, by, bz = panel.button_centre(n)
            discs.append((bx, by, bz, panel.button_radius_m))
    for hd in st.handles:
        discs.append((hd.x, hd.y, hd.rose_height_m, hd.rose_radius_m))
        mx, my, _ = hd.along(hd.length_m / 2)
        rects.append((mx, my, hd.bar_height_m + hd.thickness_m / 2, hd.yaw, hd.length_m / 2, hd.thickness_m / 2))
    for th in st.things:
        discs.append((th.x, th.y, th.centre[2] if th.kind in ("disc", "cup") else th.height_m, th.radius_m))
    for cup in st.cups:
        discs.append((cup.x, cup.y, cup.lift + CUP_HEIGHT_M, 0.035))
    return discs, rects


def nearest_hit(origin: np.ndarray, dirs: np.ndarray, st: SceneState) -> float:
    """Distance (m) from ``origin`` to the nearest surface along any of ``dirs`` (N, 3, robot_base);
    inf when no ray goes down towards the desk."""
    down = dirs[:, 2] < -1e-9
    if not np.any(down):
        return math.inf
    d = dirs[down]
    best = np.full(len(d), np.inf)
    best = np.minimum(best, -origin[2] / d[:, 2])  # the desk, z = 0
    discs, rects = scene_surfaces(st)
    for x, y, z, r in discs:
        s = (z - origin[2]) / d[:, 2]
        px = origin[0] + s * d[:, 0] - x
        py = origin[1] + s * d[:, 1] - y
        hit = (s > 0) & (px * px + py * py <= r * r)
        best = np.where(hit, np.minimum(best, s), best)
    for x, y, z, yaw, hu, hv in rects:
        s = (z - origin[2]) / d[:, 2]
        px = origin[0] + s * d[:, 0] - x
        py = origin[1] + s * d[:, 1] - y
        c, sn = math.cos(yaw), math.sin(yaw)
        u, v = c * px + sn * py, -sn * px + c * py
        hit = (s > 0) & (np.abs(u) <= hu) & (np.abs(v) <= hv)
        best = np.where(hit, np.minimum(best, s), best)
    return float(best.min())


class SimRangeSensor:
    """HC-SR04-like readings of the nearest surface in a cone along the sensor frame's +z."""

    def __init__(self, desk, config: RangeSensorConfig = RangeSensorConfig(), seed: int = 0):
        self.desk = desk  # anything with scene(t) -> SceneState (a SimDesk)
        self.config = config
        self._dirs = _cone_directions(math.radians(config.cone_deg) / 2)
        self._rng = np.random.default_rng([int(seed) & 0x7FFFFFFF, 4021])

    def true_range(self, base_T_sensor: np.ndarray, t: float) -> float:
        """The noiseless distance (m) to the nearest surface in the cone (inf: nothing below)."""
        T = np.asarray(base_T_sensor, dtype=float)
        return nearest_hit(T[:3, 3], self._dirs @ T[:3, :3].T, self.desk.scene(float(t)))

    def measure(self, base_T_sensor: np.ndarray, t: float) -> Optional[float]:
        """One reading (m), or None: a dropout, or the nearest surface outside min…max range."""
        c = self.config
        if self._rng.random() < c.dropout_probability:
            return None
        r = self.true_range(base_T_sensor, t)
        if not (c.min_range_m <= r <= c.max_range_m):
            return None
        return float(r + self._rng.normal(0.0, c.noise_sigma_m)) if c.noise_sigma_m > 0 else float(r)
