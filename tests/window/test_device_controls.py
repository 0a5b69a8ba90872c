"""The device controls panel, alone with a fake control list and in the window with a fake webcam."""
from __future__ import annotations

import threading
from dataclasses import replace

import pytest
from PySide6 import QtCore, QtWidgets

import widgets  # noqa: F401
from core.sim.camera import SimStereoCamera
from core.vision.cameras import CameraControl
from widgets.device_controls import DeviceControlsPanel

TIMEOUT_MS = 3000
LEFT = QtCore.Qt.MouseButton.LeftButton


def fake_controls() -> list[CameraControl]:
    """What a UVC webcam reports (focus without a known range)."""
    return [
        CameraControl("exposure", "Exposure", 3, 2047, 1, 250, 156, auto=True),
        CameraControl("gain", "Gain", 0, 255, 1, 0, 32),
        CameraControl("brightness", "Brightness", -64, 64, 1, 0, 0),
        CameraControl("contrast", "Contrast", 0, 95, 1, 32, 32),
        CameraControl("saturation", "Saturation", 0, 100, 1, 64, 64),
        CameraControl("white_balance", "White balance (K)", 2800, 6500, 10, 4600, 4600, auto=False),
        CameraControl("focus", "Focus", 0, 250, 5, 0, 0, auto=True, range_known=False),
    ]


@pytest.fixture
def panel(qtbot) -> DeviceControlsPanel:
    p = DeviceControlsPanel()
    qtbot.addWidget(p)
    p.set_controls(fake_controls())
    p.resize(400, 480)
    p.show()
    return p


def test_one_trackbar_per_control_with_the_device_range_and_auto_where_there_is_one(panel):
    assert list(panel.rows) == ["exposure", "gain", "brightness", "contrast", "saturation", "white_balance", "focus"]
    exposure = panel.rows["exposure"]
    assert (exposure.slider.minimum(), exposure.slider.maximum(), exposure.slider.value()) == (3, 2047, 156)
    assert panel.rows["brightness"].slider.minimum() == -64
    assert [n for n, r in panel.rows.items() if r.auto is not None] == ["exposure", "white_balance", "focus"]
    assert not exposure.slider.isEnabled()  # automatic: the camera sets it
    assert panel.rows["white_balance"].slider.isEnabled()
    assert panel.rows["focus"].label.text().endswith("*") and panel.note.isVisibleTo(panel)
    assert panel.message.isHidden()


def test_moving_a_slider_requests_the_clamped_value_once_per_burst(qtbot, panel):
    got = []
    panel.sigControlRequested.connect(lambda name, value: got.append((name, value)))
    with qtbot.waitSignal(panel.sigControlRequested, timeout=TIMEOUT_MS) as blocker:
        panel.rows["white_balance"].slider.setValue(3333)
        panel.rows["white_balance"].slider.setValue(5004)  # step 10 -> 5000
    assert blocker.args == ["white_balance", 5000.0]
    assert got == [("white_balance", 5000.0)]


def test_auto_checkbox_requests_the_mode_and_frees_the_slider(qtbot, panel):
    row = panel.rows["exposure"]
    with qtbot.waitSignal(panel.sigAutoRequested, timeout=TIMEOUT_MS) as blocker:
        row.auto.click()
    assert blocker.args == ["exposure", False] and row.slider.isEnabled()
    with qtbot.waitSignal(panel.sigAutoRequested, timeout=TIMEOUT_MS) as blocker:
        row.auto.click()
    assert blocker.args == ["exposure", True] and not row.slider.isEnabled()


def test_show_applied_shows_what_the_device_took_without_requesting_again(qtbot, panel):
    gain = fake_controls()[1]
    with qtbot.assertNotEmitted(panel.sigControlRequested, wait=150):
        panel.show_applied(replace(gain, value=200.0))
        panel.flush()
    assert panel.rows["gain"].slider.value() == 200


def test_no_controls_and_a_refresh_request(qtbot, panel):
    panel.set_controls([])
    assert panel.rows == {} and "no adjustable controls" in panel.message.text()
    with qtbot.waitSignal(panel.sigRefreshRequested, timeout=TIMEOUT_MS):
        qtbot.mouseClick(panel.refresh_button, LEFT)


def test_panel_fits_800x480_and_has_finger_sized_controls(qtbot):
    panel = DeviceControlsPanel(fake_controls())
    area = QtWidgets.QScrollArea()
    area.setWidgetResizable(True)
    area.setWidget(panel)
    qtbot.addWidget(area)
    hint = area.minimumSizeHint()
    assert hint.width() <= 800 and hint.height() <= 480, hint
    area.resize(400, 480)
    area.show()
    qtbot.waitExposed(area)
    for control in panel.findChildren(QtWidgets.QWidget):
        if isinstance(control, (QtWidgets.QPushButton, QtWidgets.QSlider, QtWidgets.QCheckBox)) \
                and control.isVisibleTo(panel):
            assert control.height() >= 40, (type(control).__name__, control.height())


