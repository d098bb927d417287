"""RUTA — Robot Utility-based Task Assignment (seed 003 §4.1.2, Algorithms 1 and 2, §5.2).

Seed 003 (Abukhalil, Patil, Patel, Sobh, Robotics 5:22, 2016) splits a task into subtasks and gives
each (robot, subtask) pair a *utility*; the subtask goes to the robot with the highest utility,
either decided by one computer (centralized, Algorithm 1) or by the robots bidding (decentralized,
Algorithm 2). This module is the pure logic: the equations, the two decision procedures and the
worked example of §5.2.1 as data. It imports nothing from the rest of the project.

The equations (§4.1.2; the text extraction flattens fractions and exponents, the reconstruction
of each is checked against the worked example of §5.2.1 and against SPEC §6). The paper numbers
none of its equations; the code cites them as "seed 003 §4.1.2, eq. N", counting the displayed
equations of §4.1.2 in order (eq. 1 is the plan cost Cost(P_i, T_i) = Σ_j cost(r_i, v_ij), not
used here):

* eq. 2: φ_manip_ij = 0.7 · (t_sj / t_m) · (P_rem_i / rate_act_j)   ("0.7 × [(t s j t m)[P r e m i r a t e a c t j]]")
* eq. 3: φ_nav_ij   = 0.7 · (P_rem_i / rate_servo_j) · (1 / w_i)   ("0.7 × [[p r e m i r a t e s e r v o j] × 1 w i]")
* eq. 4: φ_sens_ij  = 0.9 · (t_sj / t_m) · (P_rem_i / rate_sens_j)   (as φ_manip with 0.9)
* eq. 5: φ_given_ij = φ_manip_ij + φ_nav_ij + φ_sens_ij, a term being "null if [it is] not taking
  place in the subtask"
* eq. 6: pri_ij = ½ · min(u1 · (t − t_j), 1)                          ("1 2 × min [(u 1 × (t t j)), 1]")
* eq. 7: utility_ij = max(0, u2 · d_ij^(−1/2) · φ_given_ij · pri_ij) ("d i j 1 / 2"; the exponent is
  −1/2: "The smaller the distance d i j is, the higher the utility", and §5.2.1 divides by √3 and
  √4.3: 3^(−1/2)·2.69·0.45 = 0.69, 4.3^(−1/2)·5.04·0.45 = 1.09); d_ij = 1 "when no distance is
  involved".

Units: P_rem in mAh, consumption rates in mA (so P_rem / rate is hours of operation at that
draw), t_s, t_m, t, t_j in s, u1 in 1/s, the wheel slip w in percent as a plain number (w = 3 for
3 %, §5.2.1: "× 1/3" for R1), d in m; φ and utility are unitless scores.

Algorithms 1 and 2 are here as pure decision functions (:func:`assign_centralized`,
:func:`own_bid`, :func:`fittest`, :func:`close_auction`, :func:`deploy_first`). Their radio wiring
on the swarm (``swarm.assignment``: the status reports, slot announcements and bids over the
simulated 802.15.4 medium, the formation slots as subtasks) is :mod:`.assignment` and :mod:`.join`.

Where the paper's printed numbers do not follow from its own formulas (they are computed exactly
here; the tests state the printed value beside the exact one):

* R1's navigation quality: "0.7 [[2200/130] × 1/3] = 0.7 [5.58] = 3.90"; 2200/130/3 is 5.641 and
  0.7 × 5.641 = 3.949 (3.95).
* §5.2.1 prints the priority as "½ × max[(u1 × (110 − 20)), 0]" where §4.1.2 defines "½ × min[...,
  1]"; both give 0.45 here (0.9 < 1). We implement §4.1.2's definition. Before its announcement
  (t < t_j) a subtask's priority is negative and every utility for it is 0.
* The navigation example uses "Initially, the priorities of all sub-tasks are equal to 1", a value
  the formula (at most ½) never reaches; :func:`worked_example` passes pri = 1 as printed.
* R2's grip example uses P_rem 2000 mAh in φ_manip and 2150 mAh in φ_sens (and 2200 mAh in φ_nav
  earlier); the figures are reproduced with the inputs as printed.
* 0.698 is printed as 0.69 (truncated) while 1.637 is printed as 1.64 (rounded).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass, field

RobotId = int | str  # ids of one kind per call (ties compare them)

# --------------------------------------------------------------------------------------------
# The equations (seed 003 §4.1.2)
# --------------------------------------------------------------------------------------------


def _check(name: str, x: float, *, positive: bool = False) -> float:
    x = float(x)
    if not math.isfinite(x) or x < 0 or (positive and x == 0):
        raise ValueError(f"{name} must be a finite number {'> 0' if positive else '>= 0'}, got {x!r}")
    return x


def phi_manip(ts_s: float, tm_s: float, p_rem_mah: float, rate_act_ma: float) -> float:
    """Manipulation quality φ_manip: 0.7·(t_s/t_m)·(P_rem/rate_act).

    ``ts_s``: time assigned to the subtask (s); ``tm_s``: total time given to the robot for all its
    subtasks (s); ``p_rem_mah``: remaining battery (mAh); ``rate_act_ma``: actuator draw (mA)."""
    # seed 003 §4.1.2, eq. 2
    return 0.7 * (_check("ts_s", ts_s) / _check("tm_s", tm_s, positive=True)) * (
        _check("p_rem_mah", p_rem_mah) / _check("rate_act_ma", rate_act_ma, positive=True))


def phi_nav(p_rem_mah: float, rate_servo_ma: float, slip_pct: float) -> float:
    """Navigation quality φ_nav: 0.7·(P_rem/rate_servo)·(1/w).

    ``p_rem_mah``: remaining battery (mAh); ``rate_servo_ma``: drive servos' draw (mA);
    ``slip_pct``: wheel slip w in percent (3 for 3 %; 1/w diverges at 0, so w must be > 0)."""
    # seed 003 §4.1.2, eq. 3
    return 0.7 * (_check("p_rem_mah", p_rem_mah) / _check("rate_servo_ma", rate_servo_ma, positive=True)) * (
        1.0 / _check("slip_pct", slip_pct, positive=True))


def phi_sens(ts_s: float, tm_s: float, p_rem_mah: float, rate_sens_ma: float) -> float:
    """Sensing quality φ_sens: 0.9·(t_s/t_m)·(P_rem/rate_sens).

    Units as :func:`phi_manip`; ``rate_sens_ma``: the sensors' draw (mA)."""
    # seed 003 §4.1.2, eq. 4
    return 0.9 * (_check("ts_s", ts_s) / _check("tm_s", tm_s, positive=True)) * (
        _check("p_rem_mah", p_rem_mah) / _check("rate_sens_ma", rate_sens_ma, positive=True))


