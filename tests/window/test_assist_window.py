"""The assistive view (issue 12, part 4): the three input modes drive the approach on the simulated
panel (pytest-qt, offscreen). The worker runs the AssistLoop on the simulated clock (frames as fast
as the CPU goes); the scanning runs on a fake clock the test moves, and ``scan_tick`` is called
after each move (the window's timer does the same with the real clock) — except in one test, where
the window's own timer and the real clock move the highlight. Tests wait on the window's
signals and GUI-thread state, never sleep; every window's worker is stopped and joined.
"""
import sys

import pytest
from PySide6 import QtCore

from app.assist_window import (AssistSettings, AssistWindow, SwitchSettingsDialog, build_sim_loop, grown_boxes,
                               load_assist_settings)
from widgets._style import TOUCH_PX

TIMEOUT_MS = 30_000  # one press is ~6.5 s of simulated time, ~2–6 s of CPU on a shared core
SPACE, ENTER = QtCore.Qt.Key.Key_Space, QtCore.Qt.Key.Key_Return
LEFT = QtCore.Qt.MouseButton.LeftButton
_SIM = {}


def sim_loop():
    """The simulated desk's loop, built once per test session (0.5 s) and reset for each window."""
    if not _SIM:
        _SIM["loop"], _SIM["q"] = build_sim_loop(0)
    _SIM["loop"].reset(_SIM["q"], 0.0)
    return _SIM["loop"], _SIM["q"]


class FakeClock:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


@pytest.fixture
def make_window(qtbot):
    windows = []

    def make(mode="touch", **settings):
        clock = FakeClock()
        w = AssistWindow(sim_loop, worker_clock="sim", clock=clock)
        w.set_settings(AssistSettings(mode=mode, **settings))
        w._scan_timer.setInterval(3_600_000)  # the test ticks the scan itself (on the fake clock)
        qtbot.addWidget(w)
        w.resize(800, 480)
        w.show()
        qtbot.waitExposed(w)
        texts = []
        w.sigStateText.connect(texts.append)
        w.start()
        qtbot.waitUntil(lambda: w.choosing, timeout=TIMEOUT_MS)
        windows.append(w)
        return w, clock, texts

    yield make
    for w in windows:
        w.stop()
        assert w.worker.isFinished() and not w.worker.isRunning()
        assert w.worker.isFinished() and not w.worker.isRunning()


def wait_for_press(qtbot, w, texts, number):
    """The state line goes aligning → approaching → pressing → done, and the FSM logged the same."""
    qtbot.waitUntil(lambda: f"done: {number} pressed" in texts, timeout=TIMEOUT_MS)
    i = texts.index(f"aligning with {number}")
    assert texts[i:i + 4] == [f"aligning with {number}", f"approaching {number}", f"pressing {number}",
                              f"done: {number} pressed"]
    log = w.worker.loop.fsm.event_log()
    assert [e["to"] for e in log] == ["ALIGN", "APPROACH", "ACT", "IDLE"]
    assert log[0]["reason"] == f"target chosen: box {number}" and log[-1]["reason"].startswith("pressed")
    assert w.worker.selections == [number - 1]
    calls = w.worker.loop.camera.scene.calls  # the simulated panel: the button really went down
    assert calls and calls[-1][1] == number
    qtbot.waitUntil(lambda: w.choosing, timeout=TIMEOUT_MS)  # back at the ready pose, a new choice


def click_image_point(qtbot, w, point):
    qtbot.mouseClick(w.view, LEFT, pos=w.view.to_widget(point).toPoint())


def test_touch_a_tap_outside_every_box_is_ignored_and_a_tap_on_7_presses_it(make_window, qtbot):
    w, _, texts = make_window("touch")
    assert len(w.boxes) == 9
    click_image_point(qtbot, w, (20.0, 460.0))  # the desk, far from the panel
    assert w.ignored_taps == 1 and w.view.ack_visible
    assert w.worker.selections == [] and w.choosing
    qtbot.waitUntil(lambda: not w.view.ack_visible, timeout=5_000)  # the acknowledgement is brief
    x, y, bw, bh = w.hit_boxes[6]
    click_image_point(qtbot, w, (x + bw / 2, y + bh / 2))
    wait_for_press(qtbot, w, texts, 7)


