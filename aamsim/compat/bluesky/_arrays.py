"""BlueSky's traffic arrays over aamsim's state: copies in BlueSky's order, and writes that take effect.

``bs.traf.lat`` is a numpy array indexed by BlueSky's position (creation order;
a deletion shifts the aircraft after it, where aamsim moves its last aircraft
into the freed slot). The store gathers each field from the simulation's view
on first use after a change and keeps it until the next step or command, so
reading a field many times costs one copy. Code written for BlueSky also
*writes* these arrays (``bs.traf.selalt[0] = 1e6``, ``bs.traf.hdg[i] = qdr``):
the store keeps a copy of what it handed out, and before anything else happens
to the simulation (a step, a command, an API call) :meth:`ArrayStore.flush`
passes every changed element to the simulation through
:meth:`aamsim.api.SimulationAPI.overwrite_state` — the shim never writes aamsim's
state arrays itself.

Writable arrays accept a one-element array where an element is assigned
(``selvs[0] = action`` with an action of shape (1,)), as BlueSky's arrays did
with NumPy 1.x; NumPy 2 refuses it, which stops bluesky-gym's DescentEnv and
VerticalCREnv on BlueSky itself.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

if TYPE_CHECKING:
    from aamsim.simulation import Simulation
    from aamsim.traffic.view import TrafficView


class ArraySession(Protocol):
    """What the store and the fields' sources use of the shim's session (:class:`._session.Session`).

    Declared here rather than imported, so that this module does not depend on the session module that
    imports it (the import graph of ``aamsim`` has no cycle, issue 29).
    """

    @property
    def simulation(self) -> Simulation:
        """The aamsim simulation behind the session."""

    @property
    def view(self) -> TrafficView:
        """The simulation's traffic view (aamsim's slot order)."""

    def order(self) -> np.ndarray:
        """aamsim slot of each aircraft, in BlueSky's order."""

    def write(self, target: str, slots: np.ndarray, values: np.ndarray) -> None:
        """Set the public field ``target`` of the aircraft in ``slots`` through the simulator's API."""


class FieldArray(np.ndarray):
    """A writable traffic array: element assignment takes a one-element array, as with NumPy 1.x."""

    def __setitem__(self, key: Any, value: Any) -> None:
        try:
            super().__setitem__(key, value)
        except (ValueError, TypeError):
            value = np.asarray(value)
            if value.size != 1:
                raise
            super().__setitem__(key, value.reshape(()))


Source = Callable[["TrafficView", np.ndarray, "ArraySession"], np.ndarray]


@dataclass(frozen=True)
class Field:
    """One BlueSky array: where its values come from and, when writable, which aamsim field a write sets."""

    name: str  # BlueSky's name (``traf.M``, ``traf.ap.trk`` -> "ap.trk")
    source: Source
    target: str | None = None  # aamsim public field set by a write (None: read-only)


def view_field(view_name: str) -> Source:
    """Values of the view's field ``view_name`` in BlueSky's order."""

    def get(view: TrafficView, order: np.ndarray, session: ArraySession) -> np.ndarray:
        return getattr(view, view_name)[order]

    return get


class ArrayStore:
    """The arrays handed out since the last change, and the copies that show what was written.

    An array, once built, is put in its owner's ``__dict__`` (``bs.traf.__dict__['lat']``), so that
    reading it again is a plain attribute lookup; the store removes it there when the simulation
    changes. Assigning a whole array (``bs.traf.alt = a``) goes through :meth:`assign`.
    """

    def __init__(self, session: ArraySession) -> None:
        self._session = session
        self._held: list[tuple[Any, str]] = []  # (owner, attribute) of the arrays handed out
        self._given: list[tuple[Any, str, Field, np.ndarray]] = []  # writable ones and a copy of what was handed out

    def get(self, owner: Any, attr: str, field: Field) -> np.ndarray:
        """Build the field's array and keep it as ``owner.<attr>`` until the next flush or invalidation."""
        session = self._session
        values = field.source(session.view, session.order(), session)
        if field.target is None:
            values.flags.writeable = False  # a write would change nothing: refuse it instead
            arr = values
        else:
            arr = values.view(FieldArray)
            self._given.append((owner, attr, field, values.copy()))
        owner.__dict__[attr] = arr
        self._held.append((owner, attr))
        return arr

    def assign(self, owner: Any, attr: str, field: Field, value: Any) -> None:
        """``owner.<attr> = value``: every element of the field is written."""
        arr = owner.__dict__.get(attr)
        if arr is None:
            arr = self.get(owner, attr, field)
        arr[...] = value

    def flush(self) -> None:
        """Pass every element written since the arrays were handed out to the simulation, then forget them."""
        if self._given:
            session = self._session
            order = session.order()
            for owner, attr, field, before in self._given:
                after = owner.__dict__.get(attr)
                if after is None or after.shape != before.shape:
                    continue  # handed out before aircraft came or went: stale, as in BlueSky
                if after.tobytes() == before.tobytes():
                    continue  # nothing written (a byte comparison: the common case, and cheap)
                changed = after != before
                if after.dtype.kind == "f":
                    changed &= ~(np.isnan(after) & np.isnan(before))
                if changed.any():
                    idx = np.flatnonzero(changed)
                    session.write(field.target or field.name, order[idx], np.asarray(after)[idx])
            self._given.clear()
        self.invalidate()

    def invalidate(self) -> None:
        """Forget the arrays without passing their writes (after the simulation has moved on)."""
        if self._held:
            for owner, attr in self._held:
                owner.__dict__.pop(attr, None)
            self._held.clear()
        self._given.clear()
