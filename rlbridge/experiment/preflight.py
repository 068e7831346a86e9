"""Everything ``aamgym train`` / ``aamgym evaluate`` can check before Hydra starts the job.

Hydra makes the run directory and calls the job only after composing; a bad value used
to surface once Ray was up and the baseline episodes were played, leaving a half-made run
directory. :func:`preflight` composes the configuration of every job the command line asks
for (each point of a ``--multirun`` sweep) with Hydra's own parser and composer, checks it
against the structured configs of :mod:`rlbridge.experiment.schema` and checks what the job
will need (the scenario file, the training run, the extras of Ray, MP4 videos, BlueSky),
and returns the problems as lines naming the key. :func:`rlbridge.experiment.cli.main`
prints them and exits with status 2 before anything starts.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import MISSING, fields
from pathlib import Path
from typing import Any

from aamsim.extras import MissingExtra, require
from rlbridge.experiment.schema import SCHEMAS, EvaluateConfig, check_config

# Hydra flags that only print (help, the config, shell completion): nothing runs, nothing to check.
_INSPECT = ("help", "hydra_help", "info", "cfg", "shell_completion", "resolve")
MAX_SWEEP_POINTS = 256  # larger sweeps: each value checked with the others at their first value


def preflight(config_name: str, argv: Sequence[str]) -> list[str]:
    """The problems of the jobs ``argv`` (the arguments after ``aamgym train|evaluate``) would run.

    Returns an empty list when every job's configuration is sound, or when ``argv`` only asks
    Hydra to print something, or names its own config file or search path (then Hydra checks).
    """
    from hydra._internal.utils import get_args_parser

    try:
        args = get_args_parser().parse_args(list(argv))
    except SystemExit:  # argparse's own message is already printed
        return []
    if any(getattr(args, flag, None) for flag in _INSPECT) or args.config_name or args.config_path \
            or args.config_dir:
        return []
    overrides = [o for o in args.overrides if not _is_hydra_override(o)]
    problems: list[str] = []
    seen: set[str] = set()
    for point in sweep_points(overrides, bool(args.multirun)):
        for line in check_job(config_name, point):
            if line not in seen:
                seen.add(line)
                problems.append(line)
    return problems


def override_key(text: str) -> str:
    """The key of a Hydra override (``+usecase.params.x=1`` -> ``usecase.params.x``)."""
    return text.lstrip("+~").split("=", 1)[0]


def _is_hydra_override(text: str) -> bool:
    key = override_key(text)
    return key == "hydra" or key.startswith(("hydra.", "hydra/"))


def sweep_points(overrides: list[str], multirun: bool) -> list[list[str]]:
    """The override lists of the jobs: one, or one per point of a ``--multirun`` sweep."""
    if not multirun:
        return [overrides]
    from hydra.core.override_parser.overrides_parser import OverridesParser

    try:
        parsed = OverridesParser.create().parse_overrides(overrides)
    except Exception:  # noqa: BLE001  (Hydra's parser errors have no common base; Hydra reports them itself)
        return [overrides]
    axes: list[list[str]] = []
    for text, override in zip(overrides, parsed):
        if override.is_sweep_override() and not override.is_interval_sweep():
            key = override.get_key_element()
            axes.append([f"{key}={value}" for value in override.sweep_string_iterator()])
        else:
            axes.append([text])
    total = 1
    for axis in axes:
        total *= len(axis)
    if total <= MAX_SWEEP_POINTS:
        return [list(point) for point in itertools.product(*axes)]
    first = [axis[0] for axis in axes]
    return [first[:i] + [value] + first[i + 1:] for i, axis in enumerate(axes) for value in axis]


def check_job(config_name: str, overrides: list[str]) -> list[str]:
    """The problems of one job's configuration (composition, types and keys, what it needs)."""
    from omegaconf import OmegaConf
    from omegaconf.errors import OmegaConfBaseException

    refused: dict[str, Any] = {}
    cfg = compose_leniently(config_name, overrides, refused)
    if isinstance(cfg, str):
        return [cfg]
    try:
        container = OmegaConf.to_container(cfg, resolve=True)
    except OmegaConfBaseException:  # an interpolation only Hydra's job can resolve: check the text
        container = OmegaConf.to_container(cfg, resolve=False)
    assert isinstance(container, dict)
    plain: dict[str, Any] = {str(k): v for k, v in container.items()}
    for key, value in refused.items():  # the schema check words what the structured config refused
        *path, name = key.split(".")
        node = plain
        for part in path:
            node = node.setdefault(part, {})
        node[name] = value
    problems = check_config(plain, SCHEMAS[config_name], params_classes(plain))
    if problems:
        return problems
    return params_problems(plain) + needs(config_name, plain) + replaced_overrides(config_name, overrides, plain)


# Use-case parameters evaluate sets itself (from its own keys of the same name): an override of them would be
# replaced without a word.
EVALUATE_SETS = ("alt_noise_ft", "alt_noise_lanes_ft")


