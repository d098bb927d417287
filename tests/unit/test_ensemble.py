"""training/ensemble.py: the mean of recurrent students as one network of the policy file's format."""

import json
import shutil

import numpy as np
import pytest
import yaml

pytest.importorskip("torch")

from petswarm.baselines.learned import GRUCell, LearnedPolicy, Recurrent, Residual, read_policy, save_policy  # noqa: E402
from petswarm.baselines.policy import PolicySpec  # noqa: E402
from petswarm.training.ensemble import merge_students, write_merged  # noqa: E402
from petswarm_env import parallel_env  # noqa: E402
from petswarm_env.config import ConfigError  # noqa: E402


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

    tiny = {"timesteps": 120, "recurrent.samples_per_round": 60, "recurrent.updates_per_round": 2, "recurrent.members": 2,
            "recurrent.eval_every_rounds": 1,  # two rounds, each evaluated: the mean of the best and of the last differ (below)
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
    # a run folder whose members are trained already (a run stopped after them, or another choice of checkpoint): they
    # are kept, not trained again; with recurrent.member_checkpoint: last, policy.npz is the mean of their last students
    # and members_best.npz that of their best (the default run's policy.npz)
    again = tmp_path / "again"
    for m in (0, 1):
        shutil.copytree(runs[1] / f"member_{m}", again / f"member_{m}")
    cfg = load_train_config("configs/train/recurrent_command_teacher.yaml",
                            {**tiny, "num_cpus": 2, "recurrent.member_checkpoint": "last"})
    log = train_ensemble(cfg.model_copy(update={"randomize": {"swarm.num_slaves": [2, 3]}}), again, progress=None)
    assert log["members_kept"] == [0, 1] and log["timesteps"] == json.loads((runs[1] / "train_log.json").read_text())["timesteps"]
    for mine, theirs in (("policy.npz", "last.npz"), ("last.npz", "last.npz"), ("members_best.npz", "policy.npz")):
        one, two = _weights(again / mine), _weights(runs[1] / theirs)
        assert one.keys() == two.keys() and all(np.array_equal(one[k], two[k]) for k in one), mine
    assert not all(np.array_equal(a, b) for a, b in zip(_weights(runs[1] / "policy.npz").values(),
                                                          _weights(runs[1] / "last.npz").values()))


def test_a_member_folder_of_an_unfinished_or_other_run_is_refused_and_kept(tmp_path):
    from petswarm.training.config import load_train_config
    from petswarm.training.ensemble import finished_member

    cfg = load_train_config("configs/train/recurrent_command_teacher.yaml", {"recurrent.members": 1, "seed": 3})
    folder = tmp_path / "member_0"
    assert finished_member(cfg, folder) is None  # nothing there: train it
    folder.mkdir()
    (folder / "train_config.yaml").write_text(yaml.safe_dump(cfg.model_dump(mode="json")))
    (folder / "train_log.json").write_text(json.dumps({"rounds": [{"round": 0}]}))
    with pytest.raises(ConfigError, match=r"unfinished member run \(1 of 15 rounds\); remove that folder"):
        finished_member(cfg, folder)
    with pytest.raises(ConfigError, match="member run of another config; remove that folder"):
        finished_member(cfg.model_copy(update={"seed": 4}), folder)
    (folder / "train_log.json").write_text("{")
    with pytest.raises(ConfigError, match="cannot be read"):
        finished_member(cfg, folder)
    assert sorted(p.name for p in folder.iterdir()) == ["train_config.yaml", "train_log.json"]  # nothing removed


def test_a_member_that_raises_is_named_and_the_finished_ones_are_kept(tmp_path, monkeypatch):
    import petswarm.training.recurrent as recurrent
    from petswarm.training.config import load_train_config
    from petswarm.training.ensemble import MemberStopped, train_ensemble

    real = recurrent.train

    def train(cfg, out, command="", progress=print):
        if cfg.seed == 1:
            raise ValueError("a refill\nraised")
        return real(cfg, out, command=command, progress=progress)

    monkeypatch.setattr(recurrent, "train", train)
    tiny = {"timesteps": 60, "recurrent.samples_per_round": 60, "recurrent.updates_per_round": 2, "recurrent.members": 2,
            "eval.episodes": 1, "env.max_cycles": 30, "recurrent.encoder": [8], "recurrent.hidden_size": 4,
            "recurrent.head": [4], "num_cpus": 1}
    cfg = load_train_config("configs/train/recurrent_command_teacher.yaml", tiny)
    cfg = cfg.model_copy(update={"randomize": {"swarm.num_slaves": [2, 3]}})
    named = r"^member_1 \(seed 1\) stopped: a refill raised; remove '.*member_1' and run the same command again"
    with pytest.raises(MemberStopped, match=named):
        train_ensemble(cfg, tmp_path / "run", progress=None)
    assert (tmp_path / "run" / "member_0" / "last.npz").is_file() and not (tmp_path / "run" / "train_log.json").exists()
