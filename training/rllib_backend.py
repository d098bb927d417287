"""Train the shared slave policy with Ray RLlib (``petswarm train --backend rllib``).

RLlib 2.60's new API stack (RLModule, Learner, EnvRunner): PPO, one policy ``shared`` that every
robot maps to, over :class:`petswarm_env.wrappers.FixedAgents` in RLlib's
``ParallelPettingZooEnv``. The same training YAML as the SB3 back end (:mod:`petswarm.training.train`):
``ppo:`` maps onto RLlib's PPO (learning rate, γ, λ, clip, entropy and value coefficients, gradient
clip, epochs, minibatch, the actor/critic layers and activation, the initial log σ), a rollout is
``ppo.n_steps × num_envs`` env steps, ``pretrain:`` warm-starts the module's actor and critic
(:func:`petswarm.training.warm_start.fit_actor_critic`), ``eval:`` and ``checkpoint:`` schedule the same
evaluations and checkpoints, ``rllib:`` sets the env runners. The run folder is the SB3 one's::

    train_config.yaml, env_config.yaml, train_log.json, tb/rllib/ (TensorBoard),
    policy.npz (the best evaluated actor, baselines/learned.py's format), last.npz (the last
    checkpoint's actor), checkpoints/latest.npz

The checkpoint is training/checkpoint.py's file, weights only: the module's arrays (actor, critic
and heads, ``get_state()``) as ``policy:<name>`` and the JSON state record with ``backend:
rllib``, read as numbers only (:func:`petswarm.training.checkpoint.restore_weights`); RLlib's own
checkpoints (which unpickle ``class_and_ctor_args.pkl``) are not written. ``--resume`` follows the
SB3 back end's rules (:func:`petswarm.training.train.open_run`: the run's own config, only the resumable
keys changed, a finished run writes nothing) and reloads the weights; the optimizer's moments
start afresh.

Ray runs locally by default, bound to the loopback interface (:func:`start_ray`: Ray treats the
machine as a lone node and takes 127.0.0.1 as every address, checked after the start); ``address``
joins an existing cluster instead (docs/training.md), shipping this package's code to it.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import numpy as np

LOOPBACK = "127.0.0.1"
POLICY_ID = "shared"
ENV_ID = "petswarm_fixed_agents"
os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")  # before ray is imported: no usage reports

import ray  # noqa: E402
import torch  # noqa: E402
from ray.rllib.algorithms.ppo import PPOConfig as RLlibPPOConfig  # noqa: E402
from ray.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec  # noqa: E402
from ray.rllib.core.rl_module.rl_module import RLModuleSpec  # noqa: E402
from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv  # noqa: E402
from ray.tune.registry import register_env  # noqa: E402

from petswarm.baselines.learned import LearnedPolicy, save_policy  # noqa: E402
from petswarm.baselines.policy import PolicySpec  # noqa: E402
from petswarm_env.config import ConfigError, flatten_dotted, load_config  # noqa: E402
from petswarm_env.env import PetSwarmEnv  # noqa: E402
from petswarm_env.files import write_json_atomic  # noqa: E402
from petswarm_env.wrappers import FixedAgents  # noqa: E402
from petswarm.training.callbacks import LAST_POLICY, evaluate_and_keep, policy_info, public_log, scripted_reference  # noqa: E402
from petswarm.training.checkpoint import checkpoint_path, restore_weights, save_weights_checkpoint  # noqa: E402
from petswarm.training.config import TrainConfig  # noqa: E402
from petswarm.training.export import rllib_actor_layers  # noqa: E402
from petswarm.training.train import begin_run, write_run_configs  # noqa: E402
from petswarm.training.warm_start import fit_actor_critic  # noqa: E402
from petswarm.training.progress import LineProgress  # noqa: E402

ALGORITHM = "PPO (Ray RLlib, new API stack)"
_PACKAGES = ("petswarm_env", "baselines", "training", "evaluation")  # what a cluster's workers import


class _EndingPettingZooEnv(ParallelPettingZooEnv):
    """RLlib's adapter, ending the episode when every agent is done: RLlib sets ``__all__`` only when
    every agent is terminated, or every one truncated; FixedAgents ends an episode whose last live
    robots were terminated (they left the swarm: dead, astray) with those terminated and the others,
    inactive, truncated — then neither holds. The per-agent flags stay as FixedAgents gives them."""

    def step(self, action_dict):
        obss, rews, terminateds, truncateds, infos = super().step(action_dict)
        flags = [terminateds.get(a, False) or truncateds.get(a, False) for a in obss]
        if flags and all(flags) and not (terminateds["__all__"] or truncateds["__all__"]):
            terminateds["__all__"] = True
        return obss, rews, terminateds, truncateds, infos


def make_env(env_config: dict[str, Any]) -> ParallelPettingZooEnv:
    """The env RLlib's runners build: ``env_config["config"]`` is the env config as a dict."""
    return _EndingPettingZooEnv(FixedAgents(PetSwarmEnv(load_config(overrides=flatten_dotted(env_config["config"])))))


