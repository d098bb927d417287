"""The vectorised hot paths (issue 6) give what the general routines give, on random scenes."""

import math

import numpy as np
import pytest
import simpy

from petswarm_env.comms.ir_channel import IRChannel, line_of_sight_blocked
from petswarm_env.config import load_config
from petswarm_env.middleware import ir
from petswarm_env.scenarios import SCENARIOS
from petswarm_env.sim import geometry
from petswarm_env.sim.world import World
from tests import oracles


def _scene(rng, n_robots, n_other):
    centers = rng.uniform(-3.0, 3.0, (n_robots + n_other, 2))
    radii = rng.uniform(0.1, 0.4, n_robots + n_other)
    headings = rng.uniform(-math.pi, math.pi, n_robots)
    return centers, radii, headings


@pytest.mark.parametrize("seed", range(20))
def test_ring_first_hits_equals_ray_casts_against_circles_and_segments(seed):
    rng = np.random.default_rng(seed)
    n, k = int(rng.integers(1, 8)), int(rng.integers(1, 13))
    centers, radii, headings = _scene(rng, n, int(rng.integers(0, 3)))
    seg_a = rng.uniform(-4.0, 4.0, (int(rng.integers(0, 6)), 2))
    seg_b = seg_a + rng.uniform(-3.0, 3.0, seg_a.shape)
    reach = float(rng.uniform(0.5, 3.0))
    angles = np.arange(k) * (2 * math.pi / k)
    got = geometry.ring_first_hits(centers[:n], headings, angles, centers, radii, geometry.SegmentSet(seg_a, seg_b, reach), reach)
    ang = headings[:, None] + angles[None, :]
    dirs = np.stack([np.cos(ang), np.sin(ang)], axis=-1).reshape(-1, 2)
    origins = np.repeat(centers[:n], k, axis=0)
    want = oracles.ray_circle_distances(origins, dirs, centers, radii, reach).min(axis=1)
    if len(seg_a):
        want = np.minimum(want, geometry.ray_segment_distances(origins, dirs, seg_a, seg_b, reach).min(axis=1))
    want = want.reshape(n, k)
    assert np.array_equal(np.isinf(got), np.isinf(want))
    assert np.isfinite(want).any() or seed > 0  # the scenes do produce hits
    np.testing.assert_allclose(got[np.isfinite(got)], want[np.isfinite(want)], rtol=0, atol=1e-9)


@pytest.mark.parametrize("seed", range(10))
def test_ring_first_hits_equals_the_masked_formulation_bit_for_bit(seed):
    """Crowded scenes (touching and overlapping bodies, walls close by, origins inside other
    bodies): every distance equal to the bit, misses and the range cut included."""
    rng = np.random.default_rng(500 + seed)
    hits = 0
    for _ in range(200):
        n, k = int(rng.integers(1, 10)), int(rng.choice([1, 4, 8, 12]))
        centers = rng.uniform(-1.5, 1.5, (n + int(rng.integers(0, 3)), 2))
        radii = rng.uniform(0.1, 0.4, len(centers))
        headings = rng.uniform(-4.0, 4.0, n)
        seg_a = rng.uniform(-3.0, 3.0, (int(rng.integers(0, 4)), 2))
        seg_b = seg_a + rng.uniform(-3.0, 3.0, seg_a.shape)
        reach = float(rng.uniform(0.3, 2.5))
        angles = np.arange(k) * (2 * math.pi / k)
        want = oracles.ring_first_hits_masked(centers[:n], headings, angles, centers, radii, seg_a, seg_b, reach)
        got = geometry.ring_first_hits(centers[:n], headings, angles, centers, radii,
                                       geometry.SegmentSet(seg_a, seg_b, reach), reach)
        assert got.shape == want.shape and np.array_equal(got, want)
        hits += int(np.isfinite(want).sum())
    assert hits > 1000


def test_segments_out_of_reach_are_left_out_but_near_ones_are_hit():
    walls = geometry.SegmentSet(np.array([[5.0, -1.0], [-50.0, -1.0]]), np.array([[5.0, 1.0], [-50.0, 1.0]]), 2.0)
    assert walls.near(np.array([[0.0, 0.0]])) == []
    assert walls.near(np.array([[3.5, 0.0]])) == [0]
    d = geometry.ring_first_hits(np.array([[3.5, 0.0]]), np.array([0.0]), np.array([0.0, math.pi]), np.zeros((0, 2)),
                                 np.zeros(0), walls, 2.0)
    assert d[0, 0] == pytest.approx(1.5) and d[0, 1] == np.inf


