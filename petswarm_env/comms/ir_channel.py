"""The optical path of the IR module: from true geometry to ring readings to the paper's estimate.

This is the only place where IR measurements touch the physical truth: it takes the true
positions and headings, decides occlusion by bodies, simulates the receiver ring
(:func:`petswarm_env.comms.ir.received_strengths`) and runs the paper's estimator
(:func:`petswarm_env.comms.ir.estimate`). What a robot gets back is only the estimate.
"""

from __future__ import annotations

import math

import numpy as np

from petswarm_env.comms import ir
from petswarm_env.sim.world import World


class IRChannel:
    def __init__(self, world: World, cfg: ir.IRConfig, rng: np.random.Generator):
        self.world = world
        self.cfg = cfg
        self.rng = rng

    def measure(self, tx_index: int, rx_indices: list[int]) -> tuple[list[float], list[float], list[bool]]:
        """Receivers ``rx_indices`` measure the IR of robot ``tx_index``.

        Returns estimated distance (m), bearing of the transmitter in each receiver's body frame
        (rad), and validity, one entry per receiver (nan where not valid).
        """
        centers, radii, headings = self.world.truth_arrays()
        cl, rl, hl = centers.tolist(), radii.tolist(), headings.tolist()
        tx_x, tx_y = cl[tx_index]
        dxs, dys, bearing, occluded = [], [], [], []
        for r in rx_indices:
            px, py = cl[r]
            dx, dy = tx_x - px, tx_y - py  # receiver -> transmitter
            dxs.append(dx)
            dys.append(dy)
            bearing.append(math.atan2(dy, dx) - hl[r])  # in the receiver's frame (its heading only)
            occluded.append(line_of_sight_blocked(px, py, dx, dy, cl, rl, r, tx_index))
        # numpy's hypot (libm's), not math.hypot: the two differ in the last bit now and then
        distance = np.hypot(np.array(dxs), np.array(dys)).tolist()
        strengths = ir.received_strengths(self.cfg, distance, bearing, occluded, self.rng)
        return ir.estimate(self.cfg, strengths)


def line_of_sight_blocked(px: float, py: float, vx: float, vy: float, centers: list, radii: list, rx: int, tx: int) -> bool:
    """Does a body other than the receiver ``rx`` and the transmitter ``tx`` cut the line of sight
    ``p → p + v``? A circle (``centers``, ``radii``: every round body, as lists) blocks it when its
    centre is strictly closer than its radius to some point of the segment (grazing is clear).
    Plain Python: an IR slot has a handful of segments (``tests/oracles.py`` keeps the numpy form
    for many segments, ``segments_blocked``)."""
    vv = vx * vx + vy * vy
    den = vv if vv > 0.0 else 1.0
    for j, ((cx, cy), r) in enumerate(zip(centers, radii)):
        if j == rx or j == tx:
            continue
        u = ((cx - px) * vx + (cy - py) * vy) / den  # the closest point's parameter on the segment
        if u < 0.0:  # clamped to the segment, as max(u, 0.0) then min(u, 1.0)
            u = 0.0
        elif u > 1.0:
            u = 1.0
        ex, ey = cx - (px + u * vx), cy - (py + u * vy)
        if ex * ex + ey * ey < r * r:
            return True
    return False

