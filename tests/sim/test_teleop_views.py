"""A delta anywhere in its teleop target box leaves the teleop scenario's wristband in sight of
both cameras: none of its three arms stands between the cameras and the hand volume.

Before, the delta's target box was the common one, in front of its base: reaching there lifted the
arm that points towards the cameras (arm 0) into the line of sight — teleop calibrated, followed
1.6 s, then held for the rest of the run with the band hidden. The simulated desk draws one chain
of a delta (arm 0), so the headless teleop run (tests/e2e/test_headless_teleop_profiles.py, every
profile) cannot see arms 1 and 2: here each of the three arms is drawn in turn.
(A serial arm is one chain, drawn whole in that run; its IK's posture without the run's history
is not the one the run takes, so a pose-by-pose check like this one would test the wrong arm.)"""
import numpy as np

from core.kinematics import build_kinematics
from core.kinematics.profile import load_profile
from core.motion.teleop import reachable_target_box
from core.sim.camera import SimStereoCamera
from core.sim.scenarios import TeleopScenario


def arm_chains(kinematics, q) -> list[np.ndarray]:
    """A delta's drawable chains, one per arm: base tower, shoulder, elbow, effector joint,
    effector, tool (as ``chain_points`` draws arm 0)."""
    chains = []
    for shoulder, elbow, joint, centre in kinematics.arm_segments(q):
        tool = (centre[0], centre[1], centre[2] - kinematics.tool_offset_m)
        chains.append(np.array([(0.0, 0.0, 0.0), (0.0, 0.0, kinematics.base_height_m), shoulder, elbow, joint,
                                centre, tool]))
    return chains


def band_times(sc: TeleopScenario) -> np.ndarray:
    """Scenario times the band should be seen: in view (after the entry), not under the other hand."""
    t = np.arange(1.0, sc.COVER_IN_T, 0.5)
    lo, hi = sc.occlusion_window()
    return t[(t < lo) | (t > hi)]


def test_no_arm_of_the_delta_hides_the_band_anywhere_in_its_teleop_target_box():
    name = "delta"
    profile = load_profile(name)
    kinematics = build_kinematics(profile)
    box = reachable_target_box(kinematics, profile.workspace.desk_margin_m)
    camera = SimStereoCamera(scenario="teleop")
    desk, sc = camera.desk, camera.desk.scenario_object
    band = sc.band_marker_id
    hidden = []
    for p in box.grid(3):
        ik = kinematics.ik(tuple(p))
        assert ik.reachable, (name, p)
        for i, chain in enumerate(arm_chains(kinematics, ik.q)):
            for t in band_times(sc):
                seen = desk.truth(float(t), chain).by_id()[band]
                if not (seen.visible_left and seen.visible_right):
                    hidden.append((i, tuple(np.round(p, 3)), float(t)))
    assert hidden == [], f"{name}: the band is hidden by arm link(s) at {len(hidden)} (arm, tool, t): {hidden[:5]}"
