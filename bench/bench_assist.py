"""The assistive arm (issue 12): what one frame of its loop costs, as the window runs it.

Each trial is an ``AssistTrials`` scene (the lift panel, a random button, the arm at its ready
pose); the loop runs the approach frame by frame through ``GuardedArm`` on the simulated servo
arm, as ``deskarm --assist`` does (every joint value through the safety chain). Timed per frame
of ALIGN/APPROACH, interleaved in the same frame so every row saw the same machine state:

- **baseline**: ``SimHandCamera.render`` at the frame's joints — the hand camera's image alone
  (a real webcam replaces it with a grab);
- **loop frame**: ``AssistLoop.step`` (FSM, IBVS through the Pinocchio Jacobian, render, the
  circle detector in a window every 3rd frame, KCF or the Kalman between) — with the tracker
  and with ``tracker=False``;
- **safety chain**: ``GuardedArm.send`` (joint goal → clamps, speed limit, desk and keep-out
  check → the simulated servo arm).

Run alone: ``python -m bench.bench_assist [--quick]``.
"""
from __future__ import annotations

import time

import numpy as np

BASELINE = "assist baseline: hand camera render"


def _frames(tracker: bool, trials: int, seed: int = 0):
    """(render ms, step ms, chain ms) per ALIGN/APPROACH frame over ``trials`` approaches."""
    from app.cli_assist import AssistTrials, trial_scene
    from core.devices.guarded_arm import GuardedArm
    from core.devices.sim_arm import SimServoArm

    run = AssistTrials("touch", tracker=tracker, seed=seed)
    loop = run.loop
    render_ms, step_ms, chain_ms = [], [], []
    for i in range(trials):
        rng = np.random.default_rng([seed, i, 12])
        run.desk.set_scenario(trial_scene(rng))
        arm = GuardedArm(SimServoArm(loop.kin.profile), loop.kin, loop.frame_dt_s, now=lambda: 0.0)
        arm.connect()
        loop.reset(run.ready_q, 0.0)
        boxes = loop.offer()
        loop.select(int(rng.integers(0, len(boxes))))
        while loop.busy and loop.t < 20.0:
            servoing = loop.state in ("ALIGN", "APPROACH")
            t0 = time.perf_counter()
            loop.step()
            t1 = time.perf_counter()
            command = arm.send(loop.q, loop.t)
            t2 = time.perf_counter()
            loop.q = command.q
            if servoing:
                t3 = time.perf_counter()
                run.camera.render(loop.q, loop.t)
                render_ms.append((time.perf_counter() - t3) * 1e3)
                step_ms.append((t1 - t0) * 1e3)
                chain_ms.append((t2 - t1) * 1e3)
    return render_ms, step_ms, chain_ms


def rows(quick: bool = False) -> list[dict]:
    from bench.__main__ import _row

    trials = 2 if quick else 12
    render_k, step_k, chain_k = _frames(True, trials)
    render_n, step_n, _ = _frames(False, trials)
    return [
        _row(BASELINE, "ms/frame", render_k + render_n, extra="SimHandCamera.render, 640x480, ALIGN/APPROACH frames"),
        _row("assist loop frame: KCF between detections", "ms/frame", step_k, BASELINE,
             f"AssistLoop.step (FSM, IBVS, render, circles every 3rd frame), {trials} approaches"),
        _row("assist loop frame: no tracker (Kalman)", "ms/frame", step_n, BASELINE,
             f"the same with tracker=False, {trials} approaches"),
        _row("assist safety chain: GuardedArm.send", "ms/frame", chain_k, BASELINE,
             "joint goal -> clamps, speed limit, desk/keep-out check -> simulated servo arm"),
    ]


if __name__ == "__main__":  # pragma: no cover
    import sys

    from bench.__main__ import format_table

    print(format_table(rows("--quick" in sys.argv)))
