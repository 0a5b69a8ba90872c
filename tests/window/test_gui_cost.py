"""The window's GUI thread does less per frame (issue 28, a Pi 4 core's budget) without drawing
anything else (pytest-qt, offscreen): a marker's new position in the twin's legend lays out
nothing but the legend, the twin's still parts (grid, workspace, desk, axes) are drawn from a
cached pixmap and drawn again when they do change, a scatter's bounds are worked out once per
data and view and its few symbols are painted with the very pixels pyqtgraph paints, a frame
projects the side view's markers once, and a camera view's new fps waits for the next frame's
repaint instead of repainting the image under it.

Widgets are driven through their public calls in the GUI thread; events are counted with event
filters, and waits are on conditions, never on time.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from PySide6 import QtCore, QtWidgets

import widgets  # noqa: F401  (sets pyqtgraph's row-major image order)
from core.kinematics import build_kinematics, load_profile
from widgets._pyqtgraph import pg
from app.window_draw import draw_twin
from widgets.arm_twin import ArmTwin, side_view_coords
from widgets.camera_view import FPS_WITH_FRAME_S, CameraView

TIMEOUT_MS = 5000
CHAIN = np.array([[0, 0, 0], [0, 0, 0.0662], [0.05, 0.05, 0.15], [0.1, 0.1, 0.1]])


class EventCount(QtCore.QObject):
    """Counts the events of one type that reach one object."""

    def __init__(self, watched: QtCore.QObject, kind: QtCore.QEvent.Type) -> None:
        super().__init__()
        self.count, self._kind, self._watched = 0, kind, watched
        watched.installEventFilter(self)

    def eventFilter(self, obj, event) -> bool:  # noqa: N802 (Qt override)
        if event.type() == self._kind:
            self.count += 1
        return False

    def remove(self) -> None:
        self._watched.removeEventFilter(self)


def fps_text(view: CameraView) -> str:
    return view.overlay_widgets()["fps"].text()


def drain() -> None:
    """Deliver what is posted (layout requests, updates) — twice: one pass may post the next."""
    for _ in range(3):
        QtWidgets.QApplication.processEvents()


@pytest.fixture
def twin_in_window(qtbot):
    """An arm twin in a window with a layout, as the main window holds it."""
    window = QtWidgets.QWidget()
    layout = QtWidgets.QVBoxLayout(window)
    twin = ArmTwin()
    layout.addWidget(twin)
    qtbot.addWidget(window)
    window.resize(440, 200)
    window.show()
    qtbot.waitExposed(window)
    yield window, twin
    window.close()


# ------------------------------------------------------------------------------- the legend
def test_a_marker_moving_in_the_legend_lays_out_neither_the_twin_nor_the_window(qtbot, twin_in_window):
    window, twin = twin_in_window
    twin.set_markers({23: np.array([0.031, 0.152, 0.0])})
    qtbot.waitUntil(lambda: "23: x 3.1 y 15.2 z 0.0 cm" in twin.legend_text(), timeout=TIMEOUT_MS)
    drain()
    lines, height = twin.legend_label.line_count(), twin.legend_label.height()
    twin_layouts = EventCount(twin, QtCore.QEvent.Type.LayoutRequest)
    window_layouts = EventCount(window, QtCore.QEvent.Type.LayoutRequest)
    try:
        for k in range(1, 6):  # the marker moves a little, frame after frame
            twin.set_markers({23: np.array([0.031 + 0.001 * k, 0.152, 0.0])})
            drain()
        assert "23: x 3.6 y 15.2 z 0.0 cm" in twin.legend_text()  # the legend shows where it is
        assert twin.legend_label.line_count() == lines and twin.legend_label.height() == height
        assert (twin_layouts.count, window_layouts.count) == (0, 0)
    finally:
        twin_layouts.remove()
        window_layouts.remove()
    label = twin.legend_label  # a legend that needs more lines still grows to show them
    twin.set_markers({i: np.array([0.01 * i, 0.15, 0.0]) for i in range(20, 26)})
    assert label.line_count() > lines
    qtbot.waitUntil(lambda: label.height() >= label.sizeHint().height() > height, timeout=TIMEOUT_MS)
    assert all(f"{i}: x" in twin.legend_text() for i in range(20, 26))


# ------------------------------------------------------------------------------- the twin's items
def still_items(twin: ArmTwin) -> list:
    items = []
    for view, plot in ((twin._top, twin.top_plot), (twin._side, twin.side_plot)):
        items += [view.workspace, view.structure, view.keep_out, view.base]
        items += [item for item in plot.getPlotItem().items if isinstance(item, pg.PlotCurveItem)
                  and item.opts["connect"] == "pairs"]  # the grid
        items += [plot.getPlotItem().getAxis(side) for side in ("left", "bottom")]
    items += [twin._margin_line.curve] + [item.curve for item in twin.side_plot.getPlotItem().items
                                          if isinstance(item, pg.PlotDataItem) and item.opts["fillLevel"] == -1e4]
    return items


def test_the_twins_still_parts_are_drawn_from_a_cache_and_a_new_profile_redraws_them(qtbot):
    """The grid, workspace, structure, keep-out boxes, base and axes keep a cached pixmap, and
    one twin switched to another profile draws exactly what a twin made for it draws."""
    twins = []
    for _ in range(2):
        twin = ArmTwin()
        qtbot.addWidget(twin)
        twin.resize(440, 170)
        twin.show()
        qtbot.waitExposed(twin)
        twins.append(twin)
    switched, fresh = twins
    cached = QtWidgets.QGraphicsItem.CacheMode.DeviceCoordinateCache
    assert all(item.cacheMode() == cached for item in still_items(switched))
    rrr, rtx = load_profile("desk_rrr"), load_profile("umi_rtx")
    switched.configure_for(rrr, build_kinematics(rrr))
    drain()
    switched.grab()  # the desk arm's still parts are in the caches now
    rtx_kinematics = build_kinematics(rtx)
    switched.configure_for(rtx, rtx_kinematics)
    fresh.configure_for(rtx, rtx_kinematics)
    drain()
    a, b = switched.grab().toImage(), fresh.grab().toImage()
    assert a.size() == b.size() and a == b


def test_a_scatters_bounds_are_worked_out_once_per_data_and_view(qtbot, monkeypatch, twin_in_window):
    window, twin = twin_in_window
    twin.set_target((0.1, 0.1, 0.05), True)
    drain()
    item = twin._top.target
    computed = []
    original = pg.ScatterPlotItem.dataBounds

    def counting(self, *args, **kwargs):
        if self is item:
            computed.append(args)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(pg.ScatterPlotItem, "dataBounds", counting)
    first = item.boundingRect()
    calls = len(computed)
    for _ in range(5):  # Qt asks again and again while painting
        assert item.boundingRect() == first
    assert len(computed) == calls
    twin.set_target((-0.1, 0.1, 0.05), True)  # new data: new bounds
    moved = item.boundingRect()
    assert moved.center().x() < first.center().x()
    x_cm, _ = item.getData()
    assert moved.contains(QtCore.QPointF(float(x_cm[0]), moved.center().y()))
    window.resize(600, 300)  # another view transform: the symbol's pixel size is other cm
    qtbot.waitUntil(lambda: item.boundingRect().width() != moved.width(), timeout=TIMEOUT_MS)


def test_the_twins_symbols_are_drawn_as_pyqtgraph_draws_them(qtbot, monkeypatch, twin_in_window):
    """The twin's scatters paint their few symbols themselves: the very same pixels as
    pyqtgraph's own paint (markers, arm joints, target, base), also for a point off the view."""
    import widgets.arm_twin_plots as plots

    _, twin = twin_in_window
    twin.set_arm(CHAIN, CHAIN + (0.01, 0.0, 0.0))
    twin.set_joint_levels(["ok", "warn", "limit", "ok"])
    twin.set_target((0.1, 0.1, 0.05), False)
    twin.set_markers({23: np.array([0.031, 0.152, 0.0]), 7: np.array([2.0, 0.1, 0.0])})  # 7: off the view
    drain()
    fast = twin.grab().toImage()
    painted = []
    original = pg.ScatterPlotItem.paint
    monkeypatch.setattr(pg.ScatterPlotItem, "paint", lambda self, *a: (painted.append(self), original(self, *a))[1])
    assert twin.grab().toImage() == fast and painted == []  # the twin's own paint drew them all
    monkeypatch.setattr(plots, "FAST_SYMBOLS", 0)  # pyqtgraph's paint for every scatter
    assert twin.grab().toImage() == fast and len(painted) >= 8


