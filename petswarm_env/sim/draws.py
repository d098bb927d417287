"""Scalar random draws taken from a numpy Generator in blocks.

A numpy call per scalar draw (``rng.uniform()``, ``rng.standard_normal()``) costs several times
the draw itself; the radio's backoffs and losses, the MCU jitter and the AHRS noise draw one
scalar at a time, so they take them from a block drawn at once. Deterministic: the same generator
gives the same sequence (a different one from drawing one at a time).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from itertools import chain

import numpy as np


def _blocks(draw: Callable[[int], np.ndarray], block: int) -> Iterator[list[float]]:
    """Blocks of ``block`` draws, each drawn when the previous one is used up, handed out from its
    last draw to its first (the order in which the draws were first taken, by ``list.pop``)."""
    while True:
        values = draw(block).tolist()
        values.reverse()
        yield values


class Draws:
    """``uniform()`` → U[0, 1) and ``normal()`` → N(0, 1), one scalar per call.

    Both are the ``__next__`` of an iterator over the blocks (a call in C, no Python frame per
    draw); a block is drawn from ``rng`` on the first call after the previous one is used up.
    """

    __slots__ = ("block", "normal", "rng", "uniform")

    def __init__(self, rng: np.random.Generator, block: int = 256):
        self.rng = rng
        self.block = block
        self.uniform: Callable[[], float] = chain.from_iterable(_blocks(rng.random, block)).__next__
        self.normal: Callable[[], float] = chain.from_iterable(_blocks(rng.standard_normal, block)).__next__
