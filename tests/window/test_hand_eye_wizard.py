"""The hand-eye (camera → arm) wizard as a view: taps become signals, the app's calls show up,
and every page fits a 800×480 touch screen with finger-sized controls (pytest-qt, offscreen)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from PySide6 import QtCore, QtGui, QtWidgets

import widgets  # noqa: F401  (row-major images)
from widgets._style import ERROR_COLOUR, OK_COLOUR, TOUCH_PX
from widgets.hand_eye_wizard import (
    N_POSES_DEFAULT,
    N_POSES_RANGE,
    REJECTED_COLOUR,
    USED_COLOUR,
    WORST_COLOUR,
    HandEyeWizard,
    verdict_text,
)

LEFT = QtCore.Qt.MouseButton.LeftButton
TIMEOUT_MS = 2000
SCREEN = QtCore.QSize(800, 480)


def calibrated(**changes) -> SimpleNamespace:
    """A result as core/handeye gives it: 12 poses, #5 the worst, #12 rejected."""
    fields = dict(ok=True, problem="", method="sweep", poses_used=11,
                  residuals_mm=[1.2, 1.9, 0.8, 2.5, 4.1, 1.1, 1.7, 1.4, 2.0, 0.9, 1.3, 6.0],
                  rms_mm=1.8, max_mm=4.1, worst_index=4, rejected=[11],
                  warnings=["pose #12 rejected: 6.0 mm, above 3× the median"],
                  translation_error_mm=1.1, rotation_error_deg=0.35)
    fields.update(changes)
    return SimpleNamespace(**fields)


def failed(**changes) -> SimpleNamespace:
    fields = dict(ok=False, problem="only 3 poses saw the tool marker (4 needed)", method="sweep",
                  poses_used=3, residuals_mm=[2.0, 3.0, 1.0], rms_mm=float("nan"), max_mm=3.0,
                  worst_index=1, rejected=[], warnings=[])
    fields.update(changes)
    return SimpleNamespace(**fields)


@pytest.fixture
def wizard(qtbot):
    w = HandEyeWizard()
    qtbot.addWidget(w)
    w.resize(SCREEN)
    w.show()
    qtbot.waitExposed(w)
    return w


def tap(qtbot, button: QtWidgets.QAbstractButton) -> None:
    assert button.isVisible() and button.isEnabled(), button.text()
    qtbot.mouseClick(button, LEFT)


def colour_name(brush) -> str:
    return QtGui.QBrush(brush).color().name()


# ------------------------------------------------------------------------------------ method page
def test_start_asks_for_the_sweep_with_twelve_poses_by_default(qtbot, wizard):
    assert wizard.page() == "method" and wizard.method() == "sweep"
    assert (wizard.poses_spin.minimum(), wizard.poses_spin.maximum()) == N_POSES_RANGE == (4, 40)
    assert wizard.n_poses() == N_POSES_DEFAULT == 12
    with qtbot.waitSignal(wizard.sigStartRequested, timeout=TIMEOUT_MS) as blocker:
        tap(qtbot, wizard.start_button)
    assert blocker.args == ["sweep", 12]
    assert wizard.page() == "run"
    assert not wizard.record_button.isVisible()  # recording points is for touch points only


def test_choosing_touch_points_by_tap_starts_it_with_a_record_button(qtbot, wizard):
    wizard.set_n_poses(20)
    tap(qtbot, wizard.method_buttons["touch_points"])
    assert wizard.method() == "touch_points" and not wizard.poses_spin.isEnabled()
    with qtbot.waitSignal(wizard.sigStartRequested, timeout=TIMEOUT_MS) as blocker:
        tap(qtbot, wizard.start_button)
    assert blocker.args == ["touch_points", 20]
    assert wizard.record_button.isVisible() and wizard.points_label.isVisible()
    with qtbot.waitSignal(wizard.sigRecordPointRequested, timeout=TIMEOUT_MS):
        tap(qtbot, wizard.record_button)
    wizard.set_points_recorded(2, 4)
    assert wizard.points_label.text().startswith("2 of 4 points recorded")
    wizard.set_points_recorded(4, 4)
    assert "4 points recorded ✓" in wizard.points_label.text()


