"""A recurrent slave policy distilled from the privileged teacher (``algorithm: recurrent``,
``configs/train/recurrent.yaml``; ``petswarm train --config recurrent``).

Why a memory: a robot's observation is a frame of intermittent evidence — IR fixes of its neighbours
that come and go, headings that arrive in radio frames — and a one-frame network cannot integrate
it; a GRU over the robot's own observation history can (Cho et al. 2014). The actor
(:class:`RecurrentActor`): an encoder MLP, a GRU cell, a head reading ``[encoding, hidden state]``;
it reads only the observation, never ground truth, and its hidden state starts at zero when the
robot starts (or restarts) slave-role driving — exactly what :class:`petswarm.baselines.learned.RecurrentPolicy`
does at inference, which is the same network in numpy.

How it learns: DAgger (Ross, Gordon & Bagnell 2011). Round 0: the teacher
(:class:`petswarm.training.teacher.PrivilegedTeacher`, which reads ground truth and exists only at
training time) drives with action noise and labels what it does. Rounds 1, 2, ...: the student drives
(its exported numpy policy, with a little noise; in round ``k`` each robot's step executes the
teacher's action instead with probability ``recurrent.teacher_mix ** k``, DAgger's β mixture, so the
early data stays near the states the teacher visits), the teacher labels every state the student visits,
the data is aggregated and the student refitted on everything so far — by backpropagation through
time over whole sequences (one robot's stretch of driving, from its hidden state's zero). A robot
with no fresh IR fix of anyone is labelled by the scripted reference's rejoin and search instead
(:class:`petswarm.training.warm_start.TeacherLabels`: no observation could follow the teacher
there). Rare states weigh more in the loss: building (the robot's true formation error above
``recurrent.building_error_m``, a label, never an input) and lost (no fresh fix); and, where contacts
happen, near (the robot's true gap to another robot or a user below ``recurrent.near_m``: where the
teacher's avoidance acts) and the ``recurrent.contact_window`` steps that led into a contact the robot
began (the env's ``new_contacts``: the teacher's way out of the states the driver ran into). Ground
truth is a loss weight only, as the building weight.

The budget: ``timesteps`` labelled agent-samples in all, ``recurrent.samples_per_round`` per round,
so the number of rounds scales with ``--timesteps``; the gradient steps per round are fixed, so the
time grows linearly with it. After every ``recurrent.eval_every_rounds`` rounds the student is
evaluated against the scripted reference on the evaluation seeds (:func:`petswarm.training.callbacks.evaluate_and_keep`):
the best evaluation is ``policy.npz``, the last round's student ``last.npz``.

Generalization inside the fit: with ``recurrent.validation_fraction`` a share of each round's episodes
(every robot's sequence of them) is never fitted; the loss on them and on as many fitted sequences is
logged after each round, and with ``validation_every`` also within it (the round's ``curve`` in the
train log). With ``early_stopping`` a round ends with the weights of its lowest held-out loss (Prechelt
1998), and the next round's student is that one; ``weight_decay`` (AdamW) and ``encoder_dropout`` are
the fit's other regularizers. All four are off by default.

With ``residual_of: scripted`` the GRU learns a correction of the scripted reference's action
(residual policy learning, as training/residual.py, ``residual_scale`` its bound): its targets are
``clip((teacher − reference) / residual_scale, −1, 1)``, so the reference's precise holding is where
it starts and the memory only has to learn where the teacher does better.

With ``recurrent.target: estimate`` (``configs/train/estimator.yaml``) the GRU's targets are not the
teacher's action but what the teacher reads — the offset to the true reference point, its velocity,
the heading error and the master's turn rate, in the robot's own frame — and the policy that ships
acts with the teacher's law on that estimate (:mod:`petswarm.training.estimator`,
:mod:`petswarm.baselines.estimator`); the rounds, the fit and the evaluation are the same.

Entry point for other tools: :func:`train_recurrent` ``(config, timesteps, seed, out_dir) -> path of policy.npz``.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
import yaml

from petswarm.baselines.estimator import OUTPUTS, EstimatorPolicy
from petswarm.baselines.learned import GRUCell, Recurrent, RecurrentPolicy, Residual, save_policy
from petswarm.baselines.policy import PolicySpec
from petswarm.training.callbacks import LAST_POLICY, evaluate_and_keep, policy_info, public_log, scripted_reference
from petswarm.training.config import ConfigError, TrainConfig, load_train_config
from petswarm.training.estimator import EstimateLabels, estimator_meta
from petswarm.training.teacher import TeacherGains
from petswarm.training.vec_env import training_env
from petswarm.training.warm_start import TeacherLabels
from petswarm_env.config import Config
from petswarm_env.env import PetSwarmEnv
from petswarm_env.files import write_json_atomic, write_text_atomic
from petswarm_env.observe import ObservationLayout

ALGORITHM = "recurrent actor (GRU) distilled from the privileged teacher by DAgger"
ALGORITHM_ESTIMATE = "recurrent estimator (GRU) of what the privileged teacher reads, by DAgger, acting with the teacher's law"


class RecurrentActor(torch.nn.Module):
    """Encoder MLP -> GRU -> head MLP on ``[encoding, hidden state]`` -> 3 action means, or with
    ``outputs`` another count (an estimate: module docstring). ``dropout`` after each encoder layer
    acts only in training mode (Srivastava et al. 2014; torch's inverted dropout, so the exported
    weights need no rescaling)."""

    def __init__(self, obs_size: int, encoder: list[int], hidden_size: int, head: list[int], activation: str = "tanh",
                 outputs: int = 3, dropout: float = 0.0):
        super().__init__()
        act = torch.nn.Tanh if activation == "tanh" else torch.nn.ReLU
        self.activation = activation
        mods: list[torch.nn.Module] = []
        width = obs_size
        for n in encoder:
            mods += [torch.nn.Linear(width, n), act()] + ([torch.nn.Dropout(dropout)] if dropout > 0.0 else [])
            width = n
        self.encoder = torch.nn.Sequential(*mods)
        self.gru = torch.nn.GRU(width, hidden_size, batch_first=True)
        mods, w = [], width + hidden_size
        for n in head:
            mods += [torch.nn.Linear(w, n), act()]
            w = n
        mods.append(torch.nn.Linear(w, outputs))
        self.head = torch.nn.Sequential(*mods)

    def forward(self, x: torch.Tensor, h0: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        """``x`` (batch, time, obs) -> (action means (batch, time, 3), last hidden state (1, batch, H))."""
        e = self.encoder(x)
        hs, h_last = self.gru(e, h0)
        return self.head(torch.cat([e, hs], dim=-1)), h_last

    def export(self) -> tuple[list[tuple[np.ndarray, np.ndarray]], Recurrent]:
        """The layers (encoder's, then head's) and the GRU cell of :func:`petswarm.baselines.learned.save_policy`."""
        def linears(seq):
            return [(m.weight.detach().numpy().copy(), m.bias.detach().numpy().copy()) for m in seq if isinstance(m, torch.nn.Linear)]
        enc = linears(self.encoder)
        g = self.gru
        cell = GRUCell(*(getattr(g, name).detach().numpy().copy() for name in ("weight_ih_l0", "weight_hh_l0", "bias_ih_l0", "bias_hh_l0")))
        return enc + linears(self.head), Recurrent(len(enc), cell)


def build_actor(cfg: TrainConfig, obs_size: int) -> RecurrentActor:
    """A fresh actor of ``recurrent:``'s sizes; with ``residual_of`` its last layer is zero, so the
    first policy is the base itself."""
    r = cfg.recurrent
    outputs = len(OUTPUTS) if r.target == "estimate" else 3
    actor = RecurrentActor(obs_size, list(r.encoder), r.hidden_size, list(r.head), cfg.ppo.activation, outputs, r.encoder_dropout)
    if cfg.residual_of:
        with torch.no_grad():
            actor.head[-1].weight.zero_()
            actor.head[-1].bias.zero_()
    return actor


def numpy_policy(actor: RecurrentActor, spec: PolicySpec, residual: Residual | None = None,
                 estimator: dict[str, Any] | None = None) -> RecurrentPolicy:
    """The actor's current weights as the numpy policy that ships (for an env of the layout it trains
    on; with ``residual``, correcting that base policy's action; with ``estimator``, the estimating
    policy of :mod:`petswarm.baselines.estimator`)."""
    layers, recurrent = actor.export()
    if estimator is not None:
        return EstimatorPolicy(spec, layers, actor.activation, np.arange(spec.layout.size), recurrent, {"estimator": estimator})
    return RecurrentPolicy(spec, layers, actor.activation, np.arange(spec.layout.size), recurrent,
                           residual.meta() if residual else None)


def export_actor(actor: RecurrentActor, path: str | os.PathLike, layout: ObservationLayout, info: dict[str, Any],
                 residual: Residual | None = None, estimator: dict[str, Any] | None = None) -> None:
    layers, recurrent = actor.export()
    save_policy(path, layers, actor.activation, layout, info, residual=residual, recurrent=recurrent, estimator=estimator)


def estimator_of(cfg: TrainConfig, spec: PolicySpec) -> dict[str, Any] | None:
    """The ``estimator`` record of a ``recurrent.target: estimate`` run (None for an action target)."""
    if cfg.recurrent.target != "estimate":
        return None
    return estimator_meta(cfg.recurrent.estimate_clip_m, spec, TeacherGains(gain=cfg.recurrent.estimate_gain))


@dataclass
class Sequence:
    """One robot's stretch of slave-role driving: its observations (T, obs), the teacher's actions
    (T, 3; with ``residual_of``, the corrections of the base's actions toward them; with
    ``recurrent.target: estimate``, the estimate's targets (T, 7)) and each step's loss weight (T,)."""

    obs: np.ndarray
    act: np.ndarray
    weight: np.ndarray
    episode: int = 0  # the episode's index in its round's collection (a validation split holds whole episodes out)
    toward: np.ndarray | None = None  # (T, 2): a near step's unit vector to the nearest body in the robot's frame, else 0


def collect_sequences(env, samples: int, seed: int, cfg: TrainConfig, driver: RecurrentPolicy | None,
                      noise_std: float, beta: float = 0.0) -> tuple[list[Sequence], dict[str, int]]:
    """Episodes ``seed, seed + 1, …`` of the fixed-agents training ``env`` until ``samples``
    labelled agent-steps (the last episode is played to its end): the teacher drives (``driver``
    None) or the student does — each robot's step executing the teacher's action instead with
    probability ``beta`` (DAgger's mixture) — with Gaussian action noise of ``noise_std``; every
    live robot's step is labelled by the teacher; a seed whose start-up fails in the env's reset (a
    swarm that does not organize, a belt that never wakes) is skipped (counted as ``unorganized``). Returns the
    sequences (a robot's sequence ends when it stops driving; a new one starts when it rejoins) and
    counts of building, lost and near steps and of contacts (a contact's window of steps weighs more:
    ``recurrent.contact_window``). With ``recurrent.target: estimate`` the targets are what the
    teacher reads (:class:`petswarm.training.estimator.EstimateLabels`), and a step without them (no
    reference point, or lost: the law does not act there) weighs zero — the GRU still reads it."""
    r = cfg.recurrent
    residual = cfg.residual()
    gains = r.teacher_gains()  # the labelling teacher's constants
    rng = np.random.default_rng(seed)
    out: list[Sequence] = []
    counts = {"samples": 0, "building": 0, "lost": 0, "near": 0, "contacts": 0, "unorganized": 0}
    episode = 0
    while counts["samples"] < samples:
        episode += 1
        try:
            rows, infos = env.reset(seed=seed + episode - 1)
        except RuntimeError:  # this draw's start-up failed (OrganizeError, or a belt that never woke up): no data, the next seed
            counts["unorganized"] += 1
            if counts["unorganized"] == episode >= 20:
                raise ConfigError(f"none of seeds {seed}..{seed + episode - 1} organized a swarm; check the env config and randomize pools")
            continue
        label = TeacherLabels(env, gains=gains)  # after the reset: the episode's env
        estimates = EstimateLabels(env, r.estimate_clip_m) if r.target == "estimate" else None
        base = residual.base_policy(PolicySpec.from_env(env)) if residual else None  # a residual's target: teacher - base
        if driver is not None:
            driver.reset()
        open_: dict[str, list[tuple[np.ndarray, np.ndarray, float]]] = {}
        while env.agents:
            live = [a for a in env.agents if infos[a]["active"]]
            for a in [a for a in open_ if a not in live]:  # stopped driving: its sequence is complete
                out.append(_sequence(open_.pop(a), episode))
            if not live:
                rows, _, _, _, infos = env.step({})
                continue
            seen = {a: rows[a] for a in live}
            target = label(seen)
            executed = target if driver is None else driver.act_all(seen)  # the student acts every step: its memory runs
            if driver is not None and beta > 0.0:
                executed = {a: target[a] if rng.random() < beta else executed[a] for a in live}
            noisy = {a: np.clip(v + rng.normal(0.0, noise_std, 3), -1.0, 1.0).astype(np.float32) for a, v in executed.items()}
            if estimates is not None:  # what the teacher reads, in the estimate's units (and whether the step counts)
                read = estimates(label.teacher, seen)
                learn = {a: read[a][0] for a in live}
            elif base is not None:  # the correction that turns the base's action into the teacher's, in the residual's units
                base_act = base.act_all(seen)
                learn = {a: np.clip((target[a] - base_act[a]) / residual.scale, -1.0, 1.0) for a in live}
            else:
                learn = target
            gaps, toward = nearest_bodies(env, live) if r.near_m > 0 else ({}, {})
            for a in live:
                lost = label.lost(rows[a])
                building = infos[a]["formation_error_m"] > r.building_error_m  # ground truth as a loss weight, never an input
                near = gaps.get(a, math.inf) < r.near_m  # the same: where the teacher's avoidance acts
                w = 1.0 + r.lost_weight * lost + r.building_weight * building + r.near_weight * near
                counts["near"] += int(near)
                if estimates is not None and not read[a][1]:
                    w = 0.0
                counts["lost"] += int(lost)
                counts["building"] += int(building)
                open_.setdefault(a, []).append((rows[a], learn[a], w, toward[a] if near else _NOT_NEAR))
            counts["samples"] += len(live)
            rows, _, _, _, infos = env.step(noisy)
            if r.contact_window > 0:  # the steps that led into a contact this robot began weigh more (their labels are
                for a in live:        # the teacher's way out of the states the driver ran into)
                    if a in open_ and infos.get(a, {}).get("new_contacts", 0) > 0:
                        counts["contacts"] += 1
                        steps = open_[a]
                        for j in range(max(0, len(steps) - r.contact_window), len(steps)):
                            o, t, w, u = steps[j]
                            steps[j] = (o, t, w + r.contact_weight if w > 0 else w, u)
        out.extend(_sequence(steps, episode) for steps in open_.values())
    return out, counts


_NOT_NEAR = np.zeros(2, np.float32)


def nearest_gaps(env, agents: list[str]) -> dict[str, float]:
    """Each agent's true rim-to-rim gap to the nearest other body (robot or user) of ``env``'s world:
    ground truth, for the loss only (``recurrent.near_m``)."""
    return nearest_bodies(env, agents)[0]


def nearest_bodies(env, agents: list[str]) -> tuple[dict[str, float], dict[str, np.ndarray]]:
    """Each agent's true rim-to-rim gap to the nearest other body (robot or user) and the unit vector
    toward that body's centre in the robot's own frame (x forward, y left): ground truth, for the
    loss only (``recurrent.near_m``, ``recurrent.closing_weight``)."""
    centers, radii, headings = env.truth.truth_arrays()
    centers, radii = np.asarray(centers, float), np.asarray(radii, float)
    gaps, toward = {}, {}
    for a in agents:
        i = env.agent_robot(a)
        d = centers - centers[i]
        dist = np.hypot(d[:, 0], d[:, 1])
        gap = dist - radii - radii[i]
        gap[i] = math.inf
        j = int(np.argmin(gap))
        if j == i or not math.isfinite(gap[j]):
            gaps[a], toward[a] = math.inf, _NOT_NEAR
            continue
        c, s = math.cos(headings[i]), math.sin(headings[i])
        ux, uy = d[j] / max(dist[j], 1e-9)
        gaps[a], toward[a] = float(gap[j]), np.array([c * ux + s * uy, -s * ux + c * uy], np.float32)
    return gaps, toward


def _sequence(steps: list[tuple[np.ndarray, np.ndarray, float, np.ndarray]], episode: int) -> Sequence:
    return Sequence(np.stack([s[0] for s in steps]).astype(np.float32), np.stack([s[1] for s in steps]).astype(np.float32),
                    np.array([s[2] for s in steps], dtype=np.float32), episode,
                    np.stack([s[3] for s in steps]).astype(np.float32))


def split_episodes(seqs: list[Sequence], fraction: float, rng: np.random.Generator) -> tuple[list[Sequence], list[Sequence]]:
    """(fitted, held out): each episode's sequences go together to the held-out side with probability
    ``fraction`` — whole episodes, since a robot's neighbours in the same episode (the same user path,
    the same formation) are not new to a network that fitted them."""
    episodes = sorted({s.episode for s in seqs})
    out = {e for e, u in zip(episodes, rng.random(len(episodes))) if u < fraction}
    return [s for s in seqs if s.episode not in out], [s for s in seqs if s.episode in out]


def batch(seqs: list[Sequence]) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Sequences padded at their ends to the longest: inputs (B, T, obs), targets (B, T, 3), weights
    (B, T; zero on padding, which comes after every real step and so never reaches one through the GRU)."""
    n = max(len(s.obs) for s in seqs)
    x = np.zeros((len(seqs), n, seqs[0].obs.shape[1]), np.float32)
    y = np.zeros((len(seqs), n, seqs[0].act.shape[1]), np.float32)
    w = np.zeros((len(seqs), n), np.float32)
    for i, s in enumerate(seqs):
        x[i, :len(s.obs)], y[i, :len(s.obs)], w[i, :len(s.obs)] = s.obs, s.act, s.weight
    return torch.from_numpy(x), torch.from_numpy(y), torch.from_numpy(w)


def batch_toward(seqs: list[Sequence]) -> torch.Tensor:
    """The sequences' ``toward`` vectors padded as :func:`batch` pads (B, T, 2; zero where none)."""
    n = max(len(s.obs) for s in seqs)
    u = np.zeros((len(seqs), n, 2), np.float32)
    for i, s in enumerate(seqs):
        if s.toward is not None:
            u[i, :len(s.toward)] = s.toward
    return torch.from_numpy(u)


def closing_excess(pred: torch.Tensor, y: torch.Tensor, toward: torch.Tensor) -> torch.Tensor:
    """How much more the predicted translation closes on the nearest body than the target's (B, T;
    ≥ 0; zero where ``toward`` is zero): the asymmetric part of the loss with ``recurrent.closing_weight``."""
    return torch.relu(((pred[..., :2] - y[..., :2]) * toward).sum(-1))


def fit(actor: RecurrentActor, opt: torch.optim.Optimizer, data: list[Sequence], updates: int, batch_sequences: int,
        rng: np.random.Generator, held_out: list[Sequence] | None = None, every: int = 0,
        keep_best: bool = False, closing_weight: float = 0.0) -> tuple[float, list[dict[str, float]]]:
    """``updates`` gradient steps of the weighted MSE to the teacher's actions, each on
    ``batch_sequences`` sequences drawn from ``data`` (backpropagation through time over whole
    sequences). Returns the mean loss of the last tenth of the steps and the round's curve: with
    ``held_out`` sequences (never fitted), at the start, every ``every`` steps (0: none between) and
    at the end, the loss of :func:`validation_loss` on them and on as many fitted sequences (the same
    weights, no dropout: the two are comparable). With ``keep_best`` the actor ends with the weights of
    the curve's lowest held-out loss (early stopping; Prechelt 1998) and ``kept`` marks that point."""
    curve: list[dict[str, float]] = []
    best: tuple[float, dict[str, torch.Tensor]] | None = None
    if held_out:  # a fixed sample of the fitted sequences, as many as are held out (each check's cost stays that of two sets)
        seen = [data[i] for i in sorted(np.random.default_rng(len(data)).choice(len(data), min(len(held_out), len(data)),
                                                                               replace=False))]

    def check(step: int) -> None:
        nonlocal best
        val, zero = validation_loss(actor, held_out, batch_sequences)
        fitted, _ = validation_loss(actor, seen, batch_sequences)
        curve.append({"update": step, "fit_loss": fitted, "validation_loss": val,
                      "validation_explained": 1.0 - val / zero if zero > 0 else float("nan")})
        if keep_best and (best is None or val < best[0]):
            best = (val, {k: v.detach().clone() for k, v in actor.state_dict().items()})

    if held_out and (every or keep_best):
        check(0)
    losses = []
    actor.train()
    for step in range(1, updates + 1):
        idx = rng.choice(len(data), size=min(batch_sequences, len(data)), replace=False)
        chosen = [data[i] for i in idx]
        x, y, w = batch(chosen)
        pred, _ = actor(x)
        per_step = ((pred - y) ** 2).sum(-1)
        if closing_weight > 0.0:  # near another body, closing on it faster than the label asks costs more than the reverse
            per_step = per_step + closing_weight * closing_excess(pred, y, batch_toward(chosen)) ** 2
        loss = (w * per_step).sum() / w.gt(0).sum().clamp(min=1)
        opt.zero_grad()
        loss.backward()
        torch.nn.utils.clip_grad_norm_(actor.parameters(), 1.0)
        opt.step()
        losses.append(float(loss.detach()))
        if held_out and (step == updates or (every and step % every == 0)):
            check(step)
    actor.eval()
    if best is not None:
        actor.load_state_dict(best[1])
        kept = min(range(len(curve)), key=lambda i: (curve[i]["validation_loss"], i))
        curve[kept]["kept"] = 1.0
    tail = losses[-max(1, len(losses) // 10):]
    return float(sum(tail) / len(tail)), curve


def validation_loss(actor: RecurrentActor, data: list[Sequence], batch_sequences: int) -> tuple[float, float]:
    """The weighted loss of :func:`fit` on ``data`` (sequences never fitted) and the same of a zero
    output (the base's action, with a residual); ``1 - loss / zero`` is the share of the target the
    actor explains on new episodes."""
    loss = zero = weight = 0.0
    mode = actor.training
    actor.eval()  # no dropout
    with torch.no_grad():
        for i in range(0, len(data), batch_sequences):
            x, y, w = batch(data[i:i + batch_sequences])
            pred, _ = actor(x)
            loss += float((w * ((pred - y) ** 2).sum(-1)).sum())
            zero += float((w * (y ** 2).sum(-1)).sum())
            weight += float(w.gt(0).sum())
    actor.train(mode)
    return loss / max(weight, 1.0), zero / max(weight, 1.0)


def optimizer(cfg: TrainConfig, actor: RecurrentActor) -> torch.optim.Optimizer:
    """The fit's optimizer: Adam, or with ``recurrent.weight_decay`` AdamW (decoupled weight decay,
    Loshchilov & Hutter 2019), at round 0's learning rate."""
    r = cfg.recurrent
    if r.weight_decay > 0.0:
        return torch.optim.AdamW(actor.parameters(), lr=r.learning_rate, weight_decay=r.weight_decay)
    return torch.optim.Adam(actor.parameters(), lr=r.learning_rate)


def rounds_for(cfg: TrainConfig) -> int:
    """DAgger rounds of the budget: ``timesteps // recurrent.samples_per_round`` (at least 1), round 0 the teacher's."""
    return max(1, cfg.timesteps // cfg.recurrent.samples_per_round)


def round_learning_rate(cfg: TrainConfig, k: int, rounds: int) -> float:
    """Round ``k``'s Adam step size: ``recurrent.learning_rate``, or with ``learning_rate_final`` a
    linear decay to it over the rounds (small steps once the aggregated data is large)."""
    r = cfg.recurrent
    if r.learning_rate_final is None or rounds < 2:
        return r.learning_rate
    return r.learning_rate + (r.learning_rate_final - r.learning_rate) * k / (rounds - 1)


def train(cfg: TrainConfig, out_dir: str | os.PathLike, command: str = "", progress=print) -> dict[str, Any]:
    """Distil the teacher into a recurrent actor in the run folder ``out_dir`` (module docstring);
    returns the train log. The folder gets train_config.yaml, env_config.yaml, policy.npz (the best
    evaluation), last.npz (the last round's student) and train_log.json. One student: ``recurrent.members``
    is :func:`~petswarm.training.ensemble.train_ensemble`'s (it runs this once per member)."""
    if cfg.algorithm != "recurrent":
        raise ConfigError(f"training/recurrent.py trains algorithm: recurrent, the config says {cfg.algorithm!r}")
    out = Path(out_dir)
    if (out / "train_log.json").exists():
        raise ConfigError(f"'{out}' already holds a run; choose another --out (a recurrent run is not resumable)")
    out.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(1)  # reproducible CPU math on a shared machine
    torch.manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    env_cfg: Config = cfg.env_config()
    layout = PetSwarmEnv(env_cfg).layout
    estimator = estimator_of(cfg, PolicySpec.from_env(PetSwarmEnv(env_cfg)))  # an estimate's units: the env's speed limits
    write_text_atomic(out / "train_config.yaml", yaml.safe_dump(cfg.model_dump(mode="json"), sort_keys=False))
    write_text_atomic(out / "env_config.yaml", yaml.safe_dump(env_cfg.to_dict(), sort_keys=False))
    log: dict[str, Any] = {"timesteps": 0, "wall_time_s": 0.0, "evaluations": [], "scripted_eval_rmse_m": None,
                           "command": command, "rounds": [], "wall_time_before_s": 0.0, "_start": time.time()}
    scripted_reference(cfg, log)
    r = cfg.recurrent
    env = training_env(env_cfg, cfg.randomize, cfg.env, False)
    actor = build_actor(cfg, layout.size)
    opt = optimizer(cfg, actor)
    data: list[Sequence] = []
    held_out: list[Sequence] = []  # the sequences of recurrent.validation_fraction of each round's episodes, never fitted
    split_rng = np.random.default_rng(cfg.seed + 1)  # its own stream: without a split the run is as before
    rounds = rounds_for(cfg)
    try:
        for k in range(rounds):
            t0 = time.time()
            driver = None if k == 0 else numpy_policy(actor, PolicySpec.from_env(env), cfg.residual(), estimator)
            seqs, counts = collect_sequences(env, r.samples_per_round, cfg.seed + 100_000 + 10_000 * k, cfg, driver,
                                             r.teacher_noise_std if k == 0 else r.student_noise_std, r.teacher_mix ** k)
            if r.validation_fraction > 0.0:
                seqs, held = split_episodes(seqs, r.validation_fraction, split_rng)
                held_out.extend(held)
            data.extend(seqs)
            t1 = time.time()
            for group in opt.param_groups:
                group["lr"] = round_learning_rate(cfg, k, rounds)
            loss, curve = fit(actor, opt, data, r.updates_per_round, r.batch_sequences, rng, held_out, r.validation_every,
                              r.early_stopping, r.closing_weight)
            log["timesteps"] += counts["samples"]
            log["wall_time_s"] = time.time() - log["_start"]
            record = {"round": k, "driver": "teacher" if k == 0 else "student", "beta": r.teacher_mix ** k, "learning_rate": opt.param_groups[0]["lr"], **counts, "sequences": len(data),
                      "loss": loss, "collect_s": round(t1 - t0, 1), "fit_s": round(time.time() - t1, 1)}
            if held_out:  # the round's end (with early_stopping, the kept weights')
                end = next((c for c in curve if c.get("kept")), curve[-1])
                record.update(validation_loss=end["validation_loss"], validation_explained=end["validation_explained"],
                              fit_loss=end["fit_loss"], validation_sequences=len(held_out), curve=curve)
            log["rounds"].append(record)
            info = policy_info(cfg, log, ALGORITHM if r.target == "action" else ALGORITHM_ESTIMATE)
            export_actor(actor, out / LAST_POLICY, layout, info, cfg.residual(), estimator)
            if (k + 1) % r.eval_every_rounds == 0 or k == rounds - 1:
                ev = evaluate_and_keep(cfg, out, log, lambda spec: numpy_policy(actor, spec, cfg.residual(), estimator),
                                       log["timesteps"], lambda path, info: export_actor(actor, path, layout, info, cfg.residual(),
                                                                                          estimator),
                                       ALGORITHM if r.target == "action" else ALGORITHM_ESTIMATE, {"round": k})
                record["eval_median_ratio"] = ev["median_ratio"]
            log["wall_time_s"] = time.time() - log["_start"]
            write_json_atomic(out / "train_log.json", public_log(log))
            if progress:
                ev = log["evaluations"][-1] if log["evaluations"] and log["evaluations"][-1].get("round") == k else None
                progress(f"round {k + 1}/{rounds} ({record['driver']} drove): {log['timesteps']} samples, loss {loss:.4f}"
                         + (f", fitted/held-out loss {record['fit_loss']:.4f}/{record['validation_loss']:.4f} (explained "
                            f"{record['validation_explained']:+.2f}"
                            + (f", kept step {next(c['update'] for c in curve if c.get('kept'))}" if r.early_stopping else "")
                            + ")" if held_out else "")
                         + (f", eval median {cfg.eval.metric} ratio {ev['median_ratio']:.2f} (not built {ev['not_built']})" if ev else "")
                         + f", {log['wall_time_s']:.0f} s")
    finally:
        env.close()
    log["wall_time_s"] = time.time() - log["_start"]
    write_json_atomic(out / "train_log.json", public_log(log))
    return public_log(log)


def train_recurrent(config: TrainConfig | str | os.PathLike | None, timesteps: int | None, seed: int | None,
                    out_dir: str | os.PathLike, command: str = "", progress=None) -> Path:
    """Train a recurrent policy and return the path of its ``policy.npz`` (the best evaluated
    student; ``last.npz`` beside it). ``config``: a :class:`TrainConfig`, a training YAML (path or
    shipped name), or None for ``configs/train/recurrent.yaml``; ``timesteps`` (labelled
    agent-samples: the DAgger budget) and ``seed`` override the config's when given. The entry point
    for tools that train many runs (a benchmark)."""
    if not isinstance(config, TrainConfig):
        from petswarm import shipped

        name = "recurrent" if config is None else str(config)
        path = name if Path(name).exists() else shipped(name) or name  # a path, or a shipped config by name
        config = load_train_config(path)
    changes = {k: v for k, v in (("timesteps", timesteps), ("seed", seed)) if v is not None}
    cfg = config.model_copy(update=changes) if changes else config
    cfg = TrainConfig.model_validate(cfg.model_dump())
    if cfg.algorithm != "recurrent":
        cfg = TrainConfig.model_validate({**cfg.model_dump(), "algorithm": "recurrent"})
    train_students(cfg, out_dir, command=command, progress=progress)
    return Path(out_dir) / "policy.npz"


def train_students(cfg: TrainConfig, out_dir: str | os.PathLike, command: str = "", progress=print) -> dict[str, Any]:
    """What a recurrent config asks for: one student (:func:`train`), or with ``recurrent.members`` > 1
    the mean of several, one network (:func:`petswarm.training.ensemble.train_ensemble`); returns the train log."""
    if cfg.recurrent.members > 1:
        from petswarm.training.ensemble import train_ensemble

        return train_ensemble(cfg, out_dir, command=command, progress=progress)
    return train(cfg, out_dir, command=command, progress=progress)
