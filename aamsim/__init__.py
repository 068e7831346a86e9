"""aamsim: a BlueSky-compatible, headless, fast-time air-traffic simulator for AAM research."""

from aamsim.simulation import Simulation

__version__ = "0.1.0"
__all__ = ["Simulation", "__version__"]
