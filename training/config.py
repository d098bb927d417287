"""The training configuration: every hyper-parameter of a run, validated (pydantic).

The defaults are ``configs/train/ppo.yaml``, shipped in the package (``petswarm.shipped_configs()``)
(the two files are equal, a test checks it); ``load_train_config`` merges a user file and dotted
overrides over them. Keys under ``env.`` are overrides of the environment config
(``configs/default.yaml``) and are validated against it too.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field, ValidationError, model_validator

from petswarm_env.config import (
    Section,
    Config,
    ConfigError,
    flatten_dotted,
    format_validation_error,
    load_config,
    merge_mappings,
    nest_dotted,
    read_yaml,
)
from petswarm import shipped_configs
from petswarm.baselines.learned import Residual
from petswarm.training.randomize import check_pools, draw_config
from petswarm.training.teacher import TeacherGains

DEFAULT_TRAIN_CONFIG = shipped_configs() / "train" / "ppo.yaml"

# the ranges of the training numbers: a run's memory and time stay bounded (PPO's rollout buffer holds
# n_steps x num_envs rows per slave, the networks are a few layers of at most MAX_WIDTH units)
MAX_STEPS = 10**12  # agent-steps of a run: at 10^4 steps/s, three years
MAX_ROLLOUT = 65_536  # n_steps, batch sizes (the shipped 256 and 1024)
ROLLOUT_ROWS = 65_536  # n_steps x num_envs: with 16 slaves and 200 observation floats, 0.8 GB of rollout buffer
MAX_SAMPLES = 10**8  # warm-start and DAgger samples (the shipped at most 200,000)
MAX_WORKERS = 256  # env copies, CPUs, Ray runners
MAX_WIDTH = 1024  # units of one hidden layer (the shipped 64)
MAX_CYCLES = 1_000_000  # as the env's max_cycles


class PPOConfig(Section):
    learning_rate: float = Field(gt=0, le=1.0)
    n_steps: int = Field(ge=8, le=MAX_ROLLOUT)
    batch_size: int = Field(ge=8, le=MAX_ROLLOUT)
    n_epochs: int = Field(ge=1, le=1000)
    gamma: float = Field(gt=0, le=1)
    gae_lambda: float = Field(gt=0, le=1)
    clip_range: float = Field(gt=0, le=10.0)
    ent_coef: float = Field(ge=0, le=10.0)
    vf_coef: float = Field(ge=0, le=100.0)
    max_grad_norm: float = Field(gt=0, le=1e6)
    net_arch: list[Annotated[int, Field(ge=1, le=MAX_WIDTH)]] = Field(min_length=1, max_length=16)
    activation: Literal["tanh", "relu"]
    log_std_init: float = Field(ge=-20.0, le=5.0)  # log σ of the Gaussian policy: σ from 2e-9 to 148 action units
    critic: Literal["local", "state"] = Field(
        "local", description="local: the critic reads the observation (PPO); state: the observation and env.state() (MAPPO)")


class EvalConfig(Section):
    every_steps: int = Field(ge=1, le=MAX_STEPS)
    episodes: int = Field(ge=1, le=10_000)
    seed: int = Field(ge=0, le=2**63 - 1 - 10_000)
    max_cycles: int = Field(ge=1, le=MAX_CYCLES)
    metric: Literal["formation_rmse_m", "formation_hold_rmse_m"] = Field(
        "formation_rmse_m", description="the figure whose median per-seed ratio to scripted picks the best evaluated "
                                        "policy (policy.npz): the whole episode, or from the moment the formation is built")


class CheckpointConfig(Section):
    every_steps: int = Field(ge=1, le=MAX_STEPS)


class PretrainConfig(Section):
    samples: int = Field(ge=0, le=MAX_SAMPLES, description="agent-samples of the scripted reference to imitate; 0 = no warm start")
    noise_std: float = Field(ge=0, le=10.0, description="action noise while collecting (visits recovery states)")
    epochs: int = Field(ge=1, le=1000)
    batch_size: int = Field(ge=8, le=MAX_ROLLOUT)
    learning_rate: float = Field(gt=0, le=1.0)
    dagger_rounds: int = Field(0, ge=0, le=1000, description="DAgger rounds after the cloning: the actor drives, the reference labels")
    dagger_samples: int = Field(0, ge=0, le=MAX_SAMPLES, description="agent-samples the actor collects in each DAgger round")
    teacher: Literal["scripted", "privileged"] = Field(
        "scripted", description="who labels the demonstrations: scripted (the reference, from the observation) or "
                                "privileged (training/teacher.py, from ground truth; the student still reads only the observation)")


class RLlibConfig(Section):
    """``petswarm train --backend rllib`` (training/rllib_backend.py): the ``ppo:`` values map onto
    RLlib's PPO; a rollout is ``ppo.n_steps × num_envs`` env steps, as with SB3."""

    num_env_runners: int = Field(ge=0, le=MAX_WORKERS, description="Ray actors sampling the env (0 = in the driver)")
    num_envs_per_env_runner: int = Field(ge=1, le=MAX_WORKERS, description="env copies each runner steps together")
    sample_timeout_s: float = Field(gt=0, le=86_400.0, description="how long RLlib waits for a runner's samples")


