"""Benchmark: IK of every arm kind, beside ikpy on the same targets in the same run.

- desk_rrr (analytic, position): FK baseline, warm and cold solves, unreachable targets;
- umi_rtx (CLIK, full pose), assistive_5dof (CLIK, position): cold (no warm start) and warm
  (from the target's joints plus 0.05 rad noise) solves;
- the UR5-like and Panda-like URDFs of tests/data (CLIK, full pose, cold);
- umi_rtx and assistive_5dof tracking a moving target at 50 Hz, each solve warm-started from the
  previous tick's answer — what the control worker does (the targets come from smooth joint
  paths at up to 60 % of each joint's velocity limit);

each with its success rate, and ikpy (``pip install -e '.[bench]'``) solving the first targets
of the same set from the middle of the joint ranges (cold) or the same warm start. ikpy counts
as successful within 0.1 mm / 0.001 rad (its own tolerance is looser than CLIK's 1 µm / 1e-5 rad).

Run: ``.venv/bin/python -m bench.bench_ik`` (prints the figures; never a pass/fail assert).
``rows(n)`` feeds `make bench`'s table; ``bench_analytic_ik(n)`` returns the summary dict.
"""
from __future__ import annotations

import random
import time
from pathlib import Path

import numpy as np

from core.kinematics import build_kinematics, load_profile

FK_NAME = "FK desk_rrr"
IK_NAME = "analytic IK desk_rrr"
IK_FAR_NAME = "analytic IK desk_rrr, unreachable target"


def _cases(kin, n: int, seed: int = 1):
    """n random in-limit joint vectors, their FK targets (reachable) and warm-start joints."""
    rng = random.Random(seed)
    q = [tuple(rng.uniform(lo, hi) for lo, hi in zip(kin.q_min, kin.q_max)) for _ in range(n)]
    targets = [kin.fk_tuple(v) for v in q]
    # warm start: the previous tick's joints, a little away from the answer
    current = [tuple(min(max(v + rng.gauss(0.0, 0.05), lo), hi)
                     for v, lo, hi in zip(qq, kin.q_min, kin.q_max)) for qq in q]
    return q, targets, current


def _time_us(fn, args_list) -> list[float]:
    clock = time.perf_counter_ns
    out = []
    for args in args_list:
        t0 = clock()
        fn(*args)
        out.append((clock() - t0) * 1e-3)
    return out


def _samples(n: int):
    kin = build_kinematics(load_profile("desk_rrr"))
    q, targets, current = _cases(kin, n)
    rng = random.Random(2)
    far = [(rng.uniform(-0.5, 0.5), rng.uniform(0.3, 0.5), rng.uniform(-0.3, 0.5)) for _ in range(n)]
    for i in range(min(n, 500)):  # warm up
        kin.ik(targets[i], current[i])
        kin.fk(q[i])
    fk = _time_us(kin.fk, [(v,) for v in q])
    ik = _time_us(kin.ik, list(zip(targets, current)))
    ik_far = _time_us(kin.ik, list(zip(far, current)))
    return fk, ik, ik_far


def _summary(name: str, samples_us) -> dict:
    s = np.asarray(samples_us, dtype=float)
    return {"name": name, "median_us": float(np.median(s)), "p95_us": float(np.percentile(s, 95))}


def bench_analytic_ik(n: int = 20000) -> dict:
    """Median/p95 (µs) of ``RRRKinematics.ik`` on random reachable targets, with the FK baseline.

    Returns ``{"name", "median_us", "p95_us", "n", "baseline": {"name", "median_us", "p95_us"}}``.
    """
    fk, ik, _ = _samples(n)
    result = _summary(IK_NAME, ik)
    result["n"] = n
    result["baseline"] = _summary(FK_NAME, fk)
    return result


