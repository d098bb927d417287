"""The optical path of the IR module: from true geometry to ring readings to the paper's estimate.

This is the only place where IR measurements touch the physical truth: it takes the true
positions and headings, decides occlusion by bodies, simulates the receiver ring
(:func:`petswarm_env.middleware.ir.received_strengths`) and runs the paper's estimator
(:func:`petswarm_env.middleware.ir.estimate`). What a robot gets back is only the estimate.
"""

from __future__ import annotations

import numpy as np

from petswarm_env.middleware import ir
from petswarm_env.sim.world import World


class IRChannel:
    def __init__(self, world: World, cfg: ir.IRConfig, rng: np.random.Generator):
        self.world = world
        self.cfg = cfg
        self.rng = rng

    def measure(self, tx_index: int, rx_indices: list[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Receivers ``rx_indices`` measure the IR of robot ``tx_index``.

        Returns estimated distance (m), bearing of the transmitter in each receiver's body frame
        (rad), and validity, each of shape (len(rx_indices),).
        """
        centers, radii, headings = self.world.truth_arrays()
        rx = np.asarray(rx_indices, dtype=int)
        p_rx = centers[rx]
        delta = centers[tx_index] - p_rx  # receiver -> transmitter
        dx, dy = delta[:, 0], delta[:, 1]
        distance = np.hypot(dx, dy)
        bearing = np.arctan2(dy, dx) - headings[rx]  # in the receivers' frames (their headings only)
        occluded = _line_of_sight_blocked(p_rx, delta, centers, radii, rx, tx_index)
        strengths = ir.received_strengths(self.cfg, distance, bearing, occluded, self.rng)
        return ir.estimate(self.cfg, strengths)


def _line_of_sight_blocked(p_rx: np.ndarray, v: np.ndarray, centers: np.ndarray, radii: np.ndarray,
                           rx: np.ndarray, tx_index: int) -> np.ndarray:
    """:func:`~petswarm_env.sim.geometry.segments_blocked` for the segments ``p_rx → p_rx + v`` of
    one IR slot, the bodies of the transmitter and of each segment's receiver left out (same
    formulas, without the exclusion matrix and the general-purpose reshaping)."""
    px, py = p_rx[:, 0:1], p_rx[:, 1:2]  # (M, 1)
    vx, vy = v[:, 0:1], v[:, 1:2]
    vv = vx * vx + vy * vy
    pcx = centers[:, 0] - px  # (M, C)
    pcy = centers[:, 1] - py
    u = (pcx * vx + pcy * vy) / np.where(vv > 0.0, vv, 1.0)  # closest point's parameter on the segment
    u = np.minimum(np.maximum(u, 0.0), 1.0)
    ex = centers[:, 0] - (px + u * vx)
    ey = centers[:, 1] - (py + u * vy)
    cut = ex * ex + ey * ey < radii * radii
    cut[:, tx_index] = False
    cut[np.arange(len(rx)), rx] = False
    return cut.any(axis=1)
