"""``deskarm`` command line: the window, the headless runner and the screenshot renderer.

Qt is imported late (only when a window is needed) so ``deskarm --help`` and the headless
runner start fast; the session, the detectors and the cameras are imported when a run needs them
(the assistive view needs none of them), all while Python's cyclic garbage collector is paused
(``start_up``): start-up allocates a lot and frees little. Errors a user can hit are printed as
one clear line, exit code 2.
"""
from __future__ import annotations

import argparse
import gc
import os
import sys
from contextlib import contextmanager


# help texts that name a list from a module the run may not need: filled in only when the help is shown
_LISTED = {"{CAMERA_CHOICES}": ("core.vision.cameras", "CAMERA_CHOICES"),
           "{BRIDGE_CHOICES}": ("core.devices.bridge", "BRIDGE_CHOICES"),
           "{SCENARIOS}": ("core.session", "SCENARIOS")}


def _listed(token: str) -> str:
    import importlib

    module, name = _LISTED[token]
    value = getattr(importlib.import_module(module), name)
    return value if isinstance(value, str) else ", ".join(value)


class _HelpFormatter(argparse.HelpFormatter):
    """argparse's, without breaking words at hyphens (``calibrate-hand-eye`` stays whole), and
    with the lists of ``_LISTED`` filled in (their modules are imported only for ``--help``)."""

    def _get_help_string(self, action):
        text = super()._get_help_string(action) or ""
        for token in _LISTED:
            if token in text:
                text = text.replace(token, _listed(token))
        return text

    def _fill_text(self, text, width, indent):
        import textwrap

        text = self._whitespace_matcher.sub(" ", text).strip()
        return textwrap.fill(text, width, initial_indent=indent, subsequent_indent=indent, break_on_hyphens=False)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="deskarm",
        formatter_class=_HelpFormatter,
        description="See objects on the desk in 3D with two webcams and have a servo arm reach them. "
        "With nothing plugged in it runs on a simulated desk.",
        epilog=tools_epilog(),
    )
    p.add_argument("--camera", default="auto", help="camera source: {CAMERA_CHOICES} (default: auto)")
    p.add_argument("--bridge", default="sim://", help="motor bridge: {BRIDGE_CHOICES} (default: sim://)")
    p.add_argument("--robot", default="desk_rrr", help="robot profile name or TOML path (default: desk_rrr)")
    p.add_argument("--scenario", default="static", help="simulated desk scenario: {SCENARIOS}")
    p.add_argument("--calibration", default=None, help="stereo calibration YAML (default: the last saved one)")
    p.add_argument("--fps", type=float, default=30.0, help="camera frame rate (default: 30)")
    p.add_argument("--markers", default=None, metavar="FILE",
                   help="markers file: dictionary, ids, names, what each does (see resources/markers.example.toml; "
                        "default: markers.toml in the config folder)")
    p.add_argument("--hand-eye", default=None, metavar="FILE",
                   help="camera→arm calibration TOML (default: the saved one, when it is for these cameras)")
    p.add_argument("--rig-offset", default=None, metavar="DX,DY,DZ,ROLL,PITCH,YAW",
                   help="simulated desk: the rig is mounted this far off its nominal pose (m, degrees)")
    p.add_argument("--sim-skew-ms", type=float, default=0.0, metavar="N",
                   help="simulated desk: the right camera's frame is captured N ms after the left one "
                        "(unsynchronised webcams)")
    p.add_argument("--sim-realism", nargs="?", const="webcam", default=None, metavar="PRESET",
                   help="simulated desk: images as a cheap webcam delivers them (blur, rolling shutter, flicker, "
                        "noise, vignetting, distortion, JPEG); PRESET: webcam (default) or off")
    p.add_argument("--remote", default=None, metavar="ENDPOINT",
                   help="open the window (or headless run) on a desk served by `deskarm serve` on another "
                        "machine, e.g. tcp/192.168.1.20:7447")
    p.add_argument("--credentials", default=None, metavar="FILE",
                   help="with --remote: the credential `deskarm serve --pair` made on the serving machine "
                        "(controller.toml drives, viewer.toml watches and may STOP); default: the config "
                        "folder's remote/client.toml")
    p.add_argument("--detector", default=None, metavar="NAME[,NAME…]",
                   help="also locate marker-less objects in 3D with these detectors (e.g. hsv, circles, "
                        "onnx:PATH; the headless JSON then scores them against the simulated desk's truth); "
                        "with --assist: the hand camera's button detector, circles (default) or desk")
    p.add_argument("--follow-object", default=None, metavar="LABEL",
                   help="headless: the arm follows a marker-less object, e.g. \"green ball\", \"red\" or "
                        "\"ball\" (needs --detector): it aims where a moving object will be and approaches a "
                        "stopped one on a cubic move")
    p.add_argument("--no-intercept", action="store_true",
                   help="with --follow-object: aim where the object is, not where it will be (to compare)")
    p.add_argument("--object-roi", action="store_true",
                   help="with --detector: detect only around the tracked objects between full-frame searches")
    p.add_argument("--object-tracker", default=None, choices=("kcf", "csrt", "mil", "mosse"),
                   help="with --detector: a tracker per object and view, re-seeded by the detector")
    p.add_argument("--object-detect-every", type=int, default=1, metavar="N",
                   help="with --object-tracker: run the detectors every N frames, the trackers in between")
    p.add_argument("--no-skew-compensation", action="store_true",
                   help="with --detector: triangulate objects as seen, without bringing the right view to the "
                        "left view's instant (to measure what unsynchronised webcams cost)")
    p.add_argument("--teleop", default=None, metavar="SOURCE",
                   help="drive the arm by hand: marker:ID (a wristband marker), hsv:COLOUR (a glove, with "
                        "--detector hsv) or pose:PATH.onnx (a body pose model); calibrate by holding still 1 s "
                        "at two opposite corners (default with --scenario teleop: marker:<first marker id>)")
    p.add_argument("--assist", action="store_true",
                   help="open the assistive view (choose a button by touch, two switches or one switch; the "
                        "eye-in-hand arm presses it) instead of the main window; implies --robot assistive_5dof "
                        "and a still lift panel on the simulated desk (--scenario panel: a hand also reaches in "
                        "now and then; default size 800x480)")
    p.add_argument("--hand-camera", default=None, metavar="SPEC",
                   help="with --assist: the hand camera — webcam:N (e.g. webcam:2) or a /dev/v4l/by-id/… path as "
                        "webcam:PATH; default: the simulated desk")
    p.add_argument("--switch", action="append", default=[], metavar="NAME=ROLE",
                   help="with --assist, repeatable: a switch and its role (next, confirm, single), added to the "
                        "saved settings — gamepad:BTN_SOUTH=confirm (needs evdev), gpio:17=single (a Raspberry Pi "
                        "pin, needs gpiozero), key:F1=next")
    p.add_argument("--estop-switch", action="append", default=[], metavar="NAME",
                   help="repeatable: a physical STOP for the window — gpio:17 (a Raspberry Pi pin to ground, needs "
                        "gpiozero), gamepad:BTN_SOUTH (a gamepad or USB foot switch button, needs evdev) or key:F12; "
                        "each press stops, and while it is held down the arm cannot be re-armed")
    p.add_argument("--rearm-switch", action="append", default=[], metavar="NAME",
                   help="repeatable: a physical RE-ARM (same forms, never a STOP switch): press it after the stop "
                        "and hold it 1 s without a break; a switch held since before the stop never re-arms")
    p.add_argument("--headless", action="store_true", help="run the pipeline without a window")
    p.add_argument("--duration", type=float, default=10.0, help="headless: seconds to run (default: 10)")
    p.add_argument("--fast", action="store_true", help="headless: run as fast as possible on a simulated clock")
    p.add_argument("--json", action="store_true", help="headless: end with one JSON object of metrics")
    p.add_argument("--record", nargs="?", const="", default=None, metavar="PATH",
                   help="headless: record the run as a rosbag2 folder (MCAP) at PATH "
                        "(default: a new deskarm-YYYYmmdd-HHMMSS folder in the recordings folder)")
    p.add_argument("--tick-driven", action="store_true",
                   help="run the control step only on its 50 Hz tick (a new goal waits for it); "
                        "default: at once on each new goal — kept to compare latencies")
    p.add_argument("--screenshot", metavar="PATH", help="render the window offscreen and save a PNG")
    p.add_argument("--after", type=float, default=2.0, help="screenshot: seconds of the scenario first (default: 2)")
    p.add_argument("--size", default="1280x800", help="window size WxH (default: 1280x800)")
    return p


