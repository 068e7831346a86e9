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

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from aamsim.simulation import (
    _NO_CONDITIONS,
    AFTER_BOUNDARY,
    AFTER_CONTINUE,
    AFTER_LAST_STEP,
    PARALLEL_MIN_AIRCRAFT,
    Simulation,
)
from aamsim.stack.queue import to_us
from aamsim.threads import check_threads
from aamsim.traffic.kernel import STATUS_CONDITION, STATUS_DONE, STATUS_REACHED
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
    def run_until(self, targets: Mapping[int, float], stops: Mapping[int, Callable[[], bool]] | None = None) -> None:
        """Advance each world of ``targets`` (world -> sim time [s]) as its own ``run_until(t)`` would.

        ``stops``: world -> its ``stop`` (:meth:`Simulation.run_until`), for the worlds that have one.
        """
        ends = {w: to_us(t) for w, t in targets.items()}
        stops = stops or {}
        batches: dict[int, _Batch] = {}
        at_boundary = list(ends)
        while True:
            for w in at_boundary:
                sim = self.sim(w)
                sim._boundary()
                end = ends[w]
                if sim.state == Simulation.STATE_HOLD or sim.quit_requested or sim.simt_us >= end:
                    continue
                stop = stops.get(w)
                if stop is not None and stop():
                    continue
                batches[w] = _Batch(sim.scheduler.steps_to_next_event(end))
            at_boundary = []
            if not batches:
                return
            groups: dict[int, list[int]] = {}
            for w in list(batches):
                sim = self.sim(w)
                if sim._wind.active or (len(batches) == 1 and batches[w].done == 0):
                    # Alone (a world whose episode needs more time than the others), or in a wind field
                    # (a field per simulation): the simulation's own batch, with nothing to share.
                    sim._advance_steps(batches.pop(w).nsteps)
                    at_boundary.append(w)
                else:
                    groups.setdefault(sim._clock.dt_us, []).append(w)
            for group in groups.values():
                at_boundary += self._advance_group(group, batches)

    def _advance_group(self, worlds: list[int], batches: dict[int, _Batch]) -> list[int]:
        """Kernel calls for ``worlds`` (same time step) until some world's batch ends; returns those worlds.

        The per-world book-keeping is in arrays: a call that ended on another world's event costs a
        world nothing in Python. Its clock takes the steps when it next matters (an event of its own,
        the end of its batch).
        """
        sims = [self.sim(w) for w in worlds]
        m = len(worlds)
        nsteps = np.array([batches[w].nsteps for w in worlds], dtype=np.int64)
        done = np.array([batches[w].done for w in worlds], dtype=np.int64)
        check = np.array([batches[w].check for w in worlds], dtype=np.bool_)
        pending = np.zeros(m, dtype=np.int64)  # steps not yet on the world's clock
        hold = np.array([s.settings.hold_speed_mps for s in sims], dtype=np.float64)
        airborne = np.array([s.settings.airborne_alt_m for s in sims], dtype=np.float64)
        dt = sims[0]._clock.dt_s
        pool = self.pool
        turns = any(s._traffic.turn_speeds_used for s in sims)
        reso = any(s._traffic.resolution_used for s in sims)
        counts = [s._traffic.n for s in sims]
        threads = self.threads if self.threads > 1 and sum(counts) >= PARALLEL_MIN_AIRCRAFT else 1
        conditions = [s.conditions for s in sims]
        ended: list[int] = []
        over = np.zeros(m, dtype=np.bool_)
        while not ended:
            steps = int((nsteps - done).min())
            k, status, reached, conds = pool.advance(worlds, check, dt, steps, hold, airborne, conditions, turns,
                                                      reso, threads)
            self.kernel_calls += 1
            done += k
            pending += k
            if status == STATUS_REACHED:
                events = np.flatnonzero(reached).tolist()
                check[:] = False  # the test of the next step has run (or did not need to)
            elif status == STATUS_DONE:
                events = []
                check[:] = True  # no condition fired anywhere (the call would have stopped)
            elif status == STATUS_CONDITION:
                events = [i for i, c in enumerate(conds) if c is not None and c[6].any()]
                check[:] = True
            else:  # a non-finite state: every world checks its own
                events = list(range(m))
            for i in events:
                sim = sims[i]
                cond = conds[i]
                after = sim._after_kernel(int(pending[i]), status, counts[i], _NO_CONDITIONS if cond is None else cond)
                pending[i] = 0
                counts[i] = sim._traffic.n
                # Passing a waypoint may start a leg with a turn speed: the kernel's part for it.
                turns = turns or sim._traffic.turn_speeds_used
                reso = reso or sim._traffic.resolution_used
                check[i] = after == AFTER_CONTINUE
                if after == AFTER_LAST_STEP:
                    nsteps[i] = done[i] + 1
                elif after == AFTER_BOUNDARY:
                    over[i] = True
            finished = over | (done >= nsteps)
            if finished.any():
                ended = [worlds[i] for i in np.flatnonzero(finished).tolist()]
        for i, w in enumerate(worlds):
            sim = sims[i]
            if pending[i]:
                sim._clock.simt_us += int(pending[i]) * sim._clock.dt_us
                sim.aircraft_steps += int(pending[i]) * counts[i]
            if over[i] or done[i] >= nsteps[i]:
                del batches[w]
            else:
                batch = batches[w]
                batch.nsteps, batch.done, batch.check = int(nsteps[i]), int(done[i]), bool(check[i])
        return ended
