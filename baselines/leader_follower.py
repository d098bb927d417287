"""The scripted slave-role controller of seed 000 §3.6.3 (Fig. 12–13): the reference policy.

It reads only the observation, like a learned policy. Per step:

1. ``Vx, Vy`` from the reference location minus the actual location: for each reference
   neighbour, the IR-measured neighbour position (propagated over the measurement's age with the
   master's broadcast speed and the robot's own odometry) plus the reference offset rotated by the
   twisted heading Δθ gives where the robot should be, in its own frame. Chosen: a reference
   location closer than ``user_keep_out_m`` to the user (the master's broadcast user position) is
   moved out to that distance — a formation that lags its user's turn must not put a robot on the
   user's path. A neighbour whose fix is stale — no measurement, or one at the end of the
   observation's age range (2 s): occluded, beyond the IR's reach, or the ring lost its slots — gives
   no target (decided, issue 14): the slave cannot know where that neighbour is now (its last fix is
   carried over its own rotation only, and the age no longer grows), so it keeps moving with the
   swarm (step 2's feed-forward, step 3's heading) and takes the position correction up again with
   the next fix. It neither stops (the swarm would walk away from it) nor chases the last fix (a
   target that does not recede as it drives would run it off). The episode summary counts that
   time (``stale_fix_s``), so a slave that lost its neighbour shows;
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

Arithmetic. The controller runs once per slave and step on a few dozen numbers, so it is written on
Python floats (a numpy call costs more than its arithmetic here). It computes, value for value,
what its first, numpy form computed, so the scripted figures stay the same: the observation is
float32, and numpy keeps ``float32 · Python float`` in float32 — the scaled observation fields and
the products of their offsets with cos/sin of Δθ are float32 there, rounded here with ``_r32``;
everything mixed with float64 values is float64. tests/unit/test_leader_follower.py holds the two equal,
bit for bit, on recorded and random observations.
"""

from __future__ import annotations

import math
from array import array

import numpy as np

from baselines.policy import Policy, PolicySpec
from petswarm_env.observe import AGE_SCALE_S, MAX_LINKS, POS_SCALE_M

_F32 = array("f", [0.0])


