"""Several independent simulations stepped together: one kernel call per batch for all of them.

A :class:`WorldSet` holds ``worlds`` :class:`~aamsim.Simulation` objects, one
per world, each with its own clock, commands, random generator, hooks and
services: a world is exactly the simulation it would be alone. What they share
is the storage of their traffic (:class:`~aamsim.traffic.pool.TrafficPool`), so
that :meth:`WorldSet.run_until` advances the aircraft of every world that has
steps to go in one call of the compiled kernel, instead of one call per world.

Each world keeps its own time (the vector environments reset one world while the
others fly on). A batch of steps ends where the next event of any world is due
(a command, a hook, a performance refresh, a waypoint, a condition, each as
:meth:`Simulation.run_until` finds them); a world with nothing due there runs its
step boundary for nothing, which changes nothing, and the kernel gives every
aircraft the same bits whatever else it advances in the same call. So every world
ends exactly where it would have alone (``tests/test_worlds.py`` checks it bit for
bit). Worlds in a wind field, or with a time step of their own, take their own
kernel calls.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from aamsim.simulation import (
    AFTER_BOUNDARY,
    AFTER_CONTINUE,
    AFTER_LAST_STEP,
    PARALLEL_MIN_AIRCRAFT,
    Simulation,
    _NO_CONDITIONS,
)
from aamsim.stack.queue import to_us
from aamsim.threads import check_threads
from aamsim.traffic.pool import TrafficPool


@dataclass
class _Batch:
    """One world's batch of kernel steps in progress (as in :meth:`Simulation._advance_steps`)."""

    nsteps: int
    done: int = 0
    check: bool = True  # its waypoint test runs before the next kernel step


class WorldSet:
    """``worlds`` simulations over one traffic pool, run side by side (see the module docstring).

    Args:
        worlds: how many simulations.
        threads: Numba threads stepping the aircraft of all worlds together (1: serial; see
            :func:`aamsim.threads.check_threads`; None: ``AAMSIM_THREADS``), used from :data:`PARALLEL_MIN_AIRCRAFT` aircraft.
    """

    def __init__(self, worlds: int, threads: int | None = 1):
        if worlds < 1:
            raise ValueError(f"a world set needs at least one world, not {worlds}")
        self.pool = TrafficPool(worlds)
        self.threads = check_threads(threads)
        self.sims: list[Simulation | None] = [None] * worlds
        self.kernel_calls = 0  # calls of the kernel that stepped several worlds at once (for benchmarks)

    def __len__(self) -> int:
        return len(self.sims)

    def new_simulation(self, world: int, **kwargs: Any) -> Simulation:
        """A fresh simulation for ``world`` (``Simulation``'s arguments); the world's previous one is let go.

        The previous simulation keeps a copy of its traffic, so that it can still be read
        (an episode's final metrics); it is no longer stepped here.
        """
        if "traffic" in kwargs:
            raise TypeError("the world set gives each simulation its traffic")
        sim = Simulation(traffic=self.pool.new_traffic(world), **kwargs)
        self.sims[world] = sim
        return sim

    def sim(self, world: int) -> Simulation:
        sim = self.sims[world]
        if sim is None:
            raise RuntimeError(f"world {world} has no simulation yet")
        return sim

    # ---------------------------------------------------------------- stepping
    def run_until(self, targets: Mapping[int, float]) -> None:
        """Advance each world of ``targets`` (world -> sim time [s]) as its own ``run_until(t)`` would."""
        ends = {w: to_us(t) for w, t in targets.items()}
        batches: dict[int, _Batch] = {}
        at_boundary = list(ends)
        while True:
            for w in at_boundary:
                sim = self.sim(w)
                sim._boundary()
                end = ends[w]
                if sim.state == Simulation.STATE_HOLD or sim.quit_requested or sim.simt_us >= end:
                    continue
                batches[w] = _Batch(sim.scheduler.steps_to_next_event(end))
            at_boundary = []
            if not batches:
                return
            groups: dict[int, list[int]] = {}
            for w in list(batches):
                sim = self.sim(w)
                if sim.wind.active:  # the wind field is per simulation: a kernel call of its own
                    sim._advance_steps(batches.pop(w).nsteps)
                    at_boundary.append(w)
                else:
                    groups.setdefault(sim.clock.dt_us, []).append(w)
            for group in groups.values():
                at_boundary += self._advance_group(group, batches)

    def _advance_group(self, worlds: list[int], batches: dict[int, _Batch]) -> list[int]:
        """One kernel call for ``worlds`` (same time step); returns the worlds whose batch ended."""
        sims = [self.sim(w) for w in worlds]
        steps = min(batches[w].nsteps - batches[w].done for w in worlds)
        check = np.array([batches[w].check for w in worlds], dtype=np.bool_)
        hold = np.array([s.settings.hold_speed_mps for s in sims], dtype=np.float64)
        airborne = np.array([s.settings.airborne_alt_m for s in sims], dtype=np.float64)
        counts = [s.traffic.n for s in sims]
        threads = self.threads if self.threads > 1 and sum(counts) >= PARALLEL_MIN_AIRCRAFT else 1
        k, status, conds = self.pool.advance(
            worlds, check, sims[0].clock.dt_s, steps, hold, airborne,
            [s.conditions if len(s.conditions) else None for s in sims],
            any(s.traffic.turn_speeds_used for s in sims), any(s.traffic.resolution_used for s in sims), threads)
        self.kernel_calls += 1
        ended = []
        for w, sim, n, cond, checked in zip(worlds, sims, counts, conds, check.tolist()):
            if k == 0 and not checked:
                continue  # another world's waypoint test stopped the call before any step: nothing here ran
            batch = batches[w]
            batch.done += k
            after = sim._after_kernel(k, status, n, _NO_CONDITIONS if cond is None else cond)
            if after == AFTER_BOUNDARY:
                del batches[w]
                ended.append(w)
                continue
            batch.check = after == AFTER_CONTINUE
            if after == AFTER_LAST_STEP:
                batch.nsteps = batch.done + 1
            if batch.done >= batch.nsteps:
                del batches[w]
                ended.append(w)
        return ended
