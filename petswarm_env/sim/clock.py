"""The one discrete-event clock: a SimPy environment with bare callbacks and a plain-attribute time.

Radio frames, IR slots, token passes, master broadcasts and the wearables' bursts are events on it;
:meth:`~petswarm_env.sim.world.World.advance` runs it in physics substeps (:meth:`Clock.run_until`).

This is the only module that touches SimPy's private state (``_queue``, ``_eid``, ``_now``, the
events' ``_ok``, ``_defused`` and ``_value``); ``pyproject.toml`` bounds simpy to the major version
this was written against (4). What it adds to ``simpy.Environment``:

* ``clock.now`` is a plain attribute, not SimPy's property (a property read costs several times an
  attribute read, and the radio and the nodes read the time for every frame). SimPy's own ``_now``
  is kept equal to it: both are written here only, by :meth:`Clock.step` and :meth:`Clock.run_until`.
* ``clock.later(delay, fn, *args)`` runs ``fn(*args)`` after ``delay`` seconds of clock time: one
  entry on SimPy's queue with SimPy's ``(time, priority, id)`` key, so it is ordered among events
  exactly as a ``clock.timeout(delay)`` with one callback would be, but it is a bare ``(fn, args)``
  tuple — no event, no callback list, no value — that the clock's loop calls directly. The
  middleware schedules most of its work this way (a frame's CCA and delivery, the handling of a
  received frame after the MCU delay).
* :meth:`Clock.any_of` — "the first of these events", what ``simpy.AnyOf`` gives a process that
  only waits on it, without building a condition value.
"""

from __future__ import annotations

from collections.abc import Callable
from heapq import heappop, heappush
from typing import Any

import simpy
from simpy.events import NORMAL, PENDING, ConditionValue


class Clock(simpy.Environment):
    """The simulation's clock (SimPy), see the module docstring."""

    now: float = 0.0  # shadows SimPy's ``now`` property; an instance attribute equal to ``_now``

    def __init__(self, initial_time: float = 0.0):
        super().__init__(initial_time)
        self.now = self._now
        queue, eid, clock = self._queue, self._eid, self  # SimPy never replaces the queue or the counter

        def later(delay: float, fn: Callable[..., Any], *args: Any) -> None:
            heappush(queue, (clock.now + delay, NORMAL, next(eid), (fn, args)))

        self.later: Callable[..., None] = later

    def step(self) -> None:
        """SimPy's ``step`` (what ``run`` calls), which also runs a bare callback of :attr:`later`."""
        queue = self._queue
        if queue and type(queue[0][3]) is tuple:
            t, _, _, (fn, args) = heappop(queue)
            self._now = self.now = t
            fn(*args)
            return
        if queue:
            self.now = queue[0][0]  # the time SimPy's step is about to set
        super().step()

    def run_until(self, t: float) -> None:
        """Process every event before ``t``, then stand at ``t`` — what ``run(until=t)`` does,
        without scheduling a stop event and raising to leave the loop on every call. The body of
        ``simpy.Environment.step`` is inlined (no peek/step call per event); a bare callback of
        :attr:`later` is called directly."""
        queue = self._queue
        while queue and queue[0][0] < t:
            now, _, _, event = heappop(queue)
            self._now = self.now = now
            if type(event) is tuple:  # a bare callback: no event machinery
                event[0](*event[1])
                continue
            callbacks, event.callbacks = event.callbacks, None
            for callback in callbacks:
                callback(event)
            if not event._ok and not hasattr(event, "_defused"):  # a failed event nobody handled
                exc = type(event._value)(*event._value.args)
                exc.__cause__ = event._value
                raise exc
        self._now = self.now = t

    def any_of(self, events) -> simpy.Event:
        """An event that succeeds when the first of ``events`` has been processed — what
        ``simpy.AnyOf`` does for a process that only waits on it (the token ring's "responses or
        timeout"), without building a condition value. The same events go on the queue in the same
        order as with ``AnyOf``. Its value is a ``ConditionValue`` holding the first event."""
        return _FirstOf(self, events)


class _FirstOf(simpy.Event):

    def __init__(self, clock: Clock, events):
        self.env = clock
        self.callbacks = []
        self._value = PENDING
        for event in events:
            if event.callbacks is None:  # already processed
                self._check(event)
            else:
                event.callbacks.append(self._check)

    def _check(self, event: simpy.Event) -> None:
        if self._value is not PENDING:
            return  # an event after the first one (e.g. the timeout after the responses)
        if not event._ok:
            event._defused = True
            self.fail(event._value)
        else:
            value = ConditionValue()
            value.events.append(event)
            self.succeed(value)