def rows(n: int = 20000) -> list[dict]:
    """Rows for `make bench`: desk_rrr analytic IK, CLIK arms, and ikpy baselines (same targets)."""
    fk, ik, ik_far = _samples(n)
    out = [
        {"name": FK_NAME, "unit": "us", "samples": fk, "baseline": None,
         "extra": "RRRKinematics.fk: math on 3 scalars, one numpy array out"},
        {"name": IK_NAME, "unit": "us", "samples": ik, "baseline": FK_NAME,
         "extra": "random reachable targets, warm start; every in-limit branch enumerated"},
        {"name": IK_FAR_NAME, "unit": "us", "samples": ik_far, "baseline": FK_NAME,
         "extra": "nearest reachable point on the workspace's boundary arcs"},
    ]
    n_clik = max(200, n // 4)
    n_ikpy = max(20, n // 100)
    for robot, mode, with_ikpy in (("desk_rrr", "position", True), ("umi_rtx", "pose", True),
                                   ("assistive_5dof", "position", True),
                                   (f"urdf:{DATA / 'ur5_like.urdf'}", "pose", False),
                                   (f"urdf:{DATA / 'panda_like.urdf'}", "pose", False)):
        out += compare_rows(robot, mode, n_clik, n_ikpy if with_ikpy else 0)
    for robot, mode in (("umi_rtx", "pose"), ("assistive_5dof", "position")):
        out.append(tracking_row(robot, mode, n_clik))
    return out


DATA = Path(__file__).resolve().parent.parent / "tests" / "data"
IKPY_TOL_M = 1e-4  # ikpy counts as successful within this position error …
IKPY_TOL_RAD = 1e-3  # … and this orientation error (pose mode)
WARM_NOISE_RAD = 0.05  # warm starts: the target's joints plus this much Gaussian noise
TRACK_RATE_HZ = 50.0  # tracking rows: the control worker's tick rate …
TRACK_SPEED_FRACTION = 0.6  # … and the joint paths' peak speed, as a fraction of each limit


def _short(robot: str) -> str:
    return Path(robot[5:]).stem if robot.startswith("urdf:") else robot


def _rrr_urdf(profile) -> str:
    """A URDF of an RRR profile (yaw about z, shoulder and elbow about -y), for ikpy."""
    g = profile.geometry
    lo, hi = profile.q_min, profile.q_max

    def joint(name, parent, child, xyz, axis, i):
        return (f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
                f'<origin xyz="{xyz}" rpy="0 0 0"/><axis xyz="{axis}"/>'
                f'<limit lower="{lo[i]!r}" upper="{hi[i]!r}" effort="1" velocity="1"/></joint>')

    return ('<robot name="desk_rrr">' + "".join(f'<link name="{n}"/>' for n in ("base", "l1", "l2", "l3", "tool"))
            + joint("base_yaw", "base", "l1", "0 0 0", "0 0 1", 0)
            + joint("shoulder", "l1", "l2", f"0 0 {g.shoulder_height_m!r}", "0 -1 0", 1)
            + joint("elbow", "l2", "l3", f"{g.upper_arm_m!r} 0 0", "0 -1 0", 2)
            + f'<joint name="tool_joint" type="fixed"><parent link="l3"/><child link="tool"/>'
              f'<origin xyz="{g.forearm_m!r} 0 0" rpy="0 0 0"/></joint></robot>')


def _chain_only_urdf(path: str, tip_link: str) -> str:
    """The URDF reduced to the joints from its root to ``tip_link`` (ikpy follows one chain)."""
    import xml.etree.ElementTree as ET

    root = ET.parse(path).getroot()
    by_child = {j.find("child").get("link"): j for j in root.findall("joint")}
    keep, link = [], tip_link
    while link in by_child:
        j = by_child[link]
        keep.append(j)
        link = j.find("parent").get("link")
    for j in root.findall("joint"):
        if j not in keep:
            root.remove(j)
    return ET.tostring(root, encoding="unicode"), link


def _ikpy_chain(profile):
    """(ikpy Chain, indices of our joints in its link vector), or None without ikpy."""
    try:
        import warnings

        from ikpy.chain import Chain
    except ImportError:
        return None
    import tempfile

    if profile.kind == "rrr":
        text, root = _rrr_urdf(profile), "base"
    else:
        text, root = _chain_only_urdf(profile.geometry.urdf_path, profile.geometry.tip_frame)
    with tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False) as f:
        f.write(text)
        tmp = f.name
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            chain = Chain.from_urdf_file(tmp, base_elements=[root])
            names = [link.name for link in chain.links]
            mask = [nm in profile.joint_names for nm in names]
            chain = Chain.from_urdf_file(tmp, base_elements=[root], active_links_mask=mask)
    finally:
        Path(tmp).unlink(missing_ok=True)
    idx = [names.index(nm) for nm in profile.joint_names]
    return chain, idx


def _time_ikpy(chain, idx, targets, starts, mode, n_links):
    import warnings

    times, ok = [], 0
    for T, q0 in zip(targets, starts):
        init = np.zeros(n_links)
        init[idx] = q0
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if mode == "pose":
                sol = chain.inverse_kinematics(T[:3, 3], T[:3, :3], orientation_mode="all", initial_position=init)
            else:
                sol = chain.inverse_kinematics(T[:3, 3], initial_position=init)
        times.append((time.perf_counter() - t0) * 1e6)
        F = chain.forward_kinematics(sol)
        good = np.linalg.norm(F[:3, 3] - T[:3, 3]) <= IKPY_TOL_M
        if mode == "pose":
            c = (np.trace(F[:3, :3] @ T[:3, :3].T) - 1.0) / 2.0
            good = good and np.arccos(np.clip(c, -1.0, 1.0)) <= IKPY_TOL_RAD
        ok += bool(good)
    return times, ok


def compare_rows(robot: str, mode: str, n: int, n_ikpy: int, seed: int = 3) -> list[dict]:
    """Cold and warm rows for ``robot`` (CLIK or analytic) and, when n_ikpy > 0, ikpy on the
    first ``n_ikpy`` of the same targets and starts."""
    profile = load_profile(robot)
    kin = build_kinematics(profile)
    rng = np.random.default_rng(seed)
    lo, hi = np.array(profile.q_min), np.array(profile.q_max)
    qs = rng.uniform(lo, hi, (n, len(lo)))
    warm = np.clip(qs + rng.normal(0.0, WARM_NOISE_RAD, qs.shape), lo, hi)
    if mode == "pose":
        targets = [kin.fk_pose(q) for q in qs]
        solve = kin.ik_pose
    else:
        targets = [np.vstack([np.column_stack([np.eye(3), kin.fk(q)]), [0, 0, 0, 1]]) for q in qs]
        solve = kin.ik
    args = [(T if mode == "pose" else tuple(T[:3, 3]),) for T in targets]
    solve(*args[0], None)  # builds a CLIK solver's seed bank outside the timing
    name = _short(robot)
    kind = "analytic IK" if profile.kind in ("rrr", "delta3") else "CLIK"
    out = []
    for start in ("cold", "warm"):
        times, ok, viol, its = [], 0, 0, []
        for a, q0 in zip(args, warm):
            t0 = time.perf_counter()
            res = solve(*a, None if start == "cold" else tuple(q0))
            times.append((time.perf_counter() - t0) * 1e6)
            q = np.asarray(res.q)
            viol += int(not (np.all(q >= lo - 1e-12) and np.all(q <= hi + 1e-12)))
            ok += bool(res.success)
            its.append(getattr(res, "iterations", 0))
        row = f"{kind} {name} {mode}, {start}"
        base = f"ikpy {name} {mode}, {start}"
        t = np.asarray(times)
        extra = (f"success {ok / n * 100:.2f} % of {n}, p99 {np.percentile(t, 99) / 1000:.2f} ms,"
                 f" iterations p50 {np.median(its):.0f}, limit violations {viol}")
        ikpy_row = None
        if n_ikpy > 0:
            chain = _ikpy_chain(profile)
            if chain is None:
                extra += "; ikpy not installed (pip install -e '.[bench]')"
            else:
                m = min(n_ikpy, n)
                starts = [0.5 * (lo + hi)] * m if start == "cold" else list(warm[:m])
                itimes, iok = _time_ikpy(chain[0], chain[1], targets[:m], starts, mode, len(chain[0].links))
                ours_m = float(np.median(t[:m]))
                extra += (f"; ikpy on the first {m} targets: success {iok / m * 100:.1f} %"
                          f" (within {IKPY_TOL_M * 1000:g} mm), ours there {ours_m:.0f} us median")
                ikpy_row = {"name": base, "unit": "us", "samples": itimes, "baseline": None,
                            "extra": f"ikpy {getattr(__import__('ikpy'), '__version__', '')} from "
                                     + ("mid-range joints" if start == "cold" else "the same warm start")}
        out.append({"name": row, "unit": "us", "samples": times,
                    "baseline": base if ikpy_row is not None else None, "extra": extra})
        if ikpy_row is not None:
            out.append(ikpy_row)
    return out


def tracking_row(robot: str, mode: str, n: int, seed: int = 4) -> dict:
    """Warm solves along a moving target sampled at 50 Hz, each started from the previous answer.

    The targets are FK of smooth joint paths q_j(t) = mid_j + a_j·sin(2π f_j t + φ_j), with
    a_j up to 40 % of the joint's range and 2π f_j a_j ≤ TRACK_SPEED_FRACTION · its velocity
    limit, so every target is reachable and moves as fast as the arm may. A branch change is a
    solve the previous answer's branch could not reach (after a singularity — a straight elbow —
    the solver may follow the mirror branch until it meets a joint limit the path avoids).
    """
    profile = load_profile(robot)
    kin = build_kinematics(profile)
    rng = np.random.default_rng(seed)
    lo, hi = np.array(profile.q_min), np.array(profile.q_max)
    vmax = np.array(profile.velocity_limits)
    amp = rng.uniform(0.2, 0.4, lo.shape) * (hi - lo)
    omega = TRACK_SPEED_FRACTION * vmax / amp
    phase = rng.uniform(0.0, 2.0 * np.pi, lo.shape)
    t = np.arange(n + 1) / TRACK_RATE_HZ
    qs = 0.5 * (lo + hi) + amp * np.sin(np.outer(t, omega) + phase)
    if mode == "pose":
        targets, solve = [kin.fk_pose(q) for q in qs], kin.ik_pose
    else:
        targets, solve = [tuple(kin.fk(q)) for q in qs], kin.ik
    q_prev = tuple(qs[0])
    times, ok, viol, its, changes = [], 0, 0, [], 0
    for target in targets[1:]:
        t0 = time.perf_counter()
        res = solve(target, q_prev)
        times.append((time.perf_counter() - t0) * 1e6)
        q = np.asarray(res.q)
        viol += int(not (np.all(q >= lo - 1e-12) and np.all(q <= hi + 1e-12)))
        ok += bool(res.success)
        its.append(res.iterations)
        changes += int(res.restarts > 0)
        q_prev = res.q
    return {"name": f"CLIK {_short(robot)} {mode}, tracking 50 Hz", "unit": "us", "samples": times,
            "baseline": None,
            "extra": (f"warm from the previous tick; success {ok / n * 100:.2f} % of {n},"
                      f" iterations p50 {np.median(its):.0f}, branch changes {changes},"
                      f" limit violations {viol}")}


if __name__ == "__main__":
    import sys

    quick = "--quick" in sys.argv
    from bench.__main__ import format_table

    print(format_table(rows(2000 if quick else 20000)))
