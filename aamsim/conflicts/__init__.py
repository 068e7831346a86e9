"""Conflict detection (BlueSky STATEBASED) and loss-of-separation events (NMAC, LoWC)."""

from aamsim.conflicts.events import EventLog, SeparationEvent
from aamsim.conflicts.service import (
    PAPER_VOLUMES,
    ConflictService,
    ConflictState,
    SeparationVolume,
    closest_intruders,
    conflicts_of,
    pairs_within,
)

__all__ = [
    "PAPER_VOLUMES",
    "ConflictService",
    "ConflictState",
    "EventLog",
    "SeparationEvent",
    "SeparationVolume",
    "closest_intruders",
    "conflicts_of",
    "pairs_within",
]
