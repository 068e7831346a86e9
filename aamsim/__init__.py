"""aamsim: a BlueSky-compatible, headless, fast-time air-traffic simulator for AAM research."""

# Nothing runs at import: Numba's cache directory is chosen at the first compilation (aamsim/numba_cache.py).
from aamsim.api import SimulationAPI, Target
from aamsim.conflicts.separation import SeparationStandard
from aamsim.simulation import Simulation
from aamsim.traffic.view import TrafficView
from aamsim.units import Speed

# The distribution's version (PEP 440, MAJOR.MINOR.PATCH; 0.x: the API may still change between minor
# versions). Its only home: setup.cfg reads it, rlbridge re-exports it, CITATION.cff and the top
# release of CHANGELOG.md repeat it (tests/test_project_files.py); a release is the tag vX.Y.Z.
__version__ = "0.1.0"
__all__ = ["SeparationStandard", "Simulation", "SimulationAPI", "Speed", "Target", "TrafficView", "__version__"]
