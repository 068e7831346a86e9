"""The parameter dataclasses as Hydra structured configs: the one source of every default.

``algorithm.params`` and ``usecase.params`` of ``rlbridge/conf`` are not written in YAML: each
file of ``conf/algorithm/`` and ``conf/usecase/`` names the dataclass its ``params`` start from
(``- /schema/algorithm/dqn@params``: :class:`rlbridge.agents.ddqn.DDQNConfig`;
``- /schema/usecase/reach_destination@params``: :class:`rlbridge.usecases.reach.ReachParams`)
and lists only what its preset changes. :func:`register_configs` stores those dataclasses in
Hydra's ConfigStore under ``schema/algorithm/<learner kind>`` and ``schema/usecase/<use case>``
(every entry of the learner and use-case registries), so Hydra composes the defaults from the
dataclass itself and checks every override's type against the field
(``algorithm.params.lr=abc`` is refused naming ``algorithm.params.lr``).

The rest of ``config.yaml`` and ``evaluate.yaml`` (``scenario``, ``workers``, the ``train``,
``env`` and ``ray`` sections, ...) comes the same way from
:class:`rlbridge.experiment.schema.TrainConfig` and
:class:`~rlbridge.experiment.schema.EvaluateConfig`, stored under ``schema/app/config`` and
``schema/app/evaluate`` (``- /schema/app/config@_here_`` in the defaults list): as their
defaults only, not typed nodes, because OmegaConf has no ``int | Literal["auto"]``; the types
are checked by :func:`rlbridge.experiment.schema.check_config` before a job starts.

A use case registered by another package (the ``rlbridge.usecases`` entry-point group) has no
file in ``conf/usecase/``; :func:`register_configs` stores its group option too (``usecase/<name>``:
its dataclass's defaults as ``params``, and its ``name``), so ``aamgym train usecase=<name>`` and
``usecase.params.<field>=...`` work for it as for the built-in ones.

Registration is a call, not an import side effect: the Hydra apps (``aamgym train``,
``aamgym evaluate``) call it before composing, and :func:`compose_config` composes for
everything else (``aamgym study``, the preflight check, tests).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

SCHEMA_GROUP = "schema"  # ConfigStore group of the generated configs: schema/algorithm/<kind>, schema/usecase/<name>
CONFIG_MODULE = "rlbridge.conf"


def schema_classes(usecases: dict[str, type] | None = None) -> dict[str, type]:
    """The dataclass of each generated config, by its ConfigStore path (``schema/algorithm/dqn``, ...).

    ``usecases``: :func:`usecase_params_classes` when already at hand (None: asked here).
    """
    from rlbridge.agents import LEARNER_KINDS, learner_config_class

    if usecases is None:
        usecases = usecase_params_classes()
    out = {f"{SCHEMA_GROUP}/algorithm/{kind}": learner_config_class(kind) for kind in LEARNER_KINDS}
    out.update({f"{SCHEMA_GROUP}/usecase/{name}": cls for name, cls in usecases.items()})
    return out


def usecase_params_classes() -> dict[str, type]:
    """The parameter dataclass of every registered use case, by name.

    A use case of another package that cannot be loaded (its module fails to import, it declares
    no spec) is left out with a warning naming its entry point and the error: one broken package
    must not stop every other use case from composing (``aamgym train usecase=<it>`` then finds no
    such option, after the warning that says why). A built-in use case that fails raises.
    """
    from importlib.metadata import entry_points

    from rlbridge.usecases.registry import BUILTIN_USECASES, available, usecase_spec

    out: dict[str, type] = {}
    for name in available():
        try:
            out[name] = usecase_spec(name).params_class
        except Exception as exc:
            if name in BUILTIN_USECASES:
                raise
            where = ", ".join(f"{ep.name} = {ep.value}" for ep in entry_points(group="rlbridge.usecases")
                              if ep.name == name)
            warnings.warn(f"use case {name!r} (entry point rlbridge.usecases: {where}) cannot be loaded and is "
                          f"left out of the configs: {type(exc).__name__}: {exc}", RuntimeWarning, stacklevel=2)
    return out


def app_classes() -> dict[str, type]:
    """The dataclass of each Hydra app's own keys, by its ConfigStore path (``schema/app/config``, ...)."""
    from rlbridge.experiment.schema import SCHEMAS

    return {f"{SCHEMA_GROUP}/app/{name}": cls for name, cls in SCHEMAS.items()}


def unwritten_usecases(usecases: dict[str, type] | None = None) -> list[str]:
    """The registered use cases without a preset file in ``conf/usecase/`` (those of other packages that load).

    ``usecases``: :func:`usecase_params_classes` when already at hand (None: asked here).
    """
    from importlib.resources import files

    written = {entry.name.removesuffix(".yaml") for entry in files(CONFIG_MODULE).joinpath("usecase").iterdir()}
    return [name for name in (usecase_params_classes() if usecases is None else usecases) if name not in written]


def register_configs() -> None:
    """Store every learner's and use case's parameter dataclass, and the apps' defaults, in Hydra's
    ConfigStore (idempotent)."""
    from hydra.core.config_store import ConfigStore
    from omegaconf import OmegaConf

    store = ConfigStore.instance()
    usecases = usecase_params_classes()  # once: a broken plugin is warned about once
    for path, cls in schema_classes(usecases).items():
        group, _, name = path.rpartition("/")
        node = OmegaConf.structured(cls)
        # A frozen dataclass makes a read-only node; presets and the command line must still set fields
        # (the dataclass itself stays frozen: the job builds it from the composed values).
        OmegaConf.set_readonly(node, False)
        store.store(group=group, name=name, node=node)
    for name in unwritten_usecases(usecases):
        store.store(group="usecase", name=name,
                    node={"defaults": [f"/{SCHEMA_GROUP}/usecase/{name}@params", "_self_"], "name": name})
    from rlbridge.experiment.schema import config_defaults

    for path, cls in app_classes().items():
        group, _, name = path.rpartition("/")
        store.store(group=group, name=name, node=OmegaConf.create(config_defaults(cls)))


def compose_config(config_name: str, overrides: Sequence[str] = ()) -> Any:
    """Hydra's composition of ``config_name`` (``config``: ``aamgym train``; ``evaluate``) with ``overrides``.

    Returns:
        The composed ``DictConfig``, as the Hydra app would receive it (without the ``hydra`` node).
    """
    from hydra import compose, initialize_config_module

    register_configs()
    with initialize_config_module(CONFIG_MODULE, version_base="1.3"):
        return compose(config_name, overrides=list(overrides))


__all__ = ["app_classes", "compose_config", "register_configs", "schema_classes", "unwritten_usecases",
           "usecase_params_classes"]
