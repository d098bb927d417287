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


def _weights(path):
    """A policy file's arrays except its metadata (which records the config, num_cpus included)."""
    with np.load(path, allow_pickle=False) as f:
        return {k: f[k] for k in f.files if k != "meta"}


def test_members_trained_side_by_side_are_the_members_trained_one_after_another(tmp_path):
    from petswarm.training.config import load_train_config
    from petswarm.training.ensemble import train_ensemble

    tiny = {"timesteps": 60, "recurrent.samples_per_round": 60, "recurrent.updates_per_round": 2, "recurrent.members": 2,
            "eval.episodes": 1, "env.max_cycles": 30, "recurrent.encoder": [8], "recurrent.hidden_size": 4,
            "recurrent.head": [4]}
    runs = {}
    for cpus in (1, 2):
        cfg = load_train_config("configs/train/recurrent_command_teacher.yaml", {**tiny, "num_cpus": cpus})
        cfg = cfg.model_copy(update={"randomize": {"swarm.num_slaves": [2, 3]}})  # two draws: quick to size
        train_ensemble(cfg, tmp_path / f"cpus{cpus}", progress=None)
        runs[cpus] = tmp_path / f"cpus{cpus}"
    for name in ("member_0/policy.npz", "member_1/last.npz", "policy.npz", "last.npz"):
        one, two = _weights(runs[1] / name), _weights(runs[2] / name)
        assert one.keys() == two.keys() and all(np.array_equal(one[k], two[k]) for k in one), name
    # and the members are students of their own seeds, not one student twice
    assert not np.array_equal(_weights(runs[2] / "member_0/last.npz")["w0"], _weights(runs[2] / "member_1/last.npz")["w0"])
