"""Text that must never be cut or drawn over other text, measured at the sizes the main window
gives its widgets on a 7" 800x480 screen and on a 1280x800 one (pytest-qt, offscreen).

The sizes come from a real MainWindow (as tests/window/test_main_window.py's ``shown_window``
builds it); the widgets are then measured with QFontMetrics, ``heightForWidth`` and item
bounding rects in scene or widget coordinates.
"""
from __future__ import annotations

import os

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from PySide6 import QtCore, QtGui, QtWidgets  # noqa: E402

import widgets  # noqa: E402,F401  (sets pyqtgraph's row-major image order)
from widgets.arm_twin import ArmTwin  # noqa: E402
from widgets.camera_view import CameraView, MarkerOverlay  # noqa: E402
from widgets.status import LATENCY_WIDEST, StatusBarItems  # noqa: E402

SCREENS = ((800, 480), (1280, 800))
TIMEOUT_MS = 2000
EPS = 0.5  # px: sub-pixel rounding of item rects
# the desk's two markers, as the perception gives them (robot_base, m)
MARKERS = {23: np.array([0.031, 0.152, 0.0]), 50: np.array([-0.052, 0.121, 0.004])}
MARKER_ROWS = ["23: x 3.1 y 15.2 z 0.0 cm", "50: x -5.2 y 12.1 z 0.4 cm"]
PROBE_TEXT = "412 mm\nx -12.3 y 15.2 z 10.0 cm"  # app.gui.depth_texts, long coordinates
DEPTH_TICKS = [(0.0, "0 px\n∞"), (16.0, "16 px\n1.2 m"), (32.0, "32 px\n61 cm"),
               (48.0, "48 px\n41 cm"), (64.0, "64 px\n30 cm")]


def new_window(qtbot, width: int, height: int):
    """The main window on the static simulated desk, shown at width x height (not started)."""
    from app.gui import MainWindow
    from core.session import DeskSession, SessionOptions

    session = DeskSession.create(SessionOptions(camera="sim", scenario="static", robot="desk_rrr"))
    window = MainWindow(session)
    qtbot.addWidget(window)
    window.resize(width, height)
    window.show()
    qtbot.waitExposed(window)
    qtbot.waitUntil(lambda: window.twin.legend_label.width() > 0 and window.view_left.width() > 0,
                    timeout=TIMEOUT_MS)
    return window


@pytest.fixture(scope="module")
def window_sizes(qapp):
    """{(screen w, h): {"twin": QSize, "view": QSize, "status": int}} from shown main windows."""
    from app.gui import MainWindow
    from core.session import DeskSession, SessionOptions

    sizes = {}
    for width, height in SCREENS:
        session = DeskSession.create(SessionOptions(camera="sim", scenario="static", robot="desk_rrr"))
        window = MainWindow(session)
        window.resize(width, height)
        window.show()
        for _ in range(10):  # layouts settle through posted events; nothing here waits on time
            qapp.processEvents()
        sizes[(width, height)] = {"twin": window.twin.size(), "view": window.view_left.size(),
                                  "status": window.statusBar().width()}
        window.close()
        window.deleteLater()
        qapp.processEvents()
        session.close()
    return sizes


def rect_inside(inner: QtCore.QRectF, outer: QtCore.QRectF, eps: float = EPS) -> bool:
    return (inner.left() >= outer.left() - eps and inner.top() >= outer.top() - eps
            and inner.right() <= outer.right() + eps and inner.bottom() <= outer.bottom() + eps)


def rects_overlap(a: QtCore.QRectF, b: QtCore.QRectF, eps: float = EPS) -> bool:
    return (min(a.right(), b.right()) - max(a.left(), b.left()) > eps
            and min(a.bottom(), b.bottom()) - max(a.top(), b.top()) > eps)


def sized_twin(qtbot, size: QtCore.QSize) -> ArmTwin:
    twin = ArmTwin()
    qtbot.addWidget(twin)
    twin.resize(size)
    twin.show()
    qtbot.waitExposed(twin)
    return twin


