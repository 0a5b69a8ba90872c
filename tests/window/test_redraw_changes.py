"""The window redraws only what changed (pytest-qt, offscreen): a repeated camera frame is not
set again, a held command with a new seq marks nothing dirty, the twin skips setData while the
arm holds still, labels are not re-set with the same text — and what did change is drawn.

Worker messages are built by hand and fed to the window's slots in the GUI thread (the window
is not started unless a test needs its timers), so nothing here depends on timing.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from PySide6 import QtWidgets

import widgets  # noqa: F401  (sets pyqtgraph's row-major image order)
from app.gui import MainWindow, command_changed, result_changed, state_changed
from core.messages import (
    Goal,
    JointCommand,
    JointState,
    MarkerObservation,
    PerceptionResult,
    StereoFrame,
    TargetMode,
)
from core.session import DeskSession, SessionOptions
from widgets.arm_twin import ArmTwin, same_points
from widgets.camera_view import CameraView, MarkerOverlay, _MarkerGraphics
from widgets.joint_readout import JointReadout
from widgets.status import StatusBarItems
from widgets.target_panel import TargetPanel

CHAIN = np.array([[0, 0, 0], [0, 0, 0.0662], [0.05, 0.05, 0.15], [0.1, 0.1, 0.1]])
CORNERS = ((100.0, 100.0), (140.0, 100.0), (140.0, 140.0), (100.0, 140.0))


class Calls:
    """Counts calls of a method, replaced on one object (or class) with monkeypatch."""

    def __init__(self, monkeypatch, owner, name: str) -> None:
        self.count = 0
        original = getattr(owner, name)

        def counting(*args, **kwargs):
            self.count += 1
            return original(*args, **kwargs)

        monkeypatch.setattr(owner, name, counting)


def frame(seq: int, left=None, right=None, repeated=False) -> StereoFrame:
    rng = np.random.default_rng(seq)
    left = rng.integers(0, 255, (480, 640, 3), dtype=np.uint8) if left is None else left
    right = rng.integers(0, 255, (480, 640, 3), dtype=np.uint8) if right is None else right
    return StereoFrame(seq=seq, t=seq / 30.0, left=left, right=right, repeated=repeated)


def result(seq: int, stereo: StereoFrame, shift_px: float = 0.0, reused=False) -> PerceptionResult:
    corners = tuple((x + shift_px, y) for x, y in CORNERS)
    marker = MarkerObservation(23, True, corners, corners, (0.0, 0.1, 0.0),
                               (0.03 + shift_px * 1e-3, 0.15, 0.0))
    return PerceptionResult(seq=seq, t=stereo.t, markers=(marker,), timings_ms={},
                            full_frame_search=False, frame=stereo, reused=reused)


def command(seq: int, q, reachable=True) -> tuple[JointCommand, Goal]:
    cmd = JointCommand(seq=seq, t=seq * 0.02, q=tuple(q), reachable=reachable,
                       base_p_target=(0.03, 0.15, 0.02))
    goal = Goal(seq=seq, t=seq * 0.02, base_p_target=(0.03, 0.15, 0.02), mode=TargetMode.FOLLOW)
    return cmd, goal


@pytest.fixture
def window(qtbot) -> MainWindow:
    """The window on the static simulated desk, shown at 800x480, workers not started."""
    session = DeskSession.create(SessionOptions(camera="sim", scenario="static"))
    w = MainWindow(session)
    qtbot.addWidget(w)
    w.resize(800, 480)
    w.show()
    qtbot.waitExposed(w)
    yield w
    w.stop()


# ------------------------------------------------------------------------------- pure decisions
def test_same_points_has_a_tolerance_and_treats_nan_gaps_and_none_as_values():
    assert same_points(CHAIN, CHAIN.copy()) and same_points(CHAIN, CHAIN + 5e-7)
    assert not same_points(CHAIN, CHAIN + 1e-3)
    assert not same_points(CHAIN, CHAIN[:3])
    gaps = np.vstack([CHAIN, np.full((1, 3), np.nan), CHAIN])
    assert same_points(gaps, gaps.copy())
    assert not same_points(gaps, np.nan_to_num(gaps))
    assert same_points(None, None) and not same_points(None, CHAIN) and not same_points(CHAIN, None)
    assert same_points((0.1, 0.2), [0.1, 0.2])


def test_a_held_command_with_a_new_seq_changes_nothing_on_screen():
    cmd, goal = command(1, (1.57, 1.0, -1.2))
    assert command_changed(None, None, cmd, goal)
    again = replace(cmd, seq=2, t=0.04, source_t=0.03), replace(goal, seq=2, t=0.04)
    assert not command_changed(cmd, goal, *again)
    moved = replace(cmd, q=(1.57, 1.01, -1.2))
    assert command_changed(cmd, goal, moved, goal)
    assert command_changed(cmd, goal, replace(cmd, reachable=False, reach_error_m=0.023), goal)
    assert command_changed(cmd, goal, cmd, replace(goal, valid=False, note="target lost"))
    assert command_changed(cmd, goal, cmd, replace(goal, base_p_target=(0.04, 0.15, 0.02)))


def test_a_joint_state_changes_the_screen_when_the_joints_or_feedback_change():
    state = JointState(seq=1, t=0.0, q=(1.57, 1.0, -1.2))
    assert state_changed(None, state)
    assert not state_changed(state, replace(state, seq=2, t=0.1))
    assert state_changed(state, replace(state, q=(1.57, 1.0, -1.19)))
    assert state_changed(state, replace(state, measured=False))


def test_a_result_changes_the_screen_only_with_new_images_disparity_or_markers():
    f1 = frame(1)
    r1 = result(1, f1)
    same_arrays = result(2, frame(2, f1.left, f1.right))
    assert not result_changed(r1, same_arrays)
    assert not result_changed(r1, result(2, frame(2, repeated=True), reused=True))  # the source's word
    assert result_changed(r1, result(2, frame(2)))  # other arrays: other images
    assert result_changed(r1, result(2, frame(2, f1.left, f1.right), shift_px=3.0))  # a marker moved
    assert result_changed(r1, replace(same_arrays, disparity=np.zeros((480, 640), np.float32)))
    assert result_changed(None, r1)


# ------------------------------------------------------------------------------- widgets
def test_a_camera_view_sets_an_image_once_however_often_it_is_shown(qtbot, monkeypatch):
    view = CameraView("Left")
    qtbot.addWidget(view)
    view.show()
    set_image = Calls(monkeypatch, view._image_item, "setImage")
    img = frame(1).left
    view.show_image(img)
    view.show_image(img)
    assert set_image.count == 1 and view.frames_drawn == 1
    view.set_display_mode("disparity")
    view.set_display_mode("image")  # back: the image item still holds it
    assert set_image.count == 1 and view._image_item.isVisible()
    view.show_image(img.copy())  # a new frame, even with the same pixels, is drawn
    assert set_image.count == 2 and view.frames_drawn == 2
    view.redraw_unchanged = True  # the window's redraw-all mode
    view.show_image(view._shown_image)
    assert set_image.count == 3


def test_a_camera_view_skips_overlays_it_already_shows_and_draws_moved_ones(qtbot, monkeypatch):
    view = CameraView("Left")
    qtbot.addWidget(view)
    shows = Calls(monkeypatch, _MarkerGraphics, "show")
    overlay = MarkerOverlay(23, np.array(CORNERS), True, "23")
    view.set_markers([overlay])
    view.set_markers([MarkerOverlay(23, np.array(CORNERS), True, "23")])  # equal, not the same object
    assert shows.count == 1
    view.set_markers([MarkerOverlay(23, np.array(CORNERS) + 2.0, True, "23")])
    assert shows.count == 2
    assert view.marker_at(122.0, 122.0) == 23  # the moved outline is the one that counts
    view.set_markers([MarkerOverlay(23, np.array(CORNERS) + 2.0, False, "23")])  # lost: dashed
    assert shows.count == 3


def test_the_twin_skips_set_data_while_the_arm_holds_still_and_draws_when_it_moves(qtbot, monkeypatch):
    twin = ArmTwin()
    qtbot.addWidget(twin)
    twin.show()
    twin.set_arm(CHAIN, CHAIN)
    twin.set_target((0.3, 0.3, 0.0), reachable=False)
    twin.set_markers({23: np.array([0.031, 0.152, 0.0])})
    measured = Calls(monkeypatch, twin._top.measured, "setData")
    target = Calls(monkeypatch, twin._top.target, "setData")
    target_pen = Calls(monkeypatch, twin._top.target, "setPen")
    markers = Calls(monkeypatch, twin._top.markers, "setData")
    twin.set_arm(CHAIN.copy(), CHAIN + 1e-7)  # new arrays, same places
    twin.set_target([0.3, 0.3, 0.0], reachable=False)
    twin.set_markers({23: np.array([0.031, 0.152, 0.0])})
    assert (measured.count, target.count, target_pen.count, markers.count) == (0, 0, 0, 0)
    moved = CHAIN + (0.0, 0.0, 0.01)
    twin.set_arm(CHAIN, moved)
    assert measured.count == 1
    assert np.allclose(twin._top.measured.getData()[0], moved[:, 0] * 100)
    _, z_cm = twin._side.measured.getData()
    assert np.allclose(z_cm, moved[:, 2] * 100)
    twin.set_target((0.3, 0.3, 0.0), reachable=True)  # same place, now reachable: recoloured
    assert target_pen.count == 1 and target.count >= 1
    twin.set_markers({23: np.array([0.041, 0.152, 0.0])})
    assert markers.count == 1


def test_labels_are_set_only_when_their_text_or_colour_changes(qtbot, monkeypatch):
    window = QtWidgets.QMainWindow()
    qtbot.addWidget(window)
    items = StatusBarItems(window.statusBar())
    items.update("sim://desk", "sim:// ✓ 10 cmds", 29.96, 48.4)
    style = Calls(monkeypatch, items.bridge_label, "setStyleSheet")
    fps_text = Calls(monkeypatch, items.fps_label, "setText")
    items.update("sim://desk", "sim:// ✓ 10 cmds", 29.98, 48.1)  # same as shown, to the digit
    assert (style.count, fps_text.count) == (0, 0)
    items.update("sim://desk", "lost — retrying", 12.0, 48.1)
    assert style.count == 1 and fps_text.count == 1 and items.fps_label.text() == "12.0 fps"

    panel = TargetPanel()
    qtbot.addWidget(panel)
    panel.set_reach_status("on target", True)
    reach_style = Calls(monkeypatch, panel.reach_label, "setStyleSheet")
    panel.set_reach_status("on target", True)
    assert reach_style.count == 0
    panel.set_reach_status("out of reach by 23 mm — going to the nearest point", False)
    assert reach_style.count == 1 and panel.reach_label.property("reach_ok") is False

    readout = JointReadout()
    qtbot.addWidget(readout)
    readout.set_joints(["base", "shoulder", "elbow"], [0, 15, 0], [180, 165, 180])
    readout.set_values([90.0, 150.0, 120.0], [91.0, 150.0, 120.0])
    repaint = Calls(monkeypatch, readout._bars[0], "update")
    cmd_text = Calls(monkeypatch, readout._rows[0][1], "setText")
    readout.set_values([90.0, 150.0, 120.0], [91.0, 150.0, 120.0])
    assert (repaint.count, cmd_text.count) == (0, 0)
    readout.set_values([95.0, 150.0, 120.0], [91.0, 150.0, 120.0])
    assert repaint.count == 1 and readout._rows[0][1].text() == "95.0"


# ------------------------------------------------------------------------------- the window
def test_the_same_frame_fed_twice_is_drawn_once_and_a_changed_frame_is_drawn(window, monkeypatch):
    set_image = Calls(monkeypatch, window.view_left._image_item, "setImage")
    f1 = frame(1)
    window.on_result(result(1, f1))
    assert window.dirty
    window.redraw()
    assert set_image.count == 1 and not window.dirty
    window.on_result(result(2, frame(2, f1.left, f1.right)))  # the source re-delivered the arrays
    assert not window.dirty
    window._dirty = True  # drawn anyway (e.g. the arm moved): the view still skips the image
    window.redraw()
    assert set_image.count == 1
    window.on_result(result(3, frame(3)))
    assert window.dirty
    window.redraw()
    assert set_image.count == 2 and window.view_left._shown_image is window._result.frame.left


def test_a_held_command_or_state_does_not_mark_the_window_dirty(window, monkeypatch):
    q = window.session.profile.q_home
    cmd, goal = command(1, q)
    window.on_command(cmd, goal)
    window.on_state(JointState(seq=1, t=0.0, q=tuple(q)))
    assert window.dirty
    window.redraw()
    arm = Calls(monkeypatch, window.twin._top.measured, "setData")
    for seq in range(2, 6):  # the control loop repeating the held command at 50 Hz
        window.on_command(replace(cmd, seq=seq, t=seq * 0.02), replace(goal, seq=seq))
        window.on_state(JointState(seq=seq, t=seq * 0.02, q=tuple(q)))
        assert not window.dirty
    moved = tuple(v + 0.05 for v in q)
    window.on_state(JointState(seq=6, t=0.12, q=moved))
    assert window.dirty
    window.redraw()
    assert arm.count == 1
    expected = np.asarray(window.session.kinematics.chain_points(moved))[:, 0] * 100
    assert np.allclose(window.twin._top.measured.getData()[0], expected)


def test_an_unreachable_target_shows_as_soon_as_the_command_says_so(window):
    q = window.session.profile.q_home
    cmd, goal = command(1, q)
    window.on_command(cmd, goal)
    window.redraw()
    assert window.target_panel.reach_label.property("reach_ok") is True
    window.on_command(replace(cmd, seq=2, reachable=False, reach_error_m=0.023), replace(goal, seq=2))
    assert window.dirty
    window.redraw()
    assert "23 mm" in window.target_panel.reach_label.text()


def test_an_idle_window_does_not_rearm_its_redraw_timer_but_new_data_does(window):
    window.start()
    window.redraw()  # whatever was pending is drawn; nothing runs between these lines
    assert not window._redraw_timer.isActive()
    window._mark_dirty()
    assert window._redraw_timer.isActive()
    window.redraw_only_changes = False  # the bench's baseline: re-armed after every draw
    window.redraw()
    assert window._redraw_timer.isActive()
    assert window.view_left.redraw_unchanged and window.twin.redraw_unchanged


def test_a_moving_marker_is_drawn_at_camera_rate(qtbot):
    """The wander scenario: the window keeps drawing new frames (not a rate assert: a count)."""
    session = DeskSession.create(SessionOptions(camera="sim", scenario="wander"))
    w = MainWindow(session)
    qtbot.addWidget(w)
    w.resize(800, 480)
    w.show()
    w.start()
    try:
        qtbot.waitUntil(lambda: w.view_left.frames_drawn >= 10, timeout=5000)
        qtbot.waitUntil(lambda: w.status_items.fps_label.text() != "— fps", timeout=3000)
    finally:
        w.stop()


def test_the_latency_shown_is_of_the_first_command_carrying_a_frame_not_of_the_ticks_after_it(window):
    """Ticks repeat the last frame's time in source_t: its age grows, but that is no latency."""
    clock_now = {"t": 10.010}
    window.session.clock.now = lambda: clock_now["t"]
    cmd, goal = command(1, window.session.profile.q_home)
    window.on_command(replace(cmd, source_t=10.0), goal)
    assert window._latency_ms == pytest.approx(10.0)
    clock_now["t"] = 10.030  # a tick 20 ms later, same frame behind it
    window.on_command(replace(cmd, seq=2, source_t=10.0), goal)
    assert window._latency_ms == pytest.approx(10.0)
    clock_now["t"] = 10.036  # the next frame's command, 3 ms after that frame
    window.on_command(replace(cmd, seq=3, source_t=10.033), goal)
    assert window._latency_ms == pytest.approx(3.0)


