"""The simulated desk warps a still marker's paper once (issue 28: the simulator's own cost in a
Pi 4 budget): its patch is kept while the marker's homography and outline stay the same to the
bit, and the frames are exactly those of warping it every time."""
import numpy as np

from core.sim import desk as desk_module
from core.sim.camera import SimStereoCamera


def test_a_still_marker_is_warped_once_and_frames_equal_warping_every_time(monkeypatch):
    cam = SimStereoCamera(scenario="objects")  # its markers lie still on the desk, the objects roll
    warps = []
    real_warp = desk_module.SimDesk._warp_patch

    def counted(*args):
        warps.append(args[0])
        return real_warp(*args)

    monkeypatch.setattr(desk_module.SimDesk, "_warp_patch", staticmethod(counted))
    times = [i / 30 for i in range(30)]
    cached = [cam._frame_at(t) for t in times]
    per_frame_markers = len(warps)
    assert 0 < per_frame_markers <= 8  # the markers' patches of both views, made in the first frame(s) only

    # the reference: a fresh camera that forgets every patch before each frame
    ref_cam = SimStereoCamera(scenario="objects")
    desk = ref_cam.desk
    for t, frame in zip(times, cached):
        desk._marker_patches.clear()
        ref = ref_cam._frame_at(t)
        assert np.array_equal(frame.left, ref.left) and np.array_equal(frame.right, ref.right), t
    assert len(warps) > per_frame_markers + len(times)  # the reference did warp on every frame


def test_a_moving_marker_is_warped_again_and_the_patches_stay_few():
    cam = SimStereoCamera(scenario="wander")  # the marker moves every frame
    desk = cam.desk
    for i in range(3 * desk_module.MARKER_PATCH_CACHE):
        cam._frame_at(i / 30)
        assert len(desk._marker_patches) <= desk_module.MARKER_PATCH_CACHE
