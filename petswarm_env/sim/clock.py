"""The one discrete-event clock: a typed event heap and loop, with SimPy's events and processes.

Radio frames, IR slots, token passes, master broadcasts and the wearables' bursts are events on it;
:meth:`~petswarm_env.sim.world.World.advance` runs it in physics substeps (:meth:`Clock.run_until`).

A module of the compiled core (``petswarm_env/_core.py``): Cython's pure-Python mode, so this file
runs as it is under the interpreter and is compiled to C at install. The clock is SimPy's
*environment* for SimPy's own events and processes (``simpy.Event``, ``Timeout``, ``Process``:
the middleware's generators run on it unchanged) — it has what they use of an environment
(``now``, ``schedule``, ``active_process``) — but its queue and loop are its own, typed:

* every entry of the queue is ordered by SimPy's key ``(time, priority, insertion id)``, the id
  counted by the clock for every entry, so events come off it in exactly SimPy's order;
* ``clock.now`` is a plain (C double) attribute;
* ``clock.later(delay, fn, *args)`` runs ``fn(*args)`` after ``delay`` seconds of clock time: one
  entry with SimPy's key, so it is ordered among events exactly as a ``clock.timeout(delay)`` with
  one callback would be, but it is a bare callback — no event, no callback list, no value — that the
  loop calls directly. The middleware schedules most of its work this way (a frame's CCA and
  delivery, the handling of a received frame after the MCU delay);
* ``clock.start(fn, *args)`` and ``clock.soon(fn, *args)``: a bare callback now, keyed where SimPy
  would put the first step of a process started now (``start``: its initialisation is *urgent*, before
  the events due now) or an event that succeeds now (``soon``: after the events already due now).
  With ``later`` they let a protocol written as callbacks (the token ring, :mod:`..middleware.token_ring`)
  run its steps exactly where the same protocol written as SimPy processes ran them;
* :meth:`Clock.any_of` — "the first of these events", what ``simpy.AnyOf`` gives a process that
  only waits on it, without building a condition value.

Each robot's MCU (and each wearable that keeps time) runs its own crystal, so it has its own clock
(seed 000 §3.3: the robots' clocks are independent — that is why the IR ring passes a token): a
:class:`LocalClock` over the one clock, ``local = offset + (1 + drift) · t``. Its ``timeout`` and
``later`` take local seconds (a timer of ``d`` local seconds fires after ``d / (1 + drift)`` true
seconds), its ``now`` is local time; the events and processes are the one clock's.

This is the only module that touches SimPy's internals (the events' ``callbacks``, ``_ok``,
``_defused``, ``_value``, the environment's ``_active_proc``); ``pyproject.toml`` bounds simpy to
the major version this was written against (4).
"""

from __future__ import annotations

from typing import Any, Optional

import cython
import simpy
from simpy.events import NORMAL, PENDING, URGENT, ConditionValue, Event, Process, Timeout

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)


@cython.final
@cython.freelist(256)  # entries are made and dropped for every event: reused, not allocated
@cython.cclass
class _Entry:
    """One entry of the queue: SimPy's key, and a SimPy event or a bare callback (``args`` not None).
    Its typed fields are declared in ``clock.pxd``: ``t``, ``prio``, ``eid``, ``event``, ``args``."""


@cython.cclass
class Due:
    """Work the clock runs at its time by one C call (its :meth:`run`), for the modules of the
    compiled core that schedule something for every frame (the radio's clear-channel assessment and
    delivery): the object carries its own arguments, so no callback's bound method nor argument
    tuple is made, and the loop calls it directly. Keyed like :meth:`Clock.later` (``Clock.call_due``):
    it runs exactly where ``later(delay, fn, *args)`` would have run ``fn(*args)``."""

    @cython.cfunc
    def run(self) -> cython.void:
        raise NotImplementedError(f"{type(self).__name__} gives no run()")


@cython.cfunc
@cython.inline
def _before(a: _Entry, b: _Entry) -> cython.bint:
    """SimPy's order: time, then priority, then insertion id (unique: a total order)."""
    if a.t != b.t:
        return a.t < b.t
    if a.prio != b.prio:
        return a.prio < b.prio
    return a.eid < b.eid


