"""training/ensemble.py: the mean of recurrent students as one network of the policy file's format."""

import numpy as np
import pytest

pytest.importorskip("torch")

from petswarm.baselines.learned import GRUCell, LearnedPolicy, Recurrent, Residual, read_policy, save_policy  # noqa: E402
from petswarm.baselines.policy import PolicySpec  # noqa: E402
from petswarm.training.ensemble import merge_students, write_merged  # noqa: E402
from petswarm_env import parallel_env  # noqa: E402


def _student(path, layout, seed, encoder=(12, 10), hidden=6, head=(7,)):
    """A recurrent residual policy file with random weights (encoder layers, a GRU, head layers, 3 outputs)."""
    rng = np.random.default_rng(seed)
    sizes, layers = [layout.size, *encoder], []
    for i, o in zip(sizes[:-1], sizes[1:]):
        layers.append((rng.normal(0, 0.3, (o, i)), rng.normal(0, 0.1, o)))
    feed = sizes[-1]
    cell = GRUCell(rng.normal(0, 0.3, (3 * hidden, feed)), rng.normal(0, 0.3, (3 * hidden, hidden)),
                   rng.normal(0, 0.1, 3 * hidden), rng.normal(0, 0.1, 3 * hidden))
    for i, o in zip([feed + hidden, *head], [*head, 3]):
        layers.append((rng.normal(0, 0.3, (o, i)), rng.normal(0, 0.1, o)))
    save_policy(path, layers, "tanh", layout, residual=Residual("scripted", 0.5), recurrent=Recurrent(len(encoder), cell))


@pytest.fixture(scope="module")
def env_spec():
    env = parallel_env()
    obs, _ = env.reset(seed=1)
    return env, obs, PolicySpec.from_env(env)


@pytest.mark.parametrize("members", [2, 3])
def test_the_merged_network_steps_as_the_mean_of_its_members(tmp_path, env_spec, members):
    env, obs, spec = env_spec
    paths = [tmp_path / f"m{k}.npz" for k in range(members)]
    for k, p in enumerate(paths):
        _student(p, spec.layout, seed=k)
    write_merged(paths, tmp_path / "mean.npz", spec.layout, {"members": members})
    mean = LearnedPolicy.load(tmp_path / "mean.npz", spec)
    singles = [LearnedPolicy.load(p, spec) for p in paths]
    assert mean.cell.hidden_size == members * 6 and mean.residual is not None and mean.meta["residual_scale"] == 0.5
    x = np.stack([obs[a] for a in env.agents]).astype(np.float64)
    rng = np.random.default_rng(5)
    h, hs = np.zeros((len(x), members * 6)), [np.zeros((len(x), 6)) for _ in singles]
    for _ in range(25):  # the hidden states evolve: a wrong block would show within a few steps
        xt = x + rng.normal(0, 0.2, x.shape)
        y, h = mean.step_batch(xt, h)
        ys = []
        for k, s in enumerate(singles):
            yk, hs[k] = s.step_batch(xt, hs[k])
            ys.append(yk)
        assert np.max(np.abs(y - np.mean(ys, axis=0))) < 1e-5
        assert np.max(np.abs(h - np.concatenate(hs, axis=1))) < 1e-5


def test_students_of_other_sizes_are_refused(tmp_path, env_spec):
    _, _, spec = env_spec
    _student(tmp_path / "a.npz", spec.layout, 0)
    _student(tmp_path / "b.npz", spec.layout, 1, hidden=5)
    with pytest.raises(ValueError, match="not a student of the same config"):
        merge_students([tmp_path / "a.npz", tmp_path / "b.npz"])
    meta, layers, rec = read_policy(tmp_path / "a.npz")
    assert rec.encoder_layers == 2 and len(layers) == 4
