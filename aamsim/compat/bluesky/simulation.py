"""BlueSky's ``bluesky.simulation``: the ``Simulation`` class of ``bs.sim`` and ``ScreenIO``.

``ScreenIO`` is the screen stand-in of a simulation without a GUI: code that
subclasses it (bluesky-gym's ``ScreenDummy``) or assigns ``bs.scr`` keeps
working. Its drawing methods do nothing, as a detached BlueSky's do; ``echo``
logs the text.
"""

from __future__ import annotations

import logging
from typing import Any

from aamsim.compat.bluesky._errors import not_provided
from aamsim.compat.bluesky._sim import Simulation

__all__ = ["ScreenIO", "Simulation"]

LOG = logging.getLogger("aamsim.compat.bluesky")


class ScreenIO:
    """The screen of a simulation node without a GUI (nothing is drawn)."""

    def __init__(self) -> None:
        self.def_pan = (0.0, 0.0)
        self.def_zoom = 1.0
        self.route_all = ""
        self.client_route: dict[Any, str] = {}
        self.custacclr: dict[str, tuple[int, int, int]] = {}
        self.custgrclr: dict[Any, tuple[int, int, int]] = {}
        self.prevtime = 0.0
        self.samplecount = 0
        self.prevcount = 0

    def update(self) -> None:
        self.samplecount += 1

    def reset(self) -> None:
        self.__init__()  # type: ignore[misc]

    def echo(self, text: str = "", flags: int = 0) -> None:
        """Text for the operator: logged (a detached BlueSky sends it nowhere)."""
        LOG.log(logging.WARNING if flags else logging.INFO, "%s", text)

    # Display requests: a simulation without a screen has nothing to show them on (BlueSky's detached
    # node sends them nowhere either).
    def showroute(self, acid: str) -> bool:
        return True

    def addnavwpt(self, name: str, lat: float, lon: float) -> bool:
        return True

    def removenavwpt(self, name: str) -> bool:
        return True

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        raise not_provided(f"bluesky.simulation.ScreenIO.{name}")
