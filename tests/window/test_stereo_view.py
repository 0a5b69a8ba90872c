"""The Stereo tab and the disparity view: matcher choice, WLS, half resolution, presets per camera
pair, the depth legend and the depth probe under a tap (pytest-qt, offscreen)."""
from __future__ import annotations

import numpy as np
import pytest
from PySide6 import QtCore, QtWidgets

import widgets  # noqa: F401
from core.settings import SgbmParams, StereoMatchParams
from core.vision.disparity import list_presets, load_preset, presets_path
from widgets.stereo_panel import StereoPanel

TIMEOUT_MS = 3000
LEFT = QtCore.Qt.MouseButton.LeftButton


@pytest.fixture
def panel(qtbot) -> StereoPanel:
    p = StereoPanel()
    qtbot.addWidget(p)
    p.resize(400, 900)
    p.show()
    return p


def test_bm_hides_the_sgbm_only_controls_and_shows_its_own(qtbot, panel):
    assert panel.match_params() == StereoMatchParams()
    assert panel.sgbm.mode_combo.isVisibleTo(panel) and not panel.prefilter_combo.isVisibleTo(panel)
    with qtbot.waitSignal(panel.sigMatchParamsChanged, timeout=TIMEOUT_MS) as blocker:
        qtbot.mouseClick(panel.matcher_buttons["BM"], LEFT)
    assert blocker.args[0].matcher == "BM"
    assert not panel.sgbm.mode_combo.isVisibleTo(panel) and not panel.sgbm.sliders["p1"].isVisibleTo(panel)
    assert panel.prefilter_combo.isVisibleTo(panel) and panel.texture_threshold.isVisibleTo(panel)
    with qtbot.waitSignal(panel.sigMatchParamsChanged, timeout=TIMEOUT_MS) as blocker:
        panel.prefilter_combo.setCurrentIndex(1)
        panel.prefilter_size.setValue(20)  # even: snapped to 21
        panel.texture_threshold.setValue(150)
    m = blocker.args[0]
    assert (m.bm_prefilter, m.bm_prefilter_size, m.bm_texture_threshold) == ("NORMALIZED_RESPONSE", 21, 150)


def test_wls_with_lambda_and_sigma_and_half_resolution(qtbot, panel):
    assert not panel.wls_lambda.isEnabled()
    with qtbot.waitSignal(panel.sigMatchParamsChanged, timeout=TIMEOUT_MS) as blocker:
        panel.wls_box.click()
        panel.wls_lambda.setValue(2540)  # to the 100 grid
        panel.wls_sigma.setValue(1.234)
        panel.half_box.click()
    m = blocker.args[0]
    assert (m.wls, m.wls_lambda, m.wls_sigma, m.half_resolution) == (True, 2500.0, 1.23, True)
    assert panel.wls_lambda.isEnabled()


def test_block_matching_sliders_still_emit_sgbm_params(qtbot, panel):
    with qtbot.waitSignal(panel.sigParamsChanged, timeout=TIMEOUT_MS) as blocker:
        panel.sgbm.sliders["num_disparities"].setValue(100)
        panel.sgbm.mode_combo.setCurrentText("HH")
    assert (blocker.args[0].num_disparities, blocker.args[0].mode) == (96, "HH")


def test_set_all_shows_a_preset_without_emitting(qtbot, panel):
    sgbm = SgbmParams(num_disparities=128, block_size=7, mode="SGBM")
    match = StereoMatchParams(matcher="BM", wls=True, wls_lambda=800.0, wls_sigma=1.1, half_resolution=True)
    with qtbot.assertNotEmitted(panel.sigMatchParamsChanged, wait=120):
        with qtbot.assertNotEmitted(panel.sigParamsChanged, wait=0):
            panel.set_all(sgbm, match)
            panel.flush()
    assert panel.params() == sgbm and panel.match_params() == match
    assert panel.prefilter_combo.isVisibleTo(panel)