def tools_epilog() -> str:
    """The help's list of tools, from ``SUBCOMMANDS`` (what ``main`` dispatches on), so it cannot drift."""
    return "tools (deskarm TOOL --help for each): " + " | ".join(SUBCOMMANDS)


def parse_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise ValueError(f"--size {text!r} is not WIDTHxHEIGHT, e.g. 800x480") from None
    if not (320 <= w <= 7680 and 240 <= h <= 4320):
        raise ValueError(f"--size {text!r} is outside 320x240…7680x4320")
    return w, h


def object_option_problem(args) -> str:
    """"" when the object-following options fit together, else what is wrong and the fix."""
    if args.follow_object is None and args.no_intercept:
        return "--no-intercept only changes --follow-object: add --follow-object LABEL"
    if (args.object_roi or args.object_tracker) and not args.detector:
        return "--object-roi and --object-tracker change the objects of --detector: add --detector hsv"
    if args.object_detect_every != 1 and not args.object_tracker:
        return "--object-detect-every needs a tracker between detector runs: add --object-tracker kcf"
    if args.no_skew_compensation and not args.detector:
        return "--no-skew-compensation only changes the objects of --detector: add --detector hsv"
    return ""


def estop_switch_problem(args) -> str:
    """"" when --estop-switch / --rearm-switch fit the run (their names are then made canonical in
    ``args``), else what is wrong and the fix."""
    if not (args.estop_switch or args.rearm_switch):
        return ""
    if args.assist:
        return ("--estop-switch and --rearm-switch are the main window's: in the assistive view a switch held "
                "1.5 s stops (--switch NAME=ROLE), and Esc is STOP")
    if args.headless:
        return ("--estop-switch and --rearm-switch act through the window: leave out --headless (a headless run "
                "has no physical STOP)")
    from app.estop_switches import check_estop_switch_names  # Qt: only when a switch is given

    try:
        args.estop_switch, args.rearm_switch = check_estop_switch_names(args.estop_switch, args.rearm_switch)
    except ValueError as exc:
        return str(exc)
    return ""


