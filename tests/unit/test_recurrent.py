"""The recurrent policy: numpy inference equals torch's, its hidden state restarts when a robot
(re)joins, its file format round-trips and refuses what does not fit; the DAgger budget scales."""

import json

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from petswarm.baselines.learned import (  # noqa: E402
    LearnedPolicy, PolicyLoadError, RecurrentPolicy, read_policy, read_policy_file)
from petswarm.baselines.policy import PolicySpec  # noqa: E402
from petswarm.training.config import load_train_config  # noqa: E402
from petswarm.training.recurrent import RecurrentActor, export_actor, numpy_policy, round_learning_rate, rounds_for  # noqa: E402
from petswarm_env import parallel_env  # noqa: E402
from petswarm_env.config import ConfigError  # noqa: E402


@pytest.fixture(scope="module")
def spec():
    return PolicySpec.from_env(parallel_env())


def _actor(spec, encoder=(32,), head=(16,), seed=0):
    torch.manual_seed(seed)
    actor = RecurrentActor(spec.layout.size, list(encoder), 12, list(head))
    with torch.no_grad():  # larger weights than the default init: the gates and the memory matter
        for p in actor.parameters():
            p.mul_(3.0)
    return actor


def _torch_actions(actor, seq: np.ndarray) -> np.ndarray:
    with torch.no_grad():
        out, _ = actor(torch.as_tensor(seq[None], dtype=torch.float32))
    return np.clip(out[0].numpy(), -1.0, 1.0)


@pytest.mark.parametrize("encoder,head", [((32,), (16,)), ((), (16,)), ((32, 24), ())])
def test_numpy_inference_equals_torch_over_a_sequence(spec, encoder, head):
    actor = _actor(spec, encoder, head)
    policy = numpy_policy(actor, spec)
    rng = np.random.default_rng(1)
    seqs = {a: rng.uniform(-1, 1, (40, spec.layout.size)).astype(np.float32) for a in ("robot_1", "robot_2")}
    got = {a: [] for a in seqs}
    policy.reset(0)
    for t in range(40):
        for a, act in policy.act_all({a: s[t] for a, s in seqs.items()}).items():
            got[a].append(act)
    for a, s in seqs.items():
        want = _torch_actions(actor, s)
        assert np.abs(np.stack(got[a]) - want).max() < 1e-5
        assert np.abs(want[1:] - want[:-1]).max() > 1e-3  # the actions change: the check is not vacuous


def test_the_memory_matters_and_restarts_at_reset_and_when_a_robot_rejoins(spec):
    actor = _actor(spec)
    policy = numpy_policy(actor, spec)
    rng = np.random.default_rng(2)
    s = rng.uniform(-1, 1, (12, spec.layout.size)).astype(np.float32)
    fresh = _torch_actions(actor, s)
    policy.reset(0)
    steps = [policy.act_all({"robot_1": s[t], "robot_2": s[t]}) for t in range(6)]
    # robot_1 leaves slave-role driving for a step, then rejoins with s[6:]: its memory starts again
    policy.act_all({"robot_2": s[6]})
    again = [policy.act_all({"robot_1": s[t], "robot_2": s[t]})["robot_1"] for t in range(6, 12)]
    assert np.abs(np.stack(again) - _torch_actions(actor, s[6:])).max() < 1e-5
    assert np.abs(np.stack([x["robot_1"] for x in steps]) - fresh[:6]).max() < 1e-5
    # the same frame after a different history gives another action: the policy remembers
    assert np.abs(again[0] - fresh[6]).max() > 1e-3
    # the same with robot_1 passed as the env pads a waiting agent (zeros) instead of left out
    policy.reset(3)
    for t in range(6):
        policy.act_all({"robot_1": s[t], "robot_2": s[t]})
    policy.act_all({"robot_1": np.zeros_like(s[0]), "robot_2": s[6]})
    padded = [policy.act_all({"robot_1": s[t], "robot_2": s[t]})["robot_1"] for t in range(6, 12)]
    assert np.abs(np.stack(padded) - np.stack(again)).max() < 1e-6
    policy.reset(1)
    assert np.abs(policy.act_all({"robot_2": s[0]})["robot_2"] - fresh[0]).max() < 1e-5
    # act(), robot by robot: a round in which no robot is asked twice is one step
    policy.reset(2)
    per_agent = [[policy.act(a, s[t]) for a in ("robot_1", "robot_2")] for t in range(6)]
    assert np.abs(np.stack([p[0] for p in per_agent]) - fresh[:6]).max() < 1e-5


