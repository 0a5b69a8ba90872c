"""The configured markers as a touch-sized table: id, name and action, whether each camera sees
the marker, where it is (robot_base) and how far it is from the arm's tool."""
from __future__ import annotations

import math
from typing import Optional, Sequence

from PySide6 import QtCore, QtGui, QtWidgets

from core.messages import MarkerObservation
from core.vision.markers import MarkersConfig, MarkerSpec
from widgets._style import OK_COLOUR, TOUCH_PX, WARN_COLOUR

M_TO_CM = 100.0
DASH = "–"
HEADERS = ("id", "name", "seen", "x y z cm", "tool cm")
COL_ID, COL_NAME, COL_SEEN, COL_POSITION, COL_DISTANCE = range(len(HEADERS))
# the widest texts each column must show whole (coordinates past ±1 m lose their decimal)
WIDEST = {COL_ID: "8888", COL_SEEN: "L R", COL_POSITION: "-88.8 -88.8 -88.8", COL_DISTANCE: "888.8"}
CELL_PADDING_PX = 12  # left + right padding inside a cell (the style's margins and some air)
NAME_MIN_PX = 72  # the name column gets what is left, but never less than this
LOST_COLOUR = "#8a8a8a"  # grey: a last known position, or a camera that does not see the marker
ACTION_LABELS = {"follow": "follow", "point": "point", "pick_place": "pick"}

Point3 = tuple[float, float, float]


def seen_text(obs: Optional[MarkerObservation]) -> str:
    """"L R", "L –", "– R" or "– –": which raw image the marker was detected in this frame."""
    left = obs is not None and len(obs.left_corners) > 0
    right = obs is not None and len(obs.right_corners) > 0
    return f"{'L' if left else DASH} {'R' if right else DASH}"


def cm_text(value_m: float) -> str:
    """A coordinate in cm, one decimal below a metre ("12.3", "-4.0"), whole cm above ("-123")."""
    value_cm = value_m * M_TO_CM
    return f"{value_cm:.0f}" if abs(value_cm) >= 99.95 else f"{value_cm:.1f}"


def position_text(base_p: Optional[Sequence[float]]) -> str:
    """"x y z" in cm (robot_base), or "–" when unknown."""
    if base_p is None or not all(math.isfinite(v) for v in base_p):
        return DASH
    return " ".join(cm_text(v) for v in base_p)


def distance_text(base_p: Optional[Sequence[float]], tool_base_p: Optional[Sequence[float]]) -> str:
    """Distance from the tool to the marker in cm ("12.3"), or "–" when either is unknown."""
    if base_p is None or tool_base_p is None:
        return DASH
    d = math.dist(base_p, tool_base_p)
    if not math.isfinite(d):
        return DASH
    d_cm = d * M_TO_CM
    return f"{d_cm:.0f}" if d_cm >= 999.95 else f"{d_cm:.1f}"


def name_text(spec: MarkerSpec) -> str:
    """Two lines: the name, then the action ("follow", "point", "pick → bin")."""
    action = ACTION_LABELS.get(spec.action, spec.action)
    if spec.place is not None:
        action = f"{action} → {spec.place}"
    return f"{spec.name}\n{action}"


class _Table(QtWidgets.QTableWidget):
    """A QTableWidget whose Return, Enter and Space choose the current row (a tap does too)."""

    sigRowChosen = QtCore.Signal(int)  # row index; GUI thread

    def keyPressEvent(self, event: QtGui.QKeyEvent) -> None:  # noqa: N802 (Qt override)
        keys = (QtCore.Qt.Key.Key_Return, QtCore.Qt.Key.Key_Enter, QtCore.Qt.Key.Key_Space)
        if event.key() in keys and self.currentRow() >= 0:
            self.sigRowChosen.emit(self.currentRow())
            return
        super().keyPressEvent(event)