@pytest.mark.parametrize("seed", range(20))
def test_ir_line_of_sight_equals_segments_blocked(seed):
    rng = np.random.default_rng(100 + seed)
    centers, radii, _ = _scene(rng, 8, 2)
    tx = int(rng.integers(8))
    rx = np.array([i for i in range(8) if i != tx and rng.random() < 0.8] or [(tx + 1) % 8])
    exclude = np.zeros((len(rx), len(centers)), bool)
    exclude[np.arange(len(rx)), rx] = True
    exclude[:, tx] = True
    want = oracles.segments_blocked(centers[rx], np.broadcast_to(centers[tx], (len(rx), 2)), centers, radii, exclude)
    cl, rl = centers.tolist(), radii.tolist()
    got = np.array([line_of_sight_blocked(*centers[r], *(centers[tx] - centers[r]), cl, rl, int(r), tx) for r in rx])
    assert np.array_equal(got, want)


def test_ir_measure_of_a_slot_equals_the_per_receiver_model():
    """One IR slot measured for all receivers at once equals the optical model run on each
    receiver alone (occlusion, ring, estimator), given the same noise."""
    cfg = load_config()
    world = World(cfg, SCENARIOS["straight"].script(cfg.user, np.random.default_rng(0)))
    rng = np.random.default_rng(3)
    for p, th in zip(rng.uniform(-2.0, 2.0, (6, 2)), rng.uniform(-3.0, 3.0, 6)):
        world.add_robot(p, th)
    channel = IRChannel(world, cfg.ir, np.random.default_rng(7))
    tx, rxs = 2, [0, 1, 3, 4, 5]
    dist, bearing, valid = channel.measure(tx, rxs)
    centers, radii = world.body_circles()
    z = np.random.default_rng(7).standard_normal((2, len(rxs), cfg.ir.num_receivers))  # the slot's noise
    for j, r in enumerate(rxs):
        others = [i for i in range(len(centers)) if i not in (r, tx)]
        delta = centers[tx] - centers[r]
        occluded = oracles.segments_blocked(centers[r:r + 1], centers[tx:tx + 1], centers[others], radii[others],
                                             np.zeros((1, len(others)), bool))
        b = math.atan2(delta[1], delta[0]) - world.robots[r].heading
        d = max(math.hypot(*delta), 0.01)
        lobe = np.maximum(0.0, np.cos(b - np.arange(cfg.ir.num_receivers) * cfg.ir.spacing_rad)) ** cfg.ir.lobe_exponent
        on_axis = 0.0 if d > cfg.ir.max_range_m else cfg.ir.strength_at_1m / d**2 * (cfg.ir.occlusion_attenuation if occluded[0] else 1.0)
        s = np.clip(on_axis * lobe * (1 + cfg.ir.noise_rel * z[0, j]) + cfg.ir.noise_abs * z[1, j], 0.0, cfg.ir.saturation)
        d_one, b_one, ok_one = oracles.ir_estimate(cfg.ir, s[None, :])
        assert valid[j] == ok_one[0]
        if ok_one[0]:
            assert dist[j] == pytest.approx(d_one[0], abs=1e-9)
            assert bearing[j] == pytest.approx(b_one[0], abs=1e-9)
    assert any(valid)


def test_truth_arrays_follow_the_physics_and_are_read_only():
    cfg = load_config()
    world = World(cfg, SCENARIOS["straight"].script(cfg.user, np.random.default_rng(0)))
    robot = world.add_robot((1.0, 2.0), 0.5)
    centers, radii, headings = world.truth_arrays()
    assert centers[0].tolist() == [1.0, 2.0] and headings[0] == 0.5
    assert radii.tolist() == [cfg.robot.radius_m, cfg.user.radius_m]
    with pytest.raises(ValueError):
        centers[0, 0] = 0.0
    robot.set_command(1.0, 0.0, 1.0)
    world.advance(5)
    c2, _, h2 = world.truth_arrays()
    assert c2[0].tolist() == list(robot.position) and h2[0] == robot.heading and c2[0, 0] > 1.0
    world.add_robot((-1.0, 0.0), 0.0)  # a new body: new arrays
    assert world.truth_arrays()[0].shape == (3, 2)
    robot.body.position = (9.0, 9.0)  # moved by hand: stale until told
    world.invalidate_truth()
    assert world.robot_positions()[0].tolist() == [9.0, 9.0]


