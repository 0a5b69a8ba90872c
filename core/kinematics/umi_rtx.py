"""The UMI-RTX driver's joint ↔ motor conversions: encoder ticks and the differential wrist.

The UMI-RTX's wrist is differential: its two motors WRIST1 and WRIST2 turn roll and pitch
together, ``WRIST1 = roll + pitch`` and ``WRIST2 = pitch − roll`` (degrees of motor angle, at
0.07415 °/count, i.e. 13.487 counts per degree). The original driver converts joint angles to
encoder counts with fixed ratios (degrees per count) and truncates towards zero (a C cast),
e.g. elbow 45° → 657 counts, shoulder 45° → 1315::

    shoulder 0.03422 °/count, elbow 0.06844, yaw 0.10267, wrist motors 0.07415
    column   ticks = −3554 + 3749.5 · z_m
    gripper  ticks = −30 + (1230 / 90) · grip_mm

Which wrist formula. The original sources disagree: a report gives WRIST1 = (roll + pitch)/2,
``node_arm.cpp`` sends roll + pitch (and, in another version, halves), ``umicmds.cpp`` halves
— ``0.5·(roll + pitch)`` — but then multiplies by its own 2750/102 = 26.96 counts per degree,
and ``umiinit.cpp`` sets the limits from ``(pitch + roll) · 13.487`` and
``(pitch − roll) · 13.487``. In counts, ``umicmds`` and ``umiinit`` agree: 0.5 · 26.96 = 13.48
counts per degree of (roll ± pitch). The check that decides it is the initialisation: the
driver drives the wrist to its end stops (roll −132°, pitch −98° in ``umiinit``'s table) and
writes the counts there, WRIST1 = (−98 − 132) · 13.487 → −3101 and WRIST2 = (−98 + 132) ·
13.487 → 459. ``umicmds``'s software limits on the same motors are WRIST1 + WRIST2 ≥ −2642
and WRIST1 − WRIST2 ≥ −3560: exactly −3101 + 459 and −3101 − 459. So the limits the driver
enforces are the initialisation's end stops only with the unhalved formula at 13.487 counts
per degree (this module's): WRIST1 + WRIST2 = 2 · 13.487 · pitch gives pitch −98° … +4°, and
WRIST1 − WRIST2 = 2 · 13.487 · roll gives roll −132° … +181°. The halved formula at
0.07415 °/count would put those same end stops at pitch −196° and roll −264°, which the wrist
cannot reach. deskarm therefore uses WRIST1 = roll + pitch, WRIST2 = pitch − roll at
0.07415 °/count (the halving in ``umicmds`` is undone by its doubled counts per degree).

The same arithmetic shows the yaw motor is coupled to the elbow in the original: ``umicmds``
commands yaw + elbow/2 and limits the yaw counts to ±1071 + elbow_counts/3, and with the elbow
at its stop (−2630 counts) that lower limit, −1947, is ``umiinit``'s yaw stop (−200° · 9.740).
``q_to_motor_ticks`` does not apply that coupling (its yaw is the joint's own angle); the RTX
bridge keeps yaw inside ±1071 counts, which is inside the stops whatever the elbow does.

The driver's limits in counts (``umicmds`` software limits, ``umiinit`` end stops and post-
initialisation targets) are below as data; ``core.devices.rtx_bridge`` clamps to them.

Degrees and millimetres are the driver's edge units; ``q_to_motor_ticks`` and
``motor_ticks_to_q`` take and give deskarm's SI joint vector (column m, angles rad) in the
umi_rtx profile's joint order. The motor names are the driver's.
"""
from __future__ import annotations

import math
from typing import Mapping, Sequence

DEG_PER_COUNT = {  # the original driver's ratios
    "SHOULDER": 0.03422,
    "ELBOW": 0.06844,
    "YAW": 0.10267,
    "WRIST1": 0.07415,
    "WRIST2": 0.07415,
}
COLUMN_TICKS_AT_ZERO = -3554.0  # column ("ZED") encoder value at z = 0 m
COLUMN_TICKS_PER_M = 3749.5
GRIPPER_TICKS_AT_ZERO = -30.0
GRIPPER_TICKS_PER_MM = 1230.0 / 90.0
# The driver's software limits in encoder counts (umicmds.cpp): every target is kept inside them.
SOFT_LIMIT_COUNTS = {
    "ZED": (-3478, -20),  # the top (0) is the end stop; the driver keeps 20 counts off it
    "SHOULDER": (-2630, 2630),
    "ELBOW": (-2630, 2206),
    "YAW": (-1071, 1071),
    "GRIPPER": (-30, 1200),
}
WRIST_SUM_LIMITS = (-2642, 108)  # WRIST1 + WRIST2 = 2 · 13.487 · pitch: pitch −98° … +4°
WRIST_DIFF_LIMITS = (-3560, 4882)  # WRIST1 − WRIST2 = 2 · 13.487 · roll: roll −132° … +181°
# umiinit.cpp: where each motor's end stop is once initialised (counts), and where the arm goes
# after the initialisation; (x + 0.5) truncated, from its table (zed 0 mm, shoulder 90°,
# elbow −180°, yaw −200°, pitch −98°, roll −132°, gripper 0) and its counts per unit
INIT_STOP_COUNTS = {"ELBOW": -2629, "SHOULDER": 2630, "ZED": 0, "WRIST1": -3101, "WRIST2": 459,
                    "YAW": -1947, "GRIPPER": 0}
