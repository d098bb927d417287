"""The user in the loop (seed 002): one user's wearables and the robot connected to them.

A :class:`UserSession` runs, on the shared clock, everything between one walking user and the
master of their swarm:

* **pairing** (seed 002 §3.2, Fig. 5): the user's robot, while waiting for its user, bursts LF with
  its wake-up pattern every ``lf.wake_period_s``; a belt within ``lf.wake_range_m`` whose stored
  pattern matches wakes up and connects over BLE (``ble.connect_s``); the robot enters
  *command-waiting*. A wrong pattern is ignored;
* **commands** (seed 002 §2, Table 1): what the user tells the robot through the watch (driving
  mode, organize / disperse the swarm, return from an exception, remote-control gestures),
  recognised by the watch and delivered over BLE;
* **localisation** (seed 002 §3.3): in leading / following the robot bursts LF every
  ``lf.burst_period_s``; the belt measures both antennas' RSSI and reports over BLE; the robot runs
  Eqs. 1–3 and tracks the user between fixes. A leading master is farthest from the user (seed 000
  Fig. 10) yet must stay inside its own LF range (2 m, seed 002 §3.3): it keeps the standard
  distance beyond the whole formation, capped ``LEADING_LF_MARGIN_M`` inside the LF range, so a deep
  formation takes the user between its rear members, no slot nearer than ``LEADING_CLEARANCE_M``
  (:func:`~.formation.formation_for_mode`) (chosen; the papers do not say how a leading master beyond
  2 m would keep its user);
* **user motion** (seed 002 §3.4): the belt's activity and rotation reports over BLE;
* the **robot states** of seed 002 Fig. 4: waiting-user → command-waiting → following / leading /
  remote; Circle → command-waiting; leading with an obstacle in the travel direction → *exception*
  (remote control by gestures until the user's return command, then the previous mode); no fix
  for ``master.lost_user_s`` → *emergency* (alert to the belt, every robot of the swarm stops;
  chosen: it clears by itself when the user is back inside the reliable range, and a walking user
  stops at the alert and steps back toward their robot, :meth:`UserSession._walk_back`);
* the **master-role controller** (:mod:`petswarm_env.control.master`) that drives the master.

Clocks (seed 000 §3.3: independent clocks): what the robot side does runs on the current master's
own clock (``node.clock``: the LF burst period, the user tracker's times, the lost-user timeout, the
remote driver); what the belt does on the belt's (:attr:`UserSession.belt_clock`: its report period
and its BLE supervision timeout, drawn like a robot's MCU clock). The watch's recognition and the
BLE link's latency are physics and human timing, on the true clock.

The session reads the truth only where a sensor does (the LF physics needs the true user position
relative to the transmitting robot; the belt needs the user's true motion), like every sensor model.

A module of the compiled core (``petswarm_env/_core.py``, Cython's pure-Python mode): the session's state and
what runs every control period, LF burst and belt report are the typed class :class:`SessionCore`
(``user_session.pxd``), which calls the tracker, the controller, the belt and the clocks by C calls;
:class:`UserSession` adds to it what runs at events (commands, a master change) and the interpreted mixins
of the pairing (:mod:`.pairing`) and of a new master's search for its user (:mod:`.successor_side`).
"""

from __future__ import annotations

import math

import cython
import numpy as np
from cython.cimports.libc.math import cos as _c_cos
from cython.cimports.libc.math import sin as _c_sin

from petswarm_env.config import Config
from petswarm_env.middleware.master_role import UserView, can_be_master, master_distance_m
from petswarm_env.middleware.modes import measured_geometry
from petswarm_env.middleware.pairing import PairingSide
from petswarm_env.middleware.station import mcu_clock
from petswarm_env.middleware.succession import in_place_to_resume, own_user_estimate, walk_direction
from petswarm_env.middleware.successor_side import SuccessorSide
from petswarm_env.middleware.swarm import Swarm
from petswarm_env.sim.geometry import wrap_angle
from petswarm_env.sim.user import User
from petswarm_env.sim.world import World
from petswarm_env.wearables import lf
from petswarm_env.wearables.watch import Command, RemoteDriver, Watch