def test_a_poses_number_typed_but_not_committed_is_the_one_started(qtbot, wizard):
    tap(qtbot, wizard.method_buttons["planar"])
    tap(qtbot, wizard.method_buttons["sweep"])
    assert wizard.poses_spin.isEnabled()
    wizard.poses_spin.setFocus()
    wizard.poses_spin.lineEdit().selectAll()
    qtbot.keyClicks(wizard.poses_spin.lineEdit(), "30")  # no Enter: the Start tap must still take 30
    with qtbot.waitSignal(wizard.sigStartRequested, timeout=TIMEOUT_MS) as blocker:
        tap(qtbot, wizard.start_button)
    assert blocker.args == ["sweep", 30]


def test_the_tool_marker_is_shown_and_a_missing_one_says_what_to_do(wizard):
    assert "not set" in wizard.tool_marker_text()
    wizard.set_tool_marker("id 7, 30 mm")
    assert wizard.tool_marker_text() == "Tool marker: id 7, 30 mm"
    assert wizard.tool_marker_label.isVisible()


# ------------------------------------------------------------------------------------ run page
def test_cancel_asks_to_stop_the_run_and_goes_back_to_the_methods(qtbot, wizard):
    tap(qtbot, wizard.start_button)
    with qtbot.waitSignal(wizard.sigCancelRequested, timeout=TIMEOUT_MS):
        tap(qtbot, wizard.cancel_button)
    assert wizard.page() == "method" and "Cancelled" in wizard.status_text()


def test_progress_step_and_phase_show_what_the_run_does(qtbot, wizard):
    tap(qtbot, wizard.start_button)
    wizard.set_progress(0.25, "pose 3 of 12")
    assert wizard.progress_text() == "pose 3 of 12" and wizard.progress_bar.value() == 250
    assert wizard.step_label.isVisible()
    wizard.set_progress(1.7, "done")  # clamped, never past the end
    assert wizard.progress_bar.value() == 1000
    wizard.set_phase("settling")
    assert wizard.phase_text().startswith("settling")
    wizard.set_phase("skipped", "the tool marker was not seen at pose 4")
    assert wizard.phase_text() == "skipped pose: the tool marker was not seen at pose 4"
    assert "#e08a00" in wizard.phase_label.styleSheet()  # orange: worth a look, not an error


def test_the_live_view_shows_the_image_and_outlines_the_markers(qtbot, wizard):
    tap(qtbot, wizard.start_button)
    image = np.full((480, 640, 3), 90, np.uint8)
    square = np.array([[250, 200], [330, 200], [330, 280], [250, 280]], float)
    drawn = wizard.camera_view.frames_drawn
    wizard.show_live(image, [square], [7])
    wizard.flush_live()
    assert wizard.camera_view.frames_drawn == drawn + 1
    assert wizard.camera_view.placeholder_text() == ""
    assert wizard.camera_view.marker_at(290, 240) == 7
    wizard.show_live(image, None)  # no marker seen: no outline left behind
    wizard.flush_live()
    assert wizard.camera_view.marker_at(290, 240) is None


# ------------------------------------------------------------------------------------ e-stop
def test_stop_is_a_tap_away_on_every_page_and_shows_the_state(qtbot, wizard):
    for page in ("method", "run", "result"):
        wizard.set_page(page)
        with qtbot.waitSignal(wizard.sigStopRequested, timeout=TIMEOUT_MS):
            tap(qtbot, wizard.stop_button)
    assert "keeps moving" in wizard.estop_label.text() and wizard.stop_button.text() == "STOP"
    wizard.set_estop(True)
    assert "ARM STOPPED" in wizard.estop_label.text() and wizard.stop_button.text() == "STOPPED"
    assert ERROR_COLOUR in wizard.estop_label.styleSheet()
    assert not any(b.text().upper().startswith("RE-ARM") for b in wizard.findChildren(QtWidgets.QPushButton))
    with qtbot.waitSignal(wizard.sigStopRequested, timeout=TIMEOUT_MS):  # stopping twice is stopping
        tap(qtbot, wizard.stop_button)
    wizard.set_estop(False)
    assert wizard.stop_button.text() == "STOP" and "ARM STOPPED" not in wizard.estop_label.text()


def test_esc_requests_stop_and_does_not_close_the_wizard(qtbot, wizard):
    for page in ("method", "run", "result"):
        wizard.set_page(page)
        with qtbot.waitSignal(wizard.sigStopRequested, timeout=TIMEOUT_MS):
            qtbot.keyClick(wizard, QtCore.Qt.Key.Key_Escape)
        assert wizard.isVisible() and wizard.page() == page
    wizard.set_page("method")
    wizard.poses_spin.setFocus()  # Esc in a field stops too
    with qtbot.waitSignal(wizard.sigStopRequested, timeout=TIMEOUT_MS):
        qtbot.keyClick(wizard.poses_spin, QtCore.Qt.Key.Key_Escape)
    assert wizard.isVisible()
    with qtbot.waitSignal(wizard.finished, timeout=TIMEOUT_MS):  # closing stays on Close
        tap(qtbot, wizard.close_button)
    assert not wizard.isVisible()


