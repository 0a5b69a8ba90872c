"""Words a new user reads at 800x480 (issue 22, item 17), each driven by taps in the window
(pytest-qt, offscreen, the simulated desk):

- the Robot tab's button and the dialog it opens call the calibration by one name;
- the hand-eye run never shows the same status line twice;
- the touch-point method says "4 or more markers", not "K ≥ 4";
- the Jog and Robot tabs show the elbow in one convention, or each says which and why;
- the Objects tab shows ArUco markers as on while the cameras find them.
"""
import math
import re

import pytest
from PySide6 import QtCore, QtWidgets

from app.gui import MainWindow
from tests.window.test_touch_window import make_window as make_main_window

SMALL = (800, 480)
TIMEOUT_MS = 10_000  # two cores shared with other test runs: frames can be slow
LEFT = QtCore.Qt.MouseButton.LeftButton
ELBOW = 2  # desk_rrr: base_yaw, shoulder, elbow (the elbow's servo is mounted at 180°)


def make_window(qtbot, scenario="static", detectors=()) -> MainWindow:
    return make_main_window(qtbot, scenario=scenario, size=SMALL, detectors=detectors)


@pytest.fixture
def window(qtbot):
    w = make_window(qtbot)
    w.start()
    yield w
    w.stop()  # closes the wizard too


def tap(qtbot, widget: QtWidgets.QWidget) -> None:
    assert widget.isVisible() and widget.isEnabled(), getattr(widget, "text", lambda: "")()
    qtbot.mouseClick(widget, LEFT)


def tap_tab(qtbot, window: MainWindow, title: str) -> QtWidgets.QWidget:
    """Tap the tab called ``title`` on the tab bar; its page."""
    bar = window.tabs.tabBar()
    index = [window.tabs.tabText(i) for i in range(window.tabs.count())].index(title)
    qtbot.mouseClick(bar, LEFT, pos=bar.tabRect(index).center())
    assert window.tabs.currentIndex() == index
    QtWidgets.QApplication.processEvents()
    return window.tabs.currentWidget()


def visible_texts(root: QtWidgets.QWidget, kinds=(QtWidgets.QLabel, QtWidgets.QAbstractButton)) -> list[str]:
    """The text of every label and button the user can see in ``root``."""
    return [w.text() for w in root.findChildren(QtWidgets.QWidget)
            if isinstance(w, kinds) and w.isVisibleTo(root) and w.text()]


def open_wizard(qtbot, window):
    tap_tab(qtbot, window, "Robot")
    tap(qtbot, window.hand_eye_button)
    wizard = window.hand_eye.wizard
    qtbot.waitExposed(wizard)
    return wizard


def run_page_lines(wizard) -> list[str]:
    """The status lines the run page shows beside the live view (phase, step, points)."""
    return [label.text() for label in (wizard.phase_label, wizard.step_label, wizard.points_label)
            if label.isVisibleTo(wizard) and label.text()]


# ----------------------------------------------------------------------------------------------
def test_the_button_and_the_dialog_it_opens_call_the_calibration_by_one_name(qtbot, window):
    button_text = window.hand_eye_button.text()
    name = button_text.rstrip("…").strip()
    wizard = open_wizard(qtbot, window)
    assert wizard.windowTitle() == name, (button_text, wizard.windowTitle())
    subject = name.replace(" calibration", "")  # "Camera → arm"
    assert wizard.title.text().startswith(subject), wizard.title.text()
    words = " ".join(visible_texts(wizard) + [wizard.save_button.toolTip()]).lower()
    assert "robot" not in words.replace(" ", ""), words  # no second name ("camera→robot")


def test_the_hand_eye_run_shows_each_status_line_once(qtbot, window):
    wizard = open_wizard(qtbot, window)
    controller = window.hand_eye
    # the sweep: moving, then settling and sampling at each pose
    tap(qtbot, wizard.start_button)
    qtbot.waitUntil(lambda: controller.sweep is not None and controller.sweep.phase in ("settling", "sampling"),
                    timeout=TIMEOUT_MS)
    qtbot.waitUntil(lambda: "pose" in wizard.progress_text(), timeout=TIMEOUT_MS)
    lines = run_page_lines(wizard)
    assert len(lines) == len(set(lines)) and len(lines) >= 2, lines
    assert wizard.phase_text() != wizard.progress_text(), lines
    # touch points: what to do is said once, the count once
    tap(qtbot, wizard.cancel_button)
    tap(qtbot, wizard.method_buttons["touch_points"])
    tap(qtbot, wizard.start_button)
    qtbot.waitUntil(lambda: window._result is not None and sum(m.found for m in window._result.markers) >= 1,
                    timeout=TIMEOUT_MS)
    lines = run_page_lines(wizard)
    assert len(lines) == len(set(lines)), lines
    assert sum("jog" in line for line in lines) == 1, lines
    tap(qtbot, wizard.record_button)
    qtbot.waitUntil(lambda: len(controller.records) == 1, timeout=TIMEOUT_MS)
    lines = run_page_lines(wizard)
    assert len(lines) == len(set(lines)) and sum("1 of 4" in line for line in lines) == 1, lines
    assert sum("jog" in line for line in lines) == 1, lines


