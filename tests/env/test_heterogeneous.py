"""A heterogeneous swarm in the env (seeds 001, 003): the mixed pool of the ``heterogeneous`` scenario and
``swarm.pool``, one observation space, each slave's body mapped onto the virtual ring."""

import numpy as np
import pytest

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy

HET = {"user.scenario": "heterogeneous", "max_cycles": 200}


def _run(seed: int, steps: int = 80, **over):
    env = petswarm_env.parallel_env(**{**HET, **over})
    obs, _ = env.reset(seed=seed)
    pol = make_policy("scripted", PolicySpec.from_env(env), seed)
    pol.reset(seed)
    trace = [obs]
    for _ in range(steps):
        if not env.agents:
            break
        obs, *_ = env.step(pol.act_all(obs))
        trace.append(obs)
    return env, trace


def test_the_scenario_pool_gives_each_slave_its_type_and_one_space():
    env, trace = _run(0)
    types = {a: env.episode.world.robots[env.episode.agent_index[a]].type_name for a in env.agents}
    assert sorted(types.values()) == ["mybot", "petbot", "r1", "r2"]
    assert env.episode.world.robots[env.episode.swarm.master.node_id].type_name == "petbot"
    space = env.observation_space(env.agents[0])
    assert all(env.observation_space(a) is space for a in env.possible_agents)
    for obs in trace:
        for o in obs.values():
            assert o.shape == space.shape and np.isfinite(o).all() and space.contains(o)
    lay = env.layout
    for a, t in types.items():
        pres = trace[-1][a][lay.slices["self.ultrasonic_present"]]
        known = trace[-1][a][lay.slices["self.ultrasonic_location_known"]]
        ring = trace[-1][a][lay.slices["self.ultrasonic"]]
        want = {"petbot": 8, "mybot": 6, "r1": 3, "r2": 5}[t]
        assert pres.sum() == want and (known <= pres).all()
        assert (ring[pres == 0] == 1.0).all()  # an absent sensor reads max range


def test_possible_agents_cover_the_pool():
    env = petswarm_env.parallel_env(**{"swarm.pool": [{"type": "mybot", "count": 3}, {"type": "r2", "count": 3}]})
    assert len(env.possible_agents) == 6  # the pool's 6 waiting robots (the master is no agent here)
    env.reset(seed=0)
    assert len(env.episode.world.robots) == 7
    assert [r.type_name for r in env.episode.world.robots] == ["petbot"] + ["mybot"] * 3 + ["r2"] * 3
    assert set(env.agents) <= set(env.possible_agents)
    assert env.state().shape == env.state_space.shape


def test_a_heterogeneous_episode_is_deterministic():
    _, a = _run(3, 40)
    _, b = _run(3, 40)
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert x.keys() == y.keys() and all(x[k].tobytes() == y[k].tobytes() for k in x)


def test_a_slave_with_an_empty_battery_stops():
    env, _ = _run(1, 30)
    agent = next(a for a in env.agents if env.episode.world.robots[env.episode.agent_index[a]].type_name == "mybot")
    robot = env.episode.world.robots[env.episode.agent_index[agent]]
    robot.battery.set_remaining(0.0)
    for _ in range(20):
        env.step({a: np.ones(3, np.float32) for a in env.agents})
    assert robot.battery.empty and robot.own_status()["battery_empty"]
    assert max(abs(v) for v in robot.velocity_body) < 0.05  # stopped (contacts may still nudge it)


def test_a_sensor_fault_lowers_presence():
    env, _ = _run(2, 5)
    agent = env.agents[0]
    idx = env.episode.agent_index[agent]
    env.episode.sensors.sensor_off(idx, {1})
    obs, *_ = env.step({a: np.zeros(3, np.float32) for a in env.agents})
    pres = obs[agent][env.layout.slices["self.ultrasonic_present"]]
    assert pres.sum() == env.episode.sensors.flags[idx][:8].count(1.0) and 0.0 in pres.tolist()
    status = env.episode.world.robots[idx].own_status()
    assert [s["working"] for s in status["sensors"] if s["id"] == 1] == [False]


def test_the_shipped_learned_policy_runs_on_the_mixed_swarm():
    import warnings

    env = petswarm_env.parallel_env(**HET)
    obs, _ = env.reset(seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # trained on layout 2: its fields are matched by name (the flags are new)
        pol = make_policy("learned", PolicySpec.from_env(env))
    for _ in range(10):
        acts = pol.act_all(obs)
        assert all(a.shape == (3,) and np.isfinite(a).all() for a in acts.values())
        obs, *_ = env.step(acts)


def test_an_unknown_scenario_pool_type_is_refused(monkeypatch):
    from petswarm_env.config import ConfigError
    from petswarm_env.scenarios import SCENARIOS

    monkeypatch.setattr(type(SCENARIOS["heterogeneous"]), "robot_pool", (("tank", 4),))
    with pytest.raises(ConfigError, match="scenario 'heterogeneous' robot_pool\\[0\\].type 'tank' is not a robot type"):
        petswarm_env.parallel_env(**HET)


def test_sensors_refresh_after_a_robot_is_added():
    from petswarm_env.robot_types import resolve

    env, _ = _run(0, 2)
    world = env.episode.world
    world.body_plan = world.body_plan + [resolve(env.cfg, "r1")] * (len(world.robots) - len(world.body_plan) + 1)
    robot = world.add_robot((8.0, 8.0), 0.0)  # an arrival (the faults branch wires the agent)
    env.episode.sensors.refresh()
    ranges = env.episode.sensors.read_rings()
    assert ranges.shape == (len(world.robots), 8) and robot.type_name == "r1"
    assert sum(env.episode.sensors.flags[robot.index][:8]) == 3.0