def priority(t_s: float, tj_s: float, u1_per_s: float) -> float:
    """Subtask priority pri: ½·min(u1·(t − t_j), 1).

    ``t_s``: time since the task began (s); ``tj_s``: when the subtask was announced (s);
    ``u1_per_s``: how fast the priority grows (1/s). At most ½; negative before t_j."""
    for name, x in (("t_s", t_s), ("tj_s", tj_s), ("u1_per_s", u1_per_s)):
        if not math.isfinite(float(x)):
            raise ValueError(f"{name} must be a finite number, got {x!r}")
    # seed 003 §4.1.2, eq. 6
    return 0.5 * min(float(u1_per_s) * (float(t_s) - float(tj_s)), 1.0)


def utility(d_m: float, phi_given: float, pri: float, u2: float = 1.0) -> float:
    """Utility: max(0, u2·d^(−1/2)·φ_given·pri).

    ``d_m``: distance from the robot to the subtask (m; 1 when no distance is involved, > 0);
    ``phi_given``: φ_manip + φ_nav + φ_sens of the parts the subtask has; ``pri``: the priority;
    ``u2``: weight."""
    d = _check("d_m", d_m, positive=True)
    for name, x in (("phi_given", phi_given), ("pri", pri), ("u2", u2)):
        if not math.isfinite(float(x)):
            raise ValueError(f"{name} must be a finite number, got {x!r}")
    # seed 003 §4.1.2, eq. 7
    return max(0.0, float(u2) * (d ** -0.5 * float(phi_given) * float(pri)))


