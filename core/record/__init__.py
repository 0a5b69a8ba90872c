"""Recording (and, beside it, replay and the link between machines): a desk session as a rosbag2
folder with MCAP storage and ROS 2 messages, readable by ROS 2 tools and by deskarm's replay.

``topics`` is the contract (topic names, message types, conversions); ``writer`` the crash-safe
rosbag2 writer; ``recorder`` the threaded recorder the loop feeds without blocking. Names are
imported lazily: ``import core.record.<module>`` does not load rosbags and OpenCV for the others.
"""
from __future__ import annotations

_EXPORTS = {
    "Recorder": "core.record.recorder",
    "RecordingInfo": "core.record.recorder",
    "default_recording_path": "core.record.recorder",
    "list_recordings": "core.record.recorder",
    "recordings_dir": "core.record.recorder",
    "session_info": "core.record.recorder",
    "TOPICS": "core.record.topics",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        import importlib

        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'core.record' has no attribute {name!r}")
