"""Episode values on the wire: step results, actions and traffic snapshots as protocol payloads (``docs/protocol.md``).

Both ends use these functions, so a :class:`~rlbridge.core.StepResult` or an
:class:`aamsim.snapshots.TrafficSnapshot` that crosses the wire comes back with
the same arrays, dtypes and values (float64 state arrays travel as raw buffers:
bit for bit).
"""

from __future__ import annotations

from dataclasses import fields as dataclass_fields
from typing import Any

import numpy as np

from aamsim.conflicts.separation import SeparationStandard
from aamsim.snapshots import FIELD_MEANINGS, TrafficSnapshot
from rlbridge.core import StepResult
from rlbridge.protocol import ProtocolError
from rlbridge.usecases.protocol import INFO_DTYPES, Observations

_ARRAYS = {"rewards": np.float64, "terminated": np.bool_, "truncated": np.bool_}
_INT_KINDS = "iu"
_INFO_DTYPES = tuple(np.dtype(d) for d in INFO_DTYPES)


def step_result_to_payload(result: StepResult) -> dict[str, Any]:
    obs: Any = result.obs.parts if result.obs.parts is not None else result.obs.flat
    return {
        "agents": list(result.agents), "obs": obs, "rewards": result.rewards, "terminated": result.terminated,
        "truncated": result.truncated, "alive": list(result.alive), "simt": float(result.simt),
        "done": bool(result.done), "info": dict(result.info), "agent_info": dict(result.agent_info),
        "discovered": list(result.discovered),
    }


def _str_list(payload: dict[str, Any], name: str) -> list[str]:
    value = payload.get(name)
    if not isinstance(value, list) or not all(isinstance(a, str) for a in value):
        raise ProtocolError(f"reply field {name!r} must be a list of strings")
    return value


def step_result_from_payload(payload: dict[str, Any]) -> StepResult:
    """Rebuild a step result from a reply, checking every field."""
    agents = _str_list(payload, "agents")
    n = len(agents)
    arrays: dict[str, np.ndarray] = {}
    for name, dtype in _ARRAYS.items():
        arr = payload.get(name)
        if not isinstance(arr, np.ndarray) or arr.dtype != dtype or arr.shape != (n,):
            raise ProtocolError(f"reply field {name!r} must be a {np.dtype(dtype).name} array of {n} values")
        arrays[name] = arr
    obs = payload.get("obs")
    if isinstance(obs, np.ndarray) and obs.ndim:
        observations = Observations(flat=obs)
    elif isinstance(obs, dict) and obs and all(isinstance(v, np.ndarray) and v.ndim for v in obs.values()):
        observations = Observations(parts=obs)
    else:
        raise ProtocolError("reply field 'obs' must be an array or a map of arrays")
    if len(observations) != n:
        raise ProtocolError(f"reply field 'obs' has {len(observations)} rows for {n} agents")
    simt, done, info = payload.get("simt"), payload.get("done"), payload.get("info")
    if not isinstance(simt, float) or not isinstance(done, bool) or not isinstance(info, dict):
        raise ProtocolError("reply fields simt (number), done (boolean) and info (map) are required")
    return StepResult(agents, observations, arrays["rewards"], arrays["terminated"], arrays["truncated"],
                      _str_list(payload, "alive"), simt, done, info, _agent_info(payload, n),
                      _str_list(payload, "discovered") if "discovered" in payload else [])


def _agent_info(payload: dict[str, Any], n: int) -> dict[str, np.ndarray]:
    """The use case's per-agent info columns: a map name -> bool, int64 or float64 array of n values."""
    value = payload.get("agent_info", {})
    if not isinstance(value, dict):
        raise ProtocolError("reply field 'agent_info' must be a map of arrays")
    for name, col in value.items():
        if not isinstance(name, str) or not isinstance(col, np.ndarray) or col.shape != (n,) \
                or col.dtype not in _INFO_DTYPES:
            raise ProtocolError(f"reply field agent_info[{name!r}] must be a bool, int64 or float64 array of "
                                f"{n} values")
    return dict(value)


def actions_to_payload(actions: dict[str, Any]) -> dict[str, Any]:
    """Integer actions travel as ``agents`` + one int64 array; anything else as a map."""
    agents = list(actions)
    values = list(actions.values())
    if all(isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_)) for v in values):
        return {"agents": agents, "actions": np.array(values, dtype=np.int64).reshape(len(values))}
    out: dict[str, Any] = {}
    for agent, value in actions.items():
        if isinstance(value, np.generic):
            value = value.item()
        out[agent] = value
    return {"actions": out}


