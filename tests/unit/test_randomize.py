"""Domain randomization (training/randomize.py): pools validated with one-line errors naming the
key, seeded draws (same seed -> same configs), the randomized env's spaces (the union over the
pools, FixedAgents sized for the largest draw) and the training config's round trip."""

import numpy as np
import pytest
import yaml

from petswarm_env.config import ConfigError, load_config
from petswarm_env.env import PetSwarmEnv
from petswarm_env.wrappers import FixedAgents
from petswarm.training.config import load_train_config
from petswarm.training.randomize import CACHE, PoolSpaces, RandomizedEnv, WithState, check_pools, draw, draw_config

ENV = {"max_cycles": 12}
POOLS = {"swarm.num_slaves": [2, 3], "world.num_users": [1, 2],
         "mode": [{"swarm.mode": "following"}, {"swarm.mode": "leading"}],
         "swarm.formation": ["column", "wedge"]}


@pytest.fixture(scope="module")
def spaces():
    return PoolSpaces.of(ENV, POOLS)


@pytest.mark.parametrize("key, value, named", [
    ("randomize.swarm.bogus", [1, 2], "randomize.swarm.bogus: unknown env config key 'swarm.bogus'"),
    ("randomize.swarm.num_slaves", [2, -1], "randomize.swarm.num_slaves: entry int -1 is refused"),
    ("randomize.swarm.formation", ["wedge", "star"], "randomize.swarm.formation: entry str 'star' is refused"),
    ("randomize.radio.loss_prob", [], "randomize.radio.loss_prob: a pool must be a non-empty list"),
    ("randomize.radio.loss_prob", 0.1, "randomize.radio.loss_prob"),  # not a list: the config's type error names it
    ("randomize.mode", [{"swarm.mode": "following"}, {"swarm.nope": 1}], "randomize.mode: unknown env config key 'swarm.nope'"),
])
def test_a_bad_pool_is_one_line_naming_its_key(key, value, named):
    with pytest.raises(ConfigError) as err:
        load_train_config(overrides={key: value})
    message = str(err.value)
    assert named in message and "\n" not in message


def test_a_combination_that_builds_no_env_is_refused_by_name():
    # 8 slaves in leading mode do not fit a 6 x 6 m arena: the combination is named, not a traceback at reset
    with pytest.raises(ConfigError, match=r"randomize: the combination .*swarm.num_slaves.* does not build an env"):
        PoolSpaces.of({"world.arena_m": [6.0, 6.0]}, {"swarm.num_slaves": [2, 8], "swarm.mode": ["following", "leading"]})


def test_same_seed_same_draws_and_the_pools_are_all_drawn():
    draws = [draw(ENV, POOLS, s) for s in range(40)]
    assert draws == [draw(ENV, POOLS, s) for s in range(40)]
    assert {d["swarm.num_slaves"] for d in draws} == {2, 3} and {d["swarm.mode"] for d in draws} == {"following", "leading"}
    cfg = draw_config(ENV, POOLS, 7)
    assert cfg.swarm.num_slaves == draws[7]["swarm.num_slaves"] and cfg.max_cycles == 12
    assert len(check_pools(ENV, POOLS)) == 16  # every combination, each entry once


def test_a_randomized_episode_is_the_drawn_configs_episode(spaces):
    env = RandomizedEnv(ENV, POOLS, spaces)
    for seed in range(3, 3 + CACHE + 3):  # more configs than the cache keeps
        obs, _ = env.reset(seed=seed)
        ref = PetSwarmEnv(draw_config(ENV, POOLS, seed))
        ref_obs, _ = ref.reset(seed=seed)
        assert env.drawn == draw(ENV, POOLS, seed) and sorted(obs) == sorted(ref_obs)
        assert all(np.array_equal(obs[a], ref_obs[a]) for a in obs)
        step = {a: np.full(3, 0.2, np.float32) for a in env.agents}
        o1, *_ = env.step(step)
        o2, *_ = ref.step(step)
        assert all(np.array_equal(o1[a], o2[a]) for a in o2)
    assert len(env._envs) <= CACHE
    # unseeded resets continue a stream started by the last seeded one: reproducible too
    a, b = RandomizedEnv(ENV, POOLS, spaces), RandomizedEnv(ENV, POOLS, spaces)
    a.reset(seed=5), b.reset(seed=5)
    assert [(a.reset(), a.drawn)[1] for _ in range(4)] == [(b.reset(), b.drawn)[1] for _ in range(4)]


def test_fixed_agents_over_the_pools_is_sized_for_the_largest_draw(spaces):
    env = WithState(FixedAgents(RandomizedEnv(ENV, POOLS, spaces)))
    largest = max(len(PetSwarmEnv(load_config(overrides=o)).possible_agents) for o in check_pools(ENV, POOLS))
    assert len(env.possible_agents) >= largest
    box = env.observation_space(env.possible_agents[0])
    for seed in range(6):
        rows, infos = env.reset(seed=seed)
        assert sorted(rows) == sorted(env.possible_agents)
        while env.agents:
            assert all(box.contains(r) for r in rows.values())
            assert env.state_space.contains(env.state())
            rows, *_ = env.step({a: np.full(3, 0.5, np.float32) for a in env.agents})
    assert box.shape[0] == env.layout.size + env.state_space.shape[0]


def test_the_training_config_round_trips_with_its_pools(tmp_path):
    cfg = load_train_config("configs/train/generalize.yaml")
    assert cfg.randomize and cfg.ppo.critic == "state"
    saved = tmp_path / "train_config.yaml"
    saved.write_text(yaml.safe_dump(cfg.model_dump(mode="json"), sort_keys=False))
    assert load_train_config(base=saved) == cfg
    # --set adds a pool with a dotted key, null drops one
    more = load_train_config(overrides={"randomize.radio.loss_prob": [0.0, 0.3], "randomize.swarm.num_slaves": None})
    assert more.randomize == {"radio.loss_prob": [0.0, 0.3]}
    assert load_train_config().randomize == {} and load_train_config().ppo.critic == "local"
