"""The perception thread's CPU per frame, as the window's PerceptionWorker spends it (issue 28).

Frames: the simulated desk run by the headless runner on its simulated clock (``--camera sim
--scenario objects|wander``, the arm moving as the loop drives it), every stereo pair the loop
reads kept and saved once under ``--frames-dir`` (an .npz per scenario, with its calibration and
ground truth beside it; an existing file is reused, so two checkouts are timed on the very same
pixels). Timing: fresh perception objects built as the session builds
them (``StereoMarkerPerception``, and ``StereoObjectPerception`` with the registry's detector and
``object_perception_options``), fed every saved frame in order, as ``PerceptionWorker.loop_once``
does (markers, objects, calibration health). Per frame: the process's CPU time (this thread and
OpenCV's pool: nothing else runs) and the wall time; medians (and the CPU's mean: the frames with
a full-frame marker search are the tail) over the frames after a warm-up.

Run: ``python -m bench.bench_perception_loop [--cases hsv,desk,markers] [--frames-dir /tmp]
[--repeat 3]``; ``--root DIR`` times another checkout (e.g. ``git archive HEAD | tar -x -C DIR``)
with the same frames, in a child process whose ``PYTHONPATH`` is DIR; ``--dump PREFIX`` writes
each frame's markers and objects (PREFIX.CASE.json) to compare two checkouts' results.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

CASES = {  # name: (scenario, detectors)
    "hsv": ("objects", ("hsv",)),
    "desk": ("objects", ("desk",)),
    "markers": ("wander", ()),
}
WARMUP = 10  # frames not counted (first allocations, ONNX session warm-up)


def capture(scenario: str, seconds: float, path: Path) -> None:
    """Run the headless loop on the simulated clock and save every stereo pair perception read."""
    from app.headless import HeadlessRunner
    from core.session import DeskSession, SessionOptions

    session = DeskSession.create(SessionOptions(camera="sim", scenario=scenario, simulated_clock=True,
                                                detectors=("hsv",) if scenario == "objects" else ()))
    frames = []
    read = session.camera.read

    def keep():
        frame = read()
        if frame is not None and not frame.repeated:
            frames.append(frame)
        return frame

    session.camera.read = keep
    calib, base_T_camera = session.calibration, session.perception.base_T_camera
    HeadlessRunner(session, seconds).run()
    from core.vision.calibration import save_calibration

    calib_path = path.with_suffix(".yaml")
    save_calibration(calib_path, calib)
    import pickle

    path.with_suffix(".truth.pkl").write_bytes(pickle.dumps([f.truth for f in frames]))
    np.savez(path, left=np.stack([f.left for f in frames]), right=np.stack([f.right for f in frames]),
             t=np.array([f.t for f in frames]), skew=np.array([f.skew_s for f in frames]),
             base_T_camera=base_T_camera, marker_ids=np.array(session.perception.marker_ids))


def load(path: Path):
    from core.messages import StereoFrame
    from core.vision.calibration import load_calibration

    data = dict(np.load(path))  # each item read once (an NpzFile reads an array at every access)
    frames = [StereoFrame(seq=k + 1, t=float(t), left=data["left"][k], right=data["right"][k], skew_s=float(s))
              for k, (t, s) in enumerate(zip(data["t"], data["skew"]))]
    return frames, load_calibration(path.with_suffix(".yaml")), data["base_T_camera"], tuple(int(i) for i in data["marker_ids"])


def time_case(case: str, path: Path, dump=None) -> dict:
    """Median CPU and wall ms per frame of the worker's perception on the saved frames."""
    from core.detect.registry import make_detector
    from core.detect.stereo import StereoObjectPerception
    from core.session import SessionOptions, object_perception_options
    from core.vision.calibration_health import CalibrationHealth
    from core.vision.perception import StereoMarkerPerception

    frames, calib, base_T_camera, ids = load(path)
    _, detectors = CASES[case]
    markers = StereoMarkerPerception(calib, base_T_camera, marker_ids=ids)
    objects = None
    if detectors:
        objects = StereoObjectPerception(calib, base_T_camera, [make_detector(d) for d in detectors],
                                         **object_perception_options(SessionOptions(detectors=detectors)))
    health = CalibrationHealth()
    cpu, wall, split = [], [], []
    n_obj = 0
    outputs = []
    for k, frame in enumerate(frames):
        c0, w0 = time.process_time(), time.perf_counter()
        result = markers.process(frame)
        c1 = time.process_time()
        found = objects.process(frame) if objects is not None else []
        n_obj += len(found)
        health.feed(result)
        c2, w2 = time.process_time(), time.perf_counter()
        if k >= WARMUP:
            cpu.append((c2 - c0) * 1e3)
            wall.append((w2 - w0) * 1e3)
            split.append(((c1 - c0) * 1e3, (c2 - c1) * 1e3))
        if dump:
            outputs.append({"markers": {m.marker_id: m.base_p_centre for m in result.markers if m.found},
                            "objects": [(o.object_id, o.label, o.base_p, o.left.box if o.left else None,
                                         o.right.box if o.right else None) for o in found]})
    if dump:
        Path(dump).write_text(json.dumps(outputs))
    return {"case": case, "frames": len(cpu), "cpu_ms": statistics.median(cpu), "cpu_mean_ms": statistics.fmean(cpu),
            "wall_ms": statistics.median(wall), "markers_cpu_ms": statistics.median(s[0] for s in split),
            "objects_cpu_ms": statistics.median(s[1] for s in split), "objects_per_frame": n_obj / len(frames)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="hsv,desk,markers")
    ap.add_argument("--frames-dir", default="/tmp")
    ap.add_argument("--seconds", type=float, default=8.0, help="simulated seconds of frames to capture (30 fps)")
    ap.add_argument("--root", default=None, help="time this checkout instead (child process)")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--cv-threads", type=int, default=None, help="cv2.setNumThreads(N) before timing (default: OpenCV's)")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--dump", default=None, help="write each frame's markers and objects (JSON) to DUMP.CASE.json")
    args = ap.parse_args(argv)
    cases = [c.strip() for c in args.cases.split(",") if c.strip()]
    if args.cv_threads is not None:
        import cv2

        cv2.setNumThreads(args.cv_threads)
    rows = []
    for _ in range(args.repeat):
        for case in cases:
            scenario, _ = CASES[case]
            path = Path(args.frames_dir) / f"perception_loop_{scenario}.npz"
            if not path.exists():
                capture(scenario, args.seconds, path)
            if args.root:
                env = dict(os.environ, PYTHONPATH=args.root)
                out = subprocess.run([sys.executable, "-m", "bench.bench_perception_loop", "--cases", case,
                                      "--frames-dir", args.frames_dir, "--json"]
                                     + ([] if args.cv_threads is None else ["--cv-threads", str(args.cv_threads)])
                                     + (["--dump", args.dump] if args.dump else []), cwd=args.root, env=env,
                                     check=True, capture_output=True, text=True).stdout
                rows.append(json.loads(out.strip().splitlines()[-1]))
            else:
                rows.append(time_case(case, path, f"{args.dump}.{case}.json" if args.dump else None))
            if args.json:
                print(json.dumps(rows[-1]))
            else:
                r = rows[-1]
                print(f"{r['case']:8s} {r['frames']} frames  CPU {r['cpu_ms']:.2f} ms/frame (mean {r['cpu_mean_ms']:.2f}; markers "
                      f"{r['markers_cpu_ms']:.2f}, objects {r['objects_cpu_ms']:.2f})  wall {r['wall_ms']:.2f} ms  "
                      f"objects/frame {r['objects_per_frame']:.2f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
