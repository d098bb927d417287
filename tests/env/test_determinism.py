"""Same seed, same episode, bit for bit — over 500 steps, not just one (cf. PettingZoo PR #1437)."""

import numpy as np

import petswarm_env


def _rollout(seed: int, steps: int):
    env = petswarm_env.parallel_env(max_cycles=steps)
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(1234)  # the same seeded actions for both envs
    trace = [{a: o.copy() for a, o in obs.items()}]
    rewards = []
    while env.agents:
        actions = {a: rng.uniform(-1, 1, 3).astype(np.float32) for a in env.agents}
        obs, rew, _, _, _ = env.step(actions)
        trace.append({a: o.copy() for a, o in obs.items()})
        rewards.append(dict(rew))
    return trace, rewards, env.episode_summary()


def test_same_seed_same_500_steps_bit_for_bit():
    t1, r1, s1 = _rollout(7, 500)
    t2, r2, s2 = _rollout(7, 500)
    assert len(t1) == len(t2) == 501
    for a, b in zip(t1, t2):
        assert a.keys() == b.keys()
        for k in a:
            assert np.array_equal(a[k], b[k])
    assert r1 == r2
    assert s1 == s2


def test_different_seeds_differ():
    t1, _, _ = _rollout(1, 20)
    t2, _, _ = _rollout(2, 20)
    assert any(not np.array_equal(t1[-1][k], t2[-1][k]) for k in t1[-1])


def test_reset_without_seed_continues_the_seed_sequence_reproducibly():
    e1 = petswarm_env.parallel_env()
    e2 = petswarm_env.parallel_env()
    e1.reset(seed=3)
    e2.reset(seed=3)
    o1, _ = e1.reset()
    o2, _ = e2.reset()
    for k in o1:
        assert np.array_equal(o1[k], o2[k])
