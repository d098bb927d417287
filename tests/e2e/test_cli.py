"""The petswarm command line: help, one-line errors without traceback, JSON and GIF output."""

import json
import subprocess
import sys

import pytest

from petswarm.cli.main import main


def _run(*args):
    return subprocess.run([sys.executable, "-m", "petswarm.cli.main", *args], capture_output=True, text=True, timeout=300)


def test_run_help_documents_every_option():
    out = _run("run", "--help")
    assert out.returncode == 0
    for opt in ("--config", "--set", "--policy", "--episodes", "--seed", "--json", "--render", "--video"):
        assert opt in out.stdout


@pytest.mark.parametrize(
    "args, words",
    [
        (["--set", "swarm.formaton=wedge"], "swarm.formaton"),
        (["--set", "swarm.formation=hexagon"], "swarm.formation"),
        (["--set", "user.scenario=moonwalk"], "user.scenario"),
        (["--set", "radio.loss_prob=2"], "radio.loss_prob"),
        (["--set", "nokeyvalue"], "KEY=VALUE"),
        (["--policy", "clever"], "--policy"),
        (["--episodes", "-1"], "--episodes"),
        (["--config", "/does/not/exist.yaml"], "does not exist"),
    ],
)
def test_bad_options_exit_nonzero_with_one_line(args, words):
    out = _run("run", *args)
    assert out.returncode != 0
    assert "Traceback" not in out.stderr
    lines = [ln for ln in out.stderr.splitlines() if ln.strip()]
    assert lines and words in lines[-1]
    assert lines[-1].startswith("petswarm")


def test_run_writes_json_and_gif(tmp_path, capsys):
    out = tmp_path / "res.json"
    gif = tmp_path / "ep.gif"
    code = main(["run", "--set", "max_cycles=20", "--episodes", "2", "--seed", "3", "--json", str(out), "--video", str(gif)])
    assert code == 0
    data = json.loads(out.read_text())
    assert data["summary"]["episodes"] == 2
    assert [e["seed"] for e in data["episodes"]] == [3, 4]
    assert data["config"]["max_cycles"] == 20
    assert gif.stat().st_size > 0
    printed = capsys.readouterr().out
    assert "summary:" in printed and "rmse_m" in printed and "hold_m" in printed and "formation_hold_rmse_m" in printed
    for key in ("formation_hold_rmse_m", "building_time_s", "formations_built", "refill_settle_rmse_m"):
        assert key in data["summary"], key
    assert all("formation_hold_rmse_m" in e and "building_time_s" in e for e in data["episodes"])
    assert not list(tmp_path.glob(".*"))  # no temp files left behind


def test_eval_writes_per_scenario_summaries_and_gifs_relative_to_the_json(tmp_path):
    out = tmp_path / "res" / "eval.json"
    code = main(["eval", "--scenarios", "straight,u_turn", "--episodes", "2", "--set", "max_cycles=12",
                 "--video-dir", str(tmp_path / "gifs"), "--json", str(out)])
    assert code == 0
    data = json.loads(out.read_text())
    assert set(data["scenarios"]) == {"straight", "u_turn"}
    assert all(s["episodes"] == 2 for s in data["scenarios"].values())
    gifs = [e["gif"] for e in data["episodes"] if "gif" in e]
    assert len(gifs) == 2 and all(not g.startswith("/") for g in gifs)
    assert all((out.parent / g).is_file() for g in gifs)
    assert len(data["episodes"][0]["error_trace"]) == 12


@pytest.mark.parametrize("args, words", [(["--address", "127.0.0.1:6379"], "--backend rllib"), (["--backend", "jax"], "--backend"),
                                         (["--backend", "rllib", "--vec-env", "supersuit"], "--vec-env"),
                                         (["--vec-env", "gym"], "--vec-env")])
def test_train_backend_options_are_checked_with_one_line(args, words, tmp_path):
    out = _run("train", "--out", str(tmp_path / "r"), *args)
    assert out.returncode == 2 and "Traceback" not in out.stderr
    lines = [ln for ln in out.stderr.splitlines() if ln.strip()]
    assert words in lines[-1] and lines[-1].startswith("petswarm")


@pytest.mark.parametrize("command", [["run", "--episodes", "2"], ["eval", "--scenarios", "straight", "--episodes", "1"]])
def test_a_swarm_that_organized_short_is_reported(monkeypatch, capsys, command):
    """A swarm short of swarm.num_slaves gives a warning line per episode from
    petswarm run / eval (and slaves_missing in the JSON); a full one gives none."""
    from petswarm_env.env import OTHER_USER_ID
    from petswarm_env.episode import Episode

    original = Episode._organize

    def organize_with_robot_4_taken(self):
        if self.streams[0].entropy == 7:  # only the episode with seed 7 is short
            self.fleet.nodes[4].connected_user = OTHER_USER_ID  # Table 1: it declines
        original(self)

    monkeypatch.setattr(Episode, "_organize", organize_with_robot_4_taken)
    assert main([*command, "--seed", "7", "--set", "max_cycles=10"]) == 0
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("warning:")]
    assert len(err) == 1 and "seed 7" in err[0] and "1 of 4 required slave(s) did not join" in err[0]


def test_an_rllib_training_run_as_a_program_restarts_with_a_fixed_string_hash(monkeypatch):
    """RLlib's order of agents follows Python's string hash (docs/training.md, "Deterministic runs"):
    ``petswarm train --backend rllib`` from the command line re-executes itself with PYTHONHASHSEED
    set, unless it is set; other commands and in-process calls are left alone."""
    from petswarm.cli import main as cli_main

    calls = []
    monkeypatch.setattr(cli_main.os, "execve", lambda path, argv, env: calls.append((path, argv, env["PYTHONHASHSEED"])))
    monkeypatch.delenv("PYTHONHASHSEED", raising=False)
    parse = cli_main.build_parser().parse_args
    cli_main._restart_with_fixed_hash(parse(["train", "--backend", "rllib"]))
    assert calls == [(cli_main.sys.executable, cli_main.sys.orig_argv, "0")]
    cli_main._restart_with_fixed_hash(parse(["train"]))
    cli_main._restart_with_fixed_hash(parse(["run"]))
    monkeypatch.setenv("PYTHONHASHSEED", "123")
    cli_main._restart_with_fixed_hash(parse(["train", "--backend", "rllib"]))
    assert len(calls) == 1
