"""Conditional commands (ATALT, ATSPD, ATDIST): run a command once a threshold is crossed.

A condition fires in the step where ``target - actual`` changes sign (or
becomes zero), as in BlueSky; it is then removed. Conditions of a deleted
aircraft are dropped when it is deleted. The step kernel evaluates them; this module keeps the
list and hands the kernel flat arrays.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from aamsim.errors import SourceRef
from aamsim.traffic.kernel import COND_ALT, COND_DIST, COND_SPD
from aamsim.traffic.traffic import Traffic

KINDS = {"alt": COND_ALT, "spd": COND_SPD, "dist": COND_DIST}


@dataclass
class Condition:
    acid: str
    kind: int  # COND_ALT | COND_SPD | COND_DIST
    target: float  # m, CAS m/s, or m
    lastdif: float
    command: str
    source: SourceRef
    lat: float = 0.0
    lon: float = 0.0


@dataclass
class Conditions:
    items: list[Condition] = field(default_factory=list)
    _cache: tuple[np.ndarray, ...] | None = field(default=None, repr=False)
    _cache_layout: tuple[Traffic | None, int] = field(default=(None, -1), repr=False)  # traffic and its layout
    _cache_n: int = -1

    def __len__(self) -> int:
        return len(self.items)

    def _sync(self) -> None:
        """Copy the kernel's differences back into the items before the cache is rebuilt."""
        if self._cache is not None and len(self._cache[3]) == len(self.items):
            for k, c in enumerate(self.items):
                c.lastdif = float(self._cache[3][k])
        self._cache = None

    def add(self, cond: Condition) -> None:
        self._sync()
        self.items.append(cond)

    def drop_aircraft(self, acid: str) -> None:
        """Forget the conditions of an aircraft being deleted.

        Done at deletion, not when the kernel next runs: an aircraft deleted and
        created again under the same callsign in one step must not inherit them.
        """
        if any(c.acid == acid for c in self.items):
            self._sync()
            self.items = [c for c in self.items if c.acid != acid]

    def clear(self) -> None:
        self._cache = None
        self.items.clear()

    def arrays(self, traffic: Traffic) -> tuple[np.ndarray, ...]:
        """Kernel arrays for the live conditions (drops those of deleted aircraft).

        Cached while neither the conditions nor the aircraft slots change; the
        kernel updates ``lastdif`` in place and :meth:`update_after` keeps it.
        """
        # cached(), inlined: this runs before every kernel call (some 18,000 per corridor episode).
        arrays, layout = self._cache, self._cache_layout
        if arrays is not None and layout[0] is traffic and layout[1] == traffic.layout_version \
                and self._cache_n == len(self.items):
            arrays[6][:] = False
            return arrays
        self._sync()
        self.items = [c for c in self.items if c.acid in traffic]
        n = len(self.items)
        ac = np.empty(n, dtype=np.int64)
        kind = np.empty(n, dtype=np.int64)
        target = np.empty(n)
        lastdif = np.empty(n)
        lat = np.empty(n)
        lon = np.empty(n)
        for k, c in enumerate(self.items):
            ac[k] = traffic.index(c.acid)
            kind[k] = c.kind
            target[k] = c.target
            lastdif[k] = c.lastdif
            lat[k] = c.lat
            lon[k] = c.lon
        self._cache = (ac, kind, target, lastdif, lat, lon, np.zeros(n, dtype=np.bool_))
        self._cache_layout = (traffic, traffic.layout_version)
        self._cache_n = n
        return self._cache

    def cached(self, traffic: Traffic) -> tuple[np.ndarray, ...] | None:
        """The kernel arrays :meth:`arrays` would return now without rebuilding them (fired flags as the
        kernel left them), or None when they must be rebuilt."""
        # Slots move only when aircraft come or go (the traffic's layout version changes then).
        layout = self._cache_layout
        if self._cache is not None and layout[0] is traffic and layout[1] == traffic.layout_version \
                and self._cache_n == len(self.items):
            return self._cache
        return None

    def adopt_arrays(self, views: tuple[np.ndarray, ...]) -> tuple[np.ndarray, ...]:
        """Use ``views`` (kind, target, lastdif, lat, lon, fired: parts of a pool's joint arrays, with the
        same values) in place of the cached arrays, keeping the slots; returns the new cached arrays."""
        assert self._cache is not None and len(views) == 6 and len(views[0]) == len(self._cache[0])
        self._cache = (self._cache[0], *views)
        return self._cache

    def update_after(self, lastdif: np.ndarray, fired: np.ndarray) -> list[Condition]:
        """Remove and return fired conditions (the others keep the kernel's new differences)."""
        if not fired.any():
            return []  # lastdif lives on in the cached arrays
        done: list[Condition] = []
        keep: list[Condition] = []
        for k, c in enumerate(self.items):
            c.lastdif = float(lastdif[k])
            (done if fired[k] else keep).append(c)
        self.items = keep
        self._cache = None
        return done