def replaced_overrides(config_name: str, overrides: list[str], cfg: dict[str, Any]) -> list[str]:
    """Overrides the job would ignore or replace with a value of its own, each named with what decides instead."""
    if config_name != "evaluate":
        return []
    trained = [k for k in ("run", "policy") if cfg.get(k) not in (None, "")]
    problems = []
    for text in overrides:
        key = override_key(text)
        if trained and key.split(".")[0].split("/")[0] == "usecase":
            # A trained policy plays in the use case it was trained in, from its checkpoint (evaluation_env).
            problems.append(f"{key}: {trained[0]}=... is evaluated in the use case and parameters it was trained "
                            "with; usecase overrides apply to baseline=NAME evaluations (the altitude noise: "
                            "alt_noise_ft=..., alt_noise_lanes_ft=...)")
            continue
        own = key.removeprefix("usecase.params.")
        if own != key and own in EVALUATE_SETS:  # a nested one (hierarchical's levels) is not always replaced
            spec = {f.name: f for f in fields(EvaluateConfig)}[own]
            default: Any = spec.default if spec.default is not MISSING else spec.default_factory()  # type: ignore[misc,operator]
            shown = ", ".join(f"{v:g}" for v in default) if isinstance(default, list) else f"{default:g}"
            problems.append(f"{key}: evaluate gives the use case its own {own} (default {shown}); "
                            f"set {own}=... instead")
    return problems


def compose_leniently(config_name: str, overrides: list[str], refused: dict[str, Any] | None = None) -> Any:
    """Hydra's composition of the job, or its error in one line.

    Hydra refuses to override a key the YAML lacks (``train.foo=1``); such an override is
    composed again as an addition (``+train.foo=1``), so that the schema check names the key
    and lists the keys of its section, the learner's or the use case's dataclass included.
    A value the parameter dataclass's structured config refuses (``algorithm.params.lr=abc``)
    is left out of the composition and put in ``refused`` (key: the value as Hydra parsed it),
    for the schema check to word.
    """
    from hydra.errors import HydraException
    from omegaconf.errors import OmegaConfBaseException

    from rlbridge.experiment.configstore import compose_config

    overrides = list(overrides)
    for _ in range(2 * len(overrides) + 1):
        try:
            return compose_config(config_name, overrides)
        except (HydraException, OmegaConfBaseException) as exc:
            typed = refused_override(exc, overrides)
            if typed is not None:
                index, value = typed
                field = overrides.pop(index).lstrip("+~").split("=", 1)[0]
                if refused is None:
                    return f"{field}={value}: {typed_override_error(exc)}"
                refused[field] = value
                continue
            text = str(exc)
            key = text.split("'")[1] if text.startswith("Could not override '") else None
            at = [i for i, o in enumerate(overrides) if key is not None and o.split("=", 1)[0] == key]
            if not at:
                return one_line(text)
            for i in at:
                overrides[i] = "+" + overrides[i]
    return "; ".join(overrides)  # not reached: each pass turns at least one override into an addition


def typed_override_error(exc: BaseException) -> str | None:
    """What the field's type refused (OmegaConf's words), when a structured config refused an override."""
    from omegaconf.errors import ValidationError

    cause = exc.__cause__
    if not isinstance(cause, ValidationError) or not getattr(cause, "full_key", None):
        return None
    return str(getattr(cause, "msg", "") or cause).splitlines()[0].strip()


def refused_override(exc: BaseException, overrides: list[str]) -> tuple[int, Any] | None:
    """(index in ``overrides``, parsed value) of the override whose value a structured config refused.

    Hydra says only "Error merging override KEY=VALUE"; its cause (OmegaConf's ``ValidationError``)
    names the field, e.g. ``algorithm.params.lr`` or ``usecase.params.alt_noise_lanes_ft[1]``.
    """
    from hydra.core.override_parser.overrides_parser import OverridesParser

    if typed_override_error(exc) is None:
        return None
    full_key = str(getattr(exc.__cause__, "full_key", "")).split("[", 1)[0]
    for i, text in enumerate(overrides):
        if text.lstrip("+~").split("=", 1)[0] == full_key:
            return i, OverridesParser.create().parse_override(text).value()
    return None


def one_line(text: str) -> str:
    """Hydra's multi-line composition error as one line (its config search path left out)."""
    text = text.split("Config search path")[0]
    head, _, options = text.partition("Available options in")
    lines = [line.strip() for line in head.splitlines() if line.strip()]
    if options:
        group, _, names = options.partition(":")
        lines.append(f"available in{group}: " + ", ".join(n.strip() for n in names.split() if n.strip()))
    return "; ".join(lines)


