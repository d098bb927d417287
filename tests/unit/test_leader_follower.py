"""The scripted leader–follower controller on Python floats computes, bit for bit, what its numpy
form computed (the reference figures of docs/results.md depend on it), on recorded and random observations."""

import math

import numpy as np
import pytest

import petswarm_env
from petswarm.baselines.leader_follower import LeaderFollowerPolicy
from petswarm.baselines.policy import PolicySpec
from petswarm_env.control.master import LEADING_ARC_MAX_RPS
from petswarm_env.observe import AGE_SCALE_S, POS_SCALE_M


def numpy_act(p: LeaderFollowerPolicy, obs: np.ndarray) -> np.ndarray:
    """The controller's first form (numpy on the observation's float32 slices), kept as the reference."""
    sl = p.spec.layout.slices
    vmax, wmax = p.spec.max_speed_mps, p.spec.max_omega_rps
    have_status = obs[sl["master.valid"]][0] > 0.5
    mv = obs[sl["master.velocity"]] * np.array([vmax, vmax, wmax]) if have_status else np.zeros(3)
    targets, dthetas, ref_dists = [], [], []
    search_turn = 0.0
    own = {}  # link -> its heading difference, from a heading exchange within the age range
    for k in range(2):
        q = f"link{k}."
        if obs[sl[q + "present"]][0] < 0.5:
            continue
        s, c = obs[sl[q + "heading_sincos"]]
        if obs[sl[q + "heading_valid"]][0] > 0.5 and obs[sl[q + "heading_age"]][0] < 1.0:
            own[k] = math.atan2(s, c) + mv[2] * obs[sl[q + "heading_age"]][0] * AGE_SCALE_S
            dthetas.append(own[k])
    # the master's fix and an anchor's: the formation frame's rotation into ours (steps 1b and 3)
    m, phi = None, None
    if obs[sl["master.ir_valid"]][0] > 0.5 and obs[sl["master.ir_age"]][0] < 1.0:
        # the fixes come carried over our own motion relative to the swarm (observe.py)
        m = (obs[sl["master.ir_xy"]] * POS_SCALE_M).astype(np.float64)
        if obs[sl["anchor.ir_valid"]][0] > 0.5 and obs[sl["anchor.ir_age"]][0] < 1.0:
            k = obs[sl["anchor.ir_xy"]] * POS_SCALE_M - m
            a = obs[sl["anchor.slot_xy"]] * POS_SCALE_M
            if abs(math.hypot(*k) - math.hypot(*a)) < p.anchor_tol:
                phi = math.atan2(k[1], k[0]) - math.atan2(a[1], a[0])
    if dthetas:
        mean_dth = float(np.mean(dthetas))
    elif phi is not None and p.anchor_heading and not any(
            obs[sl[f"link{k}.present"]][0] > 0.5 and obs[sl[f"link{k}.ir_valid"]][0] > 0.5 and obs[sl[f"link{k}.ir_age"]][0] < 1.0
            for k in range(2)):
        mean_dth = math.atan2(math.sin(phi), math.cos(phi))
    else:
        mean_dth = 0.0
    for k in range(2):
        q = f"link{k}."
        if obs[sl[q + "present"]][0] < 0.5:
            continue
        dth = own.get(k, mean_dth)
        if obs[sl[q + "ir_valid"]][0] < 0.5 or obs[sl[q + "ir_age"]][0] >= 1.0:
            continue
        nb_now = (obs[sl[q + "neighbour_xy"]] * POS_SCALE_M).astype(np.float64)  # carried over our motion in the swarm
        cd, sd = math.cos(dth), math.sin(dth)
        off = obs[sl[q + "offset_xy"]] * POS_SCALE_M
        ref_dists.append(math.hypot(off[0], off[1]))
        targets.append(nb_now + np.array([cd * off[0] - sd * off[1], sd * off[0] + cd * off[1]]))
    dth = mean_dth
    cd, sd = math.cos(dth), math.sin(dth)
    ref = obs[sl["self.offset_from_master_xy"]] * POS_SCALE_M
    leading_turn = have_status and obs[sl["master.leading"]][0] > 0.5 and obs[sl["master.rotating"]][0] > 0.5
    wr = 0.0 if leading_turn or not p.carry else mv[2]
    fx, fy = mv[0] - wr * ref[1], mv[1] + wr * ref[0]
    v = np.array([cd * fx - sd * fy, sd * fx + cd * fy])
    if targets:
        target = np.mean(targets, axis=0)
        act = obs[sl["master.activity"]]  # one-hot: stop, rest, walk, run
        walking = have_status and (act[2] > 0.5 or act[3] > 0.5) and obs[sl["master.rotating"]][0] < 0.5
        keep_out = p.leading_user_keep_out if walking and obs[sl["master.leading"]][0] > 0.5 else p.user_keep_out
        if have_status and keep_out > 0:
            du = obs[sl["master.user_xy"]] * POS_SCALE_M - ref
            user = target + np.array([cd * du[0] - sd * du[1], sd * du[0] + cd * du[1]])
            away = target - user
            gap = float(np.hypot(*away))
            if gap < keep_out:
                target = user + (away / gap if gap > 1e-6 else -user / max(float(np.hypot(*user)), 1e-6)) * keep_out
        v = v + p.kp * target
    elif m is not None:  # step 1b, building
        goal = None
        if phi is not None:
            c, s = np.float64(math.cos(phi)), np.float64(math.sin(phi))
            goal = np.array([m[0] + c * ref[0] - s * ref[1], m[1] + s * ref[0] + c * ref[1]])
        if goal is None:
            dist, reach = max(math.hypot(*m), 1e-9), min(math.hypot(*ref), p.orbit_max)
            goal = m * (1.0 - reach / dist)
            turn = p.orbit if obs[sl["self.member"]][0] * 16.0 % 2.0 > 0.5 else -p.orbit
            v = v + np.array([turn * float(m[1]) / dist, -(turn * float(m[0])) / dist])
        v = v + min(p.kp, p.approach / max(math.hypot(*goal), 1e-9)) * goal
    elif have_status and obs[sl["master.ir_valid"]][0] > 0.5:  # step 1c, lost
        m = [float(x) for x in obs[sl["master.ir_xy"]] * POS_SCALE_M]
        dist = max(math.hypot(*m), 1e-9)
        d = np.array([m[0] / dist, m[1] / dist])
        us = obs[sl["self.ultrasonic"]]
        k = int(np.argmin(us))
        u = np.array(p._us_dirs[k])
        if p.detour > 0 and float(us[k] * np.float32(p.spec.us_max_range_m)) < min(p.detour, dist) and float(u @ d) > math.cos(math.pi / 4):
            la = [float(x) for x in obs[sl["self.last_action"]]]  # the way we rounded it last step
            was_ccw = (la[0] * vmax - float(v[0])) * -float(u[1]) + (la[1] * vmax - float(v[1])) * float(u[0]) > 0.5 * p.rejoin
            tie = math.sin(math.radians(10.0))
            right = float(d[0] * u[1] - d[1] * u[0]) < (tie if was_ccw else -tie)  # the echo right of our way
            d = np.array([-u[1], u[0]]) if right else np.array([u[1], -u[0]])  # round it on the side away from it
        v = v + p.rejoin * d
    else:  # step 1d, nothing in IR sight: circle the nearest echo, turning with the circle; none: turn on the spot
        us = obs[sl["self.ultrasonic"]]
        k = int(np.argmin(us))
        if us[k] < 1.0:
            ux, uy = p._us_dirs[k]
            v = v + np.array([p.search * uy, -(p.search * ux)])
            if p.scan > 0:
                search_turn = -p.search / (float(us[k] * np.float32(p.spec.us_max_range_m)) + 0.25)
        else:
            search_turn = -p.scan
    turn = obs[sl["master.turn_rate"]][0] * wmax
    act = obs[sl["master.activity"]]  # stop, rest, walk, run
    if leading_turn and (act[2] > 0.5 or act[3] > 0.5):  # a walking turn: at most the formation's rate
        turn = np.clip(turn, -np.float32(LEADING_ARC_MAX_RPS), np.float32(LEADING_ARC_MAX_RPS))
    if leading_turn:
        r = ref - obs[sl["master.user_xy"]] * POS_SCALE_M
        arc = np.array([-turn * r[1], turn * r[0]])
        v = v + np.array([cd * arc[0] - sd * arc[1], sd * arc[0] + cd * arc[1]])
    omega = mv[2] + (p.kh * dth if abs(dth) > p.band else 0.0) + search_turn
    keep_out = p.keep_out
    if ref_dists:
        keep_out = min(keep_out, max(0.1, 0.85 * (min(ref_dists) - 0.4)))
    ranges = obs[sl["self.ultrasonic"]] * p.spec.us_max_range_m
    close = ranges < keep_out
    if close.any():
        dirs = np.array(p._us_dirs)
        push = ((keep_out - ranges[close])[:, None] * dirs[close]).sum(axis=0)
        v = v - p.krep * push
    return np.clip(np.array([v[0] / vmax, v[1] / vmax, omega / wmax], dtype=np.float32), -1.0, 1.0)


