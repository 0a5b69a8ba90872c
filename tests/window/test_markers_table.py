"""The markers table (widgets/markers_table.py, pytest-qt offscreen): rows for the configured
markers, seen flags, positions and tool distances, taps, and touch sizes in a 380 px wide tab."""
from __future__ import annotations

import os

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import pytest  # noqa: E402
from PySide6 import QtCore, QtGui, QtWidgets  # noqa: E402

from core.messages import MarkerObservation  # noqa: E402
from core.vision.markers import MarkersConfig, MarkerSpec, default_markers  # noqa: E402
from widgets.markers_table import (  # noqa: E402
    COL_DISTANCE,
    COL_ID,
    COL_NAME,
    COL_POSITION,
    COL_SEEN,
    HEADERS,
    MarkersTable,
    cm_text,
    distance_text,
    position_text,
    seen_text,
)

TIMEOUT_MS = 1000
LEFT = QtCore.Qt.MouseButton.LeftButton
TAB_W, TAB_H = 380, 330  # the right-hand tab of the main window on a 7" 800x480 screen
TOUCH_PX = 44
CORNERS = ((10.0, 10.0), (40.0, 10.0), (40.0, 40.0), (10.0, 40.0))

CONFIG = MarkersConfig(
    dictionary="DICT_APRILTAG_36h11",
    markers=(MarkerSpec(23, "cup A", "pick_place", "bin"), MarkerSpec(50, "a rather long marker name", "point"),
             MarkerSpec(586, "", "follow")),
    places={"bin": (0.15, 0.05, 0.02)},
)


def seen(marker_id, base_p, left=True, right=True):
    return MarkerObservation(marker_id=marker_id, found=left and right and base_p is not None,
                             left_corners=CORNERS if left else (), right_corners=CORNERS if right else (),
                             base_p_centre=base_p)


@pytest.fixture
def table(qtbot):
    t = MarkersTable()
    qtbot.addWidget(t)
    t.set_config(CONFIG)
    t.resize(TAB_W, TAB_H)
    t.show()
    qtbot.waitExposed(t)
    return t


def test_one_row_per_configured_marker_in_file_order(table):
    assert table.table.rowCount() == 3
    assert [table.row_texts(r)[COL_ID] for r in range(3)] == ["23", "50", "586"]
    assert table.row_texts(0)[COL_NAME] == "cup A\npick → bin"
    assert table.row_texts(1)[COL_NAME] == "a rather long marker name\npoint"
    assert table.row_texts(2)[COL_NAME] == "marker 586\nfollow"
    for r in range(3):  # nothing seen yet
        assert table.row_texts(r)[COL_SEEN:] == ("– –", "–", "–")
    table.set_config(default_markers())
    assert table.table.rowCount() == 2 and table.row_of(50) == 1 and table.row_of(586) == -1


def test_update_shows_positions_in_cm_and_the_distance_to_the_tool(table):
    changed = table.update([seen(23, (0.031, 0.152, 0.0)), seen(50, (-0.052, 0.121, 0.004))],
                           tool_base_p=(0.031, 0.152, 0.10))
    assert changed
    assert table.row_texts(0)[COL_SEEN:] == ("L R", "3.1 15.2 0.0", "10.0")
    assert table.row_texts(1)[COL_SEEN:] == ("L R", "-5.2 12.1 0.4", "13.1")
    assert table.row_texts(2)[COL_SEEN:] == ("– –", "–", "–"), "a marker missing from the result"
    # without a tool position there is no distance
    table.update([seen(23, (0.031, 0.152, 0.0))], None)
    assert table.row_texts(0)[COL_DISTANCE] == "–"


def test_seen_flags_show_which_camera_sees_each_marker(table):
    table.update([seen(23, None, right=False), seen(50, None, left=False),
                  seen(586, (0.0, 0.1, 0.0), left=False, right=False)], (0.0, 0.0, 0.0))
    assert [table.row_texts(r)[COL_SEEN] for r in range(3)] == ["L –", "– R", "– –"]
    assert table.row_texts(0)[COL_POSITION] == "–"
    # a lost marker keeps its last known position, in grey italics
    item = table.table.item(2, COL_POSITION)
    assert item.text() == "0.0 10.0 0.0" and item.font().italic()
    assert table.table.item(0, COL_SEEN).foreground().color() != table.table.item(2, COL_SEEN).foreground().color()


def test_an_unchanged_result_touches_no_cell(table):
    obs = [seen(23, (0.031, 0.152, 0.0))]
    assert table.update(obs, (0.0, 0.0, 0.0))
    item = table.table.item(0, COL_POSITION)
    assert not table.update(obs, (0.0, 0.0, 0.0)), "the same texts: nothing to do"
    # sub-display-resolution jitter (0.01 mm) shows the same texts: still nothing to do
    assert not table.update([seen(23, (0.03100001, 0.152, 0.0))], (0.0, 0.0, 0.0))
    assert table.table.item(0, COL_POSITION) is item
    assert table.update([seen(23, (0.032, 0.152, 0.0))], (0.0, 0.0, 0.0))
    assert table.row_texts(0)[COL_POSITION] == "3.2 15.2 0.0"