class RecurrentConfig(Section):
    """``algorithm: recurrent`` (training/recurrent.py): a GRU actor over the observation history,
    distilled from the privileged teacher by DAgger. ``timesteps`` is the budget: labelled
    agent-samples over all rounds, ``samples_per_round`` each (the first round driven by the teacher)."""

    hidden_size: int = Field(64, ge=1, le=MAX_WIDTH, description="units of the GRU cell")
    encoder: list[Annotated[int, Field(ge=1, le=MAX_WIDTH)]] = Field(
        default_factory=lambda: [128], max_length=16, description="layers encoding the observation before the GRU")
    head: list[Annotated[int, Field(ge=1, le=MAX_WIDTH)]] = Field(
        default_factory=lambda: [64], max_length=16, description="hidden layers from [encoding, hidden state] to the action")
    samples_per_round: int = Field(20_000, ge=1, le=MAX_SAMPLES, description="labelled agent-samples collected per DAgger round")
    teacher_noise_std: float = Field(0.3, ge=0, le=10.0, description="action noise while the teacher drives (round 0)")
    student_noise_std: float = Field(0.1, ge=0, le=10.0, description="action noise while the student drives (rounds 1, 2, ...)")
    teacher_mix: float = Field(0.5, ge=0, le=1.0, description="DAgger's beta: in round k a robot's step executes the teacher's "
                                                             "action with probability teacher_mix ** k (the student's otherwise)")
    updates_per_round: int = Field(150, ge=1, le=1_000_000, description="gradient steps after each round, on all data so far")
    batch_sequences: int = Field(16, ge=1, le=MAX_ROLLOUT, description="sequences (one robot's stretch of driving each) per step")
    learning_rate: float = Field(1e-3, gt=0, le=1.0)
    learning_rate_final: float | None = Field(
        None, gt=0, le=1.0, description="the last round's learning rate: from learning_rate down to this, linearly over the "
                                        "rounds (None: constant)")
    building_error_m: float = Field(0.3, ge=0, le=1000.0, description="a step counts as building while the robot's formation "
                                                                      "error (ground truth, a label only) exceeds this")
    building_weight: float = Field(3.0, ge=0, le=1000.0, description="extra loss weight of a building step")
    lost_weight: float = Field(5.0, ge=0, le=1000.0, description="extra loss weight of a step without a fresh IR fix (search, lost)")
    near_m: float = Field(0.0, ge=0, le=100.0, description="a step counts as near while the robot's true rim-to-rim gap to another "
                                                          "robot or a user (ground truth, a loss weight only) is below this (0: off)")
    near_weight: float = Field(0.0, ge=0, le=1000.0, description="extra loss weight of a near step (where the teacher's avoidance acts)")
    closing_weight: float = Field(0.0, ge=0, le=1000.0, description="near another body, the square of how much faster the "
                                                                    "student's translation closes on it than the label's costs "
                                                                    "this much more (an asymmetric loss: imperfect imitation "
                                                                    "errs away from bodies; 0: off)")
    contact_window: int = Field(0, ge=0, le=1000, description="the steps up to this many before a contact the robot began (the env's "
                                                              "new_contacts) weigh contact_weight more (0: off)")
    contact_weight: float = Field(0.0, ge=0, le=1000.0, description="extra loss weight of a step in a contact's window")
    eval_every_rounds: int = Field(1, ge=1, le=1_000_000, description="evaluate (and keep the best as policy.npz) every this many rounds")
    members: int = Field(1, ge=1, le=16, description="train this many students of this config, seeds seed, seed + 1, ..., and ship "
                                                     "their mean as one network (training/ensemble.py; 1: one student)")
    member_checkpoint: Literal["best", "last", "validated"] = Field(
        "best", description="with members > 1: policy.npz is the mean of each member's best evaluated student (best), of its "
                            "last round's (last; the mean of the best is then written as members_best.npz), or of whichever "
                            "of the two scores lower on member_grid at member_seeds (validated; training/select_members.py)")
    keep_members: int = Field(0, ge=0, le=16, description="with members > 1: the policy is the mean of this many members, those "
                                                          "whose student scores lowest on member_grid at member_seeds "
                                                          "(training/select_members.py; 0: every member)")
    member_grid: str = Field("configs/eval/heldout_recurrent.yaml", min_length=1,
                             description="with keep_members or member_checkpoint: validated: the grid file whose cells "
                                         "score each member's student alone")
    member_seeds: list[Annotated[int, Field(ge=900_000_000, le=2**62)]] = Field(
        default_factory=lambda: [940_000_000, 942_000_000, 944_000_000], min_length=1, max_length=16,
        description="with keep_members or validated: the grid's seeds the students are scored on (held-out: >= 900 000 000, "
                    "docs/training.md 'Held-out seeds'; none of the sets the docs report on)")
    validation_fraction: float = Field(0.0, ge=0.0, lt=1.0, description="share of each round's episodes whose sequences are held "
                                                                        "out of the fit: their loss and explained share are logged "
                                                                        "(0: none)")
    validation_every: int = Field(0, ge=0, le=1_000_000, description="with validation_fraction: also measure the held-out loss "
                                                                     "every this many gradient steps within a round, logged as "
                                                                     "the round's curve (0: after the round only)")
    early_stopping: bool = Field(False, description="with validation_fraction: each round ends with the weights of the lowest "
                                                    "held-out loss among the round's measurements (its start and every "
                                                    "validation_every steps), not the last step's")
    weight_decay: float = Field(0.0, ge=0.0, le=1.0, description="decoupled weight decay of the fit (AdamW; 0: Adam, as before)")
    encoder_dropout: float = Field(0.0, ge=0.0, lt=1.0, description="dropout after each encoder layer during the fit (none at "
                                                                    "validation, evaluation and in the exported policy)")
    target: Literal["action", "estimate"] = Field(
        "action", description="action: the GRU learns the teacher's action (or, with residual_of, its correction); estimate: "
                              "it learns what the teacher reads (offset to the reference point, its velocity, the heading error, "
                              "the master's turn rate) and acts with the teacher's law on it (training/estimator.py)")
    estimate_clip_m: float = Field(1.5, gt=0, le=100.0, description="target: estimate: the offset label's length is clipped to "
                                                                   "this (beyond it the teacher's approach runs at full speed)")
    estimate_gain: float = Field(4.0, gt=0, le=1000.0, description="target: estimate: the law's approach gain near the point "
                                                                    "(1/s; the teacher's is 4)")
    teacher_push: float = Field(
        TeacherGains.push, ge=0, le=100.0,
        description="the labelling teacher's avoidance push (TeacherGains.push, m/s per unit of missing clearance)")
    teacher_user_keep_out_m: float = Field(
        TeacherGains.user_keep_out_m, ge=0, le=10.0,
        description="the labelling teacher's keep-out of its reference points from every user (TeacherGains.user_keep_out_m)")
    teacher_orphan_to_slot: bool = Field(
        TeacherGains.orphan_to_slot,
        description="the labelling teacher drives a slave whose reference neighbour is off to its slot about the master "
                    "(TeacherGains.orphan_to_slot)")

    teacher_master_command: bool = Field(
        TeacherGains.master_command,
        description="the labelling teacher's reference points lead by what the master commands beyond its motion "
                    "(TeacherGains.master_command)")
    teacher_differential_gain: float = Field(
        TeacherGains.differential_gain, gt=0, le=100.0,
        description="the labelling teacher's approach gain on a differential body (TeacherGains.differential_gain, 1/s)")

    def teacher_gains(self) -> TeacherGains:
        """The labelling teacher's constants: its defaults with the five above."""
        return TeacherGains(push=self.teacher_push, user_keep_out_m=self.teacher_user_keep_out_m,
                            orphan_to_slot=self.teacher_orphan_to_slot, master_command=self.teacher_master_command,
                            differential_gain=self.teacher_differential_gain)

    @model_validator(mode="after")
    def _check_validation(self) -> RecurrentConfig:
        if self.member_checkpoint == "validated" and self.members == 1:
            raise ValueError("recurrent.member_checkpoint: validated chooses among the students of an ensemble; set "
                             "recurrent.members above 1, or member_checkpoint: best")
        if self.keep_members and self.keep_members >= self.members:
            raise ValueError(f"recurrent.keep_members ({self.keep_members}) must be below recurrent.members ({self.members}), "
                             "or 0 to keep every member")
        if (self.early_stopping or self.validation_every) and self.validation_fraction == 0.0:
            raise ValueError("recurrent.early_stopping and recurrent.validation_every need held-out sequences; set "
                             "recurrent.validation_fraction (e.g. 0.2)")
        return self


