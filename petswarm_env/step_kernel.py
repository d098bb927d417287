"""The episode's per-step bookkeeping around the physics and the middleware, as typed loops: the
actions' stack and clip (``PetSwarmEnv._validate``), the masters' and the slaves' commands through
their arbiters (seed 001; ``Episode._control``), the true centres and headings
(``World.truth_arrays``), the formation errors, the contacts each robot began and the slaves
without a fresh IR fix (the experimenter's step, :mod:`petswarm_env.metrics`), the agents' infos
(``Episode._infos``) and the drained batteries (:meth:`petswarm_env.runtime.Runtime.check_batteries`).

Each function does what the interpreted lines it replaced did, in the same order and with the same
arithmetic: the action scale is one float32 product per value (a float32 action times a float32
scale, rounded to float32, as numpy's ``acts * scale``), every other figure is a C double computed
as the interpreter computes the Python float (the C build has no fused multiply-add: setup.py). The
middleware's own methods (the sequence's master-lost check, the recovery's move out, the arbiter's
decision, the robot's motors) are called as they are: only the loops around them are compiled.

A module of the compiled core (``petswarm_env/_core.py``, Cython's pure-Python mode): the
interpreted form is the oracle the tests hold the compiled form to.
"""

from __future__ import annotations

import cython
import numpy as np
from cython.cimports.libc.math import isfinite as _c_isfinite

from petswarm_env.sim.body import read_poses

if cython.compiled:  # a station's typed attributes (middleware/station.pxd), the MCU clock's C methods (sim/clock.pxd),
    # what a robot knows (middleware/knowledge.pxd), a slave's master check (middleware/sequence.pxd)
    from cython.cimports.petswarm_env.control.arbiter import ControlArbiter  # its decide a C call (control/arbiter.pxd)
    from cython.cimports.petswarm_env.middleware.knowledge import IRMeasurement, Knowledge, MasterStatus
    from cython.cimports.petswarm_env.middleware.sequence import SequenceManager
    from cython.cimports.petswarm_env.middleware.station import Station
    from cython.cimports.petswarm_env.sim.body import DrivenBody  # a robot's battery as a C read (sim/body.pxd)
    from cython.cimports.petswarm_env.sim.health import FaultState
    from cython.cimports.petswarm_env.sim.robot import drive_command  # a robot's command, a C call (sim/robot.pxd)
    from cython.cimports.petswarm_env.sim.clock import LocalClock
else:
    from petswarm_env.control.arbiter import ControlArbiter
    from petswarm_env.middleware.knowledge import IRMeasurement, Knowledge, MasterStatus
    from petswarm_env.middleware.sequence import SequenceManager
    from petswarm_env.middleware.station import Station
    from petswarm_env.sim.body import DrivenBody
    from petswarm_env.sim.health import FaultState
    from petswarm_env.sim.robot import drive_command
    from petswarm_env.sim.clock import LocalClock

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)

_STOP = (0.0, 0.0, 0.0)
_ndarray = np.ndarray
_array = np.array
_empty = np.empty
_float32 = np.float32
_F32 = np.dtype(np.float32)  # the dtype of a native float32 array (one object)
_builtin_sum = sum  # called as the builtin (not inlined): its rule of adding floats is the interpreter's


def clip_finite(arr) -> bool:
    """Clip a float32 ``(n, 3)`` array of actions to [-1, 1] in place if every value is finite
    (True); otherwise leave it as it is (False: the caller names the agent)."""
    return _clip_finite(arr)


@cython.cfunc
def _clip_finite(a: cython.float[:, :]) -> cython.bint:
    """:func:`clip_finite` on the array's values (a C call on a view already taken)."""
    i: cython.Py_ssize_t
    j: cython.Py_ssize_t
    v: cython.float
    for i in range(a.shape[0]):
        for j in range(3):
            if not _c_isfinite(a[i, j]):
                return False
    for i in range(a.shape[0]):
        for j in range(3):
            v = a[i, j]
            if v > 1.0:
                a[i, j] = 1.0
            elif v < -1.0:
                a[i, j] = -1.0
    return True


