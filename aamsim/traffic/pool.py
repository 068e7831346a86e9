"""Traffic storage shared by several simulations, so that one kernel call steps them all.

A :class:`TrafficPool` holds the state matrices of ``worlds`` simulations side
by side: world ``w`` owns the slot block ``w * block .. (w + 1) * block - 1``
and its :class:`~aamsim.traffic.traffic.Traffic` sees that block as its own
arrays (views: the aircraft of a world keep slots ``0..n-1`` for everything
else in the simulator). Blocks are the same size; when one world needs more
room, every block doubles at once (rare: a block grows to the most aircraft a
world has had at once).

:meth:`TrafficPool.advance` runs :func:`aamsim.traffic.kernel.advance_ranges`
on the live slots of several worlds in one call: the aircraft are advanced by
the same compiled code as in a simulation of their own, so each world's
results are the same bit for bit (the vector environments rely on it,
``rlbridge/vector``). A world's aircraft never meet another world's: nothing in
the kernel couples two aircraft.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numba
import numpy as np

from aamsim.traffic.kernel import advance_ranges, advance_ranges_parallel
from aamsim.traffic.traffic import Traffic, new_state_arrays

if TYPE_CHECKING:
    from aamsim.traffic.conditions import Conditions

DEFAULT_BLOCK = 64  # slots per world at first (a Traffic's own default capacity)


class TrafficPool:
    """The state of ``worlds`` simulations' traffic in one pair of matrices (see the module docstring)."""

    def __init__(self, worlds: int, block: int = DEFAULT_BLOCK):
        if worlds < 1:
            raise ValueError(f"a traffic pool needs at least one world, not {worlds}")
        if block < 1:
            raise ValueError(f"a block holds at least one aircraft, not {block}")
        self.worlds = worlds
        self.block = block
        self.F, self.B, self.scratch = new_state_arrays(worlds * block)
        self.members: list[Traffic | None] = [None] * worlds
        self._joint_conditions = _JointConditions()

    # ------------------------------------------------------------------ blocks
    def new_traffic(self, world: int) -> Traffic:
        """An empty :class:`Traffic` on block ``world``; the traffic there before leaves the pool with a copy."""
        if not 0 <= world < self.worlds:
            raise IndexError(f"no world {world} in a pool of {self.worlds}")
        old = self.members[world]
        if old is not None:
            old.detach()
        return Traffic(pool=self, world=world)

    def bind(self, traffic: Traffic) -> None:
        """Give ``traffic`` its block's arrays (called by :class:`Traffic` when it is made)."""
        lo = traffic.world * self.block
        hi = lo + self.block
        traffic.F = self.F[:, lo:hi]
        traffic.B = self.B[:, lo:hi]
        traffic.scratch = tuple(a[lo:hi] for a in self.scratch)  # type: ignore[assignment]
        traffic.capacity = self.block
        self.members[traffic.world] = traffic

    def start(self, world: int) -> int:
        """First slot of a world's block in the pool's matrices."""
        return world * self.block

    def grow(self) -> None:
        """Double every block (the live aircraft keep their slots within their block)."""
        block = 2 * self.block
        F, B, scratch = new_state_arrays(self.worlds * block)
        for w, traffic in enumerate(self.members):
            if traffic is None:
                continue
            lo, hi = w * block, (w + 1) * block
            traffic.adopt(F[:, lo:hi], B[:, lo:hi], tuple(a[lo:hi] for a in scratch), block)  # type: ignore[arg-type]
        self.F, self.B, self.scratch, self.block = F, B, scratch, block

    # ---------------------------------------------------------------- stepping
    def advance(
        self,
        worlds: Sequence[int],
        check: np.ndarray,
        dt: float,
        nsteps: int,
        hold_speed: np.ndarray,
        airborne_alt: np.ndarray,
        conditions: Sequence[Conditions | None],
        turns: bool,
        resolution: bool,
        threads: int = 1,
    ) -> tuple[int, int, np.ndarray, list[tuple[np.ndarray, ...] | None]]:
        """Advance the aircraft of ``worlds`` (no wind) by up to ``nsteps`` steps of ``dt`` [s] in one kernel call.

        Per world (in the order given): whether its waypoint test runs first, its holding-speed
        and airborne thresholds, and its conditional commands (None: none). ``threads`` > 1 splits
        the worlds over Numba's threads. Returns the kernel's ``(steps_done, status)`` and each
        world's waypoint count (the kernel's ``counts``: 0 where no aircraft reached its waypoint)
        and condition arrays (what :meth:`Conditions.arrays` gives it, None without conditions):
        each world reads its own waypoint and condition flags afterwards, as after a call of its own.
        """
        members = self.members
        block = self.block
        lo = np.empty(len(worlds), dtype=np.int64)
        hi = np.empty(len(worlds), dtype=np.int64)
        for k, w in enumerate(worlds):
            traffic = members[w]
            assert traffic is not None
            lo[k] = w * block
            hi[k] = lo[k] + traffic.n
        cond, per_world = self._joint_conditions.arrays(
            [(c, members[w], w * block) if c is not None and len(c) else None for w, c in zip(worlds, conditions)])
        kernel = advance_ranges
        if threads > 1:
            numba.set_num_threads(threads)  # a per-thread setting: set it where the kernel runs
            kernel = advance_ranges_parallel
        counts = np.empty(len(worlds), dtype=np.int64)
        k, status = kernel(self.F, self.B, lo, hi, check, dt, nsteps, hold_speed, airborne_alt, self.scratch, cond,
                           () if turns else None, () if resolution else None, counts)
        return k, status, counts, per_world


