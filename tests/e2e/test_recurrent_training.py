"""A short recurrent run through ``petswarm train --config recurrent``: DAgger rounds from the
privileged teacher, the best evaluation as policy.npz, the last round as last.npz; the run
refuses to resume or to overwrite."""

import json

import numpy as np
import pytest

pytest.importorskip("torch")

from petswarm.baselines.learned import LearnedPolicy, RecurrentPolicy, read_policy_file  # noqa: E402
from petswarm.baselines.policy import PolicySpec  # noqa: E402
from petswarm.evaluation.runner import run_episode  # noqa: E402
from petswarm.training.recurrent import train_recurrent  # noqa: E402
from petswarm.training.train import train_command  # noqa: E402
from petswarm_env import parallel_env  # noqa: E402
from petswarm_env.config import ConfigError  # noqa: E402

SHORT = ["env.max_cycles=60", "eval.max_cycles=60", "eval.episodes=2", "recurrent.samples_per_round=300",
         "recurrent.updates_per_round=3", "recurrent.batch_sequences=4", "recurrent.encoder=[16]", "recurrent.head=[8]",
         "recurrent.hidden_size=8", "recurrent.eval_every_rounds=1"]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("runs") / "rec"
    assert train_command("configs/train/recurrent.yaml", SHORT, 600, str(out), False, False, "petswarm train --config recurrent") == 0
    return out, json.loads((out / "train_log.json").read_text())


def test_the_rounds_are_driven_by_the_teacher_then_the_student(run):
    out, log = run
    assert [r["driver"] for r in log["rounds"]] == ["teacher", "student"]
    assert {r["learning_rate"] for r in log["rounds"]} == {0.002}  # recurrent.yaml: no decay
    assert log["timesteps"] == sum(r["samples"] for r in log["rounds"]) >= 600
    assert len(log["evaluations"]) == 2 and log["best"]["timesteps"] in {e["timesteps"] for e in log["evaluations"]}
    assert log["command"] == "petswarm train --config recurrent"


def test_policy_npz_is_the_best_evaluation_and_last_npz_the_last_round(run):
    out, log = run
    best, _ = read_policy_file(out / "policy.npz")
    last, _ = read_policy_file(out / "last.npz")
    assert best["info"]["selected"]["timesteps"] == log["best"]["timesteps"]
    assert last["info"]["timesteps"] == log["timesteps"]
    assert best["recurrent"]["hidden_size"] == 8 and best["info"]["train_config"]["algorithm"] == "recurrent"
    env = parallel_env(max_cycles=40)
    policy = LearnedPolicy.load(out / "policy.npz", PolicySpec.from_env(env))
    assert isinstance(policy, RecurrentPolicy)
    summary = run_episode(env, policy, seed=3)
    assert np.isfinite(summary["formation_rmse_m"])


def test_a_recurrent_run_is_not_resumed_nor_overwritten(run):
    out, _ = run
    with pytest.raises(ConfigError, match="not resumable"):
        train_command("configs/train/recurrent.yaml", SHORT, 600, str(out), True, False, "")
    with pytest.raises(ConfigError, match="already holds a run"):
        train_recurrent("recurrent", 600, 0, out)


def test_a_validation_split_is_held_out_of_the_fit_and_logged(tmp_path):
    out = tmp_path / "val"
    short = [s for s in SHORT if not s.startswith(("recurrent.samples_per_round", "recurrent.updates_per_round"))] + [
        "recurrent.samples_per_round=600", "recurrent.updates_per_round=4", "recurrent.validation_fraction=0.5",
        "recurrent.validation_every=2", "recurrent.early_stopping=true"]
    assert train_command("configs/train/recurrent.yaml", short, 1800, str(out), False, False, "") == 0
    rounds = [r for r in json.loads((out / "train_log.json").read_text())["rounds"] if "validation_sequences" in r]
    held = [r["validation_sequences"] for r in rounds]
    assert held and 0 < held[0] <= held[-1] and all(r["sequences"] + r["validation_sequences"] > r["sequences"] for r in rounds)
    assert all(np.isfinite(r["validation_loss"]) and r["validation_explained"] <= 1.0 for r in rounds)
    for r in rounds:  # the round's curve: its start, every 2 steps, its end; the kept point is the lowest held-out loss
        assert [c["update"] for c in r["curve"]] == [0, 2, 4]
        kept = [c for c in r["curve"] if c.get("kept")]
        assert len(kept) == 1 and kept[0]["validation_loss"] == min(c["validation_loss"] for c in r["curve"])
        assert r["validation_loss"] == kept[0]["validation_loss"] and np.isfinite(r["fit_loss"])


def test_a_run_of_two_students_ships_their_mean(tmp_path, capsys):
    """recurrent.members: 2 trains two students (seeds 0 and 1, each a run of its own in member_k/) and
    writes their mean as one recurrent network: policy.npz (the members' best) and last.npz."""
    out = tmp_path / "ens"
    assert train_command("configs/train/recurrent.yaml", SHORT + ["recurrent.members=2"], 600, str(out), False, False, "") == 0
    assert f"policy: {out}/policy.npz, the mean of the members' best students (median " in capsys.readouterr().out
    log = json.loads((out / "train_log.json").read_text())
    assert [m["seed"] for m in log["members"]] == [0, 1] and len(log["evaluations"]) == 1
    for k in range(2):
        member = json.loads((out / f"member_{k}" / "train_log.json").read_text())
        assert member["timesteps"] >= 600 and (out / f"member_{k}" / "policy.npz").is_file()
    env = parallel_env(**{"max_cycles": 60})
    spec = PolicySpec.from_env(env)
    for name in ("policy.npz", "last.npz"):
        policy = LearnedPolicy.load(out / name, spec)
        assert isinstance(policy, RecurrentPolicy) and policy.cell.hidden_size == 16  # two GRUs of 8
    assert read_policy_file(out / "policy.npz")[0]["info"]["members"] == 2
    with pytest.raises(ConfigError, match="already holds a run"):
        train_command("configs/train/recurrent.yaml", SHORT + ["recurrent.members=2"], 600, str(out), False, False, "")
