"""The use-case protocol: what every AAM use case provides to the episode engine (docs/usecases.md).

A use case names only what every use case has:

* **agents**: aircraft become agents through the simulation's creation events
  (``agent_of`` maps an aircraft to its agent name, or None when it is not an
  agent), so aircraft from CRE, MCRE, PCALL or SCHEDULE are all agents and
  ``possible_agents`` grows with them; ``standing_agents`` live for the whole
  episode whatever flies (a planner);
* **decision events**: ``next_decision_s`` (default: every
  ``decision_interval_s``);
* **spaces**, **observe** and **apply_actions**;
* **feedback**: per-agent rewards and a typed per-agent info (columns declared
  in ``info_fields``, e.g. ``{"nmac": np.bool_}``), computed over the interval
  since the last decision;
* optional **extra metrics** added to the episode's standard metrics;
* optional **scenario commands**: the commands the engine queues, so that a
  planner can hold departure requests back and release them as it decides
  (``holding`` tells the engine the scenario is not over while it does);
* its **spec** (:class:`~rlbridge.usecases.spec.UseCaseSpec`): what it is as
  data (parameters class, action kinds, the baselines that fit, how an
  advisory is counted, its metrics, whether aircraft are agents, whether it
  plans departures, which parameters name frozen policies).

The engine (:mod:`rlbridge.core`), the environments, the wire and the agents'
dimension helpers use nothing else, so a new use case is one module plus a
registry entry. :class:`UseCaseBase` gives every optional member a default.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import gymnasium as gym
import numpy as np

from rlbridge.usecases.spec import CapabilityError, UseCaseSpec, spec_of

if TYPE_CHECKING:
    from aamsim import Simulation
    from aamsim.stack.parser import TimedCommand

# Per-agent info columns travel as arrays of these dtypes (docs/protocol.md).
INFO_DTYPES = (np.bool_, np.int64, np.float64)
# What a tactical use case's actions can change: the selected speed (CAS), heading (track) or altitude.
ADVISORY_KINDS = ("speed", "heading", "altitude")
# Units of each kind's action targets (UseCaseBase.action_targets).
ADVISORY_UNITS = {"speed": "CAS m/s", "heading": "deg true", "altitude": "m"}


class AdvisoryKindError(CapabilityError):
    """A use case was asked for an advisory kind it does not declare, or a policy needs one it lacks."""


@dataclass
class Observations:
    """Observations of several agents as arrays (row k belongs to agent k)."""

    flat: np.ndarray | None = None  # (n, dim) when the use case emits flat vectors
    parts: dict[str, np.ndarray] | None = None  # name -> (n, ...) when it emits a Dict space

    def row(self, k: int) -> Any:
        if self.parts is not None:
            return {name: arr[k] for name, arr in self.parts.items()}
        assert self.flat is not None
        return self.flat[k]

    def __len__(self) -> int:
        if self.parts is not None:
            return len(next(iter(self.parts.values())))
        return 0 if self.flat is None else len(self.flat)


@dataclass
class Feedback:
    """Rewards and per-agent info of several agents (row k belongs to agent k)."""

    rewards: np.ndarray
    info: dict[str, np.ndarray] = field(default_factory=dict)  # column name -> (n,) array


class UseCase(Protocol):
    """What a use case provides (see the module docstring)."""

    name: str  # registry name, e.g. "corridor_sa"
    env_name: str  # Gymnasium id part: aamgym/<env_name>-v<N>
    spec: UseCaseSpec  # what it is as data (rlbridge.usecases.spec)
    standing_agents: tuple[str, ...]
    info_fields: dict[str, type]

    @property
    def decision_interval_s(self) -> float: ...

    def observation_space(self) -> gym.Space[Any]: ...

    def action_space(self) -> gym.Space[Any]: ...

    def attach(self, sim: Simulation) -> None:
        """Prepare a fresh simulation (hooks, settings, services) before the scenario loads."""

    def agent_of(self, sim: Simulation, slot: int) -> str | None:
        """The agent that the aircraft in ``slot`` is (called on its creation and deletion), or None."""

    def next_decision_s(self, sim: Simulation) -> float:
        """Sim time of the next decision, from now."""

    def observe(self, sim: Simulation, agents: list[str]) -> Observations: ...

    def apply_actions(self, sim: Simulation, actions: dict[str, Any]) -> None: ...

    def feedback(self, sim: Simulation, agents: list[str], actions: dict[str, Any], since_s: float) -> Feedback:
        """Rewards and info of ``agents`` for the interval that began at ``since_s`` with ``actions``."""

    def extra_metrics(self, sim: Simulation) -> dict[str, Any]:
        """Metrics the use case adds to the episode's standard ones ({} when none)."""

    def scenario_commands(self, sim: Simulation, commands: list[TimedCommand]) -> list[TimedCommand]:
        """The scenario's commands the engine queues (a planner holds departure requests back)."""

    def holding(self, sim: Simulation) -> bool:
        """Whether the use case still holds traffic to release (the scenario is not over before)."""