def stack_actions(actions: dict, agents: list):
    """The actions of ``agents`` (``actions``: agent -> action) as one new float32 array ``(n, 3)``
    clipped to [-1, 1], when every agent has a float numpy array of shape (3,) with finite values;
    otherwise None (the caller checks them one by one and names the agent). The values of float32
    arrays (what the policies give) are written into the new array one by one; any other float
    dtype takes numpy's cast (:func:`_stack_cast`)."""
    n: cython.Py_ssize_t = len(agents)
    out = _empty((n, 3), _float32)
    o: cython.float[:, :] = out
    k: cython.Py_ssize_t
    j: cython.Py_ssize_t
    x: cython.double  # a float32 value, exactly (its list's Python float)
    for k in range(n):
        v = actions.get(agents[k])
        if type(v) is not _ndarray:
            return None
        if v.dtype is not _F32:
            return _stack_cast(actions, agents)
        if v.ndim != 1:
            return None
        values: list = v.tolist()
        if len(values) != 3:
            return None
        for j in range(3):
            x = values[j]
            o[k, j] = x
    return out if _clip_finite(o) else None  # a NaN or an infinity: not clipped


def _stack_cast(actions: dict, agents: list):
    """:func:`stack_actions` through numpy's array from the values (any float dtype, cast to float32)."""
    values = []
    for a in agents:
        v = actions.get(a)
        if type(v) is not _ndarray or v.dtype.kind != "f":
            return None
        values.append(v)
    try:
        arr = _array(values, _float32)
    except ValueError:  # ragged shapes
        return None
    if arr.shape != (len(agents), 3) or not clip_finite(arr):  # a NaN or an infinity: not clipped
        return None
    return arr


def command_masters(sessions: list, sensors, rows: list, arbiters: dict, robots: list) -> set:
    """Each user's master commanded from its user session (its odometry and ring in, the session's
    policy command, the user's command and the emergency stop out) through its arbiter (seed
    001); a master that is off (a fault) has its motors off. ``rows``: every robot's ring as Python floats
    (``Sensors.range_rows``). Returns the masters' robot indices."""
    masters = set()
    arb: ControlArbiter
    health: FaultState
    for session in sessions:
        idx = session.swarm.master.node_id
        masters.add(idx)
        policy, user_cmd, stop = session.step(sensors.odometry(idx), rows[idx])
        arb = arbiters[idx]
        cmd = arb.decide(policy, user_cmd, rows[idx], stop)[0]
        robot = robots[idx]
        health = robot.health
        if health.powered:
            drive_command(robot, cmd[0], cmd[1], cmd[2])
        else:
            drive_command(robot, 0.0, 0.0, 0.0)
    return masters


def all_walking(sessions: list) -> bool:
    """Whether every session's user walks."""
    for session in sessions:
        if not session.user.walking:
            return False
    return True


def command_slaves(robot_ids: list, acts, scale, masters: set, nodes: dict, robots: list, arbiters: dict, rows: list) -> None:
    """Each agent's command (``robot_ids[k]``'s action ``acts[k]``, float32, scaled by ``scale``:
    action 1 -> Vx, Vy, ω) through its arbiter to its motors; a robot that drives a user
    (``masters``) is skipped; a slave whose master is lost (on its own clock: no status broadcast for
    ``protocol.status_timeout_s``) stops, waiting; the master's emergency broadcast stops it. ``rows``: every
    robot's ring as Python floats (``Sensors.range_rows``)."""
    a: cython.float[:, :] = acts
    sx: cython.float = scale[0]
    sy: cython.float = scale[1]
    sw: cython.float = scale[2]
    vx: cython.float
    vy: cython.float
    omega: cython.float
    k: cython.Py_ssize_t
    node: Station
    seq: SequenceManager
    arb: ControlArbiter
    for k in range(len(robot_ids)):
        idx = robot_ids[k]
        if idx in masters:
            continue
        node = nodes[idx]
        seq = node.seq
        if seq.master_lost(node._mcu.local_now()):  # on its own clock (``node.clock.now``)
            drive_command(robots[idx], 0.0, 0.0, 0.0)
            continue
        know: Knowledge = node.know
        st: MasterStatus = know.status
        stop = st is not None and st.mode == "emergency"
        vx, vy, omega = a[k, 0] * sx, a[k, 1] * sy, a[k, 2] * sw  # float32 products, as numpy's
        arb = arbiters[idx]
        cmd = arb.decide((float(vx), float(vy), float(omega)), None, rows[idx], stop)[0]
        drive_command(robots[idx], cmd[0], cmd[1], cmd[2])