def test_a_frame_projects_the_side_views_markers_once_for_the_arms_new_plane(qtbot, monkeypatch, twin_in_window):
    """A frame moves the marker and turns the arm (the side view's plane): its markers are
    projected onto the new plane once, not once for the old plane and again for the new one."""
    _, twin = twin_in_window
    profile = load_profile("desk_rrr")
    kinematics = build_kinematics(profile)
    twin.configure_for(profile, kinematics)
    session = SimpleNamespace(profile=profile, kinematics=kinematics, camera=SimpleNamespace())
    sets = []
    original = twin._side.markers.setData
    monkeypatch.setattr(twin._side.markers, "setData", lambda *a, **k: (sets.append(a), original(*a, **k))[1])

    def draw(k: int) -> np.ndarray:
        q = np.asarray(profile.q_home, dtype=float).copy()
        q[0] += 0.2 * k  # the base turns: another plane for the side view
        marker = np.array([0.03 + 0.01 * k, 0.15, 0.0])
        result = SimpleNamespace(frame=SimpleNamespace(t=0.1 * k), objects=(), markers=[
            SimpleNamespace(marker_id=23, found=True, base_p_centre=tuple(marker))])
        draw_twin(twin, session, result, SimpleNamespace(q=tuple(q)), SimpleNamespace(q=tuple(q), measured=True))
        return marker

    for k in range(1, 4):
        before = len(sets)
        marker = draw(k)
        assert len(sets) - before == 1
        s_cm, z_cm = twin._side.markers.getData()
        expected = side_view_coords(marker[None, :], twin.azimuth)[0] * 100
        assert np.allclose((s_cm[0], z_cm[0]), expected)


