"""One BlueSky "process" on one aamsim :class:`~aamsim.Simulation`: the aircraft order, the stack, the echo.

:func:`aamsim.compat.bluesky.init` makes the session; ``bs.traf`` and ``bs.sim``
are views of it. It keeps what BlueSky's API has and aamsim does not:

* the order of the aircraft as BlueSky has it (creation order; a deletion
  shifts the ones after it) and the callsigns as they were given, kept up to
  date by the simulation's creation and deletion hooks, so that aircraft
  created by a stack command or deleted by an area appear where BlueSky would
  put them;
* the commands stacked and not yet run (:mod:`aamsim.compat.bluesky.stack`): they run
  at the start of the next ``bs.sim.step()``, as BlueSky's do, and what they
  report goes to BlueSky's echo;
* the simulation state (INIT, HOLD, OP, END) as BlueSky steps it.
"""

from __future__ import annotations

import logging
import random
import warnings
from typing import TYPE_CHECKING, Any

import numpy as np

from aamsim.compat.bluesky import settings
from aamsim.compat.bluesky._arrays import ArrayStore
from aamsim.simulation import Simulation

if TYPE_CHECKING:
    from aamsim.traffic.traffic import FlightRecord
    from aamsim.traffic.view import TrafficView

LOG = logging.getLogger("aamsim.compat.bluesky")

BS_OK, BS_ARGERR, BS_FUNERR, BS_CMDERR = 0, 1, 2, 4
INIT, HOLD, OP, END = 0, 1, 2, 3
_STATES = {Simulation.STATE_INIT: INIT, Simulation.STATE_HOLD: HOLD, Simulation.STATE_OP: OP}


class StackWarning(UserWarning):
    """A stack command the shim could not run (BlueSky echoes it; the caller's code keeps running)."""


