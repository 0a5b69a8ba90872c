"""The simulated desk shows a calibration board while the wizard is open (``show_board``): held
still at each of a fixed sequence of poses, then moved on; without it the frames are untouched."""
import numpy as np
import pytest

from core.clock import SimClock, WallClock
from core.sim.board_render import board_overlay, paint_overlay, sim_rig_truth
from core.sim.camera import BOARD_HOLD_S, BOARD_POSES, SimStereoCamera
from core.vision.stereo_calibration import (
    CharucoSpec,
    ChessboardSpec,
    DetectOptions,
    coverage_of,
    detect_pair,
    pose_params,
)

BOARD = ChessboardSpec(9, 6, 0.025)  # the wizard's default board


def camera(scenario: str = "static") -> tuple[SimStereoCamera, SimClock]:
    clock = SimClock()
    cam = SimStereoCamera(scenario=scenario, clock=clock)
    cam.connect()
    return cam, clock


def frame_at(cam: SimStereoCamera, clock: SimClock, t: float):
    """The camera's frame at camera time ``t`` (the simulated clock jumps there)."""
    clock.advance(t - clock.now())
    frame = cam.read()
    assert frame.t == pytest.approx(t)
    return frame


def test_a_shown_board_is_found_in_both_views_at_most_poses_and_covers_the_image():
    cam, clock = camera()
    cam.show_board(BOARD)
    found, params = 0, []
    for k in range(BOARD_POSES):
        f = frame_at(cam, clock, (k + 0.5) * BOARD_HOLD_S)
        assert cam.board_pose_index(f.t) == k
        det = detect_pair(f.left, f.right, BOARD)  # the wizard's own detector, full quality
        if det.ok:
            found += 1
            params.append(pose_params(det.left, BOARD))
    assert found >= 0.9 * BOARD_POSES, f"board found in both views at {found} of {BOARD_POSES} poses"
    cov = coverage_of(params)
    # near and far, left and right, up and down, tilted: enough for the wizard's meters
    assert min(cov.x, cov.y, cov.size, cov.skew) >= 0.7, cov


def test_the_board_holds_still_for_a_while_then_jumps_to_the_next_pose():
    cam, clock = camera()
    cam.show_board(BOARD)
    first = frame_at(cam, clock, 0.1)
    still = frame_at(cam, clock, BOARD_HOLD_S - 0.1)
    moved = frame_at(cam, clock, BOARD_HOLD_S + 0.1)
    # held still: the very same images, flagged so (the wizard's "held still" gate sees no motion)
    assert still.repeated and still.left is first.left
    assert not moved.repeated and not np.array_equal(moved.left, first.left)
    opts = DetectOptions(fast=True)
    a, b = detect_pair(first.left, first.right, BOARD, opts), detect_pair(moved.left, moved.right, BOARD, opts)
    assert a.ok and b.ok
    assert np.linalg.norm(a.left_points - b.left_points, axis=1).mean() > 20.0  # a new pose, not jitter
    # after the last pose the sequence starts again
    again = frame_at(cam, clock, BOARD_POSES * BOARD_HOLD_S + 0.1)
    assert cam.board_pose_index(again.t) == 0 and np.array_equal(again.left, first.left)


def test_without_a_board_the_frames_are_those_of_a_camera_that_never_showed_one():
    for scenario in ("static", "wander"):
        shown, clock_a = camera(scenario)
        plain, clock_b = camera(scenario)
        shown.show_board(BOARD)
        times = [0.0, 0.4, 2.0]
        for t in times:  # the board is there …
            a, b = frame_at(shown, clock_a, t), frame_at(plain, clock_b, t)
            assert not np.array_equal(a.left, b.left)
        shown.show_board(None)
        assert shown.shown_board is None and shown.board_pose_index(3.0) is None
        for t in (3.0, 3.5, 5.0):  # … and gone without a trace
            a, b = frame_at(shown, clock_a, t), frame_at(plain, clock_b, t)
            assert np.array_equal(a.left, b.left) and np.array_equal(a.right, b.right), (scenario, t)
            assert a.truth == b.truth


def test_the_arm_moving_renders_the_desk_again_under_a_still_board():
    cam, clock = camera()
    cam.show_board(BOARD)
    first = frame_at(cam, clock, 0.1)
    cam.set_arm_points(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.12], [0.1, 0.05, 0.2]]))
    second = frame_at(cam, clock, 0.2)
    assert not second.repeated and not np.array_equal(first.left, second.left)
    det1, det2 = (detect_pair(f.left, f.right, BOARD, DetectOptions(fast=True)) for f in (first, second))
    assert det1.ok and det2.ok
    assert np.abs(det1.left_points - det2.left_points).max() < 0.5  # the board itself did not move


def test_a_charuco_board_is_shown_too():
    board = CharucoSpec(5, 7, 0.03, 0.022, "DICT_4X4_50")
    cam, clock = camera()
    cam.show_board(board)
    seen = 0
    for k in range(6):
        f = frame_at(cam, clock, (k + 0.5) * BOARD_HOLD_S)
        seen += detect_pair(f.left, f.right, board).ok
    assert seen >= 5


def test_show_board_is_safe_while_the_sensor_thread_renders_ahead():
    cam = SimStereoCamera(scenario="static", fps=60.0, clock=WallClock())
    cam.connect()
    try:
        cam.read()
        cam.show_board(BOARD)  # from this (the "GUI") thread while the sensor thread renders
        shown_at = cam.clock.now()
        frame = cam.read()
        while frame is not None and frame.t < shown_at + 1.0 / 60.0:  # maybe rendered before the call
            frame = cam.read()
        assert frame is not None
        assert detect_pair(frame.left, frame.right, BOARD, DetectOptions(fast=True)).ok
        cam.show_board(None)
        hidden_at = cam.clock.now()
        assert cam.shown_board is None
        frame = cam.read()
        while frame is not None and frame.t < hidden_at + 1.0 / 60.0:
            frame = cam.read()
        assert frame is not None
        assert not detect_pair(frame.left, frame.right, BOARD, DetectOptions(fast=True)).left.ok
    finally:
        cam.disconnect()
    assert cam._sensor is None


def test_an_overlay_off_the_image_paints_nothing():
    from core.sim.board_render import BoardPose
    from core.sim.rig import SimRig

    truth = sim_rig_truth(SimRig())
    behind = BoardPose(np.eye(3), np.array([0.0, 0.0, -0.5]))
    assert board_overlay(BOARD, truth, "left", behind) is None
    aside = BoardPose(np.eye(3), np.array([5.0, 0.0, 0.5]))  # far to the right, out of view
    assert board_overlay(BOARD, truth, "left", aside) is None
    image = np.full((480, 640, 3), 90, np.uint8)
    assert paint_overlay(image, None) is image and (image == 90).all()
