"""Never drive a real arm from a fake world: a camera that does not open is a visible missing
state and the arm holds; the simulated desk stands in only for 'nothing plugged in'."""
import json

from app.cli import main
from core.session import DeskSession, SessionOptions


def test_named_cameras_missing_with_a_real_arm_send_no_pulses(board, capsys):
    """`--camera /dev/video99,/dev/video98 --bridge v2:PORT`: before, the simulated desk stood in
    and the board received moving pulses; now nothing is commanded at all, and the run that saw
    nothing exits 1."""
    code = main(["--headless", "--camera", "/dev/video99,/dev/video98", "--bridge", f"v2:{board.path}",
                 "--duration", "1.5", "--json"])
    captured = capsys.readouterr()
    assert code == 1
    assert "CAMERA MISSING — camera /dev/video99 did not open" in captured.err and "SIMULATED DESK" not in captured.err
    assert "the run saw nothing" in captured.err.strip().splitlines()[-1]
    summary = json.loads(captured.out)
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


def test_switching_to_a_real_arm_on_the_stand_in_simulated_desk_is_refused(board, qtbot):
    """No webcam found ('auto'): the window shows the simulated desk; choosing a real port in
    the bridge picker keeps the simulated arm and says why (a real arm asked for with
    --camera sim is allowed)."""
    from app.workers import BridgeWorker, Latest

    session = DeskSession.create(SessionOptions(camera="auto"))  # no webcam on this machine
    worker = BridgeWorker(session, Latest(), Latest())
    try:
        assert session.camera.kind == "sim"
        assert "would follow markers that do not exist" in session.real_arm_refusal(f"v2:{board.path}")
        assert session.real_arm_refusal("sim://") == ""
        worker.request_bridge(f"v2:{board.path}")
        worker._handle_requests()
        assert session.bridge.url == "sim://" and "--camera sim" in session.bridge.message
    finally:
        session.close()
    asked = DeskSession.create(SessionOptions(camera="sim"))
    try:
        assert asked.real_arm_refusal(f"v2:{board.path}") == ""
    finally:
        asked.close()


def test_sessions_starting_together_do_not_collide_on_their_files():
    """Simultaneous starts all write the simulated rig's calibration to the cache (2 of 30
    starts failed on a fixed temporary file name)."""
    import threading

    from core.session import load_session_calibration

    session = DeskSession.create(SessionOptions(camera="sim"))
    errors, go = [], threading.Barrier(12)

    def start():
        go.wait()
        try:
            for _ in range(5):
                calib, note = load_session_calibration(session.camera, None)
                assert note == "" and calib.image_size == (640, 480)
        except Exception as exc:  # noqa: BLE001 - collected for the assert below
            errors.append(repr(exc))

    threads = [threading.Thread(target=start) for _ in range(12)]
    try:
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=60)
    finally:
        session.close()
    assert errors == []


def test_a_read_only_cache_folder_does_not_stop_the_simulated_desk(monkeypatch):
    import core.session as session_module

    def refuse(path, calib, *args, **kwargs):
        raise PermissionError(13, f"{path}: cannot write: permission denied — make it writable")

    monkeypatch.setattr(session_module, "save_calibration", refuse)
    session = DeskSession.create(SessionOptions(camera="sim"))
    try:
        assert session.calibration.image_size == (640, 480)
        assert any("permission denied" in b for b in session.banners)
    finally:
        session.close()
