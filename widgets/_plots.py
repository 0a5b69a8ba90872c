"""Small pyqtgraph plots shared by the wizards (private to ``widgets``)."""
from __future__ import annotations

from widgets._pyqtgraph import pg

BAR_PLOT_MIN_HEIGHT_PX = 110


def static_bar_plot(y_label: str, x_label: str) -> tuple[pg.PlotWidget, pg.BarGraphItem]:
    """A bar plot for a touch screen: no menu, no mouse pan/zoom, no auto-range button (taps are
    only taps), a y grid, and an empty BarGraphItem to fill with ``setOpts``."""
    plot = pg.PlotWidget()
    plot.setMinimumHeight(BAR_PLOT_MIN_HEIGHT_PX)
    plot.setMenuEnabled(False)
    plot.setMouseEnabled(x=False, y=False)
    plot.hideButtons()
    plot.setLabel("left", y_label)
    plot.getAxis("left").enableAutoSIPrefix(False)
    plot.setLabel("bottom", x_label)
    plot.showGrid(y=True, alpha=0.3)
    bars = pg.BarGraphItem(x=[], height=[], width=0.7, brushes=[])
    plot.addItem(bars)
    return plot, bars
