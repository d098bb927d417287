"""A short estimating run through ``petswarm train --config estimator``: the recurrent trainer's DAgger
rounds with the estimate as the GRU's target; its policy.npz loads as an estimating policy and drives."""

import json

import numpy as np
import pytest

pytest.importorskip("torch")

from petswarm.baselines.estimator import OUTPUTS, EstimatorPolicy  # noqa: E402
from petswarm.baselines.learned import LearnedPolicy, read_policy  # noqa: E402
from petswarm.baselines.policy import PolicySpec  # noqa: E402
from petswarm.evaluation.runner import run_episode  # noqa: E402
from petswarm.training.config import load_train_config  # noqa: E402
from petswarm.training.train import train_command  # noqa: E402
from petswarm_env import parallel_env  # noqa: E402
from petswarm_env.config import ConfigError  # noqa: E402

SHORT = ["env.max_cycles=60", "eval.max_cycles=60", "eval.episodes=2", "recurrent.samples_per_round=300",
         "recurrent.updates_per_round=3", "recurrent.batch_sequences=4", "recurrent.encoder=[16]", "recurrent.head=[8]",
         "recurrent.hidden_size=8", "recurrent.eval_every_rounds=1"]


def test_an_estimating_run_trains_and_ships_an_estimating_policy(tmp_path):
    out = tmp_path / "est"
    assert train_command("configs/train/estimator.yaml", SHORT, 600, str(out), False, False, "petswarm train --config estimator") == 0
    log = json.loads((out / "train_log.json").read_text())
    assert [r["driver"] for r in log["rounds"]] == ["teacher", "student"]
    assert all(np.isfinite(r["loss"]) for r in log["rounds"])
    for name in ("policy.npz", "last.npz"):
        meta, layers, cell = read_policy(out / name)
        assert meta["estimator"]["outputs"] == list(OUTPUTS) and layers[-1][0].shape[0] == len(OUTPUTS)
        assert "residual_of" not in meta and cell is not None
        assert meta["info"]["train_config"]["recurrent"]["target"] == "estimate"
    env = parallel_env(max_cycles=40)
    policy = LearnedPolicy.load(out / "policy.npz", PolicySpec.from_env(env))
    assert isinstance(policy, EstimatorPolicy)
    assert np.isfinite(run_episode(env, policy, seed=3)["formation_rmse_m"])


def test_an_estimate_target_refuses_a_residual(tmp_path):
    with pytest.raises(ConfigError, match="residual_of: null"):
        train_command("configs/train/estimator.yaml", SHORT + ["residual_of=scripted"], 600, str(tmp_path / "x"), False, False, "")
    assert load_train_config("configs/train/estimator.yaml").recurrent.target == "estimate"
