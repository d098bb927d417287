"""The privileged teacher: a slave controller that reads ground truth, for training only.

Learning by a privileged teacher (teacher–student imitation, as in "learning by cheating"): the
teacher drives with what no robot has — its true reference point, every body's true position and
velocity — and the student, the policy that ships, learns to act like it from the observation
alone (:mod:`petswarm.training.warm_start`: behaviour cloning, then DAgger rounds in which the student
drives and the teacher labels the states the student visits). The one rule holds for what ships:
``policy.npz`` is a function of the observation; the teacher is a training signal like the reward
and the centralized critic, which read ground truth too. It is never a policy of
:mod:`petswarm.baselines.registry`: nothing at run time can pick it.

The teacher's control law, per slave and step (world frame, then into the robot's body frame):

1. *reference point*: the experimenter's (:meth:`.metrics.Experimenter.references`: the
   neighbours' true positions plus the offsets turned by the master's true heading) and its
   velocity (its change over the last step); with ``orphan_to_slot``, a slave whose reference
   neighbour is off takes its slot about the master's true pose instead; with ``master_command``,
   the velocity leads by what the master's own last motor command asks beyond the master's motion
   (a start or a stop of its user: the slaves start and stop with the master, not one motor ramp
   after it; the students read that command in ``master.velocity``, seed 000 §3.5);
2. *keep out of the users' way*: a reference point closer than ``user_keep_out_m`` to a user is
   moved out to that distance (as the scripted reference does with the broadcast user position);
3. *time-optimal approach*: the reference point's velocity plus a correction toward it of speed
   ``min(v_max, gain·d, sqrt(2·decel·d))`` — full speed far away, braking at ``decel`` near it
   (the scripted reference's linear law, 1.2·d, slows down long before it arrives); a differential
   body, which turns to move sideways, with ``differential_gain`` instead of ``gain``;
4. *avoidance*: for every other body (robots, users) the closest approach over the next
   ``horizon_s`` at the commanded relative velocity; a pass nearer than the two radii plus
   ``clearance_m`` is pushed out sideways, and a body already closer than that pushes back. Then
   the robot's own ultrasonic ring, as the scripted slave's step 5: a range shorter than
   ``sonar_keep_out_m`` pushes the command away from that sensor (the one part of the teacher a
   student can see the reason for; steps 3 and 4's ring are :mod:`petswarm.baselines.estimator`'s
   functions, which an estimating student acts with);
5. *heading*: the master's true heading, with the master's turn rate as feed-forward.

The figures it reaches (the grid with the teacher as candidate) are in docs/training.md,
"A privileged teacher".
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from petswarm.baselines.estimator import approach_speed, sonar_keep_off
from petswarm_env.robot_types import resolve
from petswarm_env.sim.geometry import wrap_angle


@dataclass(frozen=True)
class TeacherGains:
    """The teacher's constants (chosen; docs/training.md has how they were picked)."""

    gain: float = 4.0  # 1/s: the correction's linear part near the reference point
    decel_mps2: float = 1.5  # the braking profile sqrt(2·decel·d) (the petbot brakes at 2.0 m/s²)
    user_keep_out_m: float = 1.1  # reference points are kept this far from every user (as the scripted slave)
    horizon_s: float = 1.0  # how far ahead closest approaches are looked for
    clearance_m: float = 0.15  # rim-to-rim gap a pass must keep
    push: float = 1.5  # m/s per unit of missing clearance (as a fraction of it)
    heading_gain: float = 2.0  # 1/s on the heading error from the master's heading
    sonar_keep_out_m: float = 0.5  # the robot's own ultrasonic ranges push it off anything this close (0 = off)
    sonar_gain: float = 5.0  # 1/s per metre inside the keep-out (the scripted slave's step 5)
    orphan_to_slot: bool = False  # a slave whose reference neighbour is off follows its slot about the master instead
    differential_gain: float = 4.0  # 1/s: step 3's gain on a differential body (2.0 tried: no clear difference, docs/training.md)
    master_command: bool = False  # the reference points' velocity leads by the master's command beyond its motion


