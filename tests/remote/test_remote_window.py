"""`deskarm --remote`: a session (headless and in the window) on a desk served by `deskarm serve`.

The server is a subprocess on a free loopback port with scouting off, as in test_remote.py. No
sleeps: every wait is a condition with a timeout, paced by the server's own camera frames.
"""
from __future__ import annotations

import io
import json
import math
from pathlib import Path

import numpy as np
import pytest

from core.remote import ros
from serving import free_port, served_desk, zenoh_loopback_problem
from core.remote.link import LinkOptions

ROOT = Path(__file__).resolve().parents[2]
LEFT = ros.IMAGE_TOPICS["left"]
MEASURED = "/deskarm/joint_states/measured"
WAIT = 10.0  # s: generous for a loaded 2-core machine; a pass takes milliseconds


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """`deskarm serve --camera sim --scenario static` on a free loopback port (scouting off); its endpoint."""
    problem = zenoh_loopback_problem()
    if problem:
        pytest.skip(problem)
    with served_desk(tmp_path_factory.mktemp("serve_home"), "static") as endpoint:
        yield endpoint


@pytest.fixture
def observer(server):
    """A DeskClient without heartbeat: watches the server, never keeps its arm un-paused."""
    from core.remote.client import DeskClient

    with DeskClient(LinkOptions(connect=(server,), scouting=False), heartbeat=False) as client:
        assert client.wait_for(LEFT, timeout=WAIT) is not None, "the server sends no frames"
        yield client


@pytest.fixture
def remote_session(server):
    from core.session import DeskSession, SessionOptions

    session = DeskSession.create(SessionOptions(remote=server))
    try:
        yield session
    finally:
        session.close()


def after_frames(client, n: int) -> None:
    """Wait for ``n`` more camera frames from the server (its clock paces the test)."""
    start = client.count(LEFT)
    assert client.wait_for(LEFT, timeout=WAIT, after=start + n - 1) is not None, f"fewer than {n} frames arrived"


def estop_echo(client, engaged: bool, after: int):
    r = client.wait_for("/deskarm/estop", lambda r: bool(r.msg.data) is engaged, timeout=WAIT, after=after)
    assert r is not None, f"no /deskarm/estop {engaged} echo from the server; status: {client.session()}"
    return r


# ---- without a server ---------------------------------------------------------------------------

def test_calibration_rebuilt_from_camera_info_matches_the_servers():
    from core.remote.desk import calibration_from_camera_info
    from core.sim.rig import SimRig

    cal = SimRig().calibration()
    rebuilt = calibration_from_camera_info(ros.camera_info(cal, "left", 0.0), ros.camera_info(cal, "right", 0.0))
    assert rebuilt.image_size == tuple(cal.image_size)
    for name in ("M1", "D1", "M2", "D2", "R", "P1", "P2"):
        a, b = np.asarray(getattr(rebuilt, name)).reshape(-1), np.asarray(getattr(cal, name)).reshape(-1)
        assert np.allclose(a, b, atol=1e-6), f"{name}: {a} vs {b}"
    assert np.allclose(rebuilt.T.reshape(3), np.asarray(cal.T).reshape(3), atol=1e-9), (rebuilt.T, cal.T)


def test_tf_static_pose_round_trips():
    from core.remote.desk import base_T_camera_of
    from core.sim.rig import SimRig

    T = np.asarray(SimRig().base_T_camera, float)
    msg = ros.tf_message([ros.transform_stamped(T, "robot_base", "camera_left", 0.0)])
    assert np.allclose(base_T_camera_of(msg), T, atol=1e-9)


def test_a_desk_that_does_not_answer_is_a_clear_error_and_a_visible_state():
    if zenoh_loopback_problem():
        pytest.skip(zenoh_loopback_problem())
    from core.remote.desk import NOT_ANSWERING, RemoteDesk, RemoteDeskError, RemoteStereoCamera, open_remote_desk

    endpoint = f"tcp/127.0.0.1:{free_port()}"  # nobody listens there
    with pytest.raises(RemoteDeskError, match="no desk server answered"):
        open_remote_desk(endpoint, profile=None, timeout=0.3)
    camera = RemoteStereoCamera(RemoteDesk(endpoint))
    camera.connect()
    try:
        assert camera.read() is None
        assert not camera.is_connected
        assert NOT_ANSWERING in camera.status_message and endpoint in camera.status_message
    finally:
        camera.disconnect()


def test_remote_option_is_validated():
    from core.session import SessionOptions

    with pytest.raises(ValueError, match="tcp/192.168.1.20:7447"):
        SessionOptions(remote="192.168.1.20").validate()
    with pytest.raises(ValueError, match="simulated clock"):
        SessionOptions(remote="tcp/127.0.0.1:7447", simulated_clock=True).validate()


# ---- against `deskarm serve` --------------------------------------------------------------------

