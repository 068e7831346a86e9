"""The vector engine: N independent episodes of one use case in one process, stepped together.

Each episode (a *world*) is an ordinary :class:`~rlbridge.core.EpisodeCore` with
its own simulation, seed, use-case state and agents; what the worlds share is a
:class:`~aamsim.worlds.WorldSet`: their aircraft live in one traffic pool, and
the engine runs the sim times that the episodes' ``reset_steps``/``step_steps``
ask for on all worlds at once, so that one kernel call per batch advances every
world. A world gives exactly what its episode gives alone
(``tests/test_vector_env.py``): the generators are the same code as
``EpisodeCore.reset``/``step``, and the world set steps each simulation as its
own ``run_until`` would.

A world whose episode needs more time than the others (a reset that flies the
traffic up to its first decision) runs on alone once the others are done; no
world waits for another's episode to end.
"""

from __future__ import annotations

import functools
from collections.abc import Generator, Mapping, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from aamsim.worlds import WorldSet
from rlbridge.core import EpisodeCore, RunUntil, StepResult

Steps = Generator["float | RunUntil", None, Any]


class VectorEngine:
    """``num_worlds`` episodes of one use case over one :class:`~aamsim.worlds.WorldSet`.

    Args:
        scenario: one scenario for every world, or one per world (a sequence of ``num_worlds``).
        usecase, params, time_limit_s, dt: as :class:`~rlbridge.core.EpisodeCore`'s, the same for every world.
        num_worlds: how many episodes run side by side (at least 1).
        threads: Numba threads stepping all worlds' aircraft together (None: ``AAMSIM_THREADS``,
            else 1; at most the CPU cores: :func:`aamsim.threads.check_threads`).

    Raises:
        ValueError: ``num_worlds`` < 1, a scenario list of another length, or worlds whose
            observation or action spaces differ (the engine serves one space to all of them).
    """

    def __init__(self, scenario: str | Path | Sequence[str | Path], usecase: str = "corridor_sa",
                 params: dict[str, Any] | None = None, num_worlds: int = 1, time_limit_s: float | None = None,
                 dt: float = 0.05, threads: int | None = None):
        if isinstance(num_worlds, bool) or not isinstance(num_worlds, int) or num_worlds < 1:
            raise ValueError(f"num_envs must be a whole number >= 1, not {num_worlds!r}")
        scenarios = _per_world(scenario, num_worlds)
        self.worlds = WorldSet(num_worlds, threads)
        self.cores: list[EpisodeCore] = []
        for w, path in enumerate(scenarios):
            core = EpisodeCore(path, usecase, params, time_limit_s=time_limit_s, dt=dt, threads=1)
            core.make_simulation = functools.partial(self.worlds.new_simulation, w)
            self.cores.append(core)
        first = self.cores[0].usecase
        for w, core in enumerate(self.cores[1:], start=1):
            for what in ("observation_space", "action_space"):
                a, b = getattr(first, what)(), getattr(core.usecase, what)()
                if a != b:
                    raise ValueError(f"the vector environment serves one {what.replace('_', ' ')} to every "
                                     f"sub-environment, but sub-environment {w} (scenario {scenarios[w]}) has "
                                     f"{b} where sub-environment 0 (scenario {scenarios[0]}) has {a}")

    def __len__(self) -> int:
        return len(self.cores)

    @property
    def observation_space(self) -> gym.Space:
        return self.cores[0].usecase.observation_space()

    @property
    def action_space(self) -> gym.Space:
        return self.cores[0].usecase.action_space()

    def run(self, programs: Mapping[int, Steps]) -> dict[int, Any]:
        """Run each world's generator (the sim times it yields) together; returns what each returned.

        A generator yields the sim time [s] its world's simulation must reach next (or a
        :class:`~rlbridge.core.RunUntil`: that time, or earlier where its ``stop`` says so); the
        worlds that wait are advanced in the same :meth:`WorldSet.run_until` call.
        """
        results: dict[int, Any] = {}
        pending: dict[int, float | RunUntil] = {}
        for w, program in programs.items():
            _resume(w, program, None, pending, results, first=True)
        while pending:
            targets = {w: t.t_s if type(t) is RunUntil else t for w, t in pending.items()}
            stops = {w: t.stop for w, t in pending.items() if type(t) is RunUntil}
            self.worlds.run_until(targets, stops)  # type: ignore[arg-type]
            waiting, pending = pending, {}
            for w in waiting:
                _resume(w, programs[w], None, pending, results)
        return results

    def reset(self, seeds: Mapping[int, int | None]) -> dict[int, StepResult]:
        """Start a new episode in each world of ``seeds`` (world -> episode seed)."""
        return self.run({w: self.cores[w].reset_steps(seed) for w, seed in seeds.items()})

    def step(self, actions: Mapping[int, dict[str, Any]]) -> dict[int, StepResult]:
        """Apply each world's actions (agent -> action) and advance it to its next decision."""
        for w in actions:
            if self.cores[w].sim is None:
                raise RuntimeError(f"step() before reset() in world {w}")
        return self.run({w: self.cores[w].step_steps(a) for w, a in actions.items()})

    def close(self) -> None:
        for core in self.cores:
            core.close()


def _resume(w: int, program: Steps, value: None, pending: dict[int, float | RunUntil], results: dict[int, Any],
            first: bool = False) -> None:
    try:
        pending[w] = next(program) if first else program.send(value)
    except StopIteration as stop:
        results[w] = stop.value


def _per_world(scenario: str | Path | Sequence[str | Path], n: int) -> list[str | Path]:
    if isinstance(scenario, (str, Path)):
        return [scenario] * n
    scenarios = list(scenario)
    if len(scenarios) != n:
        raise ValueError(f"{len(scenarios)} scenarios for {n} sub-environments: give one scenario, or one per "
                         "sub-environment")
    return scenarios


def reset_request(n: int, seed: Any, options: dict[str, Any] | None) -> tuple[list[int | None], np.ndarray]:
    """A vector reset's seed per sub-environment and the mask of those to reset.

    ``seed``: None (each draws from its own generator), an int (sub-environment ``i`` gets
    ``seed + i``, as Gymnasium's vector environments) or one per sub-environment;
    ``options["reset_mask"]``: booleans, one per sub-environment, at least one True.
    """
    if seed is None:
        seeds: list[int | None] = [None] * n
    elif isinstance(seed, (int, np.integer)):
        seeds = [int(seed) + i for i in range(n)]
    else:
        seeds = list(seed)
        if len(seeds) != n:
            raise ValueError(f"{len(seeds)} seeds for {n} sub-environments")
    mask = np.ones(n, dtype=np.bool_)
    if options is not None and "reset_mask" in options:
        mask = np.asarray(options["reset_mask"], dtype=np.bool_)
        if mask.shape != (n,) or not mask.any():
            raise ValueError(f"options['reset_mask'] must be {n} booleans, at least one True")
    return seeds, mask
