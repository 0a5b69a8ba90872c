"""The desk across machines, on loopback: `deskarm serve` in a subprocess, a DeskClient here.

No sleeps: every wait is a condition with a timeout (the client's ``wait_for``), paced by the
server's own camera frames. Skipped only when Zenoh cannot open a loopback session here.
"""
from __future__ import annotations

import math
import threading
from pathlib import Path

import numpy as np
import pytest

from core.remote import ros
from serving import served_desk, zenoh_loopback_problem
from core.remote.link import LinkOptions

ROOT = Path(__file__).resolve().parents[2]
LEFT = ros.IMAGE_TOPICS["left"]
COMMANDED = "/deskarm/joint_states/commanded"
WAIT = 10.0  # s: generous for a loaded 2-core machine; a pass takes milliseconds


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """`deskarm serve --camera sim --scenario wander` on a free loopback port (scouting off); its endpoint."""
    problem = zenoh_loopback_problem()
    if problem:
        pytest.skip(problem)
    with served_desk(tmp_path_factory.mktemp("serve_home"), "wander") as endpoint:
        yield endpoint


def client_for(endpoint, heartbeat=True):
    from core.remote.client import DeskClient

    return DeskClient(LinkOptions(connect=(endpoint,), scouting=False), heartbeat=heartbeat)


def after_frames(client, n: int) -> None:
    """Wait for ``n`` more camera frames from the server (its clock paces the test)."""
    start = client.count(LEFT)
    assert client.wait_for(LEFT, timeout=WAIT, after=start + n - 1) is not None, f"fewer than {n} frames arrived"


def moving(client) -> tuple[float, ...]:
    """Wait until the commanded joints change; the latest command."""
    first = client.wait_for(COMMANDED, timeout=WAIT)
    assert first is not None, "no commanded joint state"
    q0 = np.asarray(first.msg.position)
    r = client.wait_for(COMMANDED, lambda r: np.abs(np.asarray(r.msg.position) - q0).max() > 1e-4, timeout=WAIT)
    assert r is not None, "the commanded joints do not move"
    return tuple(r.msg.position)


def session_where(client, predicate, what: str) -> dict:
    r = client.wait_for("/deskarm/session", lambda r: predicate(__import__("json").loads(r.msg.data)), timeout=WAIT)
    assert r is not None, f"the server never reported {what}; last: {client.session()}"
    return client.session()


def test_frames_markers_and_calibration_arrive_decoded(server):
    with client_for(server) as client:
        r = client.wait_for(LEFT, timeout=WAIT)
        assert r is not None, "no left image within 10 s"
        assert r.msg.format == "jpeg" and r.msg.header.frame_id == "camera_left"
        image = client.image("left")
        info = client.wait_for("/deskarm/camera/left/camera_info", timeout=WAIT).msg
        assert image is not None and image.shape == (info.height, info.width, 3)
        assert info.k[0] > 100 and info.k[8] == 1.0 and len(info.p) == 12
        assert r.attachment is not None and r.attachment.seq > 0 and len(r.attachment.gid) == 16
        # the capture stamp is in the past of the receive time (same clock on loopback)
        assert 0 <= r.received_wall - ros.stamp_s(r.msg.header.stamp) < 5.0
        m = client.wait_for("/deskarm/markers", lambda r: bool(ros.markers_of(r.msg)), timeout=WAIT)
        assert m is not None, "no marker found in 10 s of the simulated desk"
        for marker_id, p in ros.markers_of(m.msg).items():
            assert marker_id >= 0 and all(math.isfinite(v) for v in p)
            assert 0.0 < np.linalg.norm(p) < 1.0, f"marker {marker_id} at {p} m: not on the desk"
        assert m.msg.markers[0].header.frame_id == "robot_base"
        tf = client.wait_for("/tf_static", timeout=WAIT).msg
        assert {(t.header.frame_id, t.child_frame_id) for t in tf.transforms} == {
            ("robot_base", "camera_left"), ("camera_left", "camera_right")}


