"""Scalar random draws taken from a numpy Generator in blocks.

A numpy call per scalar draw (``rng.uniform()``, ``rng.standard_normal()``) costs several times
the draw itself; the radio's backoffs and losses, the MCU jitter and the AHRS noise draw one
scalar at a time, so they take them from a block drawn at once. Deterministic: the same generator
gives the same sequence (a different one from drawing one at a time).

A module of the compiled core (``petswarm_env/_core.py``): a :class:`Stream` is a typed class whose
next draw is a C call for the compiled modules that hold it typed (``draws.pxd``: the radio, the
station); the interpreter runs the same file.
"""

from __future__ import annotations

from collections.abc import Callable

import cython
import numpy as np

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)


@cython.final
@cython.cclass
class Stream:
    """The draws of ``draw(block)`` (``rng.random`` or ``rng.standard_normal``), one scalar per call,
    ``block`` at a time: a block is drawn on the first call after the previous one is used up, and
    handed out from its last draw to its first (the order of the former ``list.pop`` of a block)."""

    # its typed attributes are declared in ``draws.pxd``

    def __init__(self, draw: Callable[[int], np.ndarray], block: int):
        self._draw = draw
        self.block = block
        self._left = 0  # draws of the current block not handed out yet (none: the next call draws a block)
        self._block = None

    @cython.ccall
    def next(self) -> cython.double:
        """The next draw (a C call where the stream is held typed)."""
        if self._left == 0:
            self._block = self._draw(self.block)
            self._values = self._block
            self._left = self.block
        self._left -= 1
        return float(self._values[self._left])  # (a Python float in the interpreted form too)

    def __call__(self) -> float:
        return self.next()


class Draws:
    """``uniform()`` → U[0, 1) and ``normal()`` → N(0, 1), one scalar per call: two :class:`Stream`
    of ``rng``'s ``random`` and ``standard_normal``, each drawn on its first call."""

    __slots__ = ("block", "normal", "rng", "uniform")

    def __init__(self, rng: np.random.Generator, block: int = 256):
        self.rng = rng
        self.block = block
        self.uniform: Stream = Stream(rng.random, block)
        self.normal: Stream = Stream(rng.standard_normal, block)
