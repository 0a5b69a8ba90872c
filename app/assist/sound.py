"""The assistive view's sound cue: a short tone each time the scan's highlight moves, when the
settings ask for it (``AssistSettings.sound``; ``app.sound_cue.SoundCue`` plays it)."""
from __future__ import annotations

from typing import Callable, Optional

from PySide6 import QtWidgets


class HighlightSound:
    """Plays the cue on ``moved()`` while ``enabled()``; the cue (``make_cue()``, default a
    ``SoundCue`` with the bell as its fall-back) is made on first use, so a view without sound never
    writes the tone or looks for a player."""

    def __init__(self, enabled: Callable[[], bool], make_cue: Optional[Callable[[], object]] = None):
        self._enabled = enabled
        self._make_cue = make_cue or _default_cue
        self._cue = None

    def cue(self):
        """The cue, made on first use."""
        if self._cue is None:
            self._cue = self._make_cue()
        return self._cue

    def moved(self, index: Optional[int] = None) -> None:
        """The highlight moved (to box ``index``): the cue sounds when the settings ask for it."""
        if self._enabled():
            self.cue().play()

    def close(self) -> None:
        """Let a tone still playing go (the player process is not waited for)."""
        if self._cue is not None:
            self._cue.close()


def _default_cue():
    from app.sound_cue import SoundCue

    return SoundCue(QtWidgets.QApplication.beep)
