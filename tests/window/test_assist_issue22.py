"""Issue 22, the assistive view (pytest-qt, offscreen): it fills its screen, a carer can quit it
(Ctrl+Q, the ☰ menu) where a switch cannot, a box's number badge is part of the box, a held key
switch stays held through X11 auto-repeat, the two-switch hint says which keys and buttons in
plain words, and ``deskarm --assist`` takes ``--screenshot`` and says when there is no display.

On a real X server (Xvfb 800x480, with and without openbox; opt in with ``DESKARM_TEST_XVFB=1``
after ``apt-get install -y xvfb xdotool openbox``) ``deskarm --assist`` runs in a child process and
``xdotool`` holds a real key with the server's auto-repeat: the cases offscreen cannot show (with
no window manager the full-screen state is ignored; X11 delivers the repeat pairs unflagged).

Key and mouse input are real events (QTest clicks at coordinates, QKeyEvents sent to the window
with the timestamps and auto-repeat flags X11 gives). The scanning runs on a fake clock the test
moves (``scan_tick`` after each move, as the window's timer does); the window's own single-shot
timer ends a pending key release, waited for with ``qtbot.waitUntil``. Every worker is joined.
"""
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from PySide6 import QtCore, QtGui, QtWidgets

from app.assist_window import AssistSettings, AssistWindow
from xserver import WAIT_S, why_no_xvfb, x_server

from tests.window.test_assist_window import TIMEOUT_MS, make_window, wait_for_press  # noqa: F401 (make_window: the fixture)
from widgets._style import TOUCH_PX

REPO = Path(__file__).resolve().parents[2]
LEFT, RIGHT = QtCore.Qt.MouseButton.LeftButton, QtCore.Qt.MouseButton.RightButton
SPACE = QtCore.Qt.Key.Key_Space
SUBPROCESS_TIMEOUT_S = 120


def rect_in(w, widget) -> QtCore.QRect:
    """``widget``'s rectangle in window coordinates."""
    return QtCore.QRect(widget.mapTo(w, QtCore.QPoint(0, 0)), widget.size())


# -- 7. it fills its screen ----------------------------------------------------------------------

def test_deskarm_assist_fills_the_available_geometry_of_its_screen(qtbot, monkeypatch):
    """run_assist_window as ``deskarm --assist`` calls it, on the offscreen screen (800x800: bigger
    than the 800x480 panel, like X11 without a window manager nothing acts on the window state)."""
    import app.startup as startup
    from app.assist_window import run_assist_window
    from app.startup import GuiThreadGarbage

    app = QtWidgets.QApplication.instance()
    # return at once, the window kept (run_until_quit would run the loop, then delete it): the test drives
    monkeypatch.setattr(startup, "run_until_quit", lambda app, window: 0)
    before = set(app.topLevelWidgets())
    run_assist_window((800, 480))
    windows = [w for w in app.topLevelWidgets() if isinstance(w, AssistWindow) and w not in before]
    assert len(windows) == 1
    w = windows[0]
    qtbot.addWidget(w)
    try:
        qtbot.waitExposed(w)
        assert w.geometry() == w.screen().availableGeometry()
    finally:
        w.stop()
        for garbage in app.findChildren(GuiThreadGarbage):
            garbage.stop()
            garbage.setParent(None)
    assert w.worker.isFinished()


