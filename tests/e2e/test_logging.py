"""Messages through stdlib logging: ``--log-level`` before or after the command, one line per
message on stderr, warnings among them; a training run whose output is not a terminal logs its
progress as periodic lines instead of drawing a bar."""

import logging
import os
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

import petswarm.cli.main as cli_main


def _command(args, argv):
    warnings.warn("a warning\nover two lines", UserWarning)
    logging.getLogger("petswarm.test").info("an info line")
    logging.getLogger("petswarm.test").debug("a debug line")
    return 0


@pytest.mark.parametrize("argv, lines", [
    (["run"], ["petswarm: warning: a warning over two lines", "petswarm: info: an info line"]),
    (["--log-level", "debug", "run"], ["petswarm: warning: a warning over two lines", "petswarm: info: an info line",
                                       "petswarm: debug: a debug line"]),
    (["run", "--log-level", "warning"], ["petswarm: warning: a warning over two lines"]),
    (["--log-level", "error", "run"], []),
])
def test_log_level_sets_what_reaches_stderr(monkeypatch, capsys, argv, lines):
    monkeypatch.setitem(cli_main.COMMANDS, "run", _command)
    assert cli_main.main(argv) == 0
    assert capsys.readouterr().err.splitlines() == lines


def test_a_bad_log_level_is_one_line(capsys):
    with pytest.raises(SystemExit) as info:
        cli_main.main(["run", "--log-level", "loud"])
    assert info.value.code == 2 and "--log-level" in capsys.readouterr().err


def test_training_without_a_terminal_logs_progress_lines(tmp_path):
    pytest.importorskip("stable_baselines3")
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2]), "SDL_VIDEODRIVER": "dummy"}
    tiny = ["--set", "num_envs=1", "--set", "num_cpus=0", "--set", "ppo.n_steps=32", "--set", "ppo.batch_size=64", "--set",
            "ppo.n_epochs=1", "--set", "ppo.net_arch=[8]", "--set", "eval.every_steps=100000", "--set", "eval.episodes=1",
            "--set", "eval.max_cycles=10", "--set", "checkpoint.every_steps=100000", "--set", "env.max_cycles=20",
            "--set", "pretrain.samples=0"]
    proc = subprocess.run([sys.executable, "-m", "petswarm.cli.main", "train", "--out", str(tmp_path / "run"), "--timesteps", "128", *tiny],
                          capture_output=True, text=True, env=env, timeout=600)  # stderr is a pipe, not a terminal
    assert proc.returncode == 0, proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert lines and all(ln.startswith("petswarm: ") for ln in lines) and "\r" not in proc.stderr
    assert any(ln.startswith("petswarm: info: trained 128 of 128 agent-steps (100 %)") for ln in lines)


def test_the_rllib_progress_line_logs_when_not_a_terminal(monkeypatch, caplog):
    from petswarm.training import progress

    monkeypatch.setattr(progress.sys.stderr, "isatty", lambda: False, raising=False)
    caplog.set_level(logging.INFO, logger="petswarm.train")
    line = progress.LineProgress(1000, every_s=0.0)
    line.update(500, 250.0)
    line.close()
    assert [r.getMessage() for r in caplog.records] == ["trained 500 of 1,000 agent-steps (50 %), 250 steps/s, about 0 min left"] * 2
