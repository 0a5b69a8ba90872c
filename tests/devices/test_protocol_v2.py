"""core.devices.protocol_v2 against the shared vectors (firmware/vectors.json) and random input.

The firmware's C tests read the same vectors, so the two implementations are held to the
same bytes.
"""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core.devices import protocol_v2 as p

VECTORS = json.loads(
    (Path(__file__).resolve().parents[2] / "firmware" / "vectors.json").read_text()
)


def _ids(items):
    return [v["name"] for v in items]


def crc16_bitwise(data: bytes) -> int:
    """CRC-16/CCITT-FALSE written out longhand, independent of binascii."""
    crc = 0xFFFF
    for b in data:
        crc ^= b << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
            crc &= 0xFFFF
    return crc


# ---- CRC ---------------------------------------------------------------------------


@pytest.mark.parametrize("vec", VECTORS["crc16_ccitt_false"], ids=_ids(VECTORS["crc16_ccitt_false"]))
def test_crc16_matches_the_vector(vec):
    data = bytes.fromhex(vec["data_hex"])
    assert p.crc16_ccitt(data) == int(vec["crc_hex"], 16)
    assert crc16_bitwise(data) == int(vec["crc_hex"], 16)


@given(st.binary(max_size=64))
def test_crc16_equals_a_longhand_implementation(data):
    assert p.crc16_ccitt(data) == crc16_bitwise(data)


# ---- v1 vectors, through a model of the board's v1 side -------------------------------


def board_v1_model(stream: bytes, joints: int) -> list[int]:
    """The board's documented v1 behaviour, as plainly as it can be written.

    Seed firmware rules, plus our one addition: F5 (v2 sync) clears the selection and the
    byte after a lone F5 is swallowed (PROTOCOL.md, "v1 and v2 on one line").
    """
    pulses = [0] * joints
    selected = None
    swallow = False
    for b in stream:
        if swallow:
            swallow = False
            assert b != p.SYNC, "this model covers v1 streams, not v2 frames"
            continue
        if b == p.SYNC:
            selected, swallow = None, True
        elif b in p.V1_SELECTORS:
            selected = b - 0xFB
        elif b <= 0xB4 and selected is not None and selected < joints:
            pulses[selected] = 900 + 10 * b
    return pulses


@pytest.mark.parametrize("vec", VECTORS["v1_streams"], ids=_ids(VECTORS["v1_streams"]))
def test_v1_stream_vector_matches_the_board_model(vec):
    stream = bytes.fromhex(vec["bytes_hex"])
    assert board_v1_model(stream, vec["joints"]) == vec["pulses_us"]
    # v1 bytes are nothing to a v2 decoder
    assert p.V2Decoder().feed(stream) == []


# ---- v2 frame vectors --------------------------------------------------------------


def frame_from_vector(vec) -> p.Frame:
    f, seq = vec["fields"], vec["seq"]
    kind = p.MsgType[vec["type"]]
    if kind is p.MsgType.SET_JOINTS:
        return p.SetJointsFrame(seq, tuple(f["angles_cdeg"]))
    if kind is p.MsgType.CONFIG:
        return p.ConfigFrame(
            seq, f["joint"], f["min_pulse_us"], f["max_pulse_us"], f["max_speed_dps"]
        )
    if kind is p.MsgType.STATUS:
        return p.StatusFrame(
            seq=seq,
            flags=p.Flag(f["flags"]),
            pulses_us=tuple(f["pulses_us"]),
            good_frames=f["good_frames"],
            bad_frames=f["bad_frames"],
            dropped_bytes=f["dropped_bytes"],
        )
    return {
        p.MsgType.ESTOP: p.EstopFrame,
        p.MsgType.ARM: p.ArmFrame,
        p.MsgType.PING: p.PingFrame,
    }[kind](seq)