def _recorded(overrides: dict, steps: int) -> tuple[LeaderFollowerPolicy, list[np.ndarray]]:
    env = petswarm_env.parallel_env(max_cycles=steps, **overrides)
    policy = LeaderFollowerPolicy(PolicySpec.from_env(env))
    obs, _ = env.reset(seed=0)
    seen = []
    while env.agents:
        seen += [obs[a] for a in env.agents]
        obs, *_ = env.step(policy.act_all({a: obs[a] for a in env.agents}))
    return policy, seen


def _assert_same(policy: LeaderFollowerPolicy, observations) -> None:
    """``act`` on each observation, and ``act_all`` on them five at a time, give the numpy form's action."""
    wants = []
    for obs in observations:
        got, want = policy.act("robot_1", obs), numpy_act(policy, obs)
        assert got.dtype == want.dtype == np.float32
        assert got.tobytes() == want.tobytes(), (obs.tolist(), got, want)
        wants.append(want)
    for k in range(0, len(observations), 5):
        batch = {f"robot_{j + 1}": obs for j, obs in enumerate(observations[k : k + 5])}
        got = policy.act_all(batch)
        assert list(got) == list(batch)
        for j, agent in enumerate(batch):
            assert got[agent].dtype == np.float32 and got[agent].shape == (3,)
            assert got[agent].tobytes() == wants[k + j].tobytes(), (batch[agent].tolist(), got[agent], wants[k + j])


