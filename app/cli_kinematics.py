"""``deskarm ik`` and ``deskarm bench-ik``: the kinematics solvers from the command line.

    deskarm ik --robot NAME|urdf:PATH [--tip FRAME] --target x,y,z[,roll,pitch,yaw] [--json]
    deskarm bench-ik --robot NAME|urdf:PATH [--tip FRAME] [--mode position|pose] [--n N] [--seed S] [--json]

Targets are in robot_base: x, y, z in metres; roll, pitch, yaw in radians (``--degrees`` reads
them in degrees), R = Rz(yaw)·Ry(pitch)·Rx(roll). ``bench-ik`` solves N targets made by forward
kinematics of random in-limit configurations, cold (no warm start), and ends with one JSON
object. Errors a user can hit are one line on stderr, exit code 2. No Qt is imported.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from typing import Optional

import numpy as np

PROG = {"ik": "deskarm ik", "bench-ik": "deskarm bench-ik"}


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2 (argparse's own default)
        self.exit(2, f"{self.prog}: {message}\n")


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--robot", default="desk_rrr",
                   help="built-in profile name (desk_rrr, umi_rtx, assistive_5dof, delta), a TOML path,"
                        " or urdf:PATH for any URDF (default: desk_rrr)")
    p.add_argument("--tip", default=None, metavar="FRAME", help="URDF profiles: the tool frame (default: the profile's)")
    p.add_argument("--json", action="store_true", help="print one JSON object only")


def build_ik_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG["ik"], description="Solve the inverse kinematics of one target and print the joints.")
    _common(p)
    p.add_argument("--target", required=True, metavar="x,y,z[,roll,pitch,yaw]",
                   help="tool point in robot_base (m), optionally with an orientation (rad)")
    p.add_argument("--degrees", action="store_true", help="read roll, pitch, yaw in degrees")
    p.add_argument("--from", dest="q_from", default=None, metavar="q1,q2,...",
                   help="warm start from these joint values (rad or m); default: a cold solve")
    return p


def build_bench_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG["bench-ik"],
                description="Solve N reachable targets (FK of random in-limit joints) cold and report"
                            " success rate and time per solve.")
    _common(p)
    p.add_argument("--mode", choices=("position", "pose"), default=None,
                   help="position only, or full pose (default: pose for arms with ≥ 6 joints)")
    p.add_argument("--n", type=int, default=1000, help="number of targets (default: 1000)")
    p.add_argument("--seed", type=int, default=1, help="random seed of the targets (default: 1)")
    return p


def _numbers(text: str, what: str) -> list[float]:
    try:
        values = [float(v) for v in text.replace(" ", "").split(",") if v != ""]
    except ValueError:
        raise ValueError(f"{what} {text!r} must be comma-separated numbers") from None
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"{what} {text!r} must be finite numbers")
    return values


def _load(robot: str, tip: Optional[str]):
    from core.kinematics import build_kinematics, load_profile

    profile = load_profile(robot, tip=tip)
    return profile, build_kinematics(profile)


def _joints_out(profile, q) -> list[dict]:
    return [
        {"name": j.name, "value": float(v), "unit": j.unit, "display": round(j.to_display(float(v)), 4),
         "display_unit": j.display_unit}
        for j, v in zip(profile.joints, q)
    ]


def run_ik(argv: list[str], out=None, err=None) -> int:
    out, err = out or sys.stdout, err or sys.stderr
    args = build_ik_parser().parse_args(argv)
    from core.kinematics.base import pose_matrix, rpy_to_matrix

    try:
        target = _numbers(args.target, "--target")
        if len(target) not in (3, 6):
            raise ValueError(f"--target {args.target!r} needs 3 values (x,y,z in m) or 6 (x,y,z,roll,pitch,yaw)")
        profile, kin = _load(args.robot, args.tip)
        q_from = None
        if args.q_from is not None:
            q_from = _numbers(args.q_from, "--from")
            if len(q_from) != profile.n_joints:
                raise ValueError(f"--from has {len(q_from)} values; {profile.name!r} has {profile.n_joints} joints"
                                 f" ({', '.join(profile.joint_names)})")
        if len(target) == 6 and not hasattr(kin, "ik_pose"):
            raise ValueError(f"{profile.name!r} ({profile.n_joints} joints, kind {profile.kind!r}) solves"
                             " position only: give --target x,y,z")
    except (ValueError, OSError) as exc:  # ProfileError is a ValueError
        print(f"{PROG['ik']}: {exc}", file=err)
        return 2
    t0 = time.perf_counter()
    if len(target) == 6:
        angles = target[3:]
        if args.degrees:
            angles = [math.radians(a) for a in angles]
        res = kin.ik_pose(pose_matrix(target[:3], rpy_to_matrix(*angles)), q_from)
    else:
        res = kin.ik(tuple(target), q_from)
    ms = (time.perf_counter() - t0) * 1e3
    summary = {
        "robot": args.robot, "profile": profile.name, "target": target,
        "mode": "pose" if len(target) == 6 else "position",
        "success": bool(res.success), "q": [float(v) for v in res.q],
        "joints": _joints_out(profile, res.q),
        "residual": float(getattr(res, "residual", res.error_m)),
        "error_m": float(res.error_m), "error_rad": float(getattr(res, "error_rad", 0.0)),
        "iterations": int(getattr(res, "iterations", 0)), "restarts": int(getattr(res, "restarts", 0)),
        "base_p_reached": [float(v) for v in res.base_p_reached], "message": res.message, "time_ms": round(ms, 4),
    }
    if args.json:
        print(json.dumps(summary), file=out)
    else:
        print(f"{profile.name}: {'solved' if res.success else 'NOT solved'} in {ms:.3f} ms"
              f" ({summary['iterations']} iterations)", file=out)
        for j in summary["joints"]:
            print(f"  {j['name']:>16s} = {j['value']:+.6f} {j['unit']:<3s} ({j['display']:+.2f} {j['display_unit']})", file=out)
        print(f"  success = {str(res.success).lower()}, residual = {summary['residual']:.3g},"
              f" position error = {res.error_m:.3g} m", file=out)
        if res.message:
            print(f"  {res.message}", file=out)
    return 0 if res.success else 1


def bench(profile, kin, mode: str, n: int, seed: int) -> dict:
    """Solve ``n`` FK-generated targets cold; the summary dict ``bench-ik`` prints."""
    rng = np.random.default_rng(seed)
    lo, hi = np.array(profile.q_min), np.array(profile.q_max)
    qs = rng.uniform(lo, hi, (n, len(lo)))
    if mode == "pose":
        targets = [kin.fk_pose(q) for q in qs]
    else:
        targets = [tuple(kin.fk(q)) for q in qs]
    if mode == "pose":
        kin.ik_pose(targets[0], None)  # builds the seed bank: not part of a solve's time
    else:
        kin.ik(targets[0], None)
    times, iters, residuals = [], [], []
    ok = violations = 0
    tol = 1e-9
    for target in targets:
        t0 = time.perf_counter()
        res = kin.ik_pose(target, None) if mode == "pose" else kin.ik(target, None)
        times.append((time.perf_counter() - t0) * 1e3)
        iters.append(int(getattr(res, "iterations", 0)))
        q = np.asarray(res.q, dtype=float)
        if not (np.all(np.isfinite(q)) and np.all(q >= lo - tol) and np.all(q <= hi + tol)):
            violations += 1
        if res.success:
            ok += 1
            residuals.append(float(res.error_m))
    t = np.asarray(times)
    return {
        "robot": profile.name, "mode": mode, "n": int(n), "success_rate": round(ok / n, 6) if n else 0.0,
        "p50_ms": round(float(np.percentile(t, 50)), 4) if n else None,
        "p95_ms": round(float(np.percentile(t, 95)), 4) if n else None,
        "p99_ms": round(float(np.percentile(t, 99)), 4) if n else None,
        "iterations_p50": float(np.percentile(iters, 50)) if n else None,
        "limit_violations": violations,
        "max_residual_m": float(max(residuals)) if residuals else None,
    }


def run_bench(argv: list[str], out=None, err=None) -> int:
    out, err = out or sys.stdout, err or sys.stderr
    args = build_bench_parser().parse_args(argv)
    try:
        if not 1 <= args.n <= 10_000_000:
            raise ValueError(f"--n {args.n} is outside 1…10000000")
        profile, kin = _load(args.robot, args.tip)
        mode = args.mode or ("pose" if hasattr(kin, "ik_pose") and profile.n_joints >= 6 else "position")
        if mode == "pose" and not hasattr(kin, "ik_pose"):
            raise ValueError(f"{profile.name!r} (kind {profile.kind!r}) solves position only: use --mode position")
    except (ValueError, OSError) as exc:
        print(f"{PROG['bench-ik']}: {exc}", file=err)
        return 2
    summary = bench(profile, kin, mode, args.n, args.seed)
    summary["robot"] = args.robot
    if not args.json:
        print(f"{profile.name} ({mode}, cold, n={args.n}): success {summary['success_rate'] * 100:.2f} %,"
              f" p50 {summary['p50_ms']:.3f} ms, p95 {summary['p95_ms']:.3f} ms, p99 {summary['p99_ms']:.3f} ms,"
              f" {summary['limit_violations']} limit violations", file=out)
    print(json.dumps(summary), file=out)
    return 0


def run(command: str, argv: list[str]) -> int:
    """Entry point for ``deskarm ik`` and ``deskarm bench-ik`` (see app.cli.SUBCOMMANDS)."""
    if command == "ik":
        return run_ik(argv)
    if command == "bench-ik":
        return run_bench(argv)
    print(f"deskarm: unknown kinematics command {command!r}; expected ik or bench-ik", file=sys.stderr)
    return 2
