"""The batched vector env (petswarm_env/vector.py): each copy's episodes are bit for bit the
ParallelEnv's with the same seed and actions, across auto-resets."""

import numpy as np
import pytest

import petswarm_env
from petswarm_env import petswarm_v1
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy


def _slots(venv, obs_dict):
    out = np.zeros((venv.max_agents, venv.obs_dim), np.float32)
    for a, o in obs_dict.items():
        out[venv.possible_agents.index(a)] = o
    return out


@pytest.mark.parametrize("overrides", [{"max_cycles": 60}, {"user.scenario": "mode_change", "max_cycles": 360}])
def test_each_copy_is_the_parallel_env_with_the_same_seed_across_auto_resets(overrides):
    num_envs = 3
    venv = petswarm_env.vector_env(num_envs, **overrides)
    obs, infos = venv.reset(seed=7)
    seeds = [i["episode_seed"] for i in infos]
    assert len(set(seeds)) == num_envs and list(venv.episode_seeds) == seeds
    refs = [petswarm_env.parallel_env(**overrides) for _ in range(num_envs)]
    ref_obs, ref_infos = map(list, zip(*(r.reset(seed=s) for r, s in zip(refs, seeds))))
    policy = make_policy("scripted", PolicySpec.from_env(refs[0]))
    rng = np.random.default_rng(0)
    restarts = 0
    for _ in range(overrides["max_cycles"] + 5):  # past every copy's first truncation: one auto-reset each
        for n in range(num_envs):
            np.testing.assert_array_equal(obs[n], _slots(venv, ref_obs[n]))
            # a slot is active while its robot is in slave-role driving: the env's agents with "active" 1
            assert venv.active[n].tolist() == [a in refs[n].agents and ref_infos[n][a]["active"] == 1 for a in venv.possible_agents]
        actions = rng.uniform(-1.2, 1.2, (num_envs, venv.max_agents, 3)).astype(np.float32)  # out of range: clipped alike
        scripted = [policy.act_all(o) for o in ref_obs]
        for n in range(num_envs):
            for a, act in scripted[n].items():
                actions[n, venv.possible_agents.index(a)] = act
        obs, rewards, terminated, truncated, infos = venv.step(actions)
        for n, ref in enumerate(refs):
            waiting = {a for a in ref.agents if not ref_infos[n][a]["active"]}  # the env's agents waiting to join
            o, r, term, trunc, i = ref.step({a: actions[n, venv.possible_agents.index(a)] for a in ref.agents})
            for a in r:
                if a in waiting and not i[a]["joined"]:
                    assert (r[a], term[a]) == (0.0, False)
                    continue
                j = venv.possible_agents.index(a)
                assert (rewards[n, j], terminated[n, j], truncated[n, j]) == (np.float32(r[a]), term[a], trunc[a])
            if not ref.agents:  # the copy started its next episode; the reference does what it did
                restarts += 1
                np.testing.assert_array_equal(infos[n]["final_observation"], _slots(venv, o))
                assert infos[n]["episode_summary"] == ref.episode_summary()
                o, i = ref.reset(seed=infos[n]["episode_seed"])
            ref_obs[n], ref_infos[n] = o, i
    assert restarts == num_envs
    assert venv.state().shape == (num_envs, venv.state_dim)
    np.testing.assert_array_equal(venv.state()[0], refs[0].state())


def test_the_seeds_are_drawn_from_the_one_given_and_inactive_slots_are_ignored():
    a, b = petswarm_env.vector_env(2, max_cycles=20), petswarm_v1.vector_env(2, max_cycles=20)
    obs_a, infos_a = a.reset(seed=3)
    obs_b, infos_b = b.reset(seed=3)
    assert [i["episode_seed"] for i in infos_a] == [i["episode_seed"] for i in infos_b]
    np.testing.assert_array_equal(obs_a, obs_b)
    acts = np.zeros((2, a.max_agents, 3), np.float32)
    noisy = acts.copy()
    noisy[~a.active] = np.nan  # an inactive slot's action is never read
    out_a, out_b = a.step(acts), b.step(noisy)
    for x, y in zip(out_a[:4], out_b[:4]):
        np.testing.assert_array_equal(x, y)
    assert not obs_a[~a.active].any()  # inactive slots observe zeros


