"""The targets of a use case's heading / altitude actions, published with each step result.

A baseline that steers with a use case's own heading and altitude actions (``mvp``) needs to
know what each action would set: a use case computes it from its routes and its per-episode
state (:meth:`rlbridge.usecases.protocol.UseCaseBase.action_targets`), which only exist where
the simulation runs. The episode engine therefore adds them to the step results of a use
case with such actions (``info["action_targets"]``), so they cross the wire with the result
and the baseline acts on the result and a traffic snapshot, on every backend.

They cost a computation per decision, which a learner never reads: an actor asks for them
by ``reads_action_targets = True`` (:func:`reads_action_targets`), and the episode engine
publishes them only while such an actor plays (``EpisodeCore.publish_targets``; over ZeroMQ
the ``targets`` field of a ``reset``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rlbridge.usecases.spec import spec_of

MANOEUVRE_KINDS = ("heading", "altitude")
TARGETS_KEY = "action_targets"  # the step result's info key


def reads_action_targets(actor: Any) -> bool:
    """Whether ``actor`` reads the published action targets (its ``reads_action_targets``; False when absent)."""
    return bool(getattr(actor, "reads_action_targets", False))


def action_target_info(usecase: Any, sim: Any, agents: list[str]) -> dict[str, Any]:
    """``{"action_targets": {"agents": [...], kind: (n, n_actions) float64, ...}}`` for the heading and
    altitude kinds the use case declares (track [deg], altitude [m]); ``{}`` for a use case with neither.

    ``agents``: those to compute them for (the ones alive now); an agent without an aircraft is left out.
    """
    if usecase is None:
        return {}
    kinds = [k for k in MANOEUVRE_KINDS if k in spec_of(usecase).action_kinds]
    if not kinds:
        return {}
    view = sim.view
    names = [a for a in agents if a in view]
    out: dict[str, Any] = {"agents": names}
    if not names:
        n_actions = int(usecase.action_space().n)
        out.update({k: np.zeros((0, n_actions)) for k in kinds})
        return {TARGETS_KEY: out}
    slots = np.array([view.slot(a) for a in names], dtype=np.int64)
    for kind in kinds:
        out[kind] = np.ascontiguousarray(usecase.action_targets(sim, slots, kind), dtype=np.float64)
    return {TARGETS_KEY: out}
