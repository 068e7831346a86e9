"""Conflict detection (BlueSky STATEBASED) and loss-of-separation events (NMAC, LoWC)."""

from aamsim.conflicts.events import EventLog, SeparationEvent
from aamsim.conflicts.separation import LOWC, NMAC, PAPER_STANDARD, SeparationStandard
from aamsim.conflicts.service import (
    PAPER_VOLUMES,
    ConflictService,
    ConflictState,
    SeparationVolume,  # (defined in aamsim.conflicts.separation)
    closest_intruders,
    pairs_within,
)

__all__ = [
    "LOWC",
    "NMAC",
    "PAPER_STANDARD",
    "PAPER_VOLUMES",
    "ConflictService",
    "ConflictState",
    "EventLog",
    "SeparationEvent",
    "SeparationStandard",
    "SeparationVolume",
    "closest_intruders",
    "pairs_within",
]
