"""Contacts in training and in diagnosis: the contact log records every contact the world counts;
the recurrent collection weighs near steps and the steps that led into a contact as configured,
from ground truth used as a loss weight only."""

import math

import numpy as np
import pytest

pytest.importorskip("torch")

from petswarm.evaluation.evaluate import make_team  # noqa: E402
from petswarm.training.config import load_train_config  # noqa: E402
from petswarm.training.contacts import trace  # noqa: E402
from petswarm.training.recurrent import collect_sequences, nearest_gaps  # noqa: E402
from petswarm.training.vec_env import training_env  # noqa: E402
from petswarm_env.config import load_config  # noqa: E402
from petswarm_env.env import PetSwarmEnv  # noqa: E402


def test_the_contact_log_records_every_contact_the_world_counts():
    # the held-out grid's heterogeneous cell: the scripted reference touches in its first 200 steps on this seed
    env = PetSwarmEnv(load_config(overrides={"user.scenario": "heterogeneous", "max_cycles": 200}))
    summary, contacts = trace(env, make_team(env, "scripted", {}, 0), 920000000)
    counted = summary["collisions"]
    assert contacts and len(contacts) == sum(counted.values())
    assert sum(c["kind"].endswith("user") for c in contacts) == counted["robot_user"]
    assert all(c["phase"] in ("holding", "building", "lost", "none") and 0 < c["step"] <= 200 for c in contacts)


def test_nearest_gaps_are_the_rim_to_rim_distances_to_the_nearest_other_body():
    env = PetSwarmEnv(load_config(overrides={"max_cycles": 30}))
    env.reset(seed=5)
    agents = env.active_agents
    gaps = nearest_gaps(env, agents)
    centers, radii, _ = env.truth.truth_arrays()
    for a in agents:
        i = env.agent_robot(a)
        want = min(math.dist(centers[i], centers[j]) - radii[i] - radii[j] for j in range(len(radii)) if j != i)
        assert gaps[a] == pytest.approx(want, abs=1e-9)


def _collect(overrides, env_wrapper=None):
    cfg = load_train_config("configs/train/recurrent.yaml", {"env.max_cycles": 40, **overrides})
    env = training_env(cfg.env_config(), cfg.randomize, cfg.env, False)
    return collect_sequences(env_wrapper(env) if env_wrapper else env, 60, 11, cfg, None, 0.0)


def test_near_steps_weigh_more_only_when_asked():
    plain, counts = _collect({})
    everywhere, near_counts = _collect({"recurrent.near_m": 100.0, "recurrent.near_weight": 2.0})
    assert counts["near"] == 0 and near_counts["near"] == near_counts["samples"]
    for a, b in zip(plain, everywhere):  # the same episodes (the weights never act on the env)
        assert np.array_equal(a.obs, b.obs) and np.allclose(b.weight, a.weight + 2.0)


class _ContactAt:
    """A training env that reports one contact begun by the first live agent at its ``step``-th step."""

    def __init__(self, env, step):
        self._env, self._step, self.n, self.agent = env, step, 0, None

    def __getattr__(self, name):
        return getattr(self._env, name)

    def step(self, actions):
        obs, rew, term, trunc, infos = self._env.step(actions)
        self.n += 1
        infos = {a: {**v, "new_contacts": 0} for a, v in infos.items()}  # no other contact
        if self.n == self._step:
            self.agent = next(a for a in actions if a in infos)
            infos[self.agent]["new_contacts"] = 1
        return obs, rew, term, trunc, infos


def test_the_steps_that_led_into_a_contact_weigh_more():
    wrapped = {}

    def wrap(env):
        wrapped["env"] = _ContactAt(env, 20)
        return wrapped["env"]

    plain, _ = _collect({}, lambda env: _ContactAt(env, 10**9))
    marked, counts = _collect({"recurrent.contact_window": 5, "recurrent.contact_weight": 3.0}, wrap)
    assert counts["contacts"] == 1
    diff = [b.weight - a.weight for a, b in zip(plain, marked)]
    touched = [d for d in diff if np.any(d != 0)]
    assert len(touched) == 1  # one robot's sequence
    (d,) = touched
    hit = np.flatnonzero(d)
    assert np.allclose(d[hit], 3.0) and len(hit) == 5 and hit[-1] - hit[0] == 4  # the five steps before it, in a row


def test_the_closing_term_costs_only_closing_faster_than_the_label_near_a_body():
    import torch

    from petswarm.training.recurrent import closing_excess

    y = torch.zeros(1, 3, 3)
    toward = torch.tensor([[[1.0, 0.0], [1.0, 0.0], [0.0, 0.0]]])  # a body ahead at steps 0 and 1; none near at step 2
    pred = torch.tensor([[[0.3, 0.5, 0.0], [-0.3, 0.0, 0.0], [0.9, 0.0, 0.0]]])
    assert closing_excess(pred, y, toward)[0].tolist() == pytest.approx([0.3, 0.0, 0.0])  # toward it: costs; away, or far: free


def test_near_steps_carry_the_direction_to_the_nearest_body_in_the_robot_frame():
    seqs, counts = _collect({"recurrent.near_m": 100.0, "recurrent.closing_weight": 1.0})
    u = np.concatenate([s.toward for s in seqs])
    assert counts["near"] == len(u) and np.allclose(np.hypot(u[:, 0], u[:, 1]), 1.0, atol=1e-5)
    plain, _ = _collect({})
    assert all(not np.any(s.toward) for s in plain)


def test_the_paired_difference_counts_and_its_interval_covers_the_draw():
    from petswarm.training.contacts import paired_difference

    def cell(cand, ref):
        return {"policies": {"a": [{"collisions": c} for c in cand], "b": [{"collisions": r} for r in ref]}}

    same = paired_difference([cell([1, 2, 0], [1, 2, 0]), cell([3], [3])], "a", "b")
    assert same["difference"] == 0 and same["ci95"] == [0.0, 0.0] and same["episodes"] == 4
    more = paired_difference([cell([2, 2, 2, 2], [0, 0, 0, 0])], "a", "b")
    assert more["difference"] == 8 and more["ci95"] == [8.0, 8.0]  # the same difference in every episode: no doubt
    mixed = paired_difference([cell([4, 0, 0, 0], [0, 0, 0, 0])], "a", "b")
    assert mixed["difference"] == 4 and mixed["ci95"][0] == 0.0 < 4.0 < mixed["ci95"][1]  # one episode's 4: could be none


def test_hold_ratios_pair_the_episodes_where_both_built():
    from petswarm.training.contacts import hold_ratios

    cell = {"policies": {"a": [{"formation_hold_rmse_m": 0.2}, {"formation_hold_rmse_m": 0.4}, {"formation_hold_rmse_m": None}],
                         "b": [{"formation_hold_rmse_m": 0.4}, {"formation_hold_rmse_m": float("nan")}, {"formation_hold_rmse_m": 0.1}]}}
    assert hold_ratios([cell], "a", "b") == [pytest.approx(0.5)]  # only the first episode pairs
