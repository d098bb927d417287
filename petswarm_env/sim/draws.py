"""Scalar random draws taken from a numpy Generator in blocks.

A numpy call per scalar draw (``rng.uniform()``, ``rng.standard_normal()``) costs several times
the draw itself; the radio's backoffs and losses, the MCU jitter and the AHRS noise draw one
scalar at a time, so they take them from a block drawn at once. Deterministic: the same generator
gives the same sequence (a different one from drawing one at a time).
"""

from __future__ import annotations

import numpy as np


class Draws:
    __slots__ = ("_n", "_u", "block", "rng")

    def __init__(self, rng: np.random.Generator, block: int = 256):
        self.rng = rng
        self.block = block
        self._u: list[float] = []
        self._n: list[float] = []

    def uniform(self) -> float:
        """U[0, 1)."""
        u = self._u
        if not u:
            u.extend(self.rng.random(self.block).tolist())
        return u.pop()

    def normal(self) -> float:
        """N(0, 1)."""
        n = self._n
        if not n:
            n.extend(self.rng.standard_normal(self.block).tolist())
        return n.pop()
