"""`petswarm benchmark` end to end on a tiny budget: the runs, the resume, the page, bad input."""

import json

import pytest
import yaml

pytest.importorskip("stable_baselines3")

from petswarm.cli.main import main
from petswarm.training.benchmark import ALGORITHMS, Algorithm, load_benchmark_config, run_benchmark

TINY = {
    "seed": 910000000,
    "episodes": 2,
    "training_seeds": [0, 1, 2],
    "set": {"max_cycles": 60},
    "train": {"num_cpus": 0, "num_envs": 1, "ppo.n_steps": 16, "ppo.batch_size": 32, "ppo.n_epochs": 1,
              "ppo.net_arch": [16], "eval.episodes": 1, "eval.max_cycles": 30, "eval.every_steps": 10**6,
              "checkpoint.every_steps": 10**6},
    "tasks": {"wedge_following": {"swarm.formation": "wedge", "user.scenario": "zigzag"}},
    "algorithms": {"scripted": {}, "ippo": {"timesteps": 64, "pretrain.samples": 0}, "unbuilt": {}},
}


def _write(tmp_path, data, name="bench.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


UNBUILT = Algorithm("unbuilt", "a row whose trainer this petswarm lacks", unavailable=lambda: "its trainer is not here")


@pytest.fixture(scope="module", autouse=True)
def unbuilt_row():
    """A row that cannot run in this petswarm: reported "not run", with its reason."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setitem(ALGORITHMS, "unbuilt", UNBUILT)
        yield


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("benchmark")
    config = _write(tmp, TINY)
    code = main(["benchmark", "--config", str(config), "--json", str(tmp / "b.json"), "--out", str(tmp / "runs"),
                 "--md", str(tmp / "bench.md")])
    assert code == 0
    return tmp, config


def test_every_seed_of_every_algorithm_is_trained_and_evaluated_on_the_held_out_seeds(tiny):
    tmp, _ = tiny
    data = json.loads((tmp / "b.json").read_text())
    assert sorted(data["runs"]) == ["wedge_following/ippo/0", "wedge_following/ippo/1", "wedge_following/ippo/2",
                                    "wedge_following/scripted/-"]
    for run in data["runs"].values():
        assert [e["seed"] for e in run["episodes"]] == [910000000, 910000001]
        assert run["status"] == "done" and "formation_hold_rmse_m" in run["episodes"][0]
    ippo = [data["runs"][f"wedge_following/ippo/{s}"] for s in range(3)]
    assert all(r["agent_steps"] >= 64 and r["wall_time_s"] > 0 for r in ippo)
    assert len({r["policy"] for r in ippo}) == 3 and all((tmp / "runs").glob("wedge_following/ippo/seed*/last.npz"))
    assert data["not_run"]["unbuilt"] == "its trainer is not here"
    row = data["summary"]["tasks"]["wedge_following"]["ippo"]
    assert row["runs"] == 3 and row["episodes"] == 6 and 0 <= row["p_improvement"] <= 1
    assert set(row["by_metric"]) == {"formation_hold_rmse_m", "formation_rmse_m"}  # both scores, each with its interval
    whole = row["by_metric"]["formation_rmse_m"]
    assert whole["iqm_ci95"][0] <= whole["iqm"] <= whole["iqm_ci95"][1]


def test_the_page_has_a_row_per_algorithm_with_cis_and_the_plot(tiny):
    tmp, _ = tiny
    page = (tmp / "bench.md").read_text()
    assert "| ippo | 3 × 2 |" in page and "| scripted | 1 × 2 |" in page
    assert "| unbuilt | not run: its trainer is not here |" in page and "![IQM with 95 % CIs per task](bench.png)" in page
    assert (tmp / "bench.png").read_bytes()[:4] == b"\x89PNG"


def test_a_second_run_keeps_the_finished_runs(tiny):
    tmp, config = tiny
    said = []
    before = json.loads((tmp / "b.json").read_text())["runs"]
    after = run_benchmark(load_benchmark_config(config), tmp / "b.json", tmp / "runs", say=said.append)["runs"]
    assert said == [] and json.dumps(after, sort_keys=True, allow_nan=True) == json.dumps(before, sort_keys=True)


def test_a_changed_task_runs_again(tmp_path, tiny):
    tmp, _ = tiny
    changed = {**TINY, "tasks": {"wedge_following": {"swarm.formation": "column", "user.scenario": "zigzag"}},
               "algorithms": {"scripted": {}}}
    said = []
    run_benchmark(load_benchmark_config(_write(tmp_path, changed)), tmp / "b.json", tmp / "runs", say=said.append)
    assert len(said) == 1 and said[0].startswith("[1/1] wedge_following/scripted/-")


@pytest.mark.parametrize("change, words", [
    ({"algorithms": {"scripted": {}, "qmix": {}}}, "unknown algorithm 'qmix'"),
    ({"algorithms": {"ippo": {}}}, "must include 'scripted'"),
    ({"tasks": {"t": {"swarm.formaton": "wedge"}}}, "task 't'"),
    ({"algorithms": {"scripted": {"timesteps": 5}}}, "is not trained here"),
    ({"algorithms": {"scripted": {}, "ippo": {"ppo.n_step": 5}}}, "algorithm 'ippo'"),
    ({"training_seeds": [1, 1]}, "training_seeds"),
])
def test_bad_input_is_one_line(tmp_path, capsys, change, words):
    code = main(["benchmark", "--config", str(_write(tmp_path, {**TINY, **change})), "--json", str(tmp_path / "b.json")])
    err = capsys.readouterr().err
    assert code == 2 and words in err and err.count("\n") == 1, err


def test_a_json_that_is_not_a_benchmarks_is_refused(tmp_path, capsys):
    (tmp_path / "b.json").write_text("[1, 2]")
    code = main(["benchmark", "--config", str(_write(tmp_path, TINY)), "--json", str(tmp_path / "b.json")])
    assert code == 2 and "is not a benchmark's JSON" in capsys.readouterr().err


def test_set_overrides_a_top_level_key_and_refuses_others(tmp_path):
    config = _write(tmp_path, TINY)
    assert load_benchmark_config(config, ["episodes=3"]).episodes == 3
    with pytest.raises(Exception, match="no such key"):
        load_benchmark_config(config, ["episode=3"])


def test_the_recurrent_row_trains_the_teacher_distilled_policy_and_reads_a_finished_run_back(tmp_path):
    pytest.importorskip("torch")
    short = {"env.max_cycles": 60, "eval.max_cycles": 60, "eval.episodes": 2, "recurrent.samples_per_round": 300,
             "recurrent.updates_per_round": 3, "recurrent.batch_sequences": 4, "recurrent.encoder": [16],
             "recurrent.head": [8], "recurrent.hidden_size": 8, "recurrent.eval_every_rounds": 1, "timesteps": 600}
    out = tmp_path / "rec"
    trained = ALGORITHMS["recurrent"].train(short, out, 3)
    assert trained.policy == str(out / "policy.npz") and (out / "policy.npz").exists()
    assert trained.agent_steps >= 600 and trained.detail["rounds"] == 2 and trained.wall_time_s > 0
    assert "seed: 3" in (out / "train_config.yaml").read_text()
    again = ALGORITHMS["recurrent"].train(short, out, 3)  # a finished run is read back, not retrained
    assert again == trained
