"""Explicit hook lists with priorities and intervals.

Plugins and built-in services (conflict detection, metrics, the trajectory
recorder, the RL bridge) attach functions here; nothing is discovered
implicitly. Periodic hooks run on a sim-time interval; an interval of 0 means
every step (and forces the simulation to advance one step at a time).
Lower priority numbers run first; ties run in registration order.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

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


@dataclass
class HookList:
    """Ordered callbacks; periodic ones know when they are next due."""

    periodic: bool = False
    _hooks: list[Hook] = field(default_factory=list)
    _order: itertools.count = field(default_factory=itertools.count)

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
        return min(h.next_due_us for h in self._hooks)

    def call(self, *args: Any) -> None:
        for hook in list(self._hooks):
            hook.fn(*args)

    def call_due(self, now_us: int, dt_us: int, *args: Any) -> None:
        """Run periodic hooks due at ``now_us`` and schedule their next run."""
        for hook in list(self._hooks):
            if hook.next_due_us <= now_us:
                hook.fn(*args)
                if hook.interval_fn is not None:
                    hook.interval_us = round(hook.interval_fn() * US_PER_S)
                step = max(hook.interval_us if hook.interval_us > 0 else dt_us, 1)
                # Periods missed within one long step are skipped in one go (a loop over
                # them froze the server for dt=1e300); the hook runs once, as before.
                missed = (now_us - hook.next_due_us) // step + 1
                hook.next_due_us += missed * step

    def restart(self, now_us: int = 0) -> None:
        for hook in self._hooks:
            hook.next_due_us = now_us


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
