"""What the rule-based baselines need of a use case, published with each step result.

A baseline that steers with a use case's own actions needs to know what each action would
set (``mvp`` and ``daa``: the speed, track or altitude), and a planner baseline (``fcfs``,
``no_planning``) what the departure planner offers for the request being decided. A use case
computes these from its routes and its per-episode state, which only exist where the
simulation runs. The episode engine therefore adds them to every step result
(:func:`step_info`), so they cross the wire with the result and the baselines act on the
result and a traffic snapshot, on every backend:

* ``info["action_targets"]`` for a use case with speed, heading or altitude actions
  (:meth:`rlbridge.usecases.protocol.UseCaseBase.action_targets`);
* ``info["departure_request"]`` for a use case with departure-slot actions
  (:func:`departure_request_info`).

Both cost a computation per decision, which a learner never reads: the action targets are
published only while an actor that asks for them plays (``reads_action_targets = True``,
:func:`reads_action_targets`; ``EpisodeCore.publish_targets``; over ZeroMQ the ``targets``
field of a ``reset``). The departure request is published for departure-slot use cases only.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rlbridge.usecases.spec import spec_of

MANOEUVRE_KINDS = ("heading", "altitude")
TARGET_KINDS = ("speed", *MANOEUVRE_KINDS)  # the kinds whose action targets are published
TARGETS_KEY = "action_targets"  # the step result's info key
REQUEST_KEY = "departure_request"  # the step result's info key of the departure planner's request


def reads_action_targets(actor: Any) -> bool:
    """Whether ``actor`` reads the published action targets (its ``reads_action_targets``; False when absent)."""
    return bool(getattr(actor, "reads_action_targets", False))


def published_targets(info: dict[str, Any], who: str) -> dict[str, Any]:
    """The action targets a step result's ``info`` carries; a ValueError naming ``who`` and how to ask
    for them when it carries none."""
    published = info.get(TARGETS_KEY)
    if published is None:
        raise ValueError(f"{who} reads the action targets of the step result (info[{TARGETS_KEY!r}]), which the "
                         "episode engine adds for use cases with speed, heading or altitude actions when asked "
                         "(EpisodeCore.publish_targets = True; a rollout asks for an actor with "
                         "reads_action_targets = True)")
    return dict(published)


def action_target_info(usecase: Any, sim: Any, agents: list[str]) -> dict[str, Any]:
    """``{"action_targets": {"agents": [...], kind: (n, n_actions) float64, ...}}`` for the speed, heading
    and altitude kinds the use case declares (CAS [m/s], track [deg], altitude [m]); ``{}`` for a use case
    with none of them.

    ``agents``: those to compute them for (the ones alive now); an agent without an aircraft is left out.
    """
    if usecase is None:
        return {}
    kinds = [k for k in TARGET_KINDS if k in spec_of(usecase).action_kinds]
    if not kinds:
        return {}
    view = sim.view
    # Agents are callsigns as the view spells them: one dict of the slots, not a look-up per agent.
    slot_of = {a: i for i, a in enumerate(view.ids)}
    names = [a for a in agents if a in slot_of]
    out: dict[str, Any] = {"agents": names}
    if not names:
        n_actions = int(usecase.action_space().n)
        out.update({k: np.zeros((0, n_actions)) for k in kinds})
        return {TARGETS_KEY: out}
    slots = np.array([slot_of[a] for a in names], dtype=np.int64)
    for kind in kinds:
        out[kind] = np.ascontiguousarray(usecase.action_targets(sim, slots, kind), dtype=np.float64)
    return {TARGETS_KEY: out}


def departure_request_info(usecase: Any) -> dict[str, Any]:
    """``{"departure_request": {...}}`` for a use case with departure-slot actions; ``{}`` otherwise.

    What its departure planner (``usecase.departure_planner()``) offers now: ``decider`` (the
    planner agent deciding the current request), ``default_action`` (depart on schedule on the
    filed layer), ``pending`` (a request is being decided) and, when one is, its candidate
    ``conflicts`` (delays x layers, int64: intent conflicts of each slot), ``action_mask``
    (int64, 1: valid), ``filed_layer`` (its filed layer index, >= 0) and ``reject_action``
    (-1: the use case cannot reject).
    """
    if usecase is None or "departure_slot" not in spec_of(usecase).action_kinds:
        return {}
    planner = usecase.departure_planner()
    decider = planner.decider() if hasattr(planner, "decider") else "planner"
    out: dict[str, Any] = {"decider": str(decider), "pending": False, "default_action": 0}
    req = planner.current() if getattr(planner, "plan", None) is not None else None
    if req is not None:
        conflicts, _ = planner.candidate_table()
        reject = planner.reject_action
        out.update(pending=True, default_action=int(planner.default_action()),
                   conflicts=np.ascontiguousarray(conflicts, dtype=np.int64),
                   action_mask=np.ascontiguousarray(planner.action_mask(req), dtype=np.int64),
                   filed_layer=max(int(planner.plan.filed_layer.get(req.key, 0)), 0),
                   reject_action=-1 if reject is None else int(reject))
    return {REQUEST_KEY: out}


def step_info(usecase: Any, sim: Any, agents: list[str], targets: bool = True) -> dict[str, Any]:
    """Everything the episode engine publishes in a step result's ``info`` (the module docstring);
    ``targets``: whether the action targets are asked for (an acting policy reads them)."""
    return {**(action_target_info(usecase, sim, agents) if targets else {}), **departure_request_info(usecase)}