def settle(qtbot, widget: QtWidgets.QWidget) -> None:
    """Let posted layout requests run (the legend's new height, pyqtgraph's layouts): a legend's
    new height reaches it after one or more layout passes, how many depends on Qt's version."""
    from widgets.arm_twin_legend import LegendLabel

    qtbot.waitUntil(lambda: not widget.layout() or not widget.layout().isEmpty(), timeout=TIMEOUT_MS)
    QtWidgets.QApplication.processEvents()  # posted updates first (a legend's new entries) ...
    QtWidgets.QApplication.processEvents()
    legends = [label for label in widget.findChildren(LegendLabel) if label.isVisible()]
    qtbot.waitUntil(lambda: all(label.height() >= label.sizeHint().height() for label in legends),
                    timeout=TIMEOUT_MS)  # ... then the layout passes that give each legend its height


def assert_legend_fits(twin) -> None:
    """Every legend line fits the label's width, every line is inside the label and the
    label inside the twin; each entry (swatch and text) is whole on one line."""
    label = twin.legend_label
    assert label.isVisible()
    hint = label.sizeHint()  # QLabel's own measurement of the rich text it draws
    assert hint.width() <= label.width(), (hint, label.size(), label.lines_text())
    assert hint.height() <= label.height(), (hint, label.size(), label.lines_text())
    metrics = QtGui.QFontMetricsF(label.font())
    for line in label.lines_text():
        assert metrics.horizontalAdvance(line) <= label.text_width() + 2.0, line
    geometry = label.geometry()
    assert geometry.bottom() < twin.height() and geometry.right() < twin.width(), geometry
    lines = label.lines_text()
    for entry in ("- - commanded", "━● " + twin._measured_label, "+ target / + out of reach",
                  "● near / ● at limit", "○ aimed"):
        assert any(entry in line for line in lines), (entry, lines)


# ------------------------------------------------------------------------------- 1: the legend
@pytest.mark.parametrize("screen", SCREENS)
@pytest.mark.parametrize("measured_label", ["measured", "commanded (no feedback)"])
def test_the_twin_legend_is_never_cut(qtbot, window_sizes, screen, measured_label):
    twin = sized_twin(qtbot, window_sizes[screen]["twin"])
    twin.set_measured_label(measured_label)
    twin.set_markers(MARKERS)
    settle(qtbot, twin)
    assert_legend_fits(twin)
    if screen == (800, 480):
        assert twin.legend_label.line_count() >= 2  # it wraps rather than cuts ("● at l…")


def test_the_legend_wraps_at_any_width_and_comes_back_to_one_line(qtbot):
    twin = sized_twin(qtbot, QtCore.QSize(1600, 300))
    settle(qtbot, twin)
    assert twin.legend_label.line_count() == 1
    for width in (900, 600, 381, 324):
        twin.resize(width, 200)
        settle(qtbot, twin)
        assert_legend_fits(twin)
    twin.resize(1600, 300)
    settle(qtbot, twin)
    assert twin.legend_label.line_count() == 1


def test_the_3d_twins_legend_is_the_same_wrapping_label():
    """The 3D twin (tested under Xvfb in test_arm_twin_3d) builds its legend with the same
    factory and entries; offscreen, check that they are the 2D twin's."""
    from widgets import arm_twin_3d
    from widgets.arm_twin import LegendLabel, make_legend_label

    assert arm_twin_3d.make_legend_label is make_legend_label
    assert isinstance(make_legend_label(), LegendLabel)
    assert issubclass(arm_twin_3d.ArmTwin3D, arm_twin_3d.TwinBase)


@pytest.mark.parametrize("screen", SCREENS)
def test_the_plot_titles_fit_their_views(qtbot, window_sizes, screen):
    twin = sized_twin(qtbot, window_sizes[screen]["twin"])
    settle(qtbot, twin)
    for plot in (twin.top_plot, twin.side_plot):
        title = plot.getPlotItem().titleLabel
        text_width = title.item.boundingRect().width()
        assert text_width <= title.size().width() + EPS, (title.text, text_width, title.size())


# ------------------------------------------------------------------------------- 2, 3: view labels
def assert_labels_inside_and_apart(twin: ArmTwin, view: str) -> None:
    plot = twin.top_plot if view == "top" else twin.side_plot
    box = plot.getPlotItem().vb.sceneBoundingRect()
    rects = [label.sceneBoundingRect() for label in twin.marker_labels(view)]
    assert rects
    for i, rect in enumerate(rects):
        assert rect_inside(rect, box), (view, i, rect, box)
        for other in rects[i + 1:]:
            assert not rects_overlap(rect, other), (view, rect, other)


