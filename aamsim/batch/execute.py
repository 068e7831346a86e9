"""Running a batch's jobs: one run directory each, serially or as Ray tasks.

A job runs in a scratch folder on whichever node Ray gives it, and returns
its run directory's files to the driver, which writes them under the batch
folder: the batch works the same on one machine and on a cluster whose
nodes share no file system. The scenario text travels with the job; only
files it PCALLs must exist on the node (at the same path).
"""

from __future__ import annotations

import os
import shutil
import socket
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aamsim.batch.plan import BatchJob


@dataclass
class JobResult:
    """What a job sends back: its summary, its run directory's files, where and how long it ran."""

    index: int
    summary: dict[str, Any] | None
    files: dict[str, bytes]
    node: str
    wall_s: float
    error: str | None = None


def run_job(job: BatchJob) -> JobResult:
    """Run one job in a scratch folder and collect its run directory (never raises)."""
    from aamsim.runner import RunConfig, run_scenario

    node = _node_name()
    wall0 = time.perf_counter()
    scratch = Path(tempfile.mkdtemp(prefix="aamsim-batch-"))
    try:
        fields = {**job.base, **job.setting.run_config_fields()}
        cfg = RunConfig(scenario=job.source.path, out_dir=scratch / "run", seed=job.seed,
                        text=job.source.text, name=job.source.name, **fields)
        result = run_scenario(cfg)
        files = {p.name: p.read_bytes() for p in sorted(result.out_dir.iterdir()) if p.is_file()}
        return JobResult(job.index, result.summary, files, node, time.perf_counter() - wall0)
    except Exception as exc:  # noqa: BLE001 - a failed job is reported in the batch table, the others go on
        return JobResult(job.index, None, {}, node, time.perf_counter() - wall0, f"{type(exc).__name__}: {exc}")
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _node_name() -> str:
    """Ray's node id when running in a Ray worker, else the host name."""
    try:
        import ray

        if ray.is_initialized():
            return str(ray.get_runtime_context().get_node_id())
    except ImportError:
        pass
    return socket.gethostname()


def run_serial(jobs: Sequence[BatchJob]) -> Iterator[JobResult]:
    """The jobs one by one in this process (no Ray)."""
    for job in jobs:
        yield run_job(job)


def run_on_ray(jobs: Sequence[BatchJob], address: str | None, workers: int | None,
               on_started: Callable[[dict[str, Any]], None] | None = None) -> Iterator[JobResult]:
    """The jobs as Ray tasks (one CPU each), yielded as they finish.

    Starts a local Ray with ``workers`` CPUs unless ``address`` names a
    cluster (``auto``, ``HOST:PORT`` or ``ray://HOST:10001``). Ray is shut
    down again only if this call started it.
    """
    import ray

    started_here = False
    if not ray.is_initialized():
        if address:
            ray.init(address=address, log_to_driver=False, configure_logging=False)
        else:
            ray.init(num_cpus=workers or os.cpu_count() or 1, include_dashboard=False, log_to_driver=False,
                     configure_logging=False)
        started_here = True
    try:
        if on_started is not None:
            on_started({"nodes": sum(1 for n in ray.nodes() if n.get("Alive")),
                        "cpus": int(ray.cluster_resources().get("CPU", 0))})
        remote = ray.remote(num_cpus=1, max_retries=1)(run_job)
        pending = [remote.remote(job) for job in jobs]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            for ref in done:
                yield ray.get(ref)
    finally:
        if started_here:
            ray.shutdown()