# ------------------------------------------------------------------------------- in the window
class FakeWebcams(SimStereoCamera):
    """The simulated desk's pictures, but controls like a webcam pair's: the device accepts only
    multiples of 5 for the gain, and it can be 'unplugged'."""

    kind = "fake-webcam"

    def __init__(self, **kw):
        super().__init__(**kw)
        self.values = {c.name: c for c in fake_controls()}
        self.unplugged = threading.Event()
        self.calls: list[tuple] = []

    @property
    def name(self) -> str:
        return "fake webcams 0,2"

    @property
    def pair_id(self) -> str:
        return "webcam:0,2"

    @property
    def is_connected(self) -> bool:
        return super().is_connected and not self.unplugged.is_set()

    def read(self):
        if self.unplugged.is_set():
            self.status_message = "camera 0 unplugged or not delivering frames — retrying every 1 s"
            threading.Event().wait(0.01)
            return None
        return super().read()

    def controls(self, side: str = "left"):
        return list(self.values.values())

    def set_control(self, name, value, side="both"):
        self.calls.append(("value", name, value, threading.current_thread() is threading.main_thread()))
        c = self.values[name]
        v = c.clamp(value)
        if name == "gain":
            v = 5 * round(v / 5)
        self.values[name] = replace(c, value=float(v), auto=False if c.auto is not None else None)
        return self.values[name]

    def set_auto(self, name, on, side="both"):
        self.calls.append(("auto", name, on, threading.current_thread() is threading.main_thread()))
        self.values[name] = replace(self.values[name], auto=bool(on))
        return self.values[name]


@pytest.fixture
def window(qtbot):
    from app.gui import MainWindow
    from core.session import DeskSession, SessionOptions

    session = DeskSession.create(SessionOptions(camera="sim", scenario="static"))
    session.camera.disconnect()
    session.camera = FakeWebcams()
    session.camera.connect()
    w = MainWindow(session)
    qtbot.addWidget(w)
    w.resize(800, 480)
    w.show()
    with qtbot.waitSignal(w.workers.perception.sigControls, timeout=TIMEOUT_MS):
        w.start()
    yield w
    w.stop()
    session.close()  # an open simulated camera keeps rendering in its thread until Python exits


def test_window_builds_the_panel_from_the_device_and_applies_requests_in_the_worker(qtbot, window):
    assert window.camera_panel is None and window.device_panel is not None
    panel = window.device_panel
    qtbot.waitUntil(lambda: len(panel.rows) == 7, timeout=TIMEOUT_MS)
    with qtbot.waitSignal(window.workers.perception.sigControlApplied, timeout=TIMEOUT_MS) as blocker:
        panel.rows["gain"].slider.setValue(33)
        panel.flush()
    applied = blocker.args[0]
    assert applied.name == "gain" and applied.value == 35.0  # what the device accepted
    qtbot.waitUntil(lambda: panel.rows["gain"].slider.value() == 35, timeout=TIMEOUT_MS)
    cam = window.session.camera
    assert cam.calls[-1] == ("value", "gain", 33.0, False)  # set in the worker, not the GUI thread
    with qtbot.waitSignal(window.workers.perception.sigControlApplied, timeout=TIMEOUT_MS):
        panel.rows["exposure"].auto.click()
    assert cam.calls[-1][:3] == ("auto", "exposure", False)


def test_unplugging_shows_the_banner_and_replugging_resumes(qtbot, window):
    p = window.workers.perception
    cam = window.session.camera
    with qtbot.waitSignal(p.sigError, timeout=TIMEOUT_MS, check_params_cb=bool):
        cam.unplugged.set()
    assert "camera lost" in window.banner.text() and "unplugged" in window.banner.text()
    assert "camera not delivering frames" in window.device_panel.message.text()
    with qtbot.waitSignal(p.sigControls, timeout=TIMEOUT_MS):  # controls are read again once back
        with qtbot.waitSignal(p.sigError, timeout=TIMEOUT_MS, check_params_cb=lambda m: m == ""):
            cam.unplugged.clear()
    assert "camera lost" not in window.banner.text()
    seq = window._result.seq if window._result is not None else -1
    qtbot.waitUntil(lambda: window._result is not None and window._result.seq > seq,
                    timeout=TIMEOUT_MS)  # frames flow again