def test_preset_buttons_ask_with_the_typed_name(qtbot, panel):
    panel.set_presets([])
    assert not panel.load_preset_button.isEnabled()
    qtbot.mouseClick(panel.save_preset_button, LEFT)  # no name yet: says so instead
    assert "type a name" in panel.preset_status.text()
    panel.preset_combo.setEditText("bright desk")
    with qtbot.waitSignal(panel.sigPresetSaveRequested, timeout=TIMEOUT_MS) as blocker:
        qtbot.mouseClick(panel.save_preset_button, LEFT)
    assert blocker.args == ["bright desk"]


def test_stereo_panel_fits_the_touch_screen(qtbot):
    panel = StereoPanel()
    area = QtWidgets.QScrollArea()
    area.setWidgetResizable(True)
    area.setWidget(panel)
    qtbot.addWidget(area)
    hint = area.minimumSizeHint()
    assert hint.width() <= 420 and hint.height() <= 480, hint  # the tab is ~40 % of 800 px
    area.resize(400, 480)
    area.show()
    qtbot.waitExposed(area)
    for control in panel.findChildren(QtWidgets.QWidget):
        if isinstance(control, (QtWidgets.QPushButton, QtWidgets.QSlider, QtWidgets.QComboBox,
                                QtWidgets.QCheckBox)) and control.isVisibleTo(panel):
            assert control.height() >= 40, (type(control).__name__, control.height())


# ------------------------------------------------------------------------------- in the window
@pytest.fixture
def window(qtbot, tmp_path, monkeypatch):
    from app.gui import MainWindow
    from core.session import DeskSession, SessionOptions

    monkeypatch.setenv("DESKARM_HOME", str(tmp_path / "home"))
    w = MainWindow(DeskSession.create(SessionOptions(camera="sim", scenario="static")))
    qtbot.addWidget(w)
    w.resize(800, 480)
    w.show()
    w.start()
    yield w
    w.stop()


def wait_for_disparity(qtbot, window, predicate=lambda r: True):
    """Until the window holds a result with a disparity map that satisfies ``predicate``.

    Polls the window's own slot state instead of connecting a blocker to the worker's 30 Hz
    signal: queued emissions reaching a finished pytest-qt blocker can crash the interpreter.
    """
    qtbot.waitUntil(lambda: window._result is not None and window._result.disparity is not None
                    and predicate(window._result), timeout=TIMEOUT_MS)


def click_image(qtbot, view, x_px, y_px):
    pos = view.graphics_view.viewport().mapFrom(view, view.image_to_widget(x_px, y_px))
    qtbot.mouseClick(view.graphics_view.viewport(), LEFT, pos=pos)


def test_tapping_the_disparity_view_shows_depth_in_mm_and_the_base_point_in_cm(qtbot, window):
    qtbot.mouseClick(window.view_left.toggle_button, LEFT)
    wait_for_disparity(qtbot, window, lambda r: r.marker(23) is not None and r.marker(23).found)
    r = window._result
    marker = r.marker(23)
    # the disparity map is in the rectified left view: tap where the marker's centre is there
    centre = window.session.perception.rectify_points("left", np.asarray(marker.left_corners)).mean(axis=0)
    window._dirty = True
    window.redraw()
    click_image(qtbot, window.view_left, float(centre[0]), float(centre[1]))
    sample = window.depth_sample
    assert sample is not None
    truth = np.asarray(marker.base_p_centre)  # the marker lies on the desk: the disparity sees it
    assert np.linalg.norm(np.asarray(sample.base_p) - truth) < 0.015, (sample.base_p, truth)
    assert sample.depth_mm == pytest.approx(np.asarray(marker.camera_p_centre)[2] * 1e3, abs=15)
    text = window.view_left.probe_text()
    assert f"{sample.depth_mm:.0f} mm" in text and " cm" in text and "x " in text
    # in the 800x480 window the text stays in the image, off the colour bar (tests/window/test_text_fit.py)
    view = window.view_left
    probe = view.overlay_widgets()["probe"]
    assert view.image_rect().contains(probe.geometry()), (probe.geometry(), view.image_rect())
    assert not probe.geometry().intersects(view.colour_bar_rect())
    assert "Depth at" in window.stereo_panel.depth_label.text()
    # image mode: the probe is hidden, taps go to the markers again
    qtbot.mouseClick(window.view_left.toggle_button, LEFT)
    assert window.view_left.probe_text() == ""