@pytest.mark.parametrize(
    "overrides",
    [{}, {"swarm.mode": "leading", "swarm.num_slaves": 5}, {"user.scenario": "mode_change"}],
    ids=["following", "leading", "mode_change"],
)
def test_equals_the_numpy_form_on_recorded_observations(overrides):
    policy, seen = _recorded(overrides, 150)
    assert len(seen) > 400
    _assert_same(policy, seen)


def test_equals_the_numpy_form_on_random_observations():
    """Every branch: flags on and off, leading turns, the user inside the keep-out disc, sensors
    closer than the keep-out (up to the whole ring), stale and fresh measurements."""
    env = petswarm_env.parallel_env()
    policy = LeaderFollowerPolicy(PolicySpec.from_env(env))
    sl = policy.spec.layout.slices
    flags = [name for name in sl if name.endswith(("present", "valid", "leading", "rotating"))]
    rng = np.random.default_rng(5)
    observations = []
    for _ in range(6000):
        obs = rng.uniform(-1.0, 1.0, policy.spec.layout.size).astype(np.float32)
        for name in flags:
            obs[sl[name]] = rng.random() < 0.8
        obs[sl["self.ultrasonic"]] = rng.uniform(0.0, rng.choice([0.3, 1.0]), sl["self.ultrasonic"].stop - sl["self.ultrasonic"].start)
        for k in range(2):  # a heading or IR measurement at the end of the age range (stale)
            for age in ("heading_age", "ir_age"):
                if rng.random() < 0.3:
                    obs[sl[f"link{k}.{age}"]] = 1.0
        if rng.random() < 0.3:  # the user right on the reference location
            obs[sl["master.user_xy"]] = obs[sl["self.offset_from_master_xy"]] + rng.normal(0, 0.05, 2).astype(np.float32)
        observations.append(obs)
    _assert_same(policy, observations)


