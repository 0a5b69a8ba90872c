"""``deskarm calibrate-hand-eye``: find where the cameras are against the arm (base_T_camera).

The arm carries its tool marker to spread poses (``core.handeye.HandEyeSweep``), the cameras
triangulate it, and a rigid solve gives camera_left's pose in robot_base. It drives the same core
objects as the headless runner (``DeskSession``, ``ArmController``, the bridge; the e-stop stops
it), on a simulated clock with ``--fast``. Saved only when the solve is good; exit 0 ok, 1 not ok
(the message says the fix), 2 bad arguments.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import replace
from typing import Optional

import numpy as np

from core.devices.bridge import BRIDGE_CHOICES, BridgeError
from core.messages import Goal, SequenceCounter, TargetMode
from core.vision.cameras import CAMERA_CHOICES

VIEW_MARGIN_PX = 40.0  # planned marker centres keep this far inside both images (nominal mount)


def parse_rig_offset(text: Optional[str]) -> Optional[tuple[float, ...]]:
    """"DX,DY,DZ,ROLL,PITCH,YAW" (m, degrees) → (m, rad) tuple; ValueError naming --rig-offset."""
    if text is None:
        return None
    from core.session import check_rig_offset_option

    try:
        v = [float(p) for p in str(text).split(",")]
    except ValueError:
        v = []
    if len(v) != 6:
        raise ValueError(f"--rig-offset {text!r} is not DX,DY,DZ,ROLL,PITCH,YAW (6 numbers: metres, degrees), "
                         "e.g. --rig-offset 0.03,-0.02,0.01,2,-3,4")
    return check_rig_offset_option((*v[:3], *(math.radians(a) for a in v[3:])))


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="deskarm calibrate-hand-eye",
        description="Move the arm's tool marker through spread poses, watch it with the stereo cameras and "
                    "solve where the cameras are against the arm (saved for the window and --headless).")
    p.add_argument("--camera", default="auto", help=f"camera source: {CAMERA_CHOICES} (default: auto)")
    p.add_argument("--bridge", default="sim://", help=f"motor bridge: {BRIDGE_CHOICES} (default: sim://)")
    p.add_argument("--robot", default="desk_rrr", help="robot profile name or TOML path (default: desk_rrr)")
    p.add_argument("--calibration", default=None, help="stereo calibration YAML (default: the last saved one)")
    p.add_argument("--rig-offset", default=None, metavar="DX,DY,DZ,ROLL,PITCH,YAW",
                   help="simulated desk: mount the rig this far off its nominal pose (m, degrees)")
    p.add_argument("--poses", type=int, default=12, help="poses to visit (default: 12, at least 4)")
    p.add_argument("--seed", type=int, default=0, help="seed of the planned poses (default: 0)")
    p.add_argument("--out", default=None, help="where to save (default: the config folder's hand_eye.toml)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of the summary")
    p.add_argument("--fast", action="store_true", help="run on a simulated clock as fast as possible")
    p.add_argument("--fps", type=float, default=30.0, help="camera frame rate (default: 30)")
    return p


def view_check(calibration, base_T_camera, margin_px: float = VIEW_MARGIN_PX):
    """``check(base_p) -> bool``: inside both images (by the calibration and this mount)."""
    camera_T_base = np.linalg.inv(np.asarray(base_T_camera, float))
    w, h = calibration.image_size
    R, T = np.asarray(calibration.R, float), np.asarray(calibration.T, float).reshape(3)

    def inside(M, cp) -> bool:
        if cp[2] <= 0.05:
            return False
        u = M @ (cp / cp[2])
        return margin_px <= u[0] <= w - 1 - margin_px and margin_px <= u[1] <= h - 1 - margin_px

    def check(base_p) -> bool:
        cp = camera_T_base[:3, :3] @ np.asarray(base_p, float) + camera_T_base[:3, 3]
        return inside(np.asarray(calibration.M1, float), cp) and inside(np.asarray(calibration.M2, float), R @ cp + T)

    return check


def run_sweep(session, n_poses: int = 12, seed: int = 0, hold_s: float = 0.8, settle_s: float = 0.5,
              status=None):
    """Drive ``session`` through a HandEyeSweep; returns (HandEyeResult, sweep). Closes nothing."""
    from core.handeye import HandEyeSweep

    s = session
    status = status or (lambda line: None)
    marker = s.tool_marker
    check = view_check(s.calibration, s.camera.base_T_camera() if s.camera.base_T_camera() is not None
                       else s.perception.base_T_camera)
    sweep = HandEyeSweep(s.profile, s.kinematics, n_poses=n_poses, hold_s=hold_s, settle_s=settle_s, seed=seed,
                         camera_view_check=check, tool_marker=marker)
    clock = s.clock
    s.bridge.connect()
    schedule = s.control_schedule()
    seq = SequenceCounter()
    goal = None
    state = s.bridge.joint_state()
    if state is not None and hasattr(s.camera, "set_arm_points"):
        s.camera.set_arm_points(s.kinematics.chain_points(state.q))
    t0 = clock.now()
    limit_s = len(sweep.points) * (sweep.move_timeout_s + settle_s + hold_s) + 5.0
    stopped = ""

    def control_step() -> None:
        nonlocal stopped
        schedule.ran(clock.now())
        if s.bridge.is_estopped or not s.controller.armed:
            stopped = "E-STOP pressed — calibration stopped; re-arm the arm and run again"
            return
        st = s.bridge.joint_state()
        cmd = s.controller.step(goal, s.controller.start_pose(st), clock.now())
        if cmd is None:
            return
        s.bridge.send(cmd)
        st = s.bridge.joint_state()
        if st is not None and hasattr(s.camera, "set_arm_points"):
            s.camera.set_arm_points(s.kinematics.chain_points(st.q))

    last_msg = ""
    while not sweep.done and not stopped and clock.now() - t0 < limit_s:
        next_frame = getattr(s.camera, "next_frame_t", None)
        due = schedule.next_due(clock.now(), next_frame)
        if next_frame is not None and due < next_frame:
            clock.wait_until(due)
            control_step()
            continue
        frame = s.camera.read()
        if frame is None:
            continue
        result = s.perception.process(frame)
        obs = result.marker(marker.marker_id)
        cam_p = obs.camera_p_centre if obs is not None and obs.found else None
        st = s.bridge.joint_state()
        step = sweep.step(frame.t, cam_p, s.controller.start_pose(st))
        if step.message != last_msg:
            last_msg = step.message
            status(f"[{step.progress:4.0%}] {step.message}")
        goal = None if step.goal_base_p is None else Goal(seq.next(), clock.now(), step.goal_base_p,
                                                          TargetMode.MANUAL, frame.t)
        schedule.goal_arrived(clock.now())
        while schedule.due(clock.now()):
            control_step()
    res = sweep.result(s.hand_eye_pair_id)
    if stopped:
        res = replace(res, ok=False, problem=stopped)
    elif not sweep.done:
        res = replace(res, ok=False, problem=f"the sweep did not finish in {limit_s:.0f} s — check that the arm "
                                             "moves (bridge connected, not e-stopped) and run again")
    return res, sweep


def run(command: str, argv: list[str]) -> int:
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exc:  # --help (0) or a bad argument (2)
        return int(exc.code or 0)
    from core.session import DeskSession, SessionOptions

    out = sys.stdout
    try:
        offset = parse_rig_offset(args.rig_offset)
        if not 1 <= args.poses <= 200:
            raise ValueError(f"--poses {args.poses} is outside 1…200 (12 is a good start)")
        if not 1.0 <= args.fps <= 240.0:
            raise ValueError(f"--fps {args.fps:g} is outside 1…240")
        from core.handeye import tool_marker_of
        from core.kinematics import load_profile

        marker = tool_marker_of(load_profile(args.robot))
        options = SessionOptions(camera=args.camera, bridge=args.bridge, robot=args.robot, fps=args.fps,
                                 simulated_clock=bool(args.fast), calibration=args.calibration, rig_offset=offset,
                                 marker_ids=tuple(dict.fromkeys((23, 50, marker.marker_id))))
        options.validate()
    except ValueError as exc:
        print(f"deskarm calibrate-hand-eye: {exc}", file=sys.stderr)
        return 2
    try:
        session = DeskSession.create(options)
    except (OSError, RuntimeError, ValueError) as exc:
        print(f"deskarm calibrate-hand-eye: {exc}", file=sys.stderr)
        return 1
    say = (lambda line: None) if args.json else (lambda line: print(line, file=out, flush=True))
    try:
        for banner in session.banners:
            say(f"deskarm: {banner}")
        try:
            result, sweep = run_sweep(session, n_poses=args.poses, seed=args.seed, status=say)
        except BridgeError as exc:
            print(f"deskarm calibrate-hand-eye: {exc}", file=sys.stderr)
            return 1
        report = report_of(result, session)
        saved = None
        if result.ok:
            from core.handeye import default_hand_eye_path, save_hand_eye

            try:
                saved = save_hand_eye(result, args.out or default_hand_eye_path())
            except OSError as exc:
                print(f"deskarm calibrate-hand-eye: {exc}", file=sys.stderr)
                return 1
        report["out"] = None if saved is None else str(saved)
    finally:
        session.close()
    if args.json:
        print(json.dumps(report), file=out, flush=True)
    else:
        print(human_summary(report), file=out, flush=True)
    return 0 if result.ok else 1


def report_of(result, session) -> dict:
    """The JSON object of a run (errors vs the true mount when the camera is simulated)."""
    def r(v, nd=3):
        return None if v is None or not math.isfinite(v) else round(float(v), nd)

    report = {
        "ok": result.ok, "problem": result.problem, "method": result.method, "poses_used": result.poses_used,
        "residual_mm_rms": r(result.rms_mm), "residual_mm_max": r(result.max_mm),
        "rejected": list(result.rejected), "warnings": list(result.warnings), "camera_pair": result.camera_pair,
        "out": None,
    }
    true_T = getattr(session.camera, "true_base_T_camera", None)
    if true_T is not None and result.poses_used >= 3:
        from core.handeye import pose_error

        t_mm, r_deg = pose_error(result.base_T_camera, true_T())
        report["translation_error_mm"] = r(t_mm)
        report["rotation_error_deg"] = r(r_deg, 4)
    return report


def human_summary(report: dict) -> str:
    lines = []
    if report["ok"]:
        lines.append(f"camera→arm calibrated from {report['poses_used']} poses: "
                     f"{report['residual_mm_rms']} mm RMS (max {report['residual_mm_max']} mm)")
        lines.append(f"saved to {report['out']}")
    else:
        lines.append(f"camera→arm NOT calibrated: {report['problem']} (nothing saved)")
    if "translation_error_mm" in report:
        lines.append(f"vs the simulated rig's true mount: {report['translation_error_mm']} mm, "
                     f"{report['rotation_error_deg']}°")
    lines += [f"warning: {w}" for w in report["warnings"]]
    return "\n".join(lines)