# --------------------------------------------------------------------------------------------
# Robots, subtasks and the utility table
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RutaParams:
    """``t_m_s`` (s), ``u1_per_s`` (1/s), ``u2``: seed 003 §5.2.1's 200 s, 0.01, 1.
    ``min_distance_m`` (chosen): distances below it count as it (d^(−1/2) diverges at a robot
    standing on its subtask)."""

    t_m_s: float = 200.0
    u1_per_s: float = 0.01
    u2: float = 1.0
    min_distance_m: float = 0.1


@dataclass(frozen=True)
class Subtask:
    """One subtask v_j: announced at ``announced_s`` (t_j, s), with the parts it has: ``nav``igation,
    manipulation for ``manip_s`` seconds and sensing for ``sens_s`` seconds (t_s; None = no such
    part). ``located``: d_ij is the robot's distance to it; False: d_ij = 1 (§4.1.2). ``needs``: the
    kinds of sensor it needs working (seed 003 Algorithm 2 step 5: "a sensor fails on one robot r_i
    by which it is prevented from completing task v_j"; chosen, the paper names none)."""

    id: str
    announced_s: float = 0.0
    nav: bool = False
    manip_s: float | None = None
    sens_s: float | None = None
    located: bool = True
    needs: frozenset[str] = frozenset()  # sensor kinds the subtask cannot be done without (RobotStatus.sensors)

    def __post_init__(self) -> None:
        if not self.nav and self.manip_s is None and self.sens_s is None:
            raise ValueError(f"subtask '{self.id}' has no part: give nav, manip_s or sens_s")


@dataclass(frozen=True)
class RobotStatus:
    """What a robot reports (seed 003 β_i = <id, w_i, P_rem_i>, plus its draws and distances).

    ``p_rem_mah`` (mAh), ``slip_pct`` (w, %), the draws in mA of its drive servos, actuator and
    sensors — None when it has no such module or it has failed (it cannot do subtasks needing it) —
    ``distance_m``: its distance estimate to each subtask id (m); ``faulty``: a robot found faulty;
    ``robot_type``: its type's name and ``sensors`` the kinds of sensor it carries and that work
    (e.g. ``DISTANCE``, ``IR``, ``LF``; reported, not used by the equations)."""

    id: RobotId
    p_rem_mah: float
    slip_pct: float
    rate_servo_ma: float | None = None
    rate_act_ma: float | None = None
    rate_sens_ma: float | None = None
    distance_m: Mapping[str, float] = field(default_factory=dict)
    faulty: bool = False
    robot_type: str = ""
    sensors: frozenset[str] = frozenset()


def capable(robot: RobotStatus, subtask: Subtask) -> bool:
    """Seed 003 assigns a subtask "to the specific robot (that is capable of accomplishing it)":
    not faulty, battery left, a working module for every part of the subtask and every sensor it needs."""
    if robot.faulty or robot.p_rem_mah <= 0 or not subtask.needs <= robot.sensors:
        return False
    return ((not subtask.nav or robot.rate_servo_ma is not None)
            and (subtask.manip_s is None or robot.rate_act_ma is not None)
            and (subtask.sens_s is None or robot.rate_sens_ma is not None))


