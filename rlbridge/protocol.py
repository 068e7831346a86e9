"""Wire format of the simulation server (``docs/protocol.md``): msgpack header + raw array frames.

A message is a list of ZeroMQ frames ``[header, buffer_0, buffer_1, ...]``.
The header is a msgpack map with ``v`` (protocol version), ``op`` (requests),
``id`` (request id, echoed in the reply) and payload fields. Every numpy array
in the payload is replaced by a descriptor ``{"__nd__": k, "dtype": name,
"shape": [...]}`` naming buffer frame ``k``, which holds the array's bytes,
C-contiguous and little-endian. Nothing is ever pickled: decoding can only
produce msgpack values (nil, bool, int, float, str, bytes, list, map with
string keys) and numpy arrays of the whitelisted dtypes.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import msgpack
import numpy as np

PROTOCOL_VERSION = 1
DEFAULT_MAX_MESSAGE_BYTES = 16 * 1024 * 1024
MAX_DEPTH = 32  # nesting of lists and maps in a header
ND_KEY = "__nd__"
DTYPES: dict[str, np.dtype] = {
    name: np.dtype(name).newbyteorder("<")
    for name in ("float32", "float64", "int64", "int32", "bool", "uint8", "int8")
}


_PLAIN = frozenset((str, int, float, bool, bytes, type(None)))  # msgpack scalars (exact types)


class ProtocolError(ValueError):
    """A message that does not follow the protocol; the text names the problem.

    ``code`` is the error code of the reply: ``protocol`` (malformed), ``version``
    or ``too_large``.
    """

    def __init__(self, message: str, code: str = "protocol"):
        super().__init__(message)
        self.code = code


def _dtype_name(arr: np.ndarray) -> str:
    name = arr.dtype.name
    if name not in DTYPES:
        raise ProtocolError(f"arrays of dtype {name} cannot travel; allowed: {', '.join(DTYPES)}")
    return name


def _pack_default(obj: Any) -> Any:
    """msgpack fallback for numpy scalars (they travel as plain numbers)."""
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"cannot encode a {type(obj).__name__}")


def _replace_arrays(value: Any, buffers: list[memoryview], depth: int) -> Any:
    if depth > MAX_DEPTH:
        raise ProtocolError(f"payload nested deeper than {MAX_DEPTH} levels")
    if isinstance(value, np.ndarray):
        name = _dtype_name(value)
        arr = value.astype(DTYPES[name], order="C", copy=False)
        buffers.append(memoryview(arr).cast("B") if arr.size else memoryview(b""))  # type: ignore[arg-type]
        return {ND_KEY: len(buffers) - 1, "dtype": name, "shape": list(arr.shape)}
    if isinstance(value, dict):
        out = {}
        for key, item in value.items():
            if not isinstance(key, str):
                raise ProtocolError(f"map keys must be strings, not {type(key).__name__}")
            if key == ND_KEY:
                raise ProtocolError(f"the key {ND_KEY!r} is reserved for array descriptors")
            out[key] = _replace_arrays(item, buffers, depth + 1)
        return out
    if isinstance(value, (list, tuple)):
        if all(type(item) in _PLAIN for item in value):  # e.g. a list of agent names: nothing to replace
            return list(value)
        return [_replace_arrays(item, buffers, depth + 1) for item in value]
    return value


def encode(message: dict[str, Any]) -> list[bytes | memoryview]:
    """Frames for ``message`` (a map whose values may contain numpy arrays)."""
    buffers: list[memoryview] = []
    header = _replace_arrays(message, buffers, 0)
    try:
        packed = msgpack.packb(header, default=_pack_default, use_bin_type=True)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ProtocolError(f"cannot encode message: {exc}") from None
    return [packed, *buffers]


def _frame_bytes(frame: Any) -> memoryview:
    view = memoryview(getattr(frame, "buffer", frame))  # zmq.Frame (copy=False), bytes or a view
    return view if view.format == "B" and view.ndim == 1 else view.cast("B")


def _check_shape(shape: Any) -> tuple[int, ...]:
    if not isinstance(shape, list) or len(shape) > MAX_DEPTH:
        raise ProtocolError("array shape must be a list of at most 32 non-negative integers")
    for dim in shape:
        if isinstance(dim, bool) or not isinstance(dim, int) or dim < 0:
            raise ProtocolError(f"array shape {shape!r}: dimensions must be non-negative integers")
    return tuple(shape)


class _Resolver:
    """Turns descriptors back into arrays, checking that each buffer is used once."""

    def __init__(self, buffers: Sequence[memoryview]):
        self.buffers = buffers
        self.used = [False] * len(buffers)

    def array(self, desc: dict[str, Any]) -> np.ndarray:
        if set(desc) != {ND_KEY, "dtype", "shape"}:
            raise ProtocolError(f"array descriptor must have exactly {ND_KEY}, dtype and shape, got {sorted(desc)}")
        k = desc[ND_KEY]
        if isinstance(k, bool) or not isinstance(k, int) or not 0 <= k < len(self.buffers):
            raise ProtocolError(f"array descriptor points at buffer {k!r}, but the message has "
                                f"{len(self.buffers)} buffer frame(s)")
        if self.used[k]:
            raise ProtocolError(f"buffer frame {k} is used by two arrays")
        self.used[k] = True
        name = desc["dtype"]
        if not isinstance(name, str) or name not in DTYPES:
            raise ProtocolError(f"array dtype {name!r} not allowed; allowed: {', '.join(DTYPES)}")
        dtype = DTYPES[name]
        shape = _check_shape(desc["shape"])
        count = math.prod(shape)
        buf = self.buffers[k]
        if count * dtype.itemsize != buf.nbytes:
            raise ProtocolError(f"buffer frame {k} has {buf.nbytes} bytes, but a {name} array of shape "
                                f"{list(shape)} needs {count * dtype.itemsize}")
        # A copy: the caller owns a writable array, as with the local backend.
        return np.frombuffer(buf, dtype=dtype, count=count).reshape(shape).astype(dtype.newbyteorder("="))

    def walk(self, value: Any, depth: int) -> Any:
        if depth > MAX_DEPTH:
            raise ProtocolError(f"header nested deeper than {MAX_DEPTH} levels")
        if isinstance(value, dict):
            if ND_KEY in value:
                return self.array(value)
            out = {}
            for key, item in value.items():
                if not isinstance(key, str):
                    raise ProtocolError(f"map keys must be strings, not {type(key).__name__}")
                out[key] = self.walk(item, depth + 1)
            return out
        if isinstance(value, list):
            if all(type(item) in _PLAIN for item in value):
                return value
            return [self.walk(item, depth + 1) for item in value]
        if value is None or isinstance(value, (bool, int, float, str, bytes)):
            return value
        raise ProtocolError(f"values of type {type(value).__name__} are not part of the protocol")


def _unpack_header(raw: memoryview) -> Any:
    try:
        return msgpack.unpackb(raw, raw=False, strict_map_key=True, use_list=True)
    except (msgpack.UnpackException, msgpack.ExtraData, ValueError, TypeError, RecursionError) as exc:
        raise ProtocolError(f"header is not valid msgpack ({type(exc).__name__}: {exc})") from None


def decode(frames: Sequence[Any], max_bytes: int = DEFAULT_MAX_MESSAGE_BYTES) -> dict[str, Any]:
    """The message carried by ``frames`` (bytes or zmq.Frame), validated; raises :class:`ProtocolError`.

    Checks the total size against ``max_bytes``, the header encoding, the
    protocol version, the types of ``v``/``op``/``id`` and every array
    descriptor. What the fields of each operation must be is checked by the
    receiver (:func:`check_fields`).
    """
    if not frames:
        raise ProtocolError("empty message")
    views = [_frame_bytes(fr) for fr in frames]
    total = sum(v.nbytes for v in views)
    if total > max_bytes:
        raise ProtocolError(f"message too large: {total} bytes, the limit is {max_bytes}", "too_large")
    header = _unpack_header(views[0])
    if not isinstance(header, dict):
        raise ProtocolError(f"header must be a map, not {type(header).__name__}")
    version = header.get("v")
    if type(version) is not int or version != PROTOCOL_VERSION:
        raise ProtocolError(f"protocol version {version!r} not supported; this end speaks version {PROTOCOL_VERSION}",
                            "version")
    msg_id = header.get("id")
    if msg_id is not None and (isinstance(msg_id, bool) or not isinstance(msg_id, int)):
        raise ProtocolError(f"id must be an integer, not {type(msg_id).__name__}")
    resolver = _Resolver(views[1:])
    message = resolver.walk(header, 0)
    unused = [k for k, used in enumerate(resolver.used) if not used]
    if unused:
        raise ProtocolError(f"buffer frame(s) {unused} not referenced by the header")
    return message


def peek_id(frames: Sequence[Any]) -> int | None:
    """Best-effort request id of a message that failed to decode (for the error reply)."""
    try:
        header = _unpack_header(_frame_bytes(frames[0])) if frames else None
    except (ProtocolError, TypeError, ValueError):
        return None
    msg_id = header.get("id") if isinstance(header, dict) else None
    return msg_id if isinstance(msg_id, int) and not isinstance(msg_id, bool) else None


# ---------------------------------------------------------------- field checks
_TYPE_NAMES = {str: "a string", int: "an integer", float: "a number", bool: "a boolean", list: "a list",
               dict: "a map", np.ndarray: "an array", type(None): "nil"}


def _matches(value: Any, kind: type) -> bool:
    if kind is float:
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    if kind is int:
        return isinstance(value, int) and not isinstance(value, bool)
    return isinstance(value, kind)


def check_fields(message: dict[str, Any], schema: dict[str, tuple[tuple[type, ...], bool]]) -> None:
    """Check a request's payload fields: ``schema`` maps name -> (allowed types, required).

    ``v``, ``op`` and ``id`` are always allowed; any other field not in the
    schema is an error, as is a missing required field or a value of another type.
    """
    op = message.get("op")
    for name, (kinds, required) in schema.items():
        if name not in message:
            if required:
                raise ProtocolError(f"{op}: missing field {name!r}")
            continue
        value = message[name]
        if not any(_matches(value, kind) for kind in kinds):
            wanted = " or ".join(_TYPE_NAMES.get(k, k.__name__) for k in kinds)
            raise ProtocolError(f"{op}: field {name!r} must be {wanted}, not {type(value).__name__}")
    extra = sorted(set(message) - set(schema) - {"v", "op", "id"})
    if extra:
        raise ProtocolError(f"{op}: unknown field(s) {', '.join(map(repr, extra))}")


def request(op: str, msg_id: int, **fields: Any) -> list[bytes | memoryview]:
    """Frames of a request."""
    return encode({"v": PROTOCOL_VERSION, "op": op, "id": msg_id, **fields})


def reply(msg_id: int | None, **fields: Any) -> list[bytes | memoryview]:
    """Frames of a successful reply."""
    return encode({"v": PROTOCOL_VERSION, "id": msg_id, "ok": True, **fields})


def error_reply(msg_id: int | None, code: str, message: str) -> list[bytes | memoryview]:
    """Frames of an error reply."""
    return encode({"v": PROTOCOL_VERSION, "id": msg_id, "ok": False, "code": code, "error": message})
