"""Use-case registry: use cases by name, and their Gymnasium ids.

A new use case is a new module that defines a class following
:class:`~rlbridge.usecases.protocol.UseCase` plus an entry here
(``BUILTIN_USECASES``) or in the ``rlbridge.usecases`` entry-point group of
another package; the environments and the server look use cases up by name
and need no edit. Every entry declares a
:class:`~rlbridge.usecases.spec.UseCaseSpec` (:func:`usecase_spec`). Each gets the Gymnasium id ``aamgym/<env_name>-v1`` (and ``-v0``: fixed traffic, see
:func:`env_id`).
"""

from __future__ import annotations

from importlib import import_module
from importlib.metadata import entry_points
from typing import Any

from rlbridge.usecases.protocol import Feedback, Observations, UseCase, UseCaseBase
from rlbridge.usecases.spec import UseCaseSpec, spec_of

BUILTIN_USECASES: dict[str, str] = {
    "corridor_sa": "rlbridge.usecases.corridor:CorridorSA",
    "reach_destination": "rlbridge.usecases.reach:ReachDestination",
    "strategic_planning": "rlbridge.usecases.strategic:StrategicPlanning",
    "hierarchical": "rlbridge.usecases.hierarchical:Hierarchical",
    "heading_altitude_sa": "rlbridge.usecases.heading_altitude:HeadingAltitudeSA",
}


def available() -> list[str]:
    names = set(BUILTIN_USECASES) | {ep.name for ep in entry_points(group="rlbridge.usecases")}
    return sorted(names)


def usecase_class(name: str) -> Any:
    """The class (or factory) registered under ``name``."""
    target = BUILTIN_USECASES.get(name)
    if target is None:
        for ep in entry_points(group="rlbridge.usecases"):
            if ep.name == name:
                return ep.load()
        raise KeyError(f"unknown use case {name!r}; available: {', '.join(available())}")
    module, _, attr = target.partition(":")
    return getattr(import_module(module), attr)


def make_usecase(name: str | type, **params: Any) -> UseCase:
    """Instantiate a use case by name with parameters (unknown parameters are an error).

    ``name`` may also be the use case's class itself: a use case written in one module of your
    own runs in-process (``backend="local"`` or ``"bluesky"``) without a registry entry
    (docs/tutorials/new-usecase.md); a simulation server knows use cases by name only.
    """
    cls = name if isinstance(name, type) else usecase_class(name)
    spec_of(cls)  # a use case without a spec is refused before it is built
    usecase: UseCase = cls(**params)
    return usecase


def usecase_spec(name: str | type) -> UseCaseSpec:
    """The spec a registry entry (or a use case class) declares, without building the use case.

    A use case whose spec depends on its parameters (``hierarchical``'s ``train``) declares its
    default one on the class; its instances carry their own (``make_usecase(...).spec``).

    Raises:
        KeyError: an unknown name.
        CapabilityError: the use case declares no spec.
    """
    return spec_of(name if isinstance(name, type) else usecase_class(name))


def env_id(name: str, version: int | None = None) -> str:
    """Gymnasium id of a use case: ``aamgym/<env_name>-v<N>``, its current version unless ``version`` is given.

    Version 1 draws each episode's variation from the reset seed (rlbridge.usecases.variation);
    version 0 is the same use case on fixed traffic (its ``fixed_traffic`` parameters), as the
    environments behaved before, for reproducing results made then.
    """
    cls = usecase_class(name)
    return f"aamgym/{cls.env_name or name}-v{getattr(cls, 'env_version', 1) if version is None else version}"


__all__ = ["BUILTIN_USECASES", "Feedback", "Observations", "UseCase", "UseCaseBase", "UseCaseSpec", "available",
           "env_id", "make_usecase", "usecase_class", "usecase_spec"]
