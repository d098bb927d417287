"""A robot's own sensor diagnosis: which of its sensors it has found broken, from what it can see.

A fault is hardware truth (:mod:`petswarm_env.sim.faults`); the robot's software never reads it. It
finds a broken part only by what its sensors deliver, compared with what its other sensors and its
radio tell it (seed 003 §4.1.2: "information about robot status (such as any error readings from
sensors) is shared between robots"; Algorithm 2 step 5 needs the robot to know a sensor failed).
All three checks run on the robot's MCU, on its own readings:

* **IR module** (seed 000 §3.3): the token ring announces every IR slot by radio (the holder's
  transmission-start sign, :mod:`.token_ring`), with its RSSI range. A slot whose announcer the
  RSSI puts within :data:`IR_EXPECT_RANGE_M` should give an IR fix of it; :data:`IR_MISSES` such
  slots in a row without a fix, spanning at least :data:`IR_MISS_SPAN_S`, while their radio frames
  keep arriving, is a broken IR module (receiver; the same module transmits). A fix after that clears it (a transient fault's end).
  From two holders only (ours and one neighbour's) the streak must span :data:`IR_PAIR_SPAN_S`; a holder that left the
  member table since ends it.
  The master also counts slots announced within :data:`IR_FAR_EXPECT_M`, over the longer :data:`IR_FAR_SPAN_S` (its swarm
  falls back from it when its IR breaks, out of the near range).
* **ultrasonic ring**, two checks. (1) The driver's self-test (chosen: the transducer diagnosis of
  ultrasonic front-ends, which listen to each transducer ringing down after its own burst, the ring-down
  that sets every ultrasonic sensor's minimum range): :data:`US_SILENT_BURSTS` readings in a row whose
  bursts did not ring down are a dead ring (a driver that sends no burst hears no echo either). It
  costs no extra reading: the ring reports it with every reading (``Sensors.read_rings``); a
  reading that rings down again clears it. (2) For a ring that rings but hears nothing: a neighbour
  that the robot's own IR fix places on a ring sensor's ray and well within its range must echo:
  :data:`US_MISSES` such expected echoes that read nothing, with no echo of the ring in between, is
  a dead ring; any echo afterwards clears it. An echo is a reading 3 σ of the ring's noise short of
  its maximum range (a sensor that hears nothing reads its maximum; the simulated one adds noise).
  A ring whose rays all miss its neighbours (they stand between the rays: in a wedge, 15° off the
  nearest rays of an 8-sensor ring) reads as a dead one does, so this check alone waits until one
  comes onto a ray (chosen: no check by silence alone — healthy rings of a 1+5 wedge stayed silent
  with a neighbour 1 m away for over 3 s, the rays passing on either side of it).
* **AHRS**: a working AHRS's yaw carries white noise, so two readings at different times never
  agree to the last bit; :data:`AHRS_FROZEN` readings in a row that repeat the same value are a
  frozen output (a stuck sensor bus). An AHRS configured without noise or drift cannot be judged
  so: for it, the rotation the robot commanded its wheels over :data:`AHRS_WINDOW_S` against the
  yaw change the AHRS reported over it (chosen: only then — a robot held by a contact while it
  turns disagrees too; on the mixed swarm this check alone found two healthy AHRSs broken in 6
  episodes). A changing reading clears it.

A detection is reported up (:attr:`Diagnosis.on_detect`, the node's seam: its status lowers and
seed 003 Algorithm 2 step 5 starts) and the robot's own record of its working sensors follows it:
the ultrasonic ring's and the IR ring's registered sensors read not ``working``
(``Robot.sensors_off``, which the observation's presence flags and the status report read).
``detected`` keeps when each part was found broken (the experimenter's figures read it).

A module of the compiled core (``petswarm_env/_core.py``): Cython's pure-Python mode, so this file
runs as it is under the interpreter and is compiled to C at install. The checks run for every
ultrasonic and AHRS reading of every robot: the diagnosis is a typed class, its counters and times
typed attributes, its checks C functions (not replaceable from Python).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable

import cython
import numpy as np

if cython.compiled:  # the angle wrap of one float as a C call (sim/geometry.pxd); a body's command by C reads (sim/body.pxd)
    from cython.cimports.petswarm_env.sim.body import DrivenBody
    from cython.cimports.petswarm_env.sim.geometry import wrap_float
else:
    from petswarm_env.sim.body import DrivenBody
    from petswarm_env.sim.geometry import wrap_float


COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)

# chosen: an announced IR slot within this RSSI range should give a fix (the IR detection fades out at
# 2.4-2.8 m, config ir.max_range_m; the RSSI range is off by ~10 % at 1 dB shadowing)
IR_EXPECT_RANGE_M = 1.6
IR_MISSES = 5  # chosen: announced slots in a row without a fix -> IR module broken (a live module misses a few by occlusion)
# chosen: ... and they span at least this long since the first of them: a body passing between (a new master
# searching among its swarm and its user, leading seeds 7 and 19) hides the holders for about a second and a fix
# ends the streak; a broken module misses every slot on (before: 5 misses in 0.8-1.1 s found a working module broken)
IR_MISS_SPAN_S = 1.5
IR_SOURCES = 3  # chosen: ... of this many holders (our own slot counts as one; fewer if fewer are in range, at least 2): occlusion hides one or two
# chosen: ... over at least this long when they are two, ours and one neighbour's: a pair that sees only each other cannot
# tell which module broke, and the broken one, with its other neighbours' slots too, usually finds it first; its bid
# request then starts our streak over (neighbour_ir_broken). With IR_MISS_SPAN_S a column's master or a row's outer
# slave found its working module broken in 11 and 12 of 100 runs (seeds 0-99; 3 with 2.0 s, 1 now with the holder
# rule of _ir_missed); it costs a column's broken master 1 s (median detection 2.4 -> 3.4 s)
IR_PAIR_SPAN_S = 2.5
# chosen: a module that the swarm has drifted away from hears its holders announced beyond IR_EXPECT_RANGE_M only: its
# slaves lost its fixes with the fault and fell back, 1.7-3 m off within seconds (the master's IR fault at loss 0.3, seeds
# 5072, 8070: never found). Announced slots within this RSSI range (the IR detection fades out at 2.4-2.8 m, the RSSI
# range ~10 % off) without a fix count too, for the master (member 0) only, with a longer streak: IR_MISSES of them from
# IR_SOURCES holders (our own slot counts), none of any holder seen, over at least IR_FAR_SPAN_S. Not for a slave: one
# building in its user's IR shadow, the user 0.5-1.2 m from it and its master and the master's near members beyond the
# user, saw no holder for over 4 s (1 + 8 at loss 0.1, seed 6036; with 2 holders, 1 + 4 at loss 0.3, seed 5024); a
# following master stands behind its user, its swarm on its other side
IR_FAR_EXPECT_M = 2.2
IR_FAR_SPAN_S = 4.0
# chosen: an IR-placed neighbour this close to a ring sensor's ray (perpendicular, m) must echo: a robot is 0.2 m
# in radius and the IR bearing is good to ~6° (seed 000 Table 4), 0.1 m at 1 m
US_RAY_MARGIN_M = 0.1
US_MARGIN_M = 0.8  # chosen: ... and its rim this much inside the sensor's maximum range (1.2 m)
US_FIX_AGE_S = 0.6  # chosen: an IR fix this fresh places the neighbour well enough for the check
US_MISSES = 8  # chosen: expected echoes that read nothing, with no echo in between -> ring dead
US_SILENT_BURSTS = 3  # chosen: readings in a row without the transducers' ring-down -> ring dead (one is a glitch)
AHRS_FROZEN = 6  # chosen: readings in a row, at different times, with the very same value -> frozen output
AHRS_WINDOW_S = 2.0  # chosen: the commanded rotation is compared with the AHRS over this long ...
AHRS_TURN_RAD = 0.6  # ... and one over this much with an AHRS change under ...
AHRS_STILL_RAD = 0.05  # ... this is a disagreement

KINDS = ("ir", "ultrasonic", "ahrs")


@cython.cclass
class Diagnosis:
    """One robot's self-diagnosis. The node feeds it: :meth:`on_ring` after every ultrasonic reading
    (its periodic tick), :meth:`on_ahrs` with every AHRS reading. ``know`` and ``ring`` are the
    node's knowledge and token ring (the IR fixes it stored, the slots it heard announced)."""

    # its typed attributes are declared in ``diagnosis.pxd``

    def __init__(self, node_id, cfg, robot, know_of: Callable[[], object], ring) -> None:
        self.node_id = node_id
        self.cfg = cfg
        self.robot = robot
        self._health = robot.health  # its parts' health (the same record for the robot's life: sim/faults.py)
        self._body = robot if isinstance(robot, DrivenBody) else None  # its command by C reads (else robot.command)
        self._know_of = know_of  # the node replaces its Knowledge when it leaves a swarm: read it each time
        self.ring = ring
        self.failed = set()  # the parts found broken (and not found working again)
        self.detected = []  # (time, part) of every detection
        self.on_detect = None  # the node's seam (status, bid request)
        us = cfg.robot.ultrasonic
        self._us_max = us.max_range_m
        self._us_angles = [2.0 * math.pi * k / us.count for k in range(us.count)]
        self._us_cos = [math.cos(a) for a in self._us_angles]  # each ray's direction (slot k)
        self._us_sin = [math.sin(a) for a in self._us_angles]
        self._radius = cfg.robot.radius_m
        self._us_reach = self._us_max - US_MARGIN_M  # a neighbour's near rim closer than this must echo
        self._us_miss = 0
        self._us_silent = 0  # readings in a row whose bursts did not ring down
        self._us_by_self_test = False  # the ring found dead by its self-test (its pass clears it)
        # chosen: 3 σ of the ring's noise below its maximum range is an echo (a sensor that hears nothing
        # reads its maximum range; the simulated one adds its noise to it)
        self._us_echo_margin = max(3.0 * us.noise_m, 1e-9)
        p = cfg.protocol
        self._slot_over_s = p.ring_response_timeout_s * 2 + p.ir_tx_s + 0.02  # an IR slot is over by then
        self._ir_seen = {}  # announcer -> start of its latest slot evaluated
        self._starts_of, self._starts = None, None  # the ring whose slot starts _starts is (ring.slot_starts)
        self._seen_keys, self._seen_marks = [], []  # by place in that dict: its key and the start found evaluated there
        self._ir_miss = 0
        self._ir_missed_from = set()  # the slots' holders of the misses since the last fix
        self._ir_first_miss_s = -math.inf  # the first of those misses
        self._ir_far_miss = 0  # misses since the last fix of slots announced within IR_FAR_EXPECT_M (the near ones too)
        self._ir_far_from = set()  # ... their holders
        self._ir_far_first_s = -math.inf  # ... the first of them
        self._own_seen = -math.inf  # start of our own latest slot evaluated
        self._ir_off, self._us_off, self._ahrs_off = False, False, False
        self._ahrs_noisy = cfg.robot.ahrs_noise_deg > 0 or cfg.robot.ahrs_drift_dps > 0
        self._yaw_read, self._yaw_last_s, self._yaw_last = False, 0.0, 0.0  # the last reading
        self._yaw_same = 0
        self._yaw_hist = deque()
        self._turned = 0.0  # the commanded rotation integrated (rad)
        self._ticked, self._tick_s = False, 0.0

    # -- the checks ---------------------------------------------------------------------------------
    @cython.ccall
    def on_ring(self, ranges, present, now_s: cython.double, rang: cython.bint = True):
        """The ultrasonic ring's reading (virtual-ring order, ``present``: which slots the body has),
        every control period, and its self-test (``rang``: the transducers rang down after their
        bursts): the ring and IR checks, and the commanded rotation's integral."""
        if not self._health.powered:
            if self.failed or self._ticked:
                self._reboot()
            return
        dt: cython.double = now_s - self._tick_s if self._ticked else 0.0
        body: DrivenBody = self._body
        self._turned += (body._cw if body is not None else self.robot.command[2]) * dt
        self._ticked, self._tick_s = True, now_s
        self._check_ir(now_s)
        self._check_ring(ranges, present, now_s, rang)

    @cython.ccall
    def on_ahrs(self, now_s: cython.double, yaw: cython.double):
        """Every AHRS reading the robot takes (its MCU's, the observation's); none while it is off (before,
        a dead robot's unchanging readings were found a frozen AHRS)."""
        if not self._health.powered:
            return
        if self._yaw_read and now_s > self._yaw_last_s:
            if yaw == self._yaw_last:
                self._yaw_same += 1
            else:
                self._yaw_same = 0
                if self._ahrs_off:
                    self._clear("ahrs")
            if not self._ahrs_noisy:
                self._check_turn(now_s, yaw)
            elif not self._ahrs_off and self._yaw_same >= AHRS_FROZEN - 1:
                self._detect("ahrs", now_s)
        if not self._yaw_read or now_s > self._yaw_last_s:
            self._yaw_read, self._yaw_last_s, self._yaw_last = True, now_s, yaw

    @cython.cfunc
    def _check_turn(self, now_s: cython.double, yaw: cython.double) -> cython.void:
        """An AHRS without noise or drift: the rotation commanded over the window against the AHRS's (the
        window's history is kept for this check only)."""
        hist = self._yaw_hist
        hist.append((now_s, yaw, self._turned))
        while hist and now_s - hist[0][0] > AHRS_WINDOW_S:
            hist.popleft()
        if not self._ahrs_off and hist and now_s - hist[0][0] >= 0.5 * AHRS_WINDOW_S:
            turned = self._turned - hist[0][2]
            seen = abs(wrap_float(yaw - hist[0][1]))
            if abs(turned) > AHRS_TURN_RAD and seen < AHRS_STILL_RAD:
                self._detect("ahrs", now_s)

    @cython.cfunc
    def _check_ir(self, now_s: cython.double) -> cython.void:
        ring = self.ring
        over: cython.double = self._slot_over_s
        own = ring.own_slot
        if own is not None:
            own_s: cython.double = own[0]
            if own_s > self._own_seen and now_s - own_s >= over:
                self._own_seen = own_s
                if ring.report_s >= own_s:
                    self._ir_hit()
                else:
                    ranges = ring.slot_range_m
                    closest: cython.double = min([ranges.get(n, math.inf) for n in own[1]], default=math.inf)
                    if closest <= IR_FAR_EXPECT_M:  # neighbours heard our start sign, none reported seeing our IR
                        self._ir_missed(now_s, self.node_id, closest <= IR_EXPECT_RANGE_M)
        seen: dict = self._ir_seen
        me = self.node_id
        know = None
        t0: cython.double
        if self._starts_of is not ring:  # the ring's dict of slot starts (its one dict for its life), read once per ring
            self._starts_of, self._starts = ring, ring.slot_starts
        starts: dict = self._starts
        keys: list = self._seen_keys
        marks: list = self._seen_marks
        n_marks: cython.Py_ssize_t = len(marks)
        p: cython.Py_ssize_t = -1
        for src, start in starts.items():
            p += 1
            if p < n_marks and marks[p] is start and keys[p] is src:
                continue  # this very start was found evaluated at this place of the dict: evaluated (the most frequent)
            t0 = start
            if now_s - t0 < over:
                continue  # not over yet
            last = seen.get(src)
            if (last is not None and t0 <= cython.cast(cython.double, last)) or src == me:
                if src != me:
                    self._mark_seen(p, src, start)
                continue  # evaluated already, or our own
            seen[src] = start
            self._mark_seen(p, src, start)
            if know is None:
                know = self._know_of()
            fixes: dict = know.ir
            ranges_m: dict = ring.slot_range_m
            fix = fixes.get(src)
            if fix is not None and fix.time_s >= t0:
                self._ir_hit()
                continue
            announced: cython.double = ranges_m.get(src, math.inf)
            if announced <= IR_FAR_EXPECT_M and src in know.members.values():
                self._ir_missed(now_s, src, announced <= IR_EXPECT_RANGE_M)

    @cython.cfunc
    def _mark_seen(self, p: cython.Py_ssize_t, src: object, start: object) -> cython.void:
        """``start`` (the ring's very float object), the slot start of ``src`` at place ``p`` of the ring's dict, is
        evaluated (``_ir_seen`` holds it or a later one): the next scans pass it by two identity tests instead of a
        dictionary lookup (a later start of ``src`` is another object; a dict reordered, a key that is not ``src``)."""
        keys: list = self._seen_keys
        while len(keys) <= p:
            keys.append(None)
            self._seen_marks.append(None)
        keys[p] = src
        self._seen_marks[p] = start

    def neighbour_ir_broken(self) -> None:
        """A neighbour reported its own IR module broken (its bid request lists the sensors that work,
        seed 003 Algorithm 2 step 5): the misses counted so far are explained by its module, not ours, and
        the streak starts over (chosen: a column's master has one neighbour within
        :data:`IR_EXPECT_RANGE_M`, its first member; when that member's IR broke, the master's own slot
        and the member's slot gave no fix or report — two holders, enough — and it found its own working
        module broken and handed its user over: column, IR fault on a slave, seeds 8, 14, 16 of 0-19)."""
        self._ir_streak_over()

    @cython.cfunc
    def _ir_streak_over(self) -> cython.void:
        self._ir_miss = self._ir_far_miss = 0
        self._ir_missed_from.clear()
        self._ir_far_from.clear()

    @cython.cfunc
    def _ir_hit(self) -> cython.void:
        self._ir_streak_over()
        if self._ir_off:
            self._clear("ir")

    @cython.cfunc
    def _ir_missed(self, now_s: cython.double, src: object, near: cython.bint) -> cython.void:
        """A slot that should have given an IR fix (``src``: its announcer) or a heading report
        (``src`` = us: our own slot) gave none; ``near``: announced within :data:`IR_EXPECT_RANGE_M`
        (else within :data:`IR_FAR_EXPECT_M`)."""
        members = self._know_of().members.values()
        for held in self._ir_far_from:  # (the near misses' holders are among these)
            if held != self.node_id and held not in members:
                # a holder that left the swarm since: its slots' misses may be its module's doing (a column's tail counted its
                # broken front neighbour's slots, then its new front neighbour's while that one drove up: column, seed 50)
                self._ir_streak_over()
                break
        if self._ir_far_miss == 0:
            self._ir_far_first_s = now_s
        self._ir_far_miss += 1
        self._ir_far_from.add(src)
        if self._ir_off:
            return
        if near:
            if self._ir_miss == 0:
                self._ir_first_miss_s = now_s
            self._ir_miss += 1
            self._ir_missed_from.add(src)
            if self._ir_miss >= IR_MISSES and now_s - self._ir_first_miss_s >= IR_MISS_SPAN_S:
                close = {n for n, r in self.ring.slot_range_m.items() if r <= IR_EXPECT_RANGE_M and n in members}
                n_from: cython.Py_ssize_t = len(self._ir_missed_from)
                if n_from >= max(2, min(IR_SOURCES, len(close | {self.node_id}))) \
                        and (n_from > 2 or now_s - self._ir_first_miss_s >= IR_PAIR_SPAN_S):
                    self._detect("ir", now_s)
                    return
        if self._ir_far_miss >= IR_MISSES and now_s - self._ir_far_first_s >= IR_FAR_SPAN_S \
                and len(self._ir_far_from) >= IR_SOURCES and self._know_of().member == 0:
            self._detect("ir", now_s)

    @cython.cfunc
    def _check_ring(self, ranges, present, now_s: cython.double, rang: cython.bint) -> cython.void:
        rs: list = ranges if type(ranges) is list else (ranges.tolist() if isinstance(ranges, np.ndarray) else list(ranges))
        ps: list = present if type(present) is list else list(present)
        n_present: cython.Py_ssize_t = len(ps)
        k: cython.Py_ssize_t
        p: cython.double
        body = False
        for k in range(n_present):
            p = ps[k]
            if p != 0.0:
                body = True
                break
        if not body:
            return  # a body without an ultrasonic sensor: nothing to judge
        top: cython.double = self._us_max - self._us_echo_margin  # a reading this short is an echo; a healthy "nothing" reads max ± noise
        echo = False
        for k in range(min(len(rs), n_present)):
            p = ps[k]
            if p != 0.0 and cython.cast(cython.double, rs[k]) < top:
                echo = True
                break
        self._us_silent = 0 if rang else self._us_silent + 1
        if rang and (echo or self._us_by_self_test):  # an echo, or the self-test that found it passes again
            self._us_miss = 0
            if self._us_off:
                self._clear("ultrasonic")
            if echo:
                return
        if self._us_off:
            return
        if self._us_silent >= US_SILENT_BURSTS:
            self._us_by_self_test = True
            self._detect("ultrasonic", now_s)
            return
        if not echo and self._on_ray(ps, now_s):
            self._us_miss += 1
            if self._us_miss >= US_MISSES:
                self._detect("ultrasonic", now_s)

    @cython.cfunc
    def _on_ray(self, present: list, now_s: cython.double) -> cython.bint:
        """A neighbour that the robot's own fresh IR fix places on a ring sensor's ray, within its reach."""
        yaw: cython.double = self.robot.ahrs._last_yaw  # the last AHRS reading the robot took (no new draw)
        r: cython.double = self._radius
        wide: cython.double = r - US_RAY_MARGIN_M
        reach: cython.double = self._us_reach
        n: cython.Py_ssize_t = min(len(present), len(self._us_cos))
        k: cython.Py_ssize_t
        x: cython.double
        y: cython.double
        c: cython.double
        s: cython.double
        along: cython.double
        p: cython.double
        for fix in self._know_of().ir.values():
            if now_s - cython.cast(cython.double, fix.time_s) > US_FIX_AGE_S:
                continue
            x, y = fix.position_now(yaw)  # the neighbour in our body frame now
            for k in range(n):
                p = present[k]
                if p == 0.0:
                    continue
                c, s = self._us_cos[k], self._us_sin[k]
                along = x * c + y * s
                # the neighbour (a body of our radius) across the ray, its near rim within reach
                if abs(-x * s + y * c) < wide and 0 < along - 2 * r < reach:
                    return True
        return False

    @cython.cfunc
    def _reboot(self) -> cython.void:
        """The robot is off: when it is switched on again it knows nothing of its sensors (sim/faults.py)."""
        for part in sorted(self.failed):
            self._mark(part, True)
        self.failed.clear()
        self._ir_off, self._us_off, self._ahrs_off = False, False, False
        self._us_miss, self._us_silent, self._yaw_same = 0, 0, 0
        self._us_by_self_test = False
        self._ir_streak_over()
        self._yaw_read, self._ticked = False, False
        self._yaw_hist.clear()

    # -- results ------------------------------------------------------------------------------------
    @cython.cfunc
    def _detect(self, part: str, now_s: cython.double) -> cython.void:
        self.failed.add(part)
        self._set_off(part, True)
        self.detected.append((now_s, part))
        self._mark(part, False)
        if self.on_detect is not None:
            self.on_detect(part)

    @cython.cfunc
    def _clear(self, part: str) -> cython.void:
        self.failed.discard(part)
        self._set_off(part, False)
        if part == "ultrasonic":
            self._us_miss = 0
            self._us_by_self_test = False
        if part == "ir":
            self._ir_streak_over()
        self._yaw_same = 0 if part == "ahrs" else self._yaw_same
        self._mark(part, True)

    @cython.cfunc
    def _set_off(self, part: str, off: cython.bint) -> cython.void:
        """The flags that mirror ``failed`` (read by every check)."""
        if part == "ir":
            self._ir_off = off
        elif part == "ultrasonic":
            self._us_off = off
        elif part == "ahrs":
            self._ahrs_off = off

    @cython.cfunc
    def _mark(self, part: str, working: cython.bint) -> cython.void:
        """The robot's record of its working sensors (``Robot.sensors_off``: the status report and
        the observation's presence flags read it) follows a detection of the ring or the IR module."""
        kind = {"ultrasonic": "DISTANCE", "ir": "IR"}.get(part)
        if kind is None:
            return
        spec = getattr(self.robot, "spec", None)
        if spec is not None:
            ids = {s.id for s in spec.sensors if s.type == kind}
        elif kind == "DISTANCE":
            ids = set(range(1, self.cfg.robot.ultrasonic.count + 1))
        else:
            ids = set()
        off = set(self.robot.sensors_off)
        self.robot.sensors_off = (off - ids) if working else (off | ids)
