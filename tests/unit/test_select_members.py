"""training/select_members.py: an ensemble keeps the members that hold best alone on validation cells."""

import json
import math
import shutil

import numpy as np
import pytest

pytest.importorskip("torch")

from petswarm.baselines.learned import GRUCell, Recurrent, Residual, save_policy  # noqa: E402
from petswarm.baselines.policy import PolicySpec  # noqa: E402
from petswarm.training.config import load_train_config  # noqa: E402
from petswarm.training.select_members import geometric_mean, score_members  # noqa: E402
from petswarm_env import parallel_env  # noqa: E402
from petswarm_env.config import ConfigError  # noqa: E402

GRID = """seed: 900000000
episodes: 1
set: {max_cycles: 150, swarm.num_slaves: 2}
cells:
  - {name: wedge straight, set: {user.scenario: straight, swarm.formation: wedge}}
  - {name: column zigzag, set: {user.scenario: zigzag, swarm.formation: column}}
"""


def _student(path, layout, bias):
    """A recurrent residual student of the scripted reference whose correction is the constant ``bias`` (its last
    layer's weights zero): 0 drives as the reference does, a large one pushes every robot the same way."""
    encoder, hidden, head = 8, 4, 5
    layers = [(np.zeros((encoder, layout.size)), np.zeros(encoder))]
    cell = GRUCell(np.zeros((3 * hidden, encoder)), np.zeros((3 * hidden, hidden)), np.zeros(3 * hidden), np.zeros(3 * hidden))
    layers += [(np.zeros((head, encoder + hidden)), np.zeros(head)), (np.zeros((3, head)), np.full(3, float(bias)))]
    save_policy(path, layers, "tanh", layout, residual=Residual("scripted", 0.5), recurrent=Recurrent(1, cell))


def _config(tmp_path, **recurrent):
    (tmp_path / "grid.yaml").write_text(GRID)
    sets = {"recurrent.members": 3, "recurrent.keep_members": 1, "recurrent.member_grid": str(tmp_path / "grid.yaml"),
            "recurrent.member_seeds": [900000000, 900000010], "num_cpus": 1}
    return load_train_config("configs/train/recurrent_eight_students.yaml",
                             {**sets, **{f"recurrent.{k}": v for k, v in recurrent.items()}})


def test_the_score_is_the_geometric_mean_and_a_cell_without_a_ratio_makes_it_infinite():
    assert geometric_mean([0.5, 2.0]) == pytest.approx(1.0) and geometric_mean([0.8]) == pytest.approx(0.8)
    assert geometric_mean([0.5, math.nan]) == math.inf and geometric_mean([0.0, 1.0]) == math.inf
    assert geometric_mean([]) == math.inf


def test_the_member_that_drives_as_the_reference_scores_one_and_a_pushing_member_is_not_chosen(tmp_path):
    env = parallel_env()
    layout = PolicySpec.from_env(env).layout
    env.close()
    paths = [tmp_path / f"m{k}.npz" for k in range(3)]
    for p, bias in zip(paths, (3.0, 0.0, -3.0)):
        _student(p, layout, bias)
    shutil.copy(paths[1], tmp_path / "copy.npz")
    lines = []
    # member 1 offers two students of the same weights (driven once), member 2 a pushing one and one with no correction
    record = score_members(_config(tmp_path), [[paths[0]], [paths[1], tmp_path / "copy.npz"], [paths[2], paths[1]]],
                           progress=lines.append)
    assert lines[0].startswith("scoring 4 students of 3 members")
    m0, m1, m2 = record["members"]
    assert m1["score"] == 1.0  # no correction: every episode the reference's, bit for bit, on every cell and seed
    assert m0["score"] > 1.0 and m2["scores"][0] > 1.0  # half the speed limit pushed one way the whole episode holds worse
    assert (m1["student"], m1["scores"]) == (0, [1.0, 1.0]) and (m2["student"], m2["score"], m2["file"]) == (1, 1.0, "m1.npz")
    assert record["chosen"] == [1]  # members 1 and 2 tie: the lower is kept
    assert record["seeds"] == [900000000, 900000010] and record["episodes"] == 1
    json.dumps(record)  # the train log's record