def test_a_stale_heading_does_not_cancel_a_fresh_one():
    """Step 3: a heading exchange at the end of the observation's age range (its neighbour may
    have turned any amount since) is not averaged with a fresh one; the slave turns by the fresh
    one, and a link without a fresh heading places its target by the fresh one too."""
    env = petswarm_env.parallel_env(**{"swarm.num_slaves": 9})
    policy = LeaderFollowerPolicy(PolicySpec.from_env(env))
    sl = policy.spec.layout.slices
    obs = np.zeros(policy.spec.layout.size, np.float32)
    obs[sl["self.ultrasonic"]] = 1.0
    fresh, stale = -1.2, 1.2  # θ_neighbour − θ_self as each exchange said
    for k, (rel, age) in enumerate([(fresh, 0.1), (stale, 1.0)]):
        q = f"link{k}."
        obs[sl[q + "present"]] = 1.0
        obs[sl[q + "heading_sincos"]] = (math.sin(rel), math.cos(rel))
        obs[sl[q + "heading_valid"]] = 1.0
        obs[sl[q + "heading_age"]] = age
        obs[sl[q + "ir_valid"]] = 1.0
        obs[sl[q + "ir_age"]] = 0.1
        obs[sl[q + "offset_xy"]] = (-1.0 / POS_SCALE_M, 0.0)  # 1 m behind either neighbour, formation frame
    obs[sl["link0.neighbour_xy"]] = (1.0 / POS_SCALE_M, 0.0)
    obs[sl["link1.neighbour_xy"]] = (1.0 / POS_SCALE_M, 0.0)
    act = policy.act("robot_1", obs)
    assert act[2] == pytest.approx(max(-1.0, policy.kh * fresh / policy.spec.max_omega_rps), abs=1e-6)
    # both targets: the neighbour's fix plus the offset turned by the fresh difference
    tx, ty = 1.0 - math.cos(fresh), -math.sin(fresh)
    want = np.clip(np.array([policy.kp * tx, policy.kp * ty]) / policy.spec.max_speed_mps, -1, 1)
    assert act[:2] == pytest.approx(want, abs=1e-5)
    assert act.tobytes() == numpy_act(policy, obs).tobytes()


def _building_obs(policy: LeaderFollowerPolicy) -> np.ndarray:
    """A slave with no reference neighbour in sight and the master's status heard (step 1b's case)."""
    sl = policy.spec.layout.slices
    obs = np.zeros(policy.spec.layout.size, np.float32)
    obs[sl["self.ultrasonic"]] = 1.0
    obs[sl["master.valid"]] = 1.0
    obs[sl["master.ir_valid"]] = 1.0
    obs[sl["master.ir_age"]] = 0.1
    return obs


def test_orbit_stays_within_the_ir_reach():
    """Step 1b without an anchor: a slave 3 m from the master whose slot lies 4.3 m from it orbits
    within the IR's reach (``orbit_max_m``), so it closes in on the master instead of driving out
    to where the master's IR no longer reaches it; a slot nearer than that is orbited at its distance."""
    env = petswarm_env.parallel_env(**{"swarm.num_slaves": 16})
    policy = LeaderFollowerPolicy(PolicySpec.from_env(env))
    sl = policy.spec.layout.slices
    obs = _building_obs(policy)
    obs[sl["master.ir_xy"]] = (3.0 / POS_SCALE_M, 0.0)  # the master 3 m ahead
    obs[sl["self.offset_from_master_xy"]] = (-4.33 / POS_SCALE_M, 0.5 / POS_SCALE_M)
    inward = policy.act("robot_1", obs)[0]
    assert inward > 0.1  # toward the master, to orbit at 2.2 m
    far = LeaderFollowerPolicy(PolicySpec.from_env(env), orbit_max_m=math.inf).act("robot_1", obs)[0]
    assert far < -0.1  # out to the slot's distance, beyond the IR's reach
    obs[sl["self.offset_from_master_xy"]] = (-1.73 / POS_SCALE_M, 1.0 / POS_SCALE_M)  # a slot 2 m from the master
    assert policy.act("robot_1", obs).tobytes() == \
        LeaderFollowerPolicy(PolicySpec.from_env(env), orbit_max_m=math.inf).act("robot_1", obs).tobytes()
    assert policy.act("robot_1", obs).tobytes() == numpy_act(policy, obs).tobytes()


