"""The learned policy shipped with the package loads safely and holds the default formation."""

import yaml

from petswarm.baselines.learned import (LearnedPolicy, RecurrentPolicy, feed_forward_policy_path, read_policy_file,
                                        shipped_policy_path)
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm.evaluation.runner import run_episode
from petswarm.training.config import load_train_config
from petswarm_env import parallel_env
from petswarm_env.env import ENV_NAME
from petswarm_env.observe import OBS_VERSION


def test_shipped_policy_records_how_it_was_trained():
    meta, layers = read_policy_file(shipped_policy_path())
    assert meta["env_name"] == ENV_NAME and meta["observation_version"] == OBS_VERSION  # trained on the current observation
    assert meta["info"]["command"].startswith("petswarm train --config recurrent_eight_students")
    assert meta["info"]["members"] == 8 and meta["recurrent"]["hidden_size"] == 8 * 64  # eight students' GRUs, side by side
    assert meta["info"]["timesteps"] >= 2_800_000  # recurrent_eight_students.npz: eight runs of 360 000 labelled samples
    assert meta["recurrent"]["cell"] == "gru" and meta["residual_of"] == "scripted"
    assert layers[-1][0].shape[0] == 3
    # the committed config is the one it was trained with: `petswarm train --config recurrent_eight_students` runs the same
    # (keys added to the schema since, at their defaults, change nothing: recurrent.validation_fraction 0, the action
    # target, whose estimate_clip_m is not read, the contact loss weights 0, the labelling teacher's own defaults)
    committed = load_train_config("configs/train/recurrent_eight_students.yaml").model_dump(mode="json")
    trained = yaml.safe_load(yaml.safe_dump(meta["info"]["train_config"]))
    added = set(committed["recurrent"]) - set(trained["recurrent"])
    defaults = {"validation_fraction": 0.0, "target": "action", "estimate_clip_m": 1.5, "estimate_gain": 4.0,
                "validation_every": 0, "early_stopping": False, "weight_decay": 0.0, "encoder_dropout": 0.0,
                "near_m": 0.0, "near_weight": 0.0, "contact_window": 0, "contact_weight": 0.0, "closing_weight": 0.0,
                "members": 1, "member_checkpoint": "best", "keep_members": 0,
                "member_grid": "configs/eval/heldout_recurrent.yaml", "member_seeds": [940000000, 942000000, 944000000],
                "teacher_push": 1.5, "teacher_user_keep_out_m": 1.1, "teacher_orphan_to_slot": False,
                "teacher_master_command": False, "teacher_differential_gain": 4.0}
    assert added <= set(defaults) and all(committed["recurrent"][k] == defaults[k] for k in added)
    # the finetune: section (algorithm: recurrent_ppo) came later and algorithm: recurrent does not read it
    sections = {k: v for k, v in committed.items() if k in trained or k != "finetune"}
    assert trained == {**sections, "recurrent": {k: v for k, v in committed["recurrent"].items() if k not in added}}


def test_the_feed_forward_policy_is_still_shipped():
    meta, _ = read_policy_file(feed_forward_policy_path())
    assert meta["env_name"] == "petswarm_v0" and "recurrent" not in meta  # mappo_generalize.npz (docs/results.md)


def test_shipped_policy_holds_the_default_wedge():
    # from the slots (the policy trained from scattered starts over drawn configs; it holds the wedge here too)
    env = parallel_env(max_cycles=300, **{"swarm.spawn": "at_slots"})
    policy = make_policy("learned", PolicySpec.from_env(env))
    assert isinstance(policy, RecurrentPolicy)
    summary = run_episode(env, policy, seed=0)
    assert summary["formation_rmse_m"] < 0.25, summary
    assert summary["collisions"]["robot_robot"] == 0


def test_the_shipped_residual_policy_corrects_the_reference_within_its_bound():
    path = "baselines/models/residual_generalize.npz"
    meta, _ = read_policy_file(path)
    assert meta["residual_of"] == "scripted" and meta["residual_scale"] == 0.2  # configs/train/residual.yaml
    assert meta["info"]["command"].startswith("petswarm train --config configs/train/residual.yaml --out ")
    env = parallel_env(max_cycles=300, **{"swarm.spawn": "at_slots"})
    spec = PolicySpec.from_env(env)
    policy, reference = make_policy(path, spec), make_policy("scripted", spec)
    assert isinstance(policy, LearnedPolicy) and policy.residual is not None
    obs, _ = env.reset(seed=0)
    for agent, o in obs.items():  # the correction is at most 0.2 of each limit (unless the reference is clipped)
        assert max(abs(policy.act(agent, o) - reference.act(agent, o))) <= 0.2 + 1e-6
    summary = run_episode(env, policy, seed=0)
    assert summary["formation_rmse_m"] < 0.25, summary
    assert summary["collisions"]["robot_robot"] == 0