def test_keep_members_is_checked_against_members_and_the_seeds_are_held_out_ones(tmp_path):
    with pytest.raises(ConfigError, match=r"keep_members \(3\) must be below recurrent.members \(3\)"):
        _config(tmp_path, keep_members=3)
    with pytest.raises(ConfigError, match="member_seeds"):
        _config(tmp_path, member_seeds=[1000])


def test_an_unreadable_validation_grid_stops_the_run_before_any_member_trains(tmp_path):
    from petswarm.training.ensemble import train_ensemble

    cfg = _config(tmp_path, member_grid=str(tmp_path / "missing.yaml"))
    with pytest.raises(ConfigError, match="missing.yaml"):
        train_ensemble(cfg, tmp_path / "run", progress=None)
    assert not any((tmp_path / "run").glob("member_*"))


def _weights(path):
    with np.load(path, allow_pickle=False) as f:
        return {k: f[k] for k in f.files if k != "meta"}


@pytest.mark.parametrize("checkpoint", ["best", "validated"])
def test_an_ensemble_run_ships_the_mean_of_its_chosen_members_and_the_mean_of_all_beside(tmp_path, checkpoint):
    from petswarm.baselines.learned import read_policy
    from petswarm.training.ensemble import finished_member, train_ensemble, write_merged

    (tmp_path / "grid.yaml").write_text(GRID)
    tiny = {"timesteps": 120, "recurrent.samples_per_round": 60, "recurrent.updates_per_round": 2, "recurrent.members": 2,
            "eval.episodes": 1, "env.max_cycles": 30, "recurrent.encoder": [8], "recurrent.hidden_size": 4,
            "recurrent.head": [4], "num_cpus": 1, "recurrent.keep_members": 1,
            "recurrent.member_grid": str(tmp_path / "grid.yaml"), "recurrent.member_seeds": [900000000],
            "recurrent.eval_every_rounds": 1, "recurrent.member_checkpoint": checkpoint}  # two rounds: best and last can differ
    cfg = load_train_config("configs/train/recurrent_command_teacher.yaml", tiny)
    cfg = cfg.model_copy(update={"randomize": {"swarm.num_slaves": [2, 3]}})
    run = tmp_path / "run"
    log = train_ensemble(cfg, run, progress=None)
    record = log["member_validation"]
    scores = [m["score"] for m in record["members"]]
    assert len(scores) == 2 and record["chosen"] == [min((0, 1), key=lambda m: (scores[m], m))]
    for r in record["members"]:  # a member stands for its student of the lower score (its best where they tie)
        assert r["file"] == ("policy.npz" if checkpoint == "best" else ["policy.npz", "last.npz"][r["student"]])
        assert r["score"] == min(r["scores"]) and r["scores"].index(r["score"]) == r["student"]
    assert json.loads((run / "train_log.json").read_text())["member_validation"]["chosen"] == record["chosen"]
    layout = PolicySpec.from_env(parallel_env()).layout
    c = record["chosen"][0]
    own = [record["members"][m]["file"] for m in (0, 1)]
    for mine, students in (("policy.npz", [run / f"member_{c}" / own[c]]), ("last.npz", [run / f"member_{c}/last.npz"]),
                           ("members_all.npz", [run / f"member_{m}" / own[m] for m in (0, 1)])):
        write_merged(students, tmp_path / "expected.npz", layout, {"members": len(students)})
        one, two = _weights(run / mine), _weights(tmp_path / "expected.npz")
        assert one.keys() == two.keys() and all(np.array_equal(one[k], two[k]) for k in one), mine
    # the same command run again keeps its members: each one's config reads back (as one student) and is the same
    one = cfg.recurrent.model_copy(update={"members": 1, "keep_members": 0})
    assert finished_member(cfg.model_copy(update={"seed": cfg.seed + 1, "recurrent": one}), run / "member_1") is not None
    meta, _, _ = read_policy(run / "policy.npz")
    assert meta["info"]["members"] == 1 and meta["info"]["members_chosen"] == record["chosen"]
