"""Conditional commands (ATALT, ATSPD, ATDIST): run a command once a threshold is crossed.

A condition fires in the step where ``target - actual`` changes sign (or
becomes zero), as in BlueSky; it is then removed. Conditions of a deleted
aircraft are dropped. The step kernel evaluates them; this module keeps the
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

    def __len__(self) -> int:
        return len(self.items)

    def add(self, cond: Condition) -> None:
        self.items.append(cond)

    def clear(self) -> None:
        self.items.clear()

    def arrays(self, traffic: Traffic) -> tuple[np.ndarray, ...]:
        """Kernel arrays for the live conditions (drops those of deleted aircraft)."""
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
        return ac, kind, target, lastdif, lat, lon, np.zeros(n, dtype=np.bool_)

    def update_after(self, lastdif: np.ndarray, fired: np.ndarray) -> list[Condition]:
        """Store the kernel's new differences; remove and return fired conditions."""
        done: list[Condition] = []
        keep: list[Condition] = []
        for k, c in enumerate(self.items):
            c.lastdif = float(lastdif[k])
            (done if fired[k] else keep).append(c)
        self.items = keep
        return done
