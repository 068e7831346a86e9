"""The aamgym configurations as typed dataclasses, and the check of a composed configuration.

``aamgym train`` and ``aamgym evaluate`` check the configuration Hydra composes from the
YAML files and the command line against these structured configs *before* anything starts
(no Ray, no episode, no run directory): every key must be one the dataclass declares, every
value of its declared type. The sections of ``config.yaml`` and ``evaluate.yaml`` are
declared here; ``algorithm.params`` is checked against the learner's own hyper-parameter
dataclass (:func:`rlbridge.agents.learner_config_class`: ``DDQNConfig``, ``D2MAVAConfig``)
and ``usecase.params`` against the use case's ``params_class`` (``CorridorParams``,
``ReachParams``, ...), field by field, so a field added to one of them is accepted and
checked with no edit here.

Problems are returned as lines naming the key, e.g.
``train.iterations=abc: expected an integer or null`` or
``algorithm.params.foo: unknown key; known: batch_size, double, ...``.
"""

from __future__ import annotations

import types
import typing
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, is_dataclass
from typing import Any, Literal, Union

# ---- the sections of rlbridge/conf/config.yaml and evaluate.yaml ----------------------------------


@dataclass
class AlgorithmSection:
    """``algorithm``: one file of ``conf/algorithm/``; ``params`` fit the learner's dataclass."""

    name: str = ""
    kind: str = ""  # a learner kind: d2mava | dqn
    label: str = ""
    params: dict[str, Any] = field(default_factory=dict)


@dataclass
class UsecaseSection:
    """``usecase``: one file of ``conf/usecase/``; ``params`` fit the use case's ``params_class``."""

    name: str = ""
    params: dict[str, Any] = field(default_factory=dict)


@dataclass
class TrainSection:
    """``train`` of ``config.yaml`` (the meaning of each key is commented there)."""

    iterations: int | None = None
    hours: float | None = None
    aircraft_states: int | None = None
    episodes_per_worker: int = 1
    checkpoint_every: int = 10
    best_window: int = 25
    baseline_episodes: int = 2
    resume: str | None = None
    torch_threads: int | Literal["auto"] = 1
    static_learner: bool | Literal["auto"] = "auto"
    mode: Literal["serial", "overlap"] = "serial"


@dataclass
class EnvSection:
    time_limit_s: float | None = None  # [s of sim time]
    dt: float = 0.05  # [s]


@dataclass
class EvalEnvSection:
    time_limit_s: float | None = None  # [s of sim time]; null: the training run's
    dt: float | None = None  # [s]; null: the training run's


@dataclass
class RaySection:
    address: str | None = None
    num_cpus: int | None = None
    cpus_per_worker: float = 1.0


@dataclass
class TrainConfig:
    """``aamgym train`` (``rlbridge/conf/config.yaml``)."""

    algorithm: AlgorithmSection
    usecase: UsecaseSection
    scenario: str = "nyc_train_100"
    workers: int | Literal["auto"] = 2
    backend: Literal["local", "zmq", "bluesky"] = "local"
    address: str | None = None  # backend=zmq: tcp://host:port
    timeout_s: float = 30.0  # backend=zmq: the longest wait for one reply [s]
    seed: int = 0
    device: str = "cpu"
    out_dir: str = "runs"
    metrics: list[str] = field(default_factory=list)
    train: TrainSection = field(default_factory=TrainSection)
    env: EnvSection = field(default_factory=EnvSection)
    ray: RaySection = field(default_factory=RaySection)


@dataclass
class EvaluateConfig:
    """``aamgym evaluate`` (``rlbridge/conf/evaluate.yaml``)."""

    usecase: UsecaseSection
    run: str | None = None
    policy: str | None = None  # pretrained:<name> or an exported policy folder
    baseline: str | None = None
    checkpoint: str = "best"
    scenario: str | None = None
    backend: Literal["local", "bluesky"] = "local"
    episodes: int = 100
    seed: int = 0
    workers: int = 2
    alt_noise_ft: float = 100.0
    alt_noise_lanes_ft: list[float] = field(default_factory=list)
    baselines: list[str] | None = None
    greedy: bool | None = None
    sampled_epsilon: float = 0.05  # epsilon of a value-based policy evaluated with greedy=false
    name: str | None = None
    metrics: list[str] = field(default_factory=list)
    video: bool = False
    video_speed: float = 60.0
    video_fps: float = 10.0
    device: str = "cpu"
    out_dir: str = "runs"
    env: EvalEnvSection = field(default_factory=EvalEnvSection)
    ray: RaySection = field(default_factory=RaySection)


