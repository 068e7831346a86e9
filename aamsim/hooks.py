"""Explicit hook lists with priorities and intervals.

Plugins and built-in services (conflict detection, metrics, the trajectory
recorder, the RL bridge) attach functions here; nothing is discovered
implicitly. Periodic hooks run on a sim-time interval; an interval of 0 means
every step (and forces the simulation to advance one step at a time).
Lower priority numbers run first; ties run in registration order.

A periodic hook can sleep (:meth:`HookList.sleep`) while its owner knows that
running it would change nothing but its own schedule: it is then neither run
nor waited for, so it no longer ends the kernel's batches. At every step
boundary its ``wake`` function is asked whether what it watches has changed;
when it wakes, it sets the hook's next due time to the one it would have had
after running, as a no-op, at each due time it slept through.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from aamsim.clock import Clock

US_PER_S = 1_000_000


@dataclass
class Hook:
    fn: Callable[..., Any]
    name: str
    priority: int
    interval_us: int
    order: int
    next_due_us: int = 0
    interval_fn: Callable[[], float] | None = None  # read at each run: the interval lives in the settings
    # While set, the hook sleeps: ``wake(now_us, ran_now, *args)`` (see HookList.sleep).
    wake: Callable[..., bool] | None = None


@dataclass
class HookList:
    """Ordered callbacks; periodic ones know when they are next due."""

    periodic: bool = False
    _hooks: list[Hook] = field(default_factory=list)
    _order: itertools.count = field(default_factory=itertools.count)
    sleeping: int = 0  # how many hooks sleep (see sleep)
    _last_call_us: int = -1  # the time of the last call_due: its hooks due then have run

    def add(
        self,
        fn: Callable[..., Any],
        *,
        priority: int = 100,
        interval_s: float | Callable[[], float] = 0.0,
        name: str | None = None,
        start_us: int = 0,
    ) -> Hook:
        """Add a hook; ``interval_s`` may be a function returning the interval, read each time the hook runs."""
        hook_name = str(name or getattr(fn, "__qualname__", repr(fn)))
        if any(h.name == hook_name for h in self._hooks):
            raise ValueError(f"a hook named {hook_name} is already registered")
        interval_fn = interval_s if callable(interval_s) else None
        first = interval_fn() if interval_fn is not None else float(interval_s)  # type: ignore[arg-type]
        hook = Hook(fn, hook_name, priority, int(round(first * US_PER_S)), next(self._order), start_us, interval_fn)
        self._hooks.append(hook)
        self._hooks.sort(key=lambda h: (h.priority, h.order))
        return hook

    def remove(self, name_or_fn: str | Callable[..., Any]) -> None:
        self._hooks = [h for h in self._hooks if h.name != name_or_fn and h.fn is not name_or_fn]
        self.sleeping = sum(h.wake is not None for h in self._hooks)

    def sleep(self, hook: Hook, wake: Callable[..., bool]) -> None:
        """Neither run ``hook`` nor wait for it until ``wake(now_us, ran_now, *args)`` returns True.

        The owner promises that, until what it watches changes, running the hook would change
        nothing but its schedule, and that the stepping of the traffic cannot change what it
        watches: then only a command or an API call can, both at or after a step boundary.
        ``wake`` is asked at every boundary: in the hook's place when the list runs (``ran_now``
        True when the list already ran at this time, so the hook would have too) and after the
        boundary's commands (:meth:`wake_sleepers`, ``ran_now`` True). Before it returns True it
        sets ``hook.next_due_us`` to the due time the hook would have now, had it run, for nothing,
        at each of its due times before ``now_us`` (with ``ran_now``: at or before).
        """
        if hook.wake is None:
            self.sleeping += 1
        hook.wake = wake

    def wake_sleepers(self, now_us: int, *args: Any) -> None:
        """Ask the sleeping hooks whether to wake, at ``now_us`` (see :meth:`sleep`)."""
        ran_now = self._last_call_us == now_us
        for hook in self._hooks:
            if hook.wake is not None and hook.wake(now_us, ran_now, *args):
                hook.wake = None
                self.sleeping -= 1

    def __iter__(self):
        return iter(list(self._hooks))

    def __len__(self) -> int:
        return len(self._hooks)

    def names(self) -> list[str]:
        return [h.name for h in self._hooks]

    def every_step(self) -> bool:
        """True when some periodic hook must run after every step."""
        return self.periodic and any(h.interval_us == 0 for h in self._hooks)

    def next_due_us(self) -> int | None:
        if not self.periodic or not self._hooks:
            return None
        if self.sleeping:
            return min((h.next_due_us for h in self._hooks if h.wake is None), default=None)
        return min(h.next_due_us for h in self._hooks)

    def call(self, *args: Any) -> None:
        for hook in list(self._hooks):
            hook.fn(*args)

    def call_due(self, now_us: int, dt_us: int, *args: Any) -> None:
        """Run periodic hooks due at ``now_us`` and schedule their next run."""
        ran_before = self._last_call_us == now_us
        self._last_call_us = now_us
        for hook in list(self._hooks):
            if hook.wake is not None:
                # Asked in its place in the list: the hooks before it may have changed what it watches.
                if not hook.wake(now_us, ran_before, *args):
                    continue
                hook.wake = None
                self.sleeping -= 1
            if hook.next_due_us <= now_us:
                hook.fn(*args)
                hook.interval_us = _interval_now(hook)
                step = max(hook.interval_us if hook.interval_us > 0 else dt_us, 1)
                # Periods missed within one long step are skipped in one go (a loop over
                # them froze the server for dt=1e300); the hook runs once, as before.
                missed = (now_us - hook.next_due_us) // step + 1
                hook.next_due_us += missed * step

    def restart(self, now_us: int = 0) -> None:
        for hook in self._hooks:
            hook.next_due_us = now_us
            hook.wake = None
        self.sleeping = 0
        self._last_call_us = -1


def sleep_while_unchanged(hooks: HookList, hook: Hook, clock: Clock, watched: Callable[[], object],
                          on_wake: Callable[[int | None], None] | None = None) -> bool:
    """Put ``hook``, running now at ``clock``'s time, to sleep until ``watched()`` changes (see :meth:`HookList.sleep`).

    For an owner whose runs would find nothing to do while ``watched()`` keeps its value now,
    and would only keep their phase: whole intervals from its due time on. ``watched()``
    holds the owner's state its runs read; the hook's interval and the time step are watched
    here. The stepping of the traffic must not change them. On waking, the hook is due where it
    would be, and ``on_wake(t_us)`` learns the last due time it slept through (None: none)
    for the owner to account for that run. The hook wakes at a boundary: where the owner reads
    that account in between (the conflict check's look-back, when an aircraft is deleted), it
    asks for the wake first (:meth:`HookList.wake_sleepers`). Returns False, and the hook stays
    awake, unless its due times are step boundaries from now on (the interval a whole number of
    steps, the due time of this run one too), where its runs would have been.
    """
    interval_us, dt_us = _interval_now(hook), clock.dt_us
    if interval_us <= 0 or interval_us % dt_us or (clock.simt_us - hook.next_due_us) % dt_us:
        return False
    before = watched()

    def wake(now_us: int, ran_now: bool, *args: Any) -> bool:
        if clock.dt_us == dt_us and _interval_now(hook) == interval_us and watched() == before:
            return False
        last = now_us if ran_now else now_us - 1
        slept_through = None
        if hook.next_due_us <= last:
            k = (last - hook.next_due_us) // interval_us
            slept_through = hook.next_due_us + k * interval_us
            hook.next_due_us = slept_through + interval_us
        if on_wake is not None:
            on_wake(slept_through)
        return True

    hooks.sleep(hook, wake)
    return True


def _interval_now(hook: Hook) -> int:
    """The interval [us] the hook would run at now (the one :meth:`HookList.call_due` reads after a run)."""
    return round(hook.interval_fn() * US_PER_S) if hook.interval_fn is not None else hook.interval_us


@dataclass
class Hooks:
    """All hook points of a simulation.

    * ``pre_step(sim)`` periodic: after the commands due now, before stepping;
    * ``post_step(sim)`` periodic: after stepping, before the commands due now;
    * ``reset(sim)``: after the simulation was reset;
    * ``created(sim, slot)``: an aircraft was created;
    * ``deleted(sim, slot, record)``: an aircraft is about to be removed.
    """

    pre_step: HookList = field(default_factory=lambda: HookList(periodic=True))
    post_step: HookList = field(default_factory=lambda: HookList(periodic=True))
    reset: HookList = field(default_factory=HookList)
    created: HookList = field(default_factory=HookList)
    deleted: HookList = field(default_factory=HookList)