# `deskarm NAME ...` runs a tool: NAME -> module with `run(command: str, argv: list[str]) -> int`
SUBCOMMANDS = {
    "calibrate": "app.cli_calibrate",
    "ik": "app.cli_kinematics",
    "bench-ik": "app.cli_kinematics",
    "calibrate-hand-eye": "app.cli_handeye",
    "serve": "app.cli_serve",
    "detect": "app.cli_detect",
    "train-detector": "app.cli_train",
    "eval-detector": "app.cli_train",
    "assist-trials": "app.cli_assist",
    "rtx-init": "app.rtx_init",
    "teach": "app.cli_teach",
}


def run_assist(args) -> int:
    """``deskarm --assist``: the assistive view (assistive_5dof): on the simulated panel, or with
    ``--hand-camera webcam:N`` on a real one; the arm is ``--bridge`` (default: the simulated servo arm)."""
    if args.robot not in ("desk_rrr", "assistive_5dof") or args.scenario not in ("static", "panel"):
        print("deskarm: --assist runs the assistive_5dof arm on the simulated panel: leave out --robot and "
              "--scenario (or give --robot assistive_5dof --scenario panel)", file=sys.stderr)
        return 2
    try:
        size = parse_size("800x480" if args.size == "1280x800" else args.size)
    except ValueError as exc:
        print(f"deskarm: {exc}", file=sys.stderr)
        return 2
    from core.devices.bridge import parse_bridge_url
    from core.devices.hand_camera import parse_hand_camera_spec
    from core.devices.switches import parse_switch_spec

    try:
        hand_camera = None if args.hand_camera is None else parse_hand_camera_spec(args.hand_camera)
        switches = [parse_switch_spec(spec) for spec in args.switch]
        real_arm = parse_bridge_url(args.bridge) != "sim"
    except ValueError as exc:
        print(f"deskarm: {exc}", file=sys.stderr)
        return 2
    from app.cli_assist import ASSIST_DETECTORS

    detector = args.detector or "circles"
    if detector not in ASSIST_DETECTORS:
        print(f"deskarm: --detector {detector} with --assist: the hand camera's button detector is one of "
              f"{', '.join(ASSIST_DETECTORS)}", file=sys.stderr)
        return 2
    refusal = assist_real_arm_refusal(args.bridge, real_arm, args.hand_camera)
    if refusal:
        print(f"deskarm: {refusal}", file=sys.stderr)
        return 2
    if args.screenshot:  # always offscreen at --size (as the main window's): needs no display, moves no real arm
        os.environ["QT_QPA_PLATFORM"] = "offscreen"
        from app.assist_window import take_assist_screenshot

        return take_assist_screenshot(args.screenshot, size, args.after, hand_camera=hand_camera, switches=switches,
                                      passing_hand=args.scenario == "panel", detector=detector)
    from app.cli_assist import display_problem

    problem = display_problem(os.environ)
    if problem:
        print(f"deskarm: {problem}", file=sys.stderr)
        return 2
    from app.assist_window import run_assist_window

    return run_assist_window(size, hand_camera=hand_camera, switches=switches, bridge_url=args.bridge,
                             passing_hand=args.scenario == "panel", detector=detector)


