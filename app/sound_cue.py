"""A short sound when the assistive view's highlight moves (the optional sound cue).

``QApplication.beep()`` rings the X bell, which most desktops and a Raspberry Pi's touch screen
never sound. ``SoundCue`` writes a short tone once (a 16-bit mono WAV in the user's cache folder)
and plays it with the first player found — ``paplay`` (PulseAudio/PipeWire), ``pw-play``,
``aplay`` (ALSA: Raspberry Pi OS has it), ``afplay`` (macOS) — started in the background so the
window never waits for it; a cue still playing when the next one comes is not doubled. With
none of them it falls back to the bell and says so once (``message``).
"""
from __future__ import annotations

import math
import shutil
import struct
import subprocess
import wave
from pathlib import Path
from typing import Callable, Optional, Sequence

PLAYERS = (("paplay",), ("pw-play",), ("aplay", "-q"), ("afplay",))
TONE_HZ = 880.0
TONE_S = 0.08
RATE_HZ = 16000


def write_tone(path: Path, freq_hz: float = TONE_HZ, duration_s: float = TONE_S, rate_hz: int = RATE_HZ) -> Path:
    """A sine tone with 10 ms fades (no click) as a 16-bit mono WAV at ``path``."""
    n = max(1, int(round(duration_s * rate_hz)))
    fade = max(1, int(0.01 * rate_hz))
    frames = bytearray()
    for i in range(n):
        gain = min(1.0, i / fade, (n - 1 - i) / fade)
        frames += struct.pack("<h", int(0.5 * 32767 * gain * math.sin(2 * math.pi * freq_hz * i / rate_hz)))
    path.parent.mkdir(parents=True, exist_ok=True)
    with wave.open(str(path), "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(rate_hz)
        w.writeframes(bytes(frames))
    return path


def find_player(which: Callable[[str], Optional[str]] = shutil.which) -> Optional[Sequence[str]]:
    """The first available player's command (without the file), or None."""
    for command in PLAYERS:
        path = which(command[0])
        if path:
            return (path, *command[1:])
    return None


class SoundCue:
    """Plays the cue (see the module docstring). ``bell``: the fallback (``QApplication.beep``);
    ``which``/``popen``: injected by tests."""

    def __init__(self, bell: Callable[[], None], cache_dir: Optional[Path] = None,
                 which: Callable[[str], Optional[str]] = shutil.which, popen=subprocess.Popen):
        self._bell = bell
        self._popen = popen
        self._player = find_player(which)
        self._cache_dir = cache_dir
        self._file: Optional[Path] = None
        self._playing = None
        self.message = "" if self._player else "no sound player found (paplay, pw-play, aplay): using the bell"

    def _tone(self) -> Path:
        if self._file is None:
            if self._cache_dir is None:
                from core.paths import user_dir

                self._cache_dir = user_dir("cache")
            self._file = write_tone(Path(self._cache_dir) / "assist_cue.wav")
        return self._file

    def play(self) -> None:
        """Start the cue (never blocks); the bell when no player works."""
        if self._player is None:
            self._bell()
            return
        if self._playing is not None and self._playing.poll() is None:
            return  # the last cue still sounds
        try:
            self._playing = self._popen([*self._player, str(self._tone())], stdin=subprocess.DEVNULL,
                                        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        except OSError as exc:
            self._player = None
            self.message = f"the sound player failed ({exc}): using the bell"
            self._bell()

    def close(self) -> None:
        """Reap a cue still playing (a short tone: it ends by itself)."""
        playing, self._playing = self._playing, None
        if playing is not None and playing.poll() is None:
            try:
                playing.wait(timeout=1.0)
            except subprocess.TimeoutExpired:
                playing.kill()
                playing.wait()