@pytest.mark.parametrize("screen", SCREENS)
def test_top_view_labels_stay_inside_the_view_at_its_edges(qtbot, window_sizes, screen):
    twin = sized_twin(qtbot, window_sizes[screen]["twin"])
    twin.set_view_range(0.25, 0.30)
    settle(qtbot, twin)
    drawn = None
    for _ in range(3):  # the legend's marker rows take height: the range follows, once
        (x0, x1), (y0, y1) = twin.top_plot.getPlotItem().vb.viewRange()  # cm, as drawn
        if drawn == (x0, x1, y0, y1):
            break
        drawn = (x0, x1, y0, y1)
        corners = {1: (x1, y1), 2: (x0, y1), 3: (x0, y0), 4: (x1, y0),  # the four corners
                   5: (x1, 0.0), 6: (0.0, y1), 7: (x0, 0.0), 8: (0.0, y0)}  # and the four edges
        twin.set_markers({i: np.array([x / 100.0, y / 100.0, 0.0]) for i, (x, y) in corners.items()})
        settle(qtbot, twin)
    assert_labels_inside_and_apart(twin, "top")
    box = twin.top_plot.getPlotItem().vb.sceneBoundingRect()
    right_edge = twin.marker_labels("top")[4]  # id 5, at the right edge: its label flips left
    assert right_edge.sceneBoundingRect().right() <= box.right() + EPS
    vb = twin.top_plot.getPlotItem().vb
    dot = vb.mapViewToScene(QtCore.QPointF(x1, 0.0))
    assert right_edge.sceneBoundingRect().right() <= dot.x()


@pytest.mark.parametrize("screen", SCREENS)
def test_labels_of_close_markers_do_not_run_together(qtbot, window_sizes, screen):
    """Ids 50 and 23 a few mm apart in the side view were drawn as "5023"."""
    twin = sized_twin(qtbot, window_sizes[screen]["twin"])
    twin.set_view_range(0.25, 0.30)
    twin.set_side_azimuth(np.pi / 2)  # the side view's s is y
    cluster = {50: (0.03, 0.150, 0.0), 23: (0.05, 0.152, 0.002), 7: (-0.02, 0.148, 0.004),
               101: (0.0, 0.155, 0.001)}
    twin.set_markers({k: np.array(v) for k, v in cluster.items()})
    settle(qtbot, twin)
    assert_labels_inside_and_apart(twin, "side")
    assert_labels_inside_and_apart(twin, "top")
    texts = [label.toPlainText() for label in twin.marker_labels("side")]
    assert texts == ["7", "23", "50", "101"]


def test_labels_follow_a_resize(qtbot):
    twin = sized_twin(qtbot, QtCore.QSize(900, 320))
    twin.set_view_range(0.25, 0.30)
    settle(qtbot, twin)
    (_, x1), _ = twin.top_plot.getPlotItem().vb.viewRange()
    twin.set_markers({9: np.array([x1 / 100.0, 0.0, 0.0])})
    twin.resize(381, 150)  # a smaller view: the label is larger in view units
    settle(qtbot, twin)
    assert_labels_inside_and_apart(twin, "top")


# ------------------------------------------------------------------------------- 5: marker positions
@pytest.mark.parametrize("screen", SCREENS)
def test_the_window_twin_shows_each_markers_id_and_position(qtbot, screen):
    window = new_window(qtbot, *screen)
    twin = window.twin
    twin.set_markers(MARKERS)
    settle(qtbot, window)
    text = twin.legend_text()
    for row in MARKER_ROWS:
        assert row in text, (row, text)  # whole, on one line
    assert [t.removeprefix("■ ") for t in twin.marker_texts()] == MARKER_ROWS
    assert_legend_fits(twin)
    # the legend is under the plots, inside the twin's part of the window, and the views keep
    # room for the arm
    legend = twin.legend_label.geometry()
    for plot in (twin.top_plot, twin.side_plot):
        assert plot.geometry().bottom() < legend.top()
        assert plot.getPlotItem().vb.height() >= 60, plot.getPlotItem().vb.size()
    stack = window.twin_stack
    assert twin.height() <= stack.height() and twin.width() <= stack.width()
    bottom_left = twin.legend_label.mapTo(window, QtCore.QPoint(0, twin.legend_label.height()))
    assert bottom_left.y() <= window.statusBar().geometry().top()
    twin.set_markers({})
    assert "■ markers" in twin.legend_text() and twin.marker_texts() == []