class FinetuneConfig(Section):
    """``algorithm: recurrent_ppo`` (training/recurrent_ppo.py): PPO fine-tuning of a distilled recurrent
    policy, anchored to it. ``timesteps`` is the budget: agent-steps of the PPO rollouts,
    ``rollout_steps`` per iteration."""

    policy: str = Field("baselines/models/recurrent_long.npz", min_length=1, description=(
        "the distilled recurrent policy (.npz) to start from and anchor to: a path, a shipped model "
        "(baselines/models/NAME.npz), or learned"))
    rollout_steps: int = Field(6_000, ge=8, le=MAX_ROLLOUT * 16, description="agent-steps collected per PPO iteration")
    chunk: int = Field(32, ge=1, le=10_000, description="steps of a training chunk (BPTT from the stored hidden state at its start)")
    chunks_per_batch: int = Field(32, ge=1, le=MAX_ROLLOUT, description="chunks per gradient step")
    epochs: int = Field(4, ge=1, le=1000, description="passes over each iteration's chunks")
    learning_rate: float = Field(1e-4, ge=0, le=1.0, description="the actor's Adam step size (0: the actor never moves)")
    critic_learning_rate: float = Field(1e-3, gt=0, le=1.0, description="the critic's Adam step size")
    critic_net: list[Annotated[int, Field(ge=1, le=MAX_WIDTH)]] = Field(
        default_factory=lambda: [256, 256], min_length=1, max_length=16, description="the critic MLP on [observation, state()]")
    critic_warmup_epochs: int = Field(10, ge=0, le=10_000, description="value-only passes over the first rollout before the actor moves")
    gamma: float = Field(0.98, gt=0, le=1)
    gae_lambda: float = Field(0.95, gt=0, le=1)
    clip_range: float = Field(0.2, gt=0, le=10.0)
    log_std_init: float = Field(-3.0, ge=-20.0, le=5.0, description="log sigma of the Gaussian head at the start, in the actor's "
                                                                     "output units (-3: 0.05)")
    learn_log_std: bool = Field(True, description="the log sigma is a learned parameter (per action value)")
    anchor_start: float = Field(1.0, ge=0, le=1e9, description="weight of the anchor at the first iteration: the KL from the "
                                                               "distilled policy's Gaussian of the same sigma, E||mu - mu_distilled||^2 / 2 sigma^2")
    anchor_end: float = Field(0.1, ge=0, le=1e9, description="... at the last (geometric decay between them)")
    bc_samples: int = Field(0, ge=0, le=MAX_SAMPLES, description="teacher-labelled agent-samples collected once with the distilled "
                                                                 "policy driving (DAgger's labels) and kept as a BC batch (0: none)")
    bc_coef: float = Field(0.5, ge=0, le=1e6, description="weight of the BC batch's loss")
    bc_sequences: int = Field(4, ge=1, le=MAX_ROLLOUT, description="BC sequences per gradient step")
    reward: Literal["own", "team"] = Field("own", description="own: each slave's env reward; team: the mean over the live slaves")
    max_grad_norm: float = Field(1.0, gt=0, le=1e6)
    target_kl: float = Field(0.0, ge=0, le=100.0, description="an iteration's epochs stop once the mean approximate KL of its "
                                                              "steps exceeds this (0: never)")
    eval_every: int = Field(2, ge=1, le=1_000_000, description="evaluate (and keep the best as policy.npz) every this many "
                                                              "iterations, after the last, and the distilled policy before the first")


