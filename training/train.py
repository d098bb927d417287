"""Train one slave policy shared by all slaves with Stable-Baselines3 PPO (``petswarm train``).

Read :func:`train` top to bottom: the run folder, the seeds, the scripted reference's score, the
vector env (:mod:`petswarm.training.vec_env`), the PPO model, the warm start (:mod:`petswarm.training.warm_start`),
``model.learn`` with the checkpoint/evaluation callback (:mod:`petswarm.training.callbacks`), the last
checkpoint. ``--resume`` rebuilds the model from the run's own config and loads the checkpoint
into it (:mod:`petswarm.training.checkpoint`; SB3's ``PPO.load`` unpickles and is never called). Every
hyper-parameter is in the training config (:mod:`petswarm.training.config`, ``configs/train/ppo.yaml``).
Everything of a run lives in its folder::

    runs/NAME/train_config.yaml      the resolved training config (hyper-parameters + env overrides)
    runs/NAME/env_config.yaml        the resolved environment config
    runs/NAME/checkpoints/latest.npz the checkpoint: weights, optimizer, counters and RNG states as
                                     arrays and JSON, never a pickle (training/checkpoint.py), atomic
    runs/NAME/policy.npz             the best evaluated actor (weights-only, see baselines/learned.py;
                                     the lowest median ratio to scripted, training/callbacks.py)
    runs/NAME/last.npz               the last checkpoint's actor, the same format
    runs/NAME/train_log.json         timesteps, wall time, evaluations against the scripted reference,
                                     the best one (``best``)
    runs/NAME/tb/                    TensorBoard logs
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

import torch
import yaml
from stable_baselines3 import PPO
from stable_baselines3.common.utils import set_random_seed
from torch.distributions import Distribution

from petswarm_env.config import ConfigError, flatten_dotted, parse_override, parse_yaml
from petswarm_env.env import PetSwarmEnv
from petswarm_env.files import check_output_path, write_json_atomic, write_text_atomic
from petswarm.training.callbacks import PeriodicCallback, evaluate_model, public_log, scripted_reference
from petswarm.training.checkpoint import checkpoint_path, has_checkpoint, read_checkpoint, restore_checkpoint
from petswarm.training.config import PPOConfig, TrainConfig, load_train_config, resume_changes
from petswarm.training.residual import zero_action_head
from petswarm.training.state_critic import StateCriticPolicy
from petswarm.training.vec_env import make_vec_env, training_env
from petswarm.training.warm_start import pretrain_policy
from petswarm.training.progress import log_progress_callback, wants_bar
from petswarm.training.run_folder import check_checkpoint_state, check_train_log


class UncheckedPPO(PPO):
    """SB3's PPO whose ``learn`` builds its action Gaussians without torch.distributions' argument
    checks (torch's documented switch ``Distribution.set_default_validate_args``, off during
    ``learn`` and back to Python's default after): every rollout step and update builds a
    ``Normal`` and takes its log-probability, and the checks (finite mean, positive scale, a sample
    in the support) cost 10-20 µs of a policy step's ~120 µs on 16 rows. The numbers are the same
    (the checks only raise); a policy gone NaN still stops at its next step, where the env names the
    non-finite action (petswarm_env.vector, petswarm_env.env)."""

    def learn(self, *args, **kwargs):
        Distribution.set_default_validate_args(False)
        try:
            return super().learn(*args, **kwargs)
        finally:
            Distribution.set_default_validate_args(__debug__)


def build_model(p: PPOConfig, venv, seed: int, tensorboard_log: str | None = None, n_steps: int | None = None,
                batch_size: int | None = None, obs_size: int | None = None) -> PPO:
    """A fresh SB3 PPO with the hyper-parameters of ``p`` (``n_steps`` and ``batch_size`` may be
    overridden: the benchmark sizes its rollouts itself): an ``MlpPolicy``, or with ``p.critic ==
    "state"`` a :class:`~petswarm.training.state_critic.StateCriticPolicy` whose actor reads the first
    ``obs_size`` values of a row (the observation) and whose critic reads the row (observation + state);
    an :class:`UncheckedPPO` (SB3's learning, the same numbers, less per-step work)."""
    act = torch.nn.Tanh if p.activation == "tanh" else torch.nn.ReLU
    policy_kwargs = {"net_arch": {"pi": list(p.net_arch), "vf": list(p.net_arch)}, "activation_fn": act,
                     "log_std_init": p.log_std_init}
    if p.critic == "state":
        if obs_size is None:
            raise ValueError("ppo.critic: state needs the observation's size (obs_size) to split the rows")
        policy_kwargs["obs_size"] = obs_size
    return UncheckedPPO(
        StateCriticPolicy if p.critic == "state" else "MlpPolicy",
        venv,
        learning_rate=p.learning_rate,
        n_steps=p.n_steps if n_steps is None else n_steps,
        batch_size=p.batch_size if batch_size is None else batch_size,
        n_epochs=p.n_epochs,
        gamma=p.gamma,
        gae_lambda=p.gae_lambda,
        clip_range=p.clip_range,
        ent_coef=p.ent_coef,
        vf_coef=p.vf_coef,
        max_grad_norm=p.max_grad_norm,
        policy_kwargs=policy_kwargs,
        tensorboard_log=tensorboard_log,
        seed=seed,
        device="cpu",
        verbose=0,
    )


def _fresh_log() -> dict[str, Any]:
    return {"timesteps": 0, "wall_time_s": 0.0, "evaluations": [], "scripted_eval_rmse_m": None}


def _read_run_file(path: Path, what: str) -> Any:
    try:
        text = path.read_text(encoding="utf-8")
        return json.loads(text) if path.suffix == ".json" else parse_yaml(text, f"'{path}'")  # bounded: no alias bomb
    except FileNotFoundError:
        raise ConfigError(f"cannot resume: the run folder has no {path.name} ({what}); train without --resume first") from None
    except ConfigError as exc:  # beyond the YAML bounds (an alias bomb, nested too deep): the reason names the file
        raise ConfigError(f"cannot resume: {exc}") from None
    except (OSError, UnicodeDecodeError, ValueError, RecursionError, yaml.YAMLError) as exc:
        raise ConfigError(f"cannot resume: '{path}' ({what}) cannot be read ({type(exc).__name__}); "
                          "the run folder is damaged, start a new run with another --out") from None


def open_run(cfg: TrainConfig | None, out: Path, resume: bool) -> tuple[TrainConfig, dict[str, Any], dict[str, Any]]:
    """The config, the train log and the config changes of the run in ``out``. A new run is
    refused if ``out`` holds one. A resumed run keeps its own config (train_config.yaml) and
    environment (env_config.yaml): ``cfg`` (``None``: the run's own) may differ from it only in
    :data:`petswarm.training.config.RESUMABLE` keys, anything else is refused by name, never dropped;
    the log continues train_log.json at the checkpoint's timesteps."""
    if not resume:
        if has_checkpoint(out):
            raise ConfigError(f"'{out}' already holds a run; pass --resume to continue it or choose another --out")
        return cfg, _fresh_log(), {}
    state, arrays = read_checkpoint(out)  # missing, old SB3 format, damaged: refused before anything else
    check_checkpoint_state(checkpoint_path(out), state, arrays)  # every field of the state record (run_folder.py)
    saved_path = out / "train_config.yaml"
    _read_run_file(saved_path, "the run's training config")
    saved = load_train_config(base=saved_path)
    changes = resume_changes(saved, cfg or saved, out)
    cfg = cfg or saved
    env_saved = _read_run_file(out / "env_config.yaml", "the run's environment config")
    if not isinstance(env_saved, dict):
        raise ConfigError(f"cannot resume: '{out / 'env_config.yaml'}' (the run's environment config) must hold a mapping of "
                          f"keys, got {type(env_saved).__name__}; the run folder is damaged, start a new run with another --out")
    env_now = flatten_dotted(cfg.env_config().to_dict())
    env_then = flatten_dotted(env_saved)
    differ = sorted(k for k in set(env_now) | set(env_then) if env_now.get(k) != env_then.get(k))
    if differ:
        k = differ[0]
        raise ConfigError(
            f"cannot resume '{out}': it trained on {k}={env_then.get(k, '(absent)')!r} (env_config.yaml) but this petswarm's "
            f"defaults give {env_now.get(k, '(absent)')!r}; resume it with the petswarm that started it, or start a new run")
    log = _read_run_file(out / "train_log.json", "the run's log")
    check_train_log(out / "train_log.json", log)  # every field the resumed run reads, before anything is written (run_folder.py)
    log["timesteps"] = state["num_timesteps"]
    return cfg, log, changes


def begin_run(cfg: TrainConfig | None, out: Path, resume: bool, command: str):
    """:func:`open_run`, then (both back ends) ``(cfg, log, changes, None)`` with this start in the
    log, or ``(…, finished)`` with the log to return for a resumed run that has reached its
    ``timesteps`` (it writes nothing)."""
    cfg, log, changes = open_run(cfg, out, resume)
    if resume and log["timesteps"] >= cfg.timesteps:
        return cfg, log, changes, {**public_log(log), "finished": True, "budget": cfg.timesteps}
    _start_log(log, resume, changes, command)
    return cfg, log, changes, None


def _start_log(log: dict[str, Any], resume: bool, changes: dict[str, Any], command: str) -> None:
    """The log's record of this start: the command of a new run, or a ``resumes`` entry (from
    which timesteps, the config changes, the command); the wall-time clock."""
    if not resume:
        log["command"] = command
    else:
        log.setdefault("resumes", []).append({"from_timesteps": log["timesteps"], "changes": changes, "command": command})
    log["wall_time_before_s"] = log.get("wall_time_s", 0.0)
    log["_start"] = time.time()


def write_run_configs(out: Path, cfg: TrainConfig, env_cfg, resume: bool, changes: dict[str, Any]) -> None:
    """train_config.yaml and env_config.yaml of a new run; on resume train_config.yaml only with
    what was asked (recorded). Called once the checkpoint is known good (both back ends)."""
    if not resume or changes:
        write_text_atomic(out / "train_config.yaml", yaml.safe_dump(cfg.model_dump(mode="json"), sort_keys=False))
    if not resume:
        write_text_atomic(out / "env_config.yaml", yaml.safe_dump(env_cfg.to_dict(), sort_keys=False))


def train(cfg: TrainConfig | None, out_dir: str | os.PathLike, resume: bool = False, progress_bar: bool = True,
          command: str = "", vec_env: str = "petswarm") -> dict:
    """Train (or resume) a run in ``out_dir``; returns the train log. ``cfg`` is the config of a
    new run; on resume the run's own (``None``) or one differing from it only in keys a resumed
    run may change (:func:`open_run`). A resumed run that has reached its ``timesteps`` returns
    its log with ``"finished": True`` and writes nothing. ``vec_env``: the batched vector env
    (``petswarm``, default) or SuperSuit's pipeline (``supersuit``), :mod:`petswarm.training.vec_env`."""
    out = Path(out_dir)
    cfg, log, changes, finished = begin_run(cfg, out, resume, command)
    if finished:
        return finished
    env_cfg = cfg.env_config()

    torch.set_num_threads(1)  # reproducible CPU math; the cores run the env workers
    set_random_seed(cfg.seed)
    layout = PetSwarmEnv(env_cfg).layout
    scripted_reference(cfg, log)  # the reference every evaluation is compared with, seed by seed

    with_state = cfg.ppo.critic == "state"
    venv = make_vec_env(env_cfg, cfg.num_envs, cfg.num_cpus, cfg.seed + log["timesteps"], cfg.randomize, cfg.env, with_state,
                        cfg.residual(), vec_env=vec_env)
    try:
        model = build_model(cfg.ppo, venv, cfg.seed, tensorboard_log=str(out / "tb"), obs_size=layout.size)
        if resume:
            restore_checkpoint(out, model)
        elif cfg.residual_of:  # the first policy is the reference itself (training/residual.py)
            zero_action_head(model.policy.action_net.weight, model.policy.action_net.bias)
        elif cfg.pretrain.samples > 0:  # warm start: imitate the scripted reference, in the run's own env (draws, rows)
            demo_env = training_env(env_cfg, cfg.randomize, cfg.env, with_state)
            log["pretrain"] = pretrain_policy(model, cfg, env_cfg, demo_env)
            demo_env.close()
        write_run_configs(out, cfg, env_cfg, resume, changes)  # once the checkpoint is known good
        if not resume and (cfg.residual_of or cfg.pretrain.samples > 0):  # the actor PPO starts from competes for the best
            start = evaluate_model(cfg, out, log, model, layout, 0)
            if "pretrain" in log:
                log["pretrain"]["eval_formation_rmse_m"] = start["formation_rmse_m"]
        callback = PeriodicCallback(cfg, out, layout, log)
        logged = [log_progress_callback(cfg.timesteps)] if progress_bar and not wants_bar(progress_bar) else []  # not a terminal: log lines
        model.learn(cfg.timesteps - model.num_timesteps, callback=[callback, *logged], reset_num_timesteps=False, tb_log_name="ppo",
                    progress_bar=wants_bar(progress_bar))
        callback.checkpoint()
        last = log["evaluations"][-1] if log["evaluations"] else {}
        # PPO's last update follows the last rollout, in which the callback evaluated: the final weights compete too
        if last.get("timesteps") != model.num_timesteps or last.get("n_updates") != model._n_updates:
            callback.evaluate()
        write_json_atomic(out / "train_log.json", public_log(log))
    finally:
        venv.close()
    return public_log(log)


def train_command(config: str | None, settings: list[str], timesteps: int | None, out: str, resume: bool,
                  progress_bar: bool, command: str, run=None, **run_options) -> int:
    """``petswarm train``: the config from ``config`` and ``--set KEY=VALUE`` ``settings`` (and
    ``--timesteps``), the run — :func:`train` (SB3), or ``run`` with ``run_options`` (the CLI passes
    :func:`petswarm.training.rllib_backend.train_rllib` and its ``address``) — and one summary line."""
    check_output_path(out, "--out", folder=True)
    overrides = dict(parse_override(item) for item in settings)
    if timesteps:
        overrides["timesteps"] = timesteps
    saved = Path(out) / "train_config.yaml"
    if resume and not saved.is_file() and has_checkpoint(out):
        raise ConfigError(f"cannot resume: the run folder '{out}' has no train_config.yaml; start a new run with another --out")
    # a resumed run starts from its own config: the file and --set change only what they name
    cfg = load_train_config(config, overrides, base=saved if resume and saved.is_file() else None)
    if cfg.algorithm == "recurrent":  # DAgger from the privileged teacher into a GRU actor (training/recurrent.py)
        return _recurrent_command(cfg, out, resume, run, command)
    if cfg.algorithm == "recurrent_ppo":  # PPO fine-tuning of a distilled GRU actor (training/recurrent_ppo.py)
        return _recurrent_ppo_command(cfg, out, resume, run, command)
    log = (run or train)(cfg, out, resume=resume, progress_bar=progress_bar, command=command, **run_options)
    if log.get("finished"):
        print(f"run '{out}' is already finished: {log['timesteps']} agent-steps trained, its budget is {log['budget']}; "
              f"pass --timesteps N with N > {log['timesteps']} to train further")
        return 0
    for key, change in log.get("resumes", [{}])[-1].get("changes", {}).items() if resume else ():
        print(f"resumed with {key} {change['from']!r} -> {change['to']!r} "
              f"(recorded in {out}/train_config.yaml and train_log.json)")
    last = log["evaluations"][-1] if log["evaluations"] else {}
    pre = log.get("pretrain") or {}
    what = f"{log['timesteps']} agent-steps" + (f" after a warm start of {pre['samples']} samples" if pre else "")
    if pre and not log["timesteps"]:
        what = f"by the warm start alone ({pre['samples']} samples, no PPO)"
    best = log.get("best")
    chosen = (f"policy: {out}/policy.npz, the best evaluation (at {best['timesteps']} agent-steps, median {best['metric']} ratio "
              f"to scripted {best['median_ratio']:.2f}); the last: {out}/last.npz" if best else f"policy: {out}/policy.npz")
    print(f"trained {what} in {log['wall_time_s']:.0f} s; "
          f"eval formation_rmse_m {last.get('formation_rmse_m', float('nan')):.3f} "
          f"(scripted {log['scripted_eval_rmse_m']:.3f}); {chosen}")
    return 0


def _in_process_command(cfg: TrainConfig, out: str, resume: bool, run, command: str, header: str, train_run,
                        what: str, steps: str) -> int:
    """``petswarm train`` of an algorithm that trains with torch in this process (``train_run(cfg, out,
    command=, progress=)``, not resumable, no RLlib): the ``header`` line, the run, one summary line
    (``what`` it did, counted in ``steps``: the log's key of its rounds or iterations)."""
    algorithm = cfg.algorithm
    if resume:
        raise ConfigError(f"algorithm: {algorithm} runs are not resumable; drop --resume and start a new run with another --out")
    if run is not None:
        raise ConfigError(f"algorithm: {algorithm} trains with torch in this process (training/{algorithm}.py); drop --backend rllib")
    print(header, flush=True)
    log = train_run(cfg, out, command=command, progress=lambda line: print(line, flush=True))
    best = log.get("best")
    if algorithm == "recurrent" and cfg.recurrent.members > 1:  # training/ensemble.py: one evaluation, of the mean
        chosen_of = f"{cfg.recurrent.keep_members} chosen of {cfg.recurrent.members} " if cfg.recurrent.keep_members else ""
        what_it_is = f"the mean of the {chosen_of}members' {cfg.recurrent.member_checkpoint} students ("
    else:
        what_it_is = f"the best evaluation (after {best['timesteps']} samples, " if best else ""
    chosen = f"policy: {out}/policy.npz" + (
        f", {what_it_is}median {best['metric']} ratio to scripted {best['median_ratio']:.2f}, {best['not_built']} formations "
        f"not built that scripted built)" if best else "")
    print(f"{what} {log['timesteps']} agent-samples in {len(log[steps])} {steps}, {log['wall_time_s']:.0f} s; "
          f"{chosen}; the last: {out}/last.npz")
    return 0


def _recurrent_command(cfg: TrainConfig, out: str, resume: bool, run, command: str) -> int:
    """``algorithm: recurrent``: :func:`petswarm.training.recurrent.train_students` (DAgger from the privileged
    teacher: one student, or the mean of several)."""
    from petswarm.training.recurrent import rounds_for, train_students

    header = (f"recurrent actor by DAgger from the privileged teacher: {rounds_for(cfg)} rounds of "
              f"{cfg.recurrent.samples_per_round} labelled agent-samples (timesteps {cfg.timesteps})")
    if cfg.recurrent.members > 1:  # the mean of several students, one network (training/ensemble.py)
        header = f"{cfg.recurrent.members} students, seeds {cfg.seed}-{cfg.seed + cfg.recurrent.members - 1}, each a " + header
    return _in_process_command(cfg, out, resume, run, command, header, train_students, "trained on", "rounds")


def _recurrent_ppo_command(cfg: TrainConfig, out: str, resume: bool, run, command: str) -> int:
    """``algorithm: recurrent_ppo``: :func:`petswarm.training.recurrent_ppo.train` (PPO anchored to a distilled policy)."""
    from petswarm.training.recurrent_ppo import iterations_for, train

    header = (f"PPO fine-tuning of {cfg.finetune.policy}, anchored to it: {iterations_for(cfg)} iterations of "
              f"{cfg.finetune.rollout_steps} agent-steps (timesteps {cfg.timesteps})")
    return _in_process_command(cfg, out, resume, run, command, header, train, "fine-tuned on", "iterations")
