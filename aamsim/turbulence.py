"""BlueSky's NOISE: turbulence as a random walk of the position, seeded by the simulation.

BlueSky's model (``traffic/turbulence.py``), kept: after every step each
aircraft is moved by normally distributed offsets with standard deviations
``sd * sqrt(dt)``, ``sd`` = 0 m/s along its track (BlueSky clamps it to
1e-6), 0.1 m/s across it and 0.1 m/s vertically; latitude changes by
``d_north / R`` and longitude by ``d_east / (R cos lat)``. Over 120 s at
dt 0.05 s the spread is about 1.1 m across track and in altitude.

The draws come from the simulation's generator (``SEED``, ``--seed``), three
arrays per step in BlueSky's order (along, across, vertical), so that a run
repeats bit for bit. BlueSky's ADS-B noise perturbs a copy of the state that
nothing in its simulation reads (conflict detection uses the true state), so
it has no counterpart here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from aamsim.stack.context import CommandContext

SD_ALONG_MPS = 1e-6  # BlueSky's 0, clamped to 1e-6
SD_ACROSS_MPS = 0.1
SD_VERTICAL_MPS = 0.1
_HOOK = "turbulence"


@dataclass
class Turbulence:
    active: bool = False

    def step(self, sim: CommandContext) -> None:
        """One step's offsets for every aircraft (a post-step hook that runs every step while active)."""
        view = sim.view
        n = view.n
        if not self.active or n == 0 or sim.simt <= 0.0:
            return
        scale = math.sqrt(sim.dt)
        rng = sim.rng
        along = rng.normal(0.0, SD_ALONG_MPS * scale, n)
        across = rng.normal(0.0, SD_ACROSS_MPS * scale, n)
        vertical = rng.normal(0.0, SD_VERTICAL_MPS * scale, n)
        trk = np.radians(view.trk)
        dnorth = np.cos(trk) * along - np.sin(trk) * across
        deast = np.sin(trk) * along + np.cos(trk) * across
        sim.displace(np.arange(n, dtype=np.int64), dnorth, deast, vertical)


def set_noise(sim: CommandContext, on: bool) -> None:
    """NOISE ON/OFF: the hook runs every step only while the noise is on (it splits the kernel's batches)."""
    turbulence = sim.features.get(Turbulence)
    if turbulence is None:
        turbulence = sim.features.add(Turbulence())
        sim.hooks.reset.add(lambda s: set_noise(s, False), name=f"{_HOOK}-reset")
    turbulence.active = on
    registered = _HOOK in sim.hooks.post_step.names()
    if on and not registered:
        # Before conflict detection (priority 10): BlueSky moves the aircraft inside its traffic update.
        sim.hooks.post_step.add(turbulence.step, interval_s=0.0, name=_HOOK, priority=5,
                                start_us=round(sim.simt * 1e6) + 1)
    elif not on and registered:
        sim.hooks.post_step.remove(_HOOK)


def noise_on(sim: CommandContext) -> bool:
    turbulence = sim.features.get(Turbulence)
    return bool(turbulence is not None and turbulence.active)
