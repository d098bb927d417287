"""The PettingZoo contract: API test, spaces, seeding, bad actions."""

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test

import petswarm_env
from petswarm_env.observe import markdown_table


def test_parallel_api_test_passes():
    env = petswarm_env.parallel_env(max_cycles=60)
    parallel_api_test(env, num_cycles=100)


def test_metadata_names_versioned_env_and_render_modes():
    env = petswarm_env.parallel_env()
    assert env.metadata["name"] == "petswarm_v1"
    assert set(env.metadata["render_modes"]) == {"human", "rgb_array"}


def test_agents_are_the_joined_slaves_with_stable_ids():
    env = petswarm_env.parallel_env(**{"swarm.num_slaves": 3})
    obs, infos = env.reset(seed=1)
    assert env.agents == ["robot_1", "robot_2", "robot_3"]
    assert set(obs) == set(env.agents)
    members = sorted(info["member"] for info in infos.values())
    assert members == [1, 2, 3]
    env.reset(seed=2)
    assert env.agents == ["robot_1", "robot_2", "robot_3"]


def test_observation_fits_space_and_layout_is_documented():
    env = petswarm_env.parallel_env()
    obs, _ = env.reset(seed=0)
    for agent, o in obs.items():
        assert env.observation_space(agent).contains(o)
        assert o.shape == (env.layout.size,)
        assert np.all(np.abs(o) <= 1.5), "observation values are scaled to about [-1, 1]"
    table = markdown_table(env.layout)
    for f in env.layout.fields:
        assert f"`{f.name}`" in table


def test_truncation_at_max_cycles_ends_the_episode():
    env = petswarm_env.parallel_env(max_cycles=5)
    env.reset(seed=0)
    for i in range(5):
        _, _, terms, truncs, infos = env.step({a: np.zeros(3) for a in env.agents})
    assert all(truncs.values()) and not any(terms.values())
    assert env.agents == []
    assert env.episode_summary()["steps"] == 5  # the summary of the episode, after its end
    with pytest.raises(RuntimeError, match="reset"):
        env.step({})


@pytest.mark.parametrize(
    "bad, match",
    [
        (np.array([np.nan, 0.0, 0.0]), "NaN"),
        (np.zeros(2), r"shape \(3,\)"),
    ],
)
def test_malformed_actions_are_refused_with_the_agent_named(bad, match):
    env = petswarm_env.parallel_env()
    env.reset(seed=0)
    actions = {a: np.zeros(3) for a in env.agents}
    actions["robot_2"] = bad
    with pytest.raises(ValueError, match=match) as err:
        env.step(actions)
    assert "robot_2" in str(err.value)


def test_actions_for_unknown_agents_are_refused():
    env = petswarm_env.parallel_env()
    env.reset(seed=0)
    with pytest.raises(KeyError, match="robot_42"):
        env.step({"robot_42": np.zeros(3)})


def test_out_of_range_actions_are_clipped_not_amplified():
    env = petswarm_env.parallel_env()
    env.reset(seed=0)
    env.step({a: np.full(3, 50.0) for a in env.agents})
    for agent in env.agents:
        vx, vy, w = env.episode.world.robots[env.episode.agent_index[agent]].command
        assert abs(vx) <= env.cfg.robot.max_speed_mps + 1e-9
        assert abs(w) <= env.cfg.robot.max_omega_rps + 1e-9


def test_rgb_array_render_returns_an_image():
    env = petswarm_env.parallel_env(render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    h, w = env.cfg.render.size_px[1], env.cfg.render.size_px[0]
    assert frame.shape == (h, w, 3) and frame.dtype == np.uint8
    assert frame.std() > 0
    env.close()


def test_unknown_render_mode_is_refused():
    with pytest.raises(ValueError, match="render_mode"):
        petswarm_env.parallel_env(render_mode="ansi")


def test_aec_wrapper_works():
    env = petswarm_env.env(max_cycles=3)
    env.reset(seed=0)
    for agent in env.agent_iter(max_iter=20):
        obs, rew, term, trunc, info = env.last()
        env.step(None if term or trunc else np.zeros(3, np.float32))


def test_scenario_pool_draws_a_seeded_scenario_per_episode():
    pool = ["u_turn", "straight", "zigzag"]
    env = petswarm_env.parallel_env(**{"user.scenario_pool": pool, "max_cycles": 2})
    drawn = []
    for seed in range(12):
        env.reset(seed=seed)
        drawn.append(env.scenario)
    assert set(drawn) <= set(pool) and len(set(drawn)) > 1
    env.reset(seed=3)
    assert env.scenario == drawn[3]
    while env.agents:
        _, _, _, _, infos = env.step({})
    assert env.episode_summary()["scenario"] == drawn[3]
