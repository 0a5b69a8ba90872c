"""Widget tests (pytest-qt, offscreen): signals, units, snapping and touch-friendly sizes."""
from __future__ import annotations

import math
import os
from dataclasses import asdict

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from PySide6 import QtCore, QtWidgets  # noqa: E402

import widgets  # noqa: E402,F401  (sets pyqtgraph's row-major image order)
from core.messages import MarkerObservation, TargetMode  # noqa: E402
from core.settings import CameraSettings, LissajousParams, SgbmParams  # noqa: E402
from widgets.arm_twin import ArmTwin, arm_azimuth, side_view_coords  # noqa: E402
from widgets.camera_controls import SGBM_SLIDERS, CameraSettingsPanel, SgbmPanel  # noqa: E402
from widgets.camera_view import (  # noqa: E402
    CameraView,
    MarkerOverlay,
    disparity_lut,
    disparity_to_index,
    marker_label,
)
from widgets.joint_readout import JointReadout, limit_level  # noqa: E402
from widgets.status import Banner, StatusBarItems  # noqa: E402
from widgets.target_panel import TargetPanel  # noqa: E402

TIMEOUT_MS = 1000
LEFT = QtCore.Qt.MouseButton.LeftButton
SCREEN_W, SCREEN_H = 800, 480
TOUCH_MIN_PX = 40


def close(a, b, tol=1e-9) -> bool:
    """Compare floats or sequences; pytest prints both sides on failure."""
    return np.allclose(np.asarray(a, dtype=float), np.asarray(b, dtype=float), atol=tol, rtol=0)


