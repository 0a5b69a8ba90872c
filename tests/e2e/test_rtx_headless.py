"""The UMI-RTX from the command line: ``python -m app.rtx_init`` (progress on stderr), the
``ensure_ready`` hook, and ``deskarm --headless --robot umi_rtx --bridge rtx:<pty>`` against the
emulator program — commands sent, no limit violation, no disconnect."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from app.rtx_init import ensure_ready, main as rtx_init_main
from core.devices import open_bridge
from core.devices.sim_arm import SimServoArm
from core.kinematics.profile import load_profile

ROOT = Path(__file__).resolve().parents[2]
TIMEOUT_S = 240


def test_rtx_init_cli_reports_each_joint_and_ends_ready(capsys):
    code = rtx_init_main(["--bridge", "rtx:sim?speedup=60"])
    err = capsys.readouterr().err
    assert code == 0, err
    for joint in ("column", "gripper", "wrist_roll", "wrist_pitch", "shoulder", "elbow", "wrist_yaw"):
        assert f"{joint} 100%" in err
    assert err.strip().endswith("rtx init: the arm is ready")


def test_rtx_init_cli_refuses_a_bridge_that_is_not_an_rtx(capsys):
    assert rtx_init_main(["--bridge", "sim://"]) == 2
    assert "not a UMI-RTX controller" in capsys.readouterr().err


def test_ensure_ready_initialises_an_rtx_and_leaves_other_bridges_alone():
    lines: list[str] = []
    profile = load_profile("umi_rtx")
    sim = SimServoArm(profile)
    sim.connect()
    assert ensure_ready(sim, lines.append) and lines == []
    bridge = open_bridge("rtx:sim?speedup=60", profile)
    try:
        bridge.connect()
        assert not bridge.ready
        assert ensure_ready(bridge, lines.append) and bridge.ready
        assert lines[-1] == "rtx init: initialised: the arm is ready"
        assert ensure_ready(bridge, lines.append)  # already ready: nothing more said
        assert lines[-1] == "rtx init: initialised: the arm is ready"
    finally:
        bridge.shutdown()


def test_headless_wander_drives_the_emulated_rtx_without_a_limit_violation(tmp_path):
    link = str(tmp_path / "rtx")
    emulator = subprocess.Popen([sys.executable, "-m", "core.devices.rtx_emulator", "--pty", "--link", link,
                                 "--time-scale", "60"], cwd=ROOT, stdout=subprocess.PIPE, text=True)
    try:
        assert emulator.stdout.readline().startswith("PORT ")
        env = dict(os.environ, QT_QPA_PLATFORM="offscreen")
        done = subprocess.run(
            [sys.executable, "-m", "app.cli", "--headless", "--robot", "umi_rtx", "--bridge", f"rtx:{link}?init=auto",
             "--camera", "sim", "--scenario", "wander", "--duration", "4", "--json"],
            cwd=ROOT, env=env, capture_output=True, text=True, timeout=TIMEOUT_S)
        assert done.returncode == 0, done.stderr
        summary = json.loads(done.stdout)
        assert summary["commands_sent"] > 0
        assert summary["limit_violations"] == 0
        assert summary["bridge_disconnects"] == 0
    finally:
        emulator.terminate()
        emulator.wait(30)


def test_rtx_init_answers_its_help_as_a_deskarm_tool(capsys):
    from app.rtx_init import run

    try:
        run("rtx-init", ["--help"])
    except SystemExit as exc:
        assert exc.code == 0
    assert "usage: deskarm rtx-init" in capsys.readouterr().out


def test_attach_status_says_the_auto_initialisation_or_that_motion_waits_for_one():
    from app.rtx_init import attach_status

    profile = load_profile("umi_rtx")
    lines: list[str] = []
    waiting = open_bridge("rtx:sim?speedup=60", profile)
    auto = open_bridge("rtx:sim?speedup=60&init=auto", profile)
    try:
        attach_status(waiting, lines.append)
        waiting.connect()
        assert len(lines) == 1 and "motion waits for it" in lines[0] and "?init=auto" in lines[0]
        lines.clear()
        attach_status(auto, lines.append)
        auto.connect()
        assert auto.ready and any("column 100%" in line for line in lines)
        assert lines[-1] == "rtx init: initialised: the arm is ready"
    finally:
        waiting.shutdown()
        auto.shutdown()
