"""Who joins and which formation slot each member takes: ``swarm.assignment`` (seed 000 Table 2 or
seed 003 RUTA, §4.1.2 and Algorithms 1-2, on the join protocol of :mod:`.join`).

The strategies (the join manager's step 3, ``JoinManager._select``; the decentralized auction runs
just before it, ``JoinManager._auction``, inside the same pipeline, so an organize and a refill of
one open slot run the same code):

* ``closest`` (the default): seed 000 Table 2 — the closest available robots (the master's RSSI
  estimate of their scan responses) fill the lowest open member numbers, closest first.
* ``ruta_centralized``: seed 003 Algorithm 1 on the master. Each candidate answers the joining query
  with its status report (``status_answer`` frame: type, battery, slip, draws, its distance
  estimate; ``messages.py`` gives its size); the master computes every candidate's utility for every
  open slot (:func:`select_centralized`) and assigns by :func:`ruta.centralized_from_reports`.
* ``ruta_decentralized``: seed 003 Algorithm 2. The master announces the open slots
  (``slot_announce``), each free candidate computes its own utilities (:func:`own_utilities`) and
  bids (``bid``); after t_out (``ruta.bid_timeout_s``, closed early once every listed bidder
  answered) the fittest bid of each slot wins (:func:`close_round`). Chosen readings of Algorithm 2:
  the announcer is the master (it holds the formation and sends the joining notifications); a bid
  goes to the announcer only (seed 003: "each robot's utility value is shared with the other
  robots"; here no other robot acts on it); step 2's "the two robots with the highest utility
  values will begin" (``ruta.deploy_first``) does not apply: every open slot is auctioned at once.

**The slot -> subtask mapping (chosen).** A slot (member number m >= 1) is one subtask v_m:

* *navigation* to the slot, always: φ_nav (seed 003 §4.1.2, eq. 3), at the distance d_im from
  robot i to the slot;
* *sensing* toward the outside where the slot is on the formation's outer edge: the slot's
  *exposed sides* e_m are the formation-frame directions (ahead, behind, left, right) in whose
  90° cone from the slot no other slot (the master's included) lies (:func:`slot_geometry`); a slot
  with e_m > 0 has a sensing part of t_s = (e_m / 4)·t_m seconds (φ_sens, eq. 4), a slot with e_m = 0
  (inside the formation, e.g. the wedge's first pair) none. A robot without a working ultrasonic ring
  (``rate_sens_ma`` None) is not capable of a slot with a sensing part (``ruta.capable``).
  Example, wedge of 4 slaves: slots 1, 2 (first pair) have 1 exposed side each, slots 3, 4 (the
  arms' ends) 2 each; a column: every slave 2 (left and right), the last 3.
* *priority*: t − t_j is the slot's age, from when it opened (the organize started, or the member
  was lost: ``JoinManager.opened_s``) to when the utility is computed (at least :data:`MIN_AGE_S`);
  the same for every robot, so it scales a slot's utilities without reordering them.

**d without ground truth (chosen).** Nobody knows a true position: the master knows a candidate
only by RSSI distance estimates (:attr:`Frame.rx_distance_est_m`, no bearing: waiting robots are
not on the IR ring), a slot by its offset a_m from the master in the formation frame. With the
bearing unknown, the robot is anywhere on the circle of radius r around the master; the
root-mean-square distance to the slot over that circle is d = sqrt(r² + a_m²) (:func:`slot_distance`),
which grows with r for every slot (closer robots are better for every slot, Table 2's reason) and
with a_m. r is the mean of two independent RSSI estimates of the same master-robot range: the
master's estimate of the robot's scan response and the robot's of the joining query (centralized,
reported in the status answer), or the robot's of the joining query and of the slot announcement
(decentralized).

**Conflicts and losses (chosen).** A bid is an offer, never a claim: only the master's joining
notification gives a robot a slot, so two robots cannot both hold one. Two bids for one slot: the
higher utility wins, equal utilities the lower robot id (``ruta.fittest``); a robot fittest for
several slots takes the first in :func:`schedule` order (the slot fewer robots can take, then the
lower number), the others go to their next-fittest bidder in the same round. A bid lost or collided is a robot missing from that round; a stale bid (an
earlier announcement's sequence number) is ignored. A slot left without a winner is announced again
(to the robots still free) while a listed bidder's bid was missing, up to ``ruta.max_announcements``
announcements and the organize deadline; a slot nobody free can take stays open (the swarm
organizes short, as with too few robots). A lost status answer is a missing joining answer: the
master queries again (the join protocol's retry). At an organize, the filled slots are then numbered
1..n without a gap (the formation table has no holes): when a slot stays open, the members after
it move up one number (chosen; a refill keeps the numbers it fills).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from petswarm_env.config import Config, RutaConfig, SwarmConfig
from petswarm_env.middleware import ruta
from petswarm_env.middleware.formation import Formation, build_formation

if TYPE_CHECKING:
    from petswarm_env.middleware.station import Station

SIDES = ((1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0))  # ahead, behind, left, right (formation frame)
# chosen: a slot is at least this old (s) when utilities are computed; at age 0 the priority ½·min(u1·(t − t_j), 1)
# is 0, every utility with it, and no robot could take the slot
MIN_AGE_S = 1e-3
NO_MODULE = -1.0  # a status answer's draw for a module the robot does not have (or that failed)
_CONE_COS = math.cos(math.radians(45.0))  # a slot within 45° of a side's direction covers it

# The petbot's status for a station without a body report (a bare station, as in the unit tests;
# every robot of the env reports its own body): seed 003's robot figures. Battery: "six packs of 6 V 2500 mAh Ni-MH batteries"
# (seed 003 §4.2); servo draw 320 mA and wheel slip 1 % (R2, seed 003 §5.2.1); sensing draw 65 mA
# (R2's sensing, §5.2.1); no manipulator (the petbot has no arm, so no actuator draw).
PETBOT_PROVISIONAL = {"type": "petbot", "battery_mah": 2500.0, "slip_pct": 1.0, "rate_servo_ma": 320.0,
                      "rate_act_ma": None, "rate_sens_ma": 65.0, "sensors": ("DISTANCE", "IR", "LF", "AHRS")}
# the status answer's sensor bit mask (seed 001's sensor types): DISTANCE (the ultrasonic sensors), the IR
# ring, the LF antennas, the AHRS (every robot carries one, seed 000 §3.5; a bit of its own so a robot whose
# AHRS failed can say so)
SENSOR_BITS = {"DISTANCE": 1, "IR": 2, "LF": 4, "AHRS": 8}
AHRS = "AHRS"
# chosen: what holding a formation slot needs working — the IR ring that locates the neighbours (seed 000 §3.3)
# and the AHRS that carries the IR bearings over the robot's own rotation and gives the heading exchange its
# turn (§3.5); a robot without either cannot keep its slot (seed 003 Algorithm 2 step 5's "prevented from
# completing task v_j")
SLOT_NEEDS = frozenset({"IR", AHRS})
# the robot's own names of its sensing parts (middleware/diagnosis.py) -> the sensor type they are
FAILED_KIND = {"ultrasonic": "DISTANCE", "ir": "IR", "ahrs": AHRS}


# chosen: a wheel slip below this counts as this (%): φ_nav's 1/w diverges at w = 0 (a type may give
# 0, "does not slip"); seed 003's smallest printed slip (R2, §5.2.1)
MIN_SLIP_PCT = 1.0


def own_status(station: Station) -> ruta.RobotStatus:
    """This robot's own status for RUTA (seed 003 β_i = <id, w_i, P_rem_i> and its draws): the ONE
    place a robot reads it. From its own body's report when the body gives one
    (``Station.own_body_status``, ``Robot.own_status()``: type, battery left,
    slip, draws, registered sensors; :func:`status_from_body`), else (a bare station) the petbot's
    figures (:data:`PETBOT_PROVISIONAL`; its body, radius and limits are ``cfg.robot``, which seed
    003's φ do not use).

    Sensor faults: the parts the robot has found broken (``failed_sensors``: its own diagnosis,
    middleware/diagnosis.py, e.g. ``{"ultrasonic"}``) and the sensors its body report says do not
    work (``working``) are left out of its sensors; a robot whose ultrasonic sensors failed reports
    no sensing draw (``rate_sens_ma`` None), so it is not capable of the slots with a sensing part;
    one whose IR ring or AHRS failed of no slot (:data:`SLOT_NEEDS`)."""
    failed = getattr(station, "failed_sensors", frozenset())
    body = station.own_body_status() if hasattr(station, "own_body_status") else None
    if body is not None:
        return status_from_body(body, failed)
    p = PETBOT_PROVISIONAL
    has_ring = station.cfg.robot.ultrasonic.count > 0 and "ultrasonic" not in failed
    broken = {FAILED_KIND[f] for f in failed if f in FAILED_KIND}
    sensors = frozenset(k for k in p["sensors"] if (k != "DISTANCE" or has_ring) and k not in broken)
    return ruta.RobotStatus(id=station.node_id, p_rem_mah=p["battery_mah"], slip_pct=p["slip_pct"],
                            rate_servo_ma=p["rate_servo_ma"], rate_act_ma=p["rate_act_ma"],
                            rate_sens_ma=p["rate_sens_ma"] if has_ring else None, robot_type=p["type"],
                            sensors=sensors)


def status_from_body(body: Mapping, failed: Iterable[str] = ()) -> ruta.RobotStatus:
    """A body's own report (``Robot.own_status()``'s dict: ``id``, ``type``,
    ``battery_mah`` left, ``battery_empty``, ``wheel_slip_pct``, ``servo_ma``, ``actuator_ma``,
    ``sensing_ma``, ``sensors`` [{type, working, ...}]) as RUTA's status: a draw of 0 is no such
    module, no working ``DISTANCE`` sensor (none registered, none ``working``, or ``"ultrasonic"`` in
    ``failed``) no sensing, an empty battery a faulty robot, the slip at least :data:`MIN_SLIP_PCT`.
    The sensors reported are the kinds with a ``working`` sensor, and the AHRS every robot carries,
    less the parts in ``failed`` (the robot's own diagnosis: :data:`FAILED_KIND`)."""
    def rate(x: float | None) -> float | None:
        return float(x) if x is not None and x > 0 else None
    broken = {FAILED_KIND[f] for f in failed if f in FAILED_KIND}
    working = [sn for sn in body.get("sensors", ()) if sn.get("working", True)]
    sensing = any(sn["type"] == "DISTANCE" for sn in working) and "DISTANCE" not in broken
    kinds = frozenset(k for k in {sn["type"] for sn in working} | {AHRS} if k not in broken)
    return ruta.RobotStatus(id=body["id"], p_rem_mah=max(0.0, float(body["battery_mah"])),
                            slip_pct=max(float(body["wheel_slip_pct"]), MIN_SLIP_PCT),
                            rate_servo_ma=rate(body["servo_ma"]), rate_act_ma=rate(body.get("actuator_ma")),
                            rate_sens_ma=rate(body.get("sensing_ma")) if sensing else None,
                            faulty=bool(body.get("battery_empty", False)), robot_type=str(body["type"]), sensors=kinds)


def params(cfg: RutaConfig) -> ruta.RutaParams:
    return ruta.RutaParams(t_m_s=cfg.t_m_s, u1_per_s=cfg.u1_per_s, u2=cfg.u2, min_distance_m=cfg.min_distance_m)


# -- the slots as subtasks --------------------------------------------------------------------------
def slot_geometry(formation: Formation) -> dict[int, tuple[float, int]]:
    """Member number -> (a_m: its distance from the master in the formation frame (m), e_m: its
    exposed sides, 0-4): a side is exposed when no other slot lies in its 90° cone (module docstring)."""
    pos = formation.slot_positions()
    out: dict[int, tuple[float, int]] = {}
    for m in range(1, len(pos)):
        rel = np.delete(pos, m, axis=0) - pos[m]
        dist = np.hypot(rel[:, 0], rel[:, 1])
        exposed = sum(1 for ux, uy in SIDES if not np.any(rel[:, 0] * ux + rel[:, 1] * uy >= _CONE_COS * dist - 1e-9))
        out[m] = (float(np.hypot(*pos[m])), exposed)
    return out


def slots_formation(swarm: SwarmConfig, open_members: Sequence[int]) -> Formation:
    """The formation whose slots are assigned at an organize: the configured shape with members up to
    the highest open number (a standard shape's slot m does not depend on the swarm's size; a custom
    table is the configured one)."""
    n = max(lk.robot for lk in swarm.custom_links) + 1 if swarm.formation == "custom" else max(open_members) + 1
    return build_formation(swarm, n)


def slot_subtask(member: int, exposed: int, cfg: RutaConfig) -> ruta.Subtask:
    """Slot ``member`` as seed 003's subtask: navigation, plus sensing for (exposed/4)·t_m seconds on
    the outer edge; announced at 0 (priorities take the slot's age as t); it needs the IR ring and the
    AHRS working (:data:`SLOT_NEEDS`)."""
    return ruta.Subtask(str(member), 0.0, nav=True, sens_s=cfg.t_m_s * exposed / 4.0 if exposed else None,
                        needs=SLOT_NEEDS)


def slot_distance(r_m: float, a_m: float) -> float:
    """d = sqrt(r² + a²): the RMS distance from a robot r from the master, bearing unknown, to a slot
    a from the master (module docstring)."""
    return math.sqrt(r_m * r_m + a_m * a_m)


def mean_range(*estimates: float | None) -> float:
    """The mean of the finite RSSI range estimates given (the same master-robot range measured twice)."""
    vals = [float(e) for e in estimates if e is not None and math.isfinite(e)]
    return sum(vals) / len(vals) if vals else math.inf


def _located(status: ruta.RobotStatus, r_m: float, geometry: Mapping[int, tuple[float, int]]) -> ruta.RobotStatus:
    return ruta.RobotStatus(status.id, status.p_rem_mah, status.slip_pct, status.rate_servo_ma, status.rate_act_ma,
                            status.rate_sens_ma, {str(m): slot_distance(r_m, a) for m, (a, _) in geometry.items()},
                            status.faulty, status.robot_type, status.sensors)


def schedule(open_members: Iterable[int], takers: Mapping[int, int]) -> list[int]:
    """The open slots in schedule order (Algorithm 1's "each unexecuted sub-task v_j in the schedule",
    Algorithm 2's slots decided in turn; chosen): the slots fewer robots can take first (``takers``:
    member -> how many candidates are capable of it, or bid for it), then by member number. With one
    robot type every robot can take every slot, so this is member order; a robot whose ring failed
    is then left the slot without a sensing part instead of nothing."""
    return sorted(open_members, key=lambda m: (takers.get(m, 0), m))


# -- closest (seed 000 Table 2) ---------------------------------------------------------------------
def select_closest(joiners_closest_first: Sequence[int], open_members: Sequence[int]) -> dict[int, int]:
    """Table 2's joiners (closest first) fill the lowest open member numbers."""
    return dict(zip(sorted(open_members), joiners_closest_first))


# -- ruta_centralized (seed 003 Algorithm 1) ---------------------------------------------------------
def status_payload(status: ruta.RobotStatus, available: bool, distance_est_m: float) -> dict:
    """The status answer's payload (``messages.STATUS_ANSWER``): a draw of -1 for a module the robot
    lacks (0xFFFF on the wire)."""
    def rate(x: float | None) -> float:
        return NO_MODULE if x is None else float(x)
    return {"available": available, "type": status.robot_type, "battery_mah": float(status.p_rem_mah),
            "slip_pct": float(status.slip_pct), "rate_servo_ma": rate(status.rate_servo_ma),
            "rate_act_ma": rate(status.rate_act_ma), "rate_sens_ma": rate(status.rate_sens_ma),
            "sensors": sum(bit for kind, bit in SENSOR_BITS.items() if kind in status.sensors),
            "distance_m": float(distance_est_m)}


def status_from_payload(robot: int, p: Mapping) -> ruta.RobotStatus:
    def rate(x: float) -> float | None:
        return None if x < 0 else x
    sensors = frozenset(kind for kind, bit in SENSOR_BITS.items() if p["sensors"] & bit)
    sens = rate(p["rate_sens_ma"]) if "DISTANCE" in sensors else None  # no working ultrasonic sensor: no sensing
    return ruta.RobotStatus(robot, p["battery_mah"], p["slip_pct"], rate(p["rate_servo_ma"]), rate(p["rate_act_ma"]),
                            sens, robot_type=p["type"], sensors=sensors)


def select_centralized(reports: Mapping[int, ruta.RobotStatus], ranges_m: Mapping[int, float],
                       geometry: Mapping[int, tuple[float, int]], open_members: Sequence[int], age_s: float,
                       cfg: Config) -> dict[int, int]:
    """Algorithm 1 on the master: every reporting available candidate's utility for every open slot
    (``ranges_m``: the master's range to each, :func:`mean_range`), then
    :func:`ruta.centralized_from_reports` with an empty team and the candidates (closest first) as
    the remaining robots, the slots in :func:`schedule` order; returns member number -> robot id."""
    rc = cfg.ruta
    order = sorted(reports, key=lambda rid: (ranges_m[rid], rid))
    located = [_located(reports[rid], ranges_m[rid], geometry) for rid in order]
    by_member = {m: slot_subtask(m, geometry[m][1], rc) for m in open_members}
    takers = {m: sum(1 for r in located if ruta.capable(r, sub)) for m, sub in by_member.items()}
    subtasks = [by_member[m] for m in schedule(open_members, takers)]
    res = ruta.centralized_from_reports(located, subtasks, max(age_s, MIN_AGE_S), team=[], params=params(rc),
                                        max_trials=rc.max_trials)
    return {int(sid): rid for sid, rid in sorted(res.assignment.items(), key=lambda kv: int(kv[0]))}


# -- ruta_decentralized (seed 003 Algorithm 2) -------------------------------------------------------
def announce_slots(geometry: Mapping[int, tuple[float, int]], open_members: Iterable[int], age_s: float) -> list:
    """The slot announcement's entries: (member, distance from the master, exposed sides, age)."""
    return [(m, geometry[m][0], geometry[m][1], max(age_s, MIN_AGE_S)) for m in sorted(open_members)]


def own_utilities(status: ruta.RobotStatus, r_m: float, slots: Iterable, cfg: RutaConfig) -> list[tuple[int, float]]:
    """Algorithm 2 step 1 on the robot: its own utility for each announced slot (``ruta.own_bid``),
    as the bid carries it (float32); slots it cannot take (utility 0) are left out."""
    out = []
    for m, a_m, exposed, age_s in slots:
        sub = slot_subtask(int(m), int(exposed), cfg)
        located = ruta.RobotStatus(status.id, status.p_rem_mah, status.slip_pct, status.rate_servo_ma,
                                   status.rate_act_ma, status.rate_sens_ma, {sub.id: slot_distance(r_m, a_m)},
                                   status.faulty, status.robot_type, status.sensors)
        u = ruta.own_bid(located, sub, float(age_s), params(cfg))
        if u is not None:
            out.append((int(m), float(np.float32(u))))
    return out


def close_round(bids: Iterable[ruta.Bid], open_members: Sequence[int], announced_s: float, t_out_s: float,
                attempt: int, max_attempts: int) -> dict[int, int]:
    """The announcer's decision after one round (Algorithm 2 steps 6-7): each open slot, in
    :func:`schedule` order of how many robots bid for it, goes to its fittest bid
    (``ruta.close_auction``) among the robots that have not won a slot earlier in this round; returns
    member number -> robot id (slots without a winner are left out)."""
    bids = list(bids)
    takers = {m: len({b.robot for b in bids if b.subtask == str(m) and b.utility > 0}) for m in open_members}
    won: dict[int, int] = {}
    for m in schedule(open_members, takers):
        free = [b for b in bids if b.robot not in won.values()]
        d = ruta.close_auction(free, str(m), announced_s, t_out_s, attempt, max_attempts)
        if d.kind == "assign":
            won[m] = d.winner.robot
    return won
