"""A served desk only its owner drives (issue 23): `deskarm serve` with the credentials `--pair`
made, on loopback, its arm the host firmware (PWM lines are what the servos would get).

- an outsider: a plain zenoh session without credentials, publishing every command on the keys;
- a viewer (viewer.toml): sees frames, may STOP, never moves or re-arms the arm;
- a controller (controller.toml): drives, re-arms with a hold, owns the arm until it lets go;
- a second controller's heartbeat never resumes an arm paused for its owner's lost link;
- TLS with mutual certificates: the controller's certificate drives, no certificate is refused.

"Nothing changed the arm" is checked at the firmware: no PWM line arrived while the server
served N more frames after the attempt (its clock paces the test; no sleeps), and the same
commands from the controller do produce PWM lines, so the check can fail.
"""
from __future__ import annotations

import json
import stat
import time

import numpy as np
import pytest

from core.remote import ros, security
from core.remote.link import LinkError, LinkOptions
from serving import serve, zenoh_loopback_problem

LEFT = ros.IMAGE_TOPICS["left"]
WAIT = 15.0  # s: generous for a loaded 2-core machine; a pass takes far less
FRAMES = 20  # served frames (~0.7 s of the server's clock) after an attempt before checking the PWM lines


@pytest.fixture(scope="module")
def paired(tmp_path_factory):
    problem = zenoh_loopback_problem()
    if problem:
        pytest.skip(problem)
    home = tmp_path_factory.mktemp("paired_home")
    files = security.pair(folder=home / "config" / "remote", hosts=("localhost", "127.0.0.1"))
    creds = {role: security.load_credential(path) for role, path in files.items()}
    creds["files"] = files
    return home, creds


@pytest.fixture(scope="module")
def desk(paired, host_firmware):
    """A paired `deskarm serve` (credentials required) whose arm is a host_firmware board."""
    from host_board import Board

    home, creds = paired
    board = Board(host_firmware)
    try:
        with serve(home, "static", "--bridge", f"v2:{board.path}") as served:
            served.board = board
            served.creds = creds
            yield served
    finally:
        board.stop()


def link(endpoint, credential=None, strict=False) -> LinkOptions:
    return LinkOptions(connect=(endpoint,), credential=credential, strict_connect=strict)


def viewer_of(desk):
    from core.remote.client import DeskClient

    return DeskClient(link(desk.endpoint, desk.creds["viewer"]), heartbeat=False, control=False)


def controller_of(desk, **kwargs):
    from core.remote.client import DeskClient

    return DeskClient(link(desk.endpoint, desk.creds["controller"]), **kwargs)


def after_frames(client, n: int = FRAMES) -> None:
    start = client.count(LEFT)
    assert client.wait_for(LEFT, timeout=WAIT, after=start + n - 1) is not None, f"fewer than {n} frames arrived"


def drain(board) -> None:
    """Wait until the arm is still (no PWM line for 0.3 s) and forget what it printed."""
    board.pwm_until_silent()


def pwm_lines_now(board) -> list[str]:
    """Every line the firmware printed since the last drain, without waiting."""
    out = []
    while not board.lines.empty():
        out.append(board.lines.get_nowait())
    return [line for line in out if line.startswith("PWM")]


def status_where(client, predicate, what: str) -> dict:
    r = client.wait_for("/deskarm/session", lambda r: predicate(json.loads(r.msg.data)), timeout=WAIT)
    assert r is not None, f"the server never reported {what}; last: {client.session()}"
    return json.loads(r.msg.data)


def rmw_attachment(seq: int) -> bytes:
    return ros.Attachment(seq, time.time_ns(), b"outsider-gid-16b").encode()


def every_command(put, client_id: str = "outsider") -> None:
    """``put(topic, payload)`` of every command that moves, re-arms, resumes or takes the arm."""
    put("/deskarm/cmd/control", ros.serialize(ros.json_msg({"claim": client_id, "take": True}), "std_msgs/msg/String"))
    for p in ((0.18, 0.05, 0.10), (0.12, -0.08, 0.15), (0.20, 0.0, 0.05), (0.10, 0.10, 0.12)):
        put("/deskarm/cmd/goal", ros.serialize(ros.point_stamped(p, time.time()), "geometry_msgs/msg/PointStamped"))
    put("/target_position", ros.serialize(ros.typestore().types["geometry_msgs/msg/Point"](x=0.15, y=0.1, z=0.1),
                                          "geometry_msgs/msg/Point"))
    for settings in ({"mode": "lissajous", "lissajous_running": True}, {"mode": "follow", "follow_id": 3},
                     {"camera": {"gain": 20.0}}):
        put("/deskarm/cmd/settings", ros.serialize(ros.json_msg(settings), "std_msgs/msg/String"))
    put("/deskarm/cmd/estop", ros.serialize(ros.bool_msg(False), "std_msgs/msg/Bool"))
    for _ in range(15):  # a re-arm "held" for 1.5 s worth of requests, and heartbeats under another id
        put("/deskarm/cmd/rearm", ros.serialize(ros.header(time.time(), client_id), "std_msgs/msg/Header"))
        put("/deskarm/cmd/heartbeat", ros.serialize(ros.header(time.time(), client_id), "std_msgs/msg/Header"))


