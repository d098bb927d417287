"""The scripted slave-role controller of seed 000 §3.6.3 (Fig. 12–13): the reference policy.

It reads only the observation, like a learned policy. Per step:

1. ``Vx, Vy`` from the reference location minus the actual location: for each reference
   neighbour, the IR-measured neighbour position (the observation carries it over the robot's own
   motion in the swarm since: its wheel odometry less the master's broadcast driving speed, turned
   by its AHRS, middleware/knowledge.py) plus the reference offset rotated by the
   twisted heading Δθ gives where the robot should be, in its own frame. Chosen: a reference
   location closer than ``user_keep_out_m`` to the user (the master's broadcast user position) is
   moved out to that distance — a formation that lags its user's turn must not put a robot on the
   user's path. While the master leads its user walking straight on (the broadcast activity walk or run,
   not rotating), ``leading_user_keep_out_m`` (1.0 m, chosen): a leading layout stands its rear slots
   0.9-1.0 m from the user (middleware/formation.py ``LEADING_CLEARANCE_M``; the 4-slave wedge's rear arms
   0.97 m), and 1.1 m held each of them 0.1-0.2 m off its slot for good. While the user stands (slaves
   crossing to their slots past them) or turns, 1.1 m: 1.0 m throughout built slower and touched the user
   more (leading, straight, seeds 920-949: robot-user contacts 5 -> 15, 2 formations never built against
   1; while walking straight only: hold RMSE 0.191 -> 0.154 m, 5 contacts, 1 never built). A neighbour whose fix is stale — no measurement, or one at the end of the
   observation's age range (2 s): occluded, beyond the IR's reach, or the ring lost its slots — gives
   no target (chosen): the slave cannot know where that neighbour is now (it may have left its
   place in the swarm since), so it keeps moving with the
   swarm (step 2's feed-forward, step 3's heading) and takes the position correction up again with
   the next fix. It neither stops (the swarm would walk away from it) nor chases the last fix (a
   target that does not recede as it drives would run it off). The episode summary counts that
   time (``stale_fix_s``), so a slave that lost its neighbour shows. Building the formation
   (seed 000 Fig. 10: robots start scattered), chosen, when no reference
   neighbour gives a target: (1b) the master in IR sight — our reference location from the
   master's fix turned by an anchor member's (the observation's ``anchor.*``: another member seen,
   standing at its slot's distance from the master), or, with no anchor, orbit the master at our
   reference's distance, at most ``orbit_max_m`` (2.2 m: the IR's detection fades at 2.4-2.8 m, seed
   000 Table 4 as calibrated; chosen), until one shows (odd members counter-clockwise); the correction's
   speed is capped at ``approach_mps``. Orbiting a rear slot's distance (up to 4.3 m in 1 + 16) took
   the slave out of the master's IR reach: its fix went stale, step 1c drove it back, 1b out again,
   and no anchor came while it see-sawed 3-4 m out (1 + 16, seed 40: 6-7 m off its slot for 25 s);
   (1c) nobody in sight but the master's status heard — back toward the master's last fix at
   ``rejoin_mps`` relative to the swarm (the swarm walked out of our IR's reach, or the crowd pushed
   us out of it; the fix is carried over our own motion in the swarm, so it recedes as we drive:
   before it was carried over our rotation only, and a slave pushed aside drove off sideways
   after a place that did not recede); (1d) nobody ever
   seen (the user or a robot between us and the swarm) — circle the nearest ultrasonic echo at
   ``search_mps``;
2. revise ``Vx, Vy`` with the master's broadcast driving speed (feed-forward that compensates the
   update delay of the sequential IR ring). Chosen reading of "driving speed": the velocity the
   master's motion gives the reference location — the master's translation plus its rotation ω
   carrying the location about it (ω × offset from the master), so a turning master does not
   leave its formation behind;
3. estimate the twisted heading Δθ = θ_neighbour − θ_self from the heading exchange and correct
   it with ω until it is inside the error band. Chosen: only an exchange within the observation's
   age range (2 s) counts; Δθ is the mean over those, and a link without one places its step-1
   target by that mean. With none, Δθ is the rotation of the formation frame into ours that the
   master's fix and an anchor's give (step 1b's two fixes; the formation frame is the master's
   heading, and the neighbours stand about in it), else 0 (chosen: a slave whose neighbours had not
   exchanged headings with it since a renumbering stood 120° off for 25 s and placed its targets
   turned by as much). An older one is carried over our own rotation only, and the neighbour may
   have turned any amount since (while building, a whole row turns): averaged with a fresh one it
   cancelled it, and a slave stood 80-90° off its neighbours, its targets turned with it (1 + 16,
   seeds 0-19: built 15 → 19 of 20);
4. on user rotation: leading mode → arc driving (the velocity a point at the robot's distance
   from the user has when the formation turns with the user); following mode → just keep moving
   toward the reference location. Chosen: about a walking user the formation turns at the belt's
   rate up to ``LEADING_ARC_MAX_RPS`` (control/master.py, where the master's own arc is capped
   alike: the wedge's outer robots cannot drive a 60°/s walking turn 2 m out); a user turning on the
   spot, at the belt's rate (the master synchronises its arc with the belt's accumulated angle);
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

from petswarm.baselines.policy import Policy, PolicySpec
from petswarm_env.control.master import LEADING_ARC_MAX_RPS
from petswarm_env.observe import AGE_SCALE_S, MAX_LINKS, POS_SCALE_M
from petswarm_env.scenarios import ACTIVITIES

_F32 = array("f", [0.0])
_COS45 = math.cos(math.pi / 4)
_TIE_SIN = math.sin(math.radians(10.0))  # step 1c: an echo this close to the master's direction is straight ahead (chosen)
_RIM_M = 0.25  # step 1d: a body's radius taken from its echo to its centre (a Pet-Bot's ~0.2 m, a person's ~0.25 m; chosen)


def _r32(x: float) -> float:
    """``x`` rounded to float32 (as numpy's float32 arithmetic rounds each result)."""
    _F32[0] = x
    return _F32[0]


def _clip1(a: np.ndarray) -> np.ndarray:
    """``np.clip(a, -1, 1)``, value for value (NaN stays NaN), without ``np.clip``'s Python wrapper."""
    return np.minimum(np.maximum(a, -1.0), 1.0)


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
        leading_user_keep_out_m: float = 1.0,
        approach_mps: float = 1.0,
        anchor_tolerance_m: float = 0.4,
        orbit_mps: float = 0.8,
        rejoin_mps: float = 0.5,
        search_mps: float = 0.5,
        orbit_max_m: float = 2.2,
        anchor_heading: bool = True,
        detour_m: float = 1.0,
        scan_rps: float = 0.3,
    ):
        super().__init__(spec)
        self.kp = position_gain
        self.kh = heading_gain
        self.band = heading_band_rad
        self.keep_out = keep_out_m
        self.krep = repulsion_gain
        self.carry = carry_rotation
        self.user_keep_out = user_keep_out_m
        self.leading_user_keep_out = leading_user_keep_out_m  # the same, while the master leads a user walking straight on
        self.approach = approach_mps  # cap of step 1b's correction speed (the feed-forward comes on top)
        self.anchor_tol = anchor_tolerance_m  # an anchor this close to its slot's distance from the master places ours
        self.orbit = orbit_mps  # step 1b: the master seen, no member: orbit it at this speed
        self.search = search_mps  # step 1d: nothing in IR sight, circle the nearest echo at this speed
        self.orbit_max = orbit_max_m  # step 1b: the master seen, no member: orbit it no farther out than this
        self.anchor_heading = anchor_heading  # step 3: no fresh heading exchange: Δθ from the master's and an anchor's fix
        self.detour = detour_m  # step 1c: an echo this close toward the master's last fix is passed by its side (0: off)
        self.scan = scan_rps  # step 1d: no echo in range, turn on the spot at this rate; with one, turn with its circle (0: neither)
        self.rejoin = rejoin_mps  # step 1c: lost, toward the master's last fix at this speed (relative to the swarm)
        st = {name: sl.start for name, sl in spec.layout.slices.items()}
        self._links = [
            tuple(st[f"link{k}.{f}"] for f in ("present", "heading_sincos", "heading_valid", "heading_age",
                                               "ir_valid", "ir_age", "neighbour_xy", "offset_xy"))
            for k in range(MAX_LINKS)
        ]
        us = spec.layout.slices["self.ultrasonic"]
        self._us = range(us.start, us.stop)
        n_us = us.stop - us.start
        self._us_dirs = [(math.cos(a), math.sin(a)) for a in (k * (2 * math.pi / max(n_us, 1)) for k in range(n_us))]
        self._us_rays = [(k, ux, uy) for k, (ux, uy) in zip(self._us, self._us_dirs)]
        self._vmax, self._wmax = spec.max_speed_mps, spec.max_omega_rps
        self._j_odo, self._j_mvalid, self._j_mvel = st["self.odometry"], st["master.valid"], st["master.velocity"]
        self._j_last = st["self.last_action"]
        self._j_ref, self._j_user, self._j_turn = st["self.offset_from_master_xy"], st["master.user_xy"], st["master.turn_rate"]
        self._j_leading, self._j_rotating, self._j_member = st["master.leading"], st["master.rotating"], st["self.member"]
        act = st["master.activity"]  # one-hot over scenarios.ACTIVITIES: stop, rest, walk, run
        self._j_walking = (act + ACTIVITIES.index("walk"), act + ACTIVITIES.index("run"))
        self.arc_max = _r32(LEADING_ARC_MAX_RPS)  # step 4: the formation's turn about a walking user, at most (rad/s)
        self._j_mir_valid, self._j_mir_xy, self._j_mir_age = st["master.ir_valid"], st["master.ir_xy"], st["master.ir_age"]
        self._j_anchor = st["anchor.ir_valid"]  # then anchor.ir_xy (+1, +2), anchor.ir_age (+3), anchor.slot_xy (+4, +5)
        if [st[f"anchor.{f}"] - self._j_anchor for f in ("ir_xy", "ir_age", "slot_xy")] != [1, 3, 4]:
            raise ValueError("observation layout: the anchor fields are not ir_valid, ir_xy, ir_age, slot_xy in this order")
        # the float32 scale of each observation value that the controller reads scaled (a Python float
        # meets float32 values as float32): positions, ages, the turn rate and the ultrasonic ranges
        self._pos32, self._age32 = _r32(POS_SCALE_M), _r32(AGE_SCALE_S)
        self._omega32, self._us32 = _r32(spec.max_omega_rps), _r32(spec.us_max_range_m)
        scale = np.ones(spec.layout.size, dtype=np.float32)
        for name, sl in spec.layout.slices.items():
            if name.endswith(("neighbour_xy", "offset_xy", "offset_from_master_xy", "user_xy", "ir_xy", "slot_xy")):
                scale[sl] = self._pos32
            elif name.endswith("ir_age"):
                scale[sl] = self._age32
        scale[spec.layout.slices["master.turn_rate"]] = self._omega32
        scale[us] = self._us32
        self._scale32 = scale

    def act(self, agent: str, obs: np.ndarray) -> np.ndarray:
        """The action of one slave (:meth:`_act` on its observation)."""
        x = np.asarray(obs, dtype=np.float32)
        return _clip1(np.array(self._act(x.tolist(), (x * self._scale32).tolist()), dtype=np.float32))

    def act_all(self, observations: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Every slave's action, the same as :meth:`act` for each, bit for bit: the observations'
        float32 scaling and the clipping run once over all of them."""
        if not observations:
            return {}
        x = np.asarray(list(observations.values()), dtype=np.float32)
        act = self._act
        rows = [act(o, s) for o, s in zip(x.tolist(), (x * self._scale32).tolist())]
        out = _clip1(np.array(rows, dtype=np.float32))
        return {agent: out[k] for k, agent in enumerate(observations)}

    def _act(self, o: list, s: list) -> tuple[float, float, float]:
        """The five steps of the module docstring, in order, on one observation: ``o`` its float32
        values, ``s`` the same values times each field's float32 scale (``POS_SCALE_M``,
        ``AGE_SCALE_S``, the ultrasonic range), rounded to float32 (numpy's float32 product: the
        ``_r32(o · scale)`` of "Arithmetic" above). Returns ``(Vx/vmax, Vy/vmax, ω/ωmax)``, before
        clipping. One function on purpose: it runs for every slave at every step on Python floats,
        where a helper call costs more than the arithmetic it would hold (see "Arithmetic" above)."""
        r32 = _r32
        vmax, wmax = self._vmax, self._wmax
        have_status = o[self._j_mvalid] > 0.5
        j = self._j_mvel
        mv0, mv1, mv2 = (o[j] * vmax, o[j + 1] * vmax, o[j + 2] * wmax) if have_status else (0.0, 0.0, 0.0)

        targets, dthetas, ref_dists = [], [], []
        links = []
        search_turn = 0.0
        for present, sincos, h_valid, h_age, ir_valid, ir_age, nb_xy, off_xy in self._links:
            if o[present] < 0.5:
                continue
            dth = None
            if o[h_valid] > 0.5 and o[h_age] < 1.0:  # the neighbour kept turning with the swarm since
                dth = math.atan2(o[sincos], o[sincos + 1]) + mv2 * o[h_age] * AGE_SCALE_S
                dthetas.append(dth)
            links.append((dth, ir_valid, ir_age, nb_xy, off_xy))
        # the master's fix and an anchor's (another member seen, standing at its slot's distance from
        # the master): the rotation ``phi`` that carries the formation frame into ours (steps 1b and 3)
        master_fix, phi = None, None
        if o[self._j_mir_valid] > 0.5 and o[self._j_mir_age] < 1.0:
            j = self._j_mir_xy
            mx, my = s[j], s[j + 1]  # (carried over our own motion in the observation)
            master_fix = (mx, my)
            j = self._j_anchor
            if o[j] > 0.5 and o[j + 3] < 1.0:
                kx, ky = s[j + 1] - mx, s[j + 2] - my
                ax_, ay_ = s[j + 4], s[j + 5]
                if abs(math.hypot(kx, ky) - math.hypot(ax_, ay_)) < self.anchor_tol:
                    phi = math.atan2(ky, kx) - math.atan2(ay_, ax_)
        if dthetas:
            dth_mean = sum(dthetas, 0.0) / len(dthetas)
        elif phi is not None and self.anchor_heading and not any(o[v] > 0.5 and o[a] < 1.0 for _, v, a, _, _ in links):
            # no heading exchange within the age range: the formation frame's rotation is θ_master − θ_self,
            # and the neighbours stand (about) in the master's heading
            dth_mean = math.atan2(math.sin(phi), math.cos(phi))
        else:
            dth_mean = 0.0
        for dth, ir_valid, ir_age, nb_xy, off_xy in links:
            if dth is None:
                dth = dth_mean
            if o[ir_valid] < 0.5 or o[ir_age] >= 1.0:
                continue  # no measurement, or one older than the observation's age range: move with the swarm
            nbx, nby = s[nb_xy], s[nb_xy + 1]
            cd, sd = math.cos(dth), math.sin(dth)
            # the observation carried the fix over our own motion relative to the swarm since
            # (odometry less the master's driving speed: the neighbour moved with the swarm)
            now_x, now_y = nbx, nby
            offx, offy = s[off_xy], s[off_xy + 1]
            ref_dists.append(math.hypot(offx, offy))
            cd, sd = r32(cd), r32(sd)
            targets.append((now_x + r32(r32(cd * offx) - r32(sd * offy)), now_y + r32(r32(sd * offx) + r32(cd * offy))))

        dth = dth_mean
        cd, sd = math.cos(dth), math.sin(dth)
        cd32, sd32 = r32(cd), r32(sd)
        # step 2: master's driving speed, rotated from the formation frame into ours — the velocity
        # the master's motion gives the reference location: its translation plus its rotation
        # carrying the location about it (ω × offset from the master); in a leading turn step 4's
        # arc about the user takes the rotation's place
        j = self._j_ref
        refx, refy = s[j], s[j + 1]
        leading_turn = have_status and o[self._j_leading] > 0.5 and o[self._j_rotating] > 0.5
        wr = 0.0 if leading_turn or not self.carry else mv2
        fx, fy = mv0 - wr * refy, mv1 + wr * refx
        vx, vy = cd * fx - sd * fy, sd * fx + cd * fy
        j = self._j_user
        user_x, user_y = s[j], s[j + 1]
        # step 1: toward the reference location — moved out of a keep-out disc around the user (the
        # master's broadcast user position, carried from the formation frame into ours): a formation
        # that lags its user's turn must not place anyone on the user's path
        if targets:
            tx = sum([t[0] for t in targets], 0.0) / len(targets)  # their mean
            ty = sum([t[1] for t in targets], 0.0) / len(targets)
            walking = have_status and (o[self._j_walking[0]] > 0.5 or o[self._j_walking[1]] > 0.5) and o[self._j_rotating] < 0.5
            keep_out = self.leading_user_keep_out if walking and o[self._j_leading] > 0.5 else self.user_keep_out
            if have_status and keep_out > 0:
                dux, duy = r32(user_x - refx), r32(user_y - refy)  # user relative to our reference
                ux = tx + r32(r32(cd32 * dux) - r32(sd32 * duy))
                uy = ty + r32(r32(sd32 * dux) + r32(cd32 * duy))
                away_x, away_y = tx - ux, ty - uy
                gap = float(np.hypot(away_x, away_y))  # numpy's hypot: it differs from math.hypot in the last bit
                if gap < keep_out:
                    if gap > 1e-6:
                        dx, dy = away_x / gap, away_y / gap
                    else:
                        norm = max(float(np.hypot(ux, uy)), 1e-6)
                        dx, dy = -ux / norm, -uy / norm
                    tx, ty = ux + dx * keep_out, uy + dy * keep_out
            vx, vy = vx + self.kp * tx, vy + self.kp * ty
        elif master_fix is not None:
            # step 1b, building (no reference neighbour in sight: a scattered start): our reference
            # location from the master's fix and an anchor's: the two fixes turn the formation frame
            # into ours (``phi``); with the master alone, orbit it at our reference's distance (within
            # the IR's reach) until a member shows up
            mx, my = master_fix
            goal = None
            if phi is not None:
                c_, s_ = math.cos(phi), math.sin(phi)
                goal = (mx + c_ * refx - s_ * refy, my + s_ * refx + c_ * refy)
            if goal is None:
                dist, reach = max(math.hypot(mx, my), 1e-9), min(math.hypot(refx, refy), self.orbit_max)
                goal = (mx * (1.0 - reach / dist), my * (1.0 - reach / dist))
                turn = self.orbit if o[self._j_member] * 16.0 % 2.0 > 0.5 else -self.orbit  # odd members counter-clockwise
                vx, vy = vx + turn * my / dist, vy - turn * mx / dist
            gain = min(self.kp, self.approach / max(math.hypot(*goal), 1e-9))
            vx, vy = vx + gain * goal[0], vy + gain * goal[1]
        elif have_status and o[self._j_mir_valid] > 0.5:
            # step 1c, lost (no fix of anyone within the age range: the swarm walked out of our IR's
            # reach): back toward where we last saw the master, relative to the swarm we keep moving
            # with (the fix is carried over our own motion in the swarm, the swarm's motion is step
            # 2's feed-forward), until its IR reaches us again; an echo in the way (within
            # ``detour_m``, less than 45° off the master's direction: the user or a robot between us,
            # whose body also blocks the IR) is rounded on the side away from it: an echo right of the
            # master's direction is passed on our right; one within ``_TIE_SIN`` of it, clockwise, or
            # counter-clockwise if we rounded it so last step (the observation's last action less step 2's
            # feed-forward) (chosen: a slave straight behind its user dithered from side to side; always
            # clockwise, a slave whose echo stood 40° right of the master's direction drove round the user's
            # far side, lost the echo between two rays, came back, and stood in front of its user 20 s;
            # without the last step's way, moving counter-clockwise turned the master's direction into the
            # clockwise band and back: a slave dithered 1.8 m ahead of its master 10 s, loss 0.3, seed 5024)
            j = self._j_mir_xy
            mx, my = s[j], s[j + 1]
            dist = max(math.hypot(mx, my), 1e-9)
            dx, dy = mx / dist, my / dist
            if self.detour > 0:
                k, ux_k, uy_k = min(self._us_rays, key=lambda r: o[r[0]])
                if s[k] < min(self.detour, dist) and ux_k * dx + uy_k * dy > _COS45:
                    j = self._j_last  # our last action less the swarm's motion: the way we rounded it last step
                    was_ccw = (o[j] * vmax - vx) * -uy_k + (o[j + 1] * vmax - vy) * ux_k > 0.5 * self.rejoin
                    if dx * uy_k - dy * ux_k < (_TIE_SIN if was_ccw else -_TIE_SIN):
                        dx, dy = -uy_k, ux_k  # the echo right of our way: round it counter-clockwise
                    else:
                        dx, dy = uy_k, -ux_k  # round it clockwise, as step 1d circles an echo
            vx, vy = vx + self.rejoin * dx, vy + self.rejoin * dy
        else:
            # step 1d, nothing in IR sight yet (the user or a robot may stand between us and the
            # swarm): circle the nearest ultrasonic echo, clockwise, until an IR fix comes. The
            # ring's rays are 45° apart and a body 1 m off fills ±12° of them, so the robot turns
            # with its circle (the echo stays on its ray); with no echo in range it turns on the spot
            # at ``scan_rps``, sweeping the rays over the gaps between them (chosen: a slave in its
            # user's IR shadow, 1 m beyond the user, found no echo and stood there 20-35 s)
            k, ux_k, uy_k = min(self._us_rays, key=lambda r: o[r[0]])
            if o[k] < 1.0:
                vx, vy = vx + self.search * uy_k, vy - self.search * ux_k
                if self.scan > 0:
                    search_turn = -self.search / (s[k] + _RIM_M)
            else:
                search_turn = -self.scan
        # step 4: leading mode arc driving on user rotation
        if leading_turn:
            turn = s[self._j_turn]
            if o[self._j_walking[0]] > 0.5 or o[self._j_walking[1]] > 0.5:  # a walking turn: as the master's arc
                turn = max(-self.arc_max, min(self.arc_max, turn))
            rx, ry = r32(refx - user_x), r32(refy - user_y)
            ax, ay = r32(-turn * ry), r32(turn * rx)
            vx, vy = vx + r32(r32(cd32 * ax) - r32(sd32 * ay)), vy + r32(r32(sd32 * ax) + r32(cd32 * ay))
        # step 3: twisted-heading correction inside an error band, plus the swarm's rotation (and
        # step 1d's turn while searching)
        omega = mv2 + (self.kh * dth if abs(dth) > self.band else 0.0) + search_turn
        # step 5: ultrasonic keep-out (shrunk for tight formations: never beyond 85 % of the rim-to-rim
        # gap the formation itself asks for, taking 0.4 m for two robot radii)
        keep_out = self.keep_out
        if ref_dists:
            keep_out = min(keep_out, max(0.1, 0.85 * (min(ref_dists) - 0.4)))
        keep32 = r32(keep_out)
        push_x = push_y = 0.0
        close = False
        for k, ux_k, uy_k in self._us_rays:
            rng_k = s[k]
            if rng_k < keep32:
                depth = r32(keep32 - rng_k)
                push_x, push_y = push_x + depth * ux_k, push_y + depth * uy_k
                close = True
        if close:
            vx, vy = vx - self.krep * push_x, vy - self.krep * push_y
        return vx / vmax, vy / vmax, omega / wmax
