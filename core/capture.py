"""Opening a webcam with OpenCV: the stereo cameras (core.vision.cameras) and the assistive arm's
hand camera (core.devices.hand_camera) open theirs the same way."""
from __future__ import annotations

import os
import sys


def open_quietly(factory, dev):
    """Open a capture without OpenCV's backend warnings (a missing camera is reported by us)."""
    import cv2

    logging = getattr(getattr(cv2, "utils", None), "logging", None)
    if logging is None:
        return factory(dev)
    previous = logging.getLogLevel()
    logging.setLogLevel(logging.LOG_LEVEL_ERROR)
    try:
        return factory(dev)
    finally:
        logging.setLogLevel(previous)


def default_capture_factory(device):
    """cv2.VideoCapture on the V4L2 backend (Linux; by-id links resolved), else the default one."""
    import cv2

    if sys.platform.startswith("linux"):
        if isinstance(device, str):
            device = os.path.realpath(device)
        return cv2.VideoCapture(device, cv2.CAP_V4L2)
    return cv2.VideoCapture(device)