@pytest.fixture
def target_panel(qtbot) -> TargetPanel:
    panel = TargetPanel()
    qtbot.addWidget(panel)
    panel.resize(SCREEN_W // 2, SCREEN_H)
    panel.show()
    qtbot.waitExposed(panel)
    return panel


@pytest.fixture
def camera_view(qtbot) -> CameraView:
    view = CameraView("Left")
    qtbot.addWidget(view)
    view.resize(660, 540)
    view.show()
    qtbot.waitExposed(view)
    view.show_image(np.zeros((480, 640, 3), np.uint8))
    return view


def square(x0: float, y0: float, side: float) -> np.ndarray:
    return np.array([[x0, y0], [x0 + side, y0], [x0 + side, y0 + side], [x0, y0 + side]])


def click_image(qtbot, view: CameraView, x_px: float, y_px: float) -> None:
    pos = view.graphics_view.viewport().mapFrom(view, view.image_to_widget(x_px, y_px))
    qtbot.mouseClick(view.graphics_view.viewport(), LEFT, pos=pos)


# ------------------------------------------------------------------------------- TargetPanel
def test_each_mode_button_emits_its_target_mode_and_shows_its_page(qtbot, target_panel):
    expected_pages = {"manual": 0, "follow": 1, "lissajous": 2, "cups": 3}
    for mode in ("follow", "lissajous", "cups", "manual"):
        button = target_panel.mode_buttons[mode]
        with qtbot.waitSignal(target_panel.sigModeChanged, timeout=TIMEOUT_MS) as blocker:
            qtbot.mouseClick(button, LEFT)
        assert blocker.args == [mode]
        assert TargetMode(blocker.args[0]).value == mode
        assert target_panel.mode == mode
        assert target_panel.stack.currentIndex() == expected_pages[mode]
        assert button.isChecked()


def test_clicking_the_current_mode_again_emits_nothing(qtbot, target_panel):
    with qtbot.assertNotEmitted(target_panel.sigModeChanged):
        qtbot.mouseClick(target_panel.mode_buttons["manual"], LEFT)


def test_set_mode_switches_page_without_emitting(qtbot, target_panel):
    with qtbot.assertNotEmitted(target_panel.sigModeChanged):
        target_panel.set_mode(TargetMode.LISSAJOUS)
    assert target_panel.mode == "lissajous"
    assert target_panel.stack.currentIndex() == 2
    assert target_panel.mode_buttons["lissajous"].isChecked()


def test_moving_the_x_slider_emits_the_target_in_metres(qtbot, target_panel):
    x = target_panel.axes["x"]
    with qtbot.waitSignal(target_panel.sigManualTargetChanged, timeout=TIMEOUT_MS) as blocker:
        x.slider.setValue(-105)  # the slider counts millimetres
    x_m, y_m, z_m = blocker.args[0]
    assert close(x_m, -0.105)
    assert close((y_m, z_m), (target_panel.axes["y"].value_cm() / 100,
                              target_panel.axes["z"].value_cm() / 100))
    assert x.spin.value() == pytest.approx(-10.5)


def test_typing_12_3_in_the_spin_box_keeps_12_3_and_emits_0_123_m(qtbot, target_panel):
    spin = target_panel.axes["x"].spin
    spin.setFocus()
    spin.selectAll()
    qtbot.keyClicks(spin, "12.3")
    with qtbot.waitSignal(target_panel.sigManualTargetChanged, timeout=TIMEOUT_MS) as blocker:
        qtbot.keyClick(spin, QtCore.Qt.Key.Key_Return)
    assert close(blocker.args[0][0], 0.123)
    assert spin.value() == pytest.approx(12.3)
    assert spin.text() == "12.3"
    assert target_panel.axes["x"].slider.value() == 123


def test_slider_never_rounds_a_typed_value_on_a_coarse_range(qtbot, target_panel):
    target_panel.set_manual_ranges(-0.5, 0.5, -0.5, 0.5, 0.0, 0.5)
    spin = target_panel.axes["y"].spin
    with qtbot.waitSignal(target_panel.sigManualTargetChanged, timeout=TIMEOUT_MS) as blocker:
        spin.setValue(-37.7)
    assert spin.value() == pytest.approx(-37.7)
    assert close(blocker.args[0][1], -0.377)


def test_set_manual_target_updates_the_controls_and_emits_once(qtbot, target_panel):
    received = []
    target_panel.sigManualTargetChanged.connect(received.append)
    target_panel.set_manual_target((0.031, 0.152, 0.0))
    assert len(received) == 1
    assert close(received[0], (0.031, 0.152, 0.0))
    assert target_panel.axes["y"].spin.value() == pytest.approx(15.2)
    assert target_panel.axes["y"].slider.value() == 152


def test_set_manual_target_clamps_to_the_configured_ranges(qtbot, target_panel):
    target_panel.set_manual_ranges(-0.1, 0.1, 0.0, 0.2, 0.0, 0.3)
    received = []
    target_panel.sigManualTargetChanged.connect(received.append)
    target_panel.set_manual_target((0.5, -0.5, 0.1))
    assert close(received[-1], (0.1, 0.0, 0.1))
    with pytest.raises(ValueError, match="manual range x"):
        target_panel.set_manual_ranges(0.1, -0.1, 0, 1, 0, 1)


def test_lissajous_run_button_emits_true_then_false(qtbot, target_panel):
    target_panel.set_mode("lissajous")
    for expected in (True, False):
        with qtbot.waitSignal(target_panel.sigLissajousRunning, timeout=TIMEOUT_MS) as blocker:
            qtbot.mouseClick(target_panel.run_button, LEFT)
        assert blocker.args == [expected]
        assert target_panel.lissajous_running is expected
    assert "Run" in target_panel.run_button.text()


def test_lissajous_edits_emit_valid_params_in_si_units(qtbot, target_panel):
    centre, amplitude, frequency, phase = target_panel.lissajous_spins
    edits = [(centre[0], -50.0), (amplitude[0], 50.0), (amplitude[1], 0.0),
             (frequency[2], 2.0), (phase[0], -180.0), (phase[1], 180.0), (centre[2], 12.5)]
    params = None
    for spin, value in edits:
        with qtbot.waitSignal(target_panel.sigLissajousChanged, timeout=TIMEOUT_MS) as blocker:
            spin.setValue(value)
        params = blocker.args[0]
        assert isinstance(params, LissajousParams)
        LissajousParams(**asdict(params))  # re-validates
    assert close(params.centre, (-0.5, 0.15, 0.125))
    assert close(params.amplitude, (0.5, 0.0, 0.03))
    assert close(params.frequency_hz, (0.10, 0.20, 2.0))
    assert close(params.phase_rad, (-math.pi, math.pi, 0.0))


def test_set_lissajous_round_trips_without_emitting(qtbot, target_panel):
    params = LissajousParams(centre=(0.02, 0.18, 0.09), amplitude=(0.05, 0.04, 0.0),
                             frequency_hz=(0.25, 0.5, 0.0), phase_rad=(0.0, math.pi / 4, -1.0))
    with qtbot.assertNotEmitted(target_panel.sigLissajousChanged):
        target_panel.set_lissajous(params)
    back = target_panel.lissajous()
    assert close(back.centre, params.centre)
    assert close(back.amplitude, params.amplitude)
    assert close(back.frequency_hz, params.frequency_hz)
    assert close(back.phase_rad, (0.0, math.pi / 4, math.radians(-57.0)))  # 1° resolution


def test_follow_combo_keeps_the_selected_id_when_it_leaves_view(qtbot, target_panel):
    with qtbot.waitSignal(target_panel.sigFollowIdChanged, timeout=TIMEOUT_MS) as blocker:
        target_panel.set_marker_ids([23, 3])
    assert blocker.args == [3]  # first id seen is picked
    with qtbot.waitSignal(target_panel.sigFollowIdChanged, timeout=TIMEOUT_MS) as blocker:
        target_panel.follow_combo.setCurrentIndex(1)
    assert blocker.args == [23]
    with qtbot.assertNotEmitted(target_panel.sigFollowIdChanged):
        target_panel.set_marker_ids([3, 5])
    assert target_panel.follow_id == 23
    assert "not seen" in target_panel.follow_combo.currentText()
    with qtbot.waitSignal(target_panel.sigFollowIdChanged, timeout=TIMEOUT_MS) as blocker:
        target_panel.set_follow_id(5)
    assert blocker.args == [5]


def test_reach_status_turns_red_when_not_ok(target_panel):
    target_panel.set_reach_status("out of reach by 23 mm — going to the nearest point", False)
    assert "23 mm" in target_panel.reach_label.text()
    assert target_panel.reach_label.property("reach_ok") is False
    assert "background" in target_panel.reach_label.styleSheet()
    target_panel.set_reach_status("reachable", True)
    assert target_panel.reach_label.property("reach_ok") is True


# ------------------------------------------------------------------------------- CameraView
def test_display_toggle_emits_disparity_then_image(qtbot, camera_view):
    for expected in ("disparity", "image"):
        with qtbot.waitSignal(camera_view.sigDisplayModeChanged, timeout=TIMEOUT_MS) as blocker:
            qtbot.mouseClick(camera_view.toggle_button, LEFT)
        assert blocker.args == [expected]
        assert camera_view.display_mode == expected


def test_show_disparity_renders_with_a_colour_bar(qtbot, camera_view):
    camera_view.set_display_mode("disparity")
    disp = np.tile(np.linspace(-1.0, 80.0, 640, dtype=np.float32), (480, 1))
    disp[:10] = np.nan
    camera_view.show_disparity(disp, max_disparity=64.0)
    image = camera_view.grab().toImage()
    assert image.width() > 0
    camera_view.show_image(np.full((480, 640, 3), 255, np.uint8))  # ignored while in disparity
    assert camera_view.display_mode == "disparity"


def test_disparity_colours_invalid_pixels_black_and_valid_ones_not():
    disp = np.array([[-16.0, 0.0, np.nan, 0.01, 32.0, 64.0, 500.0]], np.float32)
    index = disparity_to_index(disp, 64.0)
    assert index.tolist() == [[0, 0, 0, 1, 128, 255, 255]]
    lut = disparity_lut()
    assert lut.shape == (256, 3)
    assert lut[0].tolist() == [0, 0, 0]
    assert lut[1:].sum(axis=1).min() > 0


def test_click_inside_a_marker_emits_its_id(qtbot, camera_view):
    camera_view.set_markers([
        MarkerOverlay(23, square(200, 200, 60), True, "23: x 3.1 y 15.2 z 0.0 cm"),
        MarkerOverlay(7, square(400, 150, 50), False, "7"),
    ])
    pixels = []
    camera_view.sigClicked.connect(lambda x, y: pixels.append((x, y)))
    with qtbot.waitSignal(camera_view.sigMarkerClicked, timeout=TIMEOUT_MS) as blocker:
        click_image(qtbot, camera_view, 230.0, 230.0)
    assert blocker.args == [23]
    assert len(pixels) == 1 and close(pixels[0], (230.0, 230.0), tol=2.0)
    with qtbot.waitSignal(camera_view.sigMarkerClicked, timeout=TIMEOUT_MS) as blocker:
        click_image(qtbot, camera_view, 425.0, 175.0)  # a lost (dashed) marker is clickable too
    assert blocker.args == [7]


def test_click_outside_markers_emits_only_the_pixel(qtbot, camera_view):
    camera_view.set_markers([MarkerOverlay(23, square(200, 200, 60), True, "")])
    with qtbot.assertNotEmitted(camera_view.sigMarkerClicked):
        with qtbot.waitSignal(camera_view.sigClicked, timeout=TIMEOUT_MS) as blocker:
            click_image(qtbot, camera_view, 100.0, 400.0)
    assert abs(blocker.args[0] - 100.0) < 2 and abs(blocker.args[1] - 400.0) < 2


def test_set_markers_reuses_slots_and_hides_the_rest(camera_view):
    camera_view.set_markers([MarkerOverlay(i, square(10 + 60 * i, 10, 40)) for i in range(3)])
    camera_view.set_markers([MarkerOverlay(9, square(300, 300, 40))])
    assert camera_view.marker_at(320, 320) == 9
    assert camera_view.marker_at(30, 30) is None  # marker 0 is gone


def test_fps_and_banner(camera_view):
    camera_view.set_fps(29.96)
    camera_view.set_banner("camera lost — retrying")
    assert camera_view.banner_text() == "camera lost — retrying"
    camera_view.set_banner(None)
    assert camera_view.banner_text() == ""
    camera_view.set_fps(float("nan"))


def test_marker_overlay_checks_corners_and_builds_from_observations():
    with pytest.raises(ValueError, match="shape"):
        MarkerOverlay(1, np.zeros((3, 2)))
    obs = MarkerObservation(marker_id=23, found=True,
                            left_corners=((0, 0), (10, 0), (10, 10), (0, 10)),
                            base_p_centre=(0.031, 0.152, 0.0))
    overlay = MarkerOverlay.from_observation(obs, "left")
    assert overlay.label == "23: x 3.1 y 15.2 z 0.0 cm"
    assert overlay.corners.shape == (4, 2)
    assert MarkerOverlay.from_observation(obs, "right") is None
    assert marker_label(5, None) == "5"


# ------------------------------------------------------------------------------- settings panels
def test_camera_settings_panel_emits_settings_after_a_slider_change(qtbot):
    panel = CameraSettingsPanel()
    qtbot.addWidget(panel)
    received = []
    panel.sigSettingsChanged.connect(received.append)
    with qtbot.waitSignal(panel.sigSettingsChanged, timeout=TIMEOUT_MS) as blocker:
        panel.sliders["gain"].setValue(3.0)  # a burst: only the last value is sent
        panel.sliders["gain"].setValue(6.0)
        panel.sliders["exposure"].setValue(-1.5)
    settings = blocker.args[0]
    assert isinstance(settings, CameraSettings)
    assert (settings.gain, settings.exposure) == (6.0, -1.5)
    assert received == [settings]


def test_camera_settings_set_and_reset(qtbot):
    panel = CameraSettingsPanel()
    qtbot.addWidget(panel)
    custom = CameraSettings(exposure=1.0, gain=12.0, brightness=-20.0, contrast=1.5)
    with qtbot.assertNotEmitted(panel.sigSettingsChanged):
        panel.set_settings(custom)
        panel.flush()
    assert panel.settings() == custom
    with qtbot.waitSignal(panel.sigSettingsChanged, timeout=TIMEOUT_MS) as blocker:
        qtbot.mouseClick(panel.reset_button, LEFT)
    assert blocker.args[0] == CameraSettings()


def test_sgbm_panel_snaps_every_slider_value_to_valid_params(qtbot):
    panel = SgbmPanel()
    qtbot.addWidget(panel)
    for box in panel.auto_boxes.values():
        box.setChecked(False)  # exercise the P1/P2 sliders too
    received = []
    panel.sigParamsChanged.connect(received.append)
    for spec in SGBM_SLIDERS:
        slider = panel.sliders[spec.name]
        span = spec.hi - spec.lo
        stride = 1 if span <= 300 else 97
        values = list(range(spec.lo - 20, spec.hi + 21, stride)) + [spec.lo, spec.hi]
        for value in values:
            slider.setValue(value)
            params = panel.params()  # SgbmParams validates on construction
            shown = getattr(params, spec.name)
            assert shown == slider.value(), (spec.name, value, shown, slider.value())
            if spec.snap == "mult16":
                assert shown % 16 == 0
            if spec.snap == "odd":
                assert shown % 2 == 1
        panel.flush()
    assert received, "no SgbmParams emitted"
    for params in received:
        assert isinstance(params, SgbmParams)
        SgbmParams(**asdict(params))


def test_sgbm_panel_throttles_and_emits_snapped_values(qtbot):
    panel = SgbmPanel()
    qtbot.addWidget(panel)
    received = []
    panel.sigParamsChanged.connect(received.append)
    with qtbot.waitSignal(panel.sigParamsChanged, timeout=TIMEOUT_MS) as blocker:
        panel.sliders["num_disparities"].setValue(100)  # → 96
        panel.sliders["block_size"].setValue(8)  # → 9
        panel.mode_combo.setCurrentText("HH")
    params = blocker.args[0]
    assert (params.num_disparities, params.block_size, params.mode) == (96, 9, "HH")
    assert len(received) == 1


def test_sgbm_auto_checkbox_means_zero(qtbot):
    panel = SgbmPanel()
    qtbot.addWidget(panel)
    assert panel.params().p1 == 0
    panel.auto_boxes["p1"].setChecked(False)
    panel.sliders["p1"].setValue(300)
    assert panel.params().p1 == 300
    assert panel.sliders["p1"].isEnabled()
    panel.auto_boxes["p1"].setChecked(True)
    assert panel.params().p1 == 0
    assert not panel.sliders["p1"].isEnabled()
    custom = SgbmParams(num_disparities=128, block_size=7, p1=100, p2=0, mode="HH4")
    with qtbot.assertNotEmitted(panel.sigParamsChanged):
        panel.set_params(custom)
        panel.flush()
    assert panel.params() == custom


# ------------------------------------------------------------------------------- ArmTwin
def test_side_view_projects_along_the_arm_azimuth():
    p = np.array([[0.0, 0.2, 0.1], [0.1, 0.0, 0.0]])
    assert close(side_view_coords(p, math.pi / 2), [[0.2, 0.1], [0.0, 0.0]])
    assert close(side_view_coords(p, -math.pi / 2), [[-0.2, 0.1], [0.0, 0.0]])
    assert close(side_view_coords(p, 0.0), [[0.0, 0.1], [0.1, 0.0]])


def test_arm_azimuth_prefers_measured_then_commanded_then_previous():
    commanded = np.array([[0, 0, 0], [0.1, 0.0, 0.1]])
    measured = np.array([[0, 0, 0], [0.0, 0.1, 0.1]])
    assert close(arm_azimuth(commanded, measured), math.pi / 2)
    assert close(arm_azimuth(commanded, None), 0.0)
    assert close(arm_azimuth(None, None, previous=1.0), 1.0)
    straight_up = np.array([[0, 0, 0], [0.0, 0.0, 0.2]])
    assert close(arm_azimuth(None, straight_up, previous=0.3), 0.3)


def test_arm_twin_accepts_arrays_and_none(qtbot):
    twin = ArmTwin()
    qtbot.addWidget(twin)
    twin.resize(SCREEN_W, SCREEN_H // 2)
    twin.show()
    chain = np.array([[0, 0, 0], [0, 0, 0.0662], [0.05, 0.05, 0.15], [0.1, 0.1, 0.1]])
    twin.set_view_range(0.25, 0.30)
    twin.set_arm(chain, chain + 0.005)
    twin.set_measured_label("commanded (no feedback)")
    twin.set_target((0.3, 0.3, 0.0), reachable=False)
    twin.set_aimed_point((0.14, 0.14, 0.02))
    ring = np.column_stack([np.cos(np.linspace(0, 6.3, 50)), np.sin(np.linspace(0, 6.3, 50))])
    twin.set_workspace(0.215 * ring, 0.215 * ring + (0, 0.0662))
    twin.set_preview(np.column_stack([np.linspace(-0.05, 0.05, 100), np.full(100, 0.15),
                                      np.full(100, 0.1)]))
    twin.set_markers({23: np.array([0.031, 0.152, 0.0]), 7: np.array([-0.08, 0.12, 0.0])})
    assert close(twin.azimuth, math.pi / 4)
    x_cm, y_cm = twin._top.measured.getData()
    assert close(x_cm, (chain[:, 0] + 0.005) * 100)
    s_cm, z_cm = twin._side.measured.getData()
    assert close(s_cm[-1], math.hypot(0.105, 0.105) * 100, tol=1e-6)
    assert "commanded (no feedback)" in twin.legend_text()
    twin.grab()
    # every input can be cleared
    twin.set_arm(None, None)
    twin.set_target(None, True)
    twin.set_aimed_point(None)
    twin.set_workspace(None, None)
    twin.set_preview(None)
    twin.set_markers({})
    assert close(twin.azimuth, math.pi / 4)  # kept
    assert len(twin._top.measured.getData()[0] or []) == 0
    twin.grab()


def test_arm_twin_views_sit_side_by_side_when_wide_and_stacked_when_tall(qtbot):
    twin = ArmTwin()
    qtbot.addWidget(twin)
    twin.show()
    twin.resize(800, 300)
    qtbot.waitUntil(lambda: twin.side_plot.x() > twin.top_plot.x(), timeout=TIMEOUT_MS)
    twin.resize(300, 600)
    qtbot.waitUntil(lambda: twin.side_plot.y() > twin.top_plot.y() + 100, timeout=TIMEOUT_MS)


# ------------------------------------------------------------------------------- joints, status
def test_limit_level_marks_joints_near_and_at_limits():
    assert limit_level(90.0, 0.0, 180.0) == "ok"
    assert limit_level(170.0, 0.0, 180.0) == "near"
    assert limit_level(179.0, 0.0, 180.0) == "at"
    assert limit_level(1.0, 0.0, 180.0) == "at"
    assert limit_level(None, 0.0, 180.0) == "ok"


def test_joint_readout_shows_values_and_limit_levels(qtbot):
    readout = JointReadout()
    qtbot.addWidget(readout)
    readout.set_joints(["base", "shoulder", "elbow"], [0, 15, 0], [180, 165, 180])
    readout.set_values([90.0, 150.0, 120.0], [91.0, 164.5, None])
    assert readout.levels() == ["ok", "at", "ok"]
    readout.set_values(None, None)
    assert readout.levels() == ["ok", "ok", "ok"]
    with pytest.raises(ValueError, match="same count"):
        readout.set_joints(["a"], [0, 1], [2])
    readout.set_joints(["a", "b"], [0, 0], [180, 180])  # re-layout works
    readout.set_values([5.0, 170.0], None)
    assert readout.levels() == ["near", "near"]


def test_status_bar_items_and_banner(qtbot):
    window = QtWidgets.QMainWindow()
    qtbot.addWidget(window)
    items = StatusBarItems(window.statusBar())
    items.update("sim://desk", "lost — retrying", 29.96, 48.4)
    assert items.fps_label.text() == "30.0 fps"
    assert items.latency_label.text() == "latency 48 ms"
    assert "lost" in items.bridge_label.text()
    banner = Banner()
    qtbot.addWidget(banner)
    banner.show_message("SIMULATED DESK — no camera found", "warn")
    assert not banner.isHidden() and banner.level == "warn"
    banner.clear()
    assert banner.isHidden() and banner.text() == ""
    with pytest.raises(ValueError, match="level"):
        banner.show_message("x", "panic")


# ------------------------------------------------------------------------------- sizes
PANEL_FACTORIES = {
    "TargetPanel": TargetPanel,
    "CameraSettingsPanel": CameraSettingsPanel,
    "SgbmPanel": SgbmPanel,
    "JointReadout": JointReadout,
    "ArmTwin": ArmTwin,
    "CameraView": CameraView,
}


@pytest.mark.parametrize("name", sorted(PANEL_FACTORIES))
def test_panel_fits_800x480_and_has_finger_sized_controls(qtbot, name):
    panel = PANEL_FACTORIES[name]()
    if isinstance(panel, JointReadout):
        panel.set_joints(["base", "shoulder", "elbow"], [0, 15, 0], [180, 165, 180])
    hint = panel.minimumSizeHint()
    assert hint.width() <= SCREEN_W and hint.height() <= SCREEN_H, (name, hint)
    area = QtWidgets.QScrollArea()
    area.setWidgetResizable(True)
    area.setWidget(panel)
    qtbot.addWidget(area)
    area_hint = area.minimumSizeHint()
    assert area_hint.width() <= SCREEN_W and area_hint.height() <= SCREEN_H, (name, area_hint)
    area.resize(SCREEN_W, SCREEN_H)
    area.show()
    qtbot.waitExposed(area)
    touch_types = (QtWidgets.QPushButton, QtWidgets.QSlider, QtWidgets.QComboBox,
                   QtWidgets.QAbstractSpinBox, QtWidgets.QCheckBox)
    for control in panel.findChildren(QtWidgets.QWidget):
        if isinstance(control, touch_types) and control.isVisibleTo(panel):
            assert control.height() >= TOUCH_MIN_PX, (name, type(control).__name__,
                                                      control.height())