class TrainConfig(Section):
    seed: int = Field(ge=0, le=2**63 - 1)
    timesteps: int = Field(ge=0, le=MAX_STEPS, description="PPO's budget in agent-steps (rows); 0 = the warm start alone (pretrain:)")
    num_envs: int = Field(ge=1, le=MAX_WORKERS)
    num_cpus: int = Field(ge=0, le=MAX_WORKERS)
    env: dict[str, Any]
    ppo: PPOConfig
    eval: EvalConfig
    checkpoint: CheckpointConfig
    pretrain: PretrainConfig
    rllib: RLlibConfig
    randomize: dict[str, list[Any]] = Field(
        default_factory=dict, description="domain randomization: dotted env key -> pool of values, one drawn per episode "
                                          "(training/randomize.py)")
    residual_of: Literal["scripted"] | None = Field(
        None, description="scripted: the policy learns a correction added to the scripted reference's action "
                          "(training/residual.py); null: the policy is the action")
    residual_scale: float = Field(1.0, gt=0, le=1, description="with residual_of: the correction's bound in action units")
    algorithm: Literal["ppo", "recurrent", "recurrent_ppo"] = Field(
        "ppo", description="ppo: PPO (the ppo: and pretrain: sections); recurrent: a GRU actor distilled from the privileged "
                           "teacher by DAgger (the recurrent: section, training/recurrent.py); recurrent_ppo: PPO fine-tuning "
                           "of a distilled GRU actor, anchored to it (the finetune: section, training/recurrent_ppo.py)")
    recurrent: RecurrentConfig = Field(default_factory=RecurrentConfig)
    finetune: FinetuneConfig = Field(default_factory=FinetuneConfig)

    @model_validator(mode="after")
    def _check_rollout(self) -> TrainConfig:
        rows = self.ppo.n_steps * self.num_envs
        if rows > ROLLOUT_ROWS:
            raise ValueError(f"ppo.n_steps x num_envs is {rows} rollout rows per slave, more than the {ROLLOUT_ROWS} the "
                             "memory budget holds; lower ppo.n_steps or num_envs")
        return self

    def residual(self) -> Residual | None:
        """The residual the policy learns (:class:`petswarm.baselines.learned.Residual`), or None."""
        return Residual(self.residual_of, self.residual_scale) if self.residual_of else None

    def env_config(self) -> Config:
        """The environment the policy trains on (without the pools' draws)."""
        return load_config(overrides=self.env)

    def eval_env_config(self) -> Config:
        """The environment of the periodic evaluation: the training one, ``eval.max_cycles`` long."""
        return load_config(overrides={**self.env, "max_cycles": self.eval.max_cycles})

    def eval_seeds(self) -> list[int]:
        """The seeds of the periodic evaluation, the same for the learned and the scripted policy."""
        return list(range(self.eval.seed, self.eval.seed + self.eval.episodes))

    def eval_episodes(self) -> list[tuple[Config, int]]:
        """(config, seed) of each periodic evaluation episode: with pools, the config drawn with
        that seed (:func:`petswarm.training.randomize.draw_config`), ``eval.max_cycles`` long."""
        env = {**self.env, "max_cycles": self.eval.max_cycles}
        return [(draw_config(env, self.randomize, s), s) for s in self.eval_seeds()]


