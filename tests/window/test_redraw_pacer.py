"""The window draws less often while its draws wait for a CPU the loop needs (app.window_draw.
RedrawPacer), and comes back to the display rate when there is room — with injected clocks:
nothing here depends on this machine's speed or load."""
from __future__ import annotations

import pytest

import widgets  # noqa: F401  (sets pyqtgraph's row-major image order)
from app.gui import MIN_REDRAW_GAP_MS, REDRAW_INTERVAL_MS, MainWindow
from app.window_draw import MAX_REDRAW_INTERVAL_MS, RedrawPacer
from tests.window.test_touch_window import make_window


class TickingClocks:
    """A wall clock and a thread-CPU clock that advance on every reading: each draw (two
    readings of each) takes ``wall_s`` of wall time for ``cpu_s`` of CPU time."""

    def __init__(self, wall_s: float, cpu_s: float) -> None:
        self.t = self.c = 0.0
        self.wall_s, self.cpu_s = wall_s, cpu_s

    def wall(self) -> float:
        self.t += self.wall_s
        return self.t

    def cpu(self) -> float:
        self.c += self.cpu_s
        return self.c


def loop_at(fps: float, now: float = 100.0) -> list[float]:
    """The result times of a loop running at ``fps`` over the last 2 s."""
    return [now - k / fps for k in range(int(2 * fps), -1, -1)]


def draw_seconds(pacer: RedrawPacer, clocks: TickingClocks, seconds: float, frame_times) -> None:
    """Draw (nothing) until ``clocks`` read ``seconds`` of wall time, the loop at ``frame_times``."""
    while clocks.t < seconds:
        with pacer.drawing(frame_times):
            pass


def test_starved_draws_with_the_loop_behind_stretch_the_interval_up_to_its_cap():
    clocks = TickingClocks(wall_s=0.05, cpu_s=0.01)  # draws wait 4/5 of their time: a busy core
    pacer = RedrawPacer(REDRAW_INTERVAL_MS, 30.0, clock=clocks.wall, cpu_clock=clocks.cpu)
    draw_seconds(pacer, clocks, 1.5, loop_at(12.0))
    assert pacer.slowdown() == pytest.approx(5.0)
    first = pacer.interval_ms
    assert first > 100.0  # past the 100 ms the starved draws were already apart: only that frees CPU
    draw_seconds(pacer, clocks, 30.0, loop_at(12.0))
    assert pacer.interval_ms == MAX_REDRAW_INTERVAL_MS  # never fewer than 5 draws a second


def test_draws_slowed_as_in_a_pi_5_cores_budget_with_the_loop_behind_stretch_the_interval():
    """Held to 0.54 of a core (a Pi 5 core) the draws took ~1.85x their CPU time in wall time and
    the pacer kept drawing 19 frames a second while the loop fell to 23 fps."""
    clocks = TickingClocks(wall_s=0.0185, cpu_s=0.01)
    pacer = RedrawPacer(REDRAW_INTERVAL_MS, 30.0, clock=clocks.wall, cpu_clock=clocks.cpu)
    draw_seconds(pacer, clocks, 5.0, loop_at(23.0))
    assert pacer.interval_ms > REDRAW_INTERVAL_MS


def test_free_draws_or_a_loop_that_keeps_up_bring_the_display_rate_back():
    clocks = TickingClocks(wall_s=0.05, cpu_s=0.01)
    pacer = RedrawPacer(REDRAW_INTERVAL_MS, 30.0, clock=clocks.wall, cpu_clock=clocks.cpu)
    draw_seconds(pacer, clocks, 10.0, loop_at(12.0))
    assert pacer.interval_ms > 3 * REDRAW_INTERVAL_MS
    draw_seconds(pacer, clocks, 30.0, loop_at(30.0))  # the loop caught up: draws come back gently
    assert pacer.interval_ms == REDRAW_INTERVAL_MS
    draw_seconds(pacer, clocks, 40.0, loop_at(12.0))
    stretched = pacer.interval_ms
    clocks.cpu_s = clocks.wall_s  # the draws run undisturbed (a slow webcam on a free desktop)
    draw_seconds(pacer, clocks, 80.0, loop_at(12.0))
    assert stretched > REDRAW_INTERVAL_MS and pacer.interval_ms == REDRAW_INTERVAL_MS


def test_the_first_frames_of_a_start_up_do_not_stretch_the_interval():
    clocks = TickingClocks(wall_s=0.05, cpu_s=0.01)
    pacer = RedrawPacer(REDRAW_INTERVAL_MS, 30.0, clock=clocks.wall, cpu_clock=clocks.cpu)
    draw_seconds(pacer, clocks, 5.0, loop_at(12.0)[-10:])  # under a second of results: the loop's rate is unknown
    assert pacer.interval_ms == REDRAW_INTERVAL_MS


def test_a_loop_that_keeps_up_is_not_slowed_by_contended_draws():
    clocks = TickingClocks(wall_s=0.05, cpu_s=0.01)
    pacer = RedrawPacer(REDRAW_INTERVAL_MS, 30.0, clock=clocks.wall, cpu_clock=clocks.cpu)
    draw_seconds(pacer, clocks, 20.0, loop_at(29.5))
    assert pacer.interval_ms == REDRAW_INTERVAL_MS


@pytest.fixture
def window(qtbot) -> MainWindow:
    w = make_window(qtbot)  # the static simulated desk at 800x480, workers not started
    yield w
    w.stop()


def test_the_window_arms_its_redraw_timer_with_the_stretched_interval(window):
    clocks = TickingClocks(wall_s=0.05, cpu_s=0.01)
    window.pacer = RedrawPacer(REDRAW_INTERVAL_MS, 30.0, clock=clocks.wall, cpu_clock=clocks.cpu)
    window.start()
    armed = []
    for _ in range(60):  # three wall seconds of starved draws while the loop runs at 12 fps
        window._frame_times[:] = loop_at(12.0)
        window._mark_dirty()
        armed.append(window._redraw_timer.interval())
        window.redraw()  # what the timer would do (it stops itself: nothing pending)
    assert armed[0] <= REDRAW_INTERVAL_MS
    assert window.pacer.interval_ms > 2 * REDRAW_INTERVAL_MS
    assert max(armed) > 2 * REDRAW_INTERVAL_MS - MIN_REDRAW_GAP_MS  # the timer waits the longer interval
