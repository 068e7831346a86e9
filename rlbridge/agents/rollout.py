"""Episode collection on any episode backend with batched inference.

A :class:`RolloutWorker` owns one episode backend (:mod:`rlbridge.backends`: aamsim in
process, a simulation server over ZeroMQ, or BlueSky) and one *actor* (the acting half of
an algorithm, or a baseline). Every decision step it calls the actor once on the
observations of all agents reported by the environment (a single batched forward pass,
no per-agent network calls) and steps the episode with the actions of the agents that
continue. An actor sees the episode as a step result plus, when it asks for traffic fields
(``snapshot_fields``), a frozen :class:`~aamsim.snapshots.TrafficSnapshot` of them, which
every backend provides (over ZeroMQ it crosses the wire bit for bit): never the
simulation, so the same actor runs on every backend. The same class runs in-process
(``workers=0``) and as a Ray actor (``ray.remote(RolloutWorker)``).

Trajectories come back as an :class:`EpisodeBatch` of numpy arrays. Every observation the
environment returned is stored once, as one *row* (``M`` rows); a transition ``t`` (``T`` of
them) refers to the row it acted on (``obs_idx``) and the row of the agent's next
observation (``next_idx``), which is either the row it acts on next or its final
observation (arrival or truncation). Learners recover per-agent chains from the indices
(:meth:`EpisodeBatch.chains`), so agents that appear and leave need no padding.
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from aamsim.scenarios import resolve_scenario
from rlbridge.backends import BACKENDS, EpisodeBackend, make_backend
from rlbridge.core import StepResult
from rlbridge.policies import make_usecase_with_policies
from rlbridge.usecases.registry import Observations
from rlbridge.usecases.spec import metric_node, spec_of
from rlbridge.usecases.targets import reads_action_targets
from rlbridge.vector.engine import VectorEngine

if TYPE_CHECKING:
    from aamsim.snapshots import TrafficSnapshot
    from rlbridge.core import EpisodeCore

@dataclass
class ActOutput:
    """An actor's answer for the rows of one step (None: not provided)."""

    actions: np.ndarray | None  # (n,) int; None = no advisory for anyone (unequipped)
    logp: np.ndarray | None = None  # (n,) log-probability of the chosen action
    values: np.ndarray | None = None  # (n,) state value of every row (final rows included)
    advise: np.ndarray | None = None  # (n,) bool: rows that get an advisory (None: all of them)


class Actor(Protocol):
    """The acting half of an algorithm or a baseline, run inside a worker (docs/algorithms.md).

    ``act`` reads the step result, the traffic snapshot of ``snapshot_fields`` (None when the
    actor asks for no field: the observations are all it reads) and ``rng``, the episode's
    action generator: every episode gets its own, so an actor that keeps state per episode
    starts afresh when it sees a new generator. Optional members: ``act_many`` (several
    episodes in one call, :func:`act_batched`) and ``check_usecase(usecase)`` (raise when the
    use case's actions do not fit the actor; called before its first episode).
    """

    obs_format: str | None  # "flat" / "dict" required from the use case (None: any)
    snapshot_fields: tuple[str, ...]  # traffic fields read each decision (aamsim.traffic.view.PUBLIC_FLOATS)

    def set_weights(self, weights: Any) -> None: ...

    def act(self, result: StepResult, snapshot: TrafficSnapshot | None, rng: np.random.Generator,
            explore: dict[str, Any]) -> ActOutput: ...


def policy_input(actor: Any, episode: Any) -> Any:
    """What ``actor.act`` reads besides the step result: a snapshot of its fields, or None."""
    fields = tuple(getattr(actor, "snapshot_fields", ()))
    return episode.snapshot(fields) if fields else None