def load_train_config(path: str | os.PathLike | None = None, overrides: dict[str, Any] | None = None,
                      base: str | os.PathLike | None = None) -> TrainConfig:
    """Defaults from configs/train/ppo.yaml (or the complete config ``base``: a run's
    train_config.yaml when it resumes), then ``path``, then dotted overrides; validated. Keys
    under ``env.`` are checked against the environment config too."""
    data = read_yaml(DEFAULT_TRAIN_CONFIG if base is None else base)
    user: dict[str, Any] = {}
    if path is not None:
        user = read_yaml(path)
        env_user, pools_user = user.pop("env", None), user.pop("randomize", None)
        try:
            data = merge_mappings(data, user)
        except ConfigError as exc:
            raise ConfigError(f"{exc} (in training config file '{path}')") from None
        if env_user is not None:
            data["env"] = {**data.get("env", {}), **env_user}
        if pools_user is not None:  # pool by pool, as env: key by key
            data["randomize"] = {**(data.get("randomize") or {}), **pools_user}
    for key, value in (overrides or {}).items():
        if key.startswith("env."):
            data["env"] = {**data.get("env", {}), key[4:]: value}
        elif key.startswith("randomize."):  # a pool's key is dotted itself: randomize.swarm.num_slaves=[2, 4]
            data["randomize"] = {**(data.get("randomize") or {}), key[len("randomize."):]: value}
        else:
            data = merge_mappings(data, nest_dotted({key: value}))
    # a pool set to null (--set randomize.KEY=null, or KEY: null in a file) is dropped
    data["randomize"] = {k: v for k, v in (data.get("randomize") or {}).items() if v is not None}
    try:
        cfg = TrainConfig.model_validate(data)
    except ValidationError as exc:
        message = format_validation_error(exc)
        loc = exc.errors()[0]["loc"]
        from_set = bool(loc) and any(key == ".".join(map(str, loc)) or key.startswith(f"{loc[0]}.") for key in (overrides or {}))
        node = user if path is not None else {}
        for part in loc:  # the file that holds the key: the given config, else the base (a resumed run's own)
            node = node.get(part) if isinstance(node, dict) else None
        if loc and not from_set and (node is not None or base is None) and path is not None:
            message += f" (in training config file '{path}')"
        elif loc and not from_set and base is not None:
            message += f" (in '{base}')"
        raise ConfigError(message) from None
    try:
        cfg.env_config()  # validates the env overrides (unknown key / bad value -> ConfigError)
    except ConfigError as exc:
        raise ConfigError(f"{exc} (in env: of the training config, e.g. --set env.KEY=VALUE)") from None
    if cfg.randomize:
        check_pools(cfg.env, cfg.randomize)
    if not cfg.residual_of and cfg.residual_scale != 1.0:
        raise ConfigError(f"residual_scale: {cfg.residual_scale} bounds a residual policy's correction, but residual_of is null; "
                          "set residual_of: scripted, or drop residual_scale")
    if cfg.algorithm == "recurrent" and cfg.recurrent.target == "estimate" and cfg.residual_of:
        raise ConfigError(f"recurrent.target: estimate acts with the teacher's law on the GRU's estimate, not as a correction of "
                          f"another policy; set residual_of: null (got {cfg.residual_of!r})")
    if cfg.algorithm == "recurrent" and cfg.timesteps == 0:
        raise ConfigError("algorithm: recurrent distils the teacher in rounds of DAgger whose labelled samples are timesteps: give "
                          f"timesteps > 0 (got {cfg.timesteps})")
    if cfg.algorithm == "recurrent_ppo" and cfg.timesteps < cfg.finetune.rollout_steps:
        raise ConfigError(f"algorithm: recurrent_ppo fine-tunes in iterations of finetune.rollout_steps "
                          f"({cfg.finetune.rollout_steps}) agent-steps, but timesteps is {cfg.timesteps}: give timesteps >= "
                          "finetune.rollout_steps")
    if cfg.algorithm == "recurrent_ppo" and cfg.finetune.anchor_end > cfg.finetune.anchor_start:
        raise ConfigError(f"finetune.anchor_end ({cfg.finetune.anchor_end}) is above finetune.anchor_start "
                          f"({cfg.finetune.anchor_start}): the anchor decays; swap them")
    if cfg.algorithm == "ppo" and cfg.timesteps == 0 and cfg.pretrain.samples == 0:
        raise ConfigError("timesteps: 0 trains by the warm start alone, but pretrain.samples is 0 too: nothing would be trained; "
                          "give timesteps > 0 (PPO) or pretrain.samples > 0 (imitation)")
    if cfg.algorithm == "ppo" and cfg.residual_of and cfg.pretrain.samples > 0:
        raise ConfigError(f"residual_of: {cfg.residual_of} starts training at the {cfg.residual_of} reference itself (a zero "
                          f"correction), so the warm start that imitates it has nothing to learn; set pretrain.samples: 0 "
                          f"(got {cfg.pretrain.samples}) or residual_of: null")
    return cfg


