"""The 3D twin under Xvfb + Mesa, in a child process (OpenGL is never touched offscreen).

The rest of the suite runs with ``QT_QPA_PLATFORM=offscreen``, where ``GLViewWidget`` has no
valid context and ``renderToArray`` segfaults; so this test starts ``xvfb-run`` with the xcb
platform and runs :func:`child` there (a crash fails this test, not the whole run). It skips,
saying why, when ``xvfb-run`` or ``xauth`` is missing, when the X server has no usable OpenGL,
and under CI (``CI`` set), whose result must not depend on a virtual display and Mesa — set
``DESKARM_TEST_XVFB=1`` to run it there too. Set up a machine for it with::

    apt-get install -y xvfb xauth libxcb-cursor0 libxcb-icccm4 libxcb-keysyms1 libgl1 libegl1
    pip install PyOpenGL
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
CHILD_TIMEOUT_S = 120
OPT_IN_ENV = "DESKARM_TEST_XVFB"
APT_HINT = "apt-get install -y xvfb xauth libxcb-cursor0 libxcb-icccm4 libxcb-keysyms1 libgl1 libegl1"


def _skip_reason() -> str:
    """Why this machine cannot (or should not) run the Xvfb test, or ""."""
    if os.environ.get("CI") and not os.environ.get(OPT_IN_ENV):
        return f"the Xvfb/OpenGL test does not gate CI (set {OPT_IN_ENV}=1 to run it)"
    for tool in ("xvfb-run", "xauth"):
        if shutil.which(tool) is None:
            return f"{tool} not found: the 3D twin is tested under Xvfb only ({APT_HINT})"
    return ""


def test_the_3d_twin_renders_an_arm_under_xvfb(tmp_path):
    reason = _skip_reason()
    if reason:
        pytest.skip(reason)
    png = tmp_path / "twin3d.png"
    env = {k: v for k, v in os.environ.items() if k not in ("DESKARM_NO_3D", "DISPLAY",
                                                            "WAYLAND_DISPLAY")}
    env.update(QT_QPA_PLATFORM="xcb", PYTHONPATH=str(ROOT), LIBGL_ALWAYS_SOFTWARE="1")
    cmd = ["xvfb-run", "-a", "-s", "-screen 0 1280x800x24",
           sys.executable, str(Path(__file__).resolve()), "--child", str(png)]
    try:
        proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True,
                              timeout=CHILD_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        pytest.fail(f"the Xvfb child did not finish within {CHILD_TIMEOUT_S} s")
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("{")]
    assert proc.returncode == 0 and lines, (
        f"the Xvfb child failed (exit {proc.returncode}):\n{proc.stdout[-2000:]}\n{proc.stderr[-3000:]}")
    report = json.loads(lines[-1])
    if report["status"] == "skip":
        pytest.skip(f"no OpenGL under Xvfb: {report['reason']}")
    assert report["status"] == "ok", report
    assert report["size"][0] > 200 and report["size"][1] > 100, report
    assert report["distinct_colours"] > 20, report  # not a blank (or single-colour) frame
    assert report["measured_px"] > 50, report  # the orange arm
    assert report["limit_px"] > 20, report  # the red joint dot at its limit
    assert report["view_home_fits"], report
    # the legend wraps instead of cutting, and lists the marker's id and position
    assert report["legend_has_marker"], report
    assert report["legend_fits"], report
    assert report["buttons_fit"] and report["button_rows"] < 5, report
    assert png.exists()


# ------------------------------------------------------------------------------- the child
def child(out_png: str) -> int:
    """Build the 3D twin under xcb, draw the delta near a limit, grab a frame, print stats."""
    import numpy as np
    from PySide6 import QtGui, QtWidgets

    import widgets  # noqa: F401
    from core.kinematics import build_kinematics, load_profile
    from widgets.arm_twin import profile_joint_levels
    from widgets.arm_twin_3d import ArmTwin3D, available_3d, make_twin_3d

    app = QtWidgets.QApplication([])
    ok, reason = available_3d()
    if not ok:
        print(json.dumps({"status": "skip", "reason": reason}))
        return 0
    twin = make_twin_3d()
    assert isinstance(twin, ArmTwin3D), "available_3d() said yes but make_twin_3d() gave None"
    profile = load_profile("delta")
    kin = build_kinematics(profile)
    twin.resize(800, 300)
    twin.configure_for(profile, kin)
    lo, hi = np.array(profile.q_min), np.array(profile.q_max)
    q = 0.5 * (lo + hi)
    q[0] = hi[0] - 0.01 * (hi[0] - lo[0])  # arm 0 at its limit: a red dot
    levels = profile_joint_levels(profile, q)
    assert levels[0] == "limit", levels
    chain = kin.chain_points(q)
    twin.set_arm(chain, chain)
    twin.set_extra_segments(list(kin.arm_segments(q)))
    twin.set_joint_levels(levels)
    twin.set_target(kin.fk(q), True)
    twin.set_markers({7: np.array([0.05, 0.05, 0.0])})
    twin.show()
    for _ in range(20):
        app.processEvents()
    image = twin.grab_frame().convertToFormat(QtGui.QImage.Format.Format_RGB888)
    image.save(out_png)
    w, h = image.width(), image.height()
    ptr = image.constBits()
    rgb = np.frombuffer(ptr, np.uint8, count=image.sizeInBytes()).reshape(h, image.bytesPerLine())
    rgb = rgb[:, : 3 * w].reshape(h, w, 3).astype(int)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    measured = (r > 200) & (g > 120) & (g < 200) & (b < 90)
    limit = (r > 200) & (g < 70) & (b < 70)
    fits = abs(twin.view.opts["distance"] - twin._home_distance()) < 1e-6 * twin._home_distance()
    # the size the main window gives the twin at 800x480: the legend wraps, the buttons
    # re-flow into columns, nothing is pushed out of the twin
    twin.resize(381, 150)
    for _ in range(20):
        app.processEvents()
    legend = twin.legend_label
    inside = twin.rect()
    legend_fits = (twin.height() == 150 and legend.sizeHint().width() <= legend.width()
                   and legend.sizeHint().height() <= legend.height()
                   and inside.contains(legend.geometry()))
    buttons_fit = all(inside.contains(b.geometry()) and not b.geometry().intersects(legend.geometry())
                      and b.height() >= 44 for b in twin.buttons.values())
    print(json.dumps({
        "status": "ok", "size": [w, h],
        "distinct_colours": int(len(np.unique(rgb.reshape(-1, 3), axis=0))),
        "measured_px": int(measured.sum()), "limit_px": int(limit.sum()),
        "view_home_fits": bool(fits), "gl": reason,
        "legend_has_marker": "7: x 5.0 y 5.0 z 0.0 cm" in twin.legend_text(),
        "legend_fits": bool(legend_fits), "legend_lines": legend.lines_text(),
        "buttons_fit": bool(buttons_fit), "button_rows": twin.button_rows(),
    }))
    twin.close()
    return 0


if __name__ == "__main__" and len(sys.argv) == 3 and sys.argv[1] == "--child":
    sys.exit(child(sys.argv[2]))
