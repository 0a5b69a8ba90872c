"""Never drive a real arm from a fake world: a camera that does not open is a visible missing
state and the arm holds; the simulated desk stands in only for 'nothing plugged in'."""
import json

from app.cli import main
from core.session import DeskSession, SessionOptions


def test_named_cameras_missing_with_a_real_arm_send_no_pulses(board, capsys):
    """`--camera /dev/video99,/dev/video98 --bridge v2:PORT`: before, the simulated desk stood in
    and the board received moving pulses; now nothing is commanded at all."""
    code = main(["--headless", "--camera", "/dev/video99,/dev/video98", "--bridge", f"v2:{board.path}",
                 "--duration", "1.5", "--json"])
    out = capsys.readouterr().out
    assert code == 0
    assert "CAMERA MISSING — camera /dev/video99 did not open" in out and "SIMULATED DESK" not in out
    summary = json.loads(out.strip().splitlines()[-1])
    assert summary["frames"] == 0 and summary["commands_sent"] == 0
    assert board.pwm_until_silent(0.3) == []  # no servo pulse was ever set


def test_no_webcam_and_a_real_arm_is_not_the_simulated_desk(board):
    session = DeskSession.create(SessionOptions(camera="/dev/video97,/dev/video96", bridge=f"v2:{board.path}"))
    try:
        assert session.camera.kind == "webcam" and not session.camera.is_connected
        assert any(b.startswith("CAMERA MISSING") for b in session.banners)
    finally:
        session.close()


def test_nothing_plugged_in_runs_on_the_simulated_desk_and_asking_for_it_works_with_any_arm(board):
    session = DeskSession.create(SessionOptions(camera="sim", bridge=f"v2:{board.path}"))  # asked for
    try:
        assert session.camera.kind == "sim"
    finally:
        session.close()
    session = DeskSession.create(SessionOptions(camera="sim"))
    try:
        assert session.camera.kind == "sim" and session.banners[0] == "SIMULATED DESK"
    finally:
        session.close()