# ------------------------------------------------------------------------------- saved values
def test_values_and_auto_states_read_what_the_panel_shows(panel):
    assert panel.values() == {"exposure": 156.0, "gain": 32.0, "brightness": 0.0, "contrast": 32.0,
                              "saturation": 64.0, "white_balance": 4600.0, "focus": 0.0}
    assert panel.auto_states() == {"exposure": True, "white_balance": False, "focus": True}


def test_request_values_asks_for_what_differs_autos_first_and_shows_it(qtbot, panel):
    got = []
    panel.sigControlRequested.connect(lambda name, value: got.append(("value", name, value)))
    panel.sigAutoRequested.connect(lambda name, on: got.append(("auto", name, on)))
    requested = panel.request_values(
        {"gain": 33.4, "brightness": 0.0, "exposure": 300.0, "focus": 50.0, "zoom": 3.0},
        {"exposure": False})
    # brightness is already 0, focus stays automatic, the camera has no zoom; gain snaps to its step
    assert requested == {"gain": 33.0, "exposure": 300.0}
    assert got == [("auto", "exposure", False), ("value", "exposure", 300.0), ("value", "gain", 33.0)]
    assert panel.rows["exposure"].slider.isEnabled() and panel.values()["exposure"] == 300.0
    with qtbot.assertNotEmitted(panel.sigControlRequested, wait=150):
        panel.flush()  # nothing left pending: each value was sent once


def test_set_controls_tells_that_the_rows_were_rebuilt(qtbot, panel):
    with qtbot.waitSignal(panel.sigControlsRebuilt, timeout=TIMEOUT_MS):
        panel.set_controls(fake_controls()[:2])
    assert list(panel.rows) == ["exposure", "gain"]


@pytest.fixture
def window_with_saved_controls(qtbot, tmp_path, monkeypatch):
    """The fake webcams' window with saved controls for its pair, restored before it starts."""
    from app.gui import MainWindow
    from core.preferences import Preferences, save_preferences
    from core.session import DeskSession, SessionOptions

    monkeypatch.setenv("DESKARM_HOME", str(tmp_path / "home"))
    save_preferences(Preferences(camera_controls={"webcam:0,2": {"gain": 42.0, "exposure": 500.0},
                                                  "webcam:4,6": {"gain": 99.0}},
                                 camera_auto={"webcam:0,2": {"exposure": False}}))
    session = DeskSession.create(SessionOptions(camera="sim", scenario="static"))
    session.camera.disconnect()
    session.camera = FakeWebcams()
    session.camera.connect()
    w = MainWindow(session)
    qtbot.addWidget(w)
    w.resize(800, 480)
    w.show()
    prefs = w.preferences
    prefs.restore()
    with qtbot.waitSignal(w.workers.perception.sigControls, timeout=TIMEOUT_MS):
        w.start()
    yield w, prefs
    w.stop()
    session.close()


def test_saved_controls_are_requested_again_when_the_camera_lists_its_controls(qtbot, window_with_saved_controls):
    window, prefs = window_with_saved_controls
    cam, panel = window.session.camera, window.device_panel
    # exposure: automatic off first, then the value; gain 42 becomes 40 on this device (steps of 5)
    qtbot.waitUntil(lambda: panel.rows.get("gain") is not None and panel.rows["gain"].slider.value() == 40,
                    timeout=TIMEOUT_MS)
    qtbot.waitUntil(lambda: cam.values["exposure"].value == 500.0, timeout=TIMEOUT_MS)
    asked = [c[:3] for c in cam.calls]
    assert asked.index(("auto", "exposure", False)) < asked.index(("value", "exposure", 500.0))
    assert ("value", "gain", 42.0) in asked and all(not c[3] for c in cam.calls)  # in the worker
    assert not prefs._saver.pending  # re-applying saved values is not a change
    # the user's own move is remembered for this pair (and only this pair)
    with qtbot.waitSignal(panel.sigControlRequested, timeout=TIMEOUT_MS):
        panel.rows["white_balance"].slider.setValue(5000)
    assert prefs.prefs.camera_controls["webcam:0,2"] == {"gain": 42.0, "exposure": 500.0, "white_balance": 5000.0}
    assert prefs.prefs.camera_controls["webcam:4,6"] == {"gain": 99.0}
    assert prefs._saver.pending
    # after a replug or a refresh the camera lists its controls again: asked again
    cam.values["gain"] = replace(cam.values["gain"], value=0.0)
    before = len(cam.calls)
    with qtbot.waitSignal(window.workers.perception.sigControls, timeout=TIMEOUT_MS):
        window.on_controls_refresh()
    qtbot.waitUntil(lambda: ("value", "gain", 42.0) in [c[:3] for c in cam.calls[before:]], timeout=TIMEOUT_MS)