# ------------------------------------------------------------------------------------ result page
def test_a_calibrated_result_says_so_in_green_and_can_be_saved(qtbot, wizard):
    wizard.show_result(calibrated())
    assert wizard.page() == "result"
    assert wizard.verdict_label.text() == "calibrated: 1.8 mm RMS, worst pose #5 4.1 mm"
    assert OK_COLOUR in wizard.verdict_label.styleSheet() and wizard.verdict_level == "ok"
    assert "11 of 12 poses used" in wizard.details_label.text() and "#12" in wizard.details_label.text()
    assert "1.1 mm" in wizard.details_label.text()  # the simulated desk's truth
    assert "pose #12 rejected" in wizard.warnings_label.text()
    with qtbot.waitSignal(wizard.sigSaveRequested, timeout=TIMEOUT_MS):
        tap(qtbot, wizard.save_button)
    wizard.on_saved("/home/user/.config/deskarm/hand_eye.toml")
    assert wizard.status_text() == "✓ Saved and in use: …/deskarm/hand_eye.toml"
    assert wizard.status_label.toolTip() == "/home/user/.config/deskarm/hand_eye.toml"
    assert wizard.status_label.isVisible()


def test_a_failed_result_says_why_in_red_with_the_fix_and_cannot_be_saved(qtbot, wizard):
    wizard.show_result(failed())
    text = wizard.verdict_label.text()
    assert text.startswith("not calibrated: only 3 poses saw the tool marker (4 needed) — ")
    assert "tool marker is seen" in text  # the sweep's fix
    assert ERROR_COLOUR in wizard.verdict_label.styleSheet()
    assert not wizard.save_button.isEnabled()
    with qtbot.assertNotEmitted(wizard.sigSaveRequested):
        qtbot.mouseClick(wizard.save_button, LEFT)
    assert wizard.warnings_label.text() == "none"


def test_a_problem_that_names_its_fix_gets_no_second_one():
    text, level = verdict_text(failed(problem="the camera moved — run again", method="planar"))
    assert (text, level) == ("not calibrated: the camera moved — run again", "error")
    text, level = verdict_text(calibrated(problem="6.2 mm RMS is high for this arm"))
    assert level == "warn" and text.endswith("— 6.2 mm RMS is high for this arm")


def test_the_residual_plot_has_one_bar_per_pose_the_worst_red_and_the_rejected_grey(wizard):
    result = calibrated()
    wizard.show_result(result)
    opts = wizard._bars.opts
    assert len(opts["height"]) == len(opts["brushes"]) == len(result.residuals_mm) == 12
    assert list(opts["height"]) == pytest.approx(result.residuals_mm)
    colours = [colour_name(b) for b in opts["brushes"]]
    assert colours == wizard.bar_colours()
    assert colours[4] == WORST_COLOUR.lower() == ERROR_COLOUR.lower()
    assert colours[11] == REJECTED_COLOUR.lower()
    assert set(colours[:4] + colours[5:11]) == {USED_COLOUR.lower()}
    # a shorter run replaces the bars, it does not add to them
    wizard.show_result(failed())
    assert len(wizard._bars.opts["height"]) == 3 and wizard.bar_colours()[1] == WORST_COLOUR


def test_a_planar_map_without_pose_fields_and_a_fit_with_no_residuals_still_show(wizard):
    planar = SimpleNamespace(ok=True, problem="", method="planar", residuals_mm=(0.9, 2.7, 1.1, 1.4, 0.6),
                             rms_mm=1.5, max_mm=2.7)  # core/handeye's PlanarMap has no worst_index etc.
    wizard.show_result(planar)
    assert wizard.verdict_label.text() == "calibrated: 1.5 mm RMS, worst pose #2 2.7 mm"
    assert "5 of 5 points used" in wizard.details_label.text()
    assert wizard.bar_colours() == [USED_COLOUR, WORST_COLOUR, USED_COLOUR, USED_COLOUR, USED_COLOUR]
    assert wizard.save_button.isEnabled()
    nothing = failed(residuals_mm=(float("nan"),) * 4, worst_index=-1, max_mm=float("nan"), poses_used=0,
                     problem="only 2 poses saw the tool marker — check the light and run again")
    wizard.show_result(nothing)
    assert wizard.bar_heights() == [0.0] * 4 and WORST_COLOUR not in wizard.bar_colours()
    assert wizard.verdict_label.text() == "not calibrated: only 2 poses saw the tool marker — check the light and run again"
    assert not wizard.save_button.isEnabled()


