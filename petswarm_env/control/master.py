"""Master-role controller: keep the standard distance (1 m) and direction from the user.

Seed 000 §3.6.2 (details in seed 002 §3.4). Inputs are the master's own view of its user: a
noisy position relative to itself (until the wearable chain of seed 002 lands, see
:meth:`Swarm.sense_user`) and its own odometry. Following mode: stay 1 m behind the user and face
them. Leading mode: stay ahead of the user — 1 m beyond the formation's depth, since the master
leads the others — facing away from them.

The user's velocity is estimated from successive relative positions plus the master's own motion
(low-pass filtered) and fed forward, in the spirit of seed 002's ACC-style speed matching; the
distance error is corrected proportionally on top.
"""

from __future__ import annotations

import math

from petswarm_env.config import Config


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


class MasterController:
    def __init__(self, cfg: Config):
        self.cfg = cfg
        self.prev_user: tuple[float, float] | None = None
        self.user_vel = (0.0, 0.0)  # filtered user velocity in the master frame

    def reset(self) -> None:
        self.prev_user = None
        self.user_vel = (0.0, 0.0)

    def command(self, user_rel: tuple[float, float], own_velocity: tuple[float, float, float], mode: str, dt: float,
                formation_depth_m: float = 0.0):
        """(Vx, Vy, ω) body-frame command from the user's relative position (master frame).

        In leading mode the master is the robot farthest from the user (seed 000 §3.5, Fig. 10):
        the slaves drive between it and the user, so it keeps the standard distance plus the depth
        of the formation behind it (``formation_depth_m``, from the neighbour table)."""
        ux, uy = user_rel
        vx, vy, w = own_velocity
        if self.prev_user is not None:
            # d(user_rel)/dt = v_user − v_master − ω × user_rel   (all in the master frame)
            dux = (ux - self.prev_user[0]) / dt + vx - w * uy
            duy = (uy - self.prev_user[1]) / dt + vy + w * ux
            a = 0.3
            self.user_vel = (self.user_vel[0] + a * (dux - self.user_vel[0]), self.user_vel[1] + a * (duy - self.user_vel[1]))
        self.prev_user = (ux, uy)
        d_std = self.cfg.master.distance_m
        k = self.cfg.master.gain
        bearing = math.atan2(uy, ux)
        if mode == "leading":
            target = (-(d_std + formation_depth_m), 0.0)  # user behind the whole formation
            heading_err = _wrap(bearing - math.pi)
        else:
            target = (d_std, 0.0)  # user 1 m ahead
            heading_err = bearing
        # moving by +δ changes user_rel by −δ: command toward user_rel − target
        cx = self.user_vel[0] + k * (ux - target[0])
        cy = self.user_vel[1] + k * (uy - target[1])
        cw = 1.2 * heading_err
        return cx, cy, cw