@dataclass
class EpisodeStats:
    """What one episode produced (units in the names; rewards are the use case's)."""

    seed: int
    scenario: str
    scenario_sha256: str
    aircraft: int  # flights created during the episode
    transitions: int  # aircraft-states generated for learning (agent decisions)
    reward_total: float  # sum of every agent's rewards
    reward_per_aircraft: float  # reward_total / aircraft (the learning-curve reward)
    # The separation counts of the standard safety group (metrics["safety"]), kept as fields: the
    # evaluation's episodes.csv and evaluation.json are written from them.
    nmac_events: int
    lowc_events: int
    sim_s: float
    wall_s: float
    metrics: dict[str, Any] = field(default_factory=dict)  # standard groups and the use case's extra_metrics
    # Environment steps: decisions of the multi-agent environment (one advances every aircraft by the
    # decision interval), what RLlib counts by default (count_steps_by="env_steps").
    env_steps: int = 0
    # The metrics the use case declares (UseCaseSpec.declared_metrics: its learning-curve columns'
    # and its extra_metrics), dotted path -> this episode's value as its metrics hold it (a number, a
    # list of them; None where it has none), whatever the use case: "safety.nmac_events" for the
    # corridor, "reach_destination.arrivals", "strategic_planning.mean_delay_s", ...
    declared: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def summary(self) -> dict[str, Any]:
        """The ``aamsim run`` summary.json schema (what ``aamsim compare`` reads)."""
        out: dict[str, Any] = {"scenario": self.scenario, "scenario_sha256": self.scenario_sha256,
                               "seed": self.seed, "sim_time_s": self.sim_s, "wall_time_s": round(self.wall_s, 4),
                               "flights_created": self.aircraft, "aircraft_states": self.transitions,
                               "reward_total": self.reward_total}
        out.update(self.metrics)
        return out


@dataclass
class EpisodeBatch:
    """The trajectories of every agent of one episode (see the module docstring)."""

    obs: dict[str, np.ndarray]  # name -> (M, ...); a flat use case gives {"flat": (M, dim)}
    values: np.ndarray  # (M,) float32, the actor's value of each row (zeros without a critic)
    obs_idx: np.ndarray  # (T,) int64
    next_idx: np.ndarray  # (T,) int64, > obs_idx
    actions: np.ndarray  # (T,) int64
    logp: np.ndarray  # (T,) float32
    rewards: np.ndarray  # (T,) float32
    terminated: np.ndarray  # (T,) bool: the agent left (arrived/deleted) after this transition
    truncated: np.ndarray  # (T,) bool: the episode was cut with the agent still flying
    agent: np.ndarray  # (T,) int32, index in ``agents``
    agents: list[str]
    stats: EpisodeStats

    def __len__(self) -> int:
        return int(self.actions.shape[0])

    @classmethod
    def empty(cls, stats: EpisodeStats) -> EpisodeBatch:
        """No trajectories, only the statistics (evaluation runs)."""
        i, f, b = np.zeros(0, np.int64), np.zeros(0, np.float32), np.zeros(0, bool)
        return cls({}, f, i, i, i, f, f, b, b, np.zeros(0, np.int32), [], stats)

    def chains(self) -> tuple[np.ndarray, np.ndarray]:
        """``(next_t, ends)``: each transition's successor in its agent's chain (-1 if none) and chain ends."""
        pos = np.full(self.values.shape[0], -1, dtype=np.int64)
        pos[self.obs_idx] = np.arange(len(self))
        next_t = pos[self.next_idx]
        ends = self.terminated | self.truncated | (next_t < 0)
        return next_t, ends


def obs_dict(obs: Observations) -> dict[str, np.ndarray]:
    if obs.parts is not None:
        return dict(obs.parts)
    assert obs.flat is not None
    return {"flat": obs.flat}


def to_observations(arrays: dict[str, np.ndarray]) -> Observations:
    if set(arrays) == {"flat"}:
        return Observations(flat=arrays["flat"])
    return Observations(parts=arrays)


ROLLOUT_BACKENDS = BACKENDS