def test_update_without_arguments_is_still_a_repaint_request(table):
    assert table.update() is False  # QWidget.update(): the table's contents stay


def test_tapping_a_row_emits_its_marker_id(table, qtbot):
    t = table.table
    for marker_id in (50, 23, 586):
        rect = t.visualItemRect(t.item(table.row_of(marker_id), COL_POSITION))
        with qtbot.waitSignal(table.sigMarkerChosen, timeout=TIMEOUT_MS) as blocker:
            qtbot.mouseClick(t.viewport(), LEFT, pos=rect.center())
        assert blocker.args == [marker_id]
    # the keyboard chooses the current row too
    t.setFocus()
    t.setCurrentCell(table.row_of(50), COL_ID)
    with qtbot.waitSignal(table.sigMarkerChosen, timeout=TIMEOUT_MS) as blocker:
        qtbot.keyClick(t, QtCore.Qt.Key.Key_Return)
    assert blocker.args == [50]


def test_set_chosen_highlights_a_row_without_emitting(table, qtbot):
    with qtbot.assertNotEmitted(table.sigMarkerChosen):
        table.set_chosen(586)
        assert [i.row() for i in table.table.selectionModel().selectedRows()] == [2]
        table.set_chosen(None)
        assert table.table.selectionModel().selectedRows() == []


def test_rows_are_a_fingertip_tall(table):
    for r in range(table.table.rowCount()):
        assert table.table.rowHeight(r) >= TOUCH_PX
    # the name's two lines (name, action) fit the row
    fm = table.table.fontMetrics()
    assert 2 * fm.lineSpacing() <= table.table.rowHeight(0) - 4


def test_the_table_fits_a_380_px_tab_without_horizontal_scrolling(qtbot):
    t = MarkersTable()
    qtbot.addWidget(t)
    many = MarkersConfig(markers=tuple(MarkerSpec(i, f"cup number {i}") for i in range(200, 212)))
    t.set_config(many)
    assert t.minimumSizeHint().width() <= TAB_W and t.minimumWidth() <= TAB_W
    t.resize(TAB_W, TAB_H)
    t.show()
    qtbot.waitExposed(t)
    # the widest values a desk shows: every coordinate negative, a metre away from the tool
    t.update([seen(i, (-0.889, -0.889, -0.889)) for i in many.ids], (0.999, 0.999, 0.999))
    table = t.table
    assert table.verticalScrollBar().isVisible(), "12 rows need vertical scrolling in this test"
    assert table.horizontalHeader().length() <= table.viewport().width()
    assert table.horizontalScrollBar().maximum() == 0
    assert table.columnWidth(COL_NAME) >= 60, "the name keeps room to be read"
    fm = table.fontMetrics()
    header_fm = QtGui.QFontMetrics(table.horizontalHeader().font())
    for col in (COL_ID, COL_SEEN, COL_POSITION, COL_DISTANCE):
        widest = max(fm.horizontalAdvance(t.row_texts(r)[col]) for r in range(table.rowCount()))
        assert widest + 8 <= table.columnWidth(col), f"column {HEADERS[col]!r} cuts {widest} px of text"
        assert header_fm.horizontalAdvance(HEADERS[col]) + 8 <= table.columnWidth(col)
    assert t.row_texts(0)[COL_POSITION] == "-88.9 -88.9 -88.9"
    assert t.row_texts(0)[COL_DISTANCE] == "327.0"


def test_texts_for_cells():
    assert seen_text(None) == "– –"
    assert cm_text(0.1234) == "12.3" and cm_text(-1.234) == "-123" and cm_text(-0.0004) == "-0.0"
    assert position_text(None) == "–" and position_text((float("nan"), 0.0, 0.0)) == "–"
    assert distance_text((0.0, 0.0, 0.0), (0.03, 0.04, 0.0)) == "5.0"
    assert distance_text((0.0, 0.0, 0.0), None) == "–" and distance_text(None, (0.0, 0.0, 0.0)) == "–"
    assert distance_text((0.0, 0.0, 0.0), (20.0, 0.0, 0.0)) == "2000"


def test_the_table_is_usable_inside_a_tab_of_an_800x480_window(qtbot):
    window = QtWidgets.QWidget()
    qtbot.addWidget(window)
    layout = QtWidgets.QHBoxLayout(window)
    layout.addWidget(QtWidgets.QLabel("views"), 1)
    tabs = QtWidgets.QTabWidget()
    tabs.setFixedWidth(TAB_W)
    t = MarkersTable()
    t.set_config(CONFIG)
    tabs.addTab(t, "Markers")
    layout.addWidget(tabs)
    window.resize(800, 480)
    window.show()
    qtbot.waitExposed(window)
    assert t.table.horizontalHeader().length() <= t.table.viewport().width()
    assert t.table.viewport().height() >= 3 * TOUCH_PX, "all three rows show without scrolling"