@pytest.mark.parametrize("vec", VECTORS["v2_frames"], ids=_ids(VECTORS["v2_frames"]))
def test_v2_frame_vector_encodes_and_decodes(vec):
    wire = bytes.fromhex(vec["wire_hex"])
    expected = frame_from_vector(vec)
    assert p.MsgType[vec["type"]] == vec["type_code"]
    assert p.encode(expected) == wire
    assert p.encode_frame(vec["type_code"], vec["seq"], bytes.fromhex(vec["payload_hex"])) == wire
    assert p.decode_frame(wire) == expected
    body = bytes((len(bytes.fromhex(vec["payload_hex"])), vec["type_code"], vec["seq"]))
    assert p.crc16_ccitt(body + bytes.fromhex(vec["payload_hex"])) == int(vec["crc_hex"], 16)
    # on the wire: two syncs, an end byte, and never a raw v1 selector
    assert wire[:2] == bytes((p.SYNC, p.SYNC)) and wire[-1] == p.END
    assert not set(wire) & set(p.V1_SELECTORS)


def test_the_convenience_encoders_agree_with_the_vectors():
    by_name = {v["name"]: bytes.fromhex(v["wire_hex"]) for v in VECTORS["v2_frames"]}
    assert p.encode_set_joints(1, [90.0, 45.5, 120.0]) == by_name[
        "SET_JOINTS, the worked example: 90.00, 45.50, 120.00 deg"
    ]
    assert p.encode_set_joints_cdeg(2, [None, 0, 18000]) == by_name[
        "SET_JOINTS with null = keep for joint 1"
    ]
    assert p.encode_config(5, 0, 1000, 2000, 90) == by_name["CONFIG joint 0: 1000..2000 us, 90 deg/s"]
    assert p.encode_estop(7) == by_name["ESTOP"]
    assert p.encode_arm(8) == by_name["ARM"]
    assert p.encode_ping(9) == by_name["PING"]
    assert p.encode_status(9, 9, [1800, 1355, 2100], 3, 1, 12) == by_name[
        "STATUS: v2 mode, moving, 3 joints"
    ]


@pytest.mark.parametrize("vec", VECTORS["v2_rejected"], ids=_ids(VECTORS["v2_rejected"]))
def test_v2_rejected_vector_yields_no_frame_and_the_expected_counters(vec):
    dec = p.V2Decoder()
    assert dec.feed(bytes.fromhex(vec["wire_hex"])) == []
    assert (dec.good_frames, dec.bad_frames, dec.dropped_bytes) == (
        0,
        vec["bad_frames"],
        vec["dropped_bytes"],
    )
    with pytest.raises(ValueError, match="not exactly one valid v2 frame"):
        p.decode_frame(bytes.fromhex(vec["wire_hex"]))


@pytest.mark.parametrize("scenario", VECTORS["v2_scenarios"], ids=_ids(VECTORS["v2_scenarios"]))
def test_v2_scenario_frames_are_well_formed(scenario):
    """The scenarios run on the C side; here every frame in them must decode cleanly."""
    dec = p.V2Decoder()
    for step in scenario["steps"]:
        if "feed_hex" in step:
            dec.feed(bytes.fromhex(step["feed_hex"]))
        if "tx_hex" in step:
            reply = p.decode_frame(bytes.fromhex(step["tx_hex"]))
            assert isinstance(reply, p.StatusFrame)
            assert reply.n_joints == scenario["joints"]
    assert dec.bad_frames == 0


# ---- encoder argument checks ---------------------------------------------------------


def test_encoders_reject_out_of_range_values_naming_them():
    with pytest.raises(ValueError, match="joint 2: 180.5 deg out of range"):
        p.encode_set_joints(0, [90, 180.5])
    with pytest.raises(ValueError, match="9 joints"):
        p.encode_set_joints(0, [0] * 9)
    with pytest.raises(ValueError, match="seq 256"):
        p.encode_ping(256)
    with pytest.raises(ValueError, match="max_speed_dps 70000"):
        p.encode_config(0, 0, 900, 2700, 70000)
    with pytest.raises(ValueError, match="payload of 33 bytes"):
        p.encode_frame(p.MsgType.SET_JOINTS, 0, bytes(33))


def test_set_joints_rounds_degrees_to_centidegrees():
    frame = p.decode_frame(p.encode_set_joints(3, [0.004, 45.555, None, 180]))
    assert frame.angles_cdeg == (0, 4556, None, 18000)
    assert frame.angles_deg == (0.0, 45.56, None, 180.0)


# ---- random input ----------------------------------------------------------------------

