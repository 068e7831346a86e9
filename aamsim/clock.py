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


class Clock:
    """Simulation time in integer microseconds and the time step that advances it.

    The step is owned here (``DT`` and every entry point set it through
    :meth:`set_dt`); times are integers so that a day of 0.05 s steps ends
    exactly at 86,400 s.
    """

    __slots__ = ("dt_s", "dt_us", "simt_us")

    def __init__(self, dt_s: float = 0.05):
        self.simt_us = 0
        self.dt_s = 0.0
        self.dt_us = 0
        self.set_dt(dt_s)

    @property
    def simt(self) -> float:
        """Simulation time [s]."""
        return self.simt_us / US_PER_S

    def set_dt(self, dt_s: float) -> None:
        """Set the time step [s]; raises :class:`TimeStepError` outside the bounds above."""
        self.dt_s = validate_dt(dt_s)
        self.dt_us = round(self.dt_s * US_PER_S)

    def advance(self, steps: int) -> None:
        self.simt_us += steps * self.dt_us

    def reset(self) -> None:
        """Back to time 0; the step is kept (RESET keeps DT, as BlueSky does)."""
        self.simt_us = 0
