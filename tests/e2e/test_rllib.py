"""The RLlib back end (``petswarm train --backend rllib``, training/rllib_backend.py): a tiny run
with one env runner on a local Ray bound to 127.0.0.1 writes the run folder, its policy.npz is the
RLlib actor's deterministic output in numpy, its checkpoint is weights only; RLlib's own PettingZoo
adapter runs the fixed-agents env through a master change. Needs the rllib extra.

Joining a cluster (``--address``) is tested against a head this test starts on 127.0.0.1 when
``PETSWARM_TEST_RAY_CLUSTER=1`` (about a minute more); the head's processes are stopped by their ids.
"""

import json
import os
import secrets
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("ray.rllib")

from petswarm.baselines.learned import LearnedPolicy, read_policy_file  # noqa: E402
from petswarm.baselines.policy import PolicySpec  # noqa: E402
from petswarm.baselines.registry import make_policy  # noqa: E402
from petswarm.evaluation.evaluate import mean_formation_rmse  # noqa: E402
from petswarm_env import parallel_env  # noqa: E402
from petswarm_env.config import ConfigError, load_config  # noqa: E402
from petswarm.training import rllib_backend  # noqa: E402
from petswarm.training.checkpoint import read_checkpoint  # noqa: E402
from petswarm.training.config import load_train_config  # noqa: E402
from petswarm.training.export import rllib_actor_layers  # noqa: E402
from petswarm.training.train import train  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
TINY = {"timesteps": 400, "num_envs": 1, "ppo.n_steps": 50, "ppo.batch_size": 50, "ppo.n_epochs": 1, "ppo.net_arch": [16, 16],
        "eval.every_steps": 200, "eval.episodes": 1, "eval.max_cycles": 20, "checkpoint.every_steps": 200,
        "env.max_cycles": 50, "pretrain.samples": 200, "pretrain.epochs": 1,
        "rllib.num_envs_per_env_runner": 1}  # one env copy: 50 env steps x 4 robots = 200 agent-steps an iteration, exactly


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("rllib") / "tiny"
    cfg = load_train_config(overrides={**TINY, "rllib.num_env_runners": 1})
    return out, rllib_backend.train_rllib(cfg, out, progress_bar=False)


def test_a_local_run_binds_ray_to_loopback_and_writes_the_run_folder(run):
    out, log = run
    assert log["ray_node_ip"] == "127.0.0.1"  # every node and the GCS: start_ray refuses anything else
    assert log["backend"] == "rllib" and log["timesteps"] >= 400 and len(log["samples_per_s"]) >= 2
    for name in ("train_config.yaml", "env_config.yaml", "policy.npz", "last.npz", "train_log.json", "checkpoints/latest.npz"):
        assert (out / name).is_file(), name
    assert list((out / "tb" / "rllib").glob("events.out.tfevents*"))
    # the warm-started actor (agent-step 0) competes for policy.npz with every periodic evaluation
    assert [e["timesteps"] for e in log["evaluations"]] == [0, 200, 400] and log["pretrain"]["samples"] == 200
    best = min(log["evaluations"], key=lambda e: (e["not_built"], e["median_ratio"], e["timesteps"]))
    assert read_policy_file(out / "policy.npz")[0]["info"]["selected"]["timesteps"] == best["timesteps"] == log["best"]["timesteps"]
    assert not list(out.rglob(".*.npz")) and not list(out.rglob(".*.json")), "no temp files left"


def test_the_checkpoint_is_the_houses_format_weights_only_and_the_policy_is_evaluated(run):
    out, log = run
    state, arrays = read_checkpoint(out)  # training/checkpoint.py: numbers only, the state record checked
    assert state["backend"] == "rllib" and state["num_timesteps"] == log["timesteps"]
    assert {"policy:encoder.actor_encoder.net.mlp.0.weight", "policy:encoder.critic_encoder.net.mlp.0.weight",
            "policy:vf.net.mlp.0.weight"} <= set(arrays)
    assert all(k.startswith("policy:") for k in arrays), "weights only"
    meta, layers = read_policy_file(out / "policy.npz")
    cfg = load_config(overrides={"max_cycles": 20})
    size = PolicySpec.from_env(parallel_env(cfg)).layout.size
    assert [w.shape for w, _ in layers] == [(16, size), (16, 16), (3, 16)] and "RLlib" in meta["info"]["algorithm"]
    policy = LearnedPolicy.load(out / "policy.npz", PolicySpec.from_env(parallel_env(cfg)))
    assert np.isfinite(mean_formation_rmse(cfg, policy, [0]))