@cython.cclass
class Clock:
    """The simulation's clock, see the module docstring. Its typed attributes (``now``, the queue)
    and its C methods are declared in ``clock.pxd``."""

    def __init__(self, initial_time: float = 0.0):
        self.now = initial_time
        self._eid = 0
        self._heap = []
        self._active_proc = None

    # -- the queue: a binary heap of entries (heapq's algorithm, typed) ----------------------------
    @cython.cfunc
    def _push(self, t: cython.double, prio: cython.int, event: object, args: Optional[tuple]) -> cython.void:
        entry: _Entry = _Entry.__new__(_Entry)  # no __init__: the fields are set here
        entry.t = t
        entry.prio = prio
        entry.event = event
        entry.args = args
        entry.due = False
        self._insert(entry)

    @cython.cfunc
    def _insert(self, entry: _Entry) -> cython.void:
        """Put ``entry`` on the heap with the next insertion id."""
        heap: list = self._heap
        entry.eid = self._eid
        self._eid += 1
        heap.append(entry)
        pos: cython.Py_ssize_t = len(heap) - 1
        parent: _Entry
        while pos > 0:
            up: cython.Py_ssize_t = (pos - 1) >> 1
            parent = heap[up]
            if not _before(entry, parent):
                break
            heap[pos] = parent
            pos = up
        heap[pos] = entry

    @cython.cfunc
    def _pop(self) -> _Entry:
        heap: list = self._heap
        last: _Entry = heap.pop()
        if not heap:
            return last
        top: _Entry = heap[0]
        n: cython.Py_ssize_t = len(heap)
        pos: cython.Py_ssize_t = 0
        child: cython.Py_ssize_t = 1
        while child < n:  # sift ``last`` down from the root
            right: cython.Py_ssize_t = child + 1
            if right < n and _before(heap[right], heap[child]):
                child = right
            if not _before(heap[child], last):
                break
            heap[pos] = heap[child]
            pos = child
            child = 2 * pos + 1
        heap[pos] = last
        return top

    # -- what SimPy's events and processes use of their environment -------------------------------
    def schedule(self, event, priority: cython.int = NORMAL, delay: cython.double = 0.0) -> None:
        """Put ``event`` on the queue at ``now + delay`` (SimPy's ``Environment.schedule``)."""
        self._push(self.now + delay, priority, event, None)

    @property
    def active_process(self):
        return self._active_proc

    def process(self, generator) -> Process:
        return Process(self, generator)

    def timeout(self, delay: float = 0, value: Any = None) -> Timeout:
        return Timeout(self, delay, value)

    def event(self) -> Event:
        return Event(self)

    def any_of(self, events) -> Event:
        """An event that succeeds when the first of ``events`` has been processed — what
        ``simpy.AnyOf`` does for a process that only waits on it (the join and recovery managers'
        "responses or timeout"), without building a condition value. The same events go on the queue in the same
        order as with ``AnyOf``. Its value is a ``ConditionValue`` holding the first event."""
        return _FirstOf(self, events)

    # -- the clock's own ------------------------------------------------------------------------
    def later(self, delay: cython.double, fn, *args) -> None:
        """Run ``fn(*args)`` after ``delay`` seconds of clock time (a bare callback, module docstring)."""
        self._push(self.now + delay, NORMAL, fn, args)

    @cython.cfunc
    def call_later(self, delay: cython.double, fn: object, args: tuple) -> cython.void:
        """:meth:`later` with the arguments in a tuple: what the other modules of the compiled core
        call (a C call in the compiled form, ``clock.pxd``)."""
        self._push(self.now + delay, NORMAL, fn, args)

    @cython.cfunc
    def call_due(self, delay: cython.double, due: Due) -> cython.void:
        """Run ``due.run()`` after ``delay`` seconds of clock time: one entry keyed as :meth:`later`'s
        (a C call in the compiled form, ``clock.pxd``)."""
        entry: _Entry = _Entry.__new__(_Entry)
        entry.t = self.now + delay
        entry.prio = NORMAL
        entry.event = due
        entry.args = None
        entry.due = True
        self._insert(entry)

    def start(self, fn, *args) -> None:
        """Run ``fn(*args)`` now, before the events due now: where SimPy runs the first step of a
        process started now (its ``Initialize`` event is urgent)."""
        self._push(self.now, URGENT, fn, args)

    def soon(self, fn, *args) -> None:
        """Run ``fn(*args)`` now, after the entries already due now: where SimPy processes an event
        that succeeds now (``event.succeed()``)."""
        self._push(self.now, NORMAL, fn, args)

    @cython.ccall
    def run_until(self, t: cython.double):
        """Process every entry before ``t``, then stand at ``t`` — what SimPy's ``run(until=t)``
        does (its stop event at ``t`` comes before the events at ``t``)."""
        heap: list = self._heap
        entry: _Entry
        while heap:
            entry = heap[0]
            if not entry.t < t:
                break
            entry = self._pop()
            self.now = entry.t
            if entry.due:  # work that runs itself: one C call
                due: Due = entry.event
                due.run()
            elif entry.args is not None:  # a bare callback: no event machinery
                entry.event(*entry.args)
            else:
                self._process(entry.event)
        self.now = t

    def run(self, until: float) -> None:
        """SimPy's ``run(until=...)`` (a time): :meth:`run_until`."""
        self.run_until(until)

    @cython.cfunc
    def _process(self, event) -> cython.void:
        """SimPy's processing of a triggered event: its callbacks, then a failure nobody handled."""
        callbacks = event.callbacks
        event.callbacks = None
        for callback in callbacks:
            callback(event)
        if not event._ok and not hasattr(event, "_defused"):  # a failed event nobody handled
            exc = type(event._value)(*event._value.args)
            exc.__cause__ = event._value
            raise exc

    def pending(self) -> int:
        """How many entries wait on the queue."""
        return len(self._heap)


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


