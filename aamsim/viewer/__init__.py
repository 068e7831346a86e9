"""See the traffic: frames of a run or a live simulation, and the web viewer that draws them.

:mod:`aamsim.viewer.frames` turns a live :class:`~aamsim.Simulation` or a run
directory into :class:`~aamsim.viewer.frames.TrafficFrame` pictures and a
:class:`~aamsim.viewer.frames.MapLayout`; :mod:`aamsim.viewer.server` serves
them to a browser page (``aamsim view RUN_DIR``, ``aamsim run --view``);
:mod:`aamsim.viewer.live` runs that server beside a simulation.
"""
