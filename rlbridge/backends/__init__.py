"""Episode backends: where an environment's episodes run (docs/usecases.md).

=============  ===========================================================================
``local``      aamsim in this process (:class:`rlbridge.core.EpisodeCore`)
``zmq``        aamsim in a simulation server, over ZeroMQ (:class:`rlbridge.client.RemoteEpisode`)
``bluesky``    BlueSky (``bluesky-simulator``) in this process, headless
               (:class:`rlbridge.backends.bluesky.BlueSkyEpisode`)
=============  ===========================================================================

Every backend implements :class:`EpisodeBackend` with the same step results,
so the environments, the use cases and the agents run unchanged on each. A
backend never imports a use case; the use case is named (or given) by the caller.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Protocol

from aamsim.snapshots import TrafficSnapshot
from rlbridge.core import EpisodeCore, StepResult

BACKENDS = ("local", "zmq", "bluesky")


class EpisodeBackend(Protocol):
    """What an environment needs from the place its episodes run."""

    possible_agents: list[str]
    agents: list[str]
    # Whether step results carry the use case's action targets (rlbridge.usecases.targets), from the next reset.
    publish_targets: bool

    def reset(self, seed: int | None = None) -> StepResult: ...

    def step(self, actions: dict[str, Any]) -> StepResult: ...

    def metrics(self, groups: tuple[str, ...] = ("safety", "operational")) -> dict[str, Any]: ...

    def stack(self, text: str) -> list[str]: ...

    def traffic_state(self) -> dict[str, Any]: ...

    def snapshot(self, fields: tuple[str, ...] = ...) -> TrafficSnapshot:
        """A frozen copy of the traffic now (what a policy reads: rlbridge.agents.rollout.Actor)."""
        ...

    def close(self) -> None: ...


def make_backend(scenario: str | Path, usecase: str | type, params: dict[str, Any], backend: str,
                 address: str | None, time_limit_s: float | None, dt: float, timeout_s: float,
                 threads: int | None = None) -> EpisodeBackend:
    """The backend named ``backend`` for one scenario and use case (a registered name, or a class in-process).

    ``threads``: Numba threads stepping the traffic of a ``local`` episode (None: ``AAMSIM_THREADS``,
    else 1; aamsim.threads); the server and BlueSky choose their own.
    """
    if backend == "local":
        return EpisodeCore(scenario, usecase, params, time_limit_s=time_limit_s, dt=dt, threads=threads)
    if backend == "zmq":
        from rlbridge.client import RemoteEpisode

        if not address:
            raise ValueError('backend="zmq" needs address="tcp://host:port"')
        if not isinstance(usecase, str):
            raise ValueError(f'backend="zmq": the server knows use cases by registered name, not a class '
                             f'({getattr(usecase, "__name__", usecase)}); register it (docs/usecases.md) or run it '
                             f'in this process (backend="local")')
        remote: EpisodeBackend = RemoteEpisode(address, scenario, usecase, params, time_limit_s=time_limit_s, dt=dt,
                                               timeout_s=timeout_s)
        return remote
    if backend == "bluesky":
        from rlbridge.backends.bluesky import BlueSkyEpisode

        return BlueSkyEpisode(scenario, usecase, params, time_limit_s=time_limit_s, dt=dt)
    raise ValueError(f"backend must be one of {', '.join(repr(b) for b in BACKENDS)}, not {backend!r}")


__all__ = ["BACKENDS", "EpisodeBackend", "make_backend"]
