"""Bare callbacks on the SimPy clock: ``fn(*args)`` at a later instant, one queue entry each.

The middleware schedules most of its work this way (a frame's CCA and delivery, the handling of a
received frame after the MCU delay). A :class:`Call` goes on the clock's queue like any SimPy event
(same ``(time, priority, id)`` key, so the order of events is SimPy's), but it is not a
``simpy.Event``: no callback list to build, no value, nothing to wait on. :meth:`~.world.Clock.run_until`
calls it directly; SimPy's own ``step`` (a plain ``simpy.Environment``, as in unit tests) runs it
through its one callback.
"""

from __future__ import annotations

from collections.abc import Callable
from heapq import heappush
from typing import Any

import simpy
from simpy.events import NORMAL


class Call:
    __slots__ = ("_ok", "args", "callbacks", "fn")

    def __init__(self, fn: Callable[..., Any], args: tuple):
        self.fn = fn
        self.args = args
        self._ok = True  # SimPy's step checks it
        self.callbacks = [_run]  # SimPy's step calls these


def _run(call: Call) -> None:
    call.fn(*call.args)


def call_later(clock: simpy.Environment, delay: float, fn: Callable[..., Any], *args: Any) -> None:
    """Run ``fn(*args)`` after ``delay`` seconds of clock time (one entry on the clock's queue,
    ordered as ``clock.schedule`` orders events)."""
    heappush(clock._queue, (clock._now + delay, NORMAL, next(clock._eid), Call(fn, args)))