def outsider_puts(session):
    seq = [0]

    def put(topic, payload):
        seq[0] += 1
        session.put(ros.key_expr(topic), payload, attachment=rmw_attachment(seq[0]))
    return put


def test_pairing_files_are_owner_only_and_a_client_file_names_its_role(paired):
    home, creds = paired
    folder = home / "config" / "remote"
    assert stat.S_IMODE(folder.stat().st_mode) == 0o700
    for path in folder.iterdir():
        assert stat.S_IMODE(path.stat().st_mode) == 0o600, f"{path.name} is {oct(path.stat().st_mode)}"
    assert creds["controller"].user == "controller" and creds["viewer"].user == "viewer"
    assert creds["controller"].password != creds["viewer"].password
    assert b"BEGIN CERTIFICATE" in creds["viewer"].cert_pem and b"PRIVATE KEY" in creds["viewer"].key_pem
    users = (folder / "users.txt").read_text().split()
    assert sorted(u.split(":")[0] for u in users) == ["controller", "viewer"]


def test_an_outsider_without_credentials_changes_nothing_at_the_firmware(desk):
    from core.remote.link import open_session

    board = desk.board
    with viewer_of(desk) as watcher:
        assert watcher.wait_for(LEFT, timeout=WAIT) is not None, "the viewer gets no frames"
        drain(board)
        outsider = open_session(LinkOptions(connect=(desk.endpoint,)))  # plain zenoh, no credential
        try:
            every_command(outsider_puts(outsider))
            assert outsider.info.peers_zid() == [], "the server let a session without credentials in"
            got = []
            outsider.declare_subscriber(ros.key_pattern(LEFT), lambda s: got.append(1))
            after_frames(watcher)
        finally:
            outsider.close()
        assert pwm_lines_now(board) == [], "the outsider's commands reached the arm"
        assert not got, "an outsider without credentials received camera frames"
        status = watcher.session()
        assert status["controller"] is None and status["mode"] != "lissajous", status
    desk.wait_line("refused a connection: no credential", timeout=WAIT)


def test_a_wrong_password_is_refused_in_one_clear_line_on_both_sides(desk):
    from core.remote.client import DeskClient

    wrong = security.Credential("controller", "not-the-password", source="test.toml")
    with pytest.raises(LinkError) as info:
        DeskClient(link(desk.endpoint, wrong, strict=True), heartbeat=False)
    text = str(info.value)
    assert "refused this machine" in text and "user 'controller'" in text and "deskarm serve --pair" in text
    assert "\n" not in text
    line = desk.wait_line("refused a connection: a wrong password", timeout=WAIT)
    assert line.startswith("deskarm serve: refused a connection")


def test_a_viewer_sees_and_stops_but_never_moves_or_rearms(desk):
    board = desk.board
    with viewer_of(desk) as viewer, controller_of(desk, heartbeat=True) as owner:
        assert owner.rearm(timeout=WAIT), owner.session()
        drain(board)
        # the viewer tries everything the controller may do: Zenoh's access control drops it
        seq = [0]

        def put(topic, payload):
            seq[0] += 1
            viewer._zenoh.put(ros.key_expr(topic), payload, attachment=rmw_attachment(seq[0]))
        every_command(put, client_id="viewer-1")
        viewer.send_goal((0.15, 0.1, 0.1), wait=False)
        after_frames(viewer)
        assert pwm_lines_now(board) == [], "a viewer's command moved the arm"
        assert viewer.session()["controller"] == owner.client_id
        # STOP works from a viewer
        assert viewer.estop_round_trip(timeout=WAIT) is not None, "the viewer's STOP got no echo"
        status_where(viewer, lambda s: s["estopped"], "the viewer's e-stop")
        drain(board)
        # ... a re-arm from the viewer does not (held for longer than the hold)
        viewer.control = True
        assert viewer.rearm(timeout=2.5) is False
        assert viewer.session()["estopped"] is True
        # the owner's goal while e-stopped moves nothing either
        owner.send_goal((0.15, -0.1, 0.1))
        after_frames(viewer)
        assert pwm_lines_now(board) == [], "the arm moved while e-stopped"
        assert owner.rearm(timeout=WAIT), f"the controller could not re-arm: {owner.session()}"


