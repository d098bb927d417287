"""The observation builder against its oracle, bit for bit, on recorded episodes; float32 and division rounding."""

import math
import numpy as np
import pytest
from petswarm_env.comms import ir
from petswarm_env.sim import geometry
from tests import oracles


def _assert_formation_errors_from_the_bodies(env):
    """Experimenter.formation_errors (read from the truth arrays as lists) equals the same formulas on the
    bodies' own position and heading properties."""
    from petswarm_env.sim.geometry import wrap_angle as _wrap

    robots, errors, heads = env.episode.world.robots, {}, {}
    for swarm in env.episode.swarms:
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
    assert env.episode.experimenter.formation_errors(env.agents) == (errors, heads)


@pytest.mark.parametrize("overrides", [{"swarm.num_slaves": 9, "swarm.formation": "grid", "user.scenario": "u_turn"}, {"user.scenario": "mode_change"}],
                         ids=["9 slaves grid", "mode_change"])
def test_observation_builder_equals_the_oracle_bit_for_bit(overrides):
    """The builder, fed as the env feeds it (the ring as a list of floats) and as an array, gives
    the values of the oracle builder (tests/oracles.py) to the bit — in float64 (written into a float64 ``out``)
    and converted to float32 — on the knowledge of real episodes; ages beyond the clip and both
    link slots occur."""
    import petswarm_env
    from petswarm.baselines.policy import PolicySpec
    from petswarm.baselines.registry import make_policy
    from petswarm_env.observe import ObservationLayout, Readings, build_observation

    env = petswarm_env.parallel_env(max_cycles=300, **overrides)
    pol = make_policy("scripted", PolicySpec.from_env(env), 0)
    obs, _ = env.reset(seed=1)
    pol.reset(1)
    checked, clipped, two_links = 0, 0, 0
    rng = np.random.default_rng(0)
    # the env's layout, and one whose IR reach (a carried fix's bound) is short enough to clip fixes
    layouts = [ObservationLayout(env.cfg.robot.ultrasonic.count, env._limits, r, ir)
               for r, ir in ((env.cfg.robot.ultrasonic.max_range_m, env.layout.ir_max_m), (2.7, 1.0))]
    while env.agents:
        for agent in env.agents:
            idx = env.episode.agent_index[agent]
            node, robot = env.episode.fleet.nodes[idx], env.episode.world.robots[idx]
            now = node.clock.now + float(rng.choice([0.0, 1.5, 30.0]))  # its own clock; ages beyond the clip too
            args = (node.know, node.reference_links(), now, robot.velocity_body, robot.heading + float(rng.normal()),
                    rng.uniform(-1, 1, 3).astype(np.float32))
            rest = (int(rng.integers(0, 4)), (float(rng.normal()), float(rng.normal())))
            rest += ([(float(x), float(y)) for x, y in rng.normal(size=(len(node.know.members), 2))],)  # member slots: the anchor's
            layout = layouts[int(rng.integers(0, 2))]
            ranges = env.episode.sensors.ranges[idx] * float(rng.uniform(0.5, 1.5))
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


def test_every_agent_gets_its_own_observation_array():
    """The observations of one step are rows of one float32 block: each agent's is C-contiguous, shares
    no memory with another's, and writing into it leaves the others as they were."""
    import petswarm_env

    env = petswarm_env.parallel_env(max_cycles=20)
    obs, _ = env.reset(seed=0)
    for _ in range(5):
        obs, *_ = env.step({a: np.array([0.1, 0.0, 0.05], np.float32) for a in env.agents})
    agents = sorted(obs)
    assert len(agents) >= 2
    for a in agents:
        assert obs[a].dtype == np.float32 and obs[a].flags.c_contiguous and obs[a].shape == (env.layout.size,)
        assert not any(np.shares_memory(obs[a], obs[b]) for b in agents if b != a)
    kept = {a: obs[a].copy() for a in agents}
    obs[agents[0]][:] = 7.0
    assert all(np.array_equal(obs[a], kept[a]) for a in agents[1:])
