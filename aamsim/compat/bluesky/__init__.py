"""BlueSky 1.1's Python API on aamsim: code written for BlueSky runs unchanged on one aamsim Simulation.

::

    import aamsim.compat.bluesky as bs          # or: aamsim.compat.bluesky.install(); import bluesky as bs
    bs.init(mode="sim", detached=True)
    bs.traf.cre("KL001", actype="A320", acalt=3000.0, acspd=150.0)   # SI units, as BlueSky's API
    bs.stack.stack("DT 1; HDG KL001 90")          # runs at the next step
    bs.sim.step()                                 # one DT
    print(bs.traf.id, bs.traf.lat, bs.traf.hdg)   # numpy arrays in BlueSky's order

:func:`install` (or ``AAMSIM_BLUESKY=1`` in the environment, see
:func:`install_from_environment`) makes ``import bluesky`` resolve to this
package in the process, so that unchanged code (bluesky-gym's environments)
runs on aamsim. ``docs/bluesky-api.md`` lists every name: the same as BlueSky,
the same within a stated difference, or not provided (a ``NotImplementedError``
naming it). Like BlueSky's, this API is process-wide (``bs.traf``, ``bs.sim``):
the objects live in :mod:`._state`; :class:`aamsim.Simulation` is the way to
several simulations in one process.
"""

from __future__ import annotations

import importlib
import logging
from typing import Any

from aamsim.compat.bluesky._errors import NotProvided, NotProvidedModule, Unprovided, not_provided
from aamsim.compat.bluesky._finder import install, installed, uninstall

__all__ = ["NotProvided", "NotProvidedModule", "init", "install", "install_from_environment", "installed", "uninstall"]

LOG = logging.getLogger("aamsim.compat.bluesky")

# BlueSky's return flags and simulation states.
BS_OK, BS_ARGERR, BS_FUNERR, BS_CMDERR = 0, 1, 2, 4
INIT, HOLD, OP, END = 0, 1, 2, 3

# BlueSky's process-wide objects: None until init(), as in BlueSky (bluesky-gym assigns bs.scr).
mode = ""
gui = ""
traf: Any = None
sim: Any = None
scr: Any = None
net: Any = None
navdb: Any = None
ref: Any = None
server: Any = None

_SUBMODULES = ("settings", "stack", "tools", "simulation")


class DetachedNode:
    """``bs.net`` of a detached simulation node: no network, ``send`` goes nowhere (as BlueSky's)."""

    node_id = b"\x00aams"
    server_id = b""
    act_id = None

    def send(self, topic: Any, data: Any = "", to_group: bytes = b"") -> None:
        """Nothing to send to (BlueSky's detached node drops its messages too)."""

    def update(self) -> None:
        """Nothing to receive."""

    def connect(self) -> None:
        """A detached node connects to nothing."""

    def close(self) -> None:
        """Nothing to close."""

    def subscribe(self, topic: Any, from_id: bytes = b"", to_group: bytes = b"") -> None:
        """Nothing to subscribe to."""


def init(mode: str = "sim", configfile: str | None = None, scenfile: str | None = None,
         discoverable: bool = False, gui: str | None = None, detached: bool = False, workdir: str | None = None,
         group_id: Any = None, **kwargs: Any) -> None:
    """Start (or restart) the simulation behind ``bs.traf`` and ``bs.sim``: BlueSky's ``bluesky.init``.

    Only a simulation node is provided (``mode='sim'``); it has no network whatever
    ``detached`` says. A second call starts new traffic on the same simulation, as
    BlueSky's second ``init`` makes new traffic and simulation objects: the aircraft and
    the wind go, the stacked commands, the time step and the areas stay.

    Raises:
        NotImplementedError: ``mode`` other than ``'sim'``, a GUI, a configuration file,
            or ``discoverable`` (a server).
    """
    if mode != "sim":
        raise not_provided(f"bluesky.init(mode={mode!r})", "only a simulation node, mode='sim', is provided")
    if gui is not None:
        raise not_provided(f"bluesky.init(gui={gui!r})", "aamsim's web viewer: aamsim view / render_mode")
    if discoverable:
        raise not_provided("bluesky.init(discoverable=True)", "a BlueSky server")
    from aamsim.compat.bluesky import settings

    settings.init(configfile or "")
    from aamsim.compat.bluesky._session import Session
    from aamsim.compat.bluesky._sim import Simulation
    from aamsim.compat.bluesky._state import PROCESS
    from aamsim.compat.bluesky._traffic import Traffic
    from aamsim.compat.bluesky.simulation import ScreenIO

    package = importlib.import_module(__name__)
    session = PROCESS.session
    if session is None:
        session = PROCESS.session = Session(package, PROCESS.pending)
    else:
        session.reset_traffic()
        session.set_state(INIT)
    if workdir:
        from pathlib import Path

        session.simulation.files.search_path.insert(0, Path(workdir) / settings.scenario_path)
    if not detached:
        LOG.info("aamsim.compat.bluesky: a simulation node without network (as with detached=True)")
    g = globals()
    g.update(mode="sim", gui=gui or "", traf=Traffic(session), sim=Simulation(session), scr=ScreenIO(),
             net=DetachedNode(), navdb=Unprovided("bluesky.navdb", "stack commands read the navigation data"),
             ref=Unprovided("bluesky.ref"))
    if scenfile:
        from aamsim.compat.bluesky import stack

        stack.stack(f"IC {scenfile}")


def __getattr__(name: str) -> Any:
    if name in _SUBMODULES:
        return importlib.import_module(f"{__name__}.{name}")
    if name.startswith("__"):
        raise AttributeError(name)
    raise not_provided(f"bluesky.{name}")


ENVIRONMENT_VARIABLE = "AAMSIM_BLUESKY"


def install_from_environment() -> bool:
    """:func:`install` when ``AAMSIM_BLUESKY`` says so (1, true, yes, on); run by the startup hook.

    The installation's ``aamsim_bluesky.pth`` calls it at the start of every Python
    process when the variable is set to anything but 0; a value it does not
    understand is reported and changes nothing. Returns whether the shim is installed.
    """
    import os
    import warnings

    value = os.environ.get(ENVIRONMENT_VARIABLE, "").strip().lower()
    if value in ("1", "true", "yes", "on"):
        install()
        return True
    if value not in ("", "0", "false", "no", "off"):
        warnings.warn(f"{ENVIRONMENT_VARIABLE}={value!r} is not understood: set it to 1 to run `import bluesky` "
                      "on aamsim (aamsim.compat.bluesky), unset or 0 for the real BlueSky", stacklevel=2)
    return False
