"""Compatibility layers: other simulators' Python APIs on aamsim (``aamsim.compat.bluesky``)."""