def test_a_resume_continues_the_rllib_run_and_the_sb3_back_end_refuses_its_checkpoint(run, tmp_path):
    out, log = run
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    more = load_train_config(overrides={"timesteps": log["timesteps"] + 200, "rllib.num_env_runners": 0}, base=copy / "train_config.yaml")
    resumed = rllib_backend.train_rllib(more, copy, resume=True, progress_bar=False)  # where it runs may change on resume
    assert resumed["timesteps"] >= log["timesteps"] + 200 and resumed["resumes"][0]["from_timesteps"] == log["timesteps"]
    assert resumed["resumes"][0]["changes"]["rllib.num_env_runners"] == {"from": 1, "to": 0}
    assert read_checkpoint(copy)[0]["num_timesteps"] == resumed["timesteps"]
    with pytest.raises(ConfigError, match="written by --backend rllib; resume it with --backend rllib"):
        train(load_train_config(overrides={"timesteps": resumed["timesteps"] + 200, "num_cpus": 0}, base=copy / "train_config.yaml"),
              copy, resume=True, progress_bar=False)


def test_the_exported_actor_is_the_rllib_modules_deterministic_action():
    """baselines/learned.py's numpy forward over rllib_actor_layers = the module's action mean."""
    import torch
    from ray.rllib.algorithms.ppo.torch.default_ppo_torch_rl_module import DefaultPPOTorchRLModule
    from ray.rllib.core.columns import Columns

    env = parallel_env()
    space = env.observation_space(env.possible_agents[0])
    module = DefaultPPOTorchRLModule(observation_space=space, action_space=env.action_space(env.possible_agents[0]),
                                     inference_only=False,
                                     model_config={"fcnet_hiddens": [32, 32], "fcnet_activation": "tanh", "vf_share_layers": False})
    state = {k: np.asarray(v) for k, v in module.get_state().items()}
    spec = PolicySpec.from_env(env)
    policy = LearnedPolicy(spec, rllib_actor_layers(state), "tanh", np.arange(spec.layout.size))
    x = np.random.default_rng(0).uniform(space.low, space.high, (16, space.shape[0])).astype(np.float32)
    with torch.no_grad():
        logits = module.forward_inference({Columns.OBS: torch.from_numpy(x)})[Columns.ACTION_DIST_INPUTS].numpy()
    assert np.abs(policy.forward(x) - logits[:, :3]).max() < 1e-5


def test_rllibs_pettingzoo_adapter_runs_the_fixed_agents_env_through_a_master_change():
    cfg = load_config(overrides={"user.scenario": "mode_change", "max_cycles": 420, "render.size_px": [64, 48]})
    env = rllib_backend.make_env({"config": cfg.to_dict()})
    obs, infos = env.reset(seed=42, options={})  # RLlib's own env check: reset(seed=42, options={}) and one step
    assert set(obs) == set(env.get_agent_ids()) == set(env.observation_space.keys())
    # the scripted reference drives the live robots (standing ones would be left beyond the swarm's reach
    # once the user walks, and removed as astray before the mode change: middleware/recovery.py)
    policy = make_policy("scripted", PolicySpec.from_env(env.par_env))
    joined = set()
    done = {"__all__": False}
    while not done["__all__"]:
        live = {a: o for a, o in obs.items() if infos[a]["active"]}
        acts = {**{a: np.zeros(3, np.float32) for a in obs}, **policy.act_all(live)}
        obs, rewards, done, truncated, infos = env.step(acts)
        joined |= {a for a, info in infos.items() if info["joined"]}
        done = {"__all__": done["__all__"] or truncated["__all__"]}
        assert all(type(r) is float for r in rewards.values())
    assert joined == {"robot_0"}  # the old master joined mid-episode: no KeyError
    assert env.render() is None  # RLlib calls par_env.render(render_mode), here None


def _ray_head(tmp: str, token: str) -> str:
    """Start a Ray head on 127.0.0.1 with its own temp dir ``tmp`` and auth ``token``; returns its address."""
    ray_bin = Path(sys.executable).with_name("ray")
    port = 6390 + os.getpid() % 500
    envs = {**os.environ, "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0", "RAY_USAGE_STATS_ENABLED": "0", "RAY_AUTH_MODE": "token",
            "RAY_AUTH_TOKEN": token}
    subprocess.run([str(ray_bin), "start", "--head", "--node-ip-address=127.0.0.1", f"--port={port}", "--num-cpus=2",
                    "--include-dashboard=false", "--disable-usage-stats", f"--temp-dir={tmp}"], env=envs, check=True,
                   capture_output=True, timeout=180)
    return f"127.0.0.1:{port}"


