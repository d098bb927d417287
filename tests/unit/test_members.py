"""baselines/members.py: a recurrent policy's step, member by member, against the merged network's
own products (the form it replaced: ``petswarm.bench.members_step.whole_step``, the oracle here)."""

import numpy as np
import pytest

from petswarm.baselines.learned import ACTIVATIONS, LearnedPolicy, read_policy, save_policy, shipped_policy_path
from petswarm.baselines.members import MemberStack
from petswarm.baselines.policy import PolicySpec
from petswarm.bench.members_step import whole_step
from petswarm_env import parallel_env

SHIPPED = shipped_policy_path()  # a mean of eight students (docs/training.md)


def _same_steps(policy, x0, steps=25, seed=5):
    """The policy's step and the oracle's over ``steps`` steps of noisy observations: the largest
    difference of outputs and of hidden states (the hidden states evolve: a wrong block shows)."""
    rng = np.random.default_rng(seed)
    h = h_dense = np.zeros((len(x0), policy.cell.hidden_size))
    worst = 0.0
    for _ in range(steps):
        x = x0 + rng.normal(0, 0.2, x0.shape)
        y, h = policy.step_batch(x, h)
        xi = x if policy._identity else x[..., policy.index]
        y_dense, h_dense = whole_step(policy.layers, policy.encoder_layers, policy.cell, policy.act_fn, xi, h_dense)
        worst = max(worst, float(np.abs(y - y_dense).max()), float(np.abs(h - h_dense).max()))
    return worst


@pytest.fixture(scope="module")
def env_spec():
    env = parallel_env()
    obs, _ = env.reset(seed=1)
    return np.stack([obs[a] for a in env.agents]).astype(np.float64), PolicySpec.from_env(env)


def test_the_shipped_mean_of_students_steps_member_by_member_as_its_merged_network(env_spec):
    x, spec = env_spec
    policy = LearnedPolicy.load(SHIPPED, spec)
    assert policy._stack.members == policy.meta["info"]["members"] == 8 and policy._stack.hidden == 64
    assert _same_steps(policy, x) < 1e-12


def test_students_merged_by_training_are_found_again(tmp_path, env_spec):
    pytest.importorskip("torch")
    from tests.unit.test_ensemble import _student
    from petswarm.training.ensemble import write_merged

    x, spec = env_spec
    paths = [tmp_path / f"m{k}.npz" for k in range(3)]
    for k, p in enumerate(paths):
        _student(p, spec.layout, seed=k)
    write_merged(paths, tmp_path / "mean.npz", spec.layout, {"members": 3})
    mean = LearnedPolicy.load(tmp_path / "mean.npz", spec)
    assert mean._stack.members == 3 and mean._stack.hidden == 6
    assert _same_steps(mean, x) < 1e-12
    # a file that says 3 members but whose matrices are not block-diagonal is run whole, as one member
    meta, layers, rec = read_policy(tmp_path / "mean.npz")
    layers[1][0][0, -1] = 0.25  # member 0's unit reads member 2's encoding
    save_policy(tmp_path / "tampered.npz", layers, meta["activation"], spec.layout, meta["info"], None,
                mean.residual, rec)
    tampered = LearnedPolicy.load(tmp_path / "tampered.npz", spec)
    assert tampered._stack.members == 1 and _same_steps(tampered, x) < 1e-12


def test_one_student_is_one_member():
    rng = np.random.default_rng(0)
    layers = [(rng.normal(size=(8, 5)), rng.normal(size=8)), (rng.normal(size=(6, 8 + 4)), rng.normal(size=6)),
              (rng.normal(size=(3, 6)), rng.normal(size=3))]

    class Cell:
        w_ih, w_hh = rng.normal(size=(12, 8)), rng.normal(size=(12, 4))
        b_ih, b_hh = rng.normal(size=12), rng.normal(size=12)
    stack = MemberStack.split(layers, 1, Cell, 2)  # 2 asked for, but not block-diagonal: one member
    assert stack.members == 1 and stack.w_ih.shape == (1, 8, 12) and stack.out_w.shape == (1, 6, 3)
    y, h = stack.step(rng.normal(size=(2, 5)), np.zeros((2, 4)), ACTIVATIONS["tanh"])
    assert y.shape == (2, 3) and h.shape == (2, 4)


def test_the_benchmark_runs_both_ways_on_the_same_network():
    from petswarm.bench.members_step import time_steps

    res = time_steps(str(SHIPPED), agents=2, steps=3, rounds=2)
    assert res["count"] == [8] and len(res["members"]) == len(res["whole"]) == 2
    assert res["max_diff"][0] < 1e-12