@cython.final
@cython.cclass
class LocalClock:
    """One MCU's own clock over the simulation's :class:`Clock` (module docstring): it reads
    ``offset_s + (1 + drift) · t`` at true time ``t``, and its timers count its own seconds. A robot's
    middleware sees only this (``Station.clock``): what it schedules and the times it writes into its
    own state are its own; it never reads another robot's clock. ``drift`` is a fraction (50 ppm is
    5e-5); ``offset_s`` is arbitrary (the time since the MCU powered on): nothing depends on it."""

    def __init__(self, clock: Clock, offset_s: float = 0.0, drift: float = 0.0):
        if not -0.5 < drift < 0.5:
            raise ValueError(f"a clock drift of {drift!r} is not a crystal's: give a fraction such as 5e-5 (50 ppm)")
        self._clock = clock
        self.offset_s = offset_s
        self.drift = drift
        self._rate = 1.0 + drift

    @property
    def now(self) -> float:
        """This clock's reading now (local seconds)."""
        return self.offset_s + self._rate * self._clock.now

    @cython.cfunc
    def local_now(self) -> cython.double:
        """:attr:`now` (a C call in the compiled form, ``clock.pxd``)."""
        return self.offset_s + self._rate * self._clock.now

    @cython.ccall
    def local(self, t_true: cython.double) -> cython.double:
        """This clock's reading at true time ``t_true`` (for what a sensor hands its MCU at ``t_true``)."""
        return self.offset_s + self._rate * t_true

    def true_time(self, t_local: cython.double) -> cython.double:
        """The true time at which this clock read ``t_local`` — for the experimenter's records
        (metrics), never for the robot."""
        return (t_local - self.offset_s) / self._rate

    def true_delay(self, d_local: cython.double) -> cython.double:
        """How many true seconds ``d_local`` seconds of this clock last."""
        return d_local / self._rate

    def timeout(self, delay: float = 0, value: Any = None) -> Timeout:
        """SimPy's ``timeout``, ``delay`` in this clock's seconds."""
        return self._clock.timeout(delay / self._rate, value)

    def later(self, delay: cython.double, fn, *args) -> None:
        """:meth:`Clock.later`, ``delay`` in this clock's seconds."""
        self._clock._push(self._clock.now + delay / self._rate, NORMAL, fn, args)

    @cython.cfunc
    def call_later(self, delay: cython.double, fn: object, args: tuple) -> cython.void:
        """:meth:`later` with the arguments in a tuple (:meth:`Clock.call_later`)."""
        self._clock._push(self._clock.now + delay / self._rate, NORMAL, fn, args)

    @cython.cfunc
    def call_due(self, delay: cython.double, due: Due) -> cython.void:
        """:meth:`Clock.call_due`, ``delay`` in this clock's seconds."""
        self._clock.call_due(delay / self._rate, due)

    @cython.cfunc
    def call_start(self, fn: object, args: tuple) -> cython.void:
        """:meth:`start` with the arguments in a tuple (a C call in the compiled form)."""
        self._clock._push(self._clock.now, URGENT, fn, args)

    @cython.cfunc
    def call_soon(self, fn: object, args: tuple) -> cython.void:
        """:meth:`soon` with the arguments in a tuple (a C call in the compiled form)."""
        self._clock._push(self._clock.now, NORMAL, fn, args)

    def start(self, fn, *args) -> None:
        """:meth:`Clock.start` (no delay: the same on every clock)."""
        self._clock._push(self._clock.now, URGENT, fn, args)

    def soon(self, fn, *args) -> None:
        """:meth:`Clock.soon` (no delay: the same on every clock)."""
        self._clock._push(self._clock.now, NORMAL, fn, args)

    def process(self, generator) -> Process:
        return self._clock.process(generator)

    def event(self) -> Event:
        return self._clock.event()

    def any_of(self, events) -> Event:
        return self._clock.any_of(events)
