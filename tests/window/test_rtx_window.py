"""The window on an emulated UMI-RTX (issue 24): it opens on the Robot tab with the encoder
initialisation panel (touch-sized, above the fold at 800x480); Start initialises the emulated arm;
then a pose typed in the Pose tab moves it, and the twin draws the joints read back from the
controller, not the commanded ones."""
from __future__ import annotations

import numpy as np
from PySide6 import QtCore

from tests.window.test_touch_window import make_window
from widgets._style import TOUCH_PX

TIMEOUT_MS = 60_000


def test_initialise_then_the_pose_tab_moves_the_emulated_arm_and_the_twin_shows_it(qtbot):
    w = make_window(qtbot, robot="umi_rtx", bridge="rtx:sim?speedup=60", size=(800, 480))
    try:
        panel = w.rtx.page
        assert panel is not None and w.tabs.currentWidget().isAncestorOf(w.robot.page)  # where the arm starts
        w.start()
        start = panel.start_button
        qtbot.waitUntil(lambda: start.isVisible() and start.isEnabled(), timeout=TIMEOUT_MS)
        top_left = start.mapTo(w, QtCore.QPoint(0, 0))
        assert start.height() >= TOUCH_PX and 0 <= top_left.y() and top_left.y() + start.height() <= w.height()
        qtbot.waitUntil(lambda: w.session.bridge.is_connected, timeout=TIMEOUT_MS)
        with qtbot.waitSignal(w.rtx.sigReady, timeout=TIMEOUT_MS, check_params_cb=lambda ok: ok):
            qtbot.mouseClick(start, QtCore.Qt.MouseButton.LeftButton, pos=start.rect().center())
        assert all(bar.value() == 100 for bar in panel.bars.values())
        qtbot.waitUntil(lambda: w._state is not None, timeout=TIMEOUT_MS)
        q_ready = np.array(w._state.q, dtype=float)

        w.tabs.setCurrentIndex(w._jog_tab_index)  # the Pose tab
        spin = w.pose_panel.spins["z"]
        spin.setFocus()
        for _ in range(5):  # a real key on the spin box: Z up in its steps
            qtbot.keyClick(spin, QtCore.Qt.Key.Key_Up)
        qtbot.waitUntil(lambda: w._command is not None, timeout=TIMEOUT_MS)

        def moved_and_read_back() -> bool:
            s = w._state
            return (s is not None and w._command is not None
                    and float(np.max(np.abs(np.array(s.q) - q_ready))) > 0.02
                    and float(np.max(np.abs(np.array(s.q) - np.array(w._command.q)))) < 0.02)
        qtbot.waitUntil(moved_and_read_back, timeout=TIMEOUT_MS)
        assert w.session.bridge.has_feedback
        w._dirty = True
        w.redraw()
        assert w._drawn_state is w._state  # the twin drew the read-back joints
        measured = w.twin._measured
        expected = w.session.kinematics.chain_points(w._state.q)
        assert measured is not None and np.allclose(measured, np.asarray(expected), atol=1e-6)
    finally:
        w.stop()
        bridge = w.session.bridge
        w.session.close()
        if hasattr(bridge, "shutdown"):
            bridge.shutdown()