def assist_real_arm_refusal(bridge_url: str, real_arm: bool, hand_camera_spec) -> str:
    """Why ``deskarm --assist`` will not drive ``bridge_url`` ("" when it will): a real arm never
    presses buttons of the simulated panel that stands in for a missing hand camera — only a user
    who asked for ``--hand-camera sim`` gets a real arm on the simulated desk (to try the wiring)."""
    if not real_arm or hand_camera_spec is not None:
        return ""
    return (f"--bridge {bridge_url}: refused — with no --hand-camera the assistive view shows the simulated "
            "panel, and a real arm would press buttons that are not there. Give the camera on the arm's hand "
            "(--hand-camera webcam:N), or --hand-camera sim to drive the real arm from the simulated panel on purpose")


def main(argv: list[str] | None = None) -> int:
    try:
        return _main(argv)
    except ImportError as exc:  # a minimal system without the libraries under Qt (libglib, EGL, xcb…)
        from app.qt_libraries import import_failure_text

        text = import_failure_text(exc)
        if not text:
            raise
        print(text, file=sys.stderr)
        return 2


@contextmanager
def start_up():
    """Python's cyclic garbage collector paused while a run starts (imports, session, window), as
    it was again when the block ends; the block gets a function that resumes it early.

    Start-up makes hundreds of thousands of objects and frees few: each automatic collection
    walks them all for nothing. A window collects from its GUI-thread timer once it runs
    (app.startup.GuiThreadGarbage, which keeps the automatic collector off) and a headless run
    collects and freezes what start-up made (core.session.freeze_startup_objects) after resuming."""
    was_enabled = gc.isenabled()
    gc.disable()

    def resume() -> None:
        if was_enabled:
            gc.enable()

    try:
        yield resume
    finally:
        resume()


