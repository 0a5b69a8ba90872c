"""What the main window draws, apart from the window: what a new worker message changes on
screen (pure: tested without a window), the camera views' images and overlays, the arm twin, and
the line under STOP that says how the target is doing. app/gui.py's redraw calls these.
"""
from __future__ import annotations

import time
from contextlib import contextmanager

import numpy as np

from app.window_texts import following_text
from core.messages import TargetMode
from widgets.arm_twin import profile_joint_levels, same_points
from widgets.camera_view import MarkerOverlay, ObjectOverlay

COMPACT_VIEW_PX = 420  # narrower camera views label markers by id and objects by id and name only
MAX_REDRAW_INTERVAL_MS = 200.0  # the pacer never draws fewer than 5 times a second
PACER_PERIOD_S = 1.0  # the pacer decides once a second, from that second's draws and results
SLOWDOWN_MAX = 1.5  # draws taking over 1.5x their CPU time in wall time: the CPU (or GIL) is contended (a Pi 5 core's budget gives ~1.85)
LOOP_BEHIND = 0.93  # the loop below this share of the camera's frame rate needs the CPU the draws take
LOOP_KEEPS_UP = 0.98  # … at or above it, the draws may come back towards the display rate
PACER_GROW_MAX, PACER_SHRINK = 2.0, 0.75  # interval factors per decision: back off fast, return surely
LOOP_HISTORY_S = 1.5  # the loop's rate counts from this much history (not the start-up's first frames)


class RedrawPacer:
    """How far apart the window's draws start (``interval_ms``): the display rate while the GUI
    thread draws freely, stretched — up to MAX_REDRAW_INTERVAL_MS — while its draws wait for the
    CPU or the GIL (wall time over SLOWDOWN_MAX × their thread CPU time) and the perception loop
    falls behind the camera. The loop keeps its frames and commands; the screen shows fewer.

    On a machine with room (a desktop, a Pi's spare core) draws run at their CPU speed and the
    interval stays at the display rate; in a Pi 4 core's budget the draws and the loop share the
    core and drawing less is what lets the loop keep up. ``clock``/``cpu_clock``: wall and this
    thread's CPU seconds (injected by tests). GUI thread only.
    """

    def __init__(self, base_ms: float, camera_fps: float = 30.0, max_ms: float = MAX_REDRAW_INTERVAL_MS,
                 clock=time.perf_counter, cpu_clock=time.thread_time) -> None:
        self.base_ms, self.max_ms, self.camera_fps = float(base_ms), float(max_ms), float(camera_fps)
        self.interval_ms = self.base_ms
        self.draw_started = 0.0  # clock() when the last draw began
        self._clock, self._cpu_clock = clock, cpu_clock
        self._period_start = clock()
        self._wall_s = self._cpu_s = 0.0  # of this period's draws
        self._draws = 0  # in this period

    @contextmanager
    def drawing(self, frame_times=()):
        """Time one draw; ``frame_times``: the loop's recent result times (seconds, ascending)."""
        t0 = self.draw_started = self._clock()
        c0 = self._cpu_clock()
        try:
            yield
        finally:
            now = self._clock()
            self._wall_s += now - t0
            self._cpu_s += self._cpu_clock() - c0
            self._draws += 1
            if now - self._period_start >= PACER_PERIOD_S:
                t = list(frame_times)
                known = len(t) > 2 and t[-1] - t[0] >= LOOP_HISTORY_S
                self.decide((len(t) - 1) / (t[-1] - t[0]) if known else None,
                            (now - self._period_start) * 1e3 / self._draws)
                self._period_start, self._wall_s, self._cpu_s, self._draws = now, 0.0, 0.0, 0

    def next_draw_in_ms(self, min_gap_ms: float) -> int:
        """When the next draw may start: the interval after the last draw began, but never
        sooner than ``min_gap_ms`` from now (the event loop's share between slow draws)."""
        since_ms = (self._clock() - self.draw_started) * 1e3
        return int(max(min_gap_ms, self.interval_ms - since_ms))

    def slowdown(self) -> float:
        """This period's draws' wall time over their CPU time (1: they ran undisturbed)."""
        return self._wall_s / self._cpu_s if self._cpu_s > 0 else 1.0

    def decide(self, loop_fps, spacing_ms: float = 0.0) -> float:
        """The new interval from this period's draws and the loop's rate (None: unknown).

        Starved, it grows by the draws' slowdown over SLOWDOWN_MAX (at most PACER_GROW_MAX a
        period) from the spacing the draws actually had (``spacing_ms``: a CPU-bound window
        already draws slower than its interval, and only a longer interval than that frees CPU).
        """
        slowdown = self.slowdown()
        contended = slowdown > SLOWDOWN_MAX
        if contended and loop_fps is not None and loop_fps < LOOP_BEHIND * self.camera_fps:
            grow = min(PACER_GROW_MAX, slowdown / SLOWDOWN_MAX)
            self.interval_ms = min(self.max_ms, max(self.interval_ms, spacing_ms) * grow)
        elif not contended or loop_fps is None or loop_fps >= LOOP_KEEPS_UP * self.camera_fps:
            self.interval_ms = max(self.base_ms, self.interval_ms * PACER_SHRINK)
        return self.interval_ms


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
        # objects: id, name and score; position and speed too in a wide view, or for the
        # object being followed; the labels of both kinds laid out once
        view.set_overlays(overlays, [o for o in (ObjectOverlay.from_observation(obs, side, not compact or
                                                                                obs.object_id == followed)
                                                 for obs in r.objects) if o is not None])


def draw_twin(twin, session, result, command, state) -> None:
    """The markers, the commanded and the measured (or, in a replay, the recorded) arm in ``twin``."""
    with twin.batch():  # the side view projects the new markers for the new arm plane once
        _draw_twin(twin, session, result, command, state)


def _draw_twin(twin, session, result, command, state) -> None:
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


def note_frame(times: list, now: float, keep_s: float = 2.0) -> None:
    """Add a camera frame's arrival time (``now``) to ``times``; forget those older than ``keep_s``."""
    times.append(now)
    while times and now - times[0] > keep_s:
        times.pop(0)


def frame_rate(times) -> float:
    """Frames per second over ``times`` (0 with fewer than three)."""
    return (len(times) - 1) / (times[-1] - times[0]) if len(times) > 2 else 0.0