seqs = st.integers(0, 255)
u16 = st.integers(0, 0xFFFF)
frames = st.one_of(
    st.builds(
        p.SetJointsFrame,
        seqs,
        st.lists(st.one_of(st.none(), st.integers(0, 0xFFFE)), min_size=1, max_size=8).map(tuple),
    ),
    st.builds(p.ConfigFrame, seqs, st.integers(0, 255), u16, u16, u16),
    st.builds(p.EstopFrame, seqs),
    st.builds(p.ArmFrame, seqs),
    st.builds(p.PingFrame, seqs),
    st.builds(
        p.StatusFrame,
        seq=seqs,
        flags=st.integers(0, 255).map(p.Flag),
        pulses_us=st.lists(u16, min_size=1, max_size=8).map(tuple),
        good_frames=u16,
        bad_frames=u16,
        dropped_bytes=u16,
    ),
)


def feed_in_chunks(dec: p.V2Decoder, data: bytes, cuts: list[int]) -> list[p.Frame]:
    out: list[p.Frame] = []
    start = 0
    for cut in sorted(c % (len(data) + 1) for c in cuts) + [len(data)]:
        out += dec.feed(data[start:cut])
        start = max(start, cut)
    return out


@given(frames)
def test_every_frame_round_trips(frame):
    wire = p.encode(frame)
    assert p.decode_frame(wire) == frame
    # inside the body only the escape byte itself may be one of the special bytes
    assert not set(wire[2:-1]) & (p.ESCAPED - {p.ESC})


@given(st.binary(max_size=2000), st.lists(st.integers(0, 2000), max_size=20))
def test_random_garbage_never_crashes_and_chunking_does_not_matter(garbage, cuts):
    whole = p.V2Decoder()
    frames_whole = whole.feed(garbage)
    chunked = p.V2Decoder()
    assert feed_in_chunks(chunked, garbage, cuts) == frames_whole
    assert (whole.good_frames, whole.bad_frames, whole.dropped_bytes) == (
        chunked.good_frames,
        chunked.bad_frames,
        chunked.dropped_bytes,
    )
    assert whole.good_frames == len(frames_whole)
    for frame in frames_whole:  # anything decoded really was in the input
        assert p.encode(frame)[2:] in garbage


# garbage biased toward the protocol's own bytes, which is where resync bugs hide
protocol_bytes = st.binary(max_size=60) | st.lists(
    st.sampled_from([p.SYNC, p.ESC, p.END, 0xFB, 0x00, 0x05, 0xD5, 0x20]), max_size=60
).map(bytes)


@given(protocol_bytes, frames, st.binary(max_size=20))
def test_a_valid_frame_embedded_in_garbage_is_recovered(before, frame, after):
    dec = p.V2Decoder()
    out = dec.feed(before + p.encode(frame) + after)
    assert frame in out


@settings(max_examples=300)
@given(frames, st.data())
def test_corrupting_any_single_byte_of_a_frame_makes_it_rejected(frame, data):
    wire = bytearray(p.encode(frame))
    pos = data.draw(st.integers(0, len(wire) - 1), label="position")
    value = data.draw(st.integers(0, 255).filter(lambda v: v != wire[pos]), label="value")
    wire[pos] = value
    dec = p.V2Decoder()
    assert dec.feed(bytes(wire)) == []
    # ...and the receiver is ready for the next frame straight away
    nxt = p.PingFrame(7)
    assert dec.feed(p.encode(nxt)) == [nxt]


@settings(max_examples=200)
@given(frames, st.data())
def test_dropping_any_single_byte_of_a_frame_makes_it_rejected(frame, data):
    wire = bytearray(p.encode(frame))
    del wire[data.draw(st.integers(0, len(wire) - 1), label="position")]
    assert p.V2Decoder().feed(bytes(wire)) == []


def test_exhaustively_every_single_byte_corruption_of_the_worked_example_is_rejected():
    wire = p.encode_set_joints(1, [90.0, 45.5, 120.0])
    for pos in range(len(wire)):
        for value in range(256):
            if value == wire[pos]:
                continue
            bad = wire[:pos] + bytes((value,)) + wire[pos + 1 :]
            assert p.V2Decoder().feed(bad) == [], (pos, value)


def test_decoder_reset_forgets_a_partial_frame():
    dec = p.V2Decoder()
    wire = p.encode_ping(1)
    assert dec.feed(wire[:4]) == []
    dec.reset()
    assert dec.feed(wire[2:]) == []  # the tail alone is garbage
    assert dec.feed(wire) == [p.PingFrame(1)]