@pytest.mark.parametrize("phi", [0.8, -2.5])
def test_heading_from_the_master_and_an_anchor(phi):
    """Step 3 with no heading exchange within the age range: the master's fix and an anchor's (a
    member standing at its slot's distance from the master) give the rotation of the formation frame
    into ours, θ_master − θ_self; the slave turns by it (and not at all without the anchor)."""
    env = petswarm_env.parallel_env(**{"swarm.num_slaves": 9})
    policy = LeaderFollowerPolicy(PolicySpec.from_env(env))
    sl = policy.spec.layout.slices
    obs = _building_obs(policy)
    c, s = math.cos(phi), math.sin(phi)
    master = np.array([1.5, 0.5])
    slot = np.array([-0.87, 0.5])  # the anchor's slot relative to the master, formation frame
    anchor = master + np.array([c * slot[0] - s * slot[1], s * slot[0] + c * slot[1]])
    obs[sl["master.ir_xy"]] = master / POS_SCALE_M
    obs[sl["anchor.ir_valid"]] = 1.0
    obs[sl["anchor.ir_xy"]] = anchor / POS_SCALE_M
    obs[sl["anchor.ir_age"]] = 0.1
    obs[sl["anchor.slot_xy"]] = slot / POS_SCALE_M
    obs[sl["self.offset_from_master_xy"]] = (-0.87 / POS_SCALE_M, -0.5 / POS_SCALE_M)
    act = policy.act("robot_1", obs)
    want = float(np.clip(policy.kh * phi / policy.spec.max_omega_rps, -1.0, 1.0))
    assert act[2] == pytest.approx(want, abs=1e-4)
    assert act.tobytes() == numpy_act(policy, obs).tobytes()
    assert LeaderFollowerPolicy(PolicySpec.from_env(env), anchor_heading=False).act("robot_1", obs)[2] == 0.0
    obs[sl["anchor.ir_valid"]] = 0.0
    assert policy.act("robot_1", obs)[2] == 0.0


def _lost_obs(policy: LeaderFollowerPolicy, master_fix: bool) -> np.ndarray:
    """A slave that hears the master's status but has no fresh IR fix of anyone: step 1c with an old
    fix of the master (``master_fix``), else step 1d."""
    sl = policy.spec.layout.slices
    obs = np.zeros(policy.spec.layout.size, np.float32)
    obs[sl["self.ultrasonic"]] = 1.0
    obs[sl["master.valid"]] = 1.0
    if master_fix:
        obs[sl["master.ir_valid"]] = 1.0
        obs[sl["master.ir_age"]] = 1.0  # at the end of the age range: step 1c
    return obs


def test_search_circles_the_echo_turning_with_it():
    """Step 1d: an echo in range is circled clockwise, the robot turning with its circle (the echo
    stays on its ray); with no echo in range the robot turns on the spot, sweeping its rays over the
    gaps between them, instead of standing still (a slave in the user's IR shadow stood 20 s and more)."""
    env = petswarm_env.parallel_env()
    policy = LeaderFollowerPolicy(PolicySpec.from_env(env))
    sl = policy.spec.layout.slices
    obs = _lost_obs(policy, master_fix=False)
    quiet = policy.act("robot_1", obs)
    assert quiet[0] == quiet[1] == 0.0 and quiet[2] < -0.1  # no echo: turn on the spot
    assert LeaderFollowerPolicy(PolicySpec.from_env(env), scan_rps=0.0).act("robot_1", obs)[2] == 0.0
    us = sl["self.ultrasonic"].start
    obs[us + 2] = 0.8 / policy.spec.us_max_range_m  # an echo 0.8 m off on the left ray (90°)
    act = policy.act("robot_1", obs)
    assert act[0] > 0.1 and abs(act[1]) < 1e-6  # clockwise about it: forward, the echo on the left
    assert act[2] < -0.1  # turning clockwise with the circle
    assert act.tobytes() == numpy_act(policy, obs).tobytes()
    assert quiet.tobytes() == numpy_act(policy, _lost_obs(policy, master_fix=False)).tobytes()


