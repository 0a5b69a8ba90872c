"""What `deskarm --headless` writes where, and its exit code: the result alone on stdout (the JSON
object pipes into `python -m json.tool`), everything else on stderr; a run that saw nothing fails."""
import json
import subprocess
import sys
from pathlib import Path

from app.cli import main

ROOT = Path(__file__).resolve().parents[2]


def test_with_json_stdout_is_the_json_object_alone_and_the_rest_goes_to_stderr(tmp_path):
    """Before: banners, the once-a-second status and the recording's path came first on stdout,
    so `deskarm --headless --json | python -m json.tool` failed."""
    done = subprocess.run(
        [sys.executable, "-m", "app.cli", "--headless", "--fast", "--camera", "sim", "--duration", "2.5", "--json",
         "--record", str(tmp_path / "rec")], cwd=ROOT, capture_output=True, text=True, timeout=180)
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)  # the whole of stdout, not its last line
    assert summary["frames"] > 0 and summary["record_path"] == str(tmp_path / "rec")
    err = done.stderr.splitlines()
    assert any(line.startswith("deskarm: SIMULATED DESK") for line in err)
    assert any(line.startswith("deskarm headless: camera") for line in err)
    assert any(line.startswith("deskarm: recording to") for line in err)
    assert sum(line.startswith("t=") for line in err) >= 2  # the status at 1 s and 2 s


def test_without_json_stdout_is_the_done_line_alone(capsys):
    assert main(["--headless", "--fast", "--camera", "sim", "--duration", "1.5"]) == 0
    captured = capsys.readouterr()
    assert captured.out.startswith("done: ") and len(captured.out.strip().splitlines()) == 1
    assert "deskarm headless: camera" in captured.err and "\nt=" in captured.err


def test_a_run_whose_camera_never_opened_exits_1_after_saying_why_on_stderr():
    """Before: two webcams that do not exist gave 0 frames and exit code 0."""
    done = subprocess.run(
        [sys.executable, "-m", "app.cli", "--headless", "--camera", "98,99", "--duration", "1", "--json"],
        cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 1, (done.stdout, done.stderr)
    assert json.loads(done.stdout)["frames"] == 0  # the metrics are still printed
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("deskarm: the run saw nothing: webcams 98,99 gave no frame in "), last
    assert "camera 98" in last or "cameras 98, 99" in last, last  # why: the device that did not open
    assert "Traceback" not in done.stderr


def test_run_headless_writes_the_result_to_out_and_the_rest_to_err():
    import io

    from app.headless import run_headless
    from core.session import SessionOptions

    out, err = io.StringIO(), io.StringIO()
    assert run_headless(SessionOptions(camera="sim", simulated_clock=True), 1.5, True, out=out, err=err) == 0
    assert json.loads(out.getvalue())["frames"] > 0
    assert "deskarm: SIMULATED DESK" in err.getvalue() and "\nt=" in err.getvalue()


def test_the_saw_nothing_line_blames_the_camera_only_when_it_was_not_open():
    from app.headless import saw_nothing

    missing = saw_nothing("webcams 98,99", 1.0, "cameras 98, 99 unplugged or not delivering frames", False, 1.0)
    assert "(cameras 98, 99 unplugged" in missing and missing.endswith("check the camera (--camera) and try again")
    short = saw_nothing("simulated desk (static)", 0.0, "", True, 0.01)
    assert "--duration 0.01 s may be shorter than its first frame" in short and "check the camera" not in short