def test_the_touch_point_method_says_how_many_markers_in_plain_words(qtbot, window):
    wizard = open_wizard(qtbot, window)
    assert wizard.page() == "method"
    texts = visible_texts(wizard)
    assert not [t for t in texts if "≥" in t or re.search(r"\bK\b", t)], texts
    touch = wizard.method_buttons["touch_points"].text()
    assert "4 or more markers" in touch, touch


def test_the_jog_and_robot_tabs_show_the_elbow_in_one_convention_or_each_says_which(qtbot, window):
    qtbot.waitUntil(lambda: window._command is not None and window._state is not None, timeout=TIMEOUT_MS)
    tap(qtbot, window.estop_button)  # the arm holds still: both tabs show the same moment
    qtbot.waitUntil(lambda: not window.session.controller.armed, timeout=TIMEOUT_MS)
    jog_page = tap_tab(qtbot, window, "Jog")
    tap(qtbot, window.jog_panel.space_buttons["joint"])
    window._dirty = True
    window.redraw()
    jog_elbow = float(window.jog_panel.value_labels[ELBOW].text().replace("°", "").replace("−", "-"))
    robot_page = tap_tab(qtbot, window, "Robot")
    window._dirty = True
    window.redraw()
    robot_elbow = float(window.joints.row_texts(ELBOW)[1])
    if abs(jog_elbow - robot_elbow) < 0.15:
        return  # one convention: nothing to explain
    # two conventions (here: the elbow's servo sits at 180°, −118° of joint is 62° of servo) —
    # the same angle, so each tab must name the one it shows and the Robot tab say why they differ
    servo = window.session.profile.joints[ELBOW].to_servo_deg(math.radians(jog_elbow))
    assert servo == pytest.approx(robot_elbow, abs=1.0), (jog_elbow, robot_elbow)
    robot_words = " ".join(visible_texts(robot_page, (QtWidgets.QLabel,))).lower()
    assert "servo angle" in robot_words and "jog" in robot_words and "joint angle" in robot_words, robot_words
    assert "offset" in robot_words, robot_words  # why they differ
    tap_tab(qtbot, window, "Jog")
    jog_words = " ".join(visible_texts(jog_page, (QtWidgets.QLabel,))).lower()
    assert "joint angle" in jog_words and "servo" in jog_words, jog_words


def test_the_objects_tab_shows_markers_on_while_the_cameras_find_them(qtbot):
    window = make_window(qtbot, scenario="objects", detectors=("hsv",))
    window.start()
    try:
        qtbot.waitUntil(lambda: window._result is not None and sum(m.found for m in window._result.markers) >= 2,
                        timeout=TIMEOUT_MS)
        page = tap_tab(qtbot, window, "Objects")
        shown = [w for w in page.findChildren(QtWidgets.QWidget)
                 if isinstance(w, (QtWidgets.QLabel, QtWidgets.QAbstractButton)) and w.isVisibleTo(page)]

        def says_markers_on(w) -> bool:
            text = w.text().lower()
            if "marker" not in text and "aruco" not in text:
                return False
            if isinstance(w, QtWidgets.QAbstractButton) and w.isCheckable():
                return w.isChecked()
            return re.search(r"\bon\b", text) is not None

        assert any(says_markers_on(w) for w in shown), [w.text() for w in shown]
        # and nothing reads as "markers: off" (a bare "aruco" toggle left unticked)
        off = [w.text() for w in shown if isinstance(w, QtWidgets.QAbstractButton) and w.isCheckable()
               and not w.isChecked() and w.text().strip().lower() in ("aruco", "markers", "aruco markers")]
        assert not off, off
        # taps on the toggles still work: markers as objects on and off again
        toggle = window.detector_panel.toggles["aruco"]
        tap(qtbot, toggle)
        qtbot.waitUntil(lambda: "aruco" in window._detectors_running, timeout=TIMEOUT_MS)
        tap(qtbot, toggle)
        qtbot.waitUntil(lambda: "aruco" not in window._detectors_running, timeout=TIMEOUT_MS)
        assert any(says_markers_on(w) for w in shown)
    finally:
        window.stop()
