"""pyqtgraph as deskarm's widgets use it, configured once: ``from widgets._pyqtgraph import pg``.

The ``widgets`` package itself does not import pyqtgraph: the assistive view, STOP and the
panels need none of it, and its import is a good part of a start-up on a Pi-class core. Every
module of ``widgets`` that makes pyqtgraph items imports it from here, so the options below are set before the first item is made.
"""
import pyqtgraph as pg

# OpenCV arrays are (row, col[, channel]); say so once for every ImageItem in the app.
pg.setConfigOptions(imageAxisOrder="row-major")