def robot_utility(robot: RobotStatus, subtask: Subtask, t_s: float, params: RutaParams = RutaParams()) -> float:
    """utility_ij of ``robot`` for ``subtask`` at time ``t_s``: 0 if it is not :func:`capable`,
    else φ_given from the parts the subtask has, pri from its announcement, d from the report."""
    if not capable(robot, subtask):
        return 0.0
    phi = 0.0  # seed 003 §4.1.2, eq. 5: φ_given, the sum of the parts the subtask has
    if subtask.nav:
        phi += phi_nav(robot.p_rem_mah, robot.rate_servo_ma, robot.slip_pct)
    if subtask.manip_s is not None:
        phi += phi_manip(subtask.manip_s, params.t_m_s, robot.p_rem_mah, robot.rate_act_ma)
    if subtask.sens_s is not None:
        phi += phi_sens(subtask.sens_s, params.t_m_s, robot.p_rem_mah, robot.rate_sens_ma)
    d = 1.0
    if subtask.located:
        if subtask.id not in robot.distance_m:
            raise ValueError(f"robot {robot.id} reports no distance to subtask '{subtask.id}'")
        d = max(float(robot.distance_m[subtask.id]), params.min_distance_m)
    return utility(d, phi, priority(t_s, subtask.announced_s, params.u1_per_s), params.u2)


def utility_table(robots: Iterable[RobotStatus], subtasks: Iterable[Subtask], t_s: float,
                  params: RutaParams = RutaParams()) -> dict[tuple[RobotId, str], float]:
    """``{(robot id, subtask id): utility}`` for every pair (what the master computes from the reports)."""
    subtasks = tuple(subtasks)
    return {(r.id, s.id): robot_utility(r, s, t_s, params) for r in robots for s in subtasks}


# --------------------------------------------------------------------------------------------
# Algorithm 1 (centralized)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CentralizedResult:
    """``assignment``: subtask id -> robot id; ``team``: the robot ordering at the end (its length
    is "the optimal number of robots", the final i); ``unassigned``: open subtasks left;
    ``trials``: passes of steps 1-9 run."""

    assignment: dict[str, RobotId]
    team: tuple[RobotId, ...]
    unassigned: tuple[str, ...]
    trials: int


def _pass(open_ids: Sequence[str], team: Sequence[RobotId], taken: set, u: Mapping) -> dict[str, RobotId]:
    """Steps 1-6 once: each open subtask, in schedule order, goes to the free team robot with the
    highest utility; a robot replaces the current holder only with a strictly higher one."""
    out: dict[str, RobotId] = {}
    for sid in open_ids:
        best, best_u = None, 0.0  # "previous utility" of a subtask nobody holds: 0
        for rid in team:
            if rid in taken:
                continue
            cur = u.get((rid, sid), 0.0)
            if cur > best_u:
                best, best_u = rid, cur
        if best is not None:
            out[sid] = best
            taken.add(best)
    return out


def _best_recruit(pool: Sequence[RobotId], open_ids: Sequence[str], u: Mapping) -> RobotId | None:
    """Step 10: the remaining robot with the highest utility for any open subtask (pool order on a
    tie); None when no remaining robot has a positive utility."""
    best, best_u = None, 0.0
    for rid in pool:
        cur = max((u.get((rid, sid), 0.0) for sid in open_ids), default=0.0)
        if cur > best_u:
            best, best_u = rid, cur
    return best


