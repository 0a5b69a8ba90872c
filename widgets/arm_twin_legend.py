"""The legend row under an arm twin (2D or 3D): its entries as HTML words (colour swatches, the
found markers' positions in cm) and ``LegendLabel``, which wraps them between entries to fit.

Re-exported by ``widgets.arm_twin``.
"""
from __future__ import annotations

import html
import math
from typing import Sequence

from PySide6 import QtCore, QtGui, QtWidgets

from widgets.arm_twin_geometry import (
    AIMED_COLOUR,
    COMMANDED_COLOUR,
    LEGEND_ENTRY_GAP,
    LEGEND_SAFETY_PX,
    LEVEL_COLOURS,
    MARKER_COLOUR,
    MEASURED_COLOUR,
    REACHABLE_COLOUR,
    TELEOP_HAND_COLOUR,
    TELEOP_TARGET_COLOUR,
    UNREACHABLE_COLOUR,
)
from widgets.camera_overlays import marker_label
def _swatch_words(colour: Sequence[int], glyph: str, text: str) -> list[str]:
    """A coloured glyph and its text as legend words (HTML): the glyph stays with the first word."""
    r, g, b = colour[:3]
    words = [html.escape(w) for w in text.split()] or [""]
    words[0] = (f'<span style="color: rgb({r},{g},{b}); font-weight: bold">{glyph}</span>'
                f"&nbsp;{words[0]}")
    return words


def marker_entry(marker_id: int, base_p: Sequence[float]) -> tuple[str, ...]:
    """One found marker as a legend entry (HTML words): its swatch, id and robot_base position
    in cm, e.g. "■ 23: x 3.1 y 15.2 z 0.0 cm" (the camera views' label, :func:`marker_label`)."""
    text = marker_label(int(marker_id), base_p)
    head, _, rest = text.partition(" ")  # "23:", "x 3.1 y 15.2 z 0.0 cm"
    if not rest:
        return tuple(_swatch_words(MARKER_COLOUR, "■", head))
    coords = rest.split(" ")
    # "x 3.1" never breaks between the letter and its number
    words = [html.escape(f"{coords[i]}\u00a0{coords[i + 1]}") for i in range(0, len(coords) - 1, 2)]
    if len(coords) % 2:
        words[-1] += html.escape(f"\u00a0{coords[-1]}")  # "cm" stays with z
    return tuple(_swatch_words(MARKER_COLOUR, "■", head)) + tuple(words)


def legend_entries(measured_label: str,
                   markers: Sequence[tuple[str, ...]] = ()) -> list[tuple[str, ...]]:
    """The twins' legend (chains, target, limit levels, aimed point, markers) as entries, each a
    tuple of HTML words. ``markers`` (from :func:`marker_entry`) replace the plain "■ markers"
    entry with each found marker's id and position."""
    def swatch(colour, glyph: str, text: str) -> tuple[str, ...]:
        return tuple(_swatch_words(colour, glyph, text))

    target = swatch(REACHABLE_COLOUR, "+", "target") + ("/",) + swatch(UNREACHABLE_COLOUR, "+",
                                                                       "out of reach")
    limits = swatch(LEVEL_COLOURS["warn"], "●", "near") + ("/",) + swatch(LEVEL_COLOURS["limit"],
                                                                         "●", "at limit")
    entries = [swatch(COMMANDED_COLOUR, "- -", "commanded"),
               swatch(MEASURED_COLOUR, "━●", measured_label), target, limits,
               swatch(AIMED_COLOUR, "○", "aimed")]
    return entries + (list(markers) if markers else [swatch(MARKER_COLOUR, "■", "markers")])


def teleop_legend_entries() -> list[tuple[str, ...]]:
    """The legend's teleop entries (while teleop boxes are drawn): the hand volume, the target box
    it maps to with the mapped point."""
    return [tuple(_swatch_words(TELEOP_HAND_COLOUR, "┅○", "hand")),
            tuple(_swatch_words(TELEOP_TARGET_COLOUR, "□◆", "teleop box"))]


def legend_html(measured_label: str) -> str:
    """The twins' legend row (rich text) on one line: chains, target, limit levels, aimed
    point, markers. :class:`LegendLabel` breaks it into lines that fit."""
    return LEGEND_ENTRY_GAP.join(" ".join(e) for e in legend_entries(measured_label))