def test_safety_stage_equals_the_numpy_formulation():
    from petswarm_env.control.arbiter import SafetyStage

    rng = np.random.default_rng(5)
    stage = SafetyStage(8, 0.35, 0.3, 2.0)
    changed = 0
    for _ in range(500):
        cmd = tuple(rng.uniform(-1.5, 1.5, 3))
        ranges = rng.uniform(0.05, 2.0, 8) if rng.random() < 0.7 else np.full(8, 2.0)
        want, got = oracles.safety_filter(stage, cmd, ranges), stage.filter(cmd, ranges)
        assert (want is None) == (got is None)
        if want is not None:
            changed += 1
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert 50 < changed < 500


def _trace_of_waits(clock):
    """Processes that wait on "an event or a timeout", as the token ring does; (time, label) trace."""
    trace = []

    def waiter(name, ev, timeout):
        got = yield clock.any_of([ev, clock.timeout(timeout)])
        trace.append((clock.now, name, ev in got))

    evs = [clock.event() for _ in range(4)]
    for k, ev in enumerate(evs):
        clock.process(waiter(f"w{k}", ev, 0.05 + 0.01 * k))
    clock.later(0.02, evs[0].succeed)  # before its timeout
    clock.later(0.08, evs[1].succeed)  # after its timeout: too late
    evs[2].succeed()  # already triggered when the condition is built? (processed at t=0)
    clock.later(0.03, lambda: trace.append((clock.now, "tick", None)))
    clock.run_until(0.2)
    return trace


def test_first_of_resumes_like_simpy_any_of():
    from petswarm_env.sim.clock import Clock

    class SimpyClock(Clock):
        def any_of(self, events):
            return simpy.AnyOf(self, events)

    fast, ref = _trace_of_waits(Clock()), _trace_of_waits(SimpyClock())
    assert fast == ref
    assert [t[1] for t in fast] == ["w2", "w0", "tick", "w1", "w3"]


def _later_as_simpy_timeouts(clock):
    """The oracle of ``Clock.later``: ``later(delay, fn, *args)`` is a SimPy timeout of ``delay``
    with one callback that calls ``fn(*args)`` (same queue key, so the same order)."""

    def later(delay, fn, *args):
        clock.timeout(delay).callbacks.append(lambda _event: fn(*args))

    return later


@pytest.mark.parametrize("loop", ["run_until", "run"])
def test_bare_callbacks_run_in_clock_order(loop):
    """``Clock.later`` runs its callbacks at the times and in the order of SimPy timeouts with a
    callback (a plain SimPy environment, the oracle), among a process's own timeouts, with
    ``run_until`` and with SimPy's ``run``; ``clock.now`` follows the time."""
    import simpy

    from petswarm_env.sim.clock import Clock

    def trace(clock, later):
        out = []
        for k, delay in enumerate([0.3, 0.1, 0.2, 0.1, 0.0]):
            later(delay, lambda k=k: out.append((round(clock.now, 9), k)))

        def proc():
            yield clock.timeout(0.15)
            out.append((round(clock.now, 9), "proc"))
            later(0.0, lambda: out.append((round(clock.now, 9), "from proc")))

        clock.process(proc())
        if loop == "run_until" and isinstance(clock, Clock):
            clock.run_until(1.0)
        else:
            clock.run(until=1.0)
        assert clock.now == 1.0
        return out

    want = trace(ref := simpy.Environment(), _later_as_simpy_timeouts(ref))
    assert want == [(0.0, 4), (0.1, 1), (0.1, 3), (0.15, "proc"), (0.15, "from proc"), (0.2, 2), (0.3, 0)]
    clock = Clock()
    assert trace(clock, clock.later) == want
    assert clock._now == clock.now