SCHEMAS: dict[str, type] = {"config": TrainConfig, "evaluate": EvaluateConfig}

# ---- the check ---------------------------------------------------------------------------------------


def check_config(cfg: Mapping[str, Any], schema: type, params_classes: Mapping[str, type | None]) -> list[str]:
    """Every problem of a composed configuration (plain containers), one line each, naming the key.

    Args:
        cfg: the configuration as plain dicts and lists (``OmegaConf.to_container``).
        schema: its dataclass (:data:`SCHEMAS`).
        params_classes: the dataclass that a ``params`` section must fit, by section
            (``{"algorithm": DDQNConfig, "usecase": CorridorParams}``); None: not checked.
    """
    errors = check_mapping(cfg, schema, "")
    for section, params_class in params_classes.items():
        node = cfg.get(section)
        if params_class is not None and isinstance(node, Mapping) and isinstance(node.get("params"), Mapping):
            errors += check_mapping(node["params"], params_class, f"{section}.params.")
    return errors


def check_mapping(node: Mapping[str, Any], cls: type, prefix: str = "") -> list[str]:
    """The problems of ``node`` against the dataclass ``cls``: unknown keys and values of the wrong type."""
    hints = typing.get_type_hints(cls)
    names = [f.name for f in fields(cls)]
    errors = []
    for key, value in node.items():
        if key not in hints or key not in names:
            errors.append(f"{prefix}{key}: unknown key; known: {', '.join(sorted(names))}")
            continue
        errors += check_value(value, hints[key], f"{prefix}{key}")
    return errors


def check_value(value: Any, tp: Any, key: str) -> list[str]:
    """The problems of one value against a type annotation (nested dataclasses checked key by key)."""
    if is_dataclass(tp) and isinstance(tp, type):
        if isinstance(value, Mapping):
            return check_mapping(value, tp, f"{key}.")
        return [f"{key}={_show(value)}: expected a mapping of {', '.join(f.name for f in fields(tp))}"]
    if fits(value, tp):
        return []
    return [f"{key}={_show(value)}: expected {describe(tp)}"]


def fits(value: Any, tp: Any) -> bool:
    """Whether ``value`` (parsed YAML or a Hydra override) is of the annotated type.

    Integers are accepted where a float is declared and numbers where a string is (the
    YAML ``scenario: 100`` is the name "100"); a bool is never an integer. Annotations this
    check does not know are accepted.
    """
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if tp is Any:
        return True
    if tp is type(None):
        return value is None
    if origin in (Union, types.UnionType):
        return any(fits(value, a) for a in args)
    if origin is Literal:
        return any(value == a and type(value) is type(a) for a in args)
    if tp is bool:
        return isinstance(value, bool)
    if tp is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if tp is float:
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    if tp is str:
        return isinstance(value, (str, int, float)) and not isinstance(value, bool)
    if origin in (list, tuple, Sequence) or tp in (list, tuple):
        if not isinstance(value, (list, tuple)):
            return False
        if origin is tuple and args and not (len(args) == 2 and args[1] is Ellipsis):
            return len(value) == len(args) and all(fits(v, a) for v, a in zip(value, args))
        item = args[0] if args else Any
        return all(fits(v, item) for v in value)
    if origin in (dict, Mapping) or tp in (dict, Mapping):
        return isinstance(value, Mapping)
    if is_dataclass(tp):
        return isinstance(value, Mapping)
    return True


def describe(tp: Any) -> str:
    """An annotation in words: ``int | None`` -> "an integer or null"."""
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (Union, types.UnionType):
        return " or ".join(describe(a) for a in args)
    if origin is Literal:
        return "one of " + ", ".join(str(a) for a in args)
    if origin in (list, tuple, Sequence) or tp in (list, tuple):
        item = args[0] if args else Any
        return "a list" if item is Any else f"a list of {_plural(item)}"
    if origin in (dict, Mapping) or tp in (dict, Mapping) or is_dataclass(tp):
        return "a mapping"
    return {type(None): "null", bool: "true or false", int: "an integer", float: "a number",
            str: "a string"}.get(tp, str(tp))


def _plural(tp: Any) -> str:
    return {bool: "true/false", int: "integers", float: "numbers", str: "strings"}.get(tp, describe(tp))


def _show(value: Any) -> str:
    text = "null" if value is None else str(value).lower() if isinstance(value, bool) else str(value)
    return text if len(text) <= 60 else text[:57] + "..."


__all__ = ["SCHEMAS", "AlgorithmSection", "EvaluateConfig", "TrainConfig", "UsecaseSection", "check_config",
           "check_mapping", "check_value", "describe", "fits"]
