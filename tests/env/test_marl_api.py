"""What MARL libraries expect of the env : PettingZoo's own tests (API, state, seeds),
the versioned module and make, finite observation bounds that hold, flat infos with the same keys
at reset and at every step, render() as RLlib calls it, and pickling between episodes."""

import copy
import pickle

import numpy as np
import pytest
from pettingzoo.test import api_test, parallel_seed_test, seed_test, state_test
from pettingzoo.utils.conversions import parallel_to_aec_wrapper
from pettingzoo.utils.wrappers import OrderEnforcingWrapper

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm_env import petswarm_v1
from petswarm_env.env import INFO_DEFAULTS, PetSwarmEnv


def test_versioned_module_follows_pettingzoo_names():
    assert isinstance(petswarm_v1.parallel_env(), PetSwarmEnv)
    raw = petswarm_v1.raw_env()
    assert isinstance(raw, parallel_to_aec_wrapper) and isinstance(raw.unwrapped, PetSwarmEnv)
    assert isinstance(petswarm_v1.env(), OrderEnforcingWrapper)
    assert petswarm_env.raw_env is petswarm_v1.raw_env and petswarm_env.env is petswarm_v1.env


def test_make_builds_the_env_of_a_versioned_id():
    env = petswarm_env.make("petswarm_v1", **{"swarm.num_slaves": 2})
    assert isinstance(env, PetSwarmEnv) and env.cfg.swarm.num_slaves == 2
    assert isinstance(petswarm_env.make("petswarm_v1", api="aec"), OrderEnforcingWrapper)
    with pytest.raises(ValueError, match="petswarm_v1"):
        petswarm_env.make("petswarm_v9")


def test_pettingzoo_api_state_and_seed_tests_pass():
    api_test(petswarm_v1.env(max_cycles=8), num_cycles=20)
    state_test(petswarm_v1.env(max_cycles=8), petswarm_v1.parallel_env(max_cycles=8))
    seed_test(lambda: petswarm_v1.env(max_cycles=8), num_cycles=10)
    parallel_seed_test(lambda: petswarm_v1.parallel_env(max_cycles=8), num_cycles=10)


def test_infos_are_flat_numbers_with_the_same_keys_at_reset_and_every_step():
    env = petswarm_v1.parallel_env(**{"user.scenario": "mode_change", "max_cycles": 420})
    # the scripted reference drives: standing slaves would be left beyond the swarm's reach once the user
    # walks, and removed as astray before the mode change (middleware/recovery.py)
    obs, infos = env.reset(seed=0)
    policy = make_policy("scripted", PolicySpec.from_env(env), 0)
    seen = [infos]
    while env.agents:
        obs, *_, infos = env.step(policy.act_all(obs))
        seen.append(infos)
    for step_infos in seen:
        for info in step_infos.values():
            assert set(info) == set(INFO_DEFAULTS)
            assert all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in info.values())
    assert any(info["joined"] == 1 for step in seen for info in step.values())  # robot_0 after the master change
    assert seen[0]["robot_1"]["formation_error_m"] > 0  # the true error at reset, not a placeholder
    organize = env.organize_summary()
    assert organize[0]["organize_time_s"] > 0 and set(organize[0]["members"].values()) >= {1, 2, 3, 4}
    assert env.episode_summary()["steps"] == 420


def _episode_extremes(overrides, policy_name, seed, steps):
    env = petswarm_v1.parallel_env(**{**overrides, "max_cycles": steps})
    obs, _ = env.reset(seed=seed)
    policy = make_policy(policy_name, PolicySpec.from_env(env), seed)
    space, state_space = env.observation_space(env.possible_agents[0]), env.state_space
    assert np.isfinite(space.low).all() and np.isfinite(space.high).all()
    outside = []
    while True:
        for agent, o in obs.items():
            if not space.contains(o):
                bad = [f.name for f in env.layout.fields if ((o[env.layout.slices[f.name]] < space.low[env.layout.slices[f.name]])
                       | (o[env.layout.slices[f.name]] > space.high[env.layout.slices[f.name]])).any()]
                outside.append((env.num_cycles, agent, bad))
        state = env.state()
        if not state_space.contains(state):
            outside.append((env.num_cycles, "state", np.flatnonzero((state < state_space.low) | (state > state_space.high)).tolist()))
        if not env.agents:
            return outside
        obs, *_ = env.step(policy.act_all({a: obs[a] for a in env.agents}))


