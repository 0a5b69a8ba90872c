"""The objects feature (issue 11): marker-less object detectors, colour picking, taps on objects.

``ObjectsFeature`` owns the Objects tab's ``DetectorPanel`` (its ``page``): the detectors it
asks for are built and re-tuned by the perception worker between frames, and what runs comes
back here (``running``). With "Pick colour" on, the next tap on a camera view turns the pixels
around it into a named HSV colour; a tap on an object's box makes the Target tab's Object mode
follow that object. "Sure above" sets per-class score thresholds: an object below its class's is
unsure — the camera views draw it grey (``attach_views``), OBJECT mode's targeting skips it and a
tap on it says so instead of following it.

Signals (GUI thread): ``sigNote(str)`` — a message for the banner; ``sigChanged()`` — something
drawn changed (the detectors that run).
"""
from __future__ import annotations

import dataclasses
from typing import Callable, Optional

from PySide6 import QtCore, QtWidgets

from core.detect.colour import colour_from_pixel
from core.detect.thresholds import ClassThresholds
from core.messages import TargetMode
from widgets.detector_panel import DetectorPanel

PICK_TOLERANCE_HUE = 10  # "Pick colour": hue ± this (OpenCV's 0…179) around the tapped pixels
NO_DETECTOR_HINT = "no object detector is on — switch one on in the Objects tab (e.g. hsv)"


