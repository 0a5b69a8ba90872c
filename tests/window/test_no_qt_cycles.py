"""Panels are freed by reference counting, not by the cycle collector: collecting a cycle that
holds a Qt parent and its child crashed PySide6 6.8.0.2 (the newest wheel Raspberry Pi OS Bookworm
can install, the oldest deskarm allows) with superqt's sliders in it, so the window's panels must
not make one (a Coalescer held its parent's method)."""
from __future__ import annotations

import gc
import weakref

import pytest

from widgets._style import Coalescer
from widgets.camera_controls import CameraSettingsPanel
from widgets.stereo_panel import StereoPanel


@pytest.mark.parametrize("panel_class", [CameraSettingsPanel, StereoPanel])
def test_a_dropped_panel_is_freed_without_the_cycle_collector(qtbot, panel_class):
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        panel = panel_class()
        alive = weakref.ref(panel)
        del panel
        assert alive() is None  # nothing but reference counting was needed
    finally:
        if was_enabled:
            gc.enable()


def test_a_coalescer_still_calls_its_owners_method(qtbot):
    calls = []

    class Owner:
        def changed(self):
            calls.append(1)

    owner = Owner()
    coalescer = Coalescer(10, owner.changed)
    coalescer.poke()
    qtbot.waitUntil(lambda: calls == [1], timeout=5000)
    coalescer.poke()
    coalescer.flush()  # the pending call now
    assert calls == [1, 1]
    coalescer.poke()
    del owner  # a method of an owner that is gone is not called (and does not keep it alive)
    coalescer.flush()
    assert calls == [1, 1]
    plain = []
    Coalescer(10, lambda: plain.append(1)).flush()  # nothing pending: no call
    assert plain == []