if cython.compiled:  # C reads and calls: master.pxd, belt.pxd, clock.pxd, body.pxd (the user), station.pxd, sequence.pxd
    from cython.cimports.petswarm_env.control.master import BeltView, MasterController, UserTracker
    from cython.cimports.petswarm_env.middleware.diagnosis import Diagnosis
    from cython.cimports.petswarm_env.middleware.sequence import SequenceManager
    from cython.cimports.petswarm_env.middleware.station import Station
    from cython.cimports.petswarm_env.sim.body import WalkingBody
    from cython.cimports.petswarm_env.sim.clock import Clock, LocalClock
    from cython.cimports.petswarm_env.wearables.belt import SmartBelt
else:
    from petswarm_env.control.master import BeltView, MasterController, UserTracker
    from petswarm_env.middleware.diagnosis import Diagnosis
    from petswarm_env.middleware.sequence import SequenceManager
    from petswarm_env.middleware.station import Station
    from petswarm_env.sim.body import WalkingBody
    from petswarm_env.sim.clock import Clock, LocalClock
    from petswarm_env.wearables.belt import SmartBelt

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)

DRIVING_STATES = ("following", "leading", "remote")
MOVING_ACTIVITIES = ("walk", "run")  # the belt's activities (seed 002 Table 2) in which the user moves
MODE_SETTLE_S = 5.0  # chosen: after a mode change the re-forming swarm raises no obstacle exception
RETURN_MPS = 0.5  # chosen: a user whose belt alerts that their robot lost them steps back toward it at a slow walk