FILL_SCRIPT = r"""
import json, sys, time
from PySide6 import QtWidgets
import app.startup as startup
from app.startup import GuiThreadGarbage, make_app
from app.assist_window import AssistSettings, AssistWindow, run_assist_window, save_assist_settings

app = make_app()
startup.run_until_quit = lambda app, window: 0  # run_assist_window shows and starts, the script measures
out = {}
for mode in ("touch", "scan2", "scan1"):
    save_assist_settings(AssistSettings(mode=mode))
    run_assist_window((800, 480))
    w = [x for x in app.topLevelWidgets() if isinstance(x, AssistWindow) and x.isVisible()][0]
    deadline = time.monotonic() + 60
    while not w.choosing and time.monotonic() < deadline:  # the arm at its ready pose, boxes offered
        app.processEvents()
        time.sleep(0.01)
    app.processEvents()
    hint = w.hint_label
    lines = hint.fontMetrics().boundingRect(0, 0, hint.contentsRect().width(), 10000,
                                            int(hint.alignment()) | 0x1000, hint.text())  # TextWordWrap
    top_left = hint.mapTo(w, hint.rect().topLeft())
    out[mode] = {"geometry": list(w.geometry().getRect()),
                 "available": list(w.screen().availableGeometry().getRect()),
                 "choosing": w.choosing, "text": hint.text(),
                 "hint": [top_left.x(), top_left.y(), hint.width(), hint.height()],
                 "hint_needs": [lines.width(), hint.heightForWidth(hint.width())],
                 "boxes_px": [min(w.view.box_rect(i).width(), w.view.box_rect(i).height())
                              for i in range(len(w.hit_boxes))]}
    w.stop()
    w.close()
    for g in app.findChildren(GuiThreadGarbage):
        g.stop()
        g.setParent(None)
print(json.dumps(out))
"""


def test_at_800x480_the_window_is_the_whole_screen_and_the_plain_word_hints_fit(tmp_path):
    """On an 800x480 screen (the offscreen platform's screen set to 800x480): the window's geometry
    is the screen's available geometry in every mode, and the hint — in plain words, longer than
    the old "Space / right" — wraps within its label (no line wider, no line below it), the label
    inside the window. (Offscreen honours full screen; X11 without a window manager does not: see
    the Xvfb test at the end.)"""
    config = tmp_path / "screen.json"
    config.write_text(json.dumps({"screens": [{"name": "panel", "x": 0, "y": 0, "width": 800, "height": 480,
                                               "logicalDpi": 96, "logicalBaseDpi": 96, "dpr": 1}]}))
    env = dict(os.environ, QT_QPA_PLATFORM=f"offscreen:configfile={config}", DESKARM_HOME=str(tmp_path / "home"))
    done = subprocess.run([sys.executable, "-c", FILL_SCRIPT], cwd=REPO, env=env, capture_output=True, text=True,
                          timeout=SUBPROCESS_TIMEOUT_S)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    for mode, m in result.items():
        assert m["available"] == [0, 0, 800, 480], mode
        assert m["geometry"] == m["available"], (mode, m)
        assert m["choosing"], mode
        x, y, width, height = m["hint"]
        need_w, need_h = m["hint_needs"]
        assert need_w <= width and need_h <= height, (mode, m)  # every line whole
        assert x >= 0 and y >= 0 and x + width <= 800 and y + height <= 480, (mode, m)
        assert min(m["boxes_px"]) >= 40, (mode, m)  # ~44–69 px boxes (~24–37 px in the 526-px-wide window)
    assert "Hold 1.5 s: stop (again: re-arm)." in result["scan1"]["text"]
    assert "Next: Space key or right mouse button." in result["scan2"]["text"]


# -- 8. quitting: Ctrl+Q and the ☰ menu, out of a switch's reach ---------------------------------

def test_ctrl_q_quits_and_joins_the_worker(make_window, qtbot):
    w, _, _ = make_window("scan2")
    qtbot.keyClick(w, QtCore.Qt.Key.Key_Q, QtCore.Qt.KeyboardModifier.ControlModifier)
    qtbot.waitUntil(lambda: not w.isVisible(), timeout=TIMEOUT_MS)
    assert w.worker.isFinished()
    assert w.worker.engaged  # the arm was stopped before the worker let it go


