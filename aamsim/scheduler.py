"""When things happen: the clock, the timed commands, the periodic hooks and the performance timer.

The simulation advances the traffic in batches of many kernel steps; a batch
must end exactly where something else is due, so that results are the same
as stepping one by one. :class:`Scheduler` owns every source of such events
except the ones found inside the kernel (a waypoint reached, a condition met)
and answers one question: how many steps until the next of them.
"""

from __future__ import annotations

from aamsim.clock import Clock
from aamsim.hooks import Hooks
from aamsim.stack.parser import TimedCommand
from aamsim.stack.queue import CommandQueue, to_us


class Scheduler:
    """The clock, the queue of timed commands, the hooks and the performance-refresh timer."""

    def __init__(self, clock: Clock, hooks: Hooks):
        self.clock = clock
        self.hooks = hooks
        self.queue = CommandQueue()
        self.next_perf_us = 0
        # An aircraft waits for its first performance refresh. Only a refresh that
        # changes something splits a batch: afterwards the refresh rewrites values
        # that are already in place.
        self.perf_pending = False

    def due_commands(self) -> list[TimedCommand]:
        """Remove and return the commands due now."""
        return self.queue.pop_due(self.clock.simt_us)

    def performance_due(self, interval_s: float, step_us: int) -> bool:
        """True at a performance refresh that changes something; advances the refresh timer.

        The refresh is due at the first step boundary at or after each time of the timer, as when
        stepping one by one. ``step_us``: the step that led to this boundary. When an earlier step
        boundary was already at or after the timer's last time (a batch of steps went past it), the
        refresh of that time ran there, with nothing to change (a pending refresh ends the batch at
        the timer: :meth:`steps_to_next_event`); what became pending since waits for the next time.
        """
        now = self.clock.simt_us
        if now < self.next_perf_us:
            return False
        interval = to_us(interval_s)
        last_due = self.next_perf_us + interval * ((now - self.next_perf_us) // interval)
        self.next_perf_us = last_due + interval
        if now - last_due >= step_us:
            return False
        refresh = self.perf_pending
        self.perf_pending = False
        return refresh

    def run_hooks(self, phase: str, *args: object) -> None:
        """Call the ``post_step`` or ``pre_step`` hooks due now."""
        hooks = self.hooks.post_step if phase == "post_step" else self.hooks.pre_step
        hooks.call_due(self.clock.simt_us, self.clock.dt_us, *args)

    def steps_to_next_event(self, end_us: int) -> int:
        """Kernel steps from now to the next scheduled event or ``end_us`` (at least one)."""
        now = self.clock.simt_us
        dt_us = self.clock.dt_us
        post, pre = self.hooks.post_step, self.hooks.pre_step
        if post.every_step() or pre.every_step():
            return 1
        hooks_due = [t for t in (post.next_due_us(), pre.next_due_us()) if t is not None]
        if any(t <= now for t in hooks_due):
            # A hook added after its list ran at this boundary (a service that a command built):
            # it runs at the next one, and the hooks behind it keep their times.
            return 1
        nxt = end_us if end_us > now else None
        candidates = (self.next_perf_us if self.perf_pending else None, self.queue.next_due_us(), *hooks_due)
        for t in candidates:
            if t is not None and t > now and (nxt is None or t < nxt):
                nxt = t
        if nxt is None:
            return 1
        return max(1, -(-(nxt - now) // dt_us))

    def reset(self) -> None:
        """Time 0, nothing pending (RESET)."""
        self.clock.reset()
        self.queue.clear()
        self.next_perf_us = 0
        self.perf_pending = False
        self.hooks.post_step.restart(0)
        self.hooks.pre_step.restart(0)
