"""The use-case contract beyond the protocol's methods: one typed :class:`UseCaseSpec` per use case.

A use case declares here, as data, what the rest of the system needs to know
about it without running it (docs/usecases.md, "The spec"): its parameters
class, the action kinds its actions emit, the baselines that fit it, how an
advisory is counted, the extra metrics it adds, whether aircraft are its
agents, whether it holds departures back and which of its parameters name
frozen policies. Readers (the engine, the backends, the server, evaluation,
the agents) read these fields and nothing else: a use case without a spec is
an error naming it, not a silent default.

Policies declare what they need from a use case as :class:`Needs`;
:func:`check_fits` refuses a policy that does not fit, naming the use case
and the missing capability.
"""

from __future__ import annotations

from dataclasses import dataclass, is_dataclass
from typing import Any

# What a use case's actions can change. ``speed``, ``heading`` and ``altitude`` are advisories to
# aircraft (UseCaseBase.action_targets gives their targets); ``vertical_speed`` a selected climb or
# descent rate; ``departure_slot`` a planner's choice of when and at which level a flight departs.
ACTION_KINDS = ("speed", "heading", "altitude", "vertical_speed", "departure_slot")
# How the discrete speed actions are laid out (``UseCaseSpec.speed_actions``):
SPEED_ROLES = "decelerate_hold_accelerate"  # actions 0, 1, 2 = slow down / keep the current CAS / speed up
SPEED_TARGETS = "fixed_targets"  # each action selects one fixed CAS (reach_destination's speeds_kts)
SPEED_LAYOUTS = (SPEED_ROLES, SPEED_TARGETS)
# How an advisory is counted (the ``advisories`` and alert-rate metrics; ``UseCaseSpec.advisory``).
ADVISORY_RULES = {
    "non_hold": "every action other than hold is one advisory (holding is no alert)",
    "target_change": "an action that changes the aircraft's selected target is one advisory (repeating it is none)",
    "manoeuvre_change": "an action other than resume that differs from the aircraft's previous one",
    "tactical_layer": "the agents plan departures; advisories are those of the frozen tactical layer",
}


@dataclass(frozen=True)
class CurveColumn:
    """One use-case column of a training run's ``learning_curve.csv`` (and of its ``baseline.json``).

    Attributes:
        name: the column's header.
        metric: a dotted path into an episode's metrics: a standard group's key
            (``safety.nmac_events``) or the use case's ``extra_metrics`` under its registry name
            (``reach_destination.arrivals``).
        per_aircraft: divide each episode's value by its aircraft (flights created) first.
        each_episode: the iteration's episodes' values, ``;``-separated, instead of their mean.
    """

    name: str
    metric: str
    per_aircraft: bool = True
    each_episode: bool = False

    def value(self, metrics: dict[str, Any], aircraft: int) -> float:
        """This column's value for one episode (NaN when the episode has no such metric)."""
        total = metric_at(metrics, self.metric)
        return total / max(aircraft, 1) if self.per_aircraft else total


def metric_node(metrics: dict[str, Any], path: str) -> Any:
    """What an episode's metrics hold at a dotted ``path`` (``safety.nmac_events``), as is; None when absent."""
    node: Any = metrics
    for key in path.split("."):
        node = node.get(key) if isinstance(node, dict) else None
    return node


def metric_at(metrics: dict[str, Any], path: str) -> float:
    """The number at a dotted ``path`` of an episode's metrics (``safety.nmac_events``); NaN when absent."""
    node = metric_node(metrics, path)
    return float("nan") if node is None else float(node)


# The separation columns every use case flying aircraft shares (the corridor's learning curve).
SEPARATION_CURVE = (CurveColumn("nmac_per_aircraft", "safety.nmac_events"),
                    CurveColumn("lowc_per_aircraft", "safety.lowc_events"),
                    CurveColumn("episode_nmac_per_aircraft", "safety.nmac_events", each_episode=True))


class CapabilityError(TypeError):
    """A policy needs a capability a use case does not declare, or a use case declares no spec."""


