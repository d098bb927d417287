"""TorchRL over the batched vector env (petswarm.training.torchrl_env): TorchRL's own spec check, and
every copy's episodes in a TorchRL rollout — through the auto-resets — are the parallel_env
episodes of their seeds under the same actions."""

import numpy as np
import pytest

pytest.importorskip("torchrl")
import torch  # noqa: E402
from torchrl.envs.utils import check_env_specs  # noqa: E402

import petswarm_env  # noqa: E402
from petswarm.training.torchrl_env import GROUP, PetswarmTorchRLEnv  # noqa: E402

CYCLES = 12


def test_torchrls_spec_check_passes():
    env = PetswarmTorchRLEnv(2, max_cycles=CYCLES)
    env.set_seed(3)
    check_env_specs(env)
    env.close()


def _random_policy(seed: int):
    gen = torch.Generator().manual_seed(seed)

    def policy(td):
        shape = td.get((GROUP, "observation")).shape[:-1] + (3,)
        td.set((GROUP, "action"), torch.rand(shape, generator=gen) * 2 - 1)
        return td

    return policy


def test_each_copys_episodes_are_the_parallel_envs_of_their_seeds_through_auto_resets():
    num_envs, steps = 2, 2 * CYCLES + 3
    env = PetswarmTorchRLEnv(num_envs, max_cycles=CYCLES)
    env.set_seed(11)
    td = env.reset()
    seeds = [list(env.venv.episode_seeds)]
    rollout = []
    policy = _random_policy(0)
    for _ in range(steps):
        td = policy(td)
        out, td = env.step_and_maybe_reset(td)
        rollout.append(out)
        if out["next", "done"].any():
            seeds.append(list(env.venv.episode_seeds))
    done = torch.stack([r["next", "done"] for r in rollout])[..., 0]  # [steps, num_envs]
    assert done.sum(0).tolist() == [2, 2] and done[CYCLES - 1].all() and done[2 * CYCLES - 1].all()
    agents = petswarm_env.parallel_env(max_cycles=CYCLES).possible_agents
    for n in range(num_envs):
        for k in range(2):  # the first and the second episode of copy n
            ref = petswarm_env.parallel_env(max_cycles=CYCLES)
            obs, _ = ref.reset(seed=int(seeds[k][n]))
            first = rollout[k * CYCLES][GROUP, "observation"][n].numpy()
            for j, a in enumerate(agents):
                want = obs.get(a, np.zeros_like(first[j]))
                np.testing.assert_array_equal(first[j], want)
            for t in range(k * CYCLES, (k + 1) * CYCLES):
                acts = rollout[t][GROUP, "action"][n].numpy()
                obs, rew, *_ = ref.step({a: acts[j] for j, a in enumerate(agents) if a in ref.agents})
                nxt = rollout[t]["next", GROUP]
                for j, a in enumerate(agents):
                    if a in obs:
                        np.testing.assert_array_equal(nxt["observation"][n, j].numpy(), obs[a])
                        assert nxt["reward"][n, j, 0].item() == np.float32(rew[a])  # the vector env stores float32
            assert not ref.agents  # the reference episode is over where the TorchRL one said done
    env.close()