def _main(argv: list[str] | None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] in SUBCOMMANDS:
        import importlib

        module = importlib.import_module(SUBCOMMANDS[argv[0]])
        return module.run(argv[0], argv[1:])
    with start_up() as resume_collector:
        return _run(argv, resume_collector)


def _run(argv: list[str], resume_collector) -> int:
    """The window, the assistive view, the headless runner or a screenshot, as ``argv`` asks."""
    args = build_parser().parse_args(argv)
    problem = estop_switch_problem(args)
    if problem:
        print(f"deskarm: {problem}", file=sys.stderr)
        return 2
    if args.assist:
        return run_assist(args)
    if args.hand_camera is not None or args.switch:
        print("deskarm: --hand-camera and --switch belong to the assistive view: add --assist", file=sys.stderr)
        return 2
    from core.detect.registry import parse_detector_list
    from core.session import SessionOptions

    try:
        detectors = () if args.detector is None else tuple(parse_detector_list(args.detector))
    except ValueError as exc:
        print(f"deskarm: --detector {args.detector!r}: {exc}", file=sys.stderr)
        return 2
    problem = object_option_problem(args)
    if problem:
        print(f"deskarm: {problem}", file=sys.stderr)
        return 2
    try:
        rig_offset = None
        if args.rig_offset is not None:
            from app.cli_handeye import parse_rig_offset

            rig_offset = parse_rig_offset(args.rig_offset)
    except ValueError as exc:
        print(f"deskarm: {exc}", file=sys.stderr)
        return 2
    options = SessionOptions(
        camera=args.camera, bridge=args.bridge, robot=args.robot, scenario=args.scenario,
        fps=args.fps, simulated_clock=bool(args.headless and args.fast), calibration=args.calibration,
        event_driven=not args.tick_driven, rig_offset=rig_offset, hand_eye=args.hand_eye,
        markers=args.markers, remote=args.remote, remote_credentials=args.credentials or "", sim_skew_ms=args.sim_skew_ms, sim_realism=args.sim_realism,
        detectors=detectors,
        follow_object=args.follow_object, object_intercept=not args.no_intercept,
        compensate_skew=not args.no_skew_compensation, object_roi_search=args.object_roi,
        object_tracker=args.object_tracker, object_detect_every=args.object_detect_every,
        teleop_source=args.teleop, estop_switches=args.estop_switch, rearm_switches=args.rearm_switch,
    )
    try:
        options.validate()
        size = parse_size(args.size)
        if not (1.0 <= args.fps <= 240.0):
            raise ValueError(f"--fps {args.fps:g} is outside 1…240")
        if args.headless:  # the window path does not import the headless runner (start-up)
            from app.headless import check_duration

            check_duration(args.duration)
    except ValueError as exc:  # ProfileError and SettingsError are ValueErrors too
        print(f"deskarm: {exc}", file=sys.stderr)
        return 2
    try:
        if args.headless:
            from app.headless import run_headless

            resume_collector()  # a long run must collect; it freezes what start-up made first
            return run_headless(options, args.duration, args.json, record=args.record)
        if args.screenshot:
            # always offscreen (even with QT_QPA_PLATFORM=xcb and no display, where Qt would abort):
            # the PNG is exactly --size and needs no screen
            os.environ["QT_QPA_PLATFORM"] = "offscreen"
            from app.gui import take_screenshot

            return take_screenshot(options, args.screenshot, args.after, size)
        from app.cli_assist import display_problem

        problem = display_problem(os.environ)
        if problem:  # Qt would abort (exit 134) after a screenful of plugin messages
            print(f"deskarm: {problem}", file=sys.stderr)
            return 2
        from app.startup import show_splash

        splash = show_splash()  # on screen before OpenCV, Pinocchio and the cameras load
        from app.gui import run_window

        return run_window(options, size, splash)
    except KeyboardInterrupt:
        return 130
    except (OSError, RuntimeError, ValueError) as exc:
        print(f"deskarm: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
