"""Which teleop controller drives TELEOP mode: the hand source a user or an option chose, the
target box presets an arm offers, and when a session starts in TELEOP mode. No Qt.

The window's teleop page (app/features/teleop.py) only asks these questions and shows the
answers; the same choices serve any other front end (the headless runner, a remote desk).
"""
from __future__ import annotations

from typing import Callable, Optional, Sequence

from core.motion.jog import Jogger, JogTeleopSource
from core.motion.teleop import COMMON_TARGET_BOX, Box, TeleopController, reachable_target_box

KEYBOARD_SOURCE = JogTeleopSource.name  # "keyboard": the jog keys as the hand (widgets.teleop_panel's too)


def target_box_presets(kinematics, desk_margin_m: float) -> tuple[list[tuple[str, Box]], str]:
    """The target boxes an arm offers, best first, and "" — or ([], why) when the arm reaches no
    box around the common one: "Every arm reaches" (the common box), "Half size", and when they
    differ "This arm's" (its own default box, first: the delta) and "Larger (this arm)"."""
    try:
        common = reachable_target_box(kinematics, desk_margin_m, box=Box(*COMMON_TARGET_BOX))
        presets = [("Every arm reaches", common), ("Half size", common.shrunk(0.5))]
        own = reachable_target_box(kinematics, desk_margin_m)
        if own != common:
            presets.insert(0, ("This arm's", own))
        larger = reachable_target_box(kinematics, desk_margin_m, box=common.shrunk(1.5), tries=4)
        if larger != common:
            presets.append(("Larger (this arm)", larger))
    except ValueError as exc:
        return [], str(exc)
    return presets, ""


def default_source(chosen: Optional[str], marker_ids: Sequence[int]) -> str:
    """The hand source TELEOP mode starts with when none is running: the one chosen, else the first marker."""
    return chosen or f"marker:{marker_ids[0]}"


def teleop_controller_for(spec: str, profile, kinematics, desk_margin_m: float,
                          q_commanded=None, box: Optional[Box] = None,
                          source_factory: Optional[Callable] = None, params=None):
    """A new controller for the hand source ``spec``: the keyboard's ``JogTeleopSource`` (starting at
    the tool point of ``q_commanded``, else home), or a ``TeleopController`` around the hand source
    ``source_factory(spec)`` makes, mapping into ``box`` (None: the arm's reachable default box).
    Raises what the source raises (ValueError, OSError, a pose model's error)."""
    if spec == KEYBOARD_SOURCE:
        jogger = Jogger(profile, kinematics, desk_margin_m=desk_margin_m)
        q = q_commanded if q_commanded is not None else profile.q_home
        return JogTeleopSource(jogger, kinematics.fk(q))  # from where the arm is
    if source_factory is None:
        raise ValueError(f"teleop source {spec!r}: no hand source factory given")
    box = box or reachable_target_box(kinematics, desk_margin_m)
    return TeleopController(source_factory(spec), box, params)


def starts_in_teleop(options, teleop) -> bool:
    """True when a session starts in TELEOP mode whatever mode was remembered: ``--teleop`` or
    ``--scenario teleop`` gave it a controller (``teleop``: the targeter's, or None)."""
    return teleop is not None and bool(options.teleop_source or options.scenario == "teleop")


def teleop_hint(is_simulated_camera: bool, scenario: Optional[str], source: Optional[str]) -> str:
    """Why Teleop will wait for ever here, in plain words ("" when a hand can be seen): the
    simulated desk shows a hand only in its teleop scenario; the keyboard needs none."""
    if source == KEYBOARD_SOURCE or not is_simulated_camera or scenario == "teleop":
        return ""
    return ("teleop: this simulated scene has no hand in view, so calibrating waits — restart with "
            "`deskarm --scenario teleop`, or choose Keyboard (jog keys) as the hand")
