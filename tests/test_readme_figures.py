"""The README's measured figures are what the command it names measures now (on the simulated
clock the runs are repeatable): each stated number equals the measured one at the precision it
is written with. A change that moves them must update the README."""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())  # one line: paragraphs wrap


def run_json(*argv: str) -> dict:
    """The JSON object of ``deskarm ARGV`` (its last line that is one)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), QT_QPA_PLATFORM="offscreen")
    done = subprocess.run([sys.executable, "-m", "app.cli", *argv], cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    assert lines, done.stdout[-2000:]
    return json.loads(lines[-1])


def same_as_written(written: str, measured: float) -> bool:
    """``measured`` rounded to the decimals of ``written`` equals it."""
    decimals = len(written.split(".")[1]) if "." in written else 0
    return round(measured, decimals) == float(written)


def test_the_teleop_figures_are_what_the_named_command_measures():
    text = re.search(r"Measured with desk_rrr(?: by the first command above)?: calibrate detected at ([\d.]+) s "
                     r"\(true ([\d.]+)\), end at ([\d.]+) s \(true ([\d.]+)\), tracking ([\d.]+) / ([\d.]+) mm "
                     r"p50 / p95", README)
    assert text, "the README's teleop figures moved: update this test's pattern with them"
    assert ".venv/bin/deskarm --headless --fast --scenario teleop --duration 24 --json" in README
    out = run_json("--headless", "--fast", "--scenario", "teleop", "--duration", "24", "--json")
    events = {e["event"]: e for e in out["gesture_events"]}
    measured = (events["calibrate"]["t_detected"], events["calibrate"]["t_true"], events["end"]["t_detected"],
                events["end"]["t_true"], out["teleop_tracking_mm_p50"], out["teleop_tracking_mm_p95"])
    stated = text.groups()
    assert all(same_as_written(w, m) for w, m in zip(stated, measured)), (stated, measured)


@pytest.mark.parametrize("compensated", [True, False])
def test_the_skew_figures_are_what_the_named_command_measures(compensated):
    command = "deskarm --headless --fast --scenario objects --detector hsv --sim-skew-ms 16 --json"
    text = re.search(r"with `--sim-skew-ms 16`, (?:fast|moving) objects ([\d.]+) mm p50 with skew compensation "
                     r"and ([\d.]+) mm without", README)
    assert text, "the README's skew figures moved: update this test's pattern with them"
    assert f"`error_3d_mm_p50_moving` of `{command}`, then with `--no-skew-compensation`" in README
    argv = command.split()[1:] + ([] if compensated else ["--no-skew-compensation"])
    measured = run_json(*argv)["error_3d_mm_p50_moving"]
    stated = text.group(1 if compensated else 2)
    assert same_as_written(stated, measured), (stated, measured)
