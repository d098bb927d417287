"""PPO fine-tuning of a distilled recurrent policy, anchored to it (``algorithm: recurrent_ppo``,
``configs/train/recurrent_ppo.yaml``; ``petswarm train --config recurrent_ppo``).

The start: a recurrent policy distilled from the privileged teacher (:mod:`petswarm.training.recurrent`,
``finetune.policy``, e.g. the shipped ``recurrent_long.npz``), read from its plain ``.npz`` into the
same torch :class:`~petswarm.training.recurrent.RecurrentActor` (residual on the scripted reference
as the file says). What is added:

- **Actor**: that GRU, its hidden state zero whenever a robot (re)starts slave-role driving, as at
  inference; a Gaussian over its output (the correction, in the residual's units) with a learned
  log σ per action value, initialised small (``finetune.log_std_init``) so the first rollouts are
  the distilled policy's. The executed action is the residual's
  ``clip(reference + s · clip(sample, −1, 1), −1, 1)``; the log-probability is the sample's.
- **Critic**: an MLP on each robot's ``[observation, state()]`` (the agent-specific global state of
  MAPPO, Yu et al. 2022, as ``ppo.critic: state`` and :class:`~petswarm.training.randomize.WithState`);
  no memory. It is fitted alone on the first rollout's returns (``critic_warmup_epochs``) before the
  actor moves, or the first advantages would be noise.
- **Loss**: PPO's clipped surrogate (Schulman et al. 2017) with GAE (Schulman et al. 2016) over
  chunks of ``finetune.chunk`` steps of each robot's sequence, back-propagated through time from the
  hidden state the rollout stored at the chunk's start (recurrent PPO as in Pleines et al. 2023);
  plus an anchor ``λ · E‖μ_θ − μ_distilled‖²`` to the frozen distilled actor's mean on the same steps
  (for two Gaussians of equal σ the KL is this term over 2σ²), ``λ`` decaying geometrically from
  ``anchor_start`` to ``anchor_end`` over the run; and with ``bc_samples`` a behaviour-cloning batch of
  the teacher's labels on states the distilled policy visits (:func:`petswarm.training.recurrent.collect_sequences`,
  DAgger's data), so states the rollouts stop visiting are not forgotten.
- **Reward**: the env's (``finetune.reward: own``: each slave's; ``team``: their mean).
- **Selection**: the distilled policy is evaluated before the first iteration and the actor every
  ``eval_every`` iterations and after the last (:func:`petswarm.training.callbacks.evaluate_and_keep`):
  the best is ``policy.npz``, the last ``last.npz``, in the format :mod:`petswarm.baselines.learned` reads.

Entry point: :func:`train` ``(config, out_dir) -> train log``.
"""

from __future__ import annotations

import copy
import math
import os
import time
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import torch
import yaml

from petswarm.baselines.learned import PolicyLoadError, read_policy, residual_of_meta, shipped_policy_path
from petswarm.baselines.policy import PolicySpec
from petswarm.training.callbacks import LAST_POLICY, evaluate_and_keep, policy_info, public_log, scripted_reference
from petswarm.training.config import ConfigError, TrainConfig
from petswarm.training.recurrent import RecurrentActor, Sequence, batch, collect_sequences, export_actor, numpy_policy
from petswarm.training.vec_env import training_env
from petswarm_env.env import PetSwarmEnv
from petswarm_env.files import write_json_atomic, write_text_atomic
from petswarm_env.observe import ObservationLayout

ALGORITHM = "recurrent actor (GRU) distilled from the privileged teacher, fine-tuned by PPO anchored to it"


def policy_path(name: str) -> Path:
    """``finetune.policy`` as a file: an existing path, ``learned`` (the shipped policy), or a shipped
    model named as in the repository (``baselines/models/NAME.npz``)."""
    if name == "learned":
        return shipped_policy_path()
    if Path(name).is_file():
        return Path(name)
    shipped = Path(str(resources.files("petswarm.baselines") / "models" / Path(name).name))
    if name.replace("\\", "/").startswith("baselines/models/") and shipped.is_file():
        return shipped
    raise ConfigError(f"finetune.policy: no policy file '{name}'; give the path of a recurrent policy.npz, "
                      "baselines/models/NAME.npz or learned")