def actions_from_payload(payload: dict[str, Any]) -> dict[str, Any]:
    """The actions map of a ``step`` request (already type-checked at the top level)."""
    actions = payload.get("actions", {})
    agents = payload.get("agents")
    if agents is None:
        if not isinstance(actions, dict):
            raise ProtocolError("step: 'actions' must be a map agent -> action, or an array with 'agents'")
        for agent, value in actions.items():
            if isinstance(value, (bool, str, bytes, dict)) or value is None:
                raise ProtocolError(f"step: action of {agent!r} must be a number, a list or an array, "
                                    f"not {type(value).__name__}")
        return dict(actions)
    if not isinstance(agents, list) or not all(isinstance(a, str) for a in agents):
        raise ProtocolError("step: 'agents' must be a list of strings")
    if not isinstance(actions, np.ndarray) or actions.ndim < 1 or actions.shape[0] != len(agents):
        raise ProtocolError(f"step: with 'agents', 'actions' must be an array with {len(agents)} rows")
    if len(set(agents)) != len(agents):
        raise ProtocolError("step: 'agents' lists an agent twice")
    if actions.ndim == 1 and actions.dtype.kind in _INT_KINDS:
        return dict(zip(agents, actions.tolist()))
    return {a: actions[k] for k, a in enumerate(agents)}


def snapshot_fields_from_request(value: Any) -> tuple[str, ...] | None:
    """The traffic fields a ``state`` request asks for (None: the default set); unknown names are an error."""
    if value is None:
        return None
    if not isinstance(value, list) or not all(isinstance(x, str) for x in value):
        raise ProtocolError("state: 'fields' must be a list of strings")
    unknown = [x for x in value if x not in FIELD_MEANINGS]
    if unknown:
        raise ProtocolError(f"state: unknown traffic field(s) {', '.join(map(repr, unknown))}; "
                            f"known: {', '.join(FIELD_MEANINGS)}")
    if len(set(value)) != len(value):
        raise ProtocolError("state: 'fields' names a field twice")
    return tuple(value)


def snapshot_to_payload(snap: TrafficSnapshot) -> dict[str, Any]:
    """``simt``, ``ids``, ``fields`` and one float64 array per field (SI units)."""
    out: dict[str, Any] = {"simt": float(snap.simt), "ids": list(snap.ids), "fields": list(snap.fields)}
    for k, name in enumerate(snap.fields):
        out[name] = np.ascontiguousarray(snap.values[k], dtype=np.float64)
    if snap.separation is not None:
        out["separation"] = {name: (bool if name.endswith("_sphere") else float)(getattr(snap.separation, name))
                             for name in SEPARATION_KEYS}
    return out


SEPARATION_KEYS = tuple(f.name for f in dataclass_fields(SeparationStandard))


def _separation(value: Any) -> SeparationStandard | None:
    """The optional ``separation`` of a ``state`` reply: the six fields of a separation standard."""
    if value is None:
        return None
    if not isinstance(value, dict) or set(value) != set(SEPARATION_KEYS):
        raise ProtocolError(f"reply field 'separation' must be a map with the keys {', '.join(SEPARATION_KEYS)}")
    for name in SEPARATION_KEYS:
        want = bool if name.endswith("_sphere") else float
        if type(value[name]) is not want:
            raise ProtocolError(f"reply field 'separation': {name} must be a {want.__name__}, "
                                f"not {type(value[name]).__name__}")
    try:
        return SeparationStandard(**value)
    except ValueError as exc:
        raise ProtocolError(f"reply field 'separation': {exc}") from None


def snapshot_from_payload(payload: dict[str, Any]) -> TrafficSnapshot:
    """Rebuild a traffic snapshot from a ``state`` reply, checking every field (read-only values)."""
    ids = _str_list(payload, "ids")
    fields = _str_list(payload, "fields")
    simt = payload.get("simt")
    if not isinstance(simt, float):
        raise ProtocolError("reply field 'simt' must be a number")
    n = len(ids)
    rows = []
    for name in fields:
        arr = payload.get(name)
        if name not in FIELD_MEANINGS or not isinstance(arr, np.ndarray) or arr.dtype != np.float64 \
                or arr.shape != (n,):
            raise ProtocolError(f"reply field {name!r} must be a known traffic field with a float64 array of "
                                f"{n} values")
        rows.append(arr)
    values = np.stack(rows) if rows else np.zeros((0, n))
    values.flags.writeable = False
    return TrafficSnapshot(simt, tuple(ids), tuple(fields), values, _separation(payload.get("separation")))
