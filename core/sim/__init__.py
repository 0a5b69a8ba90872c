"""The simulated desk: the stereo rig, the desk renderer and its scenarios, the calibration-board renderer.

It may use the other wings' public types (calibration, camera interface, messages); no other
wing imports it except by name through a factory (``core.vision.cameras.SIMULATED_CAMERA``).
"""