# ------------------------------------------------------------------------------- 4: depth probe
@pytest.fixture(params=["800x480", "1280x800", "narrowest", "wide"])
def disparity_view(request, qtbot, window_sizes):
    sizes = {"800x480": window_sizes[(800, 480)]["view"], "1280x800": window_sizes[(1280, 800)]["view"],
             "narrowest": QtCore.QSize(160, 200), "wide": QtCore.QSize(660, 540)}
    view = CameraView("Left")
    qtbot.addWidget(view)
    view.resize(sizes[request.param])
    view.show()
    qtbot.waitExposed(view)
    view.set_display_mode("disparity")
    view.set_depth_legend(DEPTH_TICKS)
    view.show_disparity(np.full((480, 640), 20.0, np.float32), 64.0)
    settle(qtbot, view)
    return view


def assert_text_not_cut(label: QtWidgets.QLabel) -> None:
    """A word-wrapped label: its wrapped text fits its height and every word its width."""
    assert label.heightForWidth(label.width()) <= label.height(), (label.text(), label.size())
    metrics = QtGui.QFontMetricsF(label.font())
    margins = label.contentsMargins()
    room = label.width() - margins.left() - margins.right()
    for word in label.text().replace("\n", " ").split(" "):
        assert metrics.horizontalAdvance(word) <= room + 1.0, (word, room)


@pytest.mark.parametrize("text", [PROBE_TEXT, "no depth here\n(no stereo match)"])
def test_the_depth_probe_stays_in_the_image_and_off_the_colour_bar(qtbot, disparity_view, text):
    view = disparity_view
    view.set_probe(630.0, 470.0, text)  # bottom right, next to the colour bar
    settle(qtbot, view)
    probe = view.overlay_widgets()["probe"]
    assert probe.isVisible() and view.probe_text() == text
    image, bar = view.image_rect(), view.colour_bar_rect()
    assert not bar.isEmpty()
    assert image.contains(probe.geometry()), (probe.geometry(), image)
    assert not probe.geometry().intersects(bar), (probe.geometry(), bar)
    assert_text_not_cut(probe)
    assert not probe.geometry().intersects(view.overlay_widgets()["fps"].geometry())


def test_the_depth_probe_follows_a_resize(qtbot, disparity_view):
    view = disparity_view
    view.set_probe(10.0, 10.0, PROBE_TEXT)
    view.resize(view.width() + 150, view.height())
    settle(qtbot, view)
    probe = view.overlay_widgets()["probe"]
    assert view.image_rect().contains(probe.geometry())
    assert not probe.geometry().intersects(view.colour_bar_rect())


# ------------------------------------------------------------------------------- camera view labels
@pytest.mark.parametrize("size", [QtCore.QSize(411, 417), QtCore.QSize(660, 540)])
def test_camera_view_marker_labels_stay_inside_the_view(qtbot, size):
    view = CameraView("Left")
    qtbot.addWidget(view)
    view.resize(size)
    view.show()
    qtbot.waitExposed(view)
    view.show_image(np.zeros((480, 640, 3), np.uint8))
    corners = {1: [[600, 2], [636, 2], [636, 38], [600, 38]], 2: [[2, 440], [38, 440], [38, 476], [2, 476]]}
    view.set_markers([MarkerOverlay(i, np.array(c, float), True, f"{i}: x -12.3 y 15.2 z 10.0 cm")
                      for i, c in corners.items()])
    settle(qtbot, view)
    box = view._view_box.sceneBoundingRect()
    for slot in view._markers[:2]:
        assert rect_inside(slot.label_text.sceneBoundingRect(), box), slot.label_text.sceneBoundingRect()


