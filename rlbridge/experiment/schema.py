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
from dataclasses import MISSING, dataclass, field, fields, is_dataclass
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
    """``train`` of ``aamgym train``: the training loop's budget, checkpoints and learner threads."""

    iterations: int | None = None  # training iterations; one iteration = workers x episodes_per_worker episodes
    hours: float | None = None  # wall-clock budget [h]; with neither set, 100 iterations
    aircraft_states: int | None = None  # budget of aircraft-states: no iteration starts once this many were collected
    episodes_per_worker: int = 1  # episodes each worker returns per iteration (the paper: 1)
    checkpoint_every: int = 10  # iterations between checkpoints/last.pt
    best_window: int = 25  # rolling-mean window [iterations] choosing checkpoints/best.pt (the paper: 25)
    baseline_episodes: int = 2  # unequipped episodes on the training scenario, the learning curves' reference
    resume: str | None = None  # a run directory or checkpoint file to continue from
    # PyTorch threads of the learner; auto = the CPUs the workers leave free (at least 1).
    torch_threads: int | Literal["auto"] = 1
    # auto: on cuda the fixed-shape update captured in CUDA graphs, on a cpu the eager one (the same
    # losses); true / false force it (true on a cpu: run eagerly, for tests).
    static_learner: bool | Literal["auto"] = "auto"
    # serial: workers play, then the learner updates (the paper's loop); overlap: workers play
    # iteration k+1 while the learner updates on k (policy lag 1).
    mode: Literal["serial", "overlap"] = "serial"


@dataclass
class EnvSection:
    """``env`` of ``aamgym train``: the episodes' simulation."""

    time_limit_s: float | None = None  # episode limit [s of sim time]; null = last scenario command + 2 h
    dt: float = 0.05  # simulation step [s]


@dataclass
class EvalEnvSection:
    """``env`` of ``aamgym evaluate``."""

    time_limit_s: float | None = None  # [s of sim time]; null: the training run's
    dt: float | None = None  # [s]; null: the training run's


@dataclass
class RaySection:
    """``ray``: where the rollout workers run."""

    address: str | None = None  # a Ray cluster (auto, ray://head:10001); null = start a local Ray
    num_cpus: int | None = None  # CPUs of the local Ray (null: max(cpu count, workers))
    cpus_per_worker: float = 1  # (an integer: the value the YAML composed before)


def _standard_metrics() -> list[str]:
    return ["safety", "operational"]


@dataclass
class TrainConfig:
    """``aamgym train`` (``rlbridge/conf/config.yaml``: its defaults list; every default is here)."""

    algorithm: AlgorithmSection
    usecase: UsecaseSection
    scenario: str = "nyc_train_100"  # a scenario shipped in aamsim/scn (as `aamsim run` resolves it) or a path
    # Rollout workers as Ray actors; 0 = one in-process worker (debugging); auto = the cores the
    # learner leaves (cuda: all but one; cpu: half).
    workers: int | Literal["auto"] = 2
    # Where the episodes run: local (aamsim in this process), zmq (a simulation server at address,
    # from `aamsim serve`), bluesky (BlueSky flies the aircraft).
    backend: Literal["local", "zmq", "bluesky"] = "local"
    address: str | None = None  # backend=zmq: the server's address, tcp://host:port (as `aamsim serve` prints it)
    timeout_s: float = 30.0  # backend=zmq: the longest wait for one reply [s] (a server's first reset compiles)
    seed: int = 0  # run seed: network init, episode seeds (seed, iteration, worker), sampling
    device: str = "cpu"  # cpu | cuda | auto (cuda when available)
    out_dir: str = "runs"  # runs land in ${out_dir}/train/<time>_<algorithm>_s<seed>
    metrics: list[str] = field(default_factory=_standard_metrics)  # metric groups computed for every episode
    train: TrainSection = field(default_factory=TrainSection)
    env: EnvSection = field(default_factory=EnvSection)
    ray: RaySection = field(default_factory=RaySection)


def _evaluation_lanes_ft() -> list[float]:
    return [500.0, 1200.0, 1900.0]


@dataclass
class EvaluateConfig:
    """``aamgym evaluate`` (``rlbridge/conf/evaluate.yaml``: its defaults list; every default is here)."""

    usecase: UsecaseSection  # the use case of a baseline evaluation (a training run brings its own)
    run: str | None = None  # training run directory (or a checkpoint file) ...
    policy: str | None = None  # ... or a pretrained policy: pretrained:<name> or an exported policy folder ...
    baseline: str | None = None  # ... or a baseline evaluated on its own: unequipped | mvp_speed | daa
    checkpoint: str = "best"  # best | last | a checkpoint path
    scenario: str | None = None  # null = the training scenario (a baseline evaluation needs one)
    # local (aamsim) | bluesky (BlueSky flies the aircraft: the policy checked on BlueSky itself)
    backend: Literal["local", "bluesky"] = "local"
    episodes: int = 100  # episodes per policy, seeds seed .. seed + episodes - 1
    seed: int = 0
    workers: int = 2  # Ray workers (0 = in-process)
    alt_noise_ft: float = 100.0  # the scenario's altitude noise, drawn per episode seed [ft] ...
    # ... around these lanes, replacing the converted noise [ft]
    alt_noise_lanes_ft: list[float] = field(default_factory=_evaluation_lanes_ft)
    # Evaluated on the same seeds (unequipped always); null = the use case's own (its spec's baselines).
    baselines: list[str] | None = None
    greedy: bool | None = None  # null = the algorithm's choice (DDQN: greedy; D2MAV-A: its greedy_eval)
    # greedy=false on a value-based policy (DDQN): epsilon-greedy with this epsilon (Mnih et al. 2015's protocol)
    sampled_epsilon: float = 0.05
    name: str | None = None  # the policy's label in reports (null = the algorithm's label)
    metrics: list[str] = field(default_factory=_standard_metrics)
    # true: the first seed's episode of each policy beside the unequipped one, as MP4s in videos/
    # (its run directory in episodes/<policy>/seed-NNNN/, replayable: aamsim view)
    video: bool = False
    video_speed: float = 60.0  # sim seconds per second of video
    video_fps: float = 10.0
    device: str = "cpu"
    out_dir: str = "runs"
    env: EvalEnvSection = field(default_factory=EvalEnvSection)
    ray: RaySection = field(default_factory=RaySection)


def config_defaults(cls: type) -> dict[str, Any]:
    """The defaults of a configuration dataclass as plain data (nested sections included); fields
    without a default (``algorithm``, ``usecase``: the defaults list's groups) are left out."""
    out: dict[str, Any] = {}
    for f in fields(cls):
        if f.default is not MISSING:
            value = f.default
        elif f.default_factory is not MISSING:
            value = f.default_factory()
        else:
            continue
        out[f.name] = config_defaults(type(value)) if is_dataclass(value) else value
    return out


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
           "check_mapping", "check_value", "config_defaults", "describe", "fits"]
