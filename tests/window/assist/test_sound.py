"""The assistive view's sound cue on its own (app.assist.sound.HighlightSound, no AssistWindow): off,
a highlight move makes no cue and starts no player; on, each move starts the player (a real
process standing in for paplay) and a cue still sounding is not doubled."""
import subprocess
import sys

from app.assist.sound import HighlightSound
from app.sound_cue import SoundCue


def test_the_cue_is_made_on_first_use_and_sounds_only_when_the_settings_ask(tmp_path):
    started, made = [], []
    sound_on = {"on": False}

    def popen(command, **kw):  # a real process: a player that sounds until its stdin closes
        started.append(command)
        return subprocess.Popen([sys.executable, "-c", "import sys; sys.stdin.read()"], stdin=subprocess.PIPE)

    def make_cue():
        made.append(1)
        return SoundCue(lambda: None, cache_dir=tmp_path, which={"paplay": "/bin/paplay"}.get, popen=popen)

    sound = HighlightSound(lambda: sound_on["on"], make_cue)
    sound.moved(1)
    assert made == [] and started == []  # off: no tone written, no player looked for
    sound.close()  # nothing to let go
    sound_on["on"] = True
    sound.moved(2)
    sound.moved(3)  # the first still sounds: not doubled
    assert made == [1] and len(started) == 1 and started[0][0] == "/bin/paplay"
    cue = sound.cue()
    cue._playing.stdin.close()  # the tone ends
    cue._playing.wait(timeout=10)
    sound.moved(4)
    assert len(started) == 2 and made == [1]
    cue._playing.stdin.close()
    sound.close()
