"""What the main window draws, apart from the window: what a new worker message changes on
screen (pure: tested without a window), the camera views' images and overlays, the arm twin, and
the line under STOP that says how the target is doing. app/gui.py's redraw calls these.
"""
from __future__ import annotations

import numpy as np

from app.window_texts import following_text
from core.messages import TargetMode
from widgets.arm_twin import profile_joint_levels, same_points
from widgets.camera_view import MarkerOverlay, ObjectOverlay

COMPACT_VIEW_PX = 420  # narrower camera views label markers by id and objects by id and name only


# --- what a new worker message changes on screen (pure: tested without a window) -------------
def _same_markers(a, b) -> bool:
    """Two tuples of MarkerObservation draw the same (id, found, corners, position)."""
    return len(a) == len(b) and all(
        x is y or (x.marker_id == y.marker_id and x.found == y.found
                   and same_points(x.left_corners, y.left_corners)
                   and same_points(x.right_corners, y.right_corners)
                   and same_points(x.base_p_centre, y.base_p_centre))
        for x, y in zip(a, b))


def _same_detection(a, b) -> bool:
    return a is b or (a is not None and b is not None and a.label == b.label and a.box == b.box)


def _same_objects(a, b) -> bool:
    """Two tuples of ObjectObservation draw the same (id, label, boxes in both views, position)."""
    return len(a) == len(b) and all(
        x is y or (x.object_id == y.object_id and x.label == y.label and x.triangulated == y.triangulated
                   and _same_detection(x.left, y.left) and _same_detection(x.right, y.right)
                   and same_points(x.base_p, y.base_p))
        for x, y in zip(a, b))


def result_changed(drawn, result) -> bool:
    """True when a PerceptionResult shows something the drawn one did not: other images (not
    the very same arrays, unless the frame is flagged ``repeated``), another disparity map or
    other markers or objects (unless perception ``reused`` its answer). Pixels are never compared."""
    if drawn is None or result is None:
        return drawn is not result
    f0, f1 = drawn.frame, result.frame
    if (f0 is None) != (f1 is None):
        return True
    if f1 is not None and not (f1.repeated or (f1.left is f0.left and f1.right is f0.right)):
        return True
    if result.disparity is not drawn.disparity:
        return True
    return not (result.reused or (_same_markers(result.markers, drawn.markers)
                                  and _same_objects(result.objects, drawn.objects)))


def command_changed(drawn_command, drawn_goal, command, goal) -> bool:
    """True when a (JointCommand, Goal) shows something the drawn pair did not: joints, target,
    aimed point, reachability, reach error (to the mm shown), mode or note. The held command
    repeated with a new seq and time does not."""
    if drawn_command is None or (drawn_goal is None) != (goal is None):
        return True
    if not (same_points(command.q, drawn_command.q) and command.reachable == drawn_command.reachable
            and round(command.reach_error_m * 1e3) == round(drawn_command.reach_error_m * 1e3)
            and same_points(command.base_p_target, drawn_command.base_p_target)):
        return True
    if goal is None:
        return False
    return not (goal.valid == drawn_goal.valid and goal.mode is drawn_goal.mode and goal.note == drawn_goal.note
                and same_points(goal.base_p_target, drawn_goal.base_p_target))


def state_changed(drawn, state) -> bool:
    """True when a JointState shows something the drawn one did not (joints, feedback or not)."""
    return drawn is None or state.measured != drawn.measured or not same_points(state.q, drawn.q)


def draw_views(views, result, max_disparity: float, followed) -> None:
    """A result's images (or disparity maps) and its markers and objects in the (left, right)
    views; ``followed``: the id of the object being followed (its position is shown at any width)."""
    r = result
    for view, img, side in ((views[0], r.frame.left, "left"), (views[1], r.frame.right, "right")):
        if view.display_mode == "disparity" and r.disparity is not None:
            view.show_disparity(r.disparity, max_disparity)
        else:
            view.show_image(img)
        compact = view.width() < COMPACT_VIEW_PX  # small views: ids only, positions are in the twin
        overlays = [o for o in (MarkerOverlay.from_observation(m, side, "" if compact else None)
                                for m in r.markers) if o is not None]
        view.set_markers(overlays)
        # objects: id, name and score; position and speed too in a wide view, or for the
        # object being followed
        view.set_objects([o for o in (ObjectOverlay.from_observation(obs, side, not compact or
                                                                     obs.object_id == followed)
                                      for obs in r.objects) if o is not None])


def draw_twin(twin, session, result, command, state) -> None:
    """The markers, the commanded and the measured (or, in a replay, the recorded) arm in ``twin``."""
    s, r = session, result
    if r is not None and r.frame is not None:
        twin.set_markers({m.marker_id: np.asarray(m.base_p_centre) for m in r.markers
                          if m.found and m.base_p_centre is not None})
    q_cmd = command.q if command is not None else None
    q_meas = state.q if state is not None else None
    recorded = getattr(s.camera, "recorded_state_at", None)
    if recorded is not None and r is not None and r.frame is not None:
        # a replay: the recorded arm beside the command re-computed from the recorded frames
        replayed = recorded(r.frame.t)
        if replayed is not None:
            q_meas = replayed.q
    twin.set_arm(None if q_cmd is None else np.asarray(s.kinematics.chain_points(q_cmd)),
                 None if q_meas is None else np.asarray(s.kinematics.chain_points(q_meas)))
    if hasattr(s.kinematics, "arm_segments"):  # the delta's three arms
        twin.set_extra_segments(None if q_meas is None else list(s.kinematics.arm_segments(q_meas)))
    twin.set_joint_levels(None if q_meas is None else profile_joint_levels(s.profile, q_meas))
    if recorded is not None:
        twin.set_measured_label("recorded arm")
    elif state is not None:
        twin.set_measured_label("measured" if state.measured else "commanded (no feedback)")


def reach_status(controller, goal, cmd, teleop_line, preview_note: str):
    """(text, ok) for the line under STOP, or None to leave it: stopped, paused, teleop's state,
    target lost, a workspace limit, out of reach, the Lissajous preview's note, the object being
    followed, or on target. ``teleop_line``: teleop's (text, ok) in TELEOP mode."""
    if goal is None:  # no command yet (calibrating from the start): the strip says why
        return teleop_line
    if not controller.armed:  # the last "on target" is stale: nothing is commanded
        return "arm stopped (e-stop) — nothing is commanded", False
    if controller.paused:
        return f"arm holding still — {controller.note or 'paused'}", False
    if teleop_line is not None and not goal.valid:  # calibrating, hand lost, ended
        return teleop_line
    if not goal.valid:
        return goal.note or "target lost — holding", False
    if controller.workspace_note:  # below the desk, in a keep-out box: say which
        return controller.workspace_note, False
    if cmd is not None and not cmd.reachable:
        return f"out of reach by {cmd.reach_error_m * 1e3:.0f} mm — going to the nearest point", False
    if goal.mode is TargetMode.LISSAJOUS and preview_note:
        return preview_note, False
    if goal.mode is TargetMode.OBJECT:  # "following red ball #3"
        return following_text(goal), True
    if teleop_line is not None and goal.mode is TargetMode.TELEOP:  # "teleop: following"
        return teleop_line
    return f"on target{' · ' + goal.note if goal.note else ''}", True
