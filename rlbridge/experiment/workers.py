"""Rollout worker pools: in-process (``workers=0``) or Ray actors (``workers=N``).

Both pools run the same :class:`~rlbridge.agents.rollout.RolloutWorker`. With Ray, the
driver starts a local Ray itself (``ray.init(num_cpus=...)``) unless Ray is already
initialised or ``ray.address`` names a cluster (``auto``, ``ray://host:10001``...), in
which case the very same command runs the workers there. Workers import the code the
driver imported: the directory holding the ``rlbridge`` package goes into their
``PYTHONPATH`` (``runtime_env``), so a source checkout works without installing it.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from rlbridge.agents.rollout import EnvSpec, RolloutWorker

log = logging.getLogger(__name__)


class InProcessPool:
    """One worker in this process; "worker k" episodes run one after the other."""

    def __init__(self, env: EnvSpec, actors: dict[str, dict[str, Any]], torch_threads: int = 1):
        self.worker = RolloutWorker(env, actors, torch_threads)
        self.size = 1

    def collect(self, seed_lists: list[list[int]], actor: str = "policy", weights: Any = None,
                explore: dict[str, Any] | None = None, record: bool = True,
                lockstep: bool = False) -> list[list[Any]]:
        """Episodes for each list of seeds (one list per logical worker), in order."""
        if weights is not None:
            self.worker.set_weights(weights, actor)
        return [self.worker.collect(seeds, actor, None, explore, record, lockstep) for seeds in seed_lists]

    def submit(self, seed_lists: list[list[int]], actor: str = "policy", weights: Any = None,
               explore: dict[str, Any] | None = None, record: bool = True, lockstep: bool = False) -> Any:
        """:meth:`collect` started now, its result taken by :meth:`wait` (in process: played right away)."""
        return self.collect(seed_lists, actor, weights, explore, record, lockstep)

    def wait(self, handle: Any) -> list[list[Any]]:
        return list(handle)

    def map_episodes(self, seeds: list[int], actor: str, weights: Any = None, explore: dict[str, Any] | None = None,
                     record: bool = False) -> Iterator[Any]:
        """One episode per seed, yielded as they finish (here: in order)."""
        if weights is not None:
            self.worker.set_weights(weights, actor)
        for s in seeds:
            yield from self.worker.collect([s], actor, None, explore, record)

    def shutdown(self) -> None:
        pass


def _code_root() -> str:
    import rlbridge

    return str(Path(rlbridge.__file__).resolve().parent.parent)


class RayPool:
    """``size`` Ray actors, each a :class:`RolloutWorker` (one CPU each by default)."""

    def __init__(self, size: int, env: EnvSpec, actors: dict[str, dict[str, Any]], address: str | None = None,
                 num_cpus: int | None = None, cpus_per_worker: float = 1.0, torch_threads: int = 1):
        import ray

        self._ray = ray
        self._started = False
        if not ray.is_initialized():
            paths = [_code_root()] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
            runtime_env = {"env_vars": {"PYTHONPATH": os.pathsep.join(dict.fromkeys(paths))}}
            if address:
                ray.init(address=address, runtime_env=runtime_env, log_to_driver=True)
            else:
                # Ray lowers its workers' priority (niceness 15) by default; rollout workers do the
                # run's main work, so a local Ray keeps them at the driver's priority.
                os.environ.setdefault("RAY_worker_niceness", "0")
                cpus = num_cpus or max(os.cpu_count() or 1, int(size * cpus_per_worker + 0.999))
                ray.init(num_cpus=cpus, include_dashboard=False, runtime_env=runtime_env, log_to_driver=True)
            self._started = True
        remote = ray.remote(num_cpus=cpus_per_worker)(RolloutWorker)
        self.actors: list[Any] = [remote.remote(env, actors, torch_threads) for _ in range(size)]
        self.size = size

    def collect(self, seed_lists: list[list[int]], actor: str = "policy", weights: Any = None,
                explore: dict[str, Any] | None = None, record: bool = True,
                lockstep: bool = False) -> list[list[Any]]:
        """Worker k runs ``seed_lists[k]`` (k < size), all in parallel; results in worker order."""
        return self.wait(self.submit(seed_lists, actor, weights, explore, record, lockstep))

    def submit(self, seed_lists: list[list[int]], actor: str = "policy", weights: Any = None,
               explore: dict[str, Any] | None = None, record: bool = True, lockstep: bool = False) -> Any:
        """Start :meth:`collect` on the workers and return at once (the workers play while the caller
        computes); :meth:`wait` takes the episodes."""
        if len(seed_lists) > self.size:
            raise ValueError(f"{len(seed_lists)} seed lists for {self.size} workers")
        ref = self._ray.put(weights) if weights is not None else None
        return [a.collect.remote(seeds, actor, ref, explore, record, lockstep)
                for a, seeds in zip(self.actors, seed_lists)]

    def wait(self, handle: Any) -> list[list[Any]]:
        return list(self._ray.get(handle))

    def map_episodes(self, seeds: list[int], actor: str, weights: Any = None, explore: dict[str, Any] | None = None,
                     record: bool = False) -> Iterator[Any]:
        """One episode per seed on whichever worker is free; yielded as they finish."""
        ray = self._ray
        if weights is not None:
            ref = ray.put(weights)
            ray.get([a.set_weights.remote(ref, actor) for a in self.actors])
        todo = list(seeds)
        running: dict[Any, Any] = {}
        for a in self.actors:
            if todo:
                running[a.collect.remote([todo.pop(0)], actor, None, explore, record)] = a
        while running:
            done, _ = ray.wait(list(running), num_returns=1)
            a = running.pop(done[0])
            if todo:
                running[a.collect.remote([todo.pop(0)], actor, None, explore, record)] = a
            yield from ray.get(done[0])

    def shutdown(self) -> None:
        for a in self.actors:
            self._ray.kill(a)
        self.actors = []
        if self._started:
            self._ray.shutdown()


def make_pool(workers: int, env: EnvSpec, actors: dict[str, dict[str, Any]], ray_cfg: Any = None,
              torch_threads: int = 1) -> InProcessPool | RayPool:
    """``workers=0``: in-process; ``workers>=1``: that many Ray actors (``ray_cfg``: address, num_cpus, ...)."""
    if workers < 0:
        raise ValueError("workers must be >= 0")
    if workers == 0:
        return InProcessPool(env, actors, torch_threads)
    get: Callable[[str, Any], Any] = (lambda k, d: ray_cfg.get(k, d)) if ray_cfg is not None else (lambda k, d: d)
    return RayPool(workers, env, actors, address=get("address", None), num_cpus=get("num_cpus", None),
                   cpus_per_worker=float(get("cpus_per_worker", 1.0)), torch_threads=torch_threads)