def test_keys_carry_the_rihs01_type_hash_rmw_zenoh_expects(server):
    """A subscriber on the exact rmw_zenoh key (domain 0, mangled type, RIHS01 hash) gets the data."""
    from core.remote.link import open_session

    key = ros.key_expr(COMMANDED)
    assert key == ("0/deskarm/joint_states/commanded/sensor_msgs::msg::dds_::JointState_/"
                   "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e")
    got = threading.Event()
    payloads = []

    def on_sample(sample):
        payloads.append((str(sample.key_expr), sample.payload.to_bytes(), sample.attachment.to_bytes()))
        got.set()

    session = open_session(LinkOptions(connect=(server,), scouting=False))
    try:
        session.declare_subscriber(key, on_sample)
        with client_for(server) as client:  # its heartbeat keeps the arm un-paused
            client.send_settings({"mode": "lissajous", "lissajous_running": True})
            assert got.wait(WAIT), f"nothing on {key}"
    finally:
        session.close()
    k, payload, attachment = payloads[0]
    assert k == key
    assert payload[:4] == b"\x00\x01\x00\x00"  # CDR little-endian encapsulation header
    assert len(ros.deserialize(payload, "sensor_msgs/msg/JointState").position) == 3
    assert len(attachment) == ros.ATTACHMENT_SIZE


def test_estop_from_the_client_stops_the_arm_and_echoes(server):
    with client_for(server) as client:
        assert client.rearm(timeout=WAIT), f"no re-arm: {client.session()}"  # a clean start whatever ran before
        client.send_settings({"mode": "lissajous", "lissajous_running": True})
        moving(client)
        round_trip = client.estop_round_trip(timeout=WAIT)
        assert round_trip is not None, "no /deskarm/estop echo"
        status = session_where(client, lambda s: s["estopped"], "the e-stop")
        assert status["estopped"] is True
        after_frames(client, 3)
        held = client.joints("commanded")
        count = client.count(COMMANDED)
        after_frames(client, 15)
        assert client.joints("commanded") == held, "the commanded joints moved after the e-stop"
        assert client.count(COMMANDED) == count, "commands were still sent after the e-stop"
        # one re-arm message is refused; held, it re-arms and the arm moves again (so the hold
        # above was the e-stop's doing)
        client.send_estop(False)
        r = client.wait_for("/deskarm/session", lambda r: any("re-arm is held" in t for t in
                                                              __import__("json").loads(r.msg.data)["refused"]), timeout=WAIT)
        assert r is not None and client.session()["estopped"] is True, client.session()
        assert client.rearm(timeout=WAIT), f"the held re-arm did not re-arm: {client.session()}"
        session_where(client, lambda s: not s["estopped"], "re-armed")
        moving(client)


def test_a_dropped_link_pauses_the_arm_until_heartbeats_return(server):
    with client_for(server) as client, client_for(server, heartbeat=False) as observer:
        assert client.rearm(timeout=WAIT), client.session()
        client.send_settings({"mode": "lissajous", "lissajous_running": True})
        session_where(client, lambda s: s["link"] == "ok" and not s["paused"], "a live link")
        moving(client)
        client.stop_heartbeat()  # the link drops
        status = session_where(observer, lambda s: "remote link lost" in s["paused_by"], "the pause")
        assert status["link"] == "lost" and status["paused"] is True
        after_frames(observer, 3)
        held = observer.joints("commanded")
        count = observer.count(COMMANDED)
        after_frames(observer, 15)
        assert observer.joints("commanded") == held, "the arm kept moving with the link down"
        assert observer.count(COMMANDED) > count, "a pause holds the last command (it keeps being sent)"
        client.start_heartbeat()  # the link is back
        session_where(observer, lambda s: s["link"] == "ok" and not s["paused"], "the link back")
        moving(observer)
        client.close()  # a client that goes away is a dropped link too
        session_where(observer, lambda s: "remote link lost" in s["paused_by"], "the pause after close")


def test_topics_and_types_are_the_recordings():
    """The served topics are the recordings' contract (core.record.topics), type for type."""
    from core.record import topics as recorded

    for topic, msgtype in recorded.TOPICS.items():
        if topic in ros.TOPICS:
            assert ros.TOPICS[topic] == msgtype, topic
    missing = set(ros.TOPICS) - set(recorded.TOPICS)
    assert not missing, f"served but not recorded: {missing}"