def assign_centralized(open_subtasks: Sequence[str], utilities: Mapping[tuple[RobotId, str], float],
                       team: Sequence[RobotId], pool: Sequence[RobotId] = (), *,
                       busy: Collection[RobotId] = (), faulty: Collection[RobotId] = (),
                       max_trials: int = 10) -> CentralizedResult:
    """Seed 003 Algorithm 1, on the utilities the master computed (:func:`utility_table`).

    ``open_subtasks``: the unexecuted subtasks in schedule order; ``team``: the current robot
    ordering; ``pool``: the remaining robots that may be added; ``busy``: robots holding a subtask
    already; ``faulty``: robots found faulty (removed from the team and the pool); ``max_trials``: K
    (the paper gives no value; 10 is chosen).

    The paper's steps: (1) for each unexecuted subtask, (2) for each robot in the ordering,
    (3) compute its utility, (4) "if the current utility of r_i for sub-task v_j is greater than its
    previous utility then assign" — we read "previous" as the utility of the subtask's current
    holder (0 while nobody holds it), so the subtask ends with its highest-utility robot and a tie
    keeps the earlier robot in the ordering; (7) stop when done or after K trials; (8) on a faulty
    robot go to (10): "pick the robot with the highest utility value from the list of remaining
    robots", (11) add it to the ordering, (12) go to (1). Step 10 also runs when a pass leaves a
    subtask open; it stops early when no remaining robot has a positive utility.

    One robot per subtask: each subtask has one holder. One subtask per robot: a robot that is
    ``busy`` or took a subtask earlier in the run is skipped for the later subtasks, so schedule
    order is precedence (earlier subtasks choose first).
    """
    if max_trials < 1:
        raise ValueError(f"max_trials (K) must be >= 1, got {max_trials}")
    bad = set(faulty)
    ordering = [r for r in team if r not in bad]
    remaining = [r for r in pool if r not in bad and r not in ordering]
    taken = set(busy) - bad
    assignment: dict[str, RobotId] = {}
    open_ids = list(open_subtasks)
    if bad & set(team):  # step 8 -> 10: replace the faulty robot first
        recruit = _best_recruit(remaining, open_ids, utilities)
        if recruit is not None:
            ordering.append(recruit)
            remaining.remove(recruit)
    trials = 0
    while open_ids and trials < max_trials:
        trials += 1
        assignment.update(_pass(open_ids, ordering, taken, utilities))
        open_ids = [s for s in open_ids if s not in assignment]
        if not open_ids:
            break
        recruit = _best_recruit(remaining, open_ids, utilities)  # step 10
        if recruit is None:
            break
        ordering.append(recruit)
        remaining.remove(recruit)
    return CentralizedResult(assignment, tuple(ordering), tuple(open_ids), trials)


def centralized_from_reports(reports: Sequence[RobotStatus], open_subtasks: Sequence[Subtask], t_s: float,
                             team: Sequence[RobotId], params: RutaParams = RutaParams(), *,
                             busy: Collection[RobotId] = (), max_trials: int = 10) -> CentralizedResult:
    """Algorithm 1 as the master runs it: utilities from the robots' reported status (faulty
    reports mark the robot faulty), the team first, every other reporting robot as the pool."""
    in_team = set(team)
    return assign_centralized([s.id for s in open_subtasks], utility_table(reports, open_subtasks, t_s, params),
                              team, [r.id for r in reports if r.id not in in_team], busy=busy,
                              faulty={r.id for r in reports if r.faulty}, max_trials=max_trials)


# --------------------------------------------------------------------------------------------
# Algorithm 2 (decentralized) decision pieces
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Bid:
    """A reply to a bid request: ``robot`` offers ``utility`` for ``subtask``, heard at ``received_s``."""

    robot: RobotId
    subtask: str
    utility: float
    received_s: float


def own_bid(robot: RobotStatus, subtask: Subtask, t_s: float, params: RutaParams = RutaParams(),
            *, busy: bool = False) -> float | None:
    """Algorithm 2 step 1 and 5: the utility ``robot`` replies with to a request for ``subtask``,
    computed on the robot itself, or None when it does not reply — it holds a subtask already
    (``busy``: one subtask per robot) or its utility is 0 (not capable, or not yet announced)."""
    if busy:
        return None
    u = robot_utility(robot, subtask, t_s, params)
    return u if u > 0 else None


def must_request_bids(robot: RobotStatus, held: Subtask) -> bool:
    """Algorithm 2 step 5: "if a sensor fails on one robot r_i by which it is prevented from
    completing task v_j, it sends a request (bid) to the other robots": the robot holding ``held``
    is no longer :func:`capable` of it (a module failed, faulty, battery empty)."""
    return not capable(robot, held)


def fittest(bids: Iterable[Bid]) -> Bid | None:
    """The fittest reply: the highest utility; equal utilities go to the lower robot id, so the
    winner does not depend on the order frames arrived in. None without a positive bid."""
    best = None
    for b in bids:
        if b.utility <= 0:
            continue
        if best is None or b.utility > best.utility or (b.utility == best.utility and b.robot < best.robot):
            best = b
    return best