def test_two_switches_next_moves_the_highlight_and_confirm_presses(make_window, qtbot):
    w, _, texts = make_window("scan2")
    assert w.view.highlight == 0
    seen = []
    for _ in range(6):
        qtbot.keyClick(w, SPACE)
        seen.append(w.view.highlight)
    assert seen == [1, 2, 3, 4, 5, 6] and w.worker.selections == []
    qtbot.keyClick(w, ENTER)
    wait_for_press(qtbot, w, texts, 7)


def test_one_switch_timed_scanning_and_one_press(make_window, qtbot):
    w, clock, texts = make_window("scan1", scan_period_s=1.0)
    assert w.view.highlight == 0
    seen = []
    for _ in range(6):
        clock.t += 1.0
        w.scan_tick()
        seen.append(w.view.highlight)
    assert seen == [1, 2, 3, 4, 5, 6] and w.worker.selections == []
    clock.t += 0.3  # the user reacts …
    qtbot.keyPress(w, SPACE)
    clock.t += 0.15  # … and presses briefly
    qtbot.keyRelease(w, SPACE)
    wait_for_press(qtbot, w, texts, 7)


def test_one_switch_on_the_window_s_own_timer_and_the_real_clock(qtbot):
    """No fake clock: the window's 40 ms timer moves the highlight every T = 1 s of wall time; the
    test waits for box 7 to light up (an event), then presses the one switch."""
    w = AssistWindow(sim_loop, worker_clock="sim")  # time.monotonic, the real scan timer
    w.set_settings(AssistSettings(mode="scan1", scan_period_s=1.0))
    qtbot.addWidget(w)
    w.resize(800, 480)
    w.show()
    texts, seen = [], []
    w.sigStateText.connect(texts.append)
    set_highlight = w.view.set_highlight
    w.view.set_highlight = lambda index: (seen.append(index), set_highlight(index))[1]
    try:
        w.start()
        qtbot.waitUntil(lambda: w.choosing, timeout=TIMEOUT_MS)
        qtbot.waitUntil(lambda: w.view.highlight == 6, timeout=TIMEOUT_MS)
        qtbot.keyPress(w, SPACE)
        qtbot.keyRelease(w, SPACE)
        wait_for_press(qtbot, w, texts, 7)
        moves = [i for i in seen if i is not None]
        assert moves[moves.index(0):moves.index(6) + 1] == [0, 1, 2, 3, 4, 5, 6]  # one box per step, none skipped
    finally:
        w.stop()
    assert w.worker.isFinished()


def test_one_switch_long_press_stops_the_arm_and_a_second_hold_re_arms(make_window, qtbot):
    w, clock, texts = make_window("scan1", scan_period_s=1.0)
    for _ in range(2):
        clock.t += 1.0
        w.scan_tick()
    qtbot.keyPress(w, SPACE)
    clock.t += 0.1
    qtbot.keyRelease(w, SPACE)  # box 3 chosen: the arm starts
    assert w.state_text == "aligning with 3"
    qtbot.keyPress(w, SPACE)  # at once: the long press
    clock.t += 1.0
    w.scan_tick()
    assert not w.engaged  # not long enough yet
    clock.t += 0.6
    w.scan_tick()
    assert w.engaged and w.stop_button.engaged and w.state_text == "stopped"
    qtbot.keyRelease(w, SPACE)
    loop = w.worker.loop
    qtbot.waitUntil(lambda: w.worker.engaged and loop.state == "IDLE", timeout=TIMEOUT_MS)
    log = loop.fsm.event_log()
    assert log[0]["to"] == "ALIGN" and log[-1]["to"] == "IDLE" and log[-1]["reason"] == "stopped by the user"
    assert "ACT" not in [e["to"] for e in log]  # stopped before any press
    assert not w.choosing  # nothing can be chosen while stopped
    qtbot.keyClick(w, SPACE)  # a short press while stopped does nothing
    assert w.engaged
    qtbot.keyPress(w, SPACE)  # hold again: re-arm
    clock.t += 1.6
    w.scan_tick()
    qtbot.keyRelease(w, SPACE)
    assert not w.engaged and not w.stop_button.engaged
    qtbot.waitUntil(lambda: w.choosing and w.state_text == "choose a button", timeout=TIMEOUT_MS)


