"""Packaging: the wheel installs two import packages (``petswarm_env`` and ``petswarm``) and ships
everything ``petswarm run/train/eval/report/reproduce`` read (the configs, the grid, the examples,
the shipped policies), so a fresh venv with only the wheel runs them outside the repository, in a
folder that has packages of its own named like the repository's folders (``training/``...). The venv gets the already-installed dependencies through a ``.pth`` line to this
interpreter's site-packages (no torch reinstall); petswarm itself comes only from the wheel."""

import json
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")

ROOT = Path(__file__).resolve().parents[2]
SKIP = shutil.ignore_patterns(".git", ".venv*", "build", "dist", "runs", "__pycache__", "*.egg-info", ".pytest_cache")


def _run(cmd, cwd, timeout=600):
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    proc = subprocess.run([str(c) for c in cmd], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, f"{cmd[0]} {cmd[1:3]} failed ({proc.returncode}):\n{proc.stdout[-2000:]}\n{proc.stderr[-3000:]}"
    return proc.stdout


@pytest.fixture(scope="module")
def venv(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"
    shutil.copytree(ROOT, src, ignore=SKIP)  # a clean copy: no stale build/ in the wheel
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", tmp / "dist", src], tmp)
    wheel = next((tmp / "dist").glob("petswarm-*.whl"))
    env_dir = tmp / "venv"
    _run([sys.executable, "-m", "venv", env_dir], tmp)
    py = env_dir / "bin" / "python"
    site = Path(_run([py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], tmp).strip())
    (site / "_deps_of_the_test_venv.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")  # deps only, appended
    (site / "_venv_own_packages.txt").write_text("\n".join(p.name for p in site.iterdir()))  # pip, setuptools on 3.11
    _run([py, "-m", "pip", "install", "-q", "--no-deps", "--no-index", wheel], tmp)
    work = tmp / "work"
    for name in ("training", "baselines", "evaluation", "cli"):  # a user's own packages of generic names
        (work / name).mkdir(parents=True)
        (work / name / "__init__.py").write_text("raise ImportError('the user's own package was imported')\n")
    return env_dir / "bin", work, site


def test_the_wheel_installs_only_project_named_packages(venv):
    bin_dir, work, site = venv
    where = _run([bin_dir / "python", "-c",
                  "import petswarm_env, petswarm.training, petswarm.baselines; print(petswarm_env.__file__, petswarm.training.__file__)"],
                 work)
    assert all(p.startswith(str(site)) for p in where.split()), where
    own = set((site / "_venv_own_packages.txt").read_text().split())  # what `python -m venv` put there
    top = {p.name for p in site.iterdir() if p.is_dir() and not p.name.endswith((".dist-info", "__pycache__"))} - own
    assert top == {"petswarm", "petswarm_env"}, top
    assert (site / "petswarm" / "configs" / "train" / "generalize.yaml").is_file()
    assert (site / "petswarm" / "examples" / "torchrl_collect.py").is_file()


def test_train_eval_and_reproduce_run_from_the_wheel_outside_the_repo(venv):
    bin_dir, work, _ = venv
    petswarm = bin_dir / "petswarm"
    sets = ["num_envs=1", "num_cpus=0", "ppo.n_steps=32", "ppo.batch_size=64", "ppo.net_arch=[8,8]", "ppo.n_epochs=1",
            "pretrain.samples=0", "eval.episodes=1", "eval.max_cycles=10", "eval.every_steps=1000000",
            "checkpoint.every_steps=1000000", "env.max_cycles=20"]
    out = _run([petswarm, "train", "--timesteps", "128", "--out", "runs/w", "--no-progress",
                *[a for s in sets for a in ("--set", s)]], work)
    assert "trained" in out and (work / "runs" / "w" / "policy.npz").is_file()
    _run([petswarm, "eval", "--policy", "runs/w/policy.npz", "--episodes", "1", "--set", "max_cycles=10", "--json", "e.json"], work)
    assert json.loads((work / "e.json").read_text())["episodes"]
    _run([petswarm, "eval", "--policy", "learned", "--episodes", "1", "--set", "max_cycles=10"], work)  # the shipped model
    out = _run([petswarm, "reproduce", "--only", "ir_accuracy", "--quick"], work)
    assert "ir_accuracy" in out


def test_run_grid_and_report_by_shipped_names_from_the_wheel(venv):
    bin_dir, work, _ = venv
    petswarm = bin_dir / "petswarm"
    _run([petswarm, "run", "--episodes", "1", "--set", "max_cycles=20", "--json", "r.json"], work)
    assert json.loads((work / "r.json").read_text())["summary"]["episodes"] == 1
    grid = ("seed: 900000000\nepisodes: 1\ncells:\n  - name: tiny\n    set: {max_cycles: 10}\n")  # seed, episodes: required
    (work / "tiny_grid.yaml").write_text(grid)
    _run([petswarm, "eval", "--grid", "tiny_grid.yaml", "--policy", "scripted", "--episodes", "1", "--json", "g.json"], work)
    assert (work / "g.json").is_file()
    _run([petswarm, "report", "r.json", "--out", "r.html"], work)
    assert (work / "r.html").stat().st_size > 0
    # a shipped training config by the repository's path, found in the package
    out = _run([petswarm, "train", "--config", "configs/train/ppo.yaml", "--timesteps", "64", "--out", "runs/named", "--no-progress",
                "--set", "num_envs=1", "--set", "num_cpus=0", "--set", "ppo.n_steps=32", "--set", "ppo.batch_size=32",
                "--set", "ppo.net_arch=[8,8]", "--set", "pretrain.samples=0", "--set", "eval.every_steps=1000000",
                "--set", "checkpoint.every_steps=1000000", "--set", "env.max_cycles=20"], work)
    assert (work / "runs" / "named" / "policy.npz").is_file(), out