def deploy_first(utilities: Mapping[RobotId, float], n: int = 2) -> tuple[RobotId, ...]:
    """Algorithm 2 step 2: "The two robots with the highest utility values will begin their
    pre-programmed plans" — the ``n`` highest positive utilities, highest first (ties: lower id)."""
    ranked = sorted((r for r, u in utilities.items() if u > 0), key=lambda r: (-utilities[r], r))
    return tuple(ranked[:n])


@dataclass(frozen=True)
class AuctionDecision:
    """``kind``: ``assign`` (``winner`` takes the subtask), ``reannounce`` (no reply within t_out:
    ask again at ``next_announce_s``) or ``unfilled`` (no reply after the last attempt)."""

    kind: str
    winner: Bid | None = None
    next_announce_s: float | None = None


def close_auction(bids: Iterable[Bid], subtask: str, announced_s: float, t_out_s: float,
                  attempt: int = 1, max_attempts: int = 3) -> AuctionDecision:
    """The announcer's decision at ``announced_s + t_out_s`` (Algorithm 2 steps 5-7).

    "Robot waits for reply (t_out) from the fittest one (based on the highest utility value). Task
    v_j is taken over by the winning robot." Bids for ``subtask`` heard in [announced_s,
    announced_s + t_out_s] count (a late or stale bid does not); the :func:`fittest` wins. The paper
    does not say what happens without a reply; we choose: announce again right away, up to
    ``max_attempts`` announcements in all, then the subtask stays ``unfilled`` until the team
    changes (an arrival or a new status) and someone announces it again.
    """
    if not (math.isfinite(t_out_s) and t_out_s > 0):
        raise ValueError(f"t_out_s must be a finite number > 0, got {t_out_s!r}")
    if not 1 <= attempt <= max_attempts:
        raise ValueError(f"attempt must be in 1..max_attempts ({max_attempts}), got {attempt}")
    end = announced_s + t_out_s
    win = fittest(b for b in bids if b.subtask == subtask and announced_s <= b.received_s <= end)
    if win is not None:
        return AuctionDecision("assign", win)
    if attempt < max_attempts:
        return AuctionDecision("reannounce", None, end)
    return AuctionDecision("unfilled")


# --------------------------------------------------------------------------------------------
# Seed 003's own figures
# --------------------------------------------------------------------------------------------

# §5.2, the fault example (decentralized): the task announcement at 100 s, utilities computed at
# 101 s, the task assigned at 105 s.
FAULT_EXAMPLE_S = {"announced": 100.0, "utilities": 101.0, "assigned": 105.0}
# Table 1 (centralized): team size -> (body weight g, average pulling distance m, average time s).
TABLE_1 = {1: (300, 1.6, 196), 2: (800, 1.3, 240), 3: (1200, 2.5, 201), 4: (1200, 2.0, 210), 5: (1200, 1.6, 400)}
# Table 2: team -> (centralized utility, time s, decentralized utility, time s).
TABLE_2 = {("R1", "R3", "R4", "R5"): (8.82, 210, 6.62, 299), ("R1", "R3", "R4"): (9.63, 201, 6.91, 277),
           ("R2", "R3", "R4", "R1", "R5"): (8.43, 400, 6.66, 405), ("R2", "R5"): (8.16, 240, 6.34, 310)}
# Fig. 6: the five robots' hardware (the paper gives no further specification of R3 and R5).
FIG6_HARDWARE = {"R1": "4-DoF arm", "R2": "1-DoF arm", "R3": "onboard Blackfin camera",
                 "R4": "two kinds of sensors at the front", "R5": "3-DoF arm and a camera"}

# §5.2.1, the inputs as printed (None: the paper does not print it). R4's φ are printed only as
# results (nav utility 1.21 at d = 1, pri = 1, so φ_nav = 1.21; grip φ_given 5.04), without inputs.
EXAMPLE_PARAMS = RutaParams(t_m_s=200.0, u1_per_s=0.01, u2=1.0)
EXAMPLE_NAV = {"R1": {"p_rem_mah": 2200.0, "rate_servo_ma": 130.0, "slip_pct": 3.0},
               "R2": {"p_rem_mah": 2200.0, "rate_servo_ma": 320.0, "slip_pct": 1.0},
               "R4": {"phi_printed": 1.21}}