@cython.cclass
class SessionCore:
    """The user session's state and what runs every control period (:meth:`step`), LF burst and belt report,
    typed (its attributes are declared in ``user_session.pxd``); :class:`UserSession` is the session."""

    def __init__(self, cfg: Config, world: World, swarm: Swarm, user: User, rng: np.random.Generator,
                 user_pattern: int, robot_pattern: int):
        self.cfg = cfg
        self.world = world
        self.clock = world.clock
        self.swarm = swarm
        self.user = user
        rngs = rng.spawn(4)
        self.rng_lf, rng_belt, rng_watch, self.rng_misc = rngs
        self.belt_clock = mcu_clock(world.clock, cfg, rng.spawn(1)[0])  # the belt's MCU keeps its own time (chosen: a robot's crystal)
        self.belt = SmartBelt(cfg.belt, rng_belt, t0_s=world.now)
        self._fed_s, self._fed_heading = world.now, user.heading  # when the belt was last advanced, the user's heading then
        self.watch = Watch(cfg.watch, rng_watch)
        self.remote = RemoteDriver(cfg.watch)
        self.ctrl = MasterController(cfg.master, math.radians(cfg.lf.reliable_half_angle_deg))
        self.tracker = UserTracker(cfg.master.tracker_alpha, cfg.master.tracker_beta)
        self.tracker_node = swarm.master  # the robot the tracker runs on: its times are on that robot's own clock
        self.user_pattern = user_pattern  # stored in the belt's LF receiver register
        self.robot_pattern = robot_pattern  # what the user's robot bursts
        self.state = "waiting_user"
        self.previous_mode = cfg.swarm.mode
        # plain copies of the config's values that every step reads (the config is frozen)
        self._period_s, self._lost_user_s = cfg.control_period_s, cfg.master.lost_user_s
        self._distance_m = cfg.master.distance_m
        self._report_period_s, self._ble_latency_s = cfg.ble.report_period_s, cfg.ble.latency_s
        self._lf_period_s, self._lf_cfg = cfg.lf.burst_period_s, cfg.lf
        self.belt_view = BeltView()
        self.connected_robot: int | None = None  # node id the belt is connected to over BLE
        self.paired_at_s: float | None = None
        self.link_since_s = math.inf  # the current BLE connection carries data from this time
        self.events = {"emergencies": 0, "exceptions": 0, "alerts_to_belt": 0, "masters_lost": 0}
        self.commands_received: list[tuple[float, str]] = []
        self.startup: list[str] = []  # commands the user gives right after pairing (set by the env)
        self._emergency_since = 0.0
        self._gestures: list[str] = []  # gestures the user is about to perform, one stroke at a time
        self._watch_free_s = -math.inf
        self._guess_only = False  # the tracker holds only a new master's own guess of its user, no LF fix yet
        self.alert_pause_s: float | None = None  # the user stopped at a belt's alert (a broken part's handover, an emergency), since
        self._returning = False  # the user steps back toward their robot after an emergency's alert (_walk_back)
        self.paused = False  # the user stopped after losing their master (the belt's alert), until paired with an organized swarm
        self._succeeded = False  # a slave took the lost master's place (_on_succession) since the user stopped
        self._succession_walk: float | None = None  # its walk direction of the user, tracker frame (_on_succession)
        self.link_ack_s = -math.inf  # the belt last heard the connected robot's BLE link layer
        self.released_by: set[int | None] = set()  # robots whose link the belt lost (it does not pair with them again)
        self.link_losses: list[tuple[float, str]] = []  # (time, supervision_timeout | released)
        self.pairings: list[tuple[float, int]] = []  # (time, robot) of every pairing after the first
        self._wake_next_s = -math.inf  # a new master's next wake-up burst
        self._first_burst_done = False  # a new master burst its wake-up pattern at its takeover
        self._stalled_since: float | None = None  # since when a new master has stood while looking for its user
        self._progress: tuple[float, float] = (math.inf, 0.0)  # (its nearest to where it drives, since when)
        self._arrival_burst = True  # a new master bursts as it arrives short of its first estimate
        self._search: tuple | None = None  # a new master's search, odometry frame: (origin, way, places to do, the current one)
        self._search_way: tuple[float, float] | None = None  # the way its user walked (its body frame at its takeover)
        self._search_yaw = 0.0  # its yaw at its takeover (the odometry frame's)
        swarm.on_master_change = self._on_master_change
        swarm.on_succession = self._on_succession
        self.clock.process(self._wakeup_bursts())
        self.clock.start(self._lf_bursts)
        self.clock.start(self._belt_reports)

    # -- localisation (seed 002 §3.3) -------------------------------------------------------------
    def _lf_bursts(self) -> None:
        """The master bursts LF every ``lf.burst_period_s`` of its own clock, from a random phase."""
        period = self.cfg.lf.burst_period_s
        self.swarm.master.clock.later(float(self.rng_misc.uniform(0.0, period)), self._lf_burst)

    def _lf_burst(self) -> None:
        master: Station = self.swarm.master
        mcu: LocalClock = master._mcu  # the master's burst period and the burst's stamp, on its own clock
        state: str = self.state
        if self.connected_robot is not None and (state == "following" or state == "leading" or state == "emergency") \
                and self.clock.now >= self.link_since_s:
            tx = master.node_id
            robot = self.world.robots[tx]
            if not can_be_master(robot):
                mcu.call_later(self._lf_period_s, self._lf_burst, ())
                return  # a body without LF antennas bursts no LF (robot_types)
            ux: cython.double
            uy: cython.double
            rx: cython.double
            ry: cython.double
            (ux, uy), (rx, ry) = self.user.position, robot.position
            dx: cython.double = ux - rx
            dy: cython.double = uy - ry
            heading: cython.double = robot.heading
            c: cython.double = _c_cos(heading)  # the C library's cos and sin, as math's
            s: cython.double = _c_sin(heading)
            fix = lf.locate(self._lf_cfg, c * dx + s * dy, -s * dx + c * dy, self.rng_lf)
            if fix.valid:  # the belt heard both antennas; RSSIs go back over BLE
                t_burst: cython.double = mcu.local_now()  # stamped on the clock of the robot that burst (seed 000 §3.3)
                self.clock.call_later(self._ble_latency_s, self._on_fix, (tx, fix, t_burst))
        mcu.call_later(self._lf_period_s, self._lf_burst, ())  # the master's burst period, on its own clock

    def _on_fix(self, tx: int, fix: lf.LFFix, t_burst: float) -> None:
        master: Station = self.swarm.master
        node: Station = self.tracker_node
        if self.connected_robot != tx or master.node_id != tx or node.node_id != tx:
            return  # the link or the tracker is another robot's now (master change): a fix on tx's clock is tx's
        tracker: UserTracker = self.tracker
        if self._guess_only:  # the first LF fix replaces the new master's guess (a blend: a velocity spike)
            tracker.pos, tracker.vel, self._guess_only = None, [0.0, 0.0], False
        tracker.fix((fix.x_fwd, fix.y_left), t_burst)

    # -- belt reports (seed 002 §3.4) -------------------------------------------------------------
    def _belt_reports(self) -> None:
        """The belt reports the user's motion every ``ble.report_period_s`` of its own clock."""
        self.belt_clock.call_later(self._report_period_s, self._belt_report, ())

    def _belt_report(self) -> None:
        self._ble_supervision()
        if self.connected_robot is not None and self.clock.now >= self.link_since_s:
            r = self.belt.reading()
            view = BeltView(r.activity, r.rotating, r.angular_speed_rps, r.accumulated_angle_rad, self.belt_clock.local_now())
            self.clock.call_later(self._ble_latency_s, setattr, (self, "belt_view", view))
        self.belt_clock.call_later(self._report_period_s, self._belt_report, ())  # its report period, on its own clock

    @cython.cfunc
    def _ble_supervision(self) -> cython.void:
        """Every belt report: the connected robot's link layer acknowledges it while the robot is on
        (the BLE medium: a robot that is off answers nothing; its 802.15.4 radio is another radio);
        the belt drops the link after ``ble.supervision_timeout_s`` without an acknowledgement."""
        idx = self.connected_robot
        if idx is None:
            return
        now: cython.double = self.belt_clock.local_now()  # the belt's supervision timer runs on its own clock
        if self.world.robots[idx].health.powered:
            self.link_ack_s = now
        elif now - self.link_ack_s > self.cfg.ble.supervision_timeout_s:
            self._link_lost("supervision_timeout")

    @cython.cfunc
    def _pick_up_user_commands(self) -> cython.void:
        user: WalkingBody = self.user
        now: cython.double = self.clock.now
        if self.connected_robot is not None and self.startup and self._ready_for(self.startup[0]):
            user.pending_commands.insert(0, self.startup.pop(0))
        while user.pending_commands:
            cmd = user.pending_commands.pop(0)
            if cmd.startswith("gesture:"):
                self._gestures.append(cmd.split(":", 1)[1])
            else:  # a menu selection on the watch (chosen: recognised after the same delay)
                self._deliver(self.handle_command, cmd, self.cfg.watch.recognition_delay_s)
        while self._gestures and now >= self._watch_free_s:
            self.watch.perform(self._gestures.pop(0), now)
            self._watch_free_s = now + self.cfg.watch.gesture_duration_s
        for cmd in self.watch.poll(now):
            self._deliver(self.handle_gesture, cmd, 0.0)

    @cython.cfunc
    def _ready_for(self, command: str) -> cython.bint:
        """The user gives the next start-up command once the robot did the previous one."""
        if command.startswith("mode:"):
            return self.state == "command_waiting"
        if command == "organize":  # leading: the master shifts to its place first (seed 000 §3.5)
            if self.state not in ("following", "leading"):
                return False
            est = self.tracker.user_body(self.tracker_node._mcu.local_now())
            return est is not None and abs(math.hypot(*est[0]) - self._target_m()) < 0.15
        return True

    # -- per control step -------------------------------------------------------------------------
    def target_distance_m(self) -> float:
        """Standard distance (following), or beyond the whole formation (leading master), inside the
        LF range (seed 000 §3.5: the leading master shifts there before the formation is built)."""
        return self._target_m()

    @cython.cfunc
    def _target_m(self) -> cython.double:
        """:meth:`target_distance_m` (a C call in the compiled form)."""
        swarm = self.swarm
        if self.state != "leading" and swarm.mode != "leading":
            return self._distance_m  # following: master_distance_m's master.distance_m
        # (the formation counts only in leading)
        return master_distance_m(self.cfg, swarm.formation if swarm.organized else None, "leading")

    def step(self, odometry, ranges):
        """Before a control period: advance the belt, take the user's commands, check the exception
        and emergency rules, and return ``(policy_cmd, user_cmd, emergency_stop)`` for the master
        (``odometry``: its wheel odometry (vx, vy, ω); ``ranges``: its ultrasonic ring)."""
        now: cython.double = self.clock.now
        user: WalkingBody = self.user
        self._check_release()
        if self.alert_pause_s is not None and self.state != "emergency" \
                and self._in_place_to_resume(odometry, self.alert_pause_s):
            self.alert_pause_s, self.paused = None, False
            user.returning = self._returning = False
            user.walking = True  # the (new) master located the user by its own LF fix, near enough: they walk on
        if self.paused and self.alert_pause_s is None and self.swarm.organized and self.state in ("following", "leading") \
                and (self.state == "following" or not self._succeeded
                     or self._in_place_to_resume(odometry, self.tracker_node._mcu.local(self.paired_at_s))):
            # paired again with an organized swarm: the user walks on; after a leading master's succession once its
            # successor stands ahead of them (succession.in_place_to_resume), and its swarm re-forming about it takes
            if self._succeeded:  # its echoes for members for MODE_SETTLE_S, as after a mode change (leading, seed 1301)
                self.swarm.mode_changed_s = self.clock.now
            self.paused = self._succeeded = False
            user.walking = True
        if self._returning:
            self._walk_back()
        self._feed_belt(now)
        self._pick_up_user_commands()
        swarm = self.swarm
        master: Station = swarm.master
        tracker: UserTracker = self.tracker
        tracker_node: Station = self.tracker_node
        period: cython.double = self._period_s
        # from here on the clock of the robot whose tracker this is: the master's own (the belt and the
        # user above: physics); between a handover's takeover and its end, still the old master's
        now = tracker_node._mcu.local_now()
        diagnosis: Diagnosis = master.diagnosis
        yaw: cython.double
        if "ahrs" in diagnosis.failed:  # its own diagnosis found the AHRS broken: its wheels' ω turns the frame
            tracker.move_without_ahrs(odometry, period)
            yaw = tracker.pose[2]
        else:
            yaw = master.ahrs_yaw()
            tracker.move(odometry, yaw, period)
        est = tracker.user_body(now)
        # emergency: the user is out of the reliable range (no fix) for too long (the link came up
        # at an event of the master's own BLE radio: it knows that moment on its own clock)
        state: str = self.state
        link_s: cython.double = tracker_node._mcu.local(self.link_since_s)
        last_s: cython.double = link_s if link_s > tracker.last_fix_s else tracker.last_fix_s  # max() as Python's builtin
        if (state == "following" or state == "leading") and now - last_s > self._lost_user_s:
            self.state = state = "emergency"
            self._alert_emergency(now)
        elif state == "emergency" and tracker.last_fix_s > self._emergency_since:
            state = self._end_emergency()
        swarm.emergency = state == "emergency"
        # exception: an obstacle in the leading robot's travel direction (behind it: it faces the user) while it
        # travels — its user walks or runs by the belt's report (seed 002 §3.4); a leading robot whose user stands
        # has no travel direction (chosen: during the building of seed 000 Fig. 10 the slaves cross behind the
        # master before its IR has fixed them, and the exception they raised was never returned from by a user
        # who then walked off: 8 of 20 leading straight walks, seeds 0-19, ended 22-38 m from their master)
        view: BeltView = self.belt_view
        if state == "leading" and view.activity in MOVING_ACTIVITIES and ranges is not None \
                and len(ranges) and self._obstacle_behind(ranges):
            self.state = state = "exception"
            self.events["exceptions"] += 1
            self.events["alerts_to_belt"] += 1
            self._remote_stop()
        ctrl: MasterController = self.ctrl
        swarm.user_view = UserView(view.activity, view.angular_speed_rps, view.rotating,
                                   tuple(est[0]) if est is not None else (self._distance_m, 0.0), ctrl.walk_direction_rad)
        zero = (0.0, 0.0, 0.0)
        if state == "following" or state == "leading":
            if est is None:
                return zero, None, False
            # the user stands at the alert of a handover for a broken part (the belt's activity window still says walk)
            belt = view if self.alert_pause_s is None else BeltView("stop", False, 0.0, 0.0, view.time_s)
            return ctrl.command(est[0], est[1], belt, odometry, state, self._target_m(), period), None, False
        if state == "remote" or state == "exception":
            return zero, self.remote.command(now, yaw), False
        if state == "waiting_user" and master.state == "master" and master.connected_user is None:
            return self._successor_command(master, odometry), None, False
        return zero, None, state == "emergency"

    @cython.cfunc
    def _feed_belt(self, now: cython.double) -> cython.void:
        """The belt's sensors over the period just ended: the user's walk (or stand) and the waist's mean yaw
        rate over the period (the gyro integrates the true rotation)."""
        user: WalkingBody = self.user
        t_fed: cython.double = self._fed_s
        heading: cython.double = user._read_heading()
        turn: cython.double = (heading - self._fed_heading) / (now - t_fed) if now > t_fed else 0.0
        self._fed_s, self._fed_heading = now, heading
        belt: SmartBelt = self.belt
        if user.returning:  # stepping back to their robot: the belt feels a walk
            belt.advance(now, RETURN_MPS, turn, "walk")
        elif user.walking:
            seg = user.segment
            belt.advance(now, seg.speed_mps, turn, seg.activity)
        else:
            belt.advance(now, 0.0, turn, "stop")

    @cython.cfunc
    def _alert_emergency(self, now: cython.double) -> cython.void:
        """No LF fix of the user for ``master.lost_user_s``: the belt's alert (seed 002 Fig. 4). A walking user
        stops and steps back toward their robot (:meth:`_walk_back`); ``now``: the master's own clock. A user who
        stood (a succession's pause, the building) steps back as well, until the master's fix ends the emergency
        (chosen: standing 3.4 m from a leading successor that had swung in ahead of them, out of its LF reach,
        the user and the stopped swarm waited for each other to the end; leading, seed 1327)."""
        self._emergency_since = now
        self.events["emergencies"] += 1
        self.events["alerts_to_belt"] += 1
        user: WalkingBody = self.user
        if user.walking:
            user.walking = False
            self.paused = self._returning = True
            self.alert_pause_s = now  # they walk on at the master's own LF fix of them in place (_in_place_to_resume)
        else:
            self._returning = True

    @cython.cfunc
    def _end_emergency(self) -> str:
        """The master's LF fix of its user again: the mode before the emergency; a user who stood at the alert stops
        stepping back (a walking one stands until the fix puts them in place, :meth:`_in_place_to_resume`)."""
        self.state = self.previous_mode
        if self.alert_pause_s is None:
            user: WalkingBody = self.user
            user.returning = self._returning = False
        return self.state

    @cython.cfunc
    def _walk_back(self) -> cython.void:
        """After an emergency's alert (no LF fix of the user for ``master.lost_user_s``, seed 002 Fig. 4: the
        robot alerts the belt and every robot of the swarm stops) the user steps back toward their robot,
        which they see, at :data:`RETURN_MPS` with their heading kept, until they stand the master's distance
        from it; they walk on once its own LF fix puts them in place again (:meth:`_in_place_to_resume`).
        Chosen: the papers alert the user and say no more, and a swarm that stands while its user walks
        on has lost them for good."""
        user: WalkingBody = self.user
        idx = self.connected_robot
        if idx is None:
            user.returning = self._returning = False
            return
        rx, ry = self.world.robots[idx].body.position
        ux, uy = user.body.position
        user.returning = far = math.hypot(rx - ux, ry - uy) > self._target_m()
        if far:
            user.toward_x, user.toward_y, user.toward_mps = rx, ry, RETURN_MPS

    @cython.cfunc
    def _in_place_to_resume(self, odometry, since_s: cython.double) -> cython.bint:
        """After a handover for a broken part, an emergency's alert or a leading master's succession: whether the user may walk on
        (:func:`~.succession.in_place_to_resume`, the new master's own LF fix newer than ``since_s``, its clock)."""
        return in_place_to_resume(self.tracker, self.ctrl.walk_direction_rad, self.tracker_node._mcu.local_now(),
                                  since_s, self._target_m(), self.state == "leading", self.cfg, odometry)

    @cython.cfunc
    def _check_release(self) -> cython.void:
        """The connected master cut off from its swarm (:meth:`~.sequence.SequenceManager.cut_off`:
        no ring frame of any member for ``protocol.status_timeout_s``) alerts the belt over BLE and
        releases it, and returns to waiting: its slaves choose a new master, which calls the belt."""
        idx = self.connected_robot
        if idx is None:
            return
        node: Station = self.swarm.nodes[idx]
        seq: SequenceManager = node.seq
        if seq.cut_off(node._mcu.local_now()):  # the robot's own timeout, on its own clock
            node.recovery.plan_clear_out_cut_off()  # it moves out of its swarm's way, as after a handover
            seq.leave_swarm()
            node.connected_user = None
            self._link_lost("released")

    def _obstacle_behind(self, ranges: np.ndarray) -> bool:
        """Something closer than ``master.exception_range_m`` in the leading master's travel
        direction (its back, ±45°) that is not one of its own swarm's robots — those the master
        knows from its IR measurements (fresh within ``FRESH_IR_S``; an older one: where its slot is,
        :func:`~.modes.measured_geometry`)."""
        swarm = self.swarm
        n = len(ranges)
        members = []
        if swarm.organized:
            if self.clock.now - swarm.mode_changed_s < MODE_SETTLE_S:
                return False  # the swarm is re-forming around the master: its echoes are members
            if swarm.formation is not None:
                master = swarm.master
                geometry = measured_geometry(swarm.formation, master.know, master.ahrs_yaw(), master.clock.now, None,
                                             self.cfg.master.distance_m)
                members = [(math.hypot(x, y), math.atan2(y, x)) for m, (x, y) in geometry.positions.items() if m]
        rim = self.cfg.robot.radius_m
        for k in range(n):
            a = 2 * math.pi * k / n
            if abs(wrap_angle(a - math.pi)) > math.pi / 4 + 1e-9 or ranges[k] >= self.cfg.master.exception_range_m:
                continue
            echo_from_member = any(abs(wrap_angle(b - a)) < math.radians(35) and d - 2 * rim < ranges[k] + 0.35 for d, b in members)
            if not echo_from_member:
                return True
        return False


