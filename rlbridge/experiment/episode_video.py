"""``aamgym evaluate ... video=true``: the first evaluation episode of each policy beside the unequipped one.

The episode is played again in this process with the same seed, weights and
exploration setting, so it is the episode the evaluation scored (the test
checks the counts agree). While it runs, a trajectory recorder writes the
episode's run directory (``trajectories.csv``, ``conflicts.csv``,
``flights.csv``, ``scenario.scn`` beside the evaluation's ``summary.json``),
which ``aamsim view`` and ``aamsim figure`` read like any run. The video puts
the policy's panel beside the unequipped baseline's, at the same sim times.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from aamsim.metrics import write_conflicts_csv
from aamsim.output.flights import write_flights
from aamsim.output.recorder import TrajectoryRecorder
from rlbridge.agents.rollout import EnvSpec, RolloutWorker
from rlbridge.core import EpisodeCore

RECORD_PERIOD_S = 1.0  # trajectory samples, as `aamsim run` writes them by default


def record_episode(env: EnvSpec, actor: str, spec: dict[str, Any], weights: Any, explore: dict[str, Any],
                   seed: int, out_dir: Path) -> Any:
    """Play one episode of ``actor`` and write its run directory into ``out_dir``; returns its statistics."""
    if env.backend != "local":
        raise ValueError(f"video=true records episodes in aamsim (backend=local), not on {env.backend}")
    out_dir.mkdir(parents=True, exist_ok=True)
    worker = RolloutWorker(env, {actor: spec})
    if weights is not None:
        worker.set_weights(weights, actor)
    core = worker._core_for(worker.actors[actor])
    if not isinstance(core, EpisodeCore):  # backend local: the recorder attaches to aamsim's simulation
        raise TypeError(f"video=true records an aamsim episode, not a {type(core).__name__}")
    recorders: list[TrajectoryRecorder] = []

    def attach(sim: Any) -> None:
        rec = TrajectoryRecorder(out_dir / "trajectories.csv", RECORD_PERIOD_S)
        rec.attach(sim)
        recorders.append(rec)

    core.on_new_simulation.append(attach)
    try:
        stats = worker.run_episode(seed, explore, record=False, actor=actor).stats
    finally:
        core.on_new_simulation.remove(attach)
        for rec in recorders:
            rec.close()
    sim = core.sim
    assert sim is not None
    write_conflicts_csv(out_dir / "conflicts.csv", sim, sim.services.conflicts.events)
    write_flights(out_dir / "flights.csv", sim.flight_log)
    (out_dir / "scenario.scn").write_text(core.text, encoding="utf-8")
    return stats


def write_comparison_video(policy_dir: Path, policy_label: str, baseline_dir: Path, out_path: Path,
                           speed: float, fps: float) -> int:
    """The policy's episode (left) beside the unequipped baseline's (right); returns the frame count."""
    from aamsim.render.video import write_runs_video

    return write_runs_video([(policy_label, policy_dir), ("Unequipped", baseline_dir)], out_path, speed=speed,
                            fps=fps, width=640, height=640, progress=False)
