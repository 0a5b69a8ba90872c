"""The arm's optional 3D twin (pyqtgraph.opengl), with the same drawing API as the 2D ArmTwin.

OpenGL is not always there: ``QT_QPA_PLATFORM=offscreen`` (the tests, a headless Pi) gives an
invalid context and ``GLViewWidget.renderToArray`` segfaults; PyOpenGL may be missing; a
machine may have no GL driver. So the window asks :func:`make_twin_3d`, which answers None
(never crashes) when :func:`available_3d` says no, and keeps the 2D twin then. The check
never creates a GL context on a platform without OpenGL; on one with it, it creates a
throw-away context on an offscreen surface once and caches the answer.

Everything is drawn in centimetres, as the 2D views; inputs are metres in robot_base.
"""
from __future__ import annotations

import math
import os
from typing import Any, Mapping, Optional, Sequence

import numpy as np
from PySide6 import QtCore, QtGui, QtWidgets

from widgets._style import touch_button
from widgets.arm_twin import (
    AIMED_COLOUR,
    COMMANDED_COLOUR,
    LEVEL_COLOURS,
    LEVEL_DOT_PX,
    M_TO_CM,
    MARKER_COLOUR,
    MEASURED_COLOUR,
    KEEP_OUT_COLOUR,
    PREVIEW_COLOUR,
    REACHABLE_COLOUR,
    STRUCTURE_COLOUR,
    WORKSPACE_COLOUR,
    TwinBase,
    arm_azimuth,
    chain_start_for,
    joint_anchors_for,
    joint_dot_positions,
    keep_out_boxes_for,
    make_legend_label,
    polylines_with_gaps,
    same_chains,
    same_marker_points,
    side_azimuth_for,
    structure_segments,
    view_extent,
    workspace_outlines,
)

NO_GL_PLATFORMS = frozenset({"offscreen", "minimal", "linuxfb", "vnc", "bsdfb", "vkkhrdisplay"})
DISABLE_ENV = "DESKARM_NO_3D"  # set (non-empty) to keep the 2D twin even where OpenGL works
MIN_GL_VERSION = (2, 0)  # pyqtgraph.opengl's shaders need GLSL 1.10
DESK_GRID_STEP_CM = 10.0
DESK_COLOUR_RGBA = (150, 110, 70, 110)
CAMERA_ELEVATION_DEG = 25.0
CAMERA_AZIMUTH_DEG = -60.0  # from +x towards +y: looking from the front right
ZOOM_STEP = 1.25
TARGET_CROSS_HALF_CM = 2.0
CAMERA_MARGIN = 0.9  # the home view shows the workspace's bounding sphere with this margin

VIEW_MIN_SIZE = (160, 60)
TWIN_MIN_SIZE = (240, 120)  # the main window's twin area is never smaller (TWIN_MIN_HEIGHT_PX)
BUTTON_SPACING_PX = 2

_cached: Optional[tuple[bool, str]] = None


def _rgba(colour: Sequence[float], alpha: Optional[float] = None) -> tuple[float, float, float, float]:
    """A 0…255 colour (3 or 4 values) as GL's 0…1 floats."""
    a = (colour[3] if len(colour) > 3 else 255) if alpha is None else alpha
    return (colour[0] / 255.0, colour[1] / 255.0, colour[2] / 255.0, a / 255.0)


def available_3d(refresh: bool = False) -> tuple[bool, str]:
    """(True, "OpenGL x.y") when the 3D twin can be shown, else (False, why not).

    Checks, in order and without creating a GL context until the last step: the
    ``DESKARM_NO_3D`` switch, a QApplication exists, its platform can do OpenGL (not
    offscreen/minimal/…), PyOpenGL and pyqtgraph.opengl import, and finally that a context
    can be created and made current on an offscreen surface (OpenGL ≥ 2.0). The answer is
    cached per process (``refresh`` asks again).
    """
    global _cached
    if os.environ.get(DISABLE_ENV):
        return False, f"the 3D view is switched off ({DISABLE_ENV} is set)"
    if QtGui.QGuiApplication.instance() is None:
        return False, "no QApplication yet: the 3D check needs the Qt platform"
    platform = QtGui.QGuiApplication.platformName()
    if platform in NO_GL_PLATFORMS:
        return False, (f"the Qt platform {platform!r} has no OpenGL (QT_QPA_PLATFORM={platform}):"
                       " the 2D twin is shown")
    if _cached is not None and not refresh:
        return _cached
    _cached = _probe()
    return _cached