def command_leaving(nodes: dict, masters: set, robots: list, arbiters: dict, rows: list, now_s: float) -> None:
    """A robot leaving its slot for its own fault drives out of the way (the recovery's move out,
    middleware/recovery.py), through its arbiter; a master or a robot that is off is not driven."""
    arb: ControlArbiter
    st: Station
    for idx, node in nodes.items():
        st = node
        recovery = st.recovery
        if recovery.clear_out is None:
            continue
        move = recovery.leaving_command(now_s)
        if move is not None and idx not in masters and robots[idx].health.powered:
            arb = arbiters[idx]
            cmd = arb.decide(move, None, rows[idx], False)[0]
            drive_command(robots[idx], cmd[0], cmd[1], cmd[2])


def new_contacts(robot_ids: list, per_robot: dict, seen: dict) -> list:
    """The contacts each robot began since the last call (``per_robot``: the world's counts so far;
    ``seen``: the counts at the last call, updated)."""
    out = []
    now: cython.long
    for idx in robot_ids:
        now = per_robot.get(idx, 0)
        out.append(now - seen.get(idx, 0))
        seen[idx] = now
    return out


def slave_truth(table, centers, headings, agents: list, robot_ids: list, per_robot: dict, seen: dict) -> tuple:
    """One step's truth for ``agents`` (robots ``robot_ids``) from the true centres and headings
    and the reference table (:class:`petswarm_env.references.ReferenceTable`, updated): every agent's
    formation and heading errors (0.0 without a reference point), the errors of the agents with
    one (agent -> error), the largest of those (``max``'s, None without any) and the contacts each
    robot began (:func:`new_contacts`)."""
    errs, heads, has = table.errors(centers.tolist(), headings.tolist(), robot_ids)
    errors = {}
    worst = None
    k: cython.Py_ssize_t
    for k in range(len(agents)):
        if has[k]:
            e = errs[k]
            errors[agents[k]] = e
            if worst is None or e > worst:  # (max's rule: a later value replaces only a greater-than)
                worst = e
    return errors, errs, heads, new_contacts(robot_ids, per_robot, seen), worst


def slaves_of(nodes: dict, pan) -> list:
    """The node ids of ``nodes`` (node id -> station) in slave-role driving in the swarm of PAN ID
    ``pan``, sorted (``Swarm.slave_ids``: each station's state and swarm PAN a C read)."""
    out = []
    node: Station
    for n, node in nodes.items():
        if node.state == "slave" and node.swarm_pan == pan:
            out.append(n)
    out.sort()
    return out


def current_slaves(swarms: list) -> list:
    """The robots in slave-role driving of every swarm (each swarm's ``slave_ids()``), sorted."""
    out = []
    for swarm in swarms:
        out.extend(swarm.slave_ids())
    out.sort()
    return out


def sum_squares(values: list) -> float:
    """``sum(v * v for v in values)`` as the builtin ``sum`` adds them (its own rule, in order)."""
    squares = []
    for v in values:
        squares.append(v * v)
    return _builtin_sum(squares)