# ------------------------------------------------------------------------------- the fps label
@pytest.fixture
def view_with_frames(qtbot):
    view = CameraView("Left")
    qtbot.addWidget(view)
    view.resize(320, 260)
    view.show()
    qtbot.waitExposed(view)
    view.show_image(np.zeros((480, 640, 3), np.uint8))
    drain()
    yield view
    view.close()


def test_a_new_fps_waits_for_the_next_frame_instead_of_repainting_the_image(qtbot, view_with_frames):
    view = view_with_frames
    paints = EventCount(view.graphics_view.viewport(), QtCore.QEvent.Type.Paint)
    try:
        view.set_fps(12.3)
        drain()
        assert paints.count == 0 and fps_text(view) == "— fps"
        view.show_image(np.full((480, 640, 3), 40, np.uint8))  # the next frame brings it
        assert fps_text(view) == "12.3 fps"
        qtbot.waitUntil(lambda: paints.count >= 1, timeout=TIMEOUT_MS)
    finally:
        paints.remove()


def test_a_new_fps_shows_by_itself_when_no_frame_comes(qtbot, view_with_frames):
    view = view_with_frames
    view.set_fps(8.0)
    assert fps_text(view) == "— fps"  # a frame may still come
    qtbot.waitUntil(lambda: fps_text(view) == "8.0 fps", timeout=int(FPS_WITH_FRAME_S * 1000) + TIMEOUT_MS)
    idle = CameraView("Right")  # no frame ever drawn: nothing to wait for
    qtbot.addWidget(idle)
    idle.show()
    idle.set_fps(29.96)
    assert fps_text(idle) == "30.0 fps"
    idle.set_fps(float("nan"))
    assert fps_text(idle) == "— fps"