def test_bad_actions_are_refused_with_the_shape_named():
    venv = petswarm_env.vector_env(2, max_cycles=10)
    venv.reset(seed=0)
    with pytest.raises(ValueError, match=r"shape \(2, 4, 3\)"):
        venv.step(np.zeros((2, 3)))
    acts = np.zeros((2, 4, 3), np.float32)
    acts[1, np.flatnonzero(venv.active[1])[0], 0] = np.inf
    with pytest.raises(ValueError, match="copy 1"):
        venv.step(acts)


def test_float64_actions_step_as_their_float32_values_and_the_callers_array_stays_as_given():
    a, b = petswarm_env.vector_env(2, max_cycles=20), petswarm_env.vector_env(2, max_cycles=20)
    a.reset(seed=4)
    b.reset(seed=4)
    rng = np.random.default_rng(2)
    for _ in range(5):
        wide = rng.uniform(-1.5, 1.5, (2, a.max_agents, 3))  # float64, out of range: clipped after the float32 cast
        given = wide.copy()
        out_a, out_b = a.step(wide), b.step(wide.astype(np.float32))
        np.testing.assert_array_equal(wide, given)  # the clip works on the env's own copy
        for x, y in zip(out_a[:4], out_b[:4]):
            np.testing.assert_array_equal(x, y)


def test_copies_that_lose_agents_at_different_steps_stay_the_parallel_env():
    """Random actions lose slaves (they leave slave-role driving one by one and wait, at different
    steps in different copies): the steps where some copies keep their agents and others change are
    bit for bit the ParallelEnv's too, and so are the steady steps between them."""
    num_envs, overrides = 3, {"swarm.num_slaves": 5, "max_cycles": 420}
    venv = petswarm_env.vector_env(num_envs, **overrides)
    obs, infos = venv.reset(seed=11)
    refs = [petswarm_env.parallel_env(**overrides) for _ in range(num_envs)]
    for ref, info in zip(refs, infos):
        ref.reset(seed=info["episode_seed"])
    rng = np.random.default_rng(3)
    mixed = 0  # steps where some copies lost an agent and others did not
    for _ in range(overrides["max_cycles"]):
        actions = rng.uniform(-1, 1, (num_envs, venv.max_agents, 3)).astype(np.float32)
        was = venv.active.copy()
        obs, rewards, terminated, truncated, infos = venv.step(actions)
        lost = []
        for n, ref in enumerate(refs):
            live = ref.active_agents
            o, r, term, trunc, _ = ref.step({a: actions[n, venv.possible_agents.index(a)] for a in live})
            expect = np.zeros((3, venv.max_agents), np.float32)
            for a in set(live) | set(ref.active_agents):  # the agents that acted or joined in the step (a waiting one: zeros)
                expect[:, venv.possible_agents.index(a)] = (r[a], term[a], trunc[a])
            np.testing.assert_array_equal(np.stack([rewards[n], terminated[n], truncated[n]]), expect)
            if ref.agents:
                np.testing.assert_array_equal(obs[n], _slots(venv, o))
                assert venv.active[n].tolist() == [a in ref.active_agents for a in venv.possible_agents]
            else:  # truncated: the copy's next episode has started, the last observation is in its infos
                np.testing.assert_array_equal(infos[n]["final_observation"], _slots(venv, o))
            lost.append(bool(was[n].sum() > venv.active[n].sum()) if ref.agents else False)
        mixed += any(lost) and not all(lost)
    assert mixed >= 2