# keys a resumed run may change (its schedule and its budget); every other key stays the run's own
# what a resumed run may change: its budget, its schedules, and where it runs (processes, RLlib env runners)
RESUMABLE = ("timesteps", "checkpoint.every_steps", "eval.every_steps", "num_cpus", "rllib.num_env_runners",
             "rllib.sample_timeout_s")


def resume_changes(saved: TrainConfig, requested: TrainConfig, out: str | os.PathLike) -> dict[str, dict[str, Any]]:
    """The keys in which ``requested`` differs from the run's ``saved`` config, as ``{key: {"from":
    old, "to": new}}``; a :class:`ConfigError` naming the key if one of them may not change on
    resume (:data:`RESUMABLE`)."""
    old, new = flatten_dotted(saved.model_dump(mode="json")), flatten_dotted(requested.model_dump(mode="json"))
    changes = {}
    for key in sorted(set(old) | set(new)):
        if old.get(key) == new.get(key):
            continue
        if key not in RESUMABLE:
            raise ConfigError(
                f"cannot resume '{out}' with {key}={new.get(key)!r}: the run was trained with {old.get(key)!r} and a resumed run "
                f"keeps its config; on --resume only {', '.join(RESUMABLE)} may change (start a new run with another --out "
                f"to change {key})")
        changes[key] = {"from": old.get(key), "to": new.get(key)}
    return changes
