"""The target mode at start (issue 22 item 14): a scenario or a replay chooses its own mode; the
mode saved by the last run comes back only on a plain start, and one that cannot run there says
why once, in plain words (replays: tests/record/test_replay_end_window.py)."""
from __future__ import annotations

from pathlib import Path

import pytest
from PySide6 import QtCore

from app.gui import MainWindow
from core.messages import TargetMode
from core.motion.teleop import FOLLOWING
from core.preferences import Preferences, load_preferences, remembered_mode_refusal, save_preferences
from core.session import DeskSession, SessionOptions

DATA = Path(__file__).resolve().parents[1] / "data" / "stereo_7x5_320x240"  # a real webcam pair's pictures
LEFT = QtCore.Qt.MouseButton.LeftButton


@pytest.fixture(autouse=True)
def home(tmp_path, monkeypatch):
    monkeypatch.setenv("DESKARM_HOME", str(tmp_path / "home"))
    return tmp_path / "home"


@pytest.fixture
def make_window(qtbot):
    """Windows as tests/window/test_preferences_window.py makes them; stopped and closed after."""
    made = []

    def make(scenario="static", camera="sim"):
        session = DeskSession.create(SessionOptions(camera=camera, scenario=scenario))
        w = MainWindow(session)
        qtbot.addWidget(w)
        w.resize(800, 480)
        w.show()
        made.append(w)
        return w

    yield make
    for w in made:
        w.stop()
        w.session.close()


def banner(w) -> str:
    return w.banner.text() if w.banner.isVisible() else ""


# ------------------------------------------------------------------------------------- the rule
def test_only_a_plain_start_gets_the_remembered_mode_back():
    plain = dict(scenario="static", camera_kind="sim")
    assert remembered_mode_refusal(TargetMode.LISSAJOUS, **plain) is None
    assert remembered_mode_refusal(TargetMode.OBJECT, **plain) is None  # its own hint says: switch a detector on
    for chosen in (dict(scenario="cups"), dict(scenario="teleop"), dict(scenario="panel"),
                   dict(camera_kind="replay"), dict(teleop_source="marker:23"), dict(follow_object="red")):
        for mode in TargetMode:
            assert remembered_mode_refusal(mode, **{**plain, **chosen}) == "", (mode, chosen)
    for mode, words in ((TargetMode.TELEOP, "needs a hand in the camera views"), (TargetMode.CUPS, "ball and cups")):
        why = remembered_mode_refusal(mode, **plain)
        assert words in why and "--scenario" in why and "0.0" not in why
        assert remembered_mode_refusal(mode, scenario="static", camera_kind="webcam") is None  # a real desk may


# ------------------------------------------------------------------------------ in the window
@pytest.mark.parametrize("saved, scenario, own", [
    (TargetMode.CUPS, "teleop", TargetMode.TELEOP),
    (TargetMode.TELEOP, "panel", TargetMode.FOLLOW),
    (TargetMode.TELEOP, "cups", TargetMode.CUPS),
    (TargetMode.LISSAJOUS, "wander", TargetMode.FOLLOW),
])
def test_a_scenario_starts_in_its_own_mode_whatever_mode_was_saved(make_window, saved, scenario, own):
    save_preferences(Preferences(target_mode=saved))
    w = make_window(scenario)
    assert w.session.targeter.mode is own and w.target_panel.mode == own.value
    assert (w.session.targeter.teleop is not None) == (own is TargetMode.TELEOP)
    assert w.preferences.messages == []
    if own is not TargetMode.CUPS:  # no cups banner in another scenario
        assert "cups" not in banner(w).lower() and "cups" not in w._note.lower()
    assert "too thin" not in banner(w) and "too thin" not in w.target_status.text()


def test_the_teleop_scenario_after_a_cups_run_shows_no_cups_banner_and_calibrates(qtbot, make_window):
    save_preferences(Preferences(target_mode=TargetMode.CUPS))
    w = make_window("teleop")
    seen = set()
    timer = QtCore.QTimer()
    timer.timeout.connect(lambda: seen.add(banner(w)))
    timer.start(100)
    w.start()
    qtbot.waitUntil(lambda: w.session.targeter.teleop_status().state == FOLLOWING, timeout=30_000)
    timer.stop()
    assert w.target_panel.mode == "teleop"
    assert not [text for text in seen if "cups" in text.lower()], seen