def map_to_shared(agent_id, *args, **kwargs) -> str:
    """Every robot is driven by the one shared policy (parameter sharing)."""
    return POLICY_ID


def node_ip() -> str:
    """The address of the Ray node this driver runs on."""
    return ray.util.get_node_ip_address()


def is_loopback(address: str | None) -> bool:
    """Whether a Ray address ``HOST:PORT`` names this machine's loopback interface."""
    host = (address or "").rsplit(":", 1)[0].strip("[]")
    return host in ("localhost", "::1") or host.startswith("127.")


def _bind_to_loopback(on: bool) -> None:
    """Ray takes this machine's outward address as a node's address unless it treats the machine
    as a lone node (``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0``; Ray reads it into a constant at
    import, read again here at each call): on for a local Ray or a head on 127.0.0.1 (the driver
    and every process Ray starts then use 127.0.0.1), off to join a cluster on other machines (the
    driver must tell them an address they can reach)."""
    ray._private.ray_constants.ENABLE_RAY_CLUSTER = not on
    if on:
        os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"  # Ray's processes, started from here, inherit it
    elif os.environ.get("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER") == "0":
        del os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"]


def _addresses() -> set[str]:
    """The driver's node address, every node's and the GCS's host."""
    return {node_ip(), *(n["NodeManagerAddress"] for n in ray.nodes()), ray.get_runtime_context().gcs_address.rsplit(":", 1)[0]}


def start_ray(address: str | None, num_cpus: int) -> str:
    """Connect to the cluster at ``address`` (``HOST:PORT`` of a head started with ``ray start
    --head``), shipping this package's code, or start a local Ray instance with ``num_cpus`` CPUs on
    the loopback interface; returns the driver's node address. A local instance, or a head on a
    loopback address, whose nodes took another address is refused (and shut down)."""
    local = not address or is_loopback(address)
    _bind_to_loopback(local)
    if address:
        import importlib

        modules = [importlib.import_module(name) for name in _PACKAGES]
        try:
            ray.init(address=address, runtime_env={"py_modules": modules}, log_to_driver=False)
        except ConnectionError as exc:  # Ray 2.60's heads expect their token; Ray never sends it unasked to an explicit address
            raise RuntimeError(f"cannot join the Ray cluster at {address} ({exc}); if its head uses token authentication, "
                               "run with RAY_AUTH_MODE=token and RAY_AUTH_TOKEN=<the token of `ray get-auth-token` on the head>") from None
    else:
        # Ray starts its workers at niceness 15 (its worker_niceness): on a shared machine the env runners, which do
        # the sampling, then got a quarter of a core beside ordinary processes (measured: 1 runner 0.3x of 0 runners)
        os.environ.setdefault("RAY_worker_niceness", "0")
        ray.init(num_cpus=num_cpus, include_dashboard=False, log_to_driver=False, _node_ip_address=LOOPBACK)
    if local and _addresses() != {LOOPBACK}:
        found = sorted(_addresses())
        ray.shutdown()
        raise RuntimeError(f"the Ray instance on this machine took the address(es) {found}, not {LOOPBACK}; a head started by "
                           "hand needs RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0 ray start --head --node-ip-address=127.0.0.1")
    return node_ip()


def algorithm_config(cfg: TrainConfig, env_cfg, seed: int) -> RLlibPPOConfig:
    """RLlib's PPO config from the training config (the mapping in the module docstring)."""
    p, r = cfg.ppo, cfg.rllib
    model = {"fcnet_hiddens": list(p.net_arch), "fcnet_activation": p.activation, "vf_share_layers": False}
    return (
        RLlibPPOConfig()
        .environment(ENV_ID, env_config={"config": env_cfg.to_dict()})
        .env_runners(num_env_runners=r.num_env_runners, num_envs_per_env_runner=r.num_envs_per_env_runner,
                     num_cpus_per_env_runner=1, sample_timeout_s=r.sample_timeout_s)
        .learners(num_learners=0)  # the learner runs in the driver
        .multi_agent(policies={POLICY_ID}, policy_mapping_fn=map_to_shared)
        .rl_module(rl_module_spec=MultiRLModuleSpec(rl_module_specs={POLICY_ID: RLModuleSpec(model_config=model)}))
        .training(lr=p.learning_rate, gamma=p.gamma, lambda_=p.gae_lambda, clip_param=p.clip_range, entropy_coeff=p.ent_coef,
                  vf_loss_coeff=p.vf_coef, grad_clip=p.max_grad_norm, grad_clip_by="global_norm", num_epochs=p.n_epochs,
                  minibatch_size=p.batch_size, train_batch_size_per_learner=p.n_steps * cfg.num_envs,
                  use_kl_loss=False, vf_clip_param=float("inf"))  # SB3's PPO: no KL term, no value clipping
        .debugging(seed=seed)
    )