def test_the_menu_button_opens_a_menu_with_quit_and_stop_still_stops_while_it_is_open(make_window, qtbot):
    w, _, _ = make_window("touch")
    b = w.menu_button
    assert b.isVisible() and b.width() >= TOUCH_PX and b.height() >= TOUCH_PX
    stop = rect_in(w, w.stop_button)
    assert not rect_in(w, b).intersects(stop.adjusted(-40, -40, 40, 40))  # far from STOP
    qtbot.mouseClick(b, LEFT)
    assert w.menu_panel.isVisible() and w.quit_button.isVisible()
    assert w.quit_button.height() >= TOUCH_PX
    assert not rect_in(w, w.menu_panel).intersects(stop)  # the menu never covers STOP
    qtbot.mouseClick(w.stop_button, LEFT)  # no popup grabs the press: STOP stops with the menu open
    assert w.engaged and w.stop_button.engaged
    qtbot.keyClick(w, QtCore.Qt.Key.Key_Escape)  # Esc stops (again) and closes the menu
    assert w.engaged and not w.menu_panel.isVisible()
    qtbot.mouseClick(b, LEFT)
    assert w.menu_panel.isVisible()
    qtbot.mouseClick(w.quit_button, LEFT)
    qtbot.waitUntil(lambda: not w.isVisible(), timeout=TIMEOUT_MS)
    assert w.worker.isFinished()


def test_in_the_switch_modes_a_mouse_switch_over_the_menu_button_is_the_switch_not_a_click(make_window, qtbot):
    w, _, texts = make_window("scan2")
    assert w.view.highlight == 0
    qtbot.mouseClick(w.menu_button, RIGHT)  # "next", with the pointer resting on ☰
    assert w.view.highlight == 1 and not w.menu_panel.isVisible()
    qtbot.mouseClick(w.menu_button, LEFT)  # "confirm"
    assert not w.menu_panel.isVisible() and w.isVisible() and "aligning with 2" in texts
    qtbot.waitUntil(lambda: w.worker.selections == [1], timeout=TIMEOUT_MS)  # (the worker's thread takes it)
    qtbot.mouseDClick(w.menu_button, LEFT)  # a double press is two switch presses, never a click
    assert not w.menu_panel.isVisible() and w.isVisible()


# -- 9. the badge and the outline are one target --------------------------------------------------

def test_a_tap_on_a_number_badge_chooses_its_box(make_window, qtbot):
    w, _, texts = make_window("touch")
    badge, outline = w.view.badge_rect(6), w.view.box_rect(6)
    point = QtCore.QPointF(badge.left() + 4, badge.center().y())  # on the badge, left of the outline
    assert not outline.contains(point)
    image = w.view.grab().toImage()
    pixel = image.pixelColor(point.toPoint())
    assert max(pixel.red(), pixel.green(), pixel.blue()) < 60  # the badge's black fill is drawn there
    qtbot.mouseClick(w.view, LEFT, pos=point.toPoint())
    assert w.ignored_taps == 0 and not w.view.ack_visible  # not "not a button"
    wait_for_press(qtbot, w, texts, 7)


# -- 10. a held key switch stays held through X11 auto-repeat -------------------------------------

def send_key(w, kind: str, stamp: int, autorepeat: bool = False) -> None:
    """A Space key event as X11 delivers it: its server timestamp (ms) and auto-repeat flag."""
    event_type = QtCore.QEvent.Type.KeyPress if kind == "press" else QtCore.QEvent.Type.KeyRelease
    event = QtGui.QKeyEvent(event_type, SPACE, QtCore.Qt.KeyboardModifier.NoModifier, " ", autorepeat)
    event.setTimestamp(stamp)
    QtWidgets.QApplication.sendEvent(w, event)


def hold_space(w, clock, stamp: int, seconds: float, seen: list) -> int:
    """Space held ``seconds`` with X11's auto-repeat (660 ms delay, then a pair every 40 ms): pairs
    Qt flagged and pairs it did not (a release and a press with one timestamp — what the running
    window got under Xvfb), the scan ticked after each; the highlight after each tick goes to
    ``seen``. Returns the last timestamp (the key is still down)."""
    t0 = clock.t
    send_key(w, "press", stamp)
    clock.t += 0.66
    stamp += 660
    w.scan_tick()
    seen.append(w.view.highlight)
    n = 0
    while clock.t - t0 < seconds:
        clock.t += 0.04
        stamp += 40
        flagged = n % 4 == 3
        send_key(w, "release", stamp, autorepeat=flagged)
        send_key(w, "press", stamp, autorepeat=flagged)
        w.scan_tick()
        seen.append(w.view.highlight)
        n += 1
    return stamp