@pytest.mark.parametrize("saved, words", [(TargetMode.TELEOP, "Teleop, your last mode, needs a hand"),
                                          (TargetMode.CUPS, "the cups game, your last mode, needs a ball")])
def test_a_saved_mode_the_simulated_desk_cannot_run_says_why_once_and_starts_in_follow(qtbot, make_window,
                                                                                      saved, words):
    save_preferences(Preferences(target_mode=saved))
    real = make_window(camera=f"folder:{DATA}")  # real cameras: the hand or the ball may be on the desk
    assert real.session.targeter.mode is saved and real.target_panel.mode == saved.value
    assert real.preferences.messages == []
    real.stop()
    w = make_window()
    assert w.session.targeter.mode is TargetMode.FOLLOW and w.target_panel.mode == "follow"
    assert w.session.targeter.teleop is None  # no hand source that would wait for a hand forever
    assert len(w.preferences.messages) == 1 and w.preferences.messages[0].startswith("Started in Follow marker: ")
    assert words in banner(w) and w.banner.level == "info"
    w.start()
    qtbot.waitUntil(lambda: w._result is not None, timeout=10_000)
    assert "too thin" not in w.target_status.text() and "0.0 ×" not in w.target_status.text()
    w.close()  # saved as it closes: Follow marker, the mode in use
    assert load_preferences()[0].target_mode is TargetMode.FOLLOW
    again = make_window()  # once: the next start has nothing to say
    assert again.preferences.messages == [] and words not in banner(again)


def test_a_scenario_run_keeps_the_saved_mode_unless_the_user_picks_another(qtbot, make_window):
    save_preferences(Preferences(target_mode=TargetMode.LISSAJOUS))
    w = make_window("cups")
    assert w.session.targeter.mode is TargetMode.CUPS
    w.preferences.save()
    assert load_preferences()[0].target_mode is TargetMode.LISSAJOUS  # a cups run is no vote for cups
    with qtbot.waitSignal(w.target_panel.sigModeChanged, timeout=5000):
        qtbot.mouseClick(w.target_panel.mode_buttons["follow"], LEFT)
    w.preferences.save()
    assert load_preferences()[0].target_mode is TargetMode.FOLLOW  # the user's own choice is


def test_the_scene_starts_over_when_the_window_is_up_so_a_slow_start_misses_no_calibration_corner():
    """The teleop scenario's first corner is held from 1.5 s to 3.5 s after the camera opened: a
    window that took 4 s to build would have missed it and waited for it forever."""
    from app.gui import start_scene_now
    from core.sim.scenarios import TeleopScenario

    session = DeskSession.create(SessionOptions(camera="sim", scenario="teleop", simulated_clock=True))
    try:
        session.clock.advance(4.0)  # building the window took this long
        start_scene_now(session)
        band = session.camera.read().truth.by_id()[23].base_p_centre
        assert band == pytest.approx(TeleopScenario.ENTRY, abs=0.002)  # the scene's start, not 4 s in
    finally:
        session.close()


def test_choosing_teleop_on_a_simulated_scene_without_a_hand_says_why_it_waits(qtbot):
    """Chosen by hand on the plain simulated desk, Teleop waited at "calibrating" without a word:
    one plain line now says there is no hand and what to do; the teleop scenario gets none."""
    from app.gui import MainWindow, teleop_hint
    from core.session import DeskSession, SessionOptions

    for scenario, expect in (("static", True), ("teleop", False)):
        w = MainWindow(DeskSession.create(SessionOptions(camera="sim", scenario=scenario)))
        qtbot.addWidget(w)
        w.resize(800, 480)
        w.show()
        try:
            qtbot.mouseClick(w.target_panel.mode_buttons["teleop"], QtCore.Qt.MouseButton.LeftButton)
            said = "no hand in view" in w.banner.text()
            assert said is expect, (scenario, w.banner.text())
            assert bool(teleop_hint(w.session, "marker:23")) is expect and teleop_hint(w.session, "keyboard") == ""
        finally:
            w.stop()