def test_run_again_restarts_the_same_method_and_method_goes_back(qtbot, wizard):
    tap(qtbot, wizard.method_buttons["planar"])
    tap(qtbot, wizard.start_button)
    wizard.show_result(failed(method="planar"))
    with qtbot.waitSignal(wizard.sigStartRequested, timeout=TIMEOUT_MS) as blocker:
        tap(qtbot, wizard.again_button)
    assert blocker.args == ["planar", 12] and wizard.page() == "run"
    wizard.show_result(failed(method="planar"))
    tap(qtbot, wizard.method_button)
    assert wizard.page() == "method" and wizard.method() == "planar"


def test_a_failure_is_said_on_the_page_the_user_looks_at(qtbot, wizard):
    wizard.show_result(calibrated())
    tap(qtbot, wizard.save_button)
    assert not wizard.save_button.isEnabled()  # one save at a time
    wizard.on_failed("hand_eye.toml: permission denied — choose another folder")
    assert wizard.status_text() == "hand_eye.toml: permission denied — choose another folder"
    assert ERROR_COLOUR in wizard.status_label.styleSheet() and wizard.status_label.isVisible()
    assert wizard.save_button.isEnabled()  # the user may try again


# ------------------------------------------------------------------------------------ 800×480
def _method(w):
    w.set_tool_marker("id 7, 30 mm")


def _run_sweep(w):
    w.start("sweep", 12)
    w.set_progress(0.25, "pose 3 of 12 — moving to x 12.0 y 15.0 z 8.0 cm")
    w.set_phase("skipped", "the tool marker was not seen: it faced away from both cameras")


def _run_touch(w):
    w.start("touch_points", 12)
    w.set_points_recorded(2, 4)
    w.on_failed("no marker under the tool tip — jog it onto the centre of a desk marker and record again")


def _result_ok(w):
    w.show_result(calibrated())
    w.on_saved("/home/user/.config/deskarm/calibration/hand_eye.toml")


def _result_failed(w):
    w.show_result(failed(warnings=[f"pose #{k} skipped: the tool marker was not seen" for k in range(1, 30)]))
    w.on_failed("could not save: nothing to save — run again")


STATES = {"method": (_method, ["start_button"]),
          "run sweep": (_run_sweep, ["cancel_button"]),
          "run touch": (_run_touch, ["cancel_button", "record_button"]),
          "result ok": (_result_ok, ["save_button", "again_button", "method_button"]),
          "result failed": (_result_failed, ["save_button", "again_button", "method_button"])}


@pytest.mark.parametrize("state", list(STATES))
def test_every_page_fits_800x480_with_finger_sized_controls(qtbot, wizard, state):
    prepare, keys = STATES[state]
    prepare(wizard)
    hint = wizard.minimumSizeHint()
    assert hint.width() <= SCREEN.width() and hint.height() <= SCREEN.height(), hint
    assert wizard.size() == SCREEN
    inside = wizard.rect()

    def rect_of(widget):
        return QtCore.QRect(widget.mapTo(wizard, QtCore.QPoint(0, 0)), widget.size())

    for name in keys + ["stop_button", "close_button"]:
        button = getattr(wizard, name)
        assert button.isVisible(), (state, name)
        assert inside.contains(rect_of(button)), (state, name, rect_of(button), inside)
        assert button.height() >= TOUCH_PX, (state, name, button.height())
    for control in wizard.findChildren(QtWidgets.QWidget):
        if isinstance(control, (QtWidgets.QPushButton, QtWidgets.QAbstractSpinBox)) and control.isVisible():
            assert control.height() >= TOUCH_PX, (state, control.text() if hasattr(control, "text") else control)
            assert inside.contains(rect_of(control)), (state, rect_of(control))
    # STOP and Close are apart: a finger aiming at one does not land on the other
    assert rect_of(wizard.close_button).left() - rect_of(wizard.stop_button).right() >= 10
    assert wizard.stop_button.height() >= TOUCH_PX + 8
    if wizard.page() == "result":
        assert wizard.residual_plot.height() >= 100 and inside.contains(rect_of(wizard.residual_plot))
        assert inside.contains(rect_of(wizard.verdict_label))
