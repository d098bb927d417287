"""The scripted slave-role controller of seed 000 §3.6.3 (Fig. 12–13): the reference policy.

It reads only the observation, like a learned policy. Per step:

1. ``Vx, Vy`` from the reference location minus the actual location: for each reference
   neighbour, the IR-measured neighbour position (propagated over the measurement's age with the
   master's broadcast speed and the robot's own odometry) plus the reference offset rotated by the
   twisted heading Δθ gives where the robot should be, in its own frame. Chosen: a reference
   location closer than ``user_keep_out_m`` to the user (the master's broadcast user position) is
   moved out to that distance — a formation that lags its user's turn must not put a robot on the
   user's path;
2. revise ``Vx, Vy`` with the master's broadcast driving speed (feed-forward that compensates the
   update delay of the sequential IR ring). Chosen reading of "driving speed": the velocity the
   master's motion gives the reference location — the master's translation plus its rotation ω
   carrying the location about it (ω × offset from the master), so a turning master does not
   leave its formation behind;
3. estimate the twisted heading Δθ = θ_neighbour − θ_self from the heading exchange and correct
   it with ω until it is inside the error band;
4. on user rotation: leading mode → arc driving (the velocity a point at the robot's distance
   from the user has when the formation turns with the user); following mode → just keep moving
   toward the reference location;
5. ultrasonic ranges push the robot away from anything closer than the keep-out distance.
"""

from __future__ import annotations

import math

import numpy as np

from baselines.policy import Policy, PolicySpec
from petswarm_env.observe import AGE_SCALE_S, POS_SCALE_M


class LeaderFollowerPolicy(Policy):
    name = "scripted"

    def __init__(
        self,
        spec: PolicySpec,
        position_gain: float = 1.2,
        heading_gain: float = 1.5,
        heading_band_rad: float = math.radians(3.0),  # error band of step 3
        keep_out_m: float = 0.50,
        repulsion_gain: float = 5.0,
        carry_rotation: bool = True,
        user_keep_out_m: float = 1.1,
    ):
        super().__init__(spec)
        self.kp = position_gain
        self.kh = heading_gain
        self.band = heading_band_rad
        self.keep_out = keep_out_m
        self.krep = repulsion_gain
        self.carry = carry_rotation
        self.user_keep_out = user_keep_out_m
        lay = spec.layout
        self._sl = lay.slices
        n_us = lay.slices["self.ultrasonic"].stop - lay.slices["self.ultrasonic"].start
        ang = np.arange(n_us) * (2 * math.pi / max(n_us, 1))
        self._us_dirs = np.stack([np.cos(ang), np.sin(ang)], axis=1)

    def act(self, agent: str, obs: np.ndarray) -> np.ndarray:
        sl = self._sl
        vmax, wmax = self.spec.max_speed_mps, self.spec.max_omega_rps
        odo = obs[sl["self.odometry"]] * np.array([vmax, vmax, wmax])
        have_status = obs[sl["master.valid"]][0] > 0.5
        mv = obs[sl["master.velocity"]] * np.array([vmax, vmax, wmax]) if have_status else np.zeros(3)

        targets, dthetas, ref_dists = [], [], []
        for k in range(2):
            p = f"link{k}."
            if obs[sl[p + "present"]][0] < 0.5:
                continue
            s, c = obs[sl[p + "heading_sincos"]]
            dth = 0.0
            if obs[sl[p + "heading_valid"]][0] > 0.5:  # the neighbour kept turning with the swarm since
                dth = math.atan2(s, c) + mv[2] * obs[sl[p + "heading_age"]][0] * AGE_SCALE_S
            dthetas.append(dth)
            if obs[sl[p + "ir_valid"]][0] < 0.5 or obs[sl[p + "ir_age"]][0] >= 1.0:
                continue  # no measurement, or one older than the observation's age range: move with the swarm
            nb = obs[sl[p + "neighbour_xy"]] * POS_SCALE_M
            age = obs[sl[p + "ir_age"]][0] * AGE_SCALE_S
            cd, sd = math.cos(dth), math.sin(dth)
            # the neighbour moved with the swarm (master speed, formation frame) and we moved (odometry)
            nb_v = np.array([cd * mv[0] - sd * mv[1], sd * mv[0] + cd * mv[1]])
            nb_now = nb + (nb_v - odo[:2]) * age
            off = obs[sl[p + "offset_xy"]] * POS_SCALE_M
            ref_dists.append(math.hypot(off[0], off[1]))
            targets.append(nb_now + np.array([cd * off[0] - sd * off[1], sd * off[0] + cd * off[1]]))

        dth = float(np.mean(dthetas)) if dthetas else 0.0
        cd, sd = math.cos(dth), math.sin(dth)
        # step 2: master's driving speed, rotated from the formation frame into ours — the velocity
        # the master's motion gives the reference location: its translation plus its rotation
        # carrying the location about it (ω × offset from the master); in a leading turn step 4's
        # arc about the user takes the rotation's place
        ref = obs[sl["self.offset_from_master_xy"]] * POS_SCALE_M
        leading_turn = have_status and obs[sl["master.leading"]][0] > 0.5 and obs[sl["master.rotating"]][0] > 0.5
        wr = 0.0 if leading_turn or not self.carry else mv[2]
        fx, fy = mv[0] - wr * ref[1], mv[1] + wr * ref[0]
        v = np.array([cd * fx - sd * fy, sd * fx + cd * fy])
        # step 1: toward the reference location — moved out of a keep-out disc around the user (the
        # master's broadcast user position, carried from the formation frame into ours): a formation
        # that lags its user's turn must not place anyone on the user's path
        if targets:
            target = np.mean(targets, axis=0)
            if have_status and self.user_keep_out > 0:
                du = obs[sl["master.user_xy"]] * POS_SCALE_M - ref  # user relative to our reference
                user = target + np.array([cd * du[0] - sd * du[1], sd * du[0] + cd * du[1]])
                away = target - user
                gap = float(np.hypot(*away))
                if gap < self.user_keep_out:
                    target = user + (away / gap if gap > 1e-6 else -user / max(float(np.hypot(*user)), 1e-6)) * self.user_keep_out
            v = v + self.kp * target
        # step 4: leading mode arc driving on user rotation
        turn = obs[sl["master.turn_rate"]][0] * wmax
        if leading_turn:
            r = ref - obs[sl["master.user_xy"]] * POS_SCALE_M
            arc = np.array([-turn * r[1], turn * r[0]])
            v = v + np.array([cd * arc[0] - sd * arc[1], sd * arc[0] + cd * arc[1]])
        # step 3: twisted-heading correction inside an error band, plus the swarm's rotation
        omega = mv[2] + (self.kh * dth if abs(dth) > self.band else 0.0)
        # step 5: ultrasonic keep-out (shrunk for tight formations: never beyond 85 % of the rim-to-rim
        # gap the formation itself asks for, taking 0.4 m for two robot radii)
        keep_out = self.keep_out
        if ref_dists:
            keep_out = min(keep_out, max(0.1, 0.85 * (min(ref_dists) - 0.4)))
        ranges = obs[sl["self.ultrasonic"]] * self.spec.us_max_range_m
        close = ranges < keep_out
        if close.any():
            push = ((keep_out - ranges[close])[:, None] * self._us_dirs[close]).sum(axis=0)
            v = v - self.krep * push
        return np.clip(np.array([v[0] / vmax, v[1] / vmax, omega / wmax], dtype=np.float32), -1.0, 1.0)