def learner_module(algo):
    """The shared policy's torch module on the learner (the weights that train)."""
    return algo.learner_group._learner.module[POLICY_ID]


def module_state(algo) -> dict[str, np.ndarray]:
    """The shared module's weights as numpy arrays (actor, critic, heads)."""
    return {k: np.asarray(v) for k, v in learner_module(algo).get_state(inference_only=False).items()}


def set_module_state(algo, state: dict[str, np.ndarray]) -> None:
    """Load ``state`` into the learner's module and send it to every env runner."""
    learner_module(algo).set_state(state)
    algo.env_runner_group.sync_weights(from_worker_or_learner_group=algo.learner_group)


def init_module(algo, cfg: TrainConfig, env_cfg) -> dict | None:
    """The module's start: the head's log σ rows at ``ppo.log_std_init`` (SB3's initial
    exploration), then the warm start when ``pretrain.samples > 0``; returns its figures."""
    module = learner_module(algo)
    head = module.pi.net.mlp[0]
    with torch.no_grad():
        head.weight[3:] = 0.0
        head.bias[3:] = cfg.ppo.log_std_init
    figures = None
    if cfg.pretrain.samples > 0:
        actor, critic = module.encoder.actor_encoder.net.mlp, module.encoder.critic_encoder.net.mlp
        params = [*actor.parameters(), *head.parameters(), *critic.parameters(), *module.vf.net.mlp.parameters()]
        figures = fit_actor_critic(lambda x: head(actor(x))[:, :3], lambda x: module.vf.net.mlp(critic(x)), params, cfg, env_cfg)
    algo.env_runner_group.sync_weights(from_worker_or_learner_group=algo.learner_group)
    return figures


def restore_module(algo, out: Path) -> None:
    """The run's checkpoint into the learner's module and every env runner (training/checkpoint.py)."""
    set_module_state(algo, restore_weights(out, "rllib", module_state(algo)))