@pytest.mark.parametrize("mode", ["scan2", "scan1"])
def test_a_key_switch_held_with_x11_auto_repeat_stops_and_a_second_hold_re_arms(make_window, qtbot, mode):
    w, clock, texts = make_window(mode, scan_period_s=5.0)
    chose = lambda: [t for t in texts if t.startswith("aligning")]  # noqa: E731 (a choice, seen at once in the GUI)
    assert w.view.highlight == 0
    seen = []
    stamp = hold_space(w, clock, 100_000, 1.8, seen)
    assert w.engaged and w.state_text == "stopped"  # stopped at 1.5 s of holding
    assert not chose()  # no repeat pair was a confirm …
    stopped_at = seen.index(None)
    assert set(seen[:stopped_at]) == {0}  # … nor a "next": the highlight stayed on box 1
    for _ in range(50):  # holding on past 3 s does not re-arm: one hold, one action
        clock.t += 0.04
        stamp += 40
        send_key(w, "release", stamp)
        send_key(w, "press", stamp)
        w.scan_tick()
    assert w.engaged
    send_key(w, "release", stamp + 30)  # the key really comes up: no press follows
    qtbot.waitUntil(lambda: w.switches.held is None, timeout=TIMEOUT_MS)  # the window's timer ends the wait
    assert w.engaged and not chose()
    stamp = hold_space(w, clock, stamp + 2_000, 1.8, [])  # hold again: re-arm
    assert not w.engaged
    send_key(w, "release", stamp + 30)
    qtbot.waitUntil(lambda: w.choosing and w.switches.held is None, timeout=TIMEOUT_MS)
    assert not chose() and w.view.highlight == 0
    # a real short press (a timestamp, no repeat) still acts once, after the release's wait
    send_key(w, "press", stamp + 1_000)
    clock.t += 0.12
    send_key(w, "release", stamp + 1_120)
    if mode == "scan2":
        qtbot.waitUntil(lambda: w.view.highlight == 1 and w.switches.held is None, timeout=TIMEOUT_MS)
        assert not chose()
    else:
        qtbot.waitUntil(lambda: w.worker.selections == [0], timeout=TIMEOUT_MS)


# -- 17. the two-switch hint in plain words --------------------------------------------------------

def test_the_hints_name_keys_and_mouse_buttons_in_plain_words(make_window, qtbot):
    from app.assist_window import switch_words

    w, _, _ = make_window("scan2")
    text = w.hint_label.text()
    assert "Space key or right mouse button" in text and "Enter key or left mouse button" in text
    assert " / " not in text
    w.set_mode("scan1")
    assert "Space key, Enter key or left mouse button" in w.hint_label.text()
    assert switch_words(("gamepad:BTN_SOUTH", "gpio:17", "key:F1")) == "gamepad BTN_SOUTH, switch on pin 17 or F1 key"


# -- 19. --screenshot and no display --------------------------------------------------------------

def no_display_env(tmp_path, **extra) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM")}
    env.update(DESKARM_HOME=str(tmp_path / "home"), **extra)
    return env


def test_deskarm_assist_with_no_display_says_so_in_one_line_and_exits_2(tmp_path):
    done = subprocess.run([sys.executable, "-m", "app.cli", "--assist"], cwd=REPO, env=no_display_env(tmp_path),
                          capture_output=True, text=True, timeout=SUBPROCESS_TIMEOUT_S)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("deskarm: no display") and "--screenshot" in lines[0]