def test_rewards_of_all_slaves_at_once_equal_one_at_a_time():
    from petswarm_env.reward import slave_rewards
    from tests.oracles import slave_reward

    cfg = load_config().reward
    rng = np.random.default_rng(9)
    n = 7
    acts = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
    last = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
    errs, heads, contacts = rng.uniform(0, 2, n).tolist(), rng.uniform(-3, 3, n).tolist(), rng.integers(0, 3, n).tolist()
    want = [slave_reward(cfg, e, h, c, a, b) for e, h, c, a, b in zip(errs, heads, contacts, acts, last)]
    assert slave_rewards(cfg, errs, heads, contacts, acts, last) == want
    assert slave_rewards(cfg, [], [], [], np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32)) == []


@pytest.mark.parametrize("seed", range(5))
def test_ir_model_equals_the_numpy_oracle(seed):
    """ir.received_strengths / ir.estimate (plain Python, the env's path) give the numbers of their
    numpy forms (tests/oracles.py), also for saturated, occluded, out-of-range and undetected rows:
    validity and distance exactly; the readings and the bearing to the last bit of the lobe's pow and
    of atan2 (numpy's SIMD ``power`` and ``arctan2`` on AVX-512 CPUs and the C library's ``pow`` and
    ``atan2`` may round differently)."""
    cfg = load_config().ir
    rng = np.random.default_rng(seed)
    m = 9
    d = np.concatenate([[0.05, 0.3, cfg.max_range_m + 0.5, 5.0], rng.uniform(0.1, 3.5, m - 4)])
    b = rng.uniform(-4.0, 4.0, m)
    occ = rng.random(m) < 0.3
    want = oracles.ir_received_strengths(cfg, d, b, occ, np.random.default_rng(seed))
    got = ir.received_strengths(cfg, d.tolist(), b.tolist(), occ.tolist(), np.random.default_rng(seed))
    np.testing.assert_allclose(np.array(got), want, rtol=1e-13, atol=1e-12)
    assert np.array_equal(np.array(got) == 0.0, want == 0.0)  # the same clipped and unlit receivers
    assert (want == cfg.saturation).any() and (want.max(axis=1) < cfg.detect_threshold).any()
    d1, b1, ok1 = oracles.ir_estimate(cfg, np.array(got))
    d2, b2, ok2 = ir.estimate(cfg, got)
    assert np.array_equal(ok1, ok2) and ok1.any() and not ok1.all()
    assert np.array_equal(d1, np.array(d2), equal_nan=True)
    np.testing.assert_allclose(np.array(b2), b1, rtol=0, atol=1e-12)  # nan where invalid, in both
    assert np.array_equal(ir.estimate(cfg, [[1.0] * cfg.num_receivers])[2], [cfg.detect_threshold <= 1.0])


def _assert_formation_errors_from_the_bodies(env):
    """Experimenter.formation_errors (read from the truth arrays as lists) equals the same formulas on the
    bodies' own position and heading properties."""
    from petswarm_env.sim.geometry import wrap_angle as _wrap

    robots, errors, heads = env.world.robots, {}, {}
    for swarm in env.swarms:
        if swarm.formation is None or not swarm.organized:
            continue
        members, th = swarm.master.know.members, robots[swarm.master.node_id].heading
        for m, links in swarm.formation.links.items():
            idx = members.get(m)
            agent = f"robot_{idx}"
            if idx is None or not links or agent not in env.agents:
                continue
            sx = sy = 0.0
            for link in links:
                nx, ny = robots[members[link.neighbour]].position
                ox, oy = link.offset_m
                sx += nx + math.cos(th) * ox - math.sin(th) * oy
                sy += ny + math.sin(th) * ox + math.cos(th) * oy
            x, y = robots[idx].position
            errors[agent] = math.hypot(x - sx / len(links), y - sy / len(links))
            heads[agent] = _wrap(robots[idx].heading - th)
    assert env.experimenter.formation_errors(env.agents) == (errors, heads)


@pytest.mark.parametrize("overrides", [{"swarm.num_slaves": 9, "swarm.formation": "grid", "user.scenario": "u_turn"}, {"user.scenario": "mode_change"}],
                         ids=["9 slaves grid", "mode_change"])
