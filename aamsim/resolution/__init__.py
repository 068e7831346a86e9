"""Conflict resolution: the DO-365 / DAIDALUS detect-and-avoid logic and its service (``RESO DAA``)."""

from aamsim.resolution.daa import (
    CORRECTIVE,
    LEVEL_NAMES,
    NONE,
    PREVENTIVE,
    WARNING,
    Alerts,
    DAAParams,
    DetectAndAvoid,
    SpeedBands,
)
from aamsim.resolution.service import DAAService

__all__ = ["CORRECTIVE", "LEVEL_NAMES", "NONE", "PREVENTIVE", "WARNING", "Alerts", "DAAParams", "DAAService",
           "DetectAndAvoid", "SpeedBands"]
