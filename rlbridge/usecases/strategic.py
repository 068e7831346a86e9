"""Strategic flight planning (macro): the agent is the planner of a departure schedule.

One agent, ``planner``, decides every departure request of the scenario
(:mod:`rlbridge.usecases.schedule`: its CRE / SCHEDULE lines) in filed order,
at the request's time: a departure delay of 0 .. ``max_delay_slots`` slots of
``slot_s`` and, where the network has several (``layers_ft``), the corridor
layer to fly (the flight keeps its filed altitude noise about the new layer),
or (``allow_reject``) no departure. The flights then fly in the simulation,
unequipped or with a tactical layer (``tactical``,
:mod:`rlbridge.usecases.tactical`), and the simulation measures their
safety. Observation (a Dict, or flat): the request, the conflicts of every
candidate with the planned traffic's 4-D intents
(:mod:`rlbridge.usecases.reservation`), the planned flights around it, its
vertiports' queues and the valid actions. Reward per decision: minus the
weighted delay, minus a penalty for a rejected (unplaced) request and per
planned flight its intent conflicts with, minus the NMAC and LoWC events the
simulation opened since the previous decision.

A request no slot within ``horizon_s`` can hold, or whose flight never flew in
the probe, is **unplaced**: reported (a warning naming it) and counted in the
metrics (``unplaced``, ``unplaced_flights``), never dropped silently. So is a
rejected request, or an action whose slot lies beyond the horizon.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar

import gymnasium as gym
import numpy as np

from aamsim.metrics import NotDeparted
from aamsim.stack.parser import TimedCommand
from aamsim.units import FT
from rlbridge.usecases.frozen import PolicySource
from rlbridge.usecases.protocol import Feedback, Observations, UseCaseBase, make_params
from rlbridge.usecases.reservation import Frame, Intent, IntentTable, probe_intents
from rlbridge.usecases.schedule import DepartureRequest, Schedule, split_schedule
from rlbridge.usecases.separation import apply_separation, check_distances, lowc_distance
from rlbridge.usecases.spec import SEPARATION_CURVE, CurveColumn, UseCaseSpec
from rlbridge.usecases.tactical import TacticalLayer
from rlbridge.usecases.variation import PAPER_ALT_NOISE_FT, add_altitude_noise

if TYPE_CHECKING:
    from aamsim import Simulation

PLANNER = "planner"
PLANNER_MODES = ("single", "vertiport")


def request_planner(req: DepartureRequest) -> str:
    """The planner of a request with one planner per vertiport: ``planner_<origin>`` (its ORIG), else ``planner``."""
    for cmd in req.commands:
        if cmd.command.name == "ORIG":
            words = cmd.command.argtext.replace(",", " ").split()
            if len(words) >= 2 and words[0].upper() == req.acid:
                return f"{PLANNER}_{words[1].upper()}"
    return PLANNER
PROBE_LIMIT_S = 24 * 3600.0  # a flight still flying a day after the last request ends its intent there


@dataclass(frozen=True)
class StrategicParams:
    """Use-case parameters (times in s, distances in m, altitudes in ft)."""

    slot_s: float = 60.0  # departure slot length
    max_delay_slots: int = 10  # delays 0 .. this many slots
    layers_ft: tuple[float, ...] = (500.0, 1200.0, 1900.0)  # the network's layers (docs/nyc-network.md); () = none
    allow_reject: bool = True  # an extra action: do not depart (the request is unplaced)
    horizon_s: float | None = None  # latest departure [s of sim time]; None: no limit
    # Intent conflict: 3-D distance below this [m]; None: the simulation's LoWC distance (the paper's 450 m).
    separation_m: float | None = None
    intent_grid_s: float = 5.0  # time grid of the intents (slot_s must be a multiple)
    n_planned: int = 16  # planned flights in the observation (closest in departure time)
    queue_window_s: float = 600.0  # vertiport queues count departures/arrivals within this
    tactical: str = "unequipped"  # tactical layer: a baseline name or a corridor training run / checkpoint
    # "single": one planner decides every request; "vertiport": one planner per origin vertiport
    # (planner_<ORIG>), each deciding its own requests (the AEC view, rlbridge.aec).
    planners: str = "single"
    tactical_interval_s: float = 10.0
    obs_format: str = "dict"  # "dict" or "flat" (the Dict flattened in its key order)
    # Reward
    delay_weight: float = 0.01  # per minute of departure delay
    reject_penalty: float = 1.0  # per unplaced request
    intent_conflict_penalty: float = 0.1  # per planned flight the accepted intent conflicts with
    nmac_penalty: float = 1.0  # per NMAC event opened since the last decision
    lowc_penalty: float = 0.1  # per LoWC event opened since the last decision
    nmac_m: float | None = None  # None: the simulation's separation standard (rlbridge.usecases.separation)
    lowc_m: float | None = None  # None: the simulation's separation standard
    scale_pos_m: float = 10000.0
    # The paper's altitude noise (uniform +-100 ft about the flight's layer), drawn per episode seed when
    # the flight takes off (rlbridge.usecases.variation): the planner's intents are probed at the filed
    # altitudes, the flights hold theirs imperfectly. 0 flies the scenario's altitudes.
    alt_noise_ft: float = PAPER_ALT_NOISE_FT

    def __post_init__(self) -> None:
        object.__setattr__(self, "layers_ft", tuple(float(x) for x in self.layers_ft))
        if self.alt_noise_ft < 0:
            raise ValueError("alt_noise_ft cannot be negative")
        if self.obs_format not in ("dict", "flat"):
            raise ValueError(f"obs_format must be 'dict' or 'flat', not {self.obs_format!r}")
        if self.planners not in PLANNER_MODES:
            raise ValueError(f"planners must be one of {', '.join(PLANNER_MODES)}, not {self.planners!r}")
        check_distances(self, "separation_m", "nmac_m", "lowc_m")
        for name in ("slot_s", "intent_grid_s", "queue_window_s", "scale_pos_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive")
        if self.max_delay_slots < 0 or self.n_planned < 1:
            raise ValueError("max_delay_slots must be >= 0 and n_planned >= 1")
        ratio = self.slot_s / self.intent_grid_s
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError(f"slot_s ({self.slot_s}) must be a multiple of intent_grid_s ({self.intent_grid_s})")


@dataclass
class Outcome:
    """What became of one request."""

    key: str
    request_s: float
    delay_s: float = 0.0
    layer: int = -1  # index in layers_ft (-1: the filed altitude, no layers)
    filed_layer: int = -1  # the layer the request was filed on
    unplaced: bool = False
    reason: str = ""
    intent_conflicts: int = 0
    planner: str = PLANNER  # the planner agent that decided it


@dataclass
class PlanData:
    """What one scenario gives the planner (computed once per scenario and time step)."""

    schedule: Schedule
    intents: dict[str, Intent]  # request key -> its intent on its filed layer
    layer_intents: list[dict[str, Intent]]  # per layer index: the intents flown on that layer ([intents] without)
    frame: Frame
    filed_layer: dict[str, int]  # request key -> nearest layer index (-1 without layers)
    ends: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)  # key -> origin, dest x/y [m]


@dataclass
class Episode:
    """The planner's state in one episode."""

    table: IntentTable
    next: int = 0
    outcomes: list[Outcome] = field(default_factory=list)
    # callsign -> (request key, altitude offset [m]) of each placed flight still to take off, in order
    pending: dict[str, list[tuple[str, float]]] = field(default_factory=dict)
    departed: set[str] = field(default_factory=set)  # request keys whose aircraft was created
    last: Outcome | None = None  # the decision whose feedback is due
    nmac_seen: int = 0
    lowc_seen: int = 0
    candidates: tuple[int, np.ndarray, np.ndarray] | None = None  # (request index, conflicts, closest)
    last_decider: str = PLANNER  # the planner that decided last (gets the interval's NMAC and LoWC)