def test_observation_builder_equals_the_oracle_bit_for_bit(overrides):
    """The builder, fed as the env feeds it (the ring as a list of floats) and as an array, gives
    the values of the oracle builder (tests/oracles.py) to the bit — in float64 (written into a float64 ``out``)
    and converted to float32 — on the knowledge of real episodes; ages beyond the clip and both
    link slots occur."""
    import petswarm_env
    from baselines.policy import PolicySpec
    from baselines.registry import make_policy
    from petswarm_env.observe import ObservationLayout, Readings, build_observation

    env = petswarm_env.parallel_env(max_cycles=300, **overrides)
    pol = make_policy("scripted", PolicySpec.from_env(env), 0)
    obs, _ = env.reset(seed=1)
    pol.reset(1)
    checked, clipped, two_links = 0, 0, 0
    rng = np.random.default_rng(0)
    layouts = [ObservationLayout(env.cfg.robot.ultrasonic.count, env._limits, r) for r in (env.cfg.robot.ultrasonic.max_range_m, 2.7)]
    while env.agents:
        for agent in env.agents:
            idx = env._agent_index[agent]
            node, robot = env.fleet.nodes[idx], env.world.robots[idx]
            now = env.world.now + float(rng.choice([0.0, 1.5, 30.0]))  # ages beyond the clip too
            args = (node.know, node.reference_links(), now, robot.velocity_body, robot.heading + float(rng.normal()),
                    rng.uniform(-1, 1, 3).astype(np.float32))
            rest = (int(rng.integers(0, 4)), (float(rng.normal()), float(rng.normal())))
            layout = layouts[int(rng.integers(0, 2))]
            ranges = env.sensors.ranges[idx] * float(rng.uniform(0.5, 1.5))
            values = oracles.build_observation(layout, Readings(*args, ranges, *rest))
            want, want32 = np.array(values), np.array(values, dtype=np.float32)
            for ring in (ranges, ranges.tolist()):
                readings = Readings(*args, ring, *rest)
                got = build_observation(layout, readings, np.empty(layout.size))  # float64: every bit
                assert got.tobytes() == want.tobytes()
                got = build_observation(layout, readings)
                assert got.dtype == np.float32 and got.tobytes() == want32.tobytes()
            checked += 1
            clipped += int(want[layout.slices["link0.ir_age"]][0] == 1.0 and bool(node.know.ir))
            two_links += int(want[layout.slices["link1.present"]][0] == 1.0)
        _assert_formation_errors_from_the_bodies(env)
        obs, *_ = env.step(pol.act_all({a: obs[a] for a in env.agents}))
    assert checked > 500 and clipped > 10 and (two_links > 10 or "swarm.formation" not in overrides)


def test_float32_conversion_and_python_division_round_as_numpy():
    """The two plain-Python/numpy swaps of the builder, on 200 000 values: np.fromiter(v, float32)
    rounds as np.array(v, dtype=float32) (halfway cases between float32 neighbours included), and
    x / s on Python floats equals numpy's array / s."""
    rng = np.random.default_rng(11)
    v = np.concatenate([rng.normal(0.0, 1.0, 100_000), rng.uniform(-2.0, 2.0, 50_000) * 10.0 ** rng.integers(-40, 39, 50_000)])
    f = rng.uniform(-1.0, 1.0, 50_000).astype(np.float32).astype(np.float64)
    halfway = (f + np.nextafter(f.astype(np.float32), np.float32(np.inf)).astype(np.float64)) / 2.0  # exact in float64
    v = np.concatenate([v, halfway, [0.0, -0.0, 1.0, -1.0, 1e-45, 3.4e38]]).tolist()
    assert np.array_equal(np.fromiter(v, np.float32, len(v)).view(np.uint32), np.array(v, dtype=np.float32).view(np.uint32))
    r = rng.uniform(0.0, 2.5, 200_000)
    for s in (2.0, 3.0, 2.7, 0.3):
        assert np.array_equal(np.array([x / s for x in r.tolist()]).view(np.uint64), (r / s).view(np.uint64))
    age = [float("nan"), float("inf"), -1.0, 0.999, 1.0, 1.0000001]
    assert [1.0 if a > 1.0 else a for a in age][1:] == [min(a, 1.0) for a in age][1:]
    assert math.isnan(min(age[0], 1.0)) and math.isnan(1.0 if age[0] > 1.0 else age[0])