class _JointConditions:
    """The conditional commands of several worlds as one set of kernel arrays.

    Each world's own cached arrays (:meth:`Conditions.arrays`) become views of its part
    of the joint arrays, so the kernel's updates (differences, fired flags) are the
    world's own with no copy; the joint arrays are rebuilt when a world's are.
    """

    def __init__(self) -> None:
        self._key: tuple[tuple[object, int], ...] = ()
        self._arrays: tuple[np.ndarray, ...] = _no_conditions()
        # The last call's parts and what each got: a call with the same parts, none of them rebuilt,
        # clears the fired flags of all in one write (a world set calls this for every kernel call).
        self._last_parts: list[tuple[Conditions, Traffic | None, int] | None] = []
        self._last_own: list[tuple[np.ndarray, ...] | None] = []

    def arrays(self, parts: list[tuple[Conditions, Traffic | None, int] | None]
               ) -> tuple[tuple[np.ndarray, ...], list[tuple[np.ndarray, ...] | None]]:
        """The joint arrays (slots into the pool) and each part's own arrays (None for a part without)."""
        if self._unchanged(parts):
            self._arrays[6][:] = False  # each part's fired flags are views of these
            return self._arrays, list(self._last_own)
        joint, own = self._rebuild(parts)
        self._last_parts, self._last_own = list(parts), list(own)
        return joint, own

    def _unchanged(self, parts: list[tuple[Conditions, Traffic | None, int] | None]) -> bool:
        """Whether ``parts`` are the last call's, each part's cached arrays still the ones it got then."""
        last = self._last_parts
        if len(parts) != len(last):
            return False
        for part, before, got in zip(parts, last, self._last_own):
            if part is None or before is None:
                if part is not before:
                    return False
                continue
            cond, traffic, offset = part
            if cond is not before[0] or traffic is not before[1] or offset != before[2] or got is None \
                    or traffic is None or cond.cached(traffic) is not got:
                return False
        return True

    def _rebuild(self, parts: list[tuple[Conditions, Traffic | None, int] | None]
                 ) -> tuple[tuple[np.ndarray, ...], list[tuple[np.ndarray, ...] | None]]:
        own: list[tuple[np.ndarray, ...] | None] = []
        used = []
        for part in parts:
            if part is None:
                own.append(None)
                continue
            cond, traffic, offset = part
            assert traffic is not None
            arrays = cond.arrays(traffic)
            own.append(arrays)
            used.append((arrays, offset, cond))
        key = tuple((arrays, offset) for arrays, offset, _ in used)
        if len(key) == len(self._key) and all(a is b and o == p for (a, o), (b, p) in zip(key, self._key)):
            return self._arrays, own
        if not used:
            self._key, self._arrays = (), _no_conditions()
            return self._arrays, own
        ac = np.concatenate([arrays[0] + offset for arrays, offset, _ in used])
        rest = [np.concatenate([arrays[r] for arrays, _, _ in used]) for r in range(1, 7)]
        start = 0
        adopted = {}
        for arrays, offset, cond in used:
            stop = start + len(arrays[0])
            adopted[id(arrays)] = cond.adopt_arrays(tuple(a[start:stop] for a in rest))
            start = stop
        own = [None if a is None else adopted[id(a)] for a in own]
        self._key = tuple((adopted[id(arrays)], offset) for arrays, offset, _ in used)
        self._arrays = (ac, *rest)
        return self._arrays, own


def _no_conditions() -> tuple[np.ndarray, ...]:
    return (np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64), np.empty(0), np.empty(0), np.empty(0),
            np.empty(0), np.empty(0, dtype=np.bool_))
