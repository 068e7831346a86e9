"""Conflict detection (BlueSky STATEBASED) and loss-of-separation events (NMAC, LoWC)."""

from aamsim.conflicts.service import (
    PAPER_VOLUMES,
    ConflictService,
    ConflictState,
    SeparationEvent,
    SeparationVolume,
    closest_intruders,
    conflicts_of,
)

__all__ = [
    "PAPER_VOLUMES",
    "ConflictService",
    "ConflictState",
    "SeparationEvent",
    "SeparationVolume",
    "closest_intruders",
    "conflicts_of",
]