POST_INIT_COUNTS = {"ELBOW": 0, "SHOULDER": 0, "ZED": -18, "WRIST1": 0, "WRIST2": 0, "YAW": 0, "GRIPPER": 0}
JOINT_ORDER = ("column", "shoulder", "elbow", "wrist_yaw", "wrist_roll", "wrist_pitch")  # umi_rtx.toml
MOTORS = ("ZED", "SHOULDER", "ELBOW", "YAW", "WRIST1", "WRIST2")


def _trunc(value: float) -> int:
    """The driver's (int) cast: truncation towards zero."""
    if not math.isfinite(value):
        raise ValueError(f"cannot convert {value!r} to encoder ticks")
    return int(value)


def wrist_differential(roll_deg: float, pitch_deg: float) -> tuple[float, float]:
    """Wrist motor angles (WRIST1, WRIST2) in degrees for the wrist's roll and pitch (degrees)."""
    return (roll_deg + pitch_deg, pitch_deg - roll_deg)


def wrist_from_motors(wrist1_deg: float, wrist2_deg: float) -> tuple[float, float]:
    """(roll, pitch) in degrees for the wrist motor angles WRIST1, WRIST2 (inverse of the above)."""
    return (0.5 * (wrist1_deg - wrist2_deg), 0.5 * (wrist1_deg + wrist2_deg))


def angle_deg_to_ticks(motor: str, angle_deg: float) -> int:
    """Encoder counts for a motor angle (degrees), truncated like the driver."""
    try:
        per = DEG_PER_COUNT[motor]
    except KeyError:
        raise ValueError(f"unknown UMI-RTX motor {motor!r}; expected one of {', '.join(DEG_PER_COUNT)}") from None
    return _trunc(angle_deg / per)


def ticks_to_angle_deg(motor: str, ticks: int) -> float:
    """Motor angle (degrees) for encoder counts."""
    try:
        return ticks * DEG_PER_COUNT[motor]
    except KeyError:
        raise ValueError(f"unknown UMI-RTX motor {motor!r}; expected one of {', '.join(DEG_PER_COUNT)}") from None


def column_m_to_ticks(z_m: float) -> int:
    """Column ("ZED") encoder counts for the column height z (m)."""
    return _trunc(COLUMN_TICKS_AT_ZERO + COLUMN_TICKS_PER_M * z_m)


def ticks_to_column_m(ticks: int) -> float:
    """Column height (m) for column encoder counts."""
    return (ticks - COLUMN_TICKS_AT_ZERO) / COLUMN_TICKS_PER_M


def gripper_mm_to_ticks(grip_mm: float) -> int:
    """Gripper encoder counts for a gripper opening (mm)."""
    return _trunc(GRIPPER_TICKS_AT_ZERO + GRIPPER_TICKS_PER_MM * grip_mm)


def ticks_to_gripper_mm(ticks: int) -> float:
    """Gripper opening (mm) for gripper encoder counts."""
    return (ticks - GRIPPER_TICKS_AT_ZERO) / GRIPPER_TICKS_PER_MM


def q_to_motor_ticks(q: Sequence[float]) -> dict[str, int]:
    """Encoder targets of the six arm motors for the umi_rtx joint vector ``q`` (m, rad)."""
    if len(q) != len(JOINT_ORDER):
        raise ValueError(f"q has {len(q)} values; the UMI-RTX arm has {len(JOINT_ORDER)}: {', '.join(JOINT_ORDER)}")
    column, shoulder, elbow, yaw, roll, pitch = (float(v) for v in q)
    w1, w2 = wrist_differential(math.degrees(roll), math.degrees(pitch))
    return {
        "ZED": column_m_to_ticks(column),
        "SHOULDER": angle_deg_to_ticks("SHOULDER", math.degrees(shoulder)),
        "ELBOW": angle_deg_to_ticks("ELBOW", math.degrees(elbow)),
        "YAW": angle_deg_to_ticks("YAW", math.degrees(yaw)),
        "WRIST1": angle_deg_to_ticks("WRIST1", w1),
        "WRIST2": angle_deg_to_ticks("WRIST2", w2),
    }


def motor_ticks_to_q(ticks: Mapping[str, int]) -> tuple[float, ...]:
    """The umi_rtx joint vector (m, rad) for the six motors' encoder counts."""
    missing = [m for m in MOTORS if m not in ticks]
    if missing:
        raise ValueError(f"missing motor ticks for {', '.join(missing)}")
    roll_deg, pitch_deg = wrist_from_motors(
        ticks_to_angle_deg("WRIST1", ticks["WRIST1"]), ticks_to_angle_deg("WRIST2", ticks["WRIST2"])
    )
    return (
        ticks_to_column_m(ticks["ZED"]),
        math.radians(ticks_to_angle_deg("SHOULDER", ticks["SHOULDER"])),
        math.radians(ticks_to_angle_deg("ELBOW", ticks["ELBOW"])),
        math.radians(ticks_to_angle_deg("YAW", ticks["YAW"])),
        math.radians(roll_deg),
        math.radians(pitch_deg),
    )
