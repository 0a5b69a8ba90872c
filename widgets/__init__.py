"""deskarm's Qt widgets: camera views, the arm twin, control panels and status items.

Widgets never parse config files and own no threads: they receive data through methods and
report user actions through ``sig*`` signals (documented in each class docstring, all emitted
from the GUI thread). Import the classes from their modules, e.g.
``from widgets.target_panel import TargetPanel``; this package stays light: it imports no
pyqtgraph (the modules that draw with it take it, configured, from ``widgets._pyqtgraph``).
"""