def params_classes(cfg: dict[str, Any]) -> dict[str, type | None]:
    """The dataclasses ``algorithm.params`` and ``usecase.params`` must fit (None: unknown name, reported)."""
    from rlbridge.agents import learner_config_class
    from rlbridge.usecases.registry import usecase_spec

    out: dict[str, type | None] = {}
    algorithm = cfg.get("algorithm")
    if isinstance(algorithm, dict):
        try:
            out["algorithm"] = learner_config_class(str(algorithm.get("kind")))
        except KeyError:
            out["algorithm"] = None
    usecase = cfg.get("usecase")
    if isinstance(usecase, dict):
        try:
            out["usecase"] = usecase_spec(str(usecase.get("name"))).params_class
        except KeyError:
            out["usecase"] = None
    return out


def params_problems(cfg: dict[str, Any]) -> list[str]:
    """Unknown learner kinds and use cases, and what the parameter dataclasses refuse when built."""
    from rlbridge.agents import LEARNER_KINDS, learner_config_class
    from rlbridge.usecases.registry import available, usecase_spec

    problems = []
    algorithm = cfg.get("algorithm")
    if isinstance(algorithm, dict):
        kind = str(algorithm.get("kind"))
        if kind not in LEARNER_KINDS:
            problems.append(f"algorithm.kind={kind}: expected one of {', '.join(LEARNER_KINDS)}")
        else:
            problems += _build(learner_config_class(kind), algorithm.get("params") or {}, "algorithm.params")
    usecase = cfg.get("usecase")
    if isinstance(usecase, dict):
        name = str(usecase.get("name"))
        if name not in available():
            problems.append(f"usecase.name={name}: expected one of {', '.join(available())}")
        else:
            problems += _build(usecase_spec(name).params_class, usecase.get("params") or {}, "usecase.params")
    return problems


def _build(cls: type, params: dict[str, Any], key: str) -> list[str]:
    """Build the dataclass as the job will, so its own checks (``__post_init__``) run now."""
    try:
        cls(**params)
    except (TypeError, ValueError) as exc:
        return [f"{key}: {exc}"]
    return []


def needs(config_name: str, cfg: dict[str, Any]) -> list[str]:
    """What the job needs beyond a well-typed configuration: its files and the extras it will import."""
    from aamsim.scenarios import resolve_scenario

    problems = []
    scenario = cfg.get("scenario")
    if scenario is not None and resolve_scenario(str(scenario)) is None:
        problems.append(f"scenario={scenario}: not found (neither a file nor a scenario shipped in aamsim/scn)")
    if config_name == "evaluate":
        given = [key for key in ("run", "policy", "baseline") if cfg.get(key) not in (None, "")]
        if len(given) != 1:
            problems.append("run=RUN_DIR (a training run), policy=pretrained:NAME (a shipped policy) or "
                            f"baseline=NAME: exactly one of them is needed, not {' and '.join(given) or 'none'}")
        if cfg.get("policy") not in (None, ""):
            from rlbridge.pretrained import policy_dir

            try:
                policy_dir(str(cfg["policy"]))
            except FileNotFoundError as exc:
                problems.append(f"policy={cfg['policy']}: {exc}")
        if cfg.get("run") is not None and not Path(str(cfg["run"])).exists():
            problems.append(f"run={cfg['run']}: no such training run or checkpoint file")
        if cfg.get("baseline") is not None and cfg.get("scenario") is None:
            problems.append("scenario: a baseline evaluation needs one (e.g. scenario=nyc_train_100)")
        from rlbridge.agents import BASELINE_KINDS

        named = [("baseline", cfg["baseline"])] if cfg.get("baseline") not in (None, "") else []
        named += [("baselines", b) for b in cfg.get("baselines") or []]
        for key, name in named:
            if str(name) not in BASELINE_KINDS:
                problems.append(f"{key}={name}: unknown baseline; known: {', '.join(BASELINE_KINDS)}")
    if config_name == "config" and cfg.get("backend") == "zmq":
        from rlbridge.experiment.train import ZMQ_ADDRESS

        address = cfg.get("address")
        if not address or not ZMQ_ADDRESS.fullmatch(str(address)):
            problems.append(f"address={address}: backend=zmq needs the simulation server's address, "
                            "tcp://host:port (as `aamsim serve` prints it)")
    workers = cfg.get("workers") or 0
    wanted = [("batch", "Ray workers (workers > 0)", ("ray",), workers == "auto" or int(workers) > 0,
               "or workers=0: one in-process worker")]
    if config_name == "evaluate":
        wanted += [("video", "video=true (MP4 videos)", ("imageio_ffmpeg",), bool(cfg.get("video")), ""),
                   ("bluesky", "backend=bluesky", ("bluesky",), cfg.get("backend") == "bluesky", "")]
    if config_name == "config":
        wanted += [("bluesky", "backend=bluesky", ("bluesky",), cfg.get("backend") == "bluesky", "")]
    for extra, feature, modules, used, hint in wanted:
        if used:
            try:
                require(extra, feature, modules, hint)
            except MissingExtra as exc:
                problems.append(str(exc))
    return problems


__all__ = ["check_job", "preflight", "sweep_points"]