EXAMPLE_R1_BRACKET_PRINTED = 5.58  # "0.7 [5.58] = 3.90": the paper's value of (2200/130) × (1/3)
EXAMPLE_GRIP = {"t_s": 110.0, "tj_s": 20.0,
                "R2": {"manip": {"ts_s": 9.0, "p_rem_mah": 2000.0, "rate_act_ma": 60.0},
                       "sens": {"ts_s": 11.0, "p_rem_mah": 2150.0, "rate_sens_ma": 65.0}, "d_m": 3.0},
                "R4": {"phi_printed": 5.04, "d_m": 4.3}}
# The paper's printed figures (metric -> value), for the rows of reproduce.
EXAMPLE_PRINTED = {"R1 nav utility": 3.90, "R2 nav utility": 4.81, "R4 nav utility": 1.21,
                   "grip pri": 0.45, "R2 φ_manip": 1.05, "R2 φ_sens": 1.64, "R2 φ_given": 2.69,
                   "R2 grip utility": 0.69, "R4 grip utility": 1.09}


def worked_example() -> dict:
    """Seed 003 §5.2.1 through the equations and the Algorithm 1 and 2 decisions.

    Returns the figures: the navigation utilities (d = 1, pri = 1 as printed; R1's both exactly on
    its inputs and from the printed bracket 5.58), the two robots deployed first (Algorithm 2 step
    2), the grip priority at t = 110 s for t_j = 20 s, R2's φ's and both grip utilities, and who
    grips first by Algorithm 2 (the fittest bid) and by Algorithm 1 (the master's assignment)."""
    p, g = EXAMPLE_PARAMS, EXAMPLE_GRIP
    nav = {r: utility(1.0, phi_nav(**EXAMPLE_NAV[r]), 1.0, p.u2) for r in ("R1", "R2")}  # eq. 3, eq. 7
    nav["R4"] = utility(1.0, EXAMPLE_NAV["R4"]["phi_printed"], 1.0, p.u2)
    r1_printed = utility(1.0, 0.7 * EXAMPLE_R1_BRACKET_PRINTED, 1.0, p.u2)  # eq. 7 on the printed 0.7 × 5.58
    pri = priority(g["t_s"], g["tj_s"], p.u1_per_s)  # eq. 6
    m, s = g["R2"]["manip"], g["R2"]["sens"]
    r2_manip = phi_manip(m["ts_s"], p.t_m_s, m["p_rem_mah"], m["rate_act_ma"])  # eq. 2
    r2_sens = phi_sens(s["ts_s"], p.t_m_s, s["p_rem_mah"], s["rate_sens_ma"])  # eq. 4
    grip = {"R2": utility(g["R2"]["d_m"], r2_manip + r2_sens, pri, p.u2),  # eq. 5, eq. 7
            "R4": utility(g["R4"]["d_m"], g["R4"]["phi_printed"], pri, p.u2)}
    bid = fittest(Bid(r, "grip", u, g["t_s"]) for r, u in grip.items())
    central = assign_centralized(["grip"], {(r, "grip"): u for r, u in grip.items()}, team=["R2", "R4"])
    r1 = EXAMPLE_NAV["R1"]
    return {"nav_utility": nav, "R1_nav_utility_from_printed_bracket": r1_printed,
            "R1_nav_bracket_exact": r1["p_rem_mah"] / r1["rate_servo_ma"] / r1["slip_pct"],
            "R1_nav_bracket_printed": EXAMPLE_R1_BRACKET_PRINTED,
            "deployed_first": list(deploy_first(nav, 2)), "grip_pri": pri,
            "R2_phi_manip": r2_manip, "R2_phi_sens": r2_sens, "R2_phi_given": r2_manip + r2_sens,
            "grip_utility": grip, "grips_first_decentralized": bid.robot if bid else None,
            "grips_first_centralized": central.assignment.get("grip")}