def break_lines(entries: Sequence[Sequence[float]], width: float, entry_gap: float,
                word_gap: float) -> list[list[tuple[int, int, int]]]:
    """Fill lines of ``width`` px greedily with entries given as their words' widths (px).

    Lines break between entries; an entry wider than a whole line breaks between its words
    (a single word wider than the line gets a line of its own). Returns the lines, each a list
    of (entry index, first word, end word) spans.
    """
    lines: list[list[tuple[int, int, int]]] = [[]]
    used = 0.0
    for i, words in enumerate(entries):
        total = float(sum(words)) + word_gap * max(0, len(words) - 1)
        gap = entry_gap if lines[-1] else 0.0
        if used + gap + total <= width:
            lines[-1].append((i, 0, len(words)))
            used += gap + total
            continue
        if total <= width:  # on a line of its own
            lines.append([(i, 0, len(words))])
            used = total
            continue
        if lines[-1]:
            lines.append([])
        start, run = 0, 0.0
        for j, w in enumerate(words):
            if j > start and run + word_gap + w > width:
                lines[-1].append((i, start, j))
                lines.append([])
                start, run = j, float(w)
            else:
                run = float(w) if j == start else run + word_gap + w
        lines[-1].append((i, start, len(words)))
        used = run
    return [line for line in lines if line]

