"""The optical path of the IR module: from true geometry to ring readings to the paper's estimate.

This is the only place where IR measurements touch the physical truth: it takes the true
positions and headings, decides occlusion by bodies, simulates the receiver ring
(:func:`petswarm_env.middleware.ir.received_strengths`) and runs the paper's estimator
(:func:`petswarm_env.middleware.ir.estimate`). What a robot gets back is only the estimate.
"""

from __future__ import annotations

import numpy as np

from petswarm_env.middleware import ir
from petswarm_env.sim import geometry
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
        centers, radii = self.world.body_circles()
        robots = self.world.robots
        headings = np.array([robots[i].heading for i in rx_indices], dtype=float)  # the receivers' only
        rx = np.asarray(rx_indices, dtype=int)
        p_rx = centers[rx]
        p_tx = np.broadcast_to(centers[tx_index], p_rx.shape)
        delta = p_tx - p_rx
        distance = np.hypot(delta[:, 0], delta[:, 1])
        bearing = np.arctan2(delta[:, 1], delta[:, 0]) - headings
        exclude = np.zeros((len(rx), len(centers)), dtype=bool)
        exclude[np.arange(len(rx)), rx] = True
        exclude[:, tx_index] = True
        occluded = geometry.segments_blocked(p_rx, p_tx, centers, radii, exclude)
        strengths = ir.received_strengths(self.cfg, distance, bearing, occluded, self.rng)
        return ir.estimate(self.cfg, strengths)