PLANNING_METRICS = ("requests", "decided", "flights_planned", "unplaced", "unplaced_flights", "delayed_flights",
                    "mean_delay_s", "p95_delay_s", "max_delay_s", "layer_changes", "intent_conflicts", "arrivals",
                    "throughput_per_hour", "tactical_decisions")  # planning_metrics' keys


class StrategicPlanning(UseCaseBase):
    """``strategic_planning`` (``aamgym/StrategicPlanning-v1``): see the module docstring."""

    name = "strategic_planning"
    env_name = "StrategicPlanning"
    # Its planner agent chooses each departure's slot; it holds the scenario's departures back (not on
    # BlueSky's reader); ``tactical`` names a frozen policy (a baseline name or a run path).
    spec = UseCaseSpec(StrategicParams, action_kinds=("departure_slot",), baselines=("no_planning", "fcfs"),
                       advisory="tactical_layer", metrics=PLANNING_METRICS, aircraft_agents=False,
                       plans_departures=True, policy_params=("tactical",),
                       curve=(CurveColumn("mean_delay_s", "strategic_planning.mean_delay_s", per_aircraft=False),
                              CurveColumn("unplaced_per_aircraft", "strategic_planning.unplaced"),
                              CurveColumn("intent_conflicts_per_aircraft", "strategic_planning.intent_conflicts"),
                              *SEPARATION_CURVE))
    standing_agents: tuple[str, ...] = (PLANNER,)
    fixed_traffic: ClassVar[dict[str, Any]] = {"alt_noise_ft": 0.0}
    info_fields = {"delay_s": np.float64, "unplaced": np.bool_, "intent_conflicts": np.int64,  # noqa: RUF012
                   "nmac": np.int64, "lowc": np.int64}

    def __init__(self, policies: PolicySource | None = None, **params: Any):
        """``policies``: builds the frozen tactical layer named by ``tactical`` (rlbridge.usecases.frozen)."""
        if "layers_ft" in params:
            params["layers_ft"] = tuple(float(x) for x in params["layers_ft"])
        self.params: StrategicParams = make_params(StrategicParams, params)
        p = self.params
        self.n_layers = max(len(p.layers_ft), 1)
        self.n_delays = p.max_delay_slots + 1
        self.n_place = self.n_delays * self.n_layers
        self.n_actions = self.n_place + (1 if p.allow_reject else 0)
        big = np.float32(1e6)

        def box(*shape: int, low: float = -1e6) -> gym.spaces.Box:
            return gym.spaces.Box(np.float32(low), big, shape=shape, dtype=np.float32)

        self.dict_space = gym.spaces.Dict({
            "request": box(7), "conflicts": box(self.n_delays, self.n_layers, low=0.0),
            "closest": box(self.n_delays, self.n_layers, low=0.0), "planned": box(p.n_planned, 6),
            "planned_mask": gym.spaces.Box(0.0, 1.0, shape=(p.n_planned,), dtype=np.float32),
            "queues": box(2, 3, low=0.0),
            # int8, as Gymnasium's masked sampling (Discrete.sample(mask=...)) expects it
            "action_mask": gym.spaces.Box(0, 1, shape=(self.n_actions,), dtype=np.int8)})
        dim = int(gym.spaces.flatdim(self.dict_space))
        self._obs_space: gym.Space = self.dict_space if p.obs_format == "dict" else box(dim)
        self._act_space: gym.spaces.Discrete = gym.spaces.Discrete(self.n_actions)
        self.tactical = TacticalLayer(p.tactical, p.tactical_interval_s, policies=policies)
        self._plans: dict[tuple[str, float], PlanData] = {}
        self.plan: PlanData | None = None
        self.ep: Episode | None = None

    # ------------------------------------------------------------------ spaces
    def observation_space(self) -> gym.Space:
        return self._obs_space

    def action_space(self) -> gym.Space:
        return self._act_space

    def encode(self, delay_slots: int, layer: int) -> int:
        """The action of departing ``delay_slots`` late on layer index ``layer`` (0 without layers)."""
        return delay_slots * self.n_layers + max(layer, 0)

    @property
    def reject_action(self) -> int | None:
        return self.n_place if self.params.allow_reject else None

    # -------------------------------------------------------------- lifecycle
    def attach(self, sim: Simulation) -> None:
        p = self.params
        apply_separation(sim, p.nmac_m, p.lowc_m)
        sim.hooks.created.add(self._on_created, name="strategic.layer")
        add_altitude_noise(sim, p.alt_noise_ft, p.layers_ft, "strategic.alt_noise")
        self.tactical.attach(sim, sim.seed)

    def bind_scenario(self, commands: list[TimedCommand], is_command: Any) -> None:
        """With a planner per vertiport: the standing agents are the planners of the scenario's requests."""
        if self.params.planners == "vertiport":
            names = dict.fromkeys(request_planner(r) for r in split_schedule(commands, is_command).requests)
            self.standing_agents = tuple(names) or (PLANNER,)

    def separation_m(self, sim: Simulation) -> float:
        """The intent-conflict distance [m]: the parameter, or the simulation's LoWC distance."""
        p = self.params
        return float(p.separation_m) if p.separation_m is not None else lowc_distance(sim)

    def departure_planner(self) -> StrategicPlanning:
        """The planner that decides departure slots (a ``departure_slot`` use case's member): itself."""
        return self

    def decider(self) -> str:
        """The planner agent that decides the current request (``planner`` with a single planner)."""
        req = self.current() if self.plan is not None else None
        if self.params.planners == "single" or req is None:
            return PLANNER if self.params.planners == "single" else (self.ep.last_decider if self.ep else PLANNER)
        return request_planner(req)

    def scenario_commands(self, sim: Simulation, commands: list[TimedCommand]) -> list[TimedCommand]:
        """Hold back every request's block: the planner releases it when it decides."""
        key = (hashlib.sha256("\n".join(map(str, commands)).encode()).hexdigest(), float(sim.dt))
        if key not in self._plans:
            self._plans[key] = self._make_plan(sim, commands)
        self.plan = self._plans[key]
        self.ep = ep = Episode(IntentTable(self.plan.frame, self.params.intent_grid_s, self.separation_m(sim)))
        plan = self.plan
        # The flights held on the ground count in the episode's metrics (completed + unfinished + not
        # departed = scheduled; their delay runs to the end of the episode).
        sim.services.metrics.held_departures = lambda: not_departed(plan, ep)
        self._skip_unplaceable(sim)
        return list(self.plan.schedule.other)

    def _make_plan(self, sim: Simulation, commands: list[TimedCommand]) -> PlanData:
        schedule = split_schedule(commands, sim.commands.__contains__)
        last = max((r.request_s for r in schedule.requests), default=0.0)
        grid, limit = self.params.intent_grid_s, last + PROBE_LIMIT_S
        layers_m = np.array(self.params.layers_ft) * FT
        if len(layers_m):
            per_layer = [probe_intents(sim, schedule, grid, limit, layers_m, k) for k in range(len(layers_m))]
            nearest = {k: int(np.argmin(np.abs(layers_m - i.filed_alt_m))) for k, i in per_layer[0].items()}
            intents = {k: per_layer[layer][k] for k, layer in nearest.items()}
        else:
            intents = probe_intents(sim, schedule, grid, limit)
            per_layer = [intents]
        if intents:
            lat0 = float(np.mean([i.lat[0] for i in intents.values()]))
            lon0 = float(np.mean([i.lon[0] for i in intents.values()]))
        else:
            lat0 = lon0 = 0.0
        filed = {k: int(np.argmin(np.abs(layers_m - i.alt_m))) if len(layers_m) else -1 for k, i in intents.items()}
        frame = Frame(lat0, lon0)
        ends = {}
        for k, i in intents.items():
            x, y = frame.xy(i.lat[[0, -1]], i.lon[[0, -1]])
            ends[k] = (float(x[0]), float(y[0]), float(x[1]), float(y[1]))
        return PlanData(schedule, intents, per_layer, frame, filed, ends)

    def _on_created(self, sim: Simulation, slot: int) -> None:
        """A planned flight takes off on its planned layer (its filed noise about it kept)."""
        assert self.ep is not None
        pending = self.ep.pending.get(sim.view.ids[slot])
        if pending:
            key, dz = pending.pop(0)
            self.ep.departed.add(key)
            if dz:
                sim.offset_altitude(slot, dz)

    # ------------------------------------------------------------- decisions
    def current(self) -> DepartureRequest | None:
        """The request being decided (None when every request is decided)."""
        assert self.plan is not None and self.ep is not None
        reqs = self.plan.schedule.requests
        return reqs[self.ep.next] if self.ep.next < len(reqs) else None

    def agent_of(self, sim: Simulation, slot: int) -> str | None:
        return None  # the aircraft are not agents: the planner is

    def holding(self, sim: Simulation) -> bool:
        return self.plan is not None and self.current() is not None

    def next_decision_s(self, sim: Simulation) -> float:
        req = self.current() if self.plan is not None else None
        # One step ahead: the released commands then run at their time in the order the scenario
        # files them (after the conflict check and before the performance refresh of that instant).
        return math.inf if req is None else max(req.request_s - sim.dt, sim.simt)

    def _latest_slot(self, req: DepartureRequest) -> int:
        """The last delay slot within the horizon (-1: none)."""
        h = self.params.horizon_s
        if h is None:
            return self.params.max_delay_slots
        return min(self.params.max_delay_slots, math.floor((h - req.request_s) / self.params.slot_s + 1e-9))

    def _unplace(self, sim: Simulation, req: DepartureRequest, reason: str) -> Outcome:
        assert self.ep is not None
        out = Outcome(req.key, req.request_s, unplaced=True, reason=reason)
        self.ep.outcomes.append(out)
        src = req.commands[0].source
        sim.report("warning", f"{req.key}: departure request at {req.request_s:g} s not placed: {reason}", src)
        return out

    def _skip_unplaceable(self, sim: Simulation) -> None:
        """Requests no action can place are unplaced at once (reported and counted), not offered."""
        assert self.ep is not None and self.plan is not None
        while (req := self.current()) is not None:
            if req.key not in self.plan.intents:
                self._unplace(sim, req, "its flight never flew when the scenario was probed (see the errors above)")
            elif self._latest_slot(req) < 0:
                self._unplace(sim, req, f"no slot before the horizon ({self.params.horizon_s:g} s)")
            else:
                return
            self.ep.next += 1

    def candidate_table(self) -> tuple[np.ndarray, np.ndarray]:
        """Conflicts and closest predicted distance [m] of every (delay, layer) of the current request."""
        assert self.ep is not None and self.plan is not None
        req = self.current()
        if req is None:
            return np.zeros((self.n_delays, self.n_layers), np.int64), np.full((self.n_delays, self.n_layers), np.inf)
        if self.ep.candidates is None or self.ep.candidates[0] != self.ep.next:
            step = round(self.params.slot_s / self.params.intent_grid_s)
            alts = self._alts(req)
            flown = [self.plan.layer_intents[k][req.key] for k in range(self.n_layers)]
            conf, closest = self.ep.table.candidates(flown, req.request_s, self.n_delays, step, alts)
            self.ep.candidates = (self.ep.next, conf, closest)
        return self.ep.candidates[1], self.ep.candidates[2]

    def _alts(self, req: DepartureRequest) -> np.ndarray:
        """Altitude [m] the flight would fly on each layer (its filed altitude without layers)."""
        assert self.plan is not None
        return self.plan.intents[req.key].alt_m + self._layer_offsets(req)

    def _layer_offsets(self, req: DepartureRequest) -> np.ndarray:
        """Altitude change [m] from the filed layer to each layer (exactly 0 for the filed one)."""
        assert self.plan is not None
        if not self.params.layers_ft:
            return np.zeros(1)
        layers_m = np.array(self.params.layers_ft) * FT
        return layers_m - layers_m[self.plan.filed_layer[req.key]]

    def action_mask(self, req: DepartureRequest | None) -> np.ndarray:
        mask = np.zeros(self.n_actions, np.int8)
        if req is None:
            return mask
        mask[: (self._latest_slot(req) + 1) * self.n_layers] = 1
        if self.params.allow_reject:
            mask[self.n_place] = 1
        return mask

    def default_action(self) -> int:
        """No planning: depart on schedule on the filed layer."""
        assert self.plan is not None
        req = self.current()
        return 0 if req is None else self.encode(0, self.plan.filed_layer.get(req.key, 0))

    def apply_actions(self, sim: Simulation, actions: dict[str, Any]) -> None:
        assert self.plan is not None and self.ep is not None
        req = self.current()
        if req is None:
            return
        decider = self.decider()
        a = actions.get(decider)
        a = self.default_action() if a is None else int(a)
        if not 0 <= a < self.n_actions:
            raise ValueError(f"planner action {a} is not in 0..{self.n_actions - 1}")
        conf, _ = self.candidate_table()
        if a == self.reject_action:
            out = self._unplace(sim, req, "rejected by the planner")
        else:
            slot, layer = divmod(a, self.n_layers)
            if slot > self._latest_slot(req):
                out = self._unplace(sim, req, f"slot {slot} departs after the horizon ({self.params.horizon_s:g} s)")
            else:
                out = self._place(sim, req, slot, layer if self.params.layers_ft else -1, int(conf[slot, layer]))
        out.planner = self.ep.last_decider = decider
        self.ep.last = out
        self.ep.next += 1
        self._skip_unplaceable(sim)

    def _place(self, sim: Simulation, req: DepartureRequest, slot: int, layer: int, conflicts: int) -> Outcome:
        assert self.plan is not None and self.ep is not None
        delay = slot * self.params.slot_s
        intent = self.plan.intents[req.key]
        dz = float(self._layer_offsets(req)[max(layer, 0)])
        flown = self.plan.layer_intents[max(layer, 0)][req.key]
        self.ep.table.reserve(req.key, flown, req.request_s + delay, intent.alt_m + dz)
        self.ep.pending.setdefault(req.acid, []).append((req.key, dz))
        # A decision can come a step after its request (the engine advances by at least one step):
        # commands already due run at once.
        for cmd in req.shifted(delay):
            sim.queue.push(cmd if cmd.time_s >= sim.simt else TimedCommand(sim.simt, cmd.command, cmd.source))
        out = Outcome(req.key, req.request_s, delay, layer, self.plan.filed_layer[req.key], intent_conflicts=conflicts)
        self.ep.outcomes.append(out)
        return out

    # ------------------------------------------------------------ observation
    def observe_parts(self, sim: Simulation) -> dict[str, np.ndarray]:
        """The Dict observation of the current request (zeros when none is left)."""
        assert self.plan is not None and self.ep is not None
        p = self.params
        parts: dict[str, np.ndarray] = {name: np.zeros(sp.shape or (), sp.dtype)
                                        for name, sp in self.dict_space.spaces.items()}
        req = self.current()
        parts["action_mask"] = self.action_mask(req)
        if req is None:
            return parts
        intent = self.plan.intents[req.key]
        conf, closest = self.candidate_table()
        parts["conflicts"] = conf.astype(np.float32)
        parts["closest"] = np.minimum(closest / self.ep.table.separation_m, 10.0).astype(np.float32)
        ox, oy, dx, dy = self.plan.ends[req.key]
        s = p.scale_pos_m
        filed = self.plan.filed_layer[req.key]
        parts["request"] = np.array([req.request_s / 3600.0, ox / s, oy / s, dx / s, dy / s,
                                     intent.duration_s / 600.0, max(filed, 0) / max(self.n_layers - 1, 1)],
                                    np.float32)
        parts["planned"], parts["planned_mask"] = self._planned(req, ox, oy)
        parts["queues"] = self._queues(req, intent)
        return parts

    def _planned(self, req: DepartureRequest, ox: float, oy: float) -> tuple[np.ndarray, np.ndarray]:
        """The planned flights departing closest in time to the request: time, origin, destination, layer."""
        assert self.plan is not None and self.ep is not None
        n = self.params.n_planned
        rows = np.zeros((n, 6), np.float32)
        mask = np.zeros(n, np.float32)
        placed = [o for o in self.ep.outcomes if not o.unplaced]
        placed.sort(key=lambda o: abs(o.request_s + o.delay_s - req.request_s))
        s = self.params.scale_pos_m
        for k, o in enumerate(placed[:n]):
            x0, y0, x1, y1 = self.plan.ends[o.key]
            rows[k] = [(o.request_s + o.delay_s - req.request_s) / 600.0, (x0 - ox) / s, (y0 - oy) / s,
                       (x1 - ox) / s, (y1 - oy) / s, max(o.layer, 0) / max(self.n_layers - 1, 1)]
            mask[k] = 1.0
        return rows, mask

    def _queues(self, req: DepartureRequest, intent: Intent) -> np.ndarray:
        """At the request's origin and destination: planned departures not yet gone, and departures and
        arrivals planned within ``queue_window_s`` of the request."""
        assert self.plan is not None and self.ep is not None
        out = np.zeros((2, 3), np.float32)
        w, t = self.params.queue_window_s, req.request_s
        for o in self.ep.outcomes:
            if o.unplaced:
                continue
            it = self.plan.intents[o.key]
            dep = o.request_s + o.delay_s
            arr = dep + it.duration_s
            for row, vp in enumerate((intent.origin, intent.destination)):
                if vp and it.origin == vp:
                    out[row, 0] += dep > t
                    out[row, 1] += abs(dep - t) <= w
                if vp and it.destination == vp:
                    out[row, 2] += abs(arr - t) <= w
        return out

    def observe(self, sim: Simulation, agents: list[str]) -> Observations:
        parts = self.observe_parts(sim)
        stacked = {k: np.repeat(v[None], len(agents), axis=0) for k, v in parts.items()}
        if self.params.planners == "vertiport":  # only the deciding planner has a request (and valid actions)
            idle = np.array([a != self.decider() for a in agents], dtype=bool)
            for arr in stacked.values():
                arr[idle] = 0
        if self.params.obs_format == "dict":
            return Observations(parts=stacked)
        flat = np.concatenate([stacked[k].reshape(len(agents), -1) for k in self.dict_space.spaces], axis=1)
        return Observations(flat=flat.astype(np.float32))

    def as_parts(self, obs: Observations, k: int) -> dict[str, np.ndarray]:
        """Row ``k`` of an observation as the Dict's parts (either format)."""
        if obs.parts is not None:
            return {name: arr[k] for name, arr in obs.parts.items()}
        assert obs.flat is not None
        return dict(gym.spaces.unflatten(self.dict_space, obs.flat[k]))

    # ---------------------------------------------------------------- reward
    def feedback(self, sim: Simulation, agents: list[str], actions: dict[str, Any], since_s: float) -> Feedback:
        n = len(agents)
        info = {"delay_s": np.zeros(n), "unplaced": np.zeros(n, np.bool_), "intent_conflicts": np.zeros(n, np.int64),
                "nmac": np.zeros(n, np.int64), "lowc": np.zeros(n, np.int64)}
        rewards = np.zeros(n)
        who = PLANNER if self.params.planners == "single" or self.ep is None else self.ep.last_decider
        if who not in agents or self.ep is None:
            return Feedback(rewards, info)
        k = agents.index(who)
        service = sim.services.conflicts
        nmac, lowc = service.count("nmac") - self.ep.nmac_seen, service.count("lowc") - self.ep.lowc_seen
        self.ep.nmac_seen += nmac
        self.ep.lowc_seen += lowc
        p = self.params
        r = -p.nmac_penalty * nmac - p.lowc_penalty * lowc
        out, self.ep.last = self.ep.last, None
        if out is not None:
            r -= p.delay_weight * out.delay_s / 60.0 + p.intent_conflict_penalty * out.intent_conflicts
            r -= p.reject_penalty if out.unplaced else 0.0
            info["delay_s"][k], info["unplaced"][k] = out.delay_s, out.unplaced
            info["intent_conflicts"][k] = out.intent_conflicts
        info["nmac"][k], info["lowc"][k] = nmac, lowc
        rewards[k] = r
        return Feedback(rewards, info)

    # --------------------------------------------------------------- metrics
    def extra_metrics(self, sim: Simulation) -> dict[str, Any]:
        if self.ep is None or self.plan is None:
            return {}
        return planning_metrics(self.ep.outcomes, len(self.plan.schedule.requests), sim, self.tactical.decisions)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self.params)