@dataclass(frozen=True)
class EnvSpec:
    """Everything a worker needs to build its episode backend (plain data: it crosses processes)."""

    scenario: str  # a path (absolute for remote workers) or a shipped scenario name
    usecase: str = "corridor_sa"
    params: dict[str, Any] = field(default_factory=dict)  # use-case parameters
    time_limit_s: float | None = None  # None: the engine's default (last command + 2 h)
    dt: float = 0.05  # simulation step [s]
    metrics: tuple[str, ...] = ("safety", "operational")  # metric groups of each episode
    # Where the episodes run (rlbridge.backends): "local" (aamsim in this process), "zmq" (a simulation
    # server at ``address``) or "bluesky" (BlueSky flies the aircraft); the actors see step results and
    # traffic snapshots on each.
    backend: str = "local"
    address: str | None = None  # the server of backend "zmq" ("tcp://host:port")
    timeout_s: float = 30.0  # backend "zmq": the longest wait for one reply [s]

    def __post_init__(self) -> None:
        if self.backend not in ROLLOUT_BACKENDS:
            raise ValueError(f"backend {self.backend!r}: rollouts run on {', '.join(map(repr, ROLLOUT_BACKENDS))}")
        if self.backend == "zmq" and not self.address:
            raise ValueError('backend "zmq" needs the address of a simulation server (address="tcp://host:port", '
                             "from `aamsim serve`)")

    def make(self, obs_format: str | None = None) -> EpisodeBackend:
        """The episode backend, with the use case's observations in ``obs_format`` (None: its default)."""
        from rlbridge.agents import has_obs_format

        params = dict(self.params)
        # A use case without the parameter has one observation (flat): DDQN's format, nothing to choose.
        if obs_format is not None and has_obs_format(self.usecase):
            params["obs_format"] = obs_format
        return make_backend(self.scenario, self.usecase, params, self.backend, self.address, self.time_limit_s,
                            self.dt, self.timeout_s)

    def make_engine(self, episodes: int, obs_format: str | None = None) -> VectorEngine:
        """``episodes`` episode engines stepped together in one world set (backend ``local`` only)."""
        if self.backend != "local":
            raise ValueError(f"lockstep episodes step in one world set of this process: they need backend=local, "
                             f"not {self.backend!r} (run one episode at a time there: lockstep=False)")
        params = dict(self.params)
        if obs_format is not None:
            params["obs_format"] = obs_format
        return VectorEngine(self.scenario, self.usecase, params, episodes, self.time_limit_s, self.dt)


