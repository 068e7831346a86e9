"""Episode variation drawn from the reset seed: what makes ``reset(seed=1)`` and ``reset(seed=2)`` differ.

The shipped scenarios are one draw of UAMToolkit's demand: run as they are, every episode would be
the same. Each use case therefore draws, by default, what the paper draws when it generates traffic
(``docs/usecases.md``, "Episode variation"), from the simulation's generator (seeded by the reset):

* **altitude noise** (:func:`redraw_altitude`): "imperfect altitude holding ... a uniform
  distribution with a minimum value of -100 ft and maximum value of 100 ft" (the paper, Numerical
  Experiments). An aircraft created within the noise band of one of the network's lanes gets its
  offset from that lane drawn again (the scenario's own draw is replaced, not added to); others get
  the noise added;
* **cruise speed** (:func:`draw_cruise_speed`): "each vehicle is assigned a cruising speed ... by a
  uniform distribution between 87 and 150 knots" (same section).

Every use case declares in ``fixed_traffic`` the parameters that switch its draws off: the
``-v0`` environment ids keep that fixed traffic for results made before variation was the default.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from aamsim.units import FT

if TYPE_CHECKING:
    from aamsim import Simulation

PAPER_ALT_NOISE_FT = 100.0  # the paper's +-100 ft of imperfect altitude holding
NYC_LANES_FT = (500.0, 1200.0, 1900.0)  # the shipped network's lanes (docs/nyc-network.md)
PAPER_CRUISE_KTS = (87.0, 150.0)  # the paper's cruising-speed distribution (uniform)


def redraw_altitude(sim: Simulation, slot: int, noise_ft: float, lanes_m: np.ndarray) -> None:
    """Give aircraft ``slot`` a fresh uniform +-``noise_ft`` altitude offset from the simulation's generator.

    On a lane (within the band): the offset from the lane is drawn again; elsewhere it is added.
    Replayed real traffic flies where it was recorded and is left alone.
    """
    if noise_ft <= 0 or sim.view.noncooperative[slot]:
        return
    noise = float(sim.rng.uniform(-noise_ft, noise_ft)) * FT
    off = lanes_m - sim.view.alt[slot]
    k = int(np.argmin(np.abs(off))) if len(off) else -1
    on_lane = k >= 0 and abs(off[k]) <= noise_ft * FT + 1e-6
    sim.offset_altitude(slot, (float(off[k]) + noise) if on_lane else noise)


def add_altitude_noise(sim: Simulation, noise_ft: float, lanes_ft: tuple[float, ...], name: str) -> None:
    """Draw every created aircraft's altitude noise (:func:`redraw_altitude`) from a creation hook."""
    if noise_ft <= 0:
        return
    lanes_m = np.asarray(lanes_ft, dtype=np.float64) * FT
    sim.hooks.created.add(lambda s, i: redraw_altitude(s, i, noise_ft, lanes_m), name=name)


def draw_cruise_speed(sim: Simulation, range_kts: tuple[float, ...], name: str) -> None:
    """Select a cruise speed uniform in ``range_kts`` (low, high) for every created aircraft; () draws nothing."""
    if not range_kts:
        return
    low, high = float(range_kts[0]), float(range_kts[1])

    def hook(s: Simulation, i: int) -> None:
        if s.view.noncooperative[i]:
            return
        kts = float(s.rng.uniform(low, high))
        # Queued for now, after the commands the scenario files at this instant (its own SPD among
        # them), which the draw replaces: the scenario's speed is its one draw of the same distribution.
        s.schedule(s.simt, f"SPD {s.view.callsign(i)} {kts:.4f}")

    sim.hooks.created.add(hook, name=name)


def check_range(name: str, value: tuple[float, ...]) -> tuple[float, ...]:
    """A (low, high) range in knots, or () for none; anything else is an error naming the parameter."""
    out = tuple(float(x) for x in value)
    if out and (len(out) != 2 or not 0 <= out[0] <= out[1]):
        raise ValueError(f"{name} is (low, high) with 0 <= low <= high, or () for none; got {out}")
    return out
