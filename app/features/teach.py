"""The teach feature (issue 27): show the detector a new object, mark it once, and it learns it.

``TeachFeature`` owns the Teach tab's ``TeachPanel`` (its ``page``). "Take frames" collects up to
``MAX_FRAMES`` camera frames (every ``FRAME_STRIDE``-th frame handed to ``on_frame``, so ~6 s at
30 fps while the user moves the object); the user taps the object or draws a box on one or more of
them; "Teach" runs ``core.detect.learned.teach.teach`` in a QThread (``TeachRunner``): the tracker
carries the marks through the frames and the desk model is fine-tuned on CPU, with the progress
bar and time left on the panel. Cancel stops it and nothing is written (the old model stays).
When it is done the new model is in the user's config folder, and ``sigModelChanged(path)`` says
so (the window then rebuilds the "desk" detector, which loads it).

Signals (GUI thread): ``sigNote(str)`` — a message for the banner; ``sigModelChanged(str)`` — the
desk model file changed (taught).
"""
from __future__ import annotations

import threading
from typing import Optional

from PySide6 import QtCore

from core.detect.learned.teach import MAX_FRAMES, TeachConfig
from widgets.teach_panel import TeachPanel

FRAME_STRIDE = 3  # keep every 3rd frame while taking frames: 60 frames ≈ 6 s at 30 fps


class _Thread(QtCore.QThread):
    def __init__(self, fn):
        super().__init__()
        self._fn = fn

    def run(self) -> None:
        self._fn()


class TeachRunner(QtCore.QObject):
    """One teaching at a time in a QThread. Signals are emitted from the worker thread: connect
    them to GUI-thread slots. ``cancel()`` stops at the next step; ``stop()`` cancels and joins."""

    sigProgress = QtCore.Signal(float, float, str)
    sigFinished = QtCore.Signal(bool, str, str)  # ok, text, model path ("" unless ok)

    def __init__(self, config: TeachConfig = TeachConfig(), out_dir=None, base_model=None,
                 parent: Optional[QtCore.QObject] = None):
        super().__init__(parent)
        self.config = config
        self.out_dir = out_dir
        self.base_model = base_model
        self._cancel = threading.Event()
        self._thread: Optional[QtCore.QThread] = None

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.isRunning()

    def start(self, name: str, frames: list, marks: list) -> bool:
        if self.running:
            return False
        self._cancel.clear()
        frames, marks = list(frames), list(marks)
        self._thread = _Thread(lambda: self._run(name, frames, marks))
        self._thread.start()
        return True

    def _run(self, name: str, frames: list, marks: list) -> None:
        try:
            from core.detect.learned.teach import teach
            from core.sim.dataset import desk_negatives

            result = teach(name, frames, marks, base_model=self.base_model, out_dir=self.out_dir, config=self.config,
                           progress=lambda f, left, text: self.sigProgress.emit(float(f), float(left), str(text)),
                           cancelled=self._cancel.is_set, scene_negatives=desk_negatives)
        except ImportError:
            self.sigFinished.emit(False, "teaching needs torch: pip install -e '.[train]'", "")
            return
        except (ValueError, OSError) as exc:
            self.sigFinished.emit(False, str(exc), "")
            return
        if result is None:
            self.sigFinished.emit(False, "cancelled — the old model is kept", "")
        else:
            self.sigFinished.emit(True, f"taught {result.name!r} ({result.frames_used} frames, "
                                        f"{result.seconds:.0f} s)", str(result.path))

    def cancel(self) -> None:
        self._cancel.set()

    def stop(self) -> None:
        self.cancel()
        if self._thread is not None:
            self._thread.wait()
            self._thread = None


class TeachFeature(QtCore.QObject):
    """Frames, marks and the teaching run for the window (see the module docstring)."""

    sigNote = QtCore.Signal(str)
    sigModelChanged = QtCore.Signal(str)

    def __init__(self, session=None, config: TeachConfig = TeachConfig(), out_dir=None, base_model=None,
                 parent: Optional[QtCore.QObject] = None):
        super().__init__(parent)
        self.session = session
        self.page = self.teach_panel = TeachPanel()
        self.runner = TeachRunner(config, out_dir, base_model, parent=self)
        self.capturing = False
        self._frames: list = []
        self._seen = 0
        self.model_path: Optional[str] = None
        tp = self.teach_panel
        tp.sigCaptureRequested.connect(self.start_capture)
        tp.sigTeachRequested.connect(self.on_teach)
        tp.sigCancelRequested.connect(self.runner.cancel)
        self.runner.sigProgress.connect(self.on_progress, QtCore.Qt.ConnectionType.QueuedConnection)
        self.runner.sigFinished.connect(self.on_finished, QtCore.Qt.ConnectionType.QueuedConnection)

    @QtCore.Slot()
    def start_capture(self) -> None:
        self.capturing, self._frames, self._seen = True, [], 0
        self.teach_panel.hint.setText("taking frames: move the object slowly in front of the camera …")

    @QtCore.Slot(object)
    def on_frame(self, image) -> None:
        """A camera frame (BGR, the left view): kept while taking frames."""
        if not self.capturing or image is None:
            return
        if self._seen % FRAME_STRIDE == 0:
            self._frames.append(image.copy())
        self._seen += 1
        if len(self._frames) >= MAX_FRAMES:
            self.capturing = False
            self.teach_panel.set_frames(self._frames)

    def finish_capture(self) -> None:
        """Stop taking frames now (fewer than MAX_FRAMES) and show them."""
        if self.capturing:
            self.capturing = False
            self.teach_panel.set_frames(self._frames)

    @QtCore.Slot(str, list)
    def on_teach(self, name: str, marks: list) -> None:
        self.finish_capture()
        if not self.runner.start(name, self.teach_panel.frames, marks):
            self.sigNote.emit("teaching is already running")

    @QtCore.Slot(float, float, str)
    def on_progress(self, fraction: float, left: float, text: str) -> None:
        self.teach_panel.set_progress(fraction, left, text)

    @QtCore.Slot(bool, str, str)
    def on_finished(self, ok: bool, text: str, path: str) -> None:
        self.teach_panel.set_done(ok, text)
        self.sigNote.emit(text)
        if ok:
            self.model_path = path
            self.sigModelChanged.emit(path)

    def stop(self) -> None:
        """Cancel a running teaching and join its thread (before the window closes)."""
        self.runner.stop()