def test_a_recurrent_file_round_trips_and_loads_as_learned(spec, tmp_path):
    actor = _actor(spec)
    export_actor(actor, tmp_path / "r.npz", spec.layout, {"command": "test"})
    meta, layers, recurrent = read_policy(tmp_path / "r.npz")
    assert meta["format_version"] == 2 and meta["recurrent"] == {"cell": "gru", "hidden_size": 12, "encoder_layers": 1}
    assert len(read_policy_file(tmp_path / "r.npz")[1]) == len(layers) == 3
    loaded = LearnedPolicy.load(tmp_path / "r.npz", spec)
    assert isinstance(loaded, RecurrentPolicy)
    rng = np.random.default_rng(3)
    s = rng.uniform(-1, 1, (10, spec.layout.size)).astype(np.float32)
    got = np.stack([loaded.act_all({"robot_1": x})["robot_1"] for x in s])
    assert np.abs(got - _torch_actions(actor, s)).max() < 1e-5
    with pytest.raises(TypeError, match="no one-frame forward"):
        loaded.forward(s[0])


def _rewrite(src, dst, change):
    arrays = dict(np.load(src))
    meta = json.loads(arrays["meta"].tobytes())
    change(meta, arrays)
    arrays["meta"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    np.savez(dst, **arrays)


@pytest.mark.parametrize("change,field", [
    (lambda m, a: a.pop("gru_w_hh"), "gru_w_hh"),
    (lambda m, a: a.__setitem__("gru_b_ih", a["gru_b_ih"][:5]), "gru_b_ih"),
    (lambda m, a: m.pop("recurrent"), "recurrent"),
    (lambda m, a: m["recurrent"].__setitem__("cell", "lstm"), "recurrent"),
    (lambda m, a: m["recurrent"].__setitem__("hidden_size", 13), "w1"),
    (lambda m, a: m.__setitem__("format_version", 1), "recurrent"),
    (lambda m, a: m.update(residual_of="learned"), "residual_of"),
])
def test_a_damaged_recurrent_file_is_refused_by_field(spec, tmp_path, change, field):
    export_actor(_actor(spec), tmp_path / "r.npz", spec.layout, {})
    _rewrite(tmp_path / "r.npz", tmp_path / "bad.npz", change)
    with pytest.raises(PolicyLoadError, match=field):
        LearnedPolicy.load(tmp_path / "bad.npz", spec)


def test_the_dagger_budget_scales_with_timesteps():
    cfg = load_train_config("configs/train/recurrent.yaml")
    per = cfg.recurrent.samples_per_round
    assert rounds_for(cfg) == cfg.timesteps // per
    assert rounds_for(load_train_config("configs/train/recurrent.yaml", {"timesteps": 5 * per})) == 5
    assert rounds_for(load_train_config("configs/train/recurrent.yaml", {"timesteps": 1})) == 1
    with pytest.raises(ConfigError, match="timesteps > 0"):
        load_train_config("configs/train/recurrent.yaml", {"timesteps": 0})


def test_the_learning_rate_decays_linearly_over_the_rounds_when_asked():
    constant = load_train_config("configs/train/recurrent.yaml")
    assert constant.recurrent.learning_rate_final is None
    assert {round_learning_rate(constant, k, 5) for k in range(5)} == {constant.recurrent.learning_rate}
    cfg = load_train_config("configs/train/recurrent.yaml", {"recurrent.learning_rate": 0.002, "recurrent.learning_rate_final": 0.0004})
    rates = [round_learning_rate(cfg, k, 5) for k in range(5)]
    assert rates[0] == 0.002 and rates[-1] == pytest.approx(0.0004)
    assert np.allclose(np.diff(rates), -0.0004)
    assert round_learning_rate(cfg, 0, 1) == 0.002  # one round: the first rate
    with pytest.raises(ConfigError, match="learning_rate_final"):
        load_train_config("configs/train/recurrent.yaml", {"recurrent.learning_rate_final": -1.0})


def test_the_long_config_differs_from_the_committed_one_only_where_it_says():
    base, long = load_train_config("configs/train/recurrent.yaml"), load_train_config("configs/train/recurrent_long.yaml")
    assert rounds_for(long) == 3 * rounds_for(base)
    assert (long.recurrent.updates_per_round, long.recurrent.learning_rate_final) == (400, 0.0003)
    same = {**long.model_dump(), "timesteps": base.timesteps,
            "recurrent": {**long.model_dump()["recurrent"], "learning_rate_final": None, "updates_per_round": 250}}
    assert same == base.model_dump()


def test_the_validated_config_is_the_long_one_with_a_split_and_early_stopping_only():
    long, val = load_train_config("configs/train/recurrent_long.yaml"), load_train_config("configs/train/recurrent_val.yaml")
    r = val.recurrent
    assert (r.validation_fraction, r.validation_every, r.early_stopping, r.encoder_dropout, r.weight_decay) == (0.2, 25, True, 0.2, 0.0)
    changed = {"validation_fraction", "validation_every", "early_stopping", "encoder_dropout"}
    same = {**val.model_dump(), "recurrent": {k: v for k, v in val.model_dump()["recurrent"].items() if k not in changed}}
    assert same == {**long.model_dump(), "recurrent": {k: v for k, v in long.model_dump()["recurrent"].items() if k not in changed}}


def test_a_residual_recurrent_policy_corrects_the_scripted_reference(spec, tmp_path):
    from petswarm.baselines.learned import Residual
    from petswarm.baselines.registry import make_policy

    actor = _actor(spec)
    export_actor(actor, tmp_path / "rr.npz", spec.layout, {}, Residual("scripted", 0.5))
    policy = LearnedPolicy.load(tmp_path / "rr.npz", spec)
    assert isinstance(policy, RecurrentPolicy) and policy.residual == Residual("scripted", 0.5)
    env = parallel_env()
    obs, _ = env.reset(seed=0)
    agent, o = next(iter(obs.items()))
    base = make_policy("scripted", spec).act(agent, o)
    want = np.clip(base + 0.5 * _torch_actions(actor, o[None])[0], -1.0, 1.0)
    assert np.abs(policy.act_all({agent: o})[agent] - want).max() < 1e-5


class _FirstResetFails:
    """A training env whose first reset raises the swarm's OrganizeError (a draw that never organizes)."""

    def __init__(self, env):
        self._env, self.seeds = env, []

    def __getattr__(self, name):
        return getattr(self._env, name)

    def reset(self, seed=None, options=None):
        from petswarm_env.middleware.join import OrganizeError

        self.seeds.append(seed)
        if len(self.seeds) == 1:
            raise OrganizeError("user 0's swarm did not organize (a test)", seed, "a test")
        if len(self.seeds) == 2:  # the env raises this one as a plain RuntimeError (petswarm_env/episode.py)
            raise RuntimeError("user 0's belt never woke up (a test)")
        return self._env.reset(seed=seed, options=options)


def test_a_draw_that_never_organizes_is_skipped_not_fatal():
    from petswarm.training.recurrent import collect_sequences
    from petswarm.training.vec_env import training_env

    cfg = load_train_config("configs/train/recurrent.yaml", {"env.max_cycles": 40})
    env = _FirstResetFails(training_env(cfg.env_config(), cfg.randomize, cfg.env, False))
    seqs, counts = collect_sequences(env, 50, 7, cfg, None, 0.0)
    assert counts["unorganized"] == 2 and counts["samples"] >= 50 and seqs
    assert env.seeds[:3] == [7, 8, 9]  # the next seed, not the same one again


def test_the_validation_loss_of_a_zero_output_explains_nothing(spec):
    from petswarm.training.recurrent import Sequence, validation_loss

    actor = _actor(spec)
    with torch.no_grad():
        actor.head[-1].weight.zero_()
        actor.head[-1].bias.zero_()
    rng = np.random.default_rng(0)
    seqs = [Sequence(rng.normal(size=(n, spec.layout.size)).astype(np.float32), rng.normal(size=(n, 3)).astype(np.float32),
                     rng.uniform(1, 3, n).astype(np.float32)) for n in (5, 9, 2)]
    loss, zero = validation_loss(actor, seqs, 2)
    assert loss == pytest.approx(zero) and zero > 0
    y = np.concatenate([s.act for s in seqs]); w = np.concatenate([s.weight for s in seqs])
    assert zero == pytest.approx(float((w * (y ** 2).sum(1)).sum() / len(w)), rel=1e-5)


def _random_sequences(spec, lengths, seed):
    from petswarm.training.recurrent import Sequence

    rng = np.random.default_rng(seed)
    return [Sequence(rng.uniform(-1, 1, (n, spec.layout.size)).astype(np.float32), rng.uniform(-1, 1, (n, 3)).astype(np.float32),
                     np.ones(n, np.float32), e) for e, n in enumerate(lengths)]


def test_early_stopping_keeps_the_weights_of_the_lowest_held_out_loss(spec):
    from petswarm.training.recurrent import fit, validation_loss

    # noise targets: what the fit learns of 6 sequences does not carry to 6 others, so the held-out loss rises
    data, held = _random_sequences(spec, [30] * 6, 1), _random_sequences(spec, [30] * 6, 2)
    for keep in (False, True):
        actor = _actor(spec, seed=3)
        opt = torch.optim.Adam(actor.parameters(), lr=3e-3)
        loss, curve = fit(actor, opt, data, 60, 4, np.random.default_rng(0), held, every=10, keep_best=keep)
        assert [c["update"] for c in curve] == [0, 10, 20, 30, 40, 50, 60]
        assert curve[-1]["fit_loss"] < curve[0]["fit_loss"] and np.isfinite(loss)  # the fit learns its own sequences
        end, _ = validation_loss(actor, held, 4)
        best = min(c["validation_loss"] for c in curve)
        assert best < curve[-1]["validation_loss"]  # the check is not vacuous: the last step is not the best
        if keep:
            assert end == pytest.approx(best, rel=1e-5) and sum(c.get("kept", 0) for c in curve) == 1
        else:
            assert end == pytest.approx(curve[-1]["validation_loss"], rel=1e-5) and not any("kept" in c for c in curve)


def test_encoder_dropout_acts_in_the_fit_only_and_the_export_equals_the_actor(spec):
    torch.manual_seed(0)
    actor = RecurrentActor(spec.layout.size, [32], 12, [16], dropout=0.5)
    x = torch.as_tensor(np.random.default_rng(4).uniform(-1, 1, (1, 20, spec.layout.size)), dtype=torch.float32)
    actor.train()
    with torch.no_grad():
        assert not torch.allclose(actor(x)[0], actor(x)[0])  # two draws of the mask
    actor.eval()
    policy = numpy_policy(actor, spec)
    policy.reset(0)
    got = np.stack([policy.act_all({"robot_1": x[0, t].numpy()})["robot_1"] for t in range(20)])
    assert np.abs(got - _torch_actions(actor, x[0].numpy())).max() < 1e-5


def test_weight_decay_and_early_stopping_are_opt_in_and_checked():
    from petswarm.training.recurrent import optimizer

    base = load_train_config("configs/train/recurrent_long.yaml")
    r = base.recurrent
    assert (r.validation_every, r.early_stopping, r.weight_decay, r.encoder_dropout) == (0, False, 0.0, 0.0)
    actor = RecurrentActor(10, [8], 4, [4])
    assert type(optimizer(base, actor)) is torch.optim.Adam
    decayed = base.model_copy(update={"recurrent": r.model_copy(update={"weight_decay": 0.01})})
    opt = optimizer(decayed, actor)
    assert isinstance(opt, torch.optim.AdamW) and opt.param_groups[0]["weight_decay"] == 0.01
    with pytest.raises(ConfigError, match="validation_fraction"):
        load_train_config("configs/train/recurrent_long.yaml", {"recurrent.early_stopping": True})


def test_a_validation_split_holds_whole_episodes_out(spec):
    from petswarm.training.recurrent import split_episodes

    seqs = _random_sequences(spec, [5] * 40, 0)
    for i, s in enumerate(seqs):
        s.episode = i // 4  # 10 episodes of 4 robots' sequences
    fitted, held = split_episodes(seqs, 0.4, np.random.default_rng(1))
    assert len(fitted) + len(held) == 40 and fitted and held
    assert not {s.episode for s in fitted} & {s.episode for s in held}
    assert len(held) % 4 == 0  # every sequence of a held-out episode


def test_the_contact_and_last_round_configs_differ_only_where_they_say():
    long, near = load_train_config("configs/train/recurrent_long.yaml"), load_train_config("configs/train/recurrent_near.yaml")
    weights = {"near_m": 0.3, "near_weight": 2.0, "contact_window": 10, "contact_weight": 4.0}
    assert {k: getattr(near.recurrent, k) for k in weights} == weights
    assert {**near.model_dump(), "recurrent": {**near.model_dump()["recurrent"], **{k: getattr(long.recurrent, k) for k in weights}}} \
        == long.model_dump()
    val, last = load_train_config("configs/train/recurrent_val.yaml"), load_train_config("configs/train/recurrent_last.yaml")
    assert (last.recurrent.eval_every_rounds, last.recurrent.validation_every) == (100, 50)
    assert rounds_for(last) < last.recurrent.eval_every_rounds  # one periodic evaluation: after the last round
    same = {**last.model_dump(), "recurrent": {**last.model_dump()["recurrent"], "eval_every_rounds": 2, "validation_every": 25}}
    assert same == val.model_dump()


def test_the_labelling_teacher_takes_the_configs_constants(monkeypatch):
    import petswarm.training.recurrent as recurrent
    from petswarm.training.vec_env import training_env
    from petswarm.training.warm_start import TeacherLabels

    built = []

    class Recording(TeacherLabels):
        def __init__(self, env, *args, **kwargs):
            super().__init__(env, *args, **kwargs)
            built.append(self.teacher.g)

    monkeypatch.setattr(recurrent, "TeacherLabels", Recording)
    cfg = load_train_config("configs/train/recurrent.yaml", {"env.max_cycles": 30, "recurrent.teacher_push": 0.5,
                                                             "recurrent.teacher_orphan_to_slot": True})
    env = training_env(cfg.env_config(), cfg.randomize, cfg.env, False)
    recurrent.collect_sequences(env, 20, 7, cfg, None, 0.0)
    assert built and all(g == cfg.recurrent.teacher_gains() for g in built)
    assert built[0].push == 0.5 and built[0].orphan_to_slot and built[0].user_keep_out_m == 1.1