class UserSession(PairingSide, SuccessorSide, SessionCore):
    """One user's session (module docstring): the typed core (:class:`SessionCore`), the pairing
    (:class:`~.pairing.PairingSide`), a new master's search for its user
    (:class:`~.successor_side.SuccessorSide`), the user's commands and a master change."""

    # -- commands (seed 002 §2, Table 1, Fig. 4) ----------------------------------------------------
    def _deliver(self, handler, item, delay_s: float) -> None:
        """Something the watch recognised travels over BLE to the connected robot."""
        ev = self.clock.timeout(delay_s + self.cfg.ble.latency_s)
        ev.callbacks.append(lambda _e: handler(item))

    def handle_command(self, command: str) -> None:
        """A menu command from the watch: driving mode, organize, disperse, return."""
        if self.connected_robot is None:
            return
        self.commands_received.append((self.clock.now, command))
        swarm = self.swarm
        if command.startswith("mode:"):
            mode = command.split(":", 1)[1]
            if self.state in ("exception", "emergency", "waiting_user"):
                return
            if mode != "remote" and swarm.organized:
                est = self.tracker.user_body(self.tracker_node.clock.now)
                swarm.change_mode(mode, self.cfg.swarm.master_change, est[0] if est is not None else None)
            elif swarm.mode != mode:
                swarm.mode = mode
                if swarm.organized:
                    swarm.events["mode_changes"] += 1
            self.state = mode
            if swarm.master.state not in ("master", "organizing"):
                swarm.master.state = mode  # the robot's own driving state (seed 000 Fig. 4)
            if mode != "remote":
                self.previous_mode = mode
            self.ctrl.reset()
            if self._succession_walk is not None and mode in ("following", "leading"):
                self.ctrl.know_walk_direction(wrap_angle(self._succession_walk - self.tracker.pose[2]))  # body frame now
                self._succession_walk = None
        elif command == "organize":
            if not swarm.organized and swarm.master.state != "organizing" and self.state in DRIVING_STATES:
                swarm.start_organize()
        elif command == "disperse":
            if swarm.organized:
                swarm.start_disperse()
        elif command == "return" and self.state == "exception":
            self.state = self.previous_mode
            self._remote_stop()

    def handle_gesture(self, cmd: Command) -> None:
        """A recognised gesture (seed 002 Table 1) reaches the robot."""
        if self.connected_robot is None:
            return
        self.commands_received.append((self.clock.now, "gesture:" + "+".join(cmd.gestures)))
        if cmd.kind == "cancel":  # Circle: back to command-waiting
            self._remote_stop()
            if self.state not in ("emergency", "waiting_user"):
                self.state = "command_waiting"
        elif self.state in ("remote", "exception"):
            self.remote.push(cmd)

    def _remote_stop(self) -> None:
        self.remote = RemoteDriver(self.cfg.watch)

    # -- master change (seed 000 Table 3) ---------------------------------------------------------
    def _on_master_change(self, old, new) -> None:
        """The new master takes over the user (seed 000 Table 3): the wearables reconnect to it over
        BLE. Its user tracker starts from what it knows itself (:func:`~.succession.own_user_estimate`:
        the old master's last status broadcast placed through its own IR fix and heading estimate of
        the old master): the handover frame carries no track. A master that hands over before its
        user's belt paired with it (a new master still looking for its user) hands over no user: the
        belt stays unpaired, and the new master calls it by its wake-up pattern (:meth:`_on_succession`)."""
        if self.connected_robot is None:
            return
        self.connected_robot = new.node_id
        self.link_since_s = self.clock.now + self.cfg.ble.connect_s
        self.link_ack_s = self.belt_clock.now + self.cfg.ble.connect_s
        self.tracker.reset(new.ahrs_yaw())  # the new master's own odometry frame
        self.tracker_node = new
        self.ctrl.reset()
        now = new.clock.now  # the new master's own clock
        handovers = self.swarm.fault_handovers
        last = handovers[len(handovers) - 1] if handovers else None  # (the compiled core indexes without wrap-around)
        for_fault = last is not None and last[1] == old.node_id and last[2] == new.node_id
        est = own_user_estimate(new, now, old.node_id)
        if est is not None:
            self.tracker.fix(est, now)
            self._guess_only = True
            if for_fault and self.swarm.mode in ("following", "leading"):
                # the way its user walks, from its own estimate of the old master's heading (seed 002 §3.3-3.4:
                # the master drives along it facing its user; not at a mode change, where the old master
                # drove in the other mode). Leading, without it the controller guessed that the user faces the new
                # master (seed 000 Table 3 leading: the highest level, at its takeover still off straight ahead), turned the
                # robot up to 80° off the walk, and, facing its user diagonally, its mecanum wheels could
                # barely out-pace them to regain its place ahead. Following, it guessed that the user walks
                # away along its line of sight: from a front slot, half a spacing beside the old master, and
                # on a zigzag often mid-turn; its LF track pulled that guess round at heading_blend_rps while
                # it trailed its user 1.2-2 m (IR on the master, following zigzag: the user lost at the end in
                # 10 of 320 runs, now 4; with the told walk, 2: docs/faults.md)
                self.ctrl.know_walk_direction(walk_direction(new, old.node_id, self.swarm.mode, new.modes.told_walk_rad))
        if for_fault and self.user.walking:
            # a master that hands the user over for a broken part (swarm.hand_over_for_fault) alerts the belt
            # first (chosen, as the belt's alert of a lost master): the user stops until the new master's own
            # LF fix of them (its estimate above is the old master's last broadcast, a second old)
            self.user.walking = False
            self.paused = True  # the user stands until then: not the script's start (the episode's start of walks)
            self.events["alerts_to_belt"] += 1
            self.alert_pause_s = now