def _probe() -> tuple[bool, str]:
    try:
        from OpenGL import GL  # noqa: F401
    except ImportError:
        return False, "PyOpenGL is not installed (pip install PyOpenGL): the 2D twin is shown"
    except Exception as exc:  # PyOpenGL raises various errors when libGL itself is missing
        return False, f"PyOpenGL cannot load an OpenGL library ({exc}); install libgl1 libegl1"
    try:
        import pyqtgraph.opengl  # noqa: F401
    except Exception as exc:
        return False, f"pyqtgraph.opengl cannot be imported ({exc})"
    context = QtGui.QOpenGLContext()
    if not context.create():
        return False, "no OpenGL context could be created (no GPU driver or Mesa: install libgl1 libegl1)"
    surface = QtGui.QOffscreenSurface()
    surface.setFormat(context.format())
    surface.create()
    try:
        if not surface.isValid() or not context.makeCurrent(surface):
            return False, "an OpenGL context was created but cannot be made current"
        version = context.format().version()
        context.doneCurrent()
    finally:
        surface.destroy()
    if tuple(version) < MIN_GL_VERSION:
        return False, (f"OpenGL {version[0]}.{version[1]} is older than"
                       f" {MIN_GL_VERSION[0]}.{MIN_GL_VERSION[1]}, which the 3D view needs")
    kind = "OpenGL ES" if context.isOpenGLES() else "OpenGL"
    return True, f"{kind} {version[0]}.{version[1]}"


def make_twin_3d(parent: QtWidgets.QWidget | None = None) -> Optional["ArmTwin3D"]:
    """An ArmTwin3D, or None when OpenGL is not available (see :func:`available_3d`)."""
    ok, _ = available_3d()
    if not ok:
        return None
    try:
        return ArmTwin3D(parent)
    except Exception:  # a driver that fails past the probe: keep the 2D twin
        return None


def _forget_shader_programs(gl: Any) -> None:
    """Make pyqtgraph compile its shader programs again, in the next view's GL context.

    pyqtgraph caches one program per item class, valid only in the context that compiled it
    (pyqtgraph issues #1822, #3455): a second GLViewWidget — e.g. one made after the first was
    closed — then fails with ``GLError 1281 glUseProgram``. With ``Qt.AA_ShareOpenGLContexts``
    set before the QApplication is created every view shares one context and nothing is
    needed; without it the newest view wins (an older one still alive would fail to draw).
    """
    if QtCore.QCoreApplication.testAttribute(QtCore.Qt.ApplicationAttribute.AA_ShareOpenGLContexts):
        return
    for name in ("GLLinePlotItem", "GLScatterPlotItem", "GLImageItem", "GLVolumeItem"):
        cls = getattr(gl, name, None)
        if cls is not None and hasattr(cls, "_shaderProgram"):
            cls._shaderProgram = None


def segment_pairs(points: Optional[np.ndarray]) -> np.ndarray:
    """Polylines with NaN rows between them, (N,3), as GL "lines" pairs (2K,3); NaN-safe."""
    if points is None or len(points) < 2:
        return np.zeros((0, 3))
    a = np.asarray(points, dtype=float).reshape(-1, 3)
    ok = np.isfinite(a).all(axis=1)
    keep = ok[:-1] & ok[1:]
    starts, ends = a[:-1][keep], a[1:][keep]
    out = np.empty((2 * len(starts), 3))
    out[0::2], out[1::2] = starts, ends
    return out


def box_edges(box_min: Sequence[float], box_max: Sequence[float]) -> np.ndarray:
    """The 12 edges of an axis-aligned box as GL "lines" pairs, (24,3), in the boxes' units."""
    lo, hi = np.asarray(box_min, dtype=float).reshape(3), np.asarray(box_max, dtype=float).reshape(3)
    corners = np.array([[(hi if (i >> k) & 1 else lo)[k] for k in range(3)] for i in range(8)])
    pairs = [(i, i | (1 << k)) for i in range(8) for k in range(3) if not (i >> k) & 1]
    return np.array([corners[j] for pair in pairs for j in pair])