class Progress:
    """The run's bookkeeping between iterations: agent-steps, TensorBoard, the evaluation and
    checkpoint schedule (as the SB3 back end's :class:`petswarm.training.callbacks.PeriodicCallback`)."""

    def __init__(self, cfg: TrainConfig, out: Path, log: dict[str, Any], spec: PolicySpec):
        from torch.utils.tensorboard import SummaryWriter

        self.cfg, self.out, self.log, self.spec = cfg, out, log, spec
        self.eval_cfg, self.seeds = cfg.eval_env_config(), cfg.eval_seeds()
        self.writer = SummaryWriter(str(out / "tb" / "rllib"))
        self.next_eval = (log["timesteps"] // cfg.eval.every_steps + 1) * cfg.eval.every_steps
        self.next_ckpt = (log["timesteps"] // cfg.checkpoint.every_steps + 1) * cfg.checkpoint.every_steps

    def iteration(self, algo, result: dict[str, Any], wall_s: float) -> None:
        runners, log = result["env_runners"], self.log
        # per agent id; an id that never stepped in the iteration (a robot that had not joined yet) reads NaN
        agent_steps = int(sum(v for v in runners.get("num_agent_steps_sampled", {}).values() if v == v))
        if agent_steps == 0:
            raise RuntimeError(f"an RLlib iteration sampled nothing within rllib.sample_timeout_s={self.cfg.rllib.sample_timeout_s} s; "
                               "raise it (a loaded machine or slow env runners)")
        log["timesteps"] += agent_steps
        n = log["timesteps"]
        log["samples_per_s"].append(round(agent_steps / wall_s, 1))
        w = self.writer
        w.add_scalar("time/agent_steps_per_s", agent_steps / wall_s, n)
        w.add_scalar("time/env_steps_per_s", float(runners.get("num_env_steps_sampled", 0)) / wall_s, n)
        if "episode_return_mean" in runners:
            w.add_scalar("rollout/ep_rew_mean", float(runners["episode_return_mean"]), n)
        for key, value in result.get("learners", {}).get(POLICY_ID, {}).items():
            if np.isscalar(value):
                w.add_scalar(f"train/{key}", float(value), n)
        if n >= self.next_eval:
            self.next_eval = (n // self.cfg.eval.every_steps + 1) * self.cfg.eval.every_steps
            self.evaluate(algo)
        if n >= self.next_ckpt:
            self.next_ckpt = (n // self.cfg.checkpoint.every_steps + 1) * self.cfg.checkpoint.every_steps
            self.checkpoint(algo)

    def policy(self, algo) -> LearnedPolicy:
        layers = rllib_actor_layers(module_state(algo))
        return LearnedPolicy(self.spec, layers, self.cfg.ppo.activation, np.arange(self.spec.layout.size))

    def evaluate(self, algo) -> dict[str, Any]:
        """An evaluation of the module's actor; the best so far is written as policy.npz
        (:func:`petswarm.training.callbacks.evaluate_and_keep`)."""
        layers = rllib_actor_layers(module_state(algo))
        n = self.log["timesteps"]
        record = evaluate_and_keep(
            self.cfg, self.out, self.log,
            lambda spec: LearnedPolicy(spec, layers, self.cfg.ppo.activation, np.arange(spec.layout.size)), n,
            lambda path, info: save_policy(path, layers, self.cfg.ppo.activation, self.spec.layout, info), ALGORITHM)
        rmse, ref = record["formation_rmse_m"], record["scripted_rmse_m"]
        self.writer.add_scalar("eval/formation_rmse_m", rmse, n)
        self.writer.add_scalar("eval/scripted_rmse_m", ref, n)
        self.writer.add_scalar("eval/ratio_to_scripted", rmse / ref if ref else float("nan"), n)
        self.writer.add_scalar("eval/median_ratio_to_scripted", record["median_ratio"], n)
        return record

    def checkpoint(self, algo) -> None:
        log = self.log
        log["wall_time_s"] = log["wall_time_before_s"] + time.time() - log["_start"]
        state, p = module_state(algo), self.cfg.ppo
        save_weights_checkpoint(checkpoint_path(self.out), state, log["timesteps"], "rllib",
                                {"observation_size": self.spec.layout.size, "net_arch": list(p.net_arch),
                                 "activation": p.activation, "policy_id": POLICY_ID})
        save_policy(self.out / LAST_POLICY, rllib_actor_layers(state), self.cfg.ppo.activation, self.spec.layout,
                    policy_info(self.cfg, log, ALGORITHM))
        write_json_atomic(self.out / "train_log.json", public_log(log))
        self.writer.flush()


def train_rllib(cfg: TrainConfig | None, out_dir: str | os.PathLike, resume: bool = False, address: str | None = None,
                progress_bar: bool = True, command: str = "") -> dict:
    """Train (or resume) a run in ``out_dir`` with RLlib; returns the train log. Read top to
    bottom: the run folder, Ray, the scripted reference's score, the algorithm, the module's start
    or the checkpoint, the iterations, the last checkpoint."""
    out = Path(out_dir)
    if cfg is not None and (cfg.randomize or cfg.ppo.critic != "local" or cfg.residual_of):
        raise ConfigError("--backend rllib trains without randomize: pools, with ppo.critic: local and residual_of: null; use "
                          "--backend sb3 for domain randomization, the centralized critic and residual policies (docs/training.md)")
    cfg, log, changes, finished = begin_run(cfg, out, resume, command)
    if finished:
        return finished
    env_cfg, eval_cfg = cfg.env_config(), cfg.eval_env_config()
    log["backend"] = "rllib"
    log.setdefault("samples_per_s", [])  # agent-steps/s of each iteration
    torch.set_num_threads(1)  # the driver's sampler and learner; the cores run the env runners
    spec = PolicySpec.from_env(PetSwarmEnv(eval_cfg))
    scripted_reference(cfg, log)  # the reference every evaluation is compared with, seed by seed
    log["ray_node_ip"] = start_ray(address, max(1, cfg.rllib.num_env_runners))
    register_env(ENV_ID, make_env)
    algo = algorithm_config(cfg, env_cfg, cfg.seed + log["timesteps"]).build_algo()
    try:
        if resume:
            restore_module(algo, out)
        else:
            pre = init_module(algo, cfg, env_cfg)
            if pre is not None:
                log["pretrain"] = pre
        write_run_configs(out, cfg, env_cfg, resume, changes)  # once the checkpoint is known good
        progress = Progress(cfg, out, log, spec)
        if "pretrain" in log and not resume:  # the warm-started actor competes for the best
            log["pretrain"]["eval_formation_rmse_m"] = progress.evaluate(algo)["formation_rmse_m"]
        line = LineProgress(cfg.timesteps) if progress_bar else None  # a redrawn line on a terminal, log lines otherwise
        while log["timesteps"] < cfg.timesteps:
            t = time.perf_counter()
            result = algo.train()
            progress.iteration(algo, result, time.perf_counter() - t)
            if line:
                line.update(log["timesteps"], log["samples_per_s"][-1])
        if line:
            line.close()
        if not log["evaluations"] or log["evaluations"][-1]["timesteps"] != log["timesteps"]:
            progress.evaluate(algo)
        progress.checkpoint(algo)
        progress.writer.close()
    finally:
        algo.stop()
        ray.shutdown()
    return public_log(log)