def _head_processes(tmp: str) -> list[int]:
    """The ids of the head's processes: those naming its temp dir, and their descendants (workers)."""
    parent, mine = {}, set()
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            parent[int(proc.name)] = int((proc / "stat").read_text().rsplit(")", 1)[1].split()[1])
            if tmp.encode() in (proc / "cmdline").read_bytes():
                mine.add(int(proc.name))
        except (OSError, ValueError, IndexError):
            continue
    grew = True
    while grew:
        more = {pid for pid, ppid in parent.items() if ppid in mine} - mine
        mine |= more
        grew = bool(more)
    return sorted(mine)


def _stop(pids: list[int]) -> None:
    """SIGTERM, then SIGKILL what is left after 10 s (Ray's GCS and raylet may not stop on SIGTERM)."""
    for sig, wait in ((signal.SIGTERM, 10.0), (signal.SIGKILL, 1.0)):
        for pid in pids:
            try:
                os.kill(pid, sig)
            except ProcessLookupError:
                pass
        deadline = time.time() + wait
        while time.time() < deadline and any(Path(f"/proc/{pid}").exists() and "Z" not in _state(pid) for pid in pids):
            time.sleep(0.2)


def _state(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return "Z"


@pytest.mark.skipif(os.environ.get("PETSWARM_TEST_RAY_CLUSTER") != "1", reason="set PETSWARM_TEST_RAY_CLUSTER=1 (about a minute)")
def test_address_joins_a_cluster_head_started_on_loopback(tmp_path):
    """As a user would: a head with its own auth token, then ``petswarm train --backend rllib
    --address`` with RAY_AUTH_MODE=token and the token in the environment."""
    tmp = tempfile.mkdtemp(prefix="psray", dir="/tmp")
    token = secrets.token_hex(32)
    try:
        address = _ray_head(tmp, token)
        sets = [f"{k}={json.dumps(v) if isinstance(v, list) else v}" for k, v in {**TINY, "timesteps": 200, "pretrain.samples": 0,
                                                                                    "rllib.num_env_runners": 1}.items()]
        env = {**os.environ, "RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": token, "PYTHONPATH": str(ROOT)}
        proc = subprocess.run([sys.executable, "-m", "petswarm.cli.main", "train", "--backend", "rllib", "--address", address, "--no-progress",
                               "--out", str(tmp_path / "cluster"), *[a for kv in sets for a in ("--set", kv)]],
                              env=env, capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, proc.stderr[-3000:]
        log = json.loads((tmp_path / "cluster" / "train_log.json").read_text())
        assert log["ray_node_ip"] == "127.0.0.1" and log["timesteps"] >= 200
        assert (tmp_path / "cluster" / "policy.npz").is_file()
    finally:
        pids = _head_processes(tmp)
        _stop(pids)
        assert not [pid for pid in pids if _state(pid) != "Z"], "the head's processes are stopped"
        shutil.rmtree(tmp, ignore_errors=True)


def test_two_command_line_runs_of_one_seed_give_the_same_weights(tmp_path):
    """With 0 env runners the same command twice gives bit-identical weights: RLlib's seeds come
    from ``seed:`` (``.debugging(seed=…)``) and the CLI fixes Python's string hash, which orders
    RLlib's agents (docs/training.md, "Deterministic runs"); each run is its own process, as a user's."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONHASHSEED"}
    env["PYTHONPATH"] = str(ROOT)
    sets = [f"{k}={json.dumps(v) if isinstance(v, list) else v}" for k, v in {**TINY, "rllib.num_env_runners": 0}.items()]
    weights = []
    for name in ("a", "b"):
        proc = subprocess.run([sys.executable, "-m", "petswarm.cli.main", "train", "--backend", "rllib", "--no-progress",
                               "--out", str(tmp_path / name), *[a for kv in sets for a in ("--set", kv)]],
                              env=env, capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, proc.stderr[-3000:]
        with np.load(tmp_path / name / "checkpoints" / "latest.npz") as ckpt:
            weights.append({k: ckpt[k] for k in ckpt.files if k.startswith("policy:")})
    assert weights[0].keys() == weights[1].keys() and len(weights[0]) >= 6
    assert all(np.array_equal(weights[0][k], weights[1][k]) for k in weights[0])