@dataclass(frozen=True)
class UseCaseSpec:
    """What a use case is, as data (see the module docstring).

    Attributes:
        params_class: the frozen dataclass its keyword parameters build (``aamgym`` checks
            ``usecase.params`` against it).
        action_kinds: what its actions change, from :data:`ACTION_KINDS`.
        baselines: the rule-based baselines that fit it (``unequipped`` always does and is
            not listed); ``aamgym evaluate`` takes them when ``baselines`` is null.
        advisory: how an advisory is counted, a key of :data:`ADVISORY_RULES`.
        metrics: the keys of its ``extra_metrics`` (``{}`` before an episode ends is allowed).
        speed_actions: the layout of its speed actions (:data:`SPEED_LAYOUTS`); required when
            ``action_kinds`` has ``speed``, empty otherwise.
        aircraft_agents: whether aircraft can be agents (False: a planner; ``possible_agents``
            then holds only the standing agents).
        plans_departures: whether it holds the scenario's departures back (a backend that reads
            the scenario itself, BlueSky, cannot run it).
        policy_params: its parameters that name frozen policies (a baseline name or a training
            run path; a simulation server accepts baseline names only).
        curve: its columns of a training run's learning curve (:class:`CurveColumn`), between the
            reward's and the throughput's; the separation rates unless it declares its own.
    """

    params_class: type
    action_kinds: tuple[str, ...]
    baselines: tuple[str, ...]
    advisory: str
    metrics: tuple[str, ...] = ()
    speed_actions: str = ""
    aircraft_agents: bool = True
    plans_departures: bool = False
    policy_params: tuple[str, ...] = ()
    curve: tuple[CurveColumn, ...] = SEPARATION_CURVE

    def declared_metrics(self, name: str) -> tuple[str, ...]:
        """The dotted paths of the episode metrics it declares, for a use case registered as ``name``:
        its curve columns' metrics, then its ``extra_metrics`` (``name.key``), each once."""
        paths = [c.metric for c in self.curve] + [f"{name}.{key}" for key in self.metrics]
        return tuple(dict.fromkeys(paths))

    def __post_init__(self) -> None:
        if not (isinstance(self.params_class, type) and is_dataclass(self.params_class)):
            raise TypeError(f"UseCaseSpec.params_class must be a dataclass, not {self.params_class!r}")
        unknown = [k for k in self.action_kinds if k not in ACTION_KINDS]
        if unknown:
            raise ValueError(f"UseCaseSpec.action_kinds: unknown kind(s) {', '.join(unknown)}; "
                             f"known: {', '.join(ACTION_KINDS)}")
        if self.advisory not in ADVISORY_RULES:
            raise ValueError(f"UseCaseSpec.advisory {self.advisory!r}: expected one of {', '.join(ADVISORY_RULES)}")
        if ("speed" in self.action_kinds) != bool(self.speed_actions):
            raise ValueError("UseCaseSpec.speed_actions is required with a speed action kind and only then "
                             f"(action_kinds {self.action_kinds}, speed_actions {self.speed_actions!r})")
        names = [c.name for c in self.curve]
        if len(set(names)) != len(names):
            raise ValueError(f"UseCaseSpec.curve: column names repeat ({', '.join(names)})")
        if self.speed_actions and self.speed_actions not in SPEED_LAYOUTS:
            raise ValueError(f"UseCaseSpec.speed_actions {self.speed_actions!r}: expected one of "
                             f"{', '.join(SPEED_LAYOUTS)}")


def spec_of(usecase: Any) -> UseCaseSpec:
    """The spec of a use case class or instance; a use case without one is a :class:`CapabilityError`."""
    spec = getattr(usecase, "spec", None)
    if not isinstance(spec, UseCaseSpec):
        name = getattr(usecase, "name", None) or getattr(usecase, "__name__", repr(usecase))
        raise CapabilityError(f"use case {name} declares no spec: give its class a `spec = UseCaseSpec(...)` "
                              "(rlbridge.usecases.spec; docs/usecases.md, 'The spec')")
    return spec


@dataclass(frozen=True)
class Needs:
    """What a policy needs from a use case.

    Attributes:
        any_of: action kinds of which the use case must emit at least one (empty: none needed).
        speed_actions: the speed action layout it steers with, when it needs one
            (``SPEED_ROLES``: the speed-only MVP's decelerate / hold / accelerate).
        aircraft_agents: True when its agents must be aircraft, False when they must not be
            (a planner), None when either fits.
    """

    any_of: tuple[str, ...] = ()
    speed_actions: str = ""
    aircraft_agents: bool | None = None

    def missing(self, spec: UseCaseSpec) -> list[str]:
        """What ``spec`` lacks of these needs, in words (empty: it fits)."""
        out = []
        kinds = ", ".join(spec.action_kinds) or "none"
        if self.any_of and not set(self.any_of) & set(spec.action_kinds):
            out.append(f"{' or '.join(self.any_of)} actions (its action kinds: {kinds})")
        elif self.speed_actions and spec.speed_actions != self.speed_actions:
            have = spec.speed_actions or "no speed actions"
            out.append(f"speed actions laid out as {self.speed_actions} (its speed actions: {have})")
        if self.aircraft_agents is not None and spec.aircraft_agents != self.aircraft_agents:
            out.append("aircraft as agents" if self.aircraft_agents else "a planner agent, not aircraft")
        return out


def check_fits(needs: Needs, usecase: Any, who: str) -> None:
    """Refuse ``who`` (e.g. ``"baseline mvp_speed"``) on ``usecase`` when its needs are not met.

    Raises:
        CapabilityError: naming the use case and each missing capability.
    """
    missing = needs.missing(spec_of(usecase))
    if missing:
        name = getattr(usecase, "name", None) or getattr(usecase, "__name__", repr(usecase))
        raise CapabilityError(f"{who} does not fit use case {name}: it needs {'; and '.join(missing)}")
