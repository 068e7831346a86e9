"""What a heading / altitude advisory of a use case would do: its targets and a well-clear check of each action.

The rule-based baselines that act on use cases with heading and altitude
advisories (``daa``, ``mvp``) read each action's targets from the step result
(``info["action_targets"]``, :mod:`rlbridge.usecases.targets`) and, for DAA, check
every action's manoeuvre against the traffic: an instant turn to the action's
track and a climb or descent at the use case's rate to its altitude, then level
flight, intruders flying straight
(:func:`aamsim.conflicts.axis_bands.manoeuvre_intervals`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aamsim.conflicts.axis_bands import manoeuvre_intervals
from aamsim.resolution.daa import DAAParams, isotropic_pairs
from aamsim.resolution.state import KinematicState
from rlbridge.usecases.targets import MANOEUVRE_KINDS as TARGET_KINDS

MANOEUVRE_KINDS = TARGET_KINDS  # heading and altitude: the kinds these baselines steer with


@dataclass(frozen=True)
class ActionTargets:
    """Per aircraft (rows) and action (columns): the track [deg] and altitude [m] it sets."""

    trk: np.ndarray
    alt: np.ndarray
    resume: int  # the action that gives no advisory (back on the route, at the own altitude)
    rate_mps: float  # vertical speed of the level changes


def check_actions(sim: KinematicState, slots: np.ndarray, targets: ActionTargets, params: DAAParams,
                  recovery: bool = False, step_s: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Per aircraft and action: when the manoeuvre first loses well clear and when it last is not well clear
    [s from now, sampled every ``step_s``] against any intruder (``inf`` / ``-inf``: never); the recovery
    volume (the NMAC distances) over ``recovery_lookahead_s`` when ``recovery``."""
    slots = np.asarray(slots, dtype=np.int64)
    na = targets.trk.shape[1]
    first = np.full((slots.size, na), np.inf)
    last = np.full((slots.size, na), -np.inf)
    view = sim.view
    if slots.size == 0 or view.n < 2:
        return first, last
    horizon = params.recovery_lookahead_s if recovery else params.lookahead_s
    s, own, intr = isotropic_pairs(sim, slots, horizon, max(params.dmod_m, params.recovery_m))
    n = len(s.ids)
    if own.size == 0:
        return first, last
    row_of = np.full(n, -1, dtype=np.int64)
    row_of[slots] = np.arange(slots.size)
    row = row_of[own]
    gs = np.repeat(np.hypot(s.u, s.v)[slots, None], na, axis=1)
    dalt = targets.alt - np.asarray(view.alt, dtype=np.float64)[slots, None]
    rate = np.full(targets.trk.shape, targets.rate_mps)
    vol = (params.recovery_m, params.recovery_m, 0.0, params.recovery_zthr_m, 0.0) if recovery else \
        (params.dmod_m, params.hmd_m, params.taumod_s, params.zthr_m, params.tcoa_s)
    f, lst = manoeuvre_intervals(*s.frame, s.alt, s.u, s.v, s.w, own, intr, row, targets.trk, gs, dalt, rate, *vol,
                                 horizon, step_s)
    np.minimum.at(first, row, f)
    np.maximum.at(last, row, lst)
    return first, last