def test_lost_slave_passes_an_echo_in_its_way():
    """Step 1c: toward the master's last fix, but an echo in the way (the user between us and the
    master, whose body also blocks the IR) is rounded clockwise, whichever side the master lies a
    little to (a slave straight behind its user does not dither), instead of pushing against it; an
    echo well right of the way is passed on our right; an echo off the way changes nothing."""
    env = petswarm_env.parallel_env()
    policy = LeaderFollowerPolicy(PolicySpec.from_env(env))
    sl = policy.spec.layout.slices
    obs = _lost_obs(policy, master_fix=True)
    obs[sl["master.ir_xy"]] = (2.0 / POS_SCALE_M, 0.3 / POS_SCALE_M)  # the master 2 m ahead, a little left
    straight = policy.act("robot_1", obs)
    us = sl["self.ultrasonic"].start
    obs[us + 0] = 0.7 / policy.spec.us_max_range_m  # an echo 0.7 m dead ahead (ray 0)
    act = policy.act("robot_1", obs)
    assert abs(act[0]) < 1e-6 and act[1] < -0.1  # sideways, rounding it clockwise
    assert act.tobytes() == numpy_act(policy, obs).tobytes()
    assert LeaderFollowerPolicy(PolicySpec.from_env(env), detour_m=0.0).act("robot_1", obs)[0] > 0.1  # into the echo
    obs[sl["master.ir_xy"]] = (2.0 / POS_SCALE_M, -0.3 / POS_SCALE_M)  # the master a little right: the same side
    assert policy.act("robot_1", obs).tobytes() == act.tobytes()
    obs[sl["master.ir_xy"]] = (2.0 / POS_SCALE_M, -0.9 / POS_SCALE_M)  # the master 24 degrees right
    obs[us + 0], obs[us + 7] = 1.0, 0.7 / policy.spec.us_max_range_m  # an echo 45 degrees right (ray 7): right of our way
    act = policy.act("robot_1", obs)
    assert act[0] > 0.1 and act[1] > 0.1  # passed on our right: forward and left, not round its far side
    assert act.tobytes() == numpy_act(policy, obs).tobytes()
    obs[us + 7] = 1.0
    obs[sl["master.ir_xy"]] = (2.0 / POS_SCALE_M, 0.3 / POS_SCALE_M)
    obs[us + 0] = 1.0
    obs[us + 4] = 0.7 / policy.spec.us_max_range_m  # behind us: not in the way
    assert policy.act("robot_1", obs).tobytes() == straight.tobytes()


def test_a_lost_slave_keeps_rounding_the_way_it_rounded_last_step():
    """Step 1c: the master's last fix 5° right of an echo dead ahead (within the tie band): clockwise, unless the last
    action already rounded it counter-clockwise (the observation's last action less the swarm's motion), then on
    that way until the master lies clearly, 10° and more, right of the echo. Without it a slave whose counter-clockwise
    move turned the master's direction into the band turned back, and dithered 1.8 m ahead of its master for 10 s
    (loss 0.3, seed 5024)."""
    env = petswarm_env.parallel_env()
    policy = LeaderFollowerPolicy(PolicySpec.from_env(env))
    sl = policy.spec.layout.slices
    obs = _lost_obs(policy, master_fix=True)
    a = math.radians(-5.0)
    obs[sl["master.ir_xy"]] = (2.0 * math.cos(a) / POS_SCALE_M, 2.0 * math.sin(a) / POS_SCALE_M)
    obs[sl["self.ultrasonic"].start] = 0.7 / policy.spec.us_max_range_m  # an echo 0.7 m dead ahead (ray 0)
    assert policy.act("robot_1", obs)[1] < -0.1  # clockwise: to the right
    obs[sl["self.last_action"]] = (0.0, 0.33, 0.0)  # last step: to the left, counter-clockwise about it
    act = policy.act("robot_1", obs)
    assert act[1] > 0.1, act  # on that way
    assert act.tobytes() == numpy_act(policy, obs).tobytes()
    a = math.radians(-15.0)  # clearly right of the echo: clockwise again
    obs[sl["master.ir_xy"]] = (2.0 * math.cos(a) / POS_SCALE_M, 2.0 * math.sin(a) / POS_SCALE_M)
    assert policy.act("robot_1", obs)[1] < -0.1
