"""SB3's VecEnv over the batched vector env (training/vec_env.py PetswarmVecEnv): the rows of
FixedAgents under SuperSuit, seeded by SB3, and PPO(seed=...) learns on it."""

import numpy as np
import pytest
from stable_baselines3 import PPO

import petswarm_env
from petswarm_env.config import load_config
from petswarm_env.wrappers import FixedAgents
from petswarm.training.vec_env import PetswarmVecEnv, make_vec_env


def test_rows_are_fixed_agents_rows_of_each_copy_and_end_together():
    cfg = load_config(overrides={"user.scenario": "mode_change", "max_cycles": 40})
    venv = PetswarmVecEnv(cfg, 2)
    venv.seed(5)
    rows = venv.reset()
    m = venv.slots
    assert rows.shape == (2 * m, venv.observation_space.shape[0])
    refs = [FixedAgents(petswarm_env.parallel_env(cfg)) for _ in range(2)]
    ref_obs = [r.reset(seed=int(s))[0] for r, s in zip(refs, venv.venv.episode_seeds)]
    rng = np.random.default_rng(1)
    for step in range(40):
        for n, ref in enumerate(refs):
            np.testing.assert_array_equal(rows[n * m:(n + 1) * m], np.stack([ref_obs[n][a] for a in ref.possible_agents]))
        actions = rng.uniform(-1, 1, (2 * m, 3)).astype(np.float32)
        venv.step_async(actions)
        rows, rewards, dones, infos = venv.step_wait()
        for n, ref in enumerate(refs):
            o, r, term, trunc, inf = ref.step({a: actions[n * m + j] for j, a in enumerate(ref.possible_agents)})
            np.testing.assert_array_equal(rewards[n * m:(n + 1) * m], np.array([r[a] for a in ref.possible_agents], np.float32))
            assert [infos[n * m + j]["active"] for j in range(m)] == [inf[a]["active"] for a in ref.possible_agents]
            assert dones[n * m:(n + 1) * m].tolist() == [term[a] or trunc[a] for a in ref.possible_agents]
            ref_obs[n] = o
    assert dones.all() and all("terminal_observation" in i for i in infos)  # 40 steps: every copy ended at once


@pytest.mark.parametrize("with_state", [False, True])
def test_ppo_with_a_seed_learns_on_the_vector_env(with_state):
    cfg = load_config(overrides={"max_cycles": 30})
    venv = make_vec_env(cfg, 2, 0, 0, with_state=with_state)
    model = PPO("MlpPolicy", venv, n_steps=20, batch_size=80, n_epochs=1, seed=0, verbose=0)
    model.learn(320)
    assert model.num_timesteps >= 320 and venv.num_envs == 8
    assert venv.observation_space.shape[0] == 83 + (venv.venv.venv.state_dim if with_state else 0)


def test_build_models_ppo_learns_sb3s_numbers_bit_for_bit():
    """``build_model``'s PPO (training/train.py UncheckedPPO: no torch.distributions checks during
    ``learn``) ends with the parameters SB3's own ``learn`` (checks on) gives the same seed, and
    leaves the checks on after."""
    import torch
    from stable_baselines3.common.utils import set_random_seed
    from torch.distributions import Normal

    from petswarm.training.config import load_train_config
    from petswarm.training.train import UncheckedPPO, build_model

    cfg = load_config(overrides={"max_cycles": 30})
    params = lambda model: [t.detach().numpy().copy() for t in model.policy.state_dict().values()]  # noqa: E731
    learned = []
    for learn in (UncheckedPPO.learn, PPO.learn):
        set_random_seed(0)
        venv = make_vec_env(cfg, 2, 0, 0)
        model = build_model(load_train_config().ppo, venv, 0, n_steps=16, batch_size=64)
        start = params(model)
        learn(model, 256)
        learned.append(params(model))
        venv.close()
        assert any((a != b).any() for a, b in zip(start, learned[-1]))  # it learned
    for a, b in zip(*learned):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError):
        Normal(torch.zeros(1), -torch.ones(1))  # the checks are back on