# ------------------------------------------------------------------------------- 6: status bar
def test_status_bar_numbers_are_never_cut_at_800_px(qtbot, window_sizes):
    window = QtWidgets.QMainWindow()
    window.setCentralWidget(QtWidgets.QWidget())
    qtbot.addWidget(window)
    items = StatusBarItems(window.statusBar())
    window.resize(window_sizes[(800, 480)]["status"], 200)
    window.show()
    qtbot.waitExposed(window)
    long_bridge = ("E-STOP · serial:///dev/ttyUSB0 ✗ could not open /dev/ttyUSB0: permission "
                   "denied — add your user to the 'dialout' group and log in again")
    items.update("sim://desk (static scene, simulated stereo pair)", long_bridge, 99.94, 9999.0)
    settle(qtbot, window)
    bar = window.statusBar()
    for label, widest in ((items.fps_label, "99.9 fps"), (items.latency_label, LATENCY_WIDEST)):
        assert label.text() == widest
        metrics = QtGui.QFontMetricsF(label.font())
        margins = label.contentsMargins()
        room = label.width() - margins.left() - margins.right()
        assert metrics.horizontalAdvance(widest) <= room, (widest, label.size())
        assert label.geometry().right() < bar.width() and label.geometry().left() >= 0
    assert items.fps_label.geometry().right() < items.latency_label.geometry().left()
    assert items.bridge_label.geometry().right() < items.fps_label.geometry().left()
    assert items.camera_label.geometry().right() < items.bridge_label.geometry().left()
    # the long states give way: elided, the full text in the tooltip
    assert items.bridge_label.is_elided() and items.bridge_label.shown_text().endswith("…")
    assert items.bridge_label.text() == f"bridge: {long_bridge}"
    assert items.bridge_label.toolTip() == f"bridge: {long_bridge}"
    for label in (items.camera_label, items.bridge_label):
        metrics = QtGui.QFontMetricsF(label.font())
        assert metrics.horizontalAdvance(label.shown_text()) <= label.contentsRect().width() + 1.0
    # short states are shown whole again
    items.update("sim://desk", "sim:// ✓ 12 cmds", 30.0, 48.0)
    settle(qtbot, window)
    assert not items.bridge_label.is_elided() and not items.camera_label.is_elided()
    assert items.latency_label.width() >= items.latency_label.widest_px()


def test_the_window_status_bar_keeps_its_numbers_at_800x480(qtbot):
    window = new_window(qtbot, 800, 480)
    items = window.status_items
    items.update("sim://desk", "E-STOP · serial:///dev/ttyUSB0 ✗ could not open port: permission denied",
                 29.96, 119.0)
    settle(qtbot, window)
    label = items.latency_label
    assert label.text() == "latency 119 ms"
    assert label.geometry().right() < window.statusBar().width()
    assert QtGui.QFontMetricsF(label.font()).horizontalAdvance(LATENCY_WIDEST) <= label.contentsRect().width()


# ------------------------------------------------------------------------------- 7: placeholder
@pytest.mark.parametrize("screen", SCREENS)
def test_a_camera_view_shows_a_placeholder_until_the_first_image(qtbot, window_sizes, screen):
    view = CameraView("Left")
    qtbot.addWidget(view)
    view.resize(window_sizes[screen]["view"])
    view.show()
    qtbot.waitExposed(view)
    settle(qtbot, view)
    placeholder = view.overlay_widgets()["placeholder"]
    assert view.placeholder_text() == "starting cameras…" and placeholder.isVisible()
    for text in ("starting cameras…", "CAMERA MISSING — plug it in"):
        view.set_placeholder(text)
        settle(qtbot, view)
        area = view.graphics_view.rect()
        assert area.contains(placeholder.geometry()), (placeholder.geometry(), area)
        assert abs(placeholder.geometry().center().x() - area.center().x()) <= 1
        assert abs(placeholder.geometry().center().y() - area.center().y()) <= 1
        assert_text_not_cut(placeholder)
        assert placeholder.font().pointSizeF() > view.font().pointSizeF()  # large
    view.show_image(np.zeros((480, 640, 3), np.uint8))
    assert view.placeholder_text() == "" and not placeholder.isVisible()


def test_the_placeholder_is_cleared_by_a_disparity_map_or_by_an_empty_text(qtbot):
    view = CameraView("Right")
    qtbot.addWidget(view)
    view.show()
    placeholder = view.overlay_widgets()["placeholder"]
    view.set_placeholder("CAMERA MISSING — plug it in")
    assert placeholder.isVisible() and view.placeholder_text() == "CAMERA MISSING — plug it in"
    view.set_placeholder("")
    assert not placeholder.isVisible() and view.placeholder_text() == ""
    view.set_placeholder("starting cameras…")
    view.set_display_mode("disparity")
    view.show_disparity(np.zeros((480, 640), np.float32), 64.0)
    assert not placeholder.isVisible() and view.placeholder_text() == ""