def test_a_long_press_with_nothing_moving_is_a_stop_too_and_esc_is_stop(make_window, qtbot):
    w, clock, _ = make_window("scan2")
    qtbot.keyPress(w, ENTER)
    clock.t += 1.6
    w.scan_tick()
    qtbot.keyRelease(w, ENTER)
    assert w.engaged and w.worker.selections == []  # the long confirm did not also confirm
    w.rearm()
    qtbot.waitUntil(lambda: w.choosing, timeout=TIMEOUT_MS)
    qtbot.keyClick(w, QtCore.Qt.Key.Key_Escape)
    assert w.engaged and w.rearm_button.isVisible()


@pytest.mark.parametrize("mode", ["touch", "scan2", "scan1"])
def test_the_window_fits_800x480_and_stop_is_always_reachable(make_window, qtbot, mode):
    w, _, _ = make_window(mode)
    hint = w.minimumSizeHint()
    assert hint.width() <= 800 and hint.height() <= 480
    assert w.width() == 800 and w.height() == 480
    for engaged in (False, True):
        if engaged:
            qtbot.mouseClick(w.stop_button, LEFT)
            assert w.engaged and w.rearm_button.isVisible()
            assert w.rearm_button.height() >= TOUCH_PX
        b = w.stop_button
        assert b.isVisible() and b.height() >= TOUCH_PX and b.width() >= TOUCH_PX
        top_left = b.mapTo(w, QtCore.QPoint(0, 0))
        assert w.rect().contains(QtCore.QRect(top_left, b.size()))
    for box in range(len(w.hit_boxes)):  # the boxes are drawn at least a fingertip wide
        r = w.view.box_rect(box)
        assert r.width() >= 30 and r.height() >= 30


def test_the_scan_period_and_mode_are_remembered(make_window, qtbot):
    w, _, _ = make_window("scan1")
    w.set_scan_period(2.5)
    settings, warnings = load_assist_settings()
    assert settings.scan_period_s == 2.5 and settings.mode == "scan1" and warnings == []
    w.set_scan_period(9.0)  # clamped to the 0.5…5 s range
    assert load_assist_settings()[0].scan_period_s == 5.0


def test_the_switch_mapping_is_editable_and_checked(make_window, qtbot):
    w, _, texts = make_window("scan2")
    dialog = SwitchSettingsDialog(w.settings, w)
    qtbot.addWidget(dialog)
    dialog.edits["next_switch"].setText("key:Return")  # the same as confirm: refused
    dialog._accept()
    assert "both 'next' and 'confirm'" in dialog.error.text() and dialog.result() == 0
    dialog.edits["next_switch"].setText("key:N, mouse:right")
    dialog._accept()
    w.set_settings(dialog.settings)
    assert load_assist_settings()[0].next_switch == ("key:N", "mouse:right")
    qtbot.keyClick(w, QtCore.Qt.Key.Key_N)
    assert w.view.highlight == 1
    qtbot.keyClick(w, SPACE)  # no longer a switch
    assert w.view.highlight == 1
    qtbot.mouseClick(w.view, QtCore.Qt.MouseButton.RightButton)  # a mouse button as "next"
    assert w.view.highlight == 2


def test_grown_boxes_keep_their_centres_and_stay_apart():
    boxes = [(0, 0, 20, 20), (40, 0, 20, 20), (200, 200, 10, 10)]
    grown = grown_boxes(boxes)
    for (x, y, w, h), (gx, gy, gw, gh) in zip(boxes, grown):
        assert gx + gw / 2 == pytest.approx(x + w / 2) and gw >= w
    assert grown[0][0] + grown[0][2] <= grown[1][0]  # no overlap between neighbours


def test_cli_assist_refuses_another_robot_or_scene(capsys):
    from app.cli import main

    assert main(["--assist", "--scenario", "objects"]) == 2
    assert "--assist runs the assistive_5dof arm" in capsys.readouterr().err


