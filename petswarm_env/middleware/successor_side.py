"""The robot side of a user session after its master was lost (seed 002 §3.2, Fig. 4; middleware/succession.py):
the slave that took the lost master's place starts its user tracker from its own estimate, looks for its
user and bursts its wake-up pattern until the belt pairs (:meth:`SuccessorSide._successor_command`) (leading,
its user walks on only once it stands ahead of them: ``UserSession.step``). A mixin of
:class:`~.user_session.UserSession`, whose state (tracker, controller, belt view, search) it reads."""

from __future__ import annotations

import math

from petswarm_env.middleware.succession import (APPROACH_SLACK_M, BLOCKED_S, PROGRESS_M, SEARCH_STAND_M, STALLED_MPS,
                                                 search_step, walk_direction)


class SuccessorSide:
    """A new master after a succession, on a :class:`~.user_session.UserSession`."""

    def _on_succession(self, node) -> None:
        """A slave took the lost master's place (middleware/succession.py): the session's robot side
        is that robot now. Its user tracker starts from what it knows itself (its estimate from the
        last status broadcast, its IR fix and heading estimate of the lost master), the user standing
        (they stop at the belt's alert); it drives within ``succession.approach_m`` of that and bursts
        its wake-up pattern (:meth:`_successor_command`)."""
        way = node.succession.user_travel
        est = node.succession.user_estimate
        handed = self.swarm.fault_handovers
        if handed and handed[-1][1:3] == (self.tracker_node.node_id, node.node_id):
            # no election: a new master still looking for its user handed it the role for a broken part
            # (swarm.hand_over_for_fault); it knew no more than a guess of where its user is: the robot
            # looks around itself (it stands in its user's swarm)
            est, way = None, None
        self.tracker.reset(node.ahrs_yaw())
        self.tracker_node = node
        self.ctrl.reset()
        self._succeeded = True
        self._search = None
        self._search_yaw = self.tracker.pose[2]
        if est is not None:
            self.tracker.fix(est, node.clock.now)
        self._search_way = way  # the way its user walked (own body frame at its takeover)
        # the way its user walks as it knows it, from its own estimate of the lost master's heading (as at a
        # handover for a broken part, seed 002 §3.3-3.4: the master drove along it facing its user), kept in its
        # tracker's frame until the user's mode command starts its controller (chosen: without it the controller
        # guessed that a leading user faces the robot; the robot, beside its user at its slot, stood while the
        # user walked off, and lost its LF fix: leading, the master dead at 20 s, seeds 1300-1319: the user
        # driven to the end in 14 of 20, 20 with it and the place rule of step())
        lost = node.succession.lost
        self._succession_walk = None
        if est is not None and lost is not None and self.swarm.mode in ("following", "leading"):
            self._succession_walk = walk_direction(node, lost, self.swarm.mode) + self.tracker.pose[2]
        self._wake_next_s = -math.inf
        self._stalled_since: float | None = None
        self._progress = (math.inf, 0.0)
        self._first_burst_done = False
        self._arrival_burst = True

    def _search_on(self, node, reached: bool) -> None:
        """A wake-up burst the belt did not answer where the new master believed it near its user:
        it drives to the next place of its search (:func:`~.succession.search_step`; chosen, seed
        002 has no search) and bursts again there."""
        pos = tuple(self.tracker.pos) if self.tracker.pos is not None else None
        self._search, place = search_step(self._search, pos, self.tracker.pose, self._search_way, self._search_yaw, reached)
        self.tracker.pos = list(place)
        self.tracker.vel = [0.0, 0.0]

    def _successor_command(self, node, odometry) -> tuple[float, float, float]:
        """A new master waiting for its user (seed 002 Fig. 4, waiting-user): it bursts its wake-up
        pattern (seed 002 §3.2) as it takes over, wherever it stands; drives toward where it puts its
        user and bursts as it arrives ``succession.approach_m`` short of them (or stands still within
        ``lf.wake_range_m`` of that place, or comes no closer: ``BLOCKED_S``); and bursts every
        ``lf.wake_period_s`` after, wherever it is. A burst unanswered where it believed itself near
        sends it to the next place of its search (:meth:`_search_on`), where it stands
        ``SEARCH_STAND_M`` short. A belt within ``lf.wake_range_m`` whose pattern matches pairs over
        BLE (``ble.connect_s``)."""
        cfg, now = self.cfg, self.tracker_node.clock.now  # the new master's own clock (its tracker's)
        est = self.tracker.user_body(now)
        d_est = math.hypot(*est[0]) if est is not None else 0.0
        stalled = math.hypot(odometry[0], odometry[1]) < STALLED_MPS  # it gets no closer (the ultrasonic safety stage)
        self._stalled_since = (now if self._stalled_since is None else self._stalled_since) if stalled else None
        if d_est < self._progress[0] - PROGRESS_M:
            self._progress = (d_est, now)
        blocked = now - self._progress[1] >= BLOCKED_S  # it comes no closer (standing or sliding along a body in its way)
        stand = SEARCH_STAND_M if self._search is not None else cfg.succession.approach_m  # a burst place, or short of its user
        near = d_est <= stand + APPROACH_SLACK_M or (stalled and d_est <= cfg.lf.wake_range_m) or blocked
        powered = self.world.robots[node.node_id].health.powered
        if not self._first_burst_done and powered:
            self._first_burst_done = True  # the burst of entering waiting-user (seed 002 Fig. 4), wherever it stands
            self._wake_next_s = now + cfg.lf.wake_period_s
            self._arrival_burst = not near  # standing near where it puts its user already: this was that burst
            if self._wake_up(node):
                return (0.0, 0.0, 0.0)
        # waiting-user: a burst as it arrives short of where it puts its user, and every lf.wake_period_s (seed 002 §3.2)
        if powered and (now >= self._wake_next_s or (near and self._arrival_burst)):
            self._wake_next_s = now + cfg.lf.wake_period_s
            self._arrival_burst = False
            if not self._wake_up(node) and near:  # it stood where it put its user, unanswered: it looks elsewhere
                self._search_on(node, reached=self._search is None or d_est <= stand + APPROACH_SLACK_M)
                self._stalled_since = None
                est = self.tracker.user_body(now)
                self._progress = (math.hypot(*est[0]), now) if est is not None else (math.inf, now)
        if est is None:
            return (0.0, 0.0, 0.0)
        stand = SEARCH_STAND_M if self._search is not None else cfg.succession.approach_m
        return self.ctrl.command(est[0], (0.0, 0.0), self.belt_view, odometry, "following", stand,
                                 cfg.control_period_s)