class PrivilegedTeacher:
    """Actions for an env's live slaves from ground truth (module docstring).

    ``env`` is the live :class:`~petswarm_env.env.PetSwarmEnv` or a wrapper that forwards its
    attributes (``world``, ``experimenter``, ``agent_robot``, ``cfg``; the training wrappers and
    :class:`petswarm.training.randomize.RandomizedEnv` do). The truth is read once per instant of the
    env's clock (the reference points' velocities are their change since the instant before), so
    asking for one robot at a time gives the same actions as asking for all. Call :meth:`reset`
    after each ``env.reset``.
    """

    def __init__(self, env, gains: TeacherGains | None = None):
        self.env = env
        self.g = gains or TeacherGains()
        self.reset()

    def reset(self) -> None:
        cfg = self.env.cfg  # two bodies closing head-on: the fastest robot type and a running user
        self._closing_mps = max(resolve(cfg, t).robot.max_speed_mps for t in cfg.robot_types) + cfg.user.run_speed_mps
        self._at: float | None = None  # the clock time of the truth below
        self._refs: dict[int, tuple[float, float, float]] = {}
        self._ref_vel: dict[int, tuple[float, float, float]] = {}
        self._xy: list[tuple[float, float]] = []
        self._vel: list[tuple[float, float]] = []
        self._rad: list[float] = []
        self._th: list[float] = []

    def _read_truth(self) -> None:
        """The truth of the env's current instant, with each body's and reference point's velocity
        over the last instant (zero at the first; a jump faster than the body could move — a new
        table, a refill — counts as no motion)."""
        env = self.env
        now = env.truth.now
        if self._at == now:
            return
        centers, radii, headings = env.truth.truth_arrays()
        xy = [tuple(p) for p in centers.tolist()]
        refs = env.truth.references()
        if self.g.orphan_to_slot:
            self._orphans_to_slots(refs, centers, headings)
        if self._at is None or len(self._xy) != len(xy):
            vel = [(0.0, 0.0)] * len(xy)
            ref_vel = {}
        else:
            dt = now - self._at
            vel = [((x - px) / dt, (y - py) / dt) for (x, y), (px, py) in zip(xy, self._xy)]
            ref_vel = {}
            for i, (rx, ry, th_m) in refs.items():
                last = self._refs.get(i)
                if last is not None:
                    v = ((rx - last[0]) / dt, (ry - last[1]) / dt, wrap_angle(th_m - last[2]) / dt)
                    if math.hypot(v[0], v[1]) <= env.truth.robots[i].cfg.max_speed_mps:
                        ref_vel[i] = v
        if self.g.master_command and ref_vel:
            self._lead_by_master_command(ref_vel, vel, headings)
        self._at, self._xy, self._vel, self._refs, self._ref_vel = now, xy, vel, refs, ref_vel
        self._rad, self._th = radii.tolist(), headings.tolist()

    def _lead_by_master_command(self, ref_vel: dict, vel: list, headings: np.ndarray) -> None:
        """Step 1's ``master_command``: each swarm's reference points' velocities plus the master's
        last motor command (its body frame, turned into the world's) less its true velocity."""
        robots = self.env.truth.robots
        for swarm in self.env.truth.swarms:
            i_m = swarm.master.node_id
            cvx, cvy, _ = robots[i_m].motor_command
            c, s = math.cos(float(headings[i_m])), math.sin(float(headings[i_m]))
            lx, ly = c * cvx - s * cvy - vel[i_m][0], s * cvx + c * cvy - vel[i_m][1]
            for idx in swarm.master.know.members.values():
                v = ref_vel.get(idx)
                if v is not None and idx != i_m:
                    ref_vel[idx] = (v[0] + lx, v[1] + ly, v[2])

    def _orphans_to_slots(self, refs: dict, centers: np.ndarray, headings: np.ndarray) -> None:
        """Step 1's exception (``orphan_to_slot``): a slave with a reference neighbour that is off (dead, a
        drained battery) gets its formation slot about its master's true pose as its reference point.
        Without it, its reference point (the neighbour's position plus the link's offset) stands with
        the dead body while the swarm walks on, until the master removes the dead member and re-plans
        (middleware/recovery.py); the re-plan keeps each member near its slot, so a teacher that stopped
        with the dead neighbour is a walk's length behind when the new table arrives."""
        robots = self.env.truth.robots
        for swarm in self.env.truth.swarms:
            formation = swarm.formation
            if formation is None or not swarm.organized:
                continue
            members = swarm.master.know.members
            slots = None
            for m, links in formation.links.items():
                idx = members.get(m)
                if idx not in refs or all(robots[members[link.neighbour]].health.powered for link in links):
                    continue
                if slots is None:
                    slots = formation.slot_positions()
                    i_m = swarm.master.node_id
                    mx, my = float(centers[i_m, 0]), float(centers[i_m, 1])
                    th_m = float(headings[i_m])
                    c, s = math.cos(th_m), math.sin(th_m)
                if m < len(slots):
                    sx, sy = float(slots[m][0]), float(slots[m][1])
                    refs[idx] = (mx + c * sx - s * sy, my + s * sx + c * sy, th_m)

    def act_all(self, agents: list[str], sonar: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
        """The teacher's action in [-1, 1]³ for each of ``agents`` (zeros for one with no
        reference point: it is not in a formation). ``sonar``: each agent's ultrasonic ranges in
        metres (its observation's ``self.ultrasonic``, sensor 0 forward, counter-clockwise) for step
        4's keep-out from what the robot itself senses."""
        self._read_truth()
        return {agent: self._act(agent, None if sonar is None else sonar.get(agent)) for agent in agents}

    def _act(self, agent: str, ranges: np.ndarray | None) -> np.ndarray:
        env, g = self.env, self.g
        i = env.agent_robot(agent)
        point = self._reference_point(i)
        if point is None:
            return np.zeros(3, np.float32)
        body = env.truth.robots[i].cfg
        vmax, wmax = body.max_speed_mps, body.max_omega_rps
        xy, th = self._xy, self._th
        rx, ry, th_m, vrx, vry, w_m = point
        px, py = xy[i]
        ex, ey = rx - px, ry - py
        d = math.hypot(ex, ey)
        spec = env.truth.robots[i].spec
        gain = g.differential_gain if spec is not None and spec.drive == "differential" else g.gain
        speed = float(approach_speed(d, vmax, gain, g.decel_mps2))  # 3
        wx, wy = vrx + (speed * ex / d if d > 1e-9 else 0.0), vry + (speed * ey / d if d > 1e-9 else 0.0)
        wx, wy = self._avoid(i, wx, wy)  # 4, from the truth
        c, s = math.cos(th[i]), math.sin(th[i])
        vx, vy = c * wx + s * wy, -s * wx + c * wy
        if ranges is not None and g.sonar_keep_out_m > 0:  # 4, from the robot's own ultrasonic ring
            vx, vy = (float(v) for v in sonar_keep_off(np.array([[vx, vy]]), ranges, g.sonar_keep_out_m, g.sonar_gain)[0])
        norm = math.hypot(vx, vy)
        if norm > vmax:
            vx, vy = vx * vmax / norm, vy * vmax / norm
        omega = w_m + g.heading_gain * wrap_angle(th_m - th[i])  # 5
        return np.clip(np.array([vx / vmax, vy / vmax, omega / wmax], dtype=np.float32), -1.0, 1.0)

    def _reference_point(self, i: int) -> tuple[float, float, float, float, float, float] | None:
        """Steps 1 and 2 for robot ``i``: its true reference point (world frame) moved out of every
        user's way, the master's true heading, the point's velocity and the master's turn rate
        ``(rx, ry, θ_m, vrx, vry, ω_m)``; None when it has no reference point."""
        ref = self._refs.get(i)
        if ref is None:
            return None
        g, xy = self.g, self._xy
        rx, ry, th_m = ref
        vrx, vry, w_m = self._ref_vel.get(i, (0.0, 0.0, 0.0))  # 1
        for ux, uy in xy[len(self.env.truth.robots):]:  # 2: the reference point out of every user's way
            gap = math.hypot(rx - ux, ry - uy)
            if 1e-6 < gap < g.user_keep_out_m:
                rx, ry = ux + (rx - ux) * g.user_keep_out_m / gap, uy + (ry - uy) * g.user_keep_out_m / gap
        return rx, ry, th_m, vrx, vry, w_m

    def reads(self, agents: list[str]) -> dict[str, tuple[float, ...] | None]:
        """What the teacher's steps 1–3 and 5 read of each agent's situation, in the robot's own body
        frame: ``(ex, ey, vx, vy, dθ, ω_m)`` — the offset from the robot to its reference point
        (after step 2), the point's velocity, the heading error to the master
        (``wrap(θ_m − θ)``) and the master's turn rate; None for an agent with no reference point.
        The labels of an estimating student (:mod:`petswarm.training.estimator`): ground truth, for
        training and measurement only."""
        self._read_truth()
        out: dict[str, tuple[float, ...] | None] = {}
        for agent in agents:
            i = self.env.agent_robot(agent)
            point = self._reference_point(i)
            if point is None:
                out[agent] = None
                continue
            rx, ry, th_m, vrx, vry, w_m = point
            px, py = self._xy[i]
            c, s = math.cos(self._th[i]), math.sin(self._th[i])
            ex, ey = rx - px, ry - py
            out[agent] = (c * ex + s * ey, -s * ex + c * ey, c * vrx + s * vry, -s * vrx + c * vry,
                          wrap_angle(th_m - self._th[i]), w_m)
        return out

    def _avoid(self, i: int, ux: float, uy: float) -> tuple[float, float]:
        """Step 4: the commanded world velocity (ux, uy) pushed off every body it would pass too
        close to within the horizon, and away from any body already inside the clearance."""
        g, xy, rad, vel = self.g, self._xy, self._rad, self._vel
        px, py = xy[i]
        dux = duy = 0.0
        for j, (qx, qy) in enumerate(xy):
            if j == i:
                continue
            dx, dy = px - qx, py - qy
            dist = math.hypot(dx, dy)
            reach = rad[i] + rad[j] + g.clearance_m
            if dist > reach + self._closing_mps * g.horizon_s or dist < 1e-9:  # cannot meet within the horizon
                continue
            wx, wy = ux - vel[j][0], uy - vel[j][1]  # our velocity relative to theirs
            ww = wx * wx + wy * wy
            t = 0.0 if ww < 1e-12 else min(max(-(dx * wx + dy * wy) / ww, 0.0), g.horizon_s)
            mx, my = dx + wx * t, dy + wy * t  # where they are from us at the closest approach
            m = math.hypot(mx, my)
            if m < reach:
                if m < 1e-6:
                    mx, my, m = dx, dy, dist
                depth = (reach - m) / reach
                dux += g.push * depth * mx / m
                duy += g.push * depth * my / m
        return ux + dux, uy + duy


TEACHER_NAME = "privileged-teacher"  # its name where evaluation takes a policy name (petswarm eval --policy)


def is_teacher(name: str) -> bool:
    """Whether a policy word names the teacher: ``privileged-teacher`` (its defaults) or
    ``privileged-teacher:CONFIG`` (the teacher that labels a training config's samples)."""
    return name == TEACHER_NAME or name.startswith(TEACHER_NAME + ":")


def teacher_gains_of(name: str) -> TeacherGains:
    """The gains a teacher word names (:func:`is_teacher`): the defaults, or after the colon a
    training config (a YAML path or a shipped name, ``recurrent_command_teacher``) whose
    ``recurrent.teacher_*`` keys give the teacher its samples were labelled by — the ceiling of
    the policy that config trains. Raises ConfigError naming the word and the fix."""
    from petswarm import shipped
    from petswarm.training.config import load_train_config
    from petswarm_env.config import ConfigError

    config = name.partition(":")[2]
    if name == TEACHER_NAME:
        return TeacherGains()
    path = config if config.endswith((".yaml", ".yml")) and os.path.isfile(config) else shipped(f"train/{config}")
    if not config or path is None:
        raise ConfigError(f"'{name}': no training config '{config}'; write {TEACHER_NAME}:NAME with a shipped "
                          f"training config's name (e.g. {TEACHER_NAME}:recurrent_command_teacher) or a .yaml path")
    try:
        return load_train_config(path).recurrent.teacher_gains()
    except ConfigError as exc:
        raise ConfigError(f"'{name}': {exc}") from None


class TeacherDriver:
    """The teacher behind the slave-policy interface (``reset``, ``act``, ``act_all``), for
    evaluation only: ``petswarm eval --policy privileged-teacher`` and the comparison grid's
    ``--policy privileged-teacher`` measure what a controller that reads ground truth reaches —
    an empirical ceiling for a learned policy, not a bound and not a policy (it is built from the
    env, which no policy sees; :func:`petswarm.evaluation.evaluate.make_team` builds it, the policy registry
    does not know it). It reads each robot's ultrasonic ranges from its observation."""

    name = TEACHER_NAME

    def __init__(self, env, gains: TeacherGains | None = None):
        self.teacher = PrivilegedTeacher(env, gains)
        self._sonar = env.layout.slices["self.ultrasonic"]
        self._range = env.cfg.robot.ultrasonic.max_range_m

    def reset(self, seed: int | None = None) -> None:
        self.teacher.reset()

    def act(self, agent: str, observation: np.ndarray) -> np.ndarray:
        return self.act_all({agent: observation})[agent]

    def act_all(self, observations: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        sonar = {a: np.asarray(o)[self._sonar] * self._range for a, o in observations.items()}
        return self.teacher.act_all(list(observations), sonar)