class RolloutWorker:
    """One episode backend per observation format + named actors; collects whole episodes.

    Args:
        env: how to build the episode backend.
        actors: name -> actor spec (what :func:`rlbridge.agents.make_actor` builds), e.g.
            ``{"policy": learner.actor_spec(...), "unequipped": {"kind": "unequipped"}}``.
        torch_threads: intra-op threads of the worker's PyTorch (1 is fastest on few cores).
    """

    def __init__(self, env: EnvSpec, actors: dict[str, dict[str, Any]], torch_threads: int = 1):
        from rlbridge.agents import make_actor

        if torch_threads > 0:
            import torch

            torch.set_num_threads(torch_threads)
        self.env = env
        self.actors: dict[str, Actor] = {name: make_actor(spec) for name, spec in actors.items()}
        self._cores: dict[str | None, EpisodeBackend] = {}
        self._engines: dict[tuple[str | None, int], VectorEngine] = {}  # lockstep episodes, by format and number
        self._checked: set[str] = set()  # actors whose fit to the use case was checked
        first = self._core_for(next(iter(self.actors.values())) if self.actors else None)
        path = getattr(first, "path", None) or resolve_scenario(env.scenario)  # a server resolves its own copy
        text = getattr(first, "text", None)
        if text is None and path is not None:
            text = Path(path).read_text(encoding="utf-8", errors="replace")
        self.scenario_name = Path(path or env.scenario).stem
        # The metrics the use case declares, recorded in each episode's statistics (EpisodeStats.declared).
        usecase = getattr(first, "usecase", None) or make_usecase_with_policies(env.usecase, **env.params)
        self.declared_metrics = spec_of(usecase).declared_metrics(usecase.name)
        # "" where the scenario is known to the server only (backend zmq).
        self.scenario_sha256 = hashlib.sha256(text.encode("utf-8")).hexdigest() if text is not None else ""

    def _core_for(self, actor: Actor | None) -> EpisodeBackend:
        """The episode backend in ``actor``'s observation format (made once)."""
        fmt = None if actor is None else actor.obs_format
        if fmt not in self._cores:
            if self.env.backend == "bluesky":  # BlueSky is process-global: one episode engine at a time
                for core in self._cores.values():
                    core.close()
                self._cores.clear()
            self._cores[fmt] = self.env.make(fmt)
        return self._cores[fmt]

    def _check(self, name: str) -> None:
        """Refuse an actor whose actions do not fit the use case (its ``check_usecase``), once per actor."""
        if name in self._checked:
            return
        check = getattr(self.actors[name], "check_usecase", None)
        if check is not None:
            usecase = getattr(self._core_for(self.actors[name]), "usecase", None)
            check(usecase if usecase is not None else make_usecase_with_policies(self.env.usecase, **self.env.params))
        self._checked.add(name)

    def set_weights(self, weights: Any, actor: str = "policy") -> None:
        self.actors[actor].set_weights(weights)

    def collect(self, seeds: list[int], actor: str = "policy", weights: Any = None,
                explore: dict[str, Any] | None = None, record: bool = True, lockstep: bool = False) -> list[Any]:
        """Run one episode per seed: :class:`EpisodeBatch` each when ``record`` else :class:`EpisodeStats`.

        ``lockstep``: play them side by side with batched inference (:meth:`run_lockstep`), the
        same episodes as one after the other.
        """
        if weights is not None:
            self.actors[actor].set_weights(weights)
        groups = [list(seeds)] if lockstep else [[s] for s in seeds]
        out: list[Any] = []
        for group in groups:
            for batch in self.run_lockstep([int(s) for s in group], explore or {}, record, actor):
                out.append(batch if record else batch.stats)
        return out

    def run_episode(self, seed: int, explore: dict[str, Any], record: bool = True,
                    actor: str = "policy") -> EpisodeBatch:
        """One episode with actor ``actor``; the trajectories (when ``record``) and its statistics."""
        return self.run_lockstep([seed], explore, record, actor)[0]

    def run_lockstep(self, seeds: list[int], explore: dict[str, Any], record: bool = True,
                     actor: str = "policy") -> list[EpisodeBatch]:
        """The episodes of ``seeds`` side by side, one actor call per decision step for all of them.

        Every episode keeps its own engine and its own action generator (seeded from its seed), so
        each episode is the one :meth:`run_episode` plays alone; the actor sees the aircraft of
        all episodes in one batch (:func:`act_batched`), which pays its per-call cost once, and
        the simulations step together (:class:`~rlbridge.vector.engine.VectorEngine`: one kernel
        call per batch for all of them). An episode that ends stops; the others go on.
        """
        self._check(actor)
        act = self.actors[actor]
        t0 = time.perf_counter()
        engine = self._engine_for(act, len(seeds)) if len(seeds) > 1 else None
        cores: list[Any]
        if engine is not None:
            cores = engine.cores
            for core in cores:
                core.publish_targets = reads_action_targets(act)
            started = engine.reset(dict(enumerate(seeds)))
            results = [started[k] for k in range(len(seeds))]
        else:
            cores = [self._core_for(act)]
            cores[0].publish_targets = reads_action_targets(act)  # the action targets only for an actor that reads them
            results = [cores[0].reset(seeds[0])]
        runs = [_EpisodeRun(self, core, int(s), record, result, t0) for core, s, result in zip(cores, seeds, results)]
        active = list(range(len(runs)))
        while active:
            asking = [runs[k] for k in active if runs[k].wants_actor()]
            outs = act_batched(act, [r.result for r in asking], [policy_input(act, r.core) for r in asking],
                               [r.rng for r in asking], explore) if asking else []
            answer = dict(zip(map(id, asking), outs))
            steps = {}
            for k in active:
                actions = runs[k].advance(answer.get(id(runs[k]), ActOutput(None)))
                if actions is not None:
                    steps[k] = actions
            stepped = engine.step(steps) if engine is not None else {k: runs[k].core.step(a) for k, a in steps.items()}
            for k, result in stepped.items():
                runs[k].result = result
            active = [k for k in active if not runs[k].finished]
        return [r.batch() for r in runs]

    def _engine_for(self, actor: Actor, k: int) -> VectorEngine:
        """The engine of ``k`` lockstep episodes in ``actor``'s observation format (made once)."""
        key = (actor.obs_format, k)
        if key not in self._engines:
            self._engines[key] = self.env.make_engine(k, actor.obs_format)
        return self._engines[key]


