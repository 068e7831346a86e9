"""A minimal plugin: counts aircraft-steps and adds a ``COUNTSTEPS`` command.

It is the example of ``docs/plugins.md`` and is loaded by the test suite.
"""

from __future__ import annotations

from dataclasses import dataclass

from aamsim.stack.registry import command


@dataclass
class StepCounter:
    samples: int = 0
    aircraft_seen: int = 0

    def on_sample(self, sim) -> None:
        self.samples += 1
        self.aircraft_seen += sim.view.n


def init_plugin(sim) -> StepCounter:
    counter = StepCounter()
    sim.hooks.post_step.add(counter.on_sample, interval_s=1.0, name="example.on_sample")

    @command("COUNTSTEPS")
    def countsteps(sim) -> str:
        """COUNTSTEPS: how many 1 s samples and aircraft the example plugin saw."""
        return f"{counter.samples} samples, {counter.aircraft_seen} aircraft-samples"

    sim.commands.add(countsteps)
    return counter