def test_remote_session_finds_the_served_markers_with_local_perception(remote_session, server):
    s = remote_session
    assert s.banners and s.banners[0] == f"REMOTE — {server}"
    assert s.camera.kind == "remote" and s.camera.name == f"remote: {server}"
    assert s.bridge.url == f"remote:{server}"
    assert s.camera_to_robot_state() == f"camera→arm: as served by {server}"
    client = s.camera.desk.client
    for _ in range(60):  # frames, until one whose markers the server published too
        frame = s.camera.read()
        if frame is None:  # no pair within 0.25 s (a loaded machine): read again
            continue
        served = client.wait_for("/deskarm/markers", lambda r: r.msg.markers and ros.stamp_s(
            r.msg.markers[0].header.stamp) == s.camera.last_stamp_wall, timeout=1.0)
        result = s.perception.process(frame)
        found = {m.marker_id: m.base_p_centre for m in result.markers if m.found}
        if served is not None and found:
            break
    else:
        pytest.fail(f"no frame with markers found here and by the server ({s.camera.status_message})")
    assert frame.left.shape == (s.calibration.image_size[1], s.calibration.image_size[0], 3)
    assert frame.t <= s.clock.now()
    theirs = ros.markers_of(served.msg)
    for marker_id, p in found.items():
        assert all(math.isfinite(v) for v in p) and 0.0 < np.linalg.norm(p) < 1.0, f"marker {marker_id} at {p}"
        if marker_id in theirs:  # the same frame, perceived here from its JPEGs and there from raw images
            assert np.linalg.norm(np.subtract(p, theirs[marker_id])) < 0.01, (marker_id, p, theirs[marker_id])
    assert set(found) & set(theirs), (found, theirs)


def test_goal_and_estop_through_the_remote_bridge_reach_the_servers_arm(remote_session, observer):
    from core.messages import JointCommand

    s, bridge = remote_session, remote_session.bridge
    bridge.connect()  # starts the heartbeat: the server's arm is not paused by a silent link
    bridge.rearm()
    estop_echo(observer, False, after=0)
    state = None
    for _ in range(3):
        after_frames(observer, 1)
        state = bridge.joint_state()
    assert state is not None and state.measured, "no measured joint state from the server"
    q_goal = np.array(state.q, float)
    q_goal[0] += 0.35 if q_goal[0] < 0 else -0.35  # turn the base: same height, inside the limits
    target = tuple(float(v) for v in s.kinematics.fk(q_goal))
    start = np.linalg.norm(s.kinematics.fk(state.q) - np.asarray(target))

    def tool_distance(r):
        return float(np.linalg.norm(s.kinematics.fk(np.asarray(r.msg.position)) - np.asarray(target)))

    bridge.send(JointCommand(seq=1, t=s.clock.now(), q=tuple(q_goal), base_p_target=target))
    assert bridge.goals_sent == 1
    moved = observer.wait_for(MEASURED, lambda r: tool_distance(r) < start - 0.01, timeout=WAIT)
    assert moved is not None, f"the server's arm did not move toward {target}; status {observer.session()}"
    assert observer.wait_for("/deskarm/session", lambda r: json.loads(r.msg.data)["mode"] == "manual",
                             timeout=WAIT) is not None, f"the server is not in manual mode: {observer.session()}"

    before = observer.count("/deskarm/estop")
    bridge.estop()
    assert bridge.send(JointCommand(seq=2, t=s.clock.now(), q=tuple(state.q), base_p_target=target)) == ()
    estop_echo(observer, True, after=before)
    r = observer.wait_for("/deskarm/session", lambda r: json.loads(r.msg.data)["estopped"], timeout=WAIT)
    assert r is not None, f"the server does not report the e-stop: {observer.session()}"
    assert "E-STOP" in bridge.status().message
    after_frames(observer, 3)
    held = observer.joints("measured")
    after_frames(observer, 10)
    assert observer.joints("measured") == held, "the server's arm moved after the e-stop"
    before = observer.count("/deskarm/estop")
    bridge.rearm()
    estop_echo(observer, False, after=before)


def test_headless_run_on_a_remote_desk(server):
    from app.headless import run_headless
    from core.session import SessionOptions

    out = io.StringIO()
    code = run_headless(SessionOptions(remote=server), 3.0, as_json=True, out=out)
    text = out.getvalue()
    assert code == 0, text
    assert f"REMOTE — {server}" in text and f"camera remote: {server}" in text
    metrics = json.loads(text.strip().splitlines()[-1])
    assert metrics["frames"] > 10, metrics
    assert metrics["commands_sent"] > 0, metrics


def test_window_on_a_remote_desk_shows_frames_and_stop_reaches_the_server(qtbot, server, observer):
    from app.gui import MainWindow
    from core.session import DeskSession, SessionOptions

    w = MainWindow(DeskSession.create(SessionOptions(remote=server)))
    qtbot.addWidget(w)
    w.resize(800, 480)
    w.show()
    w.start()
    try:
        qtbot.waitUntil(lambda: w._result is not None, timeout=int(WAIT * 1000))
        assert w._result.frame is not None and w._result.frame.left.size > 0
        qtbot.waitUntil(lambda: w.session.bridge.is_connected, timeout=int(WAIT * 1000))
        before = observer.count("/deskarm/estop")
        w.on_stop_requested()
        estop_echo(observer, True, after=before)
        before = observer.count("/deskarm/estop")
        w.on_rearm_requested()
        estop_echo(observer, False, after=before)
    finally:
        w.stop()


def test_camera_settings_and_a_bridge_switch_while_remote(remote_session, observer):
    from core.settings import CameraSettings

    s = remote_session
    s.bridge.connect()  # the session claims control of the served desk (settings are the controller's)
    assert s.camera.desk.client.wait_control(WAIT), observer.session()
    s.camera.set_settings(CameraSettings(gain=6.0, exposure=0.5))  # the window's camera sliders
    r = observer.wait_for("/deskarm/session", lambda r: json.loads(r.msg.data).get("camera_settings", {})
                          .get("gain") == 6.0, timeout=WAIT)
    assert r is not None, observer.session()
    # the arm is on the serving machine: the window never swaps in a local bridge
    assert "served by another machine" in s.real_arm_refusal("sim://")
    assert "served by another machine" in s.real_arm_refusal("v2:/dev/ttyACM0")