def not_departed(plan: PlanData, ep: Episode) -> list[NotDeparted]:
    """The scheduled flights that have not taken off: unplaced (rejected, beyond the horizon, never flew in
    the probe), placed but not created yet (a slot after the end), and not decided yet. Each with its filed
    departure and arrival (the RTA at its destination, as the probe flew it)."""
    decided = {o.key for o in ep.outcomes}
    held = [o.key for o in ep.outcomes if o.key not in ep.departed]
    held += [r.key for r in plan.schedule.requests if r.key not in decided]
    filed = {r.key: r.request_s for r in plan.schedule.requests}
    return [NotDeparted(k, filed[k], plan.intents[k].scheduled_arrival_s if k in plan.intents else math.nan)
            for k in held]


def planning_metrics(outcomes: list[Outcome], requests: int, sim: Simulation, tactical_decisions: int) -> dict[str, Any]:
    """The planner's metrics: flights planned, unplaced, departure delays, throughput."""
    placed = [o for o in outcomes if not o.unplaced]
    delays = np.array([o.delay_s for o in placed])
    unplaced = [o for o in outcomes if o.unplaced]
    keys = {o.key for o in placed}
    arrived = [f for f in sim.flight_log if f.arrived and f.acid in {k.split("#")[0] for k in keys}]
    first = min((o.request_s for o in outcomes), default=0.0)
    last_arrival = max((f.deleted_s for f in arrived), default=first)
    span_h = (last_arrival - first) / 3600.0
    return {
        "requests": requests, "decided": len(outcomes), "flights_planned": len(placed), "unplaced": len(unplaced),
        "unplaced_flights": [o.key for o in unplaced],
        "delayed_flights": int(np.count_nonzero(delays > 0)),
        "mean_delay_s": float(delays.mean()) if len(delays) else None,
        "p95_delay_s": float(np.percentile(delays, 95)) if len(delays) else None,
        "max_delay_s": float(delays.max()) if len(delays) else None,
        "layer_changes": sum(1 for o in placed if o.layer != o.filed_layer),
        "intent_conflicts": int(sum(o.intent_conflicts for o in placed)),
        "arrivals": len(arrived),
        "throughput_per_hour": len(arrived) / span_h if span_h > 0 else None,
        "tactical_decisions": tactical_decisions,
    }
