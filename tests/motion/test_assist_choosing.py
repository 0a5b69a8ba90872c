"""What the assistive view shows, without Qt: the boxes drawn bigger but never into a neighbour
(core.motion.scanning.grown_boxes) and the state line after each loop status
(core.motion.assist_loop.state_line)."""
import pytest

from core.motion.assist_loop import LoopStatus, state_line
from core.motion.scanning import BOX_GROWTH_MAX, grown_boxes


def test_a_lone_box_grows_by_the_maximum_about_its_centre():
    (x, y, w, h), = grown_boxes([(100.0, 50.0, 20.0, 10.0)])
    assert (x + w / 2, y + h / 2) == pytest.approx((110.0, 55.0))
    assert (w, h) == pytest.approx((20.0 * BOX_GROWTH_MAX, 10.0 * BOX_GROWTH_MAX))


def test_close_neighbours_do_not_grow_into_each_other_and_never_shrink():
    grown = grown_boxes([(0, 0, 20, 20), (22, 0, 20, 20)])
    assert grown[0][0] + grown[0][2] <= grown[1][0] + 1e-9
    assert all(w >= 20 for _, _, w, _ in grown)
    assert grown_boxes([]) == []


def status(state, index=None, outcome=None):
    return LoopStatus(state, 0.0, index, None, outcome)


def test_the_state_line_follows_a_press_from_aligning_to_done():
    line = "choose a button"
    seen = []
    previous = None
    for s in (status("ALIGN", 6), status("APPROACH", 6), status("ACT", 6),
              status("RETURN", 6, "pressed and back at the start"), status("IDLE", 6, "pressed and back")):
        line = state_line(s, previous, False, line)
        previous = s
        seen.append(line)
    assert seen == ["aligning with 7", "approaching 7", "pressing 7", "done: 7 pressed", "done: 7 pressed"]


def test_a_lost_button_says_why_and_a_return_without_a_press_is_going_back():
    assert state_line(status("IDLE", 2, "lost: no detection for 1 s"), status("APPROACH", 2), False,
                      "approaching 3") == "could not reach 3: lost"
    assert state_line(status("RETURN"), status("IDLE"), False, "stopped") == "going back"
    assert state_line(status("IDLE"), None, False, "choose a button") == "choose a button"


def test_while_stopped_the_stop_wins_and_its_reason_is_kept():
    assert state_line(status("ALIGN", 0), None, True, "aligning with 1") == "stopped"
    assert state_line(status("IDLE"), status("ALIGN", 0), True, "stopped: arm not connected") == \
        "stopped: arm not connected"
