"""The reward of every slave at once (reward.slave_rewards) against the one-slave form (tests/oracles.py)."""

import numpy as np
from petswarm_env.config import load_config
from tests import oracles


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