class ObjectsFeature(QtCore.QObject):
    """Detectors and object taps for ``session``; ``target_panel``: the Target tab (its object
    list and hint); ``result``: the newest PerceptionResult (or None), when asked."""

    sigNote = QtCore.Signal(str)
    sigChanged = QtCore.Signal()

    def __init__(self, session, perception_worker, target_panel, result: Callable[[], object],
                 parent: Optional[QtCore.QObject] = None):
        super().__init__(parent)
        self.session = session
        self.perception = perception_worker
        self.target_panel = target_panel
        self._result = result
        self.page = self.detector_panel = DetectorPanel()  # marker-less objects: detectors and their settings
        self.detector_panel.sigDetectorsChanged.connect(self.on_detectors_changed)
        self.detector_panel.sigPickToggled.connect(self.on_pick_toggled)
        self.detector_panel.sigThresholdsChanged.connect(self.on_thresholds_changed)
        self._views: tuple = ()  # camera views that draw unsure objects grey (attach_views)
        self._classes: set = set()  # (label, kind) seen so far: the threshold list offers them
        session.targeter.set_object_thresholds(self.thresholds)
        perception_worker.sigResult.connect(self.on_result)
        perception_worker.sigDetectorsApplied.connect(self.on_detectors_applied)
        perception_worker.sigDetectorError.connect(self.on_detector_error)
        running = [(d.spec_name, d.params) for d in perception_worker.object_detectors()]  # --detector
        self.running: list[str] = [name for name, _ in running]  # what the perception worker runs (names)
        self.detector_panel.set_detectors(running)
        self.update_hint()

    @property
    def thresholds(self) -> ClassThresholds:
        """The per-class score thresholds of the Objects tab."""
        return self.detector_panel.thresholds

    def attach_views(self, views) -> None:
        """Camera views (``widgets.camera_view.CameraView``) that draw unsure objects grey."""
        self._views = tuple(views)
        for view in self._views:
            view.set_object_thresholds(self.thresholds)

    @QtCore.Slot(object)
    def on_thresholds_changed(self, thresholds) -> None:
        """"Sure above" moved: targeting and the views judge objects by the new thresholds."""
        self.session.targeter.set_object_thresholds(thresholds)
        for view in self._views:
            view.set_object_thresholds(thresholds)
        self.sigChanged.emit()

    @QtCore.Slot(object)
    def on_result(self, result) -> None:
        """A perception result: its object classes join the threshold's class list."""
        new = {(o.label, o.kind) for o in getattr(result, "objects", ())} - self._classes
        if new:
            self._classes |= new
            self.detector_panel.set_known_classes(sorted(new))

    def page_with(self, *panels) -> QtWidgets.QWidget:
        """The Objects tab: the detector panel, then ``panels`` (another feature's, e.g. Teach) below it."""
        page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(page)
        layout.setContentsMargins(0, 0, 0, 0)
        for widget in (self.detector_panel, *panels):
            layout.addWidget(widget)
        return page

    @property
    def picking(self) -> bool:
        """"Pick colour" is on: the next tap on a camera view picks a colour."""
        return self.detector_panel.picking

    @QtCore.Slot(object)
    def on_detectors_changed(self, specs) -> None:
        """The Objects tab wants these detectors (list of (name, options)): the perception
        worker builds or re-tunes them before its next frame."""
        if self.detector_panel.message() and not self.detector_panel.picking:
            self.detector_panel.set_message("")  # an old problem: the new request answers anew
        self.perception.request_detectors(specs)

    @QtCore.Slot(str)
    def reload_learned(self, path: str = "") -> None:
        """A taught model was saved (``path``): the learned detectors running now are built anew,
        so they load it — taken off, then (once the perception worker has done that) back on."""
        specs = [(d.spec_name, dataclasses.asdict(d.params)) for d in self.perception.object_detectors()]
        learned = [spec for spec in specs if spec[0] == "desk"]
        if not learned:
            self.sigNote.emit(f"Taught model saved ({path}): switch on the desk detector in Objects to use it")
            return
        self._reload_specs = specs
        self.perception.request_detectors([spec for spec in specs if spec[0] != "desk"])

    @QtCore.Slot(object)
    def on_detectors_applied(self, running) -> None:
        """The perception worker now runs these detectors ((name, settings) list)."""
        specs, self._reload_specs = getattr(self, "_reload_specs", None), None
        if specs is not None:  # the learned detectors are off: back on, built from the new model
            self.perception.request_detectors(specs)
        self.running = [name for name, _ in running]
        self.detector_panel.set_running(self.running)
        self.update_hint()
        self.sigChanged.emit()

    @QtCore.Slot(str)
    def on_detector_error(self, message: str) -> None:
        """A detector could not be built or failed while detecting (it is off now): say so in
        the Objects tab and the banner; everything else keeps running."""
        self.detector_panel.set_message(message, error=True)
        self.sigNote.emit(message)

    def update_hint(self) -> None:
        self.target_panel.set_object_hint("" if self.running else NO_DETECTOR_HINT)

    @QtCore.Slot(bool)
    def on_pick_toggled(self, on: bool) -> None:
        if on:
            self.sigNote.emit(f"Pick colour: tap the object in a camera view — it sets the colour "
                              f"“{self.detector_panel.pick_name()}”")

    def pick_colour_at(self, view, side: str, x_px: float, y_px: float) -> bool:
        """"Pick colour": the colour around pixel (x, y) of ``view``'s image (``side``: "left" or
        "right") becomes the named colour of the HSV detector (added or updated, the detector
        switched on). False (and a note) when there is no image there."""
        r = self._result()
        if view.display_mode != "image":
            self.sigNote.emit("Pick colour: switch the view back to the camera image, then tap the object")
            return False
        if r is None or r.frame is None:
            self.sigNote.emit("Pick colour: no camera image yet")
            return False
        image = r.frame.left if side == "left" else r.frame.right
        name = self.detector_panel.pick_name()
        try:
            colour = colour_from_pixel(image, x_px, y_px, tolerance=PICK_TOLERANCE_HUE, name=name)
        except ValueError as exc:
            self.sigNote.emit(f"Pick colour: {exc}")
            return False
        self.detector_panel.add_picked_colour(colour)
        self.sigNote.emit(f"colour “{name}” picked at ({x_px:.0f}, {y_px:.0f}) px: hue {colour.h_lo}…{colour.h_hi}, "
                          f"saturation ≥ {colour.s_lo}, value ≥ {colour.v_lo}")
        return True

    def follow_tapped(self, object_id: int) -> None:
        """A tap on an object's box: in Object mode the arm follows that object."""
        r = self._result()
        obs = None if r is None else r.object_observation(object_id)
        label = obs.label if obs is not None else ""
        name = f"{label or 'object'} #{object_id}"
        if obs is not None and hasattr(obs, "score") and not self.thresholds.is_sure(obs):
            limit = self.thresholds.threshold(obs.kind, obs.label)
            self.sigNote.emit(f"{name} is unsure (score {obs.score:.2f} < {limit:.2f}): not followed — lower "
                              f"the “Sure above” threshold of {label or 'its class'} in the Objects tab")
            return
        if self.session.targeter.mode is not TargetMode.OBJECT:
            self.sigNote.emit(f"{name}: choose the Target tab's Object mode to follow it")
            return
        self.target_panel.set_follow_object(label, object_id)  # the list shows it
        self.session.targeter.set_follow_object(label, object_id)
        self.sigNote.emit(f"following {name}")

    def mode_entered(self) -> None:
        """Object mode was chosen: follow the object chosen in the list; say when no detector runs."""
        chosen = self.target_panel.follow_object
        if chosen is not None:
            self.session.targeter.set_follow_object(*chosen)
        if not self.running:
            self.sigNote.emit(NO_DETECTOR_HINT)
