"""Kinematics: robot profiles, URDF chains, the analytic (RRR, delta) and closed-loop (CLIK) solvers.

``build_kinematics(profile)`` is the front door: it imports only the solver the profile's kind
needs (Pinocchio is loaded for URDF profiles only). ``load_profile`` reads a profile by name,
path or ``urdf:PATH``.
"""
from __future__ import annotations

import importlib

from core.kinematics.base import IKResult, ProfileError
from core.kinematics.profile import RobotProfile, list_profiles, load_profile

# kind -> (module, class) of its solver, imported on first use
SOLVERS: dict[str, tuple[str, str]] = {
    "rrr": ("core.kinematics.rrr", "RRRKinematics"),
    "delta3": ("core.kinematics.delta", "DeltaKinematics"),
    "urdf": ("core.kinematics.clik", "ClikKinematics"),
}


def build_kinematics(profile: RobotProfile):
    """The kinematics solver for ``profile``: RRRKinematics ("rrr"), DeltaKinematics ("delta3")
    or ClikKinematics ("urdf", closed-loop IK with Pinocchio)."""
    try:
        module_name, class_name = SOLVERS[profile.kind]
    except KeyError:
        raise ProfileError(
            f"{profile.source or profile.name}: no kinematics solver for kind {profile.kind!r}"
        ) from None
    return getattr(importlib.import_module(module_name), class_name)(profile)


__all__ = ["build_kinematics", "load_profile", "list_profiles", "RobotProfile", "ProfileError", "IKResult", "SOLVERS"]