def test_the_controller_drives_the_arm_at_the_firmware(desk):
    board = desk.board
    with controller_of(desk, heartbeat=True) as owner:
        assert owner.rearm(timeout=WAIT), owner.session()
        drain(board)
        owner.send_goal((0.15, 0.1, 0.1))
        assert board.next_pwm(timeout=WAIT), "the controller's goal did not move the arm"
        drain(board)
        owner.send_settings({"mode": "lissajous", "lissajous_running": True})
        lines = [board.next_pwm(timeout=WAIT) for _ in range(5)]
        assert len(set(lines)) > 1, lines
        owner.send_settings({"mode": "manual"})
        owner.send_estop(True)
        status_where(owner, lambda s: s["estopped"], "the e-stop")
        assert owner.rearm(timeout=WAIT)
        status = owner.session()
        assert status["controller"] == owner.client_id and not status["estopped"]


def test_one_controller_at_a_time_and_another_sessions_heartbeat_never_resumes(desk):
    board = desk.board
    with controller_of(desk, heartbeat=True) as owner, \
            controller_of(desk, heartbeat=False, control=False) as other, viewer_of(desk) as viewer:
        assert owner.wait_control(WAIT) and owner.rearm(timeout=WAIT), owner.session()
        # a second controller's claim is refused while the first holds the arm
        other._send("/deskarm/cmd/control", ros.json_msg({"claim": other.client_id}))
        status_where(viewer, lambda s: any("is in control" in t for t in s["refused"]), "the refused claim")
        assert viewer.session()["controller"] == owner.client_id
        owner.send_settings({"mode": "lissajous", "lissajous_running": True})
        board.next_pwm(timeout=WAIT)
        owner.stop_heartbeat()  # the owner's link drops: the arm pauses
        status_where(viewer, lambda s: "remote link lost" in s["paused_by"], "the pause")
        drain(board)
        other.start_heartbeat()  # another session's heartbeat (control=False: it does not claim)
        after_frames(viewer)
        assert "remote link lost" in viewer.session()["paused_by"], viewer.session()
        assert pwm_lines_now(board) == [], "another session's heartbeat resumed the arm"
        owner.start_heartbeat()  # the owner is back: it resumes
        status_where(viewer, lambda s: not s["paused"], "the resume")
        assert board.next_pwm(timeout=WAIT)
        # an explicit hand-over
        assert other.take_control(WAIT), viewer.session()
        status_where(viewer, lambda s: s["controller"] == other.client_id, "the hand-over")
        owner.send_settings({"mode": "manual"}, wait=False)
        status_where(viewer, lambda s: any("not in control" in t for t in s["refused"]), "the old owner refused")
        other.send_settings({"mode": "manual"})
        other.release_control()
        status_where(viewer, lambda s: s["controller"] is None, "the release")


def test_client_watches_stops_when_asked_and_never_rearms_unless_asked(desk, capsys):
    from app.cli_serve import run

    viewer_file = str(desk.creds["files"]["viewer"])
    with viewer_of(desk) as viewer, controller_of(desk, heartbeat=True) as owner:
        assert owner.rearm(timeout=WAIT), owner.session()
        code = run("serve", ["--client", desk.endpoint, "--duration", "1", "--credentials", viewer_file,
                             "--estop-test", "--json"])
        summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
        assert code == 0 and summary["estop_round_trip_ms"] is not None and summary["rearmed"] is None
        status_where(viewer, lambda s: s["estopped"], "the --client e-stop")
        after_frames(viewer)
        assert viewer.session()["estopped"] is True, "deskarm serve --client re-armed the arm"
        assert viewer.session()["controller"] == owner.client_id  # a watcher never claims the arm
        assert owner.rearm(timeout=WAIT)


def test_a_remote_desk_without_the_credential_says_it_was_refused_and_with_it_opens(desk):
    from core.remote.desk import RemoteDeskError, open_remote_desk

    with pytest.raises(RemoteDeskError, match="refused this machine"):
        open_remote_desk(desk.endpoint, profile=None, timeout=3.0)  # this test's config folder has no client.toml
    camera, bridge = open_remote_desk(desk.endpoint, profile=None, timeout=WAIT, credential=desk.creds["viewer"])
    try:
        assert camera.calibration() is not None and camera.base_T_camera() is not None
    finally:
        camera.disconnect()