def act_batched(actor: Actor, results: list[StepResult], snapshots: list[Any], rngs: list[np.random.Generator],
                explore: dict[str, Any]) -> list[ActOutput]:
    """One :class:`ActOutput` per episode; one forward pass for all when the actor has ``act_many``.

    ``snapshots``: each episode's :func:`policy_input` (a traffic snapshot, None, or the episode
    for a simulation-bound baseline).
    """
    many = getattr(actor, "act_many", None)
    if many is not None and len(results) > 1:
        return list(many(results, snapshots, rngs, explore))
    return [actor.act(r, c, g, explore) for r, c, g in zip(results, snapshots, rngs)]


def time_limit_counts(core: EpisodeBackend | EpisodeCore, result: StepResult) -> dict[str, int | None]:
    """Aircraft still flying when the time limit cut the episode, and of them those hovering.

    ``parked_at_time_limit`` counts the aircraft cut by the limit with a ground speed under the
    simulation's holding threshold (``hold_speed_mps``, 5 kt): a policy that parks aircraft in
    the air rather than resolve a conflict leaves them there (the corridor use case's "hold"
    keeps 0 kt for free). None where the engine does not expose aamsim's traffic (BlueSky).
    """
    sim = getattr(core, "sim", None)
    view = getattr(sim, "view", None)
    cut = [a for a, t in zip(result.agents, result.truncated) if t]
    if sim is None or view is None or not hasattr(sim, "settings"):
        return {"airborne_at_time_limit": len(cut), "parked_at_time_limit": None}
    # Only agents that are aircraft: a planner (strategic planning) is an agent with no aircraft.
    slots = [slot for slot in (view.find(a) for a in cut) if slot is not None]
    cut = cut if len(slots) == len(cut) else [a for a in cut if view.find(a) is not None]
    threshold = float(sim.settings.hold_speed_mps)
    parked = sum(1 for slot in slots if abs(float(view.gs[slot])) < threshold)
    return {"airborne_at_time_limit": len(cut), "parked_at_time_limit": parked}


class _EpisodeRun:
    """One episode being played: its engine, generator, recorder and counters."""

    def __init__(self, worker: RolloutWorker, core: Any, seed: int, record: bool, result: StepResult,
                 t0: float):
        self.worker, self.core, self.seed = worker, core, seed
        self.rng = np.random.default_rng(np.random.SeedSequence([seed, 0x5EED]))
        self.t0 = t0
        self.result = result
        self.rec = TrajectoryRecorder() if record else None
        self.transitions = 0
        self.env_steps = 0
        self.reward_total = 0.0
        self.pending: dict[str, tuple[int, int, float]] = {}  # agent -> (row, action, logp) of its last decision
        self.finished = False
        self._batch: EpisodeBatch | None = None

    def wants_actor(self) -> bool:
        # At the end, agents cut by the time limit bootstrap from the critic's value of their last
        # observation (GAE, docs/algorithms.md): the actor runs once more, for the values only
        # (arrived agents' values are stored too but never used: terminated, bootstrap 0).
        return not self.result.done or (self.rec is not None and len(self.result.agents) > 0)

    def advance(self, out: ActOutput) -> dict[str, int] | None:
        """Record the step's rows with the actor's answer; the actions to step with (None: finished)."""
        result = self.result
        if result.done:
            out = ActOutput(None, values=out.values)
        rows = self.rec.add(result, out, self.pending) if self.rec is not None \
            else np.zeros(len(result.agents), np.int64)
        self.transitions += len(self.pending)
        self.reward_total += float(np.sum(result.rewards))
        if result.done:
            self._finish()
            return None
        alive = set(result.alive)
        acting = [k for k, a in enumerate(result.agents) if a in alive]
        if out.actions is None:
            actions: dict[str, int] = {}
            act_rows = np.ones(len(acting), np.int64)  # recorded as hold (1): no advisory given
        else:
            act_rows = np.asarray(out.actions, np.int64)[acting]
            given = np.ones(len(acting), bool) if out.advise is None else np.asarray(out.advise, bool)[acting]
            actions = {result.agents[k]: int(a) for k, a, g in zip(acting, act_rows, given) if g}
        lp = np.zeros(len(acting), np.float32) if out.logp is None else np.asarray(out.logp)[acting]
        self.pending = {result.agents[k]: (int(rows[k]), int(act_rows[i]), float(lp[i]))
                        for i, k in enumerate(acting)}
        self.env_steps += 1  # the engine steps it with these actions
        return actions

    def _finish(self) -> None:
        w, core, result = self.worker, self.core, self.result
        metrics = core.metrics(tuple(dict.fromkeys(("safety",) + tuple(w.env.metrics))))
        if "operational" in metrics and "airborne_at_time_limit" not in metrics["operational"]:
            # An engine that does not count them itself (a server from before EpisodeCore did).
            metrics["operational"].update(time_limit_counts(core, result))
        safety = metrics.get("safety", {})
        aircraft = int(metrics.get("operational", {}).get("flights") or len(core.possible_agents))
        stats = EpisodeStats(
            seed=self.seed, scenario=w.scenario_name, scenario_sha256=w.scenario_sha256, aircraft=aircraft,
            transitions=self.transitions, reward_total=self.reward_total,
            reward_per_aircraft=self.reward_total / max(aircraft, 1),
            nmac_events=int(safety.get("nmac_events", 0)), lowc_events=int(safety.get("lowc_events", 0)),
            sim_s=float(result.simt), wall_s=time.perf_counter() - self.t0, metrics=metrics,
            env_steps=self.env_steps, declared={path: metric_node(metrics, path) for path in w.declared_metrics})
        self._batch = self.rec.batch(stats) if self.rec is not None else EpisodeBatch.empty(stats)
        self.finished = True

    def batch(self) -> EpisodeBatch:
        assert self._batch is not None, "the episode is not finished"
        return self._batch


