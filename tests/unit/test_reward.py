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


def test_the_squared_action_change_is_numpys_float32_dot_to_the_bit():
    """reward.py sums ‖Δa‖² itself (float32 squares summed in a double, rounded to float32): on many
    action pairs, near ones (tiny differences) and clipped ones among them, it is numpy's ``da @ da``."""
    from petswarm_env.reward import slave_rewards
    from tests.oracles import slave_reward

    cfg = load_config().reward
    rng = np.random.default_rng(11)
    n = 3000
    acts = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
    last = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
    last[: n // 3] = (acts[: n // 3] + rng.normal(0, 1e-3, (n // 3, 3))).astype(np.float32)
    acts[n // 3: 2 * n // 3] = np.clip(acts[n // 3: 2 * n // 3] * 3, -1, 1)
    zeros = [0.0] * n
    want = [slave_reward(cfg, 0.0, 0.0, 0, a, b) for a, b in zip(acts, last)]
    assert slave_rewards(cfg, zeros, zeros, [0] * n, acts, last) == want