def load_actor(path: Path, layout: ObservationLayout) -> tuple[RecurrentActor, dict[str, Any]]:
    """The torch actor of a recurrent policy file (its exported numpy policy acts the same) and its metadata."""
    try:
        meta, layers, recurrent = read_policy(path)
    except PolicyLoadError as exc:
        raise ConfigError(f"finetune.policy: {exc}") from None
    if recurrent is None or "estimator" in meta:
        raise ConfigError(f"finetune.policy: '{path}' is not a recurrent action policy (algorithm: recurrent with "
                          "recurrent.target: action writes one)")
    if [tuple(f) for f in meta["observation_layout"]] != [tuple(f) for f in layout.signature()]:
        raise ConfigError(f"finetune.policy: '{path}' was trained on another observation layout than this env's; "
                          "re-train it with algorithm: recurrent on the current env")
    k = recurrent.encoder_layers
    actor = RecurrentActor(layout.size, [w.shape[0] for w, _ in layers[:k]], recurrent.cell.hidden_size,
                           [w.shape[0] for w, _ in layers[k:-1]], meta["activation"], outputs=layers[-1][0].shape[0])
    linears = [m for m in list(actor.encoder) + list(actor.head) if isinstance(m, torch.nn.Linear)]
    with torch.no_grad():
        for m, (w, b) in zip(linears, layers):
            m.weight.copy_(torch.as_tensor(w))
            m.bias.copy_(torch.as_tensor(b))
        for name, a in zip(("weight_ih_l0", "weight_hh_l0", "bias_ih_l0", "bias_hh_l0"),
                           (recurrent.cell.w_ih, recurrent.cell.w_hh, recurrent.cell.b_ih, recurrent.cell.b_hh)):
            getattr(actor.gru, name).copy_(torch.as_tensor(a))
    actor.eval()
    return actor, meta


class Critic(torch.nn.Module):
    """V(observation, state()): an MLP (tanh), no memory."""

    def __init__(self, inputs: int, sizes: list[int]):
        super().__init__()
        mods: list[torch.nn.Module] = []
        for n in sizes:
            mods += [torch.nn.Linear(inputs, n), torch.nn.Tanh()]
            inputs = n
        mods.append(torch.nn.Linear(inputs, 1))
        self.net = torch.nn.Sequential(*mods)
        self.register_buffer("offset", torch.zeros(()))  # the returns' scale, fixed from the first rollout (set_scale)
        self.register_buffer("scale", torch.ones(()))

    def set_scale(self, returns: torch.Tensor) -> None:
        self.offset.fill_(float(returns.mean()))
        self.scale.fill_(float(returns.std()) + 1e-6)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.offset + self.scale * self.net(x).squeeze(-1)


@dataclass
class Segment:
    """One robot's stretch of slave-role driving in a rollout: per step its observation, critic input,
    sampled output, its log-probability, the distilled actor's mean, the hidden state before the step
    and the reward; ``next_critic`` is the critic input after the last step when the episode was cut
    by its time limit (the return is bootstrapped there), None when the robot stopped driving."""

    obs: list[np.ndarray] = field(default_factory=list)
    crit: list[np.ndarray] = field(default_factory=list)
    act: list[np.ndarray] = field(default_factory=list)
    logp: list[float] = field(default_factory=list)
    mu0: list[np.ndarray] = field(default_factory=list)
    h: list[np.ndarray] = field(default_factory=list)
    rew: list[float] = field(default_factory=list)
    next_critic: np.ndarray | None = None


def gaussian_logp(x: torch.Tensor, mu: torch.Tensor, log_std: torch.Tensor) -> torch.Tensor:
    return (-0.5 * ((x - mu) / log_std.exp()) ** 2 - log_std - 0.5 * math.log(2 * math.pi)).sum(-1)


