"""The assistive view's sound cue: a real WAV tone, played by the first player found without
blocking, not doubled while one still sounds, the bell when there is no player."""
import subprocess
import sys
import wave

from app.assist_window import AssistSettings
from app.sound_cue import SoundCue, find_player, write_tone


def test_the_tone_is_a_short_16_bit_mono_wav(tmp_path):
    path = write_tone(tmp_path / "cue.wav")
    with wave.open(str(path)) as w:
        assert (w.getnchannels(), w.getsampwidth(), w.getframerate()) == (1, 2, 16000)
        assert 0.07 <= w.getnframes() / w.getframerate() <= 0.09
        frames = w.readframes(w.getnframes())
    assert max(frames) > 0  # not silence


def test_the_first_player_on_the_path_is_chosen():
    found = {"aplay": "/usr/bin/aplay", "afplay": "/usr/bin/afplay"}
    assert find_player(found.get) == ("/usr/bin/aplay", "-q")
    assert find_player(lambda name: None) is None


def test_a_cue_runs_the_player_in_the_background_and_is_not_doubled(tmp_path):
    started = []

    def popen(command, **kw):  # a real process: a player that sounds for a moment
        started.append(command)
        return subprocess.Popen([sys.executable, "-c", "import sys; sys.stdin.read()"], stdin=subprocess.PIPE)

    bells = []
    cue = SoundCue(lambda: bells.append(1), cache_dir=tmp_path, which={"paplay": "/bin/paplay"}.get, popen=popen)
    cue.play()
    cue.play()  # the first still sounds: not started again
    assert len(started) == 1 and started[0][0] == "/bin/paplay" and started[0][-1].endswith("assist_cue.wav")
    cue._playing.stdin.close()  # the tone ends
    cue._playing.wait(timeout=10)
    cue.play()
    assert len(started) == 2 and bells == []
    cue._playing.stdin.close()
    cue.close()


def test_no_player_rings_the_bell_and_says_so(tmp_path):
    bells = []
    cue = SoundCue(lambda: bells.append(1), cache_dir=tmp_path, which=lambda name: None)
    cue.play()
    assert bells == [1] and "no sound player" in cue.message


def test_the_window_cues_each_highlight_move_when_sound_is_on(qtbot, monkeypatch):
    from test_assist_window import TIMEOUT_MS, sim_loop

    from app.assist_window import AssistWindow

    w = AssistWindow(sim_loop, worker_clock="sim")
    w.set_settings(AssistSettings(mode="scan2", sound=True))
    qtbot.addWidget(w)
    plays = []
    monkeypatch.setattr(w.sound, "cue", lambda: type("Cue", (), {"play": lambda self: plays.append(1),
                                                                 "close": lambda self: None})())
    try:
        w.start()
        qtbot.waitUntil(lambda: w.choosing, timeout=TIMEOUT_MS)
        before = len(plays)
        w.switch_down("key:Space")
        w.switch_up("key:Space")
        assert len(plays) == before + 1 and w.view.highlight == 1
    finally:
        w.stop()