def test_legend_shows_depth_and_follows_the_disparity_range(qtbot, window):
    legend = window.view_left.depth_legend
    assert [d for d, _ in legend] == pytest.approx([0, 16, 32, 48, 64])
    assert legend[0][1].endswith("∞") and "cm" in legend[-1][1] and legend[-1][1].startswith("64 px")
    with qtbot.waitSignal(window.stereo_panel.sigParamsChanged, timeout=TIMEOUT_MS):
        window.stereo_panel.sgbm.sliders["num_disparities"].setValue(128)
    assert window.view_left.depth_legend[-1][0] == 128
    assert window.view_right.depth_legend == window.view_left.depth_legend


def test_matcher_wls_and_half_resolution_reach_the_disparity_computer(qtbot, window):
    panel = window.stereo_panel
    qtbot.mouseClick(window.view_left.toggle_button, LEFT)
    panel.matcher_buttons["BM"].click()
    panel.wls_box.click()
    panel.half_box.click()
    panel.flush()
    p = window.workers.perception
    wait_for_disparity(qtbot, window, lambda r: p.disparity.match.matcher == "BM" and p.disparity.match.wls
                       and p.disparity.match.half_resolution)
    assert window._result.disparity.shape == (480, 640)  # half resolution is scaled back


def test_presets_are_saved_loaded_and_deleted_per_camera_pair(qtbot, window):
    panel, pair = window.stereo_panel, window.session.camera.pair_id
    panel.sgbm.sliders["block_size"].setValue(9)
    panel.matcher_buttons["BM"].click()
    panel.preset_combo.setEditText("shiny")
    qtbot.mouseClick(panel.save_preset_button, LEFT)
    assert presets_path().is_file() and list_presets(pair) == ["shiny"]
    assert load_preset(pair, "shiny") == (panel.params(), panel.match_params())
    assert "saved" in panel.preset_status.text()
    # change everything, then load it back: the panel and the worker get the preset
    panel.set_all(SgbmParams(), StereoMatchParams())
    panel.preset_combo.setEditText("shiny")
    qtbot.mouseClick(panel.load_preset_button, LEFT)
    assert panel.params().block_size == 9 and panel.match_params().matcher == "BM"
    p = window.workers.perception
    seq = window._result.seq if window._result is not None else -1
    # a frame computed after the load: the worker took the preset before reading it
    qtbot.waitUntil(lambda: window._result is not None and window._result.seq > seq + 1
                    and p.disparity.params.block_size == 9, timeout=TIMEOUT_MS)
    assert list_presets("another pair") == []  # stored per camera pair
    qtbot.mouseClick(panel.delete_preset_button, LEFT)
    assert list_presets(pair) == [] and "deleted" in panel.preset_status.text()


def test_the_window_starts_with_the_pairs_active_preset(qtbot, tmp_path, monkeypatch):
    from app.gui import MainWindow
    from core.session import DeskSession, SessionOptions
    from core.vision.disparity import save_preset

    monkeypatch.setenv("DESKARM_HOME", str(tmp_path / "home"))
    save_preset("sim", SgbmParams(num_disparities=96), StereoMatchParams(wls=True), "wide")
    w = MainWindow(DeskSession.create(SessionOptions(camera="sim", scenario="static")))
    qtbot.addWidget(w)
    try:
        assert w.stereo_panel.params().num_disparities == 96 and w.stereo_panel.match_params().wls
        assert w.stereo_panel.preset_name() == "wide"
        assert w.view_left.depth_legend[-1][0] == 96
    finally:
        w.session.close()
