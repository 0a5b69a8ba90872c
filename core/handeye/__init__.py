"""Hand-eye (camera → robot) calibration: the solves, the sweep that collects points, the file.

Never imports the simulated desk (an import-linter contract): the simulated mount's truth is
asked of the camera by the callers that test against it.
"""
from core.handeye.solve import (
    DEFAULT_TOOL_MARKER,
    HandEyeResult,
    PlanarMap,
    ToolMarker,
    kabsch,
    pose_error,
    solve_planar,
    solve_rigid,
    solve_touch_points,
    tool_marker_of,
)
from core.handeye.storage import HandEyeFileError, default_hand_eye_path, load_hand_eye, save_hand_eye
from core.handeye.sweep import HandEyeSweep, SweepStep

__all__ = [
    "DEFAULT_TOOL_MARKER", "HandEyeResult", "PlanarMap", "ToolMarker", "kabsch", "pose_error", "solve_planar",
    "solve_rigid", "solve_touch_points", "tool_marker_of", "HandEyeFileError", "default_hand_eye_path",
    "load_hand_eye", "save_hand_eye", "HandEyeSweep", "SweepStep",
]
