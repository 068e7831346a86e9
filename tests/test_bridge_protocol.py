"""The bridge's wire format: round trips (Hypothesis) and strict rejection of bad frames."""

from __future__ import annotations

import msgpack
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from rlbridge.core import StepResult
from rlbridge.protocol import DTYPES, PROTOCOL_VERSION, ProtocolError, check_fields, decode, encode, peek_id
from rlbridge.usecases.registry import Observations
from rlbridge.wire import actions_from_payload, actions_to_payload, step_result_from_payload, step_result_to_payload

arrays = st.sampled_from(sorted(DTYPES)).flatmap(
    lambda name: hnp.arrays(np.dtype(name), hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=5)))
scalars = st.none() | st.booleans() | st.integers(-2**63, 2**64 - 1) | st.floats(allow_nan=False) | st.text(max_size=8) \
    | st.binary(max_size=8)
keys = st.text(max_size=6).filter(lambda k: k != "__nd__")
payloads = st.recursive(scalars | arrays, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(keys, inner, max_size=4),
                        max_leaves=12)


def same(a, b) -> bool:
    """Equality that compares arrays by dtype, shape and bytes."""
    if isinstance(a, np.ndarray):
        return isinstance(b, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    return type(a) is type(b) and a == b


@settings(max_examples=200, deadline=None)
@given(payload=st.dictionaries(keys.filter(lambda k: k not in ("v", "id")), payloads, max_size=5))
def test_decode_inverts_encode(payload):
    message = {"v": PROTOCOL_VERSION, "op": "x", "id": 7, **payload}
    frames = encode(message)
    assert same(decode(frames), message)
    assert same(decode([bytes(f) for f in frames]), message)  # as received from the wire


@given(arr=arrays)
def test_arrays_come_back_writable_and_native(arr):
    out = decode(encode({"v": PROTOCOL_VERSION, "a": arr}))["a"]
    assert out.flags.writeable and out.flags.c_contiguous and out.dtype.isnative


def test_non_contiguous_big_endian_and_numpy_scalars_are_normalised():
    a = np.arange(12.0).reshape(3, 4)[:, ::2]
    b = np.arange(3, dtype=">i4")
    out = decode(encode({"v": 1, "a": a, "b": b, "c": np.int64(3), "d": np.float32(0.5), "e": (1, 2)}))
    assert np.array_equal(out["a"], a) and out["b"].dtype == np.int32 and np.array_equal(out["b"], b)
    assert out["c"] == 3 and type(out["c"]) is int and out["d"] == 0.5 and out["e"] == [1, 2]


def test_encode_refuses_what_cannot_travel():
    for bad in ({"a": np.zeros(2, np.complex64)}, {"a": np.array(["x"])}, {"a": object()}, {1: 2},
                {"__nd__": 0}):
        with pytest.raises(ProtocolError):
            encode(bad)


DEEP: list = [1]
for _ in range(40):
    DEEP = [DEEP]


def header(**fields) -> bytes:
    return msgpack.packb({"v": PROTOCOL_VERSION, "op": "x", "id": 1, **fields})


@pytest.mark.parametrize("frames, fragment", [
    ([], "empty message"),
    ([b""], "not valid msgpack"),
    ([b"\xc1garbage"], "not valid msgpack"),
    ([header()[:-2]], "not valid msgpack"),                                   # truncated header
    ([header() + b"x"], "not valid msgpack"),                                 # trailing bytes
    ([msgpack.packb([1, 2])], "header must be a map"),
    ([msgpack.packb({"op": "x"})], "protocol version None"),
    ([msgpack.packb({"v": 99, "op": "x"})], "protocol version 99"),
    ([msgpack.packb({"v": True, "op": "x"})], "protocol version True"),
    ([msgpack.packb({"v": 1, "id": "seven"})], "id must be an integer"),
    ([msgpack.packb({"v": 1, 5: 1}, strict_types=False)], "not valid msgpack"),  # integer map key
    ([msgpack.packb({"v": 1, b"k": 1})], "map keys must be strings"),
    ([msgpack.packb({"v": 1, "t": msgpack.ExtType(5, b"x")})], "not part of the protocol"),
    ([header(a={"__nd__": 0, "dtype": "float32", "shape": [2]})], "has 0 buffer frame"),  # truncated message
    ([header(a={"__nd__": 0, "dtype": "float32", "shape": [2]}), b"\0" * 7], "needs 8"),  # truncated buffer
    ([header(a={"__nd__": 0, "dtype": "object", "shape": [1]}), b"\0" * 8], "dtype 'object' not allowed"),
    ([header(a={"__nd__": 0, "dtype": "float32", "shape": [-1]}), b""], "non-negative"),
    ([header(a={"__nd__": 0, "dtype": "float32", "shape": "2"}), b""], "shape must be a list"),
    ([header(a={"__nd__": 0, "dtype": "float32"}), b""], "exactly __nd__"),
    ([header(a={"__nd__": True, "dtype": "uint8", "shape": [0]}), b""], "points at buffer True"),
    ([header(a={"__nd__": 0, "dtype": "uint8", "shape": [0]}, b={"__nd__": 0, "dtype": "uint8", "shape": [0]}),
      b""], "used by two arrays"),
    ([header(), b"stray"], "not referenced"),
    ([header(a=DEEP)], "nested deeper"),
])
def test_bad_frames_raise_protocol_error_naming_the_problem(frames, fragment):
    with pytest.raises(ProtocolError, match=None) as info:
        decode(frames)
    assert fragment in str(info.value)


def test_size_limit_and_error_codes():
    frames = encode({"v": 1, "a": np.zeros(1000)})
    assert decode(frames, max_bytes=9000)["a"].shape == (1000,)
    with pytest.raises(ProtocolError) as info:
        decode(frames, max_bytes=7999)
    assert info.value.code == "too_large" and "limit is 7999" in str(info.value)
    with pytest.raises(ProtocolError) as info:
        decode([msgpack.packb({"v": 2})])
    assert info.value.code == "version"
    assert peek_id([msgpack.packb({"v": 2, "id": 41})]) == 41 and peek_id([b"\xc1"]) is None


@given(st.binary(max_size=64), st.lists(st.binary(max_size=16), max_size=3))
def test_random_bytes_raise_only_protocol_error(head, rest):
    try:
        decode([head, *rest])
    except ProtocolError:
        pass


def test_check_fields():
    schema = {"text": ((str,), True), "dt": ((float,), False)}
    check_fields({"v": 1, "op": "stack", "id": 1, "text": "ECHO", "dt": 1}, schema)
    for message, fragment in (({"op": "stack"}, "missing field 'text'"), ({"op": "stack", "text": 3}, "must be a string"),
                              ({"op": "stack", "text": "", "dt": True}, "must be a number"),
                              ({"op": "stack", "text": "", "x": 1}, "unknown field(s) 'x'")):
        with pytest.raises(ProtocolError, match=None) as info:
            check_fields(message, schema)
        assert fragment in str(info.value)


def test_step_results_and_actions_cross_the_wire_unchanged():
    n = 3
    flat = StepResult(["A", "B", "C"], Observations(flat=np.random.default_rng(1).random((n, 5), np.float32)),
                      np.array([-0.1, 0.0, 1e-300]), np.array([0, 1, 0], bool), np.zeros(n, bool), ["A", "C"], 12.5,
                      False, {"note": "x"}, {"nmac": np.ones(n, bool), "dist_m": np.array([1.0, 2.0, np.inf])}, ["C"])
    parts = StepResult([], Observations(parts={"own": np.zeros((0, 2), np.float32), "mask": np.zeros((0, 4), np.float32)}),
                       np.zeros(0), np.zeros(0, bool), np.zeros(0, bool), [], 0.0, True)
    for result in (flat, parts):
        back = step_result_from_payload(decode(encode({"v": 1, **step_result_to_payload(result)})))
        assert same(back.__dict__ | {"obs": back.obs.__dict__}, result.__dict__ | {"obs": result.obs.__dict__})
    actions = {"A": np.int64(2), "B": 0}
    assert actions_from_payload(decode(encode({"v": 1, **actions_to_payload(actions)}))) == {"A": 2, "B": 0}
    mixed = {"A": 0.5, "B": np.array([1.0, 2.0])}
    back = actions_from_payload(decode(encode({"v": 1, **actions_to_payload(mixed)})))
    assert back["A"] == 0.5 and np.array_equal(back["B"], mixed["B"])
    with pytest.raises(ProtocolError):
        step_result_from_payload({"agents": ["A"], "obs": np.zeros((2, 3), np.float32)})
    for bad in ({"agents": ["A"], "actions": np.zeros(2, np.int64)}, {"agents": ["A", "A"], "actions": np.zeros(2, np.int64)},
                {"actions": {"A": "left"}}, {"agents": [1], "actions": np.zeros(1, np.int64)}):
        with pytest.raises(ProtocolError):
            actions_from_payload(bad)