CASES = [
    ({}, 0),
    ({"user.scenario": "mode_change"}, 1),
    ({"swarm.mode": "leading", "user.scenario": "zigzag"}, 2),
    ({"user.scenario": "u_turn", "radio.loss_prob": 0.3}, 3),
    ({"swarm.formation": "column", "swarm.num_slaves": 6, "user.scenario": "random_walk"}, 4),
    ({"swarm.formation": "grid", "swarm.num_slaves": 8, "world.num_users": 2, "swarm.extra_robots": 1}, 5),
]


@pytest.mark.parametrize("overrides, seed", CASES, ids=[str(i) for i in range(len(CASES))])
@pytest.mark.parametrize("policy_name", ["scripted", "random"])
def test_observations_and_state_stay_inside_their_finite_bounds(overrides, seed, policy_name):
    assert _episode_extremes(overrides, policy_name, seed, 120) == []


def test_supersuit_normalize_obs_accepts_the_env():
    supersuit = pytest.importorskip("supersuit")
    env = supersuit.normalize_obs_v0(petswarm_v1.parallel_env(max_cycles=5))
    obs, _ = env.reset(seed=0)
    assert all(((o >= 0) & (o <= 1)).all() for o in obs.values())


def test_render_takes_rllibs_positional_mode():
    env = petswarm_v1.parallel_env(render_mode="rgb_array", max_cycles=3)
    env.reset(seed=0)
    assert env.render("rgb_array").shape[2] == 3 and env.render().shape[2] == 3
    with pytest.raises(ValueError, match="render_mode"):
        env.render("human")
    env.close()
    assert petswarm_v1.parallel_env().render(None) is None  # no render_mode: a warning, as before


def _trace(env, steps=30, seed=None):
    obs, _ = env.reset(seed=seed)
    out = [obs]
    for _ in range(steps):
        obs, rewards, *_ = env.step({a: np.full(3, 0.2, np.float32) for a in env.agents})
        out.append((obs, rewards))
    return out


def _same(a, b):
    for x, y in zip(a, b):
        x, y = (x, {}) if isinstance(x, dict) else x, (y, {}) if isinstance(y, dict) else y
        assert x[0].keys() == y[0].keys() and all(np.array_equal(x[0][k], y[0][k]) for k in x[0])
        assert x[1] == y[1]


@pytest.mark.parametrize("copier", [lambda e: pickle.loads(pickle.dumps(e)), copy.deepcopy], ids=["pickle", "deepcopy"])
def test_env_pickles_between_episodes_and_the_copy_continues_the_seed_sequence(copier):
    env = petswarm_v1.parallel_env(max_cycles=40)
    env.reset(seed=5)
    fresh = copier(env)  # after reset
    assert fresh.episode is None and fresh.agents == []
    with pytest.raises(RuntimeError, match="reset"):
        fresh.step({})
    _trace(env, 40)  # a whole episode
    twin = copier(env)
    _same(_trace(env), _trace(twin))  # the next episode (reset without a seed) is the same on both
    _same(_trace(fresh, seed=9), _trace(petswarm_v1.parallel_env(max_cycles=40), seed=9))


def test_registered_with_pettingzoo_and_v0_kept_with_a_deprecation_warning():
    import importlib
    import sys

    import pettingzoo

    env = pettingzoo.make("parallel", "petswarm/petswarm-v1", max_cycles=3, **{"swarm.num_slaves": 2})
    assert isinstance(env, PetSwarmEnv) and env.metadata["name"] == "petswarm_v1"
    assert env.reset(seed=0)[0]
    assert isinstance(pettingzoo.make("aec", "petswarm/petswarm-v1", max_cycles=3), OrderEnforcingWrapper)
    sys.modules.pop("petswarm_env.petswarm_v0", None)
    with pytest.warns(DeprecationWarning, match="petswarm_v1"):
        v0 = importlib.import_module("petswarm_env.petswarm_v0")
    assert v0.parallel_env is petswarm_v1.parallel_env
