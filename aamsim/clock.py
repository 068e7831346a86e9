"""The simulation clock's limits: what a time step may be, checked in one place.

The clock counts integer microseconds, so a step must be a whole number of
them and at least one. The bounds are deliberate, not the clock's limits:

* ``DT_MIN_S`` = 0.1 ms: a smaller step makes every simulated second cost
  more than 10,000 kernel steps and gains nothing for aircraft (BlueSky runs
  at 0.05 s); ``--dt 1e-9`` used to pass and divide by zero.
* ``DT_MAX_S`` = 10 s: BlueSky's DT limit here since the first version; a
  larger step would skip conflict checks and waypoint captures. ``dt=1e300``
  used to freeze the ZeroMQ server in a loop over missed hook periods.

Every entry point (``Simulation(dt=...)``, the ``DT`` command, ``aamsim run
--dt``, the server's ``open``/``reset`` requests) calls :func:`validate_dt`.
"""

from __future__ import annotations

import math

US_PER_S = 1_000_000
DT_MIN_S = 1e-4
DT_MAX_S = 10.0


class TimeStepError(ValueError):
    """A time step outside [DT_MIN_S, DT_MAX_S] or not a finite number."""


def validate_dt(dt_s: float) -> float:
    """``dt_s`` as a float if it is a usable time step [s]; raises :class:`TimeStepError`."""
    try:
        value = float(dt_s)
    except (TypeError, ValueError):
        raise TimeStepError(f"time step must be a number of seconds, not {dt_s!r}") from None
    if not math.isfinite(value) or not DT_MIN_S <= value <= DT_MAX_S:
        raise TimeStepError(f"time step must be between {DT_MIN_S:g} s and {DT_MAX_S:g} s, not {dt_s!r}")
    return value
