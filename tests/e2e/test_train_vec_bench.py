"""``python -m petswarm.bench.train_vec``: one path alone, with the env's share of ``learn()`` in
wall and in CPU time. No timing is asserted (speeds depend on the machine and its load)."""

import math

import pytest

pytest.importorskip("stable_baselines3")

from petswarm.bench.train_vec import main  # noqa: E402


def test_the_petswarm_path_alone_reports_its_samples_and_the_env_share(capsys):
    out = main(["--samples", "64", "--rounds", "1", "--num-envs", "2", "--paths", "petswarm"])
    run, = out["runs"]
    assert run["path"] == "petswarm" and run["samples"] >= 64 and run["rows"] == 2 * 4
    for share in ("env_share", "env_cpu_share"):
        assert 0.0 < run[share] < 1.0 and math.isfinite(run[share])
    assert set(out) >= {"petswarm"} and "supersuit" not in out and "wall_speedup" not in out
    assert "% of its CPU time" in capsys.readouterr().out
