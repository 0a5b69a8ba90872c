"""Vision: camera sources, stereo calibration and its file, disparity/depth, perception, calibration health.

``core.vision.cameras.open_camera(spec)`` chooses a source; the simulated desk is imported by
module name only when asked for, so this wing never imports ``core.sim``.
"""
