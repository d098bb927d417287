"""Compatibility name for ``middleware/node.py``: ``scheduler(clock)`` is ``clock.later``
(:class:`petswarm_env.sim.clock.Clock`). Delete this module once node.py takes ``clock.later``."""

from __future__ import annotations

from collections.abc import Callable

from petswarm_env.sim.clock import Clock


def scheduler(clock: Clock) -> Callable[..., None]:
    """``clock.later``: ``later(delay, fn, *args)`` runs ``fn(*args)`` after ``delay`` s of clock time."""
    return clock.later
