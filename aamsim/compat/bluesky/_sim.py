"""``bs.sim``: BlueSky's simulation control object over the session.

``step()`` runs the stacked commands, then advances one time step (``DT``)
when the simulation operates (OP: after ``OP``, ``FF``, or as soon as there is
traffic or a scenario command pending), as BlueSky's does. There is no
real-time pacing: ``update()`` is ``step()``, and ``FF``'s run time does not
stop anything (BlueSky checks it only in its paced loop).
"""

from __future__ import annotations

import datetime
from typing import TYPE_CHECKING, Any

from aamsim.compat.bluesky._errors import not_provided
from aamsim.compat.bluesky._session import HOLD, OP

if TYPE_CHECKING:
    from aamsim.compat.bluesky._session import Session


def _midnight() -> datetime.datetime:
    return datetime.datetime.now(datetime.UTC).replace(hour=0, minute=0, second=0, microsecond=0, tzinfo=None)


class Simulation:
    """``bs.sim``: state, time, step and reset (see the module docstring)."""

    def __init__(self, session: Session) -> None:
        self._session = session
        self.utc = _midnight()  # simulated UTC clock (advanced with the simulation time)
        self.dtmult = 1.0
        self.ffmode = False
        self.ffstop: float | None = None
        self.rtmode = False
        self.syst = -1.0
        self.bencht = 0.0
        self.benchdt = -1.0
        self.prevstate: int | None = None
        self.clients: set[Any] = set()

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        raise not_provided(f"bluesky.sim.{name}")

    @property
    def state(self) -> int:
        """bluesky.INIT, HOLD, OP or END."""
        return self._session.state

    @state.setter
    def state(self, value: int) -> None:
        self._session.set_state(value)

    @property
    def simt(self) -> float:
        """Simulation time [s]."""
        return self._session.simulation.simt

    @property
    def simdt(self) -> float:
        """Time step [s] (the DT command sets it)."""
        return self._session.simulation.dt

    def step(self, dt_increment: float = 0) -> None:
        """Run the stacked commands, then advance one time step when operating."""
        if dt_increment:
            raise not_provided("bluesky.sim.step(dt_increment)", "real-time catch-up steps; set DT instead")
        before = self._session.simulation.simt_us
        self._session.step()
        self.utc += datetime.timedelta(microseconds=self._session.simulation.simt_us - before)

    def update(self) -> None:
        """BlueSky's paced step; the shim has no real-time pacing, so it is :meth:`step`."""
        self.step()

    def reset(self) -> None:
        """Everything back to the start: no traffic, time 0, DT ``settings.simdt``, no stacked commands."""
        self._session.reset()
        self.utc = _midnight()
        self.ffmode, self.ffstop, self.dtmult = False, None, 1.0

    def op(self) -> None:
        """Operate (run)."""
        self._session.set_state(OP)
        self.ffmode, self.ffstop = False, None

    def hold(self) -> None:
        """Hold: ``step()`` runs the stacked commands but time stands still."""
        self._session.set_state(HOLD)
        self.ffmode, self.ffstop = False, None

    def quit(self) -> None:
        """End: ``step()`` no longer advances."""
        from aamsim.compat.bluesky._session import END

        self._session.set_state(END)

    def fastforward(self, nsec: float | None = None) -> None:
        """FF: operate as fast as possible (always the case here)."""
        self._session.set_state(OP)
        self.ffmode = True
        self.ffstop = (self.simt + nsec) if nsec else None

    def set_dtmult(self, mult: float) -> None:
        """Real-time multiplier (kept; there is no real-time pacing)."""
        self.dtmult = mult

    def realtime(self, flag: bool | None = None) -> tuple[bool, str]:
        if flag is not None:
            self.rtmode = flag
        return True, "Realtime mode is o" + ("n" if self.rtmode else "ff")

    def setseed(self, value: int) -> None:
        """Seed Python's and numpy's global generators (as BlueSky) and the simulation's own."""
        self._session.seed(value)