class Session:
    """The simulation behind ``bs.traf`` / ``bs.sim`` and what BlueSky's API keeps beside it."""

    def __init__(self, package: Any, pending: list[str]) -> None:
        # BlueSky's Stack.cmdstack, the process's (``_state.PROCESS.pending``): given, not imported, so that
        # this module does not depend on the state module that holds the session (no import cycle, issue 29).
        self._pending = pending
        self.package = package  # the ``bluesky`` module: bs.scr and bs.net are looked up there, as BlueSky does
        self.simulation = Simulation(dt=settings.simdt)
        self.ids: list[str] = []  # BlueSky's traf.id: callsigns as given, in BlueSky's order (one list, kept)
        self.types: list[str] = []
        self._given: dict[str, str] = {}  # upper-case callsign -> as given
        self._naming: dict[str, tuple[str, str]] = {}  # callsign being created -> (name, type) as given
        self._order: np.ndarray = np.empty(0, dtype=np.int64)
        self._order_key: int | None = None
        self.arrays = ArrayStore(self)
        # BlueSky stays in INIT until a step finds traffic (aamsim's simulation operates from its first aircraft).
        self._operating = False
        hooks = self.simulation.hooks
        hooks.created.add(self._created, name="bluesky-api-order")
        hooks.deleted.add(self._deleted, name="bluesky-api-order")

    # ------------------------------------------------------------------ aircraft order
    @property
    def view(self) -> TrafficView:
        return self.simulation.view

    def _created(self, sim: Simulation, slot: int) -> None:
        acid = sim.view.callsign(slot)
        given, actype = self._naming.pop(acid, (acid, sim.view.actype(slot)))
        self._given[acid] = given
        self.ids.append(given)
        self.types.append(actype)

    def _deleted(self, sim: Simulation, slot: int, record: FlightRecord) -> None:
        given = self._given.pop(record.acid, record.acid)
        k = self.ids.index(given)
        del self.ids[k]  # in place: BlueSky's traf.id is one list, shifted by a deletion
        del self.types[k]

    def order(self) -> np.ndarray:
        """aamsim slot of each BlueSky position."""
        key = self.simulation._traffic.layout_version
        if key != self._order_key:
            view = self.view
            self._order = np.fromiter((view.slot(a) for a in self.ids), dtype=np.int64, count=len(self.ids))
            self._order_key = key
        return self._order

    def slots(self, idx: Any) -> np.ndarray:
        """aamsim slots of BlueSky positions (an int, or an array/list of them; negative counts from the end)."""
        order = self.order()
        return np.atleast_1d(order[np.asarray(idx, dtype=np.int64)])

    def create_as(self, acid: str, actype: str) -> None:
        """The next creation of ``acid`` keeps these spellings (BlueSky stores the callsign as given)."""
        self._naming[acid.upper()] = (acid, actype)

    def forget_naming(self) -> None:
        self._naming.clear()

    def write(self, target: str, slots: np.ndarray, values: np.ndarray) -> None:
        """A write to a BlueSky array, passed to the simulation (see :mod:`._arrays`)."""
        sim = self.simulation
        if target == "selspd":
            # BlueSky's selected speed is a Mach number when it lies between 0.1 and the threshold.
            sim.overwrite_state(slots, "selspd_mach", (values > 0.1) & (values < settings.casmach_threshold))
        sim.overwrite_state(slots, target, values)

    def changed(self) -> None:
        """The simulation changed: arrays handed out before are stale."""
        self.arrays.invalidate()

    def before_change(self) -> None:
        """Pass the writes to the arrays to the simulation before it changes."""
        self.arrays.flush()

    # ------------------------------------------------------------------ state and stepping
    @property
    def state(self) -> int:
        sim = self.simulation
        if sim.quit_requested:
            return END
        state = _STATES[sim.state]
        return INIT if state == OP and not self._operating else state

    def set_state(self, state: int) -> None:
        sim = self.simulation
        self._operating = state != INIT
        if state == END:
            sim.quit_requested = True
            return
        sim.quit_requested = False
        sim.state = {INIT: sim.STATE_INIT, HOLD: sim.STATE_HOLD, OP: sim.STATE_OP}[state]

    def step(self) -> None:
        """BlueSky's ``sim.step()``: run the stacked commands, then advance one time step when operating."""
        self.before_change()
        sim = self.simulation
        if self.state == INIT and (sim._traffic.n or len(sim.queue)):
            self.set_state(OP)
        self.process()
        if self.state == OP:
            sim.step_bluesky()
        self.changed()

    # ------------------------------------------------------------------ the stack
    def process(self, lines: list[str] | None = None) -> None:
        """Run stacked command lines now (those stacked while running run too, as in BlueSky)."""
        pending = self._pending if lines is None else lines
        if not pending:
            return
        self.before_change()
        while pending:
            self.run_line(pending.pop(0))
        self.changed()

    def run_line(self, line: str) -> bool:
        """Run one command line; what it reports goes to BlueSky's echo. False when it failed."""
        line = line.strip()
        if not line:
            return True
        word = line.split(None, 1)[0].upper().rstrip(",")
        rest = line[len(word):].strip(" ,")
        handled = _SIM_CONTROL.get(word)
        if handled is not None:
            return handled(self, rest, line)
        sim = self.simulation
        messages = sim.reporter.messages
        start = len(messages)
        ok = sim.stack(line)
        for msg in messages[start:]:
            if msg.kind == "error":
                flags = BS_CMDERR if msg.text.startswith("unknown command") else BS_FUNERR
                self.echo(f"{line}\n{msg.text}", flags)
            else:
                self.echo(msg.text, BS_OK)
        del messages[start:]  # echoed: a long training run must not keep every message
        return ok

    def echo(self, text: str, flags: int = BS_OK) -> None:
        """BlueSky's echo: to the network node (``bs.net.send('ECHO', ...)``, nothing when detached).

        A failed command is also given as a :class:`StackWarning` (once per text) and logged, so
        that it is never silent; BlueSky's detached node drops it.
        """
        net = getattr(self.package, "net", None)
        if net is not None and hasattr(net, "send"):
            net.send("ECHO", {"text": text, "flags": flags})
        if flags:
            LOG.warning("%s", text)
            warnings.warn(f"BlueSky stack: {text}", StackWarning, stacklevel=4)
        else:
            LOG.info("%s", text)

    # ------------------------------------------------------------------ whole-simulation changes
    def delete_all(self) -> None:
        sim = self.simulation
        names = list(sim.view.ids)
        if names:
            sim.delete(names)
        sim.flight_log.clear()  # nothing reads the closed flights here; a training run would keep them all

    def reset_traffic(self) -> None:
        """BlueSky's ``traf.reset()``: no aircraft, no wind, no turbulence, no conditional commands."""
        self.before_change()
        sim = self.simulation
        self.delete_all()
        sim._wind.clear()
        sim.conditions.clear()
        sim.stack("NOISE OFF")
        self.changed()

    def reset(self) -> None:
        """BlueSky's ``sim.reset()``: traffic, time, the step (back to ``settings.simdt``), stack and areas."""
        self.arrays.invalidate()
        self._pending.clear()
        sim = self.simulation
        self.delete_all()
        sim.reset()
        self._operating = False
        sim.set_dt(settings.simdt)
        sim.reporter.messages.clear()
        scr = getattr(self.package, "scr", None)
        if scr is not None and hasattr(scr, "reset"):
            scr.reset()
        self.changed()

    def seed(self, value: int) -> None:
        """BlueSky's SEED: Python's and numpy's global generators, and the simulation's own."""
        random.seed(value)
        np.random.seed(value)
        self.simulation.reseed(value)


def _ff(session: Session, rest: str, line: str) -> bool:
    # BlueSky's FF runs the simulation (state OP) fast; stepping with sim.step() is always as fast
    # as it goes, so the run time given only matters to sim.update()'s pacing, which the shim has not.
    session.set_state(OP)
    return True


def _op(session: Session, rest: str, line: str) -> bool:
    session.set_state(OP)
    return True


def _hold(session: Session, rest: str, line: str) -> bool:
    session.set_state(HOLD)
    return True


def _reset(session: Session, rest: str, line: str) -> bool:
    session.reset()
    return True


def _seed(session: Session, rest: str, line: str) -> bool:
    try:
        value = int(float(rest))
    except ValueError:
        session.echo(f"{line}\nSEED needs a whole number, not {rest!r}", BS_ARGERR)
        return False
    session.seed(value)
    return True


# Commands that control BlueSky's simulation object: the shim runs them itself (the rest go to aamsim's stack).
_SIM_CONTROL = {"FF": _ff, "FWD": _ff, "OP": _op, "RUN": _op, "START": _op, "CONTINUE": _op, "HOLD": _hold,
                "RESET": _reset, "SEED": _seed}