def _r32(x: float) -> float:
    """``x`` rounded to float32 (as numpy's float32 arithmetic rounds each result)."""
    _F32[0] = x
    return _F32[0]


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
        st = {name: sl.start for name, sl in spec.layout.slices.items()}
        self._i = st  # index of each observation field's first value
        self._links = [
            tuple(st[f"link{k}.{f}"] for f in ("present", "heading_sincos", "heading_valid", "heading_age",
                                               "ir_valid", "ir_age", "neighbour_xy", "offset_xy"))
            for k in range(MAX_LINKS)
        ]
        us = spec.layout.slices["self.ultrasonic"]
        self._us = range(us.start, us.stop)
        n_us = us.stop - us.start
        self._us_dirs = [(math.cos(a), math.sin(a)) for a in (k * (2 * math.pi / max(n_us, 1)) for k in range(n_us))]
        # the float32 scales of the observation fields (a Python float meets float32 values as float32)
        self._pos32, self._age32 = _r32(POS_SCALE_M), _r32(AGE_SCALE_S)
        self._omega32, self._us32 = _r32(spec.max_omega_rps), _r32(spec.us_max_range_m)

    def act(self, agent: str, obs: np.ndarray) -> np.ndarray:
        """The action of one slave: the five steps of the module docstring, in order. One function
        on purpose: it runs for every slave at every step on Python floats, where a helper call
        costs more than the arithmetic it would hold (see "Arithmetic" above)."""
        o = np.asarray(obs, dtype=np.float32).tolist()
        i = self._i
        r32, pos32 = _r32, self._pos32
        vmax, wmax = self.spec.max_speed_mps, self.spec.max_omega_rps
        odo_x, odo_y = o[i["self.odometry"]] * vmax, o[i["self.odometry"] + 1] * vmax
        have_status = o[i["master.valid"]] > 0.5
        j = i["master.velocity"]
        mv0, mv1, mv2 = (o[j] * vmax, o[j + 1] * vmax, o[j + 2] * wmax) if have_status else (0.0, 0.0, 0.0)

        targets, dthetas, ref_dists = [], [], []
        for present, sincos, h_valid, h_age, ir_valid, ir_age, nb_xy, off_xy in self._links:
            if o[present] < 0.5:
                continue
            dth = 0.0
            if o[h_valid] > 0.5:  # the neighbour kept turning with the swarm since
                dth = math.atan2(o[sincos], o[sincos + 1]) + mv2 * o[h_age] * AGE_SCALE_S
            dthetas.append(dth)
            if o[ir_valid] < 0.5 or o[ir_age] >= 1.0:
                continue  # no measurement, or one older than the observation's age range: move with the swarm
            nbx, nby = r32(o[nb_xy] * pos32), r32(o[nb_xy + 1] * pos32)
            age = r32(o[ir_age] * self._age32)
            cd, sd = math.cos(dth), math.sin(dth)
            # the neighbour moved with the swarm (master speed, formation frame) and we moved (odometry)
            now_x = nbx + (cd * mv0 - sd * mv1 - odo_x) * age
            now_y = nby + (sd * mv0 + cd * mv1 - odo_y) * age
            offx, offy = r32(o[off_xy] * pos32), r32(o[off_xy + 1] * pos32)
            ref_dists.append(math.hypot(offx, offy))
            cd, sd = r32(cd), r32(sd)
            targets.append((now_x + r32(r32(cd * offx) - r32(sd * offy)), now_y + r32(r32(sd * offx) + r32(cd * offy))))

        dth = sum(dthetas, 0.0) / len(dthetas) if dthetas else 0.0  # their mean
        cd, sd = math.cos(dth), math.sin(dth)
        cd32, sd32 = r32(cd), r32(sd)
        # step 2: master's driving speed, rotated from the formation frame into ours — the velocity
        # the master's motion gives the reference location: its translation plus its rotation
        # carrying the location about it (ω × offset from the master); in a leading turn step 4's
        # arc about the user takes the rotation's place
        j = i["self.offset_from_master_xy"]
        refx, refy = r32(o[j] * pos32), r32(o[j + 1] * pos32)
        leading_turn = have_status and o[i["master.leading"]] > 0.5 and o[i["master.rotating"]] > 0.5
        wr = 0.0 if leading_turn or not self.carry else mv2
        fx, fy = mv0 - wr * refy, mv1 + wr * refx
        vx, vy = cd * fx - sd * fy, sd * fx + cd * fy
        j = i["master.user_xy"]
        user_x, user_y = r32(o[j] * pos32), r32(o[j + 1] * pos32)
        # step 1: toward the reference location — moved out of a keep-out disc around the user (the
        # master's broadcast user position, carried from the formation frame into ours): a formation
        # that lags its user's turn must not place anyone on the user's path
        if targets:
            tx = sum((t[0] for t in targets), 0.0) / len(targets)  # their mean
            ty = sum((t[1] for t in targets), 0.0) / len(targets)
            if have_status and self.user_keep_out > 0:
                dux, duy = r32(user_x - refx), r32(user_y - refy)  # user relative to our reference
                ux = tx + r32(r32(cd32 * dux) - r32(sd32 * duy))
                uy = ty + r32(r32(sd32 * dux) + r32(cd32 * duy))
                away_x, away_y = tx - ux, ty - uy
                gap = float(np.hypot(away_x, away_y))
                if gap < self.user_keep_out:
                    if gap > 1e-6:
                        dx, dy = away_x / gap, away_y / gap
                    else:
                        norm = max(float(np.hypot(ux, uy)), 1e-6)
                        dx, dy = -ux / norm, -uy / norm
                    tx, ty = ux + dx * self.user_keep_out, uy + dy * self.user_keep_out
            vx, vy = vx + self.kp * tx, vy + self.kp * ty
        # step 4: leading mode arc driving on user rotation
        if leading_turn:
            turn = r32(o[i["master.turn_rate"]] * self._omega32)
            rx, ry = r32(refx - user_x), r32(refy - user_y)
            ax, ay = r32(-turn * ry), r32(turn * rx)
            vx, vy = vx + r32(r32(cd32 * ax) - r32(sd32 * ay)), vy + r32(r32(sd32 * ax) + r32(cd32 * ay))
        # step 3: twisted-heading correction inside an error band, plus the swarm's rotation
        omega = mv2 + (self.kh * dth if abs(dth) > self.band else 0.0)
        # step 5: ultrasonic keep-out (shrunk for tight formations: never beyond 85 % of the rim-to-rim
        # gap the formation itself asks for, taking 0.4 m for two robot radii)
        keep_out = self.keep_out
        if ref_dists:
            keep_out = min(keep_out, max(0.1, 0.85 * (min(ref_dists) - 0.4)))
        keep32, us32 = r32(keep_out), self._us32
        push_x = push_y = 0.0
        close = False
        for k, (ux_k, uy_k) in zip(self._us, self._us_dirs):
            rng_k = r32(o[k] * us32)
            if rng_k < keep32:
                depth = r32(keep32 - rng_k)
                push_x, push_y = push_x + depth * ux_k, push_y + depth * uy_k
                close = True
        if close:
            vx, vy = vx - self.krep * push_x, vy - self.krep * push_y
        return np.clip(np.array([vx / vmax, vy / vmax, omega / wmax], dtype=np.float32), -1.0, 1.0)