class MarkersTable(QtWidgets.QWidget):
    """One row per configured marker: id, name (and action), seen L/R, position, distance to tool.

    Rows are a fingertip tall (44 px) and the columns fit a ~380 px wide tab on a 7" 800x480
    screen without horizontal scrolling: the number columns are sized for their widest text,
    the name column takes the rest and elides. A marker that is lost keeps its last known
    position, in grey.

    Signals:
        sigMarkerChosen(int): the marker id of a tapped row (or Return on it); GUI thread.
    """

    sigMarkerChosen = QtCore.Signal(int)

    def __init__(self, parent: Optional[QtWidgets.QWidget] = None) -> None:
        super().__init__(parent)
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        self.table = _Table(0, len(HEADERS), self)
        t = self.table
        t.setHorizontalHeaderLabels(HEADERS)
        t.verticalHeader().setVisible(False)
        t.verticalHeader().setSectionResizeMode(QtWidgets.QHeaderView.ResizeMode.Fixed)
        t.verticalHeader().setMinimumSectionSize(TOUCH_PX)
        t.verticalHeader().setDefaultSectionSize(TOUCH_PX)
        t.setEditTriggers(QtWidgets.QAbstractItemView.EditTrigger.NoEditTriggers)
        t.setSelectionBehavior(QtWidgets.QAbstractItemView.SelectionBehavior.SelectRows)
        t.setSelectionMode(QtWidgets.QAbstractItemView.SelectionMode.SingleSelection)
        t.setHorizontalScrollBarPolicy(QtCore.Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
        t.setVerticalScrollMode(QtWidgets.QAbstractItemView.ScrollMode.ScrollPerPixel)
        t.setWordWrap(False)
        t.setTextElideMode(QtCore.Qt.TextElideMode.ElideRight)
        t.setCornerButtonEnabled(False)
        QtWidgets.QScroller.grabGesture(t.viewport(), QtWidgets.QScroller.ScrollerGestureType.TouchGesture)
        header = t.horizontalHeader()
        header.setHighlightSections(False)
        header.setMinimumSectionSize(24)
        for col in range(len(HEADERS)):
            mode = (QtWidgets.QHeaderView.ResizeMode.Stretch if col == COL_NAME
                    else QtWidgets.QHeaderView.ResizeMode.Fixed)
            header.setSectionResizeMode(col, mode)
        self._fit_columns()
        layout.addWidget(t)
        t.cellClicked.connect(self._on_row)
        t.sigRowChosen.connect(self._on_row)
        self._config: Optional[MarkersConfig] = None
        self._ids: tuple[int, ...] = ()
        self._shown: list[tuple] = []  # per row: what its cells show now (texts and colours)

    # --- layout ----------------------------------------------------------------------------
    def _fit_columns(self) -> None:
        """Fixed widths from the font: every number column shows its widest text whole."""
        fm = self.table.fontMetrics()
        header_fm = QtGui.QFontMetrics(self.table.horizontalHeader().font())
        bold = QtGui.QFont(self.table.horizontalHeader().font())
        bold.setBold(True)
        bold_fm = QtGui.QFontMetrics(bold)  # some styles draw header labels bold
        for col, widest in WIDEST.items():
            label = HEADERS[col]
            need = max(fm.horizontalAdvance(widest), header_fm.horizontalAdvance(label),
                       bold_fm.horizontalAdvance(label))
            self.table.setColumnWidth(col, need + CELL_PADDING_PX)
        self.setMinimumWidth(sum(self.table.columnWidth(c) for c in WIDEST) + NAME_MIN_PX
                             + 2 * self.table.frameWidth() + self.table.verticalScrollBar().sizeHint().width())

    def changeEvent(self, event: QtCore.QEvent) -> None:  # noqa: N802 (Qt override)
        if event.type() in (QtCore.QEvent.Type.FontChange, QtCore.QEvent.Type.StyleChange):
            self._fit_columns()
        super().changeEvent(event)

    # --- content ---------------------------------------------------------------------------
    def set_config(self, config: MarkersConfig) -> None:
        """One row per configured marker, in the file's order; nothing seen yet."""
        self._config = config
        self._ids = config.ids
        t = self.table
        t.clearContents()
        t.setRowCount(len(config.markers))
        for row, spec in enumerate(config.markers):
            for col in range(len(HEADERS)):
                item = QtWidgets.QTableWidgetItem()
                align = QtCore.Qt.AlignmentFlag.AlignVCenter | (
                    QtCore.Qt.AlignmentFlag.AlignLeft if col == COL_NAME else QtCore.Qt.AlignmentFlag.AlignRight
                    if col in (COL_ID, COL_POSITION, COL_DISTANCE) else QtCore.Qt.AlignmentFlag.AlignHCenter)
                item.setTextAlignment(align)
                t.setItem(row, col, item)
            t.item(row, COL_ID).setText(str(spec.marker_id))
            t.item(row, COL_NAME).setText(name_text(spec))
            t.item(row, COL_NAME).setToolTip(f"{spec.name}: {spec.action}"
                                             + (f" → {spec.place}" if spec.place else ""))
            t.setRowHeight(row, TOUCH_PX)
        self._shown = [()] * len(config.markers)
        self.update([], None)

    def update(self, observations: Optional[Sequence[MarkerObservation]] = None,  # type: ignore[override]
               tool_base_p: Optional[Point3] = None) -> bool:
        """Show a perception result's markers (robot_base, m) and their distance to the tool.

        Returns True when a cell changed; False when nothing shown changed (no cell is touched).
        ``update()`` without arguments is QWidget's repaint request.
        """
        if observations is None:
            super().update()
            return False
        by_id = {o.marker_id: o for o in observations}
        changed = False
        for row, marker_id in enumerate(self._ids):
            obs = by_id.get(marker_id)
            base_p = obs.base_p_centre if obs is not None else None
            found = obs is not None and obs.found
            state = (seen_text(obs), position_text(base_p), distance_text(base_p, tool_base_p), found)
            if state == self._shown[row]:
                continue
            self._show_row(row, state)
            self._shown[row] = state
            changed = True
        return changed

    def _show_row(self, row: int, state: tuple) -> None:
        seen, position, distance, found = state
        t = self.table
        seen_item = t.item(row, COL_SEEN)
        seen_item.setText(seen)
        both, none = DASH not in seen, seen == f"{DASH} {DASH}"
        seen_item.setForeground(QtGui.QColor(OK_COLOUR if both else LOST_COLOUR if none else WARN_COLOUR))
        normal = self.palette().color(QtGui.QPalette.ColorRole.Text)
        colour = normal if found else QtGui.QColor(LOST_COLOUR)
        for col, text in ((COL_POSITION, position), (COL_DISTANCE, distance)):
            item = t.item(row, col)
            item.setText(text)
            item.setForeground(colour)
            font = item.font()
            font.setItalic(not found and text != DASH)  # a last known position, not a live one
            item.setFont(font)

    def set_chosen(self, marker_id: Optional[int]) -> None:
        """Highlight the row of ``marker_id`` (None: no row) without emitting sigMarkerChosen."""
        row = self.row_of(marker_id) if marker_id is not None else -1
        if row < 0:
            self.table.clearSelection()
        else:
            self.table.selectRow(row)

    # --- queries (tests, the window) -------------------------------------------------------
    @property
    def config(self) -> Optional[MarkersConfig]:
        """The configuration the rows show (None before set_config)."""
        return self._config

    def row_of(self, marker_id: int) -> int:
        """The row showing ``marker_id``, or -1."""
        return self._ids.index(marker_id) if marker_id in self._ids else -1

    def row_texts(self, row: int) -> tuple[str, ...]:
        """What the row's cells show (the name cell's two lines joined by a newline)."""
        return tuple(self.table.item(row, col).text() for col in range(len(HEADERS)))

    def _on_row(self, row: int, _column: int = 0) -> None:
        if 0 <= row < len(self._ids):
            self.sigMarkerChosen.emit(self._ids[row])