@pytest.fixture(scope="module")
def tls_desk(paired):
    home, creds = paired
    with serve(home, "static", "--tls", proto="tls") as served:
        served.endpoint = served.endpoint.replace("127.0.0.1", "localhost")  # the name the certificate carries
        served.creds = creds
        yield served


def test_mutual_tls_the_controller_certificate_drives_and_no_certificate_is_refused(tls_desk):
    from core.remote.client import DeskClient

    cred = tls_desk.creds["controller"]
    with DeskClient(link(tls_desk.endpoint, cred, strict=True), heartbeat=True) as owner:
        assert owner.wait_for(LEFT, timeout=WAIT) is not None, "no frames over TLS"
        assert owner.rearm(timeout=WAIT), owner.session()
        first = owner.wait_for("/deskarm/joint_states/commanded", timeout=WAIT)
        assert first is not None
        q0 = np.asarray(first.msg.position)
        owner.send_settings({"mode": "lissajous", "lissajous_running": True})
        moved = owner.wait_for("/deskarm/joint_states/commanded",
                               lambda r: np.abs(np.asarray(r.msg.position) - q0).max() > 1e-3, timeout=WAIT)
        assert moved is not None, f"the controller's settings did not move the arm over TLS: {owner.session()}"
        owner.send_settings({"mode": "manual"})
    # the CA but no client certificate (and no password): mutual TLS refuses the handshake
    no_cert = security.Credential(ca_pem=cred.ca_pem, source="ca only")
    with pytest.raises(LinkError, match="refused this machine"):
        DeskClient(link(tls_desk.endpoint, no_cert, strict=True), heartbeat=False)
    tls_desk.wait_line("refused a connection", timeout=WAIT)


def test_network_without_pairing_is_refused_and_network_says_who_can_reach(tmp_path, monkeypatch):
    from app.cli_serve import build_parser, link_options

    monkeypatch.setenv("DESKARM_HOME", str(tmp_path))
    args = build_parser().parse_args(["--network"])
    with pytest.raises(ValueError, match="deskarm serve --pair"):
        link_options(args, server=True)
    args = build_parser().parse_args([])
    local = link_options(args, server=True)
    assert local.listen == ("tcp/127.0.0.1:7447",) and not local.scouting and local.security is None
    security.pair(hosts=("localhost",), tls=False)
    net = link_options(build_parser().parse_args(["--network"]), server=True)
    assert net.listen == ("tcp/0.0.0.0:7447",) and net.security is not None
    assert security.reachable_from(net.listen).startswith("every machine")
    keys = net.config_keys()
    assert keys["access_control"]["default_permission"] == "deny"
    assert keys["transport/auth/usrpwd"]["dictionary_file"].endswith("users.txt")
    client = link_options(build_parser().parse_args(["--client", "tcp/127.0.0.1:7447"]), server=False)
    assert client.listen == () and client.config_keys()["listen/endpoints"] == []


def test_pair_cli_prints_what_the_other_machine_needs(tmp_path, capsys, monkeypatch):
    from app.cli_serve import run

    monkeypatch.setenv("DESKARM_HOME", str(tmp_path))
    assert run("serve", ["--pair", "--pair-host", "192.168.1.20"]) == 0
    out = capsys.readouterr().out
    folder = tmp_path / "config" / "remote"
    assert str(folder / "controller.toml") in out and str(folder / "viewer.toml") in out
    assert "deskarm serve --network --tls" in out and "tls/192.168.1.20:7447" in out
    assert stat.S_IMODE(folder.stat().st_mode) == 0o700



def test_a_session_takes_the_credential_file_given_with_credentials(desk, tmp_path):
    from core.remote.security import CredentialError
    from core.session import DeskSession, SessionOptions

    with pytest.raises(ValueError, match="--credentials belongs to --remote"):
        SessionOptions(camera="sim", remote_credentials=str(desk.creds["files"]["viewer"])).validate()
    broken = tmp_path / "viewer.toml"
    broken.write_text("not = [toml")
    with pytest.raises(CredentialError):
        DeskSession.create(SessionOptions(camera="sim", remote=desk.endpoint, remote_credentials=str(broken)))
    session = DeskSession.create(SessionOptions(camera="sim", remote=desk.endpoint,
                                                remote_credentials=str(desk.creds["files"]["viewer"])))
    try:
        assert getattr(session.camera, "kind", "") == "remote" and session.calibration is not None
    finally:
        session.close()