def test_a_non_finite_manual_target_is_refused_with_a_note_not_a_traceback(window):
    before = window.session.targeter.manual_target
    window.on_manual_target((float("nan"), 0.1, 0.1))
    assert window.session.targeter.manual_target == before
    assert "must be a finite number" in window._note


def test_a_frames_markers_and_objects_are_labelled_in_one_layout_where_two_would_put_them(qtbot, monkeypatch):
    """set_overlays (what the window's draw calls) lays the labels out once for both kinds (issue 28:
    two layouts a view a frame were a tenth of the window's draw), where set_markers then
    set_objects, each laying them out, put them."""
    from tests.window.test_object_labels import small_view, square

    one, two = small_view(qtbot), small_view(qtbot)
    frames = [([MarkerOverlay(23, np.array(CORNERS) + d, True, "23: x 3.1 y 15.2 z 0.0 cm")],
               [square(1, 150 + d, 130, "#1 red"), square(2, 160, 190 + d, "#2 blue 0.98"),
                square(3, 420, 300 - d, "#3 green")]) for d in (0.0, 4.0, 9.0)]
    laid_out = []
    real = one._layout_labels

    def layout():  # a layout that places labels (not one put off until both kinds are set)
        laid_out.append(not one._defer_layout)
        real()

    monkeypatch.setattr(one, "_layout_labels", layout)
    for markers, objects in frames:
        laid_out.clear()
        one.set_overlays(markers, objects)
        assert laid_out.count(True) == 1, laid_out
        two.set_markers(markers)
        two.set_objects(objects)
        drawn_one = [(d.kind, d.key, d.text, d.rect.topLeft().toTuple()) for d in one.drawn_labels()]
        drawn_two = [(d.kind, d.key, d.text, d.rect.topLeft().toTuple()) for d in two.drawn_labels()]
        assert drawn_one == drawn_two and len(drawn_one) >= 4
