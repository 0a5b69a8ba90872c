"""Words and numbers the window shows, as pure functions of what they describe (no widgets):
depth labels, joint values, the cups game's and teleop's hints, a finished replay's line, the
Lissajous preview's points, the serial ports to offer. Shared by app/gui.py and app/features/.
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from core.motion.teleop_choice import teleop_hint as _teleop_hint


def following_text(goal) -> str:
    """"following red ball #3" for a valid Object-mode goal (its note names the object)."""
    note = goal.note or "object"
    return note if note.startswith("following") else f"following {note}"


def format_depth(depth_m: float) -> str:
    """"41 cm" below a metre, "1.25 m" above, "∞" at zero disparity."""
    if not math.isfinite(depth_m):
        return "∞"
    return f"{depth_m * 100:.0f} cm" if depth_m < 1.0 else f"{depth_m:.2f} m"


def depth_texts(x_px: float, y_px: float, sample) -> tuple[str, str]:
    """(label on the view, line in the Stereo tab) for a DepthSample (None: nothing matched)."""
    if sample is None:
        return "no depth here\n(no stereo match)", f"({x_px:.0f}, {y_px:.0f}): no depth — no stereo match there"
    text = f"{sample.depth_mm:.0f} mm"
    where = ""
    if sample.base_p is not None:
        x_cm, y_cm, z_cm = (round(100.0 * v, 1) + 0.0 for v in sample.base_p)  # + 0.0: no "-0.0"
        where = f"x {x_cm:.1f} y {y_cm:.1f} z {z_cm:.1f} cm"
        text += "\n" + where
    readout = (f"Depth at ({x_px:.0f}, {y_px:.0f}): {sample.depth_mm:.0f} mm (disparity "
               f"{sample.disparity_px:.1f} px)" + (f" · robot base {where}" if where else ""))
    return text, readout


def joint_display_limits(profile) -> tuple[list[float], list[float]]:
    """Joint limits as people read them: servo degrees for servo arms, else deg or mm."""
    if getattr(profile, "has_servos", True):
        return [j.servo_min_deg for j in profile.joints], [j.servo_max_deg for j in profile.joints]
    return [j.to_display(j.q_min) for j in profile.joints], [j.to_display(j.q_max) for j in profile.joints]


def joint_display_values(profile, q) -> list[float]:
    """Joint values as people read them (see joint_display_limits)."""
    if getattr(profile, "has_servos", True):
        return list(profile.to_servo_deg(q))
    return list(profile.to_display(q))


def cups_hint(session) -> str:
    """What the cups game needs and this desk lacks ("" when the scene can play it)."""
    if session.is_simulated_camera and session.options.scenario != "cups":
        return ("cups game: this simulated scene has no ball or cups — restart with "
                "`deskarm --scenario cups` to play it")
    if not session.is_simulated_camera:
        return ("cups game: put a red ball on the desk in view of both cameras and cover it "
                "with one of the marked cups; the arm points at the cup hiding it")
    return ""


def replay_end_text(camera) -> str:
    """"replay finished (0:12) — …" when ``camera`` is a replay that played to its end, else ""."""
    if getattr(camera, "kind", "") != "replay" or not getattr(camera, "finished", False):
        return ""
    whole_s = int(camera.duration_s)  # as the replay bar counts: "replay 0:12 / 0:12"
    return f"replay finished ({whole_s // 60}:{whole_s % 60:02d}) — tap ▶ Play again or drag the seek bar"


def lissajous_preview(params, kinematics, n: int = 400):
    """Curve points (n,3) with unreachable ones replaced by the nearest reachable, and the
    fraction that was out of reach."""
    ts = np.linspace(0.0, params.period_s(), n)
    points = np.empty((n, 3))
    outside = 0
    q = None
    for k, t in enumerate(ts):
        ik = kinematics.ik(params.point(t), q)
        q = ik.q
        points[k] = ik.base_p_reached
        outside += int(not ik.reachable)
    return points, outside / n


def list_port_choices() -> list[tuple[str, str]]:
    """(label, path) for each serial port, stable names first (empty if listing fails)."""
    try:
        from core.devices.ports import list_ports, preferred_name
    except ImportError:
        return []
    out = []
    for info in list_ports():
        path = preferred_name(info)
        out.append((f"{path} — {info.description}" if info.description else path, path))
    return out


def teleop_hint(session, source: Optional[str]) -> str:
    """Why Teleop will wait for ever on ``session``'s desk, in plain words ("" when a hand can be
    seen): the simulated desk shows a hand only in its teleop scenario; the keyboard needs none."""
    return _teleop_hint(session.is_simulated_camera, session.options.scenario, source)