def read_truth(robots: list, users: list, user_radius_m: float, radii):
    """Every body's true centre (robots, then users), the radii and the robots' headings, read from
    Chipmunk (:func:`petswarm_env.sim.body.read_poses`) into new read-only arrays; ``radii`` (the
    last read's) is kept while the bodies are the same."""
    n: cython.Py_ssize_t = len(robots)
    centers = np.empty((n + len(users), 2))
    headings = np.empty(n)
    read_poses(robots, centers, 0, headings)
    read_poses(users, centers, n)
    if radii is None or len(radii) != len(centers):
        radii = np.full(len(centers), user_radius_m)
        radii[:n] = [r.radius_m for r in robots]
        radii.setflags(write=False)
    centers.setflags(write=False)  # (setflags: one call, not a flags object per array)
    headings.setflags(write=False)
    return centers, radii, headings


def read_truth_lists(robots: list, users: list, user_radius_m: float) -> tuple:
    """:func:`read_truth`'s values as lists, read body by body without an array: every centre as
    an ``(x, y)`` pair (robots, then users), the radii and the robots' headings, Python floats."""
    centers = []
    radii = []
    headings = []
    for robot in robots:
        centers.append(robot.read_position())
        radii.append(float(robot.radius_m))
        headings.append(robot.heading)
    for user in users:
        centers.append(user.read_position())
        radii.append(float(user_radius_m))
    return centers, radii, headings


def stale_fixes(robot_ids: list, nodes: dict, start_s: float, age_s: float) -> cython.long:
    """How many of the robots ``robot_ids`` have no IR fix of any reference neighbour younger than
    ``age_s`` on their own clock (none yet counts from ``start_s``, the episode's start)."""
    stale: cython.long = 0
    t: cython.double
    newest: cython.double
    found: cython.bint
    node: Station
    clock: LocalClock
    irs: dict
    members: dict
    links: dict
    know: Knowledge
    fix: IRMeasurement
    for idx in robot_ids:
        node = nodes[idx]
        know = node.know
        irs, members = know.ir, know.members  # (dicts, looked up in C)
        found = False  # the newest fix's time: max(...) as the builtin gives it (the first of equals)
        newest = 0.0
        formation, member = node.formation, know.member  # its reference links (Station.reference_links, read here)
        links = formation.links if formation is not None and member > 0 else None
        for lk in (links.get(member, ()) if links is not None else ()):
            fix = irs.get(members.get(lk.neighbour))  # (a fix is never None: one lookup, not a test and a lookup)
            if fix is not None:
                t = fix.time_s
                if not found or t > newest:
                    newest, found = t, True
        clock = node._mcu  # (``node.clock``)
        # the fixes' times are on the robot's own clock (its MCU's): compared on that clock
        if (newest if found else clock.local(start_s)) < clock.local_now() - age_s:
            stale += 1
    return stale


def infos(agents: list, robot_ids: list, nodes: dict, missing: dict, errors_m: list, contacts: list, live: dict) -> dict:
    """The infos of ``agents`` (robots ``robot_ids``; the keys of ``episode.INFO_DEFAULTS``) with
    their formation errors and new contacts, none of them joined in this step: each a copy of
    ``live`` (the infos of an agent in slave-role driving) with its figures."""
    out = {}
    k: cython.Py_ssize_t
    node: Station
    know: Knowledge
    for k in range(len(agents)):
        node = nodes[robot_ids[k]]
        know = node.know
        info = live.copy()  # (a copy of a dict of these keys: no insertion, no resize)
        info["member"] = know.member
        info["formation_error_m"] = errors_m[k]
        info["new_contacts"] = contacts[k]
        info["slaves_missing"] = missing.get(node.swarm_pan, 0)
        out[agents[k]] = info
    return out


def drained(robots: list) -> list:
    """The robots whose battery is empty and not yet a ``battery`` fault (sim/battery.py)."""
    out = []
    body: DrivenBody
    for robot in robots:
        body = robot
        if body.battery.empty and "battery" not in robot.health.active:
            out.append(robot)
    return out