class LegendLabel(QtWidgets.QWidget):
    """The legend under a twin: entries (rich text) that wrap between entries, never inside
    one unless it is wider than the whole row, so no entry is ever cut.

    The label breaks its lines itself (:func:`break_lines`) for its width, on every resize
    and on :meth:`set_entries`; its height follows the line count. (QLabel's own word wrap
    would make it a height-for-width widget, which makes parent layouts over-allocate height.)

    The text is drawn by a QLabel inside this widget, placed by hand at its whole size: a
    QLabel's new text asks its parent's layout to lay out again, and a marker's position changes
    the text with every frame — in the twin's layout that re-laid out the whole window five to
    thirty times a second. Here only a new line count (a new height) reaches the twin's layout,
    and the label paints every pixel it covers (black), so nothing under it is repainted.

    Signals: none.
    """

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._entries: list[tuple[str, ...]] = []
        self._lines: list[list[tuple[int, int, int]]] = []
        self._widths: dict[str, float] = {}
        self._broken_for = -1  # the text width the lines were broken for
        self._hint_key = None  # the lines and font the parent layout last had the height of
        self._measure_doc: QtGui.QTextDocument | None = None  # one document measures every word
        self._label = QtWidgets.QLabel(self)
        self._label.setTextFormat(QtCore.Qt.TextFormat.RichText)
        self._label.setWordWrap(False)
        # it fills its background (the style sheet's black): an opaque widget, so Qt need not
        # paint the twin, the splitter … under it when its text changes
        self._label.setAutoFillBackground(True)
        # the width is the twin's; the height is what the lines need
        self.setSizePolicy(QtWidgets.QSizePolicy.Policy.Ignored,
                           QtWidgets.QSizePolicy.Policy.Fixed)
        font = self.font()
        font.setPointSizeF(max(7.0, font.pointSizeF() * 0.85))
        self.setFont(font)  # the label inside inherits it
        # same dark background as the plots, so the plot colours read the same (a palette, not a
        # style sheet: Qt counts a style-sheet background as not opaque, see above)
        palette = self._label.palette()
        palette.setColor(QtGui.QPalette.ColorRole.Window, QtGui.QColor("black"))
        palette.setColor(QtGui.QPalette.ColorRole.WindowText, QtGui.QColor("#dddddd"))
        self._label.setPalette(palette)
        self._label.setContentsMargins(4, 2, 4, 2)  # not in the style sheet: contentsRect() holds them

    def set_entries(self, entries: Sequence[Sequence[str]]) -> None:
        """Show these entries, each a sequence of HTML words (:func:`legend_entries`)."""
        entries = [tuple(e) for e in entries]
        if entries == self._entries:
            return
        self._entries = entries
        self._relayout(force=True)

    def entries(self) -> list[tuple[str, ...]]:
        """The entries as set."""
        return list(self._entries)

    def text(self) -> str:
        """The rich text shown: the lines joined by ``<br>``."""
        return self._label.text()

    def line_count(self) -> int:
        """How many lines the legend takes at its current width."""
        return len(self._lines)

    def lines_text(self) -> list[str]:
        """Each line as plain text (for tests and accessibility)."""
        return [_plain(html_line) for html_line in self.text().split("<br>")] if self.text() else []

    def height_for_width(self, width: int) -> int:
        """The height (px) the legend takes when the label is ``width`` px wide."""
        m = self._label.contentsMargins()
        lines = break_lines(self._entry_widths(), max(1.0, width - m.left() - m.right()
                                                      - LEGEND_SAFETY_PX), *self._gaps())
        doc = QtGui.QTextDocument()  # as QLabel lays out rich text
        doc.setDefaultFont(self.font())
        doc.setDocumentMargin(0)
        doc.setHtml("<br>".join(["x"] * max(1, len(lines))))
        return math.ceil(doc.size().height()) + m.top() + m.bottom()

    def text_width(self) -> int:
        """The width (px) the lines must fit: the label's minus its margins."""
        return self._label.contentsRect().width()

    def sizeHint(self) -> QtCore.QSize:  # noqa: N802 (Qt override)
        """The label's own measurement of the text it shows (its height: the lines')."""
        return self._label.sizeHint()

    def minimumSizeHint(self) -> QtCore.QSize:  # noqa: N802 (Qt override)
        return self._label.minimumSizeHint()

    def resizeEvent(self, event) -> None:  # noqa: N802 (Qt override)
        super().resizeEvent(event)
        self._label.setGeometry(self.rect())  # by hand: its new texts then ask no layout for anything
        if event.size().width() != event.oldSize().width():
            self._relayout()

    def changeEvent(self, event) -> None:  # noqa: N802 (Qt override)
        super().changeEvent(event)
        if event.type() == QtCore.QEvent.Type.FontChange:
            self._widths.clear()
            self._relayout(force=True)
            self._tell_layout()

    def _measure(self, fragment: str) -> float:
        width = self._widths.get(fragment)
        if width is None:
            if len(self._widths) > 512:  # marker positions make new words every frame
                self._widths.clear()
            doc = self._measure_doc
            if doc is None:
                doc = self._measure_doc = QtGui.QTextDocument(self)
                doc.setDocumentMargin(0)
            doc.setDefaultFont(self.font())
            doc.setHtml(fragment)
            width = self._widths[fragment] = doc.idealWidth()
        return width

    def _entry_widths(self) -> list[list[float]]:
        return [[self._measure(w) for w in entry] for entry in self._entries]

    def _gaps(self) -> tuple[float, float]:
        """(between entries, between words) in px."""
        metrics = QtGui.QFontMetricsF(self.font())
        return 3.0 * metrics.horizontalAdvance("\u00a0"), metrics.horizontalAdvance(" ")

    def _relayout(self, force: bool = False) -> None:
        width = self.text_width()
        if not force and width == self._broken_for:
            return
        self._broken_for = width
        self._lines = break_lines(self._entry_widths(), max(1.0, width - LEGEND_SAFETY_PX),
                                  *self._gaps())
        text = "<br>".join(LEGEND_ENTRY_GAP.join(" ".join(self._entries[i][a:b]) for i, a, b in line)
                           for line in self._lines)
        if text != self._label.text():
            self._label.setText(text)
            self._tell_layout()

    def _tell_layout(self) -> None:
        """Other lines (another count, other entries on them) or another font may need another
        height: the parent layout asks for it again. The same lines with new words (a marker's
        new position) are no news to it — and measuring the text here would lay it out twice."""
        key = (tuple(map(tuple, self._lines)), self.font().key())
        if key != self._hint_key:
            self._hint_key = key
            self.updateGeometry()


def _plain(fragment: str) -> str:
    """Plain text of an HTML fragment, non-breaking spaces as spaces."""
    return QtGui.QTextDocumentFragment.fromHtml(fragment).toPlainText().replace("\u00a0", " ")


def make_legend_label() -> LegendLabel:
    """The legend row under a twin (2D or 3D): small rich text on the plots' black."""
    return LegendLabel()
