"""Bare callbacks on the SimPy clock: ``fn(*args)`` at a later instant, one queue entry each.

The middleware schedules most of its work this way (a frame's CCA and delivery, the handling of a
received frame after the MCU delay). A call goes on the clock's queue like any SimPy event (same
``(time, priority, id)`` key, so the order of events is SimPy's), but it is not a ``simpy.Event``:
no callback list to build, no value, nothing to wait on. On the env's clock it is a bare
``(fn, args)`` tuple that :meth:`~.world.Clock.run_until` calls directly; on any other SimPy
environment (unit tests of the radio) it is a :class:`Call`, which SimPy's own ``step`` runs
through its one callback.
"""

from __future__ import annotations

from collections.abc import Callable
from heapq import heappush
from typing import Any

import simpy
from simpy.events import NORMAL


class Call:
    __slots__ = ("args", "callbacks", "fn")
    _ok = True  # SimPy's step checks it

    def __init__(self, fn: Callable[..., Any], args: tuple):
        self.fn = fn
        self.args = args
        self.callbacks = _RUN  # SimPy's step calls these (and sets the attribute to None)


def _run(call: Call) -> None:
    call.fn(*call.args)


_RUN = (_run,)


def scheduler(clock: simpy.Environment) -> Callable[..., None]:
    """:func:`call_later` bound to one clock, ``later(delay, fn, *args)``: the same queue entry,
    without finding the clock's kind again on every call (the radio and the nodes schedule a few
    dozen calls per control step)."""
    queue, eid = clock._queue, clock._eid  # SimPy never replaces either
    if getattr(clock, "fast_calls", False):

        def later(delay: float, fn: Callable[..., Any], *args: Any) -> None:
            heappush(queue, (clock._now + delay, NORMAL, next(eid), (fn, args)))

    else:

        def later(delay: float, fn: Callable[..., Any], *args: Any) -> None:
            heappush(queue, (clock._now + delay, NORMAL, next(eid), Call(fn, args)))

    return later


def call_later(clock: simpy.Environment, delay: float, fn: Callable[..., Any], *args: Any) -> None:
    """Run ``fn(*args)`` after ``delay`` seconds of clock time (one entry on the clock's queue,
    ordered as ``clock.schedule`` orders events). On the env's clock (:class:`~.world.Clock`,
    ``fast_calls``) the entry is the bare ``(fn, args)`` tuple; any other SimPy environment gets a
    :class:`Call`, which its own ``step`` can run."""
    if getattr(clock, "fast_calls", False):
        heappush(clock._queue, (clock._now + delay, NORMAL, next(clock._eid), (fn, args)))
    else:
        heappush(clock._queue, (clock._now + delay, NORMAL, next(clock._eid), Call(fn, args)))