class TrajectoryRecorder:
    """Accumulates the rows and transitions of one episode (see the module docstring)."""

    def __init__(self) -> None:
        self.m = 0  # rows stored so far
        self.obs: list[dict[str, np.ndarray]] = []
        self.values: list[np.ndarray] = []
        self.cols: dict[str, list[np.ndarray]] = {k: [] for k in ("obs_idx", "next_idx", "actions", "logp",
                                                                   "rewards", "terminated", "truncated", "agent")}
        self.agent_index: dict[str, int] = {}

    def add(self, result: StepResult, out: ActOutput, pending: dict[str, tuple[int, int, float]]) -> np.ndarray:
        """Store a step's observations as rows and close the pending decisions; returns the new rows."""
        n = len(result.agents)
        rows = self.m + np.arange(n)
        self.obs.append(obs_dict(result.obs))
        self.values.append(np.asarray(out.values if out.values is not None else np.zeros(n), np.float32))
        if pending:
            row_of = {a: k for k, a in enumerate(result.agents)}
            names = list(pending)
            ks = np.array([row_of[a] for a in names], dtype=np.int64)
            c = self.cols
            c["obs_idx"].append(np.array([pending[a][0] for a in names], dtype=np.int64))
            c["next_idx"].append(rows[ks])
            c["actions"].append(np.array([pending[a][1] for a in names], dtype=np.int64))
            c["logp"].append(np.array([pending[a][2] for a in names], dtype=np.float32))
            c["rewards"].append(result.rewards[ks].astype(np.float32))
            c["terminated"].append(result.terminated[ks])
            c["truncated"].append(result.truncated[ks])
            c["agent"].append(np.array([self.agent_index.setdefault(a, len(self.agent_index)) for a in names],
                                       dtype=np.int32))
        self.m += n
        return rows

    def batch(self, stats: EpisodeStats) -> EpisodeBatch:
        dtypes = {"obs_idx": np.int64, "next_idx": np.int64, "actions": np.int64, "logp": np.float32,
                  "rewards": np.float32, "terminated": bool, "truncated": bool, "agent": np.int32}
        cols = {k: np.concatenate(v).astype(dtypes[k], copy=False) if v else np.zeros(0, dtypes[k])
                for k, v in self.cols.items()}
        obs = {k: np.concatenate([c[k] for c in self.obs]) for k in self.obs[0]}
        agents = sorted(self.agent_index, key=self.agent_index.__getitem__)
        return EpisodeBatch(obs=obs, values=np.concatenate(self.values), agents=agents, stats=stats, **cols)