# -- gamepad and GPIO switches (core.devices.switches, fake evdev / gpiozero modules) ----------------

def test_a_gamepad_confirm_selects_the_highlighted_box_in_scan2(make_window, qtbot, monkeypatch):
    from tests.devices.test_switch_sources import BTN_SOUTH, FakeEvent, fake_evdev

    evdev = fake_evdev()
    monkeypatch.setitem(sys.modules, "evdev", evdev)
    w, _, texts = make_window("scan2", confirm_switch=("key:Return", "gamepad:BTN_SOUTH"))
    source = w.switch_sources["gamepad:BTN_SOUTH"]
    assert source.wait_for(lambda s: s.connected)
    qtbot.keyClick(w, SPACE)
    qtbot.keyClick(w, SPACE)
    assert w.view.highlight == 2 and w.worker.selections == []
    evdev.events.put(FakeEvent(BTN_SOUTH, 1))
    evdev.events.put(FakeEvent(BTN_SOUTH, 0))
    qtbot.waitUntil(lambda: w.worker.selections == [2], timeout=TIMEOUT_MS)
    assert "aligning with 3" in texts


def test_a_gpio_single_switch_confirms_in_scan1(make_window, qtbot, monkeypatch):
    from tests.devices.test_switch_sources import FakeButton, fake_gpiozero

    monkeypatch.setitem(sys.modules, "gpiozero", fake_gpiozero())
    w, clock, texts = make_window("scan1", scan_period_s=1.0, single_switch=("gpio:17",))
    assert w.switch_sources["gpio:17"].wait_for(lambda s: s.connected)
    for _ in range(3):
        clock.t += 1.0
        w.scan_tick()
    assert w.view.highlight == 3
    button = FakeButton.instances[0]
    button.when_pressed()  # from gpiozero's thread in real life: queued to the GUI thread
    qtbot.waitUntil(lambda: w.switches.held is not None, timeout=TIMEOUT_MS)
    clock.t += 0.15
    button.when_released()
    qtbot.waitUntil(lambda: w.worker.selections == [3], timeout=TIMEOUT_MS)
    assert "aligning with 4" in texts


def test_a_missing_switch_library_is_named_in_the_hint(make_window, qtbot, monkeypatch):
    monkeypatch.setitem(sys.modules, "gpiozero", None)
    w, _, _ = make_window("scan1", single_switch=("key:Space", "gpio:17"))
    assert w.switch_sources["gpio:17"].wait_for(lambda s: "pip install gpiozero" in s.status_message)
    w.scan_tick()
    assert "pip install gpiozero" in w.hint_label.text()


def test_switch_specs_from_the_cli_join_the_settings():
    from app.assist_window import device_switch_names, with_switches
    from core.devices.switches import parse_switch_spec

    s = with_switches(AssistSettings(), [parse_switch_spec("gamepad:BTN_SOUTH=confirm"),
                                         parse_switch_spec("gpio:17=single")])
    assert "gamepad:BTN_SOUTH" in s.confirm_switch and "gpio:17" in s.single_switch
    assert device_switch_names(s) == ["gamepad:BTN_SOUTH", "gpio:17"]


def test_the_view_stays_live_while_the_user_chooses(qtbot):
    """Paced by the wall clock (as the app runs), the hand camera's image keeps coming while
    nothing moves; the offered boxes stay as they were and nothing is selected."""
    w = AssistWindow(sim_loop, worker_clock="wall")
    w.set_settings(AssistSettings(mode="touch"))
    qtbot.addWidget(w)
    frames = []
    w.worker.sigFrame.connect(lambda: frames.append(1))
    try:
        w.start()
        qtbot.waitUntil(lambda: w.choosing, timeout=TIMEOUT_MS)
        boxes, t0, n0 = list(w.boxes), w.worker.loop.t, len(frames)
        qtbot.waitUntil(lambda: len(frames) >= n0 + 5, timeout=TIMEOUT_MS)
        assert w.worker.loop.t > t0 and w.boxes == boxes and w.choosing and w.worker.selections == []
    finally:
        w.stop()
    assert w.worker.isFinished()