def _step(actor: RecurrentActor, x: torch.Tensor, h: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    mu, h_last = actor(x[:, None, :], h[None])
    return mu[:, 0], h_last[0]


def rollout(env, actor: RecurrentActor, anchor: RecurrentActor, log_std: torch.Tensor, cfg: TrainConfig, residual,
            steps: int, seed: int, rng: np.random.Generator) -> tuple[list[Segment], dict[str, float]]:
    """Episodes ``seed, seed + 1, …`` of the training env until ``steps`` agent-steps, every live robot
    acting with a sample of the actor's Gaussian (module docstring). Returns the segments and counts."""
    hidden_size = actor.gru.hidden_size
    segs: list[Segment] = []
    counts = {"samples": 0, "episodes": 0, "unorganized": 0, "reward_sum": 0.0}
    episode = 0
    std = log_std.detach().exp().numpy()
    while counts["samples"] < steps:
        episode += 1
        try:
            rows, infos = env.reset(seed=seed + episode - 1)
        except RuntimeError:  # a draw whose start-up failed: the next seed (as collect_sequences)
            counts["unorganized"] += 1
            if counts["unorganized"] == episode >= 20:
                raise ConfigError(f"none of seeds {seed}..{seed + episode - 1} organized a swarm; check the env config")
            continue
        counts["episodes"] += 1
        base = residual.base_policy(PolicySpec.from_env(env))
        open_: dict[str, Segment] = {}
        hid: dict[str, tuple[torch.Tensor, torch.Tensor]] = {}
        truncated = False
        while env.agents:
            live = [a for a in env.agents if infos[a]["active"]]
            for a in [a for a in open_ if a not in live]:  # stopped driving: no bootstrap, the memory restarts on rejoining
                segs.append(open_.pop(a))
                hid.pop(a, None)
            if not live:
                rows, _, _, trunc, infos = env.step({})
                continue
            state = np.asarray(env.state(), np.float32)
            x = torch.as_tensor(np.stack([rows[a] for a in live]), dtype=torch.float32)
            zero = torch.zeros(hidden_size)
            h = torch.stack([hid[a][0] if a in hid else zero for a in live])
            h0 = torch.stack([hid[a][1] if a in hid else zero for a in live])
            with torch.no_grad():
                mu, h_next = _step(actor, x, h)
                mu0, h0_next = _step(anchor, x, h0)
                sample = mu + torch.as_tensor(rng.normal(0.0, 1.0, mu.shape) * std, dtype=torch.float32)
                logp = gaussian_logp(sample, mu, log_std.detach())
            seen = {a: rows[a] for a in live}
            base_act = base.act_all(seen)
            out = sample.numpy()
            executed = {a: residual.apply(base_act[a], out[i]) for i, a in enumerate(live)}
            rows, rew, _, trunc, infos_next = env.step(executed)
            team = float(np.mean([rew[a] for a in live]))
            for i, a in enumerate(live):
                s = open_.setdefault(a, Segment())
                s.obs.append(seen[a])
                s.crit.append(np.concatenate([seen[a], state]))
                s.act.append(out[i])
                s.logp.append(float(logp[i]))
                s.mu0.append(mu0[i].numpy())
                s.h.append(h[i].numpy())
                r = team if cfg.finetune.reward == "team" else float(rew[a])
                s.rew.append(r)
                counts["reward_sum"] += r
                hid[a] = (h_next[i], h0_next[i])
            counts["samples"] += len(live)
            truncated = any(trunc.get(a, False) for a in live)
            infos = infos_next
        state = np.asarray(env.state(), np.float32) if truncated else None
        for a, s in open_.items():  # the episode's end: cut by the time limit -> bootstrap from the last row
            if truncated and a in rows:
                s.next_critic = np.concatenate([rows[a], state])
            segs.append(s)
    counts["mean_reward"] = counts.pop("reward_sum") / max(counts["samples"], 1)
    return segs, counts


@dataclass
class Chunks:
    """An iteration's rollout as padded chunks (C, L, ·) with their start hidden states and masks."""

    x: torch.Tensor
    act: torch.Tensor
    logp: torch.Tensor
    mu0: torch.Tensor
    adv: torch.Tensor
    h0: torch.Tensor
    mask: torch.Tensor
    crit: torch.Tensor  # flat (N, ·): the critic's rows and their returns
    ret: torch.Tensor


def advantages(segs: list[Segment], critic: Critic, gamma: float, lam: float) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """GAE (Schulman et al. 2016) per segment, and the returns the critic fits (advantage + value)."""
    advs, rets = [], []
    with torch.no_grad():
        for s in segs:
            v = critic(torch.as_tensor(np.stack(s.crit))).numpy()
            last = float(critic(torch.as_tensor(s.next_critic)[None])[0]) if s.next_critic is not None else 0.0
            nxt = np.append(v[1:], last)
            delta = np.asarray(s.rew, np.float32) + gamma * nxt - v
            adv = np.zeros_like(delta)
            acc = 0.0
            for t in range(len(delta) - 1, -1, -1):
                acc = delta[t] + gamma * lam * acc
                adv[t] = acc
            advs.append(adv)
            rets.append(adv + v)
    return advs, rets


def chunks(segs: list[Segment], advs: list[np.ndarray], rets: list[np.ndarray], length: int) -> Chunks:
    pieces = [(i, t) for i, s in enumerate(segs) for t in range(0, len(s.obs), length)]
    n, obs, hs = len(pieces), len(segs[0].obs[0]), len(segs[0].h[0])
    allv = np.concatenate(advs)
    mean, std = float(allv.mean()), float(allv.std()) + 1e-8
    x = np.zeros((n, length, obs), np.float32)
    act = np.zeros((n, length, 3), np.float32)
    mu0 = np.zeros((n, length, 3), np.float32)
    logp = np.zeros((n, length), np.float32)
    adv = np.zeros((n, length), np.float32)
    mask = np.zeros((n, length), np.float32)
    h0 = np.zeros((n, hs), np.float32)
    for c, (i, t) in enumerate(pieces):
        s, m = segs[i], min(length, len(segs[i].obs) - t)
        x[c, :m] = np.stack(s.obs[t:t + m])
        act[c, :m] = np.stack(s.act[t:t + m])
        mu0[c, :m] = np.stack(s.mu0[t:t + m])
        logp[c, :m] = s.logp[t:t + m]
        adv[c, :m] = (advs[i][t:t + m] - mean) / std
        mask[c, :m] = 1.0
        h0[c] = s.h[t]
    crit = np.concatenate([np.stack(s.crit) for s in segs]).astype(np.float32)
    t = torch.as_tensor
    return Chunks(t(x), t(act), t(logp), t(mu0), t(adv), t(h0), t(mask), t(crit), t(np.concatenate(rets).astype(np.float32)))


def anchor_weight(cfg: TrainConfig, k: int, iterations: int) -> float:
    """λ of iteration ``k``: ``anchor_start`` decaying geometrically to ``anchor_end`` (linearly if that is 0)."""
    f, frac = cfg.finetune, (k / (iterations - 1) if iterations > 1 else 1.0)
    if f.anchor_end > 0.0 and f.anchor_start > 0.0:
        return f.anchor_start * (f.anchor_end / f.anchor_start) ** frac
    return f.anchor_start + (f.anchor_end - f.anchor_start) * frac


def fit_critic(critic: Critic, opt: torch.optim.Optimizer, data: Chunks, epochs: int, batch_rows: int,
               rng: np.random.Generator) -> float:
    loss = torch.zeros(())
    n = len(data.ret)
    for _ in range(epochs):
        for idx in np.array_split(rng.permutation(n), max(1, n // batch_rows)):
            loss = (((critic(data.crit[idx]) - data.ret[idx]) / critic.scale) ** 2).mean()  # in units of the returns' spread
            opt.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(critic.parameters(), 1.0)
            opt.step()
    return float(loss.detach())


def update(actor: RecurrentActor, log_std: torch.Tensor, opt: torch.optim.Optimizer, data: Chunks, cfg: TrainConfig,
           lam: float, bc: list[Sequence], rng: np.random.Generator) -> dict[str, float]:
    """``finetune.epochs`` passes of the clipped surrogate + anchor (+ BC) over the chunks (module docstring)."""
    f = cfg.finetune
    stats = {"policy_loss": 0.0, "anchor": 0.0, "bc": 0.0, "clip_fraction": 0.0, "approx_kl": 0.0}
    stopped = 0.0
    steps = 0
    actor.train()
    for epoch in range(f.epochs):
        order = rng.permutation(len(data.x))
        for idx in np.array_split(order, max(1, len(order) // f.chunks_per_batch)):
            m = data.mask[idx]
            w = m.sum().clamp(min=1.0)
            mu, _ = actor(data.x[idx], data.h0[idx][None])
            logp = gaussian_logp(data.act[idx], mu, log_std)
            ratio = ((logp - data.logp[idx]) * m).exp()  # padding: ratio 1, masked out below (never inf * 0)
            adv = data.adv[idx]
            surr = torch.min(ratio * adv, ratio.clamp(1 - f.clip_range, 1 + f.clip_range) * adv)
            pg = -(surr * m).sum() / w
            # the KL from the distilled policy's Gaussian of the same sigma: ||mu - mu_distilled||^2 / (2 sigma^2)
            var = (2.0 * log_std.detach()).exp()
            anchor = ((((mu - data.mu0[idx]) ** 2 / (2.0 * var)).sum(-1)) * m).sum() / w
            loss = pg + lam * anchor
            if bc and f.bc_coef > 0.0:
                x, y, bw = batch([bc[i] for i in rng.choice(len(bc), min(f.bc_sequences, len(bc)), replace=False)])
                pred, _ = actor(x)
                bc_loss = (bw * ((pred - y) ** 2).sum(-1)).sum() / bw.gt(0).sum().clamp(min=1)
                loss = loss + f.bc_coef * bc_loss
                stats["bc"] += float(bc_loss.detach())
            opt.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(list(actor.parameters()) + [log_std], f.max_grad_norm)
            opt.step()
            with torch.no_grad():
                stats["policy_loss"] += float(pg)
                stats["anchor"] += float(anchor)
                stats["clip_fraction"] += float((((ratio - 1).abs() > f.clip_range).float() * m).sum() / w)
                stats["approx_kl"] += float((((ratio - 1) - ratio.log()) * m).sum() / w)
            steps += 1
        if f.target_kl and stats["approx_kl"] / max(steps, 1) > f.target_kl:  # the policy moved far enough: no more epochs
            stopped = float(epoch + 1)
            break
    actor.eval()
    return {**{k: v / max(steps, 1) for k, v in stats.items()}, "epochs_run": stopped or float(f.epochs)}


def iterations_for(cfg: TrainConfig) -> int:
    return max(1, cfg.timesteps // cfg.finetune.rollout_steps)


def _start(cfg: TrainConfig, layout: ObservationLayout):
    """``finetune.policy``'s file, its torch actor and its residual (which the config must name)."""
    start = policy_path(cfg.finetune.policy)
    actor, meta = load_actor(start, layout)
    residual = residual_of_meta(meta)
    if residual is None or cfg.residual() != residual:
        raise ConfigError(f"finetune.policy '{start}' is a correction of {residual}, the config's residual_of/residual_scale "
                          f"say {cfg.residual()}; set them to the file's")
    return start, actor, residual


def _bc_batch(cfg: TrainConfig, env, anchor: RecurrentActor, residual, log: dict[str, Any]) -> list[Sequence]:
    """``finetune.bc_samples`` of the teacher's DAgger labels on states the distilled policy drives into
    (:func:`petswarm.training.recurrent.collect_sequences`, its noise ``recurrent.student_noise_std``)."""
    t0 = time.time()
    driver = numpy_policy(anchor, PolicySpec.from_env(PetSwarmEnv(cfg.env_config())), residual)  # the env's speed limits
    bc, counts = collect_sequences(env, cfg.finetune.bc_samples, cfg.seed + 900_000, cfg, driver, cfg.recurrent.student_noise_std)
    log["bc"] = {**counts, "sequences": len(bc), "collect_s": round(time.time() - t0, 1)}
    return bc


def _line(cfg: TrainConfig, log: dict[str, Any], record: dict[str, Any], iterations: int, ev: dict[str, Any] | None) -> str:
    """An iteration's progress line."""
    return (f"iteration {record['iteration'] + 1}/{iterations}: {log['timesteps']} agent-steps, mean reward "
            f"{record['mean_reward']:.4f}, anchor {record['anchor_weight']:.3g} (KL {record['anchor']:.4f}), clip "
            f"{record['clip_fraction']:.2f}, kl {record['approx_kl']:.4f}, value loss {record['value_loss']:.4f}"
            + (f", eval median {cfg.eval.metric} ratio {ev['median_ratio']:.2f} (not built {ev['not_built']})" if ev else "")
            + f", {log['wall_time_s']:.0f} s")


def train(cfg: TrainConfig, out_dir: str | os.PathLike, command: str = "", progress=print) -> dict[str, Any]:
    """Fine-tune ``finetune.policy`` in the run folder ``out_dir`` (module docstring); returns the train
    log. The folder gets train_config.yaml, env_config.yaml, policy.npz (the best evaluation, possibly
    the distilled policy itself), last.npz and train_log.json."""
    if cfg.algorithm != "recurrent_ppo":
        raise ConfigError(f"training/recurrent_ppo.py trains algorithm: recurrent_ppo, the config says {cfg.algorithm!r}")
    f = cfg.finetune
    out = Path(out_dir)
    if (out / "train_log.json").exists():
        raise ConfigError(f"'{out}' already holds a run; choose another --out (a recurrent_ppo run is not resumable)")
    env_cfg = cfg.env_config()
    layout = PetSwarmEnv(env_cfg).layout
    start, actor, residual = _start(cfg, layout)
    out.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(1)  # reproducible CPU math on a shared machine
    torch.manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    write_text_atomic(out / "train_config.yaml", yaml.safe_dump(cfg.model_dump(mode="json"), sort_keys=False))
    write_text_atomic(out / "env_config.yaml", yaml.safe_dump(env_cfg.to_dict(), sort_keys=False))
    log: dict[str, Any] = {"timesteps": 0, "wall_time_s": 0.0, "evaluations": [], "scripted_eval_rmse_m": None,
                           "command": command, "start_policy": str(start), "iterations": [], "wall_time_before_s": 0.0,
                           "_start": time.time()}
    scripted_reference(cfg, log)
    anchor = copy.deepcopy(actor).requires_grad_(False)  # the distilled actor, frozen
    log_std = torch.nn.Parameter(torch.full((3,), f.log_std_init), requires_grad=f.learn_log_std)
    opt = torch.optim.Adam(list(actor.parameters()) + ([log_std] if f.learn_log_std else []), lr=f.learning_rate)
    env = training_env(env_cfg, cfg.randomize, cfg.env, False)
    critic = Critic(layout.size + env.state_space.shape[0], list(f.critic_net))
    critic_opt = torch.optim.Adam(critic.parameters(), lr=f.critic_learning_rate)
    iterations = iterations_for(cfg)

    def evaluate(k: int) -> dict[str, Any]:
        return evaluate_and_keep(cfg, out, log, lambda spec: numpy_policy(actor, spec, residual), log["timesteps"],
                                 lambda path, info: export_actor(actor, path, layout, info, residual), ALGORITHM,
                                 {"iteration": k})

    try:
        bc = _bc_batch(cfg, env, anchor, residual, log) if f.bc_samples else []
        ev = evaluate(0)  # the distilled policy itself competes
        if progress:
            progress(f"distilled policy {start.name}: eval median {cfg.eval.metric} ratio {ev['median_ratio']:.2f} "
                     f"(not built {ev['not_built']}), {time.time() - log['_start']:.0f} s")
        for k in range(iterations):
            t0 = time.time()
            segs, counts = rollout(env, actor, anchor, log_std, cfg, residual, f.rollout_steps,
                                   cfg.seed + 200_000 + 10_000 * k, rng)
            advs, rets = advantages(segs, critic, f.gamma, f.gae_lambda)
            data = chunks(segs, advs, rets, f.chunk)
            t1 = time.time()
            batch_rows = max(64, f.chunks_per_batch * f.chunk)
            if k == 0:
                critic.set_scale(data.ret)
            if k == 0 and f.critic_warmup_epochs:  # the value of the distilled policy before the actor moves
                fit_critic(critic, critic_opt, data, f.critic_warmup_epochs, batch_rows, rng)
                advs, rets = advantages(segs, critic, f.gamma, f.gae_lambda)
                data = chunks(segs, advs, rets, f.chunk)
            lam = anchor_weight(cfg, k, iterations)
            stats = update(actor, log_std, opt, data, cfg, lam, bc, rng)
            stats["value_loss"] = fit_critic(critic, critic_opt, data, f.epochs, batch_rows, rng)
            log["timesteps"] += counts["samples"]
            record = {"iteration": k, **counts, "anchor_weight": lam, **stats,
                      "std": [round(float(s), 4) for s in log_std.detach().exp()],
                      "rollout_s": round(t1 - t0, 1), "update_s": round(time.time() - t1, 1)}
            log["iterations"].append(record)
            log["wall_time_s"] = time.time() - log["_start"]
            export_actor(actor, out / LAST_POLICY, layout, policy_info(cfg, log, ALGORITHM), residual)
            ev = None
            if (k + 1) % f.eval_every == 0 or k == iterations - 1:
                ev = evaluate(k + 1)
                record["eval_median_ratio"] = ev["median_ratio"]
            log["wall_time_s"] = time.time() - log["_start"]
            write_json_atomic(out / "train_log.json", public_log(log))
            if progress:
                progress(_line(cfg, log, record, iterations, ev))
    finally:
        env.close()
    log["wall_time_s"] = time.time() - log["_start"]
    write_json_atomic(out / "train_log.json", public_log(log))
    return public_log(log)