def _plane_points(sz_m: np.ndarray, azimuth_rad: float) -> np.ndarray:
    """(s, z) rows in the vertical plane at ``azimuth_rad`` as robot_base points (N,3)."""
    sz = np.asarray(sz_m, dtype=float).reshape(-1, 2)
    c, s = math.cos(azimuth_rad), math.sin(azimuth_rad)
    return np.column_stack([sz[:, 0] * c, sz[:, 0] * s, sz[:, 1]])


class ArmTwin3D(TwinBase, QtWidgets.QWidget):
    """A 3D view of the arm on the desk: the same inputs and calls as ``ArmTwin``.

    Drag to orbit; the buttons (finger-sized) reset the view, look from the top or the side,
    and zoom. The workspace is drawn as the top outline on the desk and the side outline in
    the arm's vertical plane. Raises RuntimeError (with :func:`available_3d`'s reason) when
    OpenGL is not available: use :func:`make_twin_3d`.

    Signals: none (display only).
    """

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        ok, reason = available_3d()
        if not ok:
            raise RuntimeError(f"ArmTwin3D: {reason}")
        super().__init__(parent)
        import pyqtgraph.opengl as gl

        _forget_shader_programs(gl)
        self._gl = gl
        self._azimuth = math.pi / 2
        self._fixed_azimuth: Optional[float] = None
        self._chain_start = 0
        self._anchors: Optional[list[tuple[int, int]]] = None
        self._levels: Optional[list[str]] = None
        self._commanded: Optional[np.ndarray] = None
        self._measured: Optional[np.ndarray] = None
        self._extra_chains: list[np.ndarray] = []
        self._top_outline: Optional[np.ndarray] = None
        self._side_outline: Optional[np.ndarray] = None
        self._target: Optional[np.ndarray] = None
        self._reachable = True
        self._aimed: Optional[np.ndarray] = None
        self._markers: dict[int, np.ndarray] = {}
        self._marker_labels: list[Any] = []
        self._home_radius = 40.0  # cm, set by set_view_range
        self._home_camera = dict(elevation=CAMERA_ELEVATION_DEG, azimuth=CAMERA_AZIMUTH_DEG,
                                 center=(0.0, 0.0, 10.0))
        self._at_home = True  # the camera is where reset_camera put it (kept so on resize)
        self._measured_label = "measured"

        self.view = gl.GLViewWidget()
        self.view.setBackgroundColor("k")
        self.view.setMinimumSize(*VIEW_MIN_SIZE)
        self.grid = gl.GLGridItem(color=(255, 255, 255, 40))
        self.grid.setSpacing(DESK_GRID_STEP_CM, DESK_GRID_STEP_CM)
        self.grid.setSize(100.0, 100.0)
        self.view.addItem(self.grid)

        def lines(colour, width, mode="lines"):
            item = gl.GLLinePlotItem(pos=np.zeros((0, 3)), color=_rgba(colour), width=width,
                                     mode=mode, antialias=True)
            self.view.addItem(item)
            return item

        def dots(colour, size):
            item = gl.GLScatterPlotItem(pos=np.zeros((0, 3)), color=_rgba(colour), size=size,
                                        pxMode=True)
            # no depth test: a later dot at the same place (a joint's level over the chain's
            # dot) must win, and the arm's dots stay visible through the workspace lines
            from OpenGL import GL
            item.setGLOptions({GL.GL_DEPTH_TEST: False, GL.GL_BLEND: True,
                               GL.GL_CULL_FACE: False,
                               "glBlendFunc": (GL.GL_SRC_ALPHA, GL.GL_ONE_MINUS_SRC_ALPHA)})
            self.view.addItem(item)
            return item

        self.workspace = lines(WORKSPACE_COLOUR, 1)
        self.structure = lines(STRUCTURE_COLOUR, 3)
        self.keep_out = lines(KEEP_OUT_COLOUR, 2)  # the profile's keep-out boxes, wireframe
        self.preview = lines(PREVIEW_COLOUR, 1)
        self.commanded = lines(COMMANDED_COLOUR, 2)
        self.extra = lines(MEASURED_COLOUR, 4)
        self.measured = lines(MEASURED_COLOUR, 5)
        self.aim_line = lines(AIMED_COLOUR, 1)
        self.measured_points = dots(MEASURED_COLOUR, 9)
        self.joints = dots(MEASURED_COLOUR, 10)
        self.base = dots((90, 90, 90), 12)
        self.base.setData(pos=np.zeros((1, 3)))
        self.markers = dots(MARKER_COLOUR, 10)
        self.aimed = dots(AIMED_COLOUR, 12)
        self.target = lines(REACHABLE_COLOUR, 3)  # a 3D cross, as the 2D views' "+"
        for item in (self.joints, self.markers, self.aimed, self.measured_points):
            item.setVisible(False)
        # drawn in this order (the dots have no depth test): dots over lines,
        # the joint levels over the chain's own dots
        for depth, item in enumerate((self.workspace, self.structure, self.keep_out, self.preview,
                                      self.commanded, self.extra, self.measured, self.aim_line,
                                      self.target, self.base, self.markers,
                                      self.measured_points, self.joints, self.aimed)):
            item.setDepthValue(depth)

        self.legend_label = make_legend_label()
        self._update_legend()

        self.buttons: dict[str, QtWidgets.QPushButton] = {}
        # the finger-sized buttons fill a grid beside the view: one column when the twin is
        # tall, more when it is short (the twin is ~150 px tall in an 800x480 window)
        self._button_grid = QtWidgets.QGridLayout()
        self._button_grid.setContentsMargins(0, 0, 0, 0)
        self._button_grid.setSpacing(BUTTON_SPACING_PX)
        for key, text, slot in (("reset", "Reset", self.reset_camera),
                                ("top", "Top", lambda: self.look_from("top")),
                                ("side", "Side", lambda: self.look_from("side")),
                                ("zoom_in", "+", lambda: self.zoom(1.0 / ZOOM_STEP)),
                                ("zoom_out", "−", lambda: self.zoom(ZOOM_STEP))):
            button = touch_button(text)
            button.clicked.connect(slot)
            self.buttons[key] = button
        self._button_rows = 0
        self._arrange_buttons(len(self.buttons))
        column = QtWidgets.QVBoxLayout()
        column.setContentsMargins(0, 0, 0, 0)
        column.addLayout(self._button_grid)
        column.addStretch(1)
        row = QtWidgets.QHBoxLayout()
        row.setContentsMargins(0, 0, 0, 0)
        row.setSpacing(2)
        row.addWidget(self.view, 1)
        row.addLayout(column)
        outer = QtWidgets.QVBoxLayout(self)
        outer.setContentsMargins(0, 0, 0, 0)
        outer.setSpacing(0)
        outer.addLayout(row, 1)
        outer.addWidget(self.legend_label)
        # set, not the layout's: with one column of buttons that would be ~280 px, and a
        # short stack could never give the twin the height that makes the buttons re-flow
        self.setMinimumSize(*TWIN_MIN_SIZE)
        self.view.installEventFilter(self)
        self.reset_camera()

    # ----------------------------------------------------------------------------- public API
    @property
    def azimuth(self) -> float:
        """The azimuth (rad) of the arm plane in which the side outline is drawn."""
        return self._azimuth

    def configure_for(self, profile: Any, kinematics: Any) -> None:
        """Set up the scene for a profile and its solver, as ``ArmTwin.configure_for``: desk
        grid and camera sized to the workspace, outlines, fixed parts, joint dots' places."""
        half_width, _, z_max = view_extent(profile, kinematics)
        self.set_view_range(half_width, z_max)
        self.set_workspace(*workspace_outlines(kinematics, profile))
        self._anchors = joint_anchors_for(profile)
        self._chain_start = chain_start_for(profile)
        structure = polylines_with_gaps(structure_segments(profile, kinematics))
        self.structure.setData(pos=segment_pairs(None if structure is None
                                                 else structure * M_TO_CM))
        self.set_keep_out(keep_out_boxes_for(profile))
        self._levels = None
        self.set_extra_segments(None)
        self.set_arm(None, None)
        self.set_side_azimuth(side_azimuth_for(profile))

    def set_keep_out(self, boxes: Sequence[tuple[str, Sequence[float], Sequence[float]]],
                     desk_margin_m: float = 0.0) -> None:
        """Draw keep-out boxes — (name, min, max) in m, robot_base — as red wireframes
        (``desk_margin_m`` is accepted for the 2D twin's signature; the desk plane is drawn)."""
        edges = [box_edges(lo, hi) * M_TO_CM for _, lo, hi in boxes]
        self.keep_out.setData(pos=np.vstack(edges) if edges else np.zeros((0, 3)))

    def set_view_range(self, xy_half_width_m: float, z_max_m: float,
                       z_min_m: Optional[float] = None) -> None:
        """Size the desk grid to ±half width and aim the home camera at the workspace."""
        hw, z_max = xy_half_width_m * M_TO_CM, z_max_m * M_TO_CM
        side = 2.0 * math.ceil(hw / DESK_GRID_STEP_CM) * DESK_GRID_STEP_CM
        self.grid.setSize(side, side)
        self._home_radius = math.hypot(hw, 0.5 * z_max)  # cm: the workspace's bounding sphere
        self._home_camera = dict(elevation=CAMERA_ELEVATION_DEG, azimuth=CAMERA_AZIMUTH_DEG,
                                 center=(0.0, 0.0, 0.45 * z_max))
        self.reset_camera()

    def set_side_azimuth(self, azimuth_rad: Optional[float]) -> None:
        """Draw the side outline in the plane at ``azimuth_rad`` (rad), or None: the tool's."""
        self._fixed_azimuth = None if azimuth_rad is None else float(azimuth_rad)
        self._azimuth = (self._fixed_azimuth if self._fixed_azimuth is not None
                         else arm_azimuth(self._commanded, self._measured, self._azimuth))
        self._draw_workspace()

    def set_arm(self, commanded: Optional[np.ndarray], measured: Optional[np.ndarray]) -> None:
        """Draw the commanded (thin, translucent) and measured (thick) chains, (N,3) m, or None."""
        if not self._take_arm(commanded, measured):
            return
        start = self._chain_start
        for chain, item in ((self._commanded, self.commanded), (self._measured, self.measured)):
            drawn = None if chain is None else chain[start:] * M_TO_CM
            item.setData(pos=segment_pairs(drawn))
        pts = np.zeros((0, 3)) if self._measured is None else self._measured[start:] * M_TO_CM
        self._set_dots(self.measured_points, pts)
        if self._fixed_azimuth is None:
            azimuth = arm_azimuth(self._commanded, self._measured, self._azimuth)
            if abs(azimuth - self._azimuth) > 1e-4:
                self._azimuth = azimuth
                self._draw_workspace()
        self._draw_joints()

    def set_extra_segments(self, segments: Optional[Sequence[np.ndarray]]) -> None:
        """Draw more chains beside the measured one (the delta's arms), each (N,3) m, or None."""
        chains = [] if segments is None else [np.asarray(s, dtype=float).reshape(-1, 3) for s in segments]
        if same_chains(chains, self._extra_chains) and not self.redraw_unchanged:
            return
        self._extra_chains = chains
        joined = polylines_with_gaps(self._extra_chains)
        self.extra.setData(pos=segment_pairs(None if joined is None else joined * M_TO_CM))
        self._draw_joints()

    def _colour_target(self, colour: str) -> None:
        self.target.setData(color=_rgba(colour))

    def set_workspace(self, top_outline: Optional[np.ndarray],
                      side_outline: Optional[np.ndarray]) -> None:
        """Reachable outlines in metres: top (M,2) x, y on the desk; side (K,2) s, z drawn in
        the arm's plane. NaN rows separate polylines; one without NaN rows is closed."""
        self._top_outline = None if top_outline is None else np.asarray(top_outline, float).reshape(-1, 2)
        self._side_outline = None if side_outline is None else np.asarray(side_outline, float).reshape(-1, 2)
        self._draw_workspace()

    def set_preview(self, points: Optional[np.ndarray]) -> None:
        """Draw a faint preview curve (P,3) m (e.g. the Lissajous path)."""
        pts = None if points is None else np.asarray(points, dtype=float).reshape(-1, 3) * M_TO_CM
        self.preview.setData(pos=segment_pairs(pts))

    def set_markers(self, points: Mapping[int, np.ndarray]) -> None:
        """Draw marker positions {id: (3,) m} as dots with their ids, and list each one's id and
        position (x, y, z cm in robot_base) in the legend."""
        markers = {int(k): np.asarray(v, dtype=float).reshape(3) for k, v in points.items()}
        if same_marker_points(markers, self._markers) and not self.redraw_unchanged:
            return
        self._markers = markers
        ids = sorted(self._markers)
        xyz = np.array([self._markers[i] for i in ids]).reshape(-1, 3) * M_TO_CM
        self._set_dots(self.markers, xyz)
        while len(self._marker_labels) < len(ids):
            label = self._gl.GLTextItem(color=QtGui.QColor(*MARKER_COLOUR))
            label.setDepthValue(100)  # last: drawn with a QPainter over the GL items
            self.view.addItem(label)
            self._marker_labels.append(label)
        for label, marker_id, p in zip(self._marker_labels, ids, xyz):
            label.setData(pos=p + (1.0, 1.0, 1.0), text=str(marker_id))
            label.setVisible(True)
        for label in self._marker_labels[len(ids):]:
            label.setVisible(False)
        self._show_marker_positions(self._markers)

    def reset_camera(self) -> None:
        """Back to the home view: from the front right, a little above, the whole workspace."""
        cam = self._home_camera
        self.view.setCameraPosition(pos=QtGui.QVector3D(*cam["center"]),
                                    distance=self._home_distance(),
                                    elevation=cam["elevation"], azimuth=cam["azimuth"])
        self._at_home = True

    def _home_distance(self) -> float:
        """Camera distance (cm) at which the workspace's bounding sphere fills the view.

        pyqtgraph's field of view is horizontal: on a wide, short view the vertical one is
        what limits.
        """
        w, h = max(1, self.view.width()), max(1, self.view.height())
        half = math.radians(0.5 * float(self.view.opts.get("fov", 60.0)))
        tan_half = math.tan(half) * min(1.0, h / w)
        return CAMERA_MARGIN * self._home_radius / math.sin(math.atan(tan_half))

    def look_from(self, where: str) -> None:
        """Look straight down ("top") or across the arm's plane ("side")."""
        self._at_home = False
        if where == "top":
            self.view.setCameraPosition(elevation=90.0, azimuth=-90.0)
        elif where == "side":
            self.view.setCameraPosition(elevation=0.0, azimuth=math.degrees(self._azimuth) - 90.0)
        else:
            raise ValueError(f"look_from({where!r}): expected 'top' or 'side'")

    def zoom(self, factor: float) -> None:
        """Move the camera ``factor`` times as far from its centre (< 1 zooms in)."""
        self._at_home = False
        self.view.setCameraPosition(distance=self.view.opts["distance"] * float(factor))

    def grab_frame(self) -> QtGui.QImage:
        """The 3D view as rendered now (the GL framebuffer), e.g. for a screenshot or a test."""
        return self.view.grabFramebuffer()

    # ----------------------------------------------------------------------------- internals
    @staticmethod
    def _set_dots(item: Any, pts_cm: np.ndarray, **kwargs) -> None:
        item.setData(pos=np.asarray(pts_cm, dtype=float).reshape(-1, 3), **kwargs)
        item.setVisible(len(pts_cm) > 0)

    def _draw_workspace(self) -> None:
        parts = []
        top = self._top_outline
        if top is not None and len(top):
            t = np.column_stack([top, np.zeros(len(top))])
            parts.append(_closed(t))
        if self._side_outline is not None and len(self._side_outline):
            parts.append(_closed(_plane_points(self._side_outline, self._azimuth)))
        joined = polylines_with_gaps(parts)
        self.workspace.setData(pos=segment_pairs(None if joined is None else joined * M_TO_CM))

    def _draw_joints(self) -> None:
        pts, levels = joint_dot_positions(self._levels, self._anchors, self._measured,
                                          self._extra_chains)
        colours = np.array([_rgba(LEVEL_COLOURS[v]) for v in levels]).reshape(-1, 4)
        sizes = np.array([LEVEL_DOT_PX[v] for v in levels], dtype=float)
        self._set_dots(self.joints, pts * M_TO_CM, color=colours, size=sizes)

    def _draw_target(self) -> None:
        t = np.zeros((0, 3)) if self._target is None else self._target[None, :] * M_TO_CM
        a = np.zeros((0, 3)) if self._aimed is None else self._aimed[None, :] * M_TO_CM
        self.target.setData(pos=_cross(t[0]) if len(t) else np.zeros((0, 3)))
        self._set_dots(self.aimed, a)
        self.aim_line.setData(pos=np.vstack([t, a]) if len(t) and len(a) else np.zeros((0, 3)))

    def sizeHint(self) -> QtCore.QSize:  # noqa: N802 (Qt override)
        """As the 2D twin's, so the two swap in a layout without a jump."""
        return QtCore.QSize(480, 260)

    def button_rows(self) -> int:
        """How many rows the view buttons are arranged in (1 to 5)."""
        return self._button_rows

    def resizeEvent(self, event) -> None:  # noqa: N802 (Qt override)
        """Re-flow the buttons to the new height (before the layout places them)."""
        self._fit_buttons(event.size())
        super().resizeEvent(event)

    def _update_legend(self) -> None:
        super()._update_legend()
        self._fit_buttons(self.size())  # more legend lines leave less height for the buttons

    def _fit_buttons(self, size: QtCore.QSize) -> None:
        """As many button rows as the height beside the view holds (at least one)."""
        if not hasattr(self, "_button_grid"):
            return  # the legend is set up before the buttons
        room = size.height() - self.legend_label.height_for_width(size.width())
        button_h = max(b.minimumSizeHint().height() for b in self.buttons.values())
        rows = (room + BUTTON_SPACING_PX) // (button_h + BUTTON_SPACING_PX)
        self._arrange_buttons(max(1, min(len(self.buttons), rows)))

    def _arrange_buttons(self, rows: int) -> None:
        if rows == self._button_rows:
            return
        self._button_rows = rows
        for button in self.buttons.values():
            self._button_grid.removeWidget(button)
        for i, button in enumerate(self.buttons.values()):  # down the columns, in order
            self._button_grid.addWidget(button, i % rows, i // rows)

    def eventFilter(self, watched: QtCore.QObject, event: QtCore.QEvent) -> bool:  # noqa: N802
        """Note when the user moves the camera (drag, wheel), so a resize keeps their view;
        refit the home view when the GL view is resized."""
        if watched is self.view:
            kind = event.type()
            if kind in (QtCore.QEvent.Type.MouseButtonPress, QtCore.QEvent.Type.Wheel,
                        QtCore.QEvent.Type.TouchBegin):
                self._at_home = False
            elif kind == QtCore.QEvent.Type.Resize and self._at_home:
                QtCore.QTimer.singleShot(0, self._refit_home)
        return super().eventFilter(watched, event)

    def _refit_home(self) -> None:
        if self._at_home:
            self.reset_camera()


def _cross(centre_cm: np.ndarray, half_cm: float = TARGET_CROSS_HALF_CM) -> np.ndarray:
    """Three axis-aligned segments through a point, as GL "lines" pairs (6,3) in cm."""
    offsets = np.repeat(np.eye(3) * half_cm, 2, axis=0) * np.tile([[1.0], [-1.0]], (3, 1))
    return np.asarray(centre_cm, dtype=float) + offsets


def _closed(points: np.ndarray) -> np.ndarray:
    """A polyline without NaN rows closed on its first point; one with NaN rows as it is."""
    if np.isfinite(points).all() and len(points) > 2 and not np.array_equal(points[0], points[-1]):
        return np.vstack([points, points[:1]])
    return points


