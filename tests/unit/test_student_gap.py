"""The student-gap diagnosis: the scripted reference as the 'student' explains none of the
teacher's correction and makes none of its own; the zero-error driver is the label, bounded."""

import math

import numpy as np

from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm.training.student_gap import PHASES, LabelDriver, imitation_by_phase
from petswarm.training.warm_start import TeacherLabels
from petswarm_env.config import load_config
from petswarm_env.env import PetSwarmEnv


def _env():
    return PetSwarmEnv(load_config(overrides={"max_cycles": 80, "user.scenario": "zigzag"}))


def test_the_reference_as_student_makes_no_correction_and_explains_none():
    acc, summary = imitation_by_phase(_env(), "scripted", 3, 0.3)
    err, corr, own, n = sum(acc[p] for p in PHASES)
    assert n > 0 and corr > 0
    assert own == 0.0 and math.isclose(err, corr, rel_tol=1e-9)  # student == reference: its error is the whole correction
    assert "formation_hold_rmse_m" in summary


def test_the_label_driver_is_the_label_through_the_residual_bound():
    env = _env()
    rows, _ = env.reset(seed=4)
    for _ in range(30):  # into the episode, where the teacher and the reference differ
        rows, _, _, _, _ = env.step(make_policy("scripted", PolicySpec.from_env(env)).act_all({a: rows[a] for a in env.active_agents}))
    seen = {a: rows[a] for a in env.active_agents}
    label = TeacherLabels(env)(seen)
    free = LabelDriver(env, None).act_all(seen)
    assert all(np.array_equal(free[a], label[a]) for a in seen)
    bounded = LabelDriver(env, 0.1).act_all(seen)
    base = make_policy("scripted", PolicySpec.from_env(env)).act_all(seen)
    assert all(np.all(np.abs(bounded[a] - base[a]) <= 0.1 + 1e-6) for a in seen)
    assert any(not np.allclose(bounded[a], label[a]) for a in seen)  # the bound cuts something here


def test_the_draws_of_a_training_config_are_diagnosed_too():
    from petswarm.training.student_gap import diagnose_draws

    out = diagnose_draws("configs/train/recurrent.yaml", "scripted", [777000])
    assert out["seeds"] == [777000]
    steps = sum(p["steps"] for p in out["phases"].values())
    assert steps > 0 and all(p["rms_student_correction"] == 0.0 for p in out["phases"].values() if p["steps"])
    assert out["phases"]["building"]["explained"] == 0.0  # the reference as student: none of the teacher's correction