def test_the_learned_desk_model_finds_the_buttons_and_7_is_pressed(qtbot):
    """``deskarm --assist --detector desk``: the shipped model's button boxes are offered and followed."""
    w = AssistWindow(lambda: build_sim_loop(0, detector="desk"), worker_clock="sim")
    w.set_settings(AssistSettings(mode="touch"))
    qtbot.addWidget(w)
    texts = []
    w.sigStateText.connect(texts.append)
    try:
        w.start()
        qtbot.waitUntil(lambda: w.choosing, timeout=TIMEOUT_MS)
        assert len(w.boxes) == 9
        x, y, bw, bh = w.hit_boxes[6]
        click_image_point(qtbot, w, (x + bw / 2, y + bh / 2))
        wait_for_press(qtbot, w, texts, 7)
    finally:
        w.stop()
    assert w.worker.isFinished()


# --- issue 22: STOP in the assistive view keeps one place, RE-ARM stays away, dialogs never cover it
def _rect_in(w, widget) -> QtCore.QRect:
    return QtCore.QRect(widget.mapTo(w, QtCore.QPoint(0, 0)), widget.size())


def _press_at(w, point):
    from PySide6.QtTest import QTest

    QTest.mousePress(w.windowHandle(), LEFT, QtCore.Qt.KeyboardModifier.NoModifier, point)
    QTest.mouseRelease(w.windowHandle(), LEFT, QtCore.Qt.KeyboardModifier.NoModifier, point)


@pytest.mark.parametrize("mode", ["touch", "scan2", "scan1"])
def test_stop_keeps_its_place_and_rearm_appears_far_from_it(make_window, qtbot, mode):
    w, _, texts = make_window(mode)
    stop = _rect_in(w, w.stop_button)
    _press_at(w, stop.center())
    qtbot.waitUntil(lambda: w.engaged)
    QtCore.QCoreApplication.processEvents()
    assert _rect_in(w, w.stop_button) == stop
    rearm = _rect_in(w, w.rearm_button)
    assert w.rearm_button.isVisible() and not rearm.intersects(stop.adjusted(-40, -40, 40, 40)), (rearm, stop)
    # pressing STOP's spot again, and holding it, reaches STOP, never RE-ARM
    from PySide6.QtTest import QTest

    QTest.mousePress(w.windowHandle(), LEFT, QtCore.Qt.KeyboardModifier.NoModifier, stop.center())
    assert not w.rearm_button.isDown() and not w.rearm_button.holding
    QTest.mouseRelease(w.windowHandle(), LEFT, QtCore.Qt.KeyboardModifier.NoModifier, stop.center())
    assert w.engaged


def test_the_switches_dialog_carries_stop_leaves_the_window_stop_uncovered_and_live(make_window, qtbot):
    from PySide6 import QtWidgets
    from PySide6.QtTest import QTest

    w, _, _ = make_window("scan2")
    qtbot.mouseClick(w.settings_button, LEFT)
    dialog = w.settings_dialog
    qtbot.waitUntil(lambda: dialog is not None and dialog.isVisible())
    assert QtWidgets.QApplication.activeModalWidget() is None  # not modal: the window's STOP works
    stop_global = QtCore.QRect(w.stop_button.mapToGlobal(QtCore.QPoint(0, 0)), w.stop_button.size())
    assert not dialog.frameGeometry().intersects(stop_global), (dialog.frameGeometry(), stop_global)
    _press_at(w, _rect_in(w, w.stop_button).center())
    qtbot.waitUntil(lambda: w.engaged)
    w.rearm()
    assert not w.engaged
    qtbot.mouseClick(dialog.stop_button, LEFT)  # its own STOP
    assert w.engaged
    w.rearm()
    QTest.keyClick(dialog.edits["next_switch"], QtCore.Qt.Key.Key_Escape)  # Esc = STOP, not Cancel
    assert w.engaged and dialog.isVisible()
    dialog.edits["next_switch"].setText("key:N, mouse:right")
    ok = dialog.findChild(QtWidgets.QDialogButtonBox).button(QtWidgets.QDialogButtonBox.StandardButton.Ok)
    qtbot.mouseClick(ok, LEFT)
    qtbot.waitUntil(lambda: w.settings.next_switch == ("key:N", "mouse:right"))
