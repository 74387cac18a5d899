"""The live protocol: frames and fused frames survive encoding; every malformed message is
rejected with its reason."""

import msgpack
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fusion.errors import BadInputError
from fusion.live.protocol import (
    VERSION,
    CameraFrame,
    Endpoint,
    FusedFrame,
    MessageType,
    ProtocolError,
    Reject,
    decode_client_message,
    decode_fused,
    encode_bye,
    encode_frame,
    encode_fused,
    unpack,
)
from fusion.topology import K4ABT, KINECT_V2


def _frame(seed=0, topology=KINECT_V2, t=1.25):
    rng = np.random.default_rng(seed)
    J = topology.n_joints
    p = rng.normal(size=(J, 3))
    s = rng.integers(0, 4, J).astype(np.int8)
    p[s == 0] = np.nan
    return CameraFrame("cam-1", 7, t, topology, p, s)


@given(seed=st.integers(0, 2**32 - 1), t=st.floats(-1e6, 1e6), k4=st.booleans())
def test_a_frame_decodes_to_itself(seed, t, k4):
    frame = _frame(seed, K4ABT if k4 else KINECT_V2, t)
    back = decode_client_message(encode_frame(frame))
    assert (back.sensor, back.seq, back.timestamp, back.topology) == ("cam-1", 7, t, frame.topology)
    assert np.array_equal(back.positions, frame.positions, equal_nan=True)
    assert np.array_equal(back.states, frame.states) and back.positions.shape == (frame.topology.n_joints, 3)


def test_bye_and_token():
    assert decode_client_message(encode_bye("cam2", token="s3cret"), token="s3cret") == "cam2"
    with pytest.raises(ProtocolError) as err:
        decode_client_message(encode_frame(_frame()), token="s3cret")
    assert err.value.reason is Reject.TOKEN
    assert decode_client_message(encode_frame(_frame(), token="s3cret"), token="s3cret").sensor == "cam-1"


def _body(**change):
    body = msgpack.unpackb(encode_frame(_frame()), raw=False)
    body.update(change)
    return msgpack.packb({k: v for k, v in body.items() if v is not None}, use_bin_type=True)


@pytest.mark.parametrize("data, reason", [
    (b"\xc1\xc1garbage", Reject.UNDECODABLE),
    (msgpack.packb([1, 2, 3]), Reject.UNDECODABLE),
    (_body(v=VERSION + 1), Reject.VERSION),
    (_body(v=None), Reject.VERSION),
    (_body(type="fused"), Reject.FIELDS),
    (_body(seq="seven"), Reject.FIELDS),
    (_body(t=None), Reject.FIELDS),
    (_body(t=float("nan")), Reject.FIELDS),
    (_body(sensor="cam 1/../x"), Reject.FIELDS),
    (_body(topology="openpose"), Reject.TOPOLOGY),
    (_body(positions=b"\x00" * 10), Reject.ARRAYS),
    (_body(states=b"\x09" * 25), Reject.ARRAYS),
    (_body(positions=np.full((25, 3), np.inf).tobytes()), Reject.ARRAYS),
])
def test_malformed_messages_are_rejected_with_their_reason(data, reason):
    with pytest.raises(ProtocolError) as err:
        decode_client_message(data)
    assert err.value.reason is reason
    assert isinstance(err.value, BadInputError)


def test_oversized_messages_are_rejected_before_decoding():
    with pytest.raises(ProtocolError) as err:
        decode_client_message(b"\x00" * 2000, max_bytes=1000)
    assert err.value.reason is Reject.OVERSIZED


def test_a_frame_normalises_absent_joints():
    p = np.zeros((25, 3))
    p[3] = np.nan
    frame = CameraFrame("c", 0, 0.0, KINECT_V2, p, np.full(25, 2))
    assert frame.states[3] == 0 and frame.states.dtype == np.int8
    with pytest.raises(ProtocolError):
        CameraFrame("c", 0, 0.0, KINECT_V2, np.zeros((24, 3)), np.full(24, 2))


def test_fused_frames_decode_to_themselves():
    rng = np.random.default_rng(3)
    frame = FusedFrame(12, 3.5, rng.normal(size=(25, 3)), np.full(25, 2, np.int8), np.full(25, 3, np.int8),
                       ("cam1", "cam2"), False, 0.0)
    body = unpack(encode_fused(frame, KINECT_V2))
    assert MessageType(body["type"]) is MessageType.FUSED
    back, topology = decode_fused(body)
    assert topology == KINECT_V2 and (back.index, back.time, back.cameras, back.complete) == (12, 3.5, ("cam1", "cam2"), False)
    assert np.array_equal(back.positions, frame.positions)
    with pytest.raises(ProtocolError):
        decode_fused({"v": VERSION, "type": "fused", "index": 1})


def test_endpoints():
    e = Endpoint.parse("127.0.0.1:5570")
    assert e.loopback and e.frames_url() == "tcp://127.0.0.1:5570" and e.publish_url() == "tcp://127.0.0.1:5571"
    assert Endpoint.parse("localhost:1").loopback and not Endpoint.parse("192.168.1.20:5570").loopback
    for bad in ("5570", "host:", "127.0.0.1:x", "127.0.0.1:65535"):
        with pytest.raises(BadInputError):
            Endpoint.parse(bad)
