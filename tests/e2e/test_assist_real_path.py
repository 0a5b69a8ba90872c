"""The assistive arm's real path, end to end, with only the hardware simulated: a "webcam" on the
hand (``WebcamHandCamera`` through a capture object, its intrinsics from a calibration file) that
films the simulated desk from where the simulated servo arm *really* is — its servos lag behind
the commands at their own speed — and the loop's joint values going through ``GuardedArm`` (the
safety chain) to that arm. So the loop sees what a webcam would: images from a pose it only
commanded, not one it knows. It still presses the chosen button."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from app.assist_window import build_webcam_loop
from app.cli_assist import trial_scene
from core.clock import SimClock
from core.devices.guarded_arm import GuardedArm
from core.devices.sim_arm import SimServoArm
from core.kinematics import build_kinematics, load_profile
from core.motion.safety import is_within_limits
from core.sim.desk import SimDesk
from core.sim.hand_camera import SimHandCamera
from core.sim.rig import SimRig

PROFILE = load_profile("assistive_5dof")


class FilmingTheDesk:
    """A cv2.VideoCapture stand-in: each ``read`` renders the simulated desk from the camera frame
    at the simulated arm's measured joints (where its servos are now, not where they were told)."""

    def __init__(self, arm: SimServoArm, clock: SimClock, seed: int = 3):
        self.arm, self.clock = arm, clock
        self.desk = SimDesk(SimRig(), "static", seed=seed)
        self.scene = trial_scene(np.random.default_rng([seed, 0, 12]))
        self.desk.set_scenario(self.scene)
        self.camera = SimHandCamera(self.desk, build_kinematics(PROFILE))
        self.reads = 0

    def isOpened(self):  # noqa: N802 (the cv2.VideoCapture interface)
        return True

    def set(self, prop, value):
        return True

    def get(self, prop):
        return 0.0

    def release(self):
        pass

    def read(self):
        self.reads += 1
        state = self.arm.joint_state()
        return True, self.camera.render(state.q, self.clock.now()).image


@pytest.fixture
def calibration_file(tmp_path):
    """The hand camera's calibration as a user's would be saved (OpenCV YAML)."""
    K = SimHandCamera(SimDesk(SimRig(), "static"), build_kinematics(PROFILE)).K
    path = tmp_path / "hand_camera.yaml"
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("camera_matrix", np.asarray(K, dtype=float))
    fs.write("image_width", 640)
    fs.write("image_height", 480)
    fs.release()
    return path


@pytest.mark.parametrize("choice", [2, 6])
def test_the_webcam_path_presses_the_chosen_button_through_the_safety_chain(calibration_file, choice):
    clock = SimClock()
    arm_bridge = SimServoArm(PROFILE, clock=clock)
    webcam = {}

    def capture_factory(device):
        webcam["cap"] = FilmingTheDesk(arm_bridge, clock)
        return webcam["cap"]

    loop, ready = build_webcam_loop("sim-webcam", bridge=arm_bridge, depth="size", calibration=calibration_file,
                                    capture_factory=capture_factory)
    arm = GuardedArm(arm_bridge, loop.kin, loop.frame_dt_s, now=clock.now)
    assert arm.connect()
    sent = []

    def frame():
        loop.step()
        command = arm.send(loop.q, loop.t)
        assert command is not None, arm.lost
        sent.append(command)
        loop.q = command.q
        clock.advance(loop.frame_dt_s)

    loop.q = arm.start_pose()  # the simulated arm starts parked
    loop.go_to(ready)
    while loop.busy and len(sent) < 300:
        frame()
    for _ in range(15):  # the servos catch up with the last command (0.5 s)
        clock.advance(loop.frame_dt_s)
    assert np.allclose(arm_bridge.joint_state().q, ready, atol=np.radians(1.0))
    boxes = loop.offer()
    assert len(boxes) >= 9 and webcam["cap"].reads > 0
    loop.select(choice)
    while loop.busy and len(sent) < 1500:
        frame()
    assert loop.fsm.outcome.startswith("pressed"), loop.fsm.event_log()
    # the button pressed is the one chosen (the button nearest the chosen box in the image the user
    # chose from): the commanded tool tip crossed its top face within 3 mm of its centre
    cam = webcam["cap"].camera
    panel = webcam["cap"].scene.panel()
    offered_px = np.array(boxes[choice].centre_px)
    offer_pose = loop.kin.camera_pose(ready)
    pixels = {n: cam.project(offer_pose, np.array([panel.button_centre(n)]))[0][0] for n in panel.BUTTONS}
    wanted = min(pixels, key=lambda n: np.hypot(*(pixels[n] - offered_px)))
    tips = np.array([loop.kin.fk(c.q) for c in sent])
    top = np.array(panel.button_centre(wanted))
    down = np.flatnonzero((tips[:-1, 2] > top[2]) & (tips[1:, 2] <= top[2]))
    assert down.size, "the tool tip never went below the button's top"
    a, b = tips[down[0]], tips[down[0] + 1]
    crossing = a + (a[2] - top[2]) / (a[2] - b[2]) * (b - a)  # where the tip passed the top face
    assert np.hypot(*(crossing[:2] - top[:2])) < 0.003  # the trials' success radius
    assert all(is_within_limits(c.q, PROFILE) for c in sent)