@pytest.mark.parametrize("size", ["800x480", "1024x600"])
def test_deskarm_assist_screenshot_writes_exactly_the_size_asked_for(tmp_path, size):
    out = tmp_path / "assist.png"
    done = subprocess.run([sys.executable, "-m", "app.cli", "--assist", "--screenshot", str(out), "--size", size,
                           "--after", "0"], cwd=REPO, env=no_display_env(tmp_path), capture_output=True, text=True,
                          timeout=SUBPROCESS_TIMEOUT_S)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"deskarm: screenshot saved to {out} ({size}, assistive view")
    assert "choose a button" in lines[0]  # taken once the boxes were offered
    image = QtGui.QImage(str(out))
    assert not image.isNull() and f"{image.width()}x{image.height()}" == size


def test_display_problem_names_what_is_missing():
    from app.cli_assist import display_problem

    assert display_problem({}, "linux").startswith("no display")
    assert "DISPLAY is not set" in display_problem({"QT_QPA_PLATFORM": "xcb"}, "linux")
    assert display_problem({"DISPLAY": ":0"}, "linux") == ""
    assert display_problem({"WAYLAND_DISPLAY": "wayland-0"}, "linux") == ""
    assert display_problem({"QT_QPA_PLATFORM": "eglfs"}, "linux") == ""
    assert display_problem({"QT_QPA_PLATFORM": "offscreen"}, "linux") == ""
    assert display_problem({}, "darwin") == ""


# -- 7, 8, 10 on a real X server ----------------------------------------------------------------------


X_CHILD = textwrap.dedent('''
    import sys
    from PySide6 import QtCore
    from app import assist_window as aw

    def say(*words):
        print(*words, flush=True)

    original_boxes, original_stop, original_close = (aw.AssistWindow._on_boxes, aw.AssistWindow.emergency_stop,
                                                     aw.AssistWindow.closeEvent)
    original_highlight = aw.AssistView.set_highlight

    def on_boxes(self, boxes):
        original_boxes(self, boxes)
        if self.choosing and not getattr(self, "_said_ready", False):
            self._said_ready = True
            def ready():
                h = self.hint_label
                lines = h.fontMetrics().boundingRect(0, 0, h.contentsRect().width(), 10000,
                                                     int(h.alignment()) | 0x1000, h.text())
                fits = lines.width() <= h.width() and h.heightForWidth(h.width()) <= h.height()
                say("READY", *self.geometry().getRect(), "hint-fits" if fits else "hint-cut")
            QtCore.QTimer.singleShot(500, ready)  # once a window manager has placed it

    def emergency_stop(self):
        say("STOP")
        original_stop(self)

    def close_event(self, event):
        say("CLOSE")
        original_close(self, event)

    def set_highlight(self, index):
        if index is not None:
            say("HIGHLIGHT", index)
        original_highlight(self, index)

    aw.AssistWindow._on_boxes, aw.AssistWindow.emergency_stop = on_boxes, emergency_stop
    aw.AssistWindow.closeEvent, aw.AssistView.set_highlight = close_event, set_highlight
    from app.cli import main
    sys.exit(main(["--assist"]))
''')


@pytest.mark.skipif(bool(why_no_xvfb()), reason=why_no_xvfb() or "-")
@pytest.mark.parametrize("window_manager", [False, True], ids=["no-window-manager", "openbox"])
def test_on_a_real_x_server_it_fills_the_screen_a_held_key_stops_and_ctrl_q_quits(tmp_path, window_manager):
    (tmp_path / "config").mkdir()
    (tmp_path / "config" / "assist.toml").write_text('mode = "scan2"\n')
    with x_server(tmp_path, window_manager) as x:
        script = tmp_path / "child.py"
        script.write_text(X_CHILD)
        child, out = x.start(script)
        ready, _ = out.wait_for("READY")
        assert ready == "READY 0 0 800 480 hint-fits"  # the whole screen, the hint whole
        x.xdo("keydown", "space")  # held: the server's auto-repeat sends release/press pairs after 660 ms …
        _, before_stop = out.wait_for("STOP")  # … and the hold stops the arm at 1.5 s
        x.xdo("keyup", "space")
        assert not [line for line in before_stop if line.startswith("HIGHLIGHT")]  # no "next" from the repeat
        x.xdo("key", "ctrl+q")
        out.wait_for("CLOSE")
        assert child.wait(timeout=WAIT_S) == 0
