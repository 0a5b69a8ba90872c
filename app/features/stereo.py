"""The stereo feature: the Stereo tab's block matching, presets per camera pair, the disparity
views' depth legend and the depth probe.

``StereoFeature`` owns the ``StereoPanel`` (its ``page``): the matcher's settings go to the
perception worker, presets are read and written here (widgets never touch files, per camera
pair, in the user's config folder). It keeps the (left, right) camera views' depth legend in
step with the settings and the calibration, turns disparity on while a view shows it, and a tap
on a disparity view measures the depth there (``depth_sample``), kept live frame after frame.
"""
from __future__ import annotations

from typing import Optional

from PySide6 import QtCore

from app.window_texts import depth_texts, format_depth
from core.vision.disparity import (
    PresetError,
    delete_preset,
    disparity_legend,
    list_presets,
    load_preset,
    save_preset,
)
from widgets.stereo_panel import StereoPanel

LEGEND_TICKS = 5


class StereoFeature(QtCore.QObject):
    """Stereo settings, presets, legend and depth probe for ``session``'s camera pair."""

    def __init__(self, session, perception_worker, views, parent: Optional[QtCore.QObject] = None):
        super().__init__(parent)
        self.session = session
        self.perception = perception_worker
        self.views = tuple(views)  # (left, right) CameraView
        self.page = self.stereo_panel = StereoPanel()
        self.probe: Optional[tuple[float, float]] = None  # tapped pixel of the disparity map
        self.depth_sample = None  # DepthSample at the probe, for tests and the readout
        sp = self.stereo_panel
        sp.sigParamsChanged.connect(self.on_sgbm_params)
        sp.sigMatchParamsChanged.connect(self.on_match_params)
        sp.sigPresetSaveRequested.connect(self.on_preset_save)
        sp.sigPresetLoadRequested.connect(self.on_preset_load)
        sp.sigPresetDeleteRequested.connect(self.on_preset_delete)
        for view in self.views:
            view.sigDisplayModeChanged.connect(self.on_display_mode)

    @QtCore.Slot(object)
    def on_sgbm_params(self, params) -> None:
        self.perception.set_sgbm_params(params)
        self.update_legend()

    @QtCore.Slot(object)
    def on_match_params(self, match) -> None:
        self.perception.set_match_params(match)

    @QtCore.Slot(str)
    def on_display_mode(self, _mode: str) -> None:
        wanted = "disparity" in (v.display_mode for v in self.views)
        self.perception.set_disparity_enabled(wanted)

    # --- presets (per camera pair, in the user's config folder) --------------------------------
    def show_initial_preset(self) -> None:
        """The preset the session starts with, and the depth legend for it."""
        self.load_initial_preset()
        self.update_legend()

    def load_initial_preset(self) -> None:
        """The pair's active preset, if it has one, into the panel and the worker."""
        pair = self.session.camera.pair_id
        try:
            names = list_presets(pair)
            loaded = load_preset(pair)
        except PresetError as exc:
            self.stereo_panel.set_presets([])
            self.stereo_panel.set_preset_status(str(exc), ok=False)
            return
        current = None
        if loaded is not None:
            self.stereo_panel.set_all(*loaded)
            self.perception.set_stereo_params(*loaded)
            current = next((n for n in names if load_preset(pair, n) == loaded), None)
        self.stereo_panel.set_presets(names, current)

    @QtCore.Slot(str)
    def on_preset_save(self, name: str) -> None:
        pair, sp = self.session.camera.pair_id, self.stereo_panel
        try:
            path = save_preset(pair, sp.params(), sp.match_params(), name)
            sp.set_presets(list_presets(pair), name)
        except (PresetError, OSError) as exc:
            sp.set_preset_status(str(exc), ok=False)
            return
        sp.set_preset_status(f"saved “{name}” for {pair} ({path.name})")

    @QtCore.Slot(str)
    def on_preset_load(self, name: str) -> None:
        pair, sp = self.session.camera.pair_id, self.stereo_panel
        try:
            loaded = load_preset(pair, name)
        except (PresetError, OSError) as exc:
            sp.set_preset_status(str(exc), ok=False)
            return
        if loaded is None:
            sp.set_preset_status(f"no preset “{name}” for {pair}", ok=False)
            return
        sp.set_all(*loaded)
        self.perception.set_stereo_params(*loaded)
        self.update_legend()
        sp.set_preset_status(f"loaded “{name}”")

    @QtCore.Slot(str)
    def on_preset_delete(self, name: str) -> None:
        pair, sp = self.session.camera.pair_id, self.stereo_panel
        try:
            existed = delete_preset(pair, name)
            sp.set_presets(list_presets(pair))
        except (PresetError, OSError) as exc:
            sp.set_preset_status(str(exc), ok=False)
            return
        sp.set_preset_status(f"deleted “{name}”" if existed else f"no preset “{name}” to delete", ok=existed)

    # --- disparity views: legend and depth probe ------------------------------------------------
    def update_legend(self) -> None:
        """Depth marks on the disparity colour bars for the current parameters and calibration."""
        p = self.stereo_panel.params()
        lo, hi = max(0.0, float(p.min_disparity)), float(p.min_disparity + p.num_disparities)
        ticks = [(t.disparity_px, f"{t.disparity_px:.0f} px\n{format_depth(t.depth_m)}")
                 for t in disparity_legend(self.session.calibration, lo, hi, LEGEND_TICKS)]
        for view in self.views:
            view.set_depth_legend(ticks)

    def max_disparity(self) -> float:
        params = self.stereo_panel.params()
        return float(params.num_disparities + params.min_disparity)

    def probe_at(self, view, x_px: float, y_px: float, result) -> bool:
        """A tap on ``view``: in disparity mode it measures the depth there (kept live until the
        next tap). False when the view shows the camera image."""
        if view.display_mode != "disparity":
            return False
        self.probe = (x_px, y_px)
        self.update_probe(result)
        return True

    def draw(self, result) -> None:
        """A new result with a disparity map: the probe's depth and the matcher's time."""
        if result.disparity is None:
            return
        self.update_probe(result)
        ms = result.timings_ms.get("disparity")
        if ms is not None:
            self.stereo_panel.set_timing(f"disparity {ms:.0f} ms per frame")

    def update_probe(self, result) -> None:
        r = result
        if self.probe is None or r is None or r.disparity is None:
            return
        x, y = self.probe
        sample = self.perception.disparity.depth_at(
            r.disparity, x, y, base_T_camera=self.session.perception.base_T_camera)
        text, readout = depth_texts(x, y, sample)
        for view in self.views:
            view.set_probe(x, y, text)
        self.stereo_panel.set_depth_readout(readout)
        self.depth_sample = sample