class UseCaseBase:
    """Defaults for the optional members of :class:`UseCase`: every aircraft is an agent named by its callsign."""

    name: ClassVar[str] = ""
    env_name: ClassVar[str] = ""
    # No default: every use case declares its own (spec_of names one that does not). An attribute, not a
    # ClassVar: the hierarchical use case's spec depends on which level learns.
    spec: UseCaseSpec
    standing_agents: tuple[str, ...] = ()
    info_fields: dict[str, type] = {}  # noqa: RUF012 (read-only by convention; subclasses replace it)
    default_decision_interval_s: ClassVar[float] = 10.0
    # Episode variation (rlbridge.usecases.variation): the parameters that switch the use case's draws
    # from the reset seed off (its fixed traffic, what the ``-v0`` environment ids keep).
    fixed_traffic: ClassVar[dict[str, Any]] = {}
    # Gymnasium id version: bumped when the environment's behaviour changes (aamgym/<env_name>-v<N>).
    env_version: ClassVar[int] = 1
    # True when the use case's observations, rewards and infos read no separation events but those that
    # involve its agents (the conflict service's ``involved_since``), and nothing else of the conflict
    # service: a single-agent view then leaves the conflict checks out until its ego exists
    # (rlbridge.core.EpisodeCore.until_alive_steps). False (the default) keeps every check.
    conflicts_of_agents_only: ClassVar[bool] = False

    def action_targets(self, sim: Simulation, slots: np.ndarray, kind: str) -> np.ndarray:
        """Per aircraft slot, the target each action sets for advisory ``kind`` (ADVISORY_UNITS): (n, n_actions).

        A kind its spec's ``action_kinds`` do not declare is an error naming it.
        """
        check_advisory_kinds(self, (kind,), f"applying {kind} advisories")
        targets: np.ndarray = getattr(self, f"{kind}_action_targets")(sim, slots)
        return targets

    @property
    def decision_interval_s(self) -> float:
        return self.default_decision_interval_s

    def attach(self, sim: Simulation) -> None:
        return None

    def agent_of(self, sim: Simulation, slot: int) -> str | None:
        # Replayed real traffic (an overlay) is an intruder, never an agent.
        return None if sim.view.noncooperative[slot] else sim.view.callsign(slot)

    def next_decision_s(self, sim: Simulation) -> float:
        return sim.simt + self.decision_interval_s

    def idle_decisions_change_nothing(self, sim: Simulation) -> bool:
        """True when ``apply_actions(sim, {})`` changes nothing now, nor at later decisions without actions.

        A single-agent view then flies to its ego without stopping at the decisions on the way
        (rlbridge.core.EpisodeCore._fly_idle), where it would apply no actions. False (the
        default) stops at each.
        """
        return False

    def extra_metrics(self, sim: Simulation) -> dict[str, Any]:
        return {}

    def scenario_commands(self, sim: Simulation, commands: list[TimedCommand]) -> list[TimedCommand]:
        return commands

    def holding(self, sim: Simulation) -> bool:
        return False


class SpeedActions(Protocol):
    """A tactical use case whose discrete actions select speeds (what the rule-based baselines steer with)."""

    def speed_action_targets(self, sim: Simulation, slots: np.ndarray) -> np.ndarray:
        """Per aircraft slot, the CAS [m/s] each action selects: ``(len(slots), n_actions)``."""
        ...


class DepartureSlots(Protocol):
    """A use case whose actions choose departure slots (``departure_slot``; what the planner baselines steer)."""

    def departure_planner(self) -> Any:
        """The planner deciding the requests (candidate slots, conflicts, the current request)."""
        ...


def check_advisory_kinds(usecase: Any, needed: tuple[str, ...], who: str, any_of: bool = False) -> None:
    """Refuse, naming the kinds, a policy or request that needs advisory kinds the use case does not emit.

    ``needed``: every one of them (``any_of``: at least one of them).
    """
    unknown = [k for k in needed if k not in ADVISORY_KINDS]
    if unknown:
        raise AdvisoryKindError(f"unknown advisory kind(s) {', '.join(unknown)}; known: {', '.join(ADVISORY_KINDS)}")
    have = tuple(k for k in spec_of(usecase).action_kinds if k in ADVISORY_KINDS)
    missing = [k for k in needed if k not in have]
    if (any_of and len(missing) == len(needed)) or (not any_of and missing):
        kinds = ", ".join(have) if have else "none"
        want = (" or " if any_of else " and ").join(missing)
        raise AdvisoryKindError(f"{who} needs {want} advisories; use case {getattr(usecase, 'name', usecase)} "
                                f"does not declare them (its advisory kinds: {kinds})")


def make_params(cls: Any, params: dict[str, Any] | None) -> Any:
    """A use case's parameter dataclass from keyword parameters (an unknown name is an error naming it)."""
    params = dict(params or {})
    known = {fl.name for fl in fields(cls)}
    unknown = sorted(set(params) - known)
    if unknown:
        raise ValueError(f"unknown use-case parameter(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")
    return cls(**params)


def empty_info(fields: dict[str, type], n: int) -> dict[str, np.ndarray]:
    """Zeroed info columns for ``n`` agents."""
    return {name: np.zeros(n, dtype=dtype) for name, dtype in fields.items()}


def check_feedback(usecase: UseCase, feedback: Feedback, n: int) -> None:
    """A use case's feedback must match its declaration (a clear error, not a wrong array later)."""
    if np.shape(feedback.rewards) != (n,):
        raise ValueError(f"use case {usecase.name}: feedback has {np.shape(feedback.rewards)} rewards for {n} agents")
    for name, dtype in usecase.info_fields.items():
        col = feedback.info.get(name)
        if col is None or col.shape != (n,) or col.dtype != np.dtype(dtype):
            raise ValueError(f"use case {usecase.name}: info column {name!r} must be a {np.dtype(dtype).name} "
                             f"array of {n} values")


def start_overlay(sim: Simulation, overlay: str, offset: str = "", area: tuple[float, ...] = ()) -> None:
    """Real traffic as intruders from the episode's start (a use case's ``overlay`` parameters): a
    recording file, or ``opensky:LAT0,LON0,LAT1,LON1``; see docs/real-traffic.md. Nothing when empty."""
    if not overlay:
        return
    from aamsim.realtraffic.overlay import start_overlay as start
    from aamsim.realtraffic.replay import parse_area

    start(sim, overlay, offset, parse_area(list(area)))
