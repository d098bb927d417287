"""The warm start: imitate the scripted reference before PPO takes over (``pretrain:`` of the
training config; ``pretrain.samples: 0`` trains from scratch).

The scripted leader–follower drives the slaves with action noise, so that the demonstrations
cover recovering from errors; the actor learns the reference's noise-free actions (behaviour
cloning, MSE on the mean action) and the critic the discounted returns of the executed
trajectories.
"""

from __future__ import annotations

import math
import time

import numpy as np
import torch

from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm_env.config import Config
from petswarm_env.env import PetSwarmEnv
from petswarm_env.observe import MAX_LINKS
from petswarm_env.wrappers import FixedAgents
from petswarm.training.config import TrainConfig
from petswarm.training.teacher import PrivilegedTeacher, TeacherGains


def discounted_returns(rewards: list[float], gamma: float) -> list[float]:
    """``G_t = r_t + γ·G_{t+1}`` for every step of one trajectory (in step order)."""
    g = 0.0
    returns = []
    for r in reversed(rewards):
        g = r + gamma * g
        returns.append(g)
    return returns[::-1]


class ScriptedLabels:
    """The scripted reference as a labeller: its action from each live robot's observation."""

    def __init__(self, env):
        self.policy = make_policy("scripted", PolicySpec.from_env(env))
        self.n = env.layout.size

    def __call__(self, rows: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        return self.policy.act_all({a: r[: self.n] for a, r in rows.items()})


class TeacherLabels:
    """The privileged teacher as a labeller (:mod:`petswarm.training.teacher`): its action from ground
    truth, for the robots whose rows it is given; of the rows it reads the ultrasonic ranges (the
    robot's own sensors, for its keep-out) and whether the robot has a fix of anyone. A robot with
    no IR fix younger than the observation's age range — of a reference neighbour or of the master
    — cannot know where its swarm is: no action of the student's could follow the teacher's there,
    so such a row is labelled with the scripted reference's action instead (its rejoin and search,
    leader_follower.py steps 1c and 1d). ``gains``: the teacher's constants (None: its defaults;
    ``recurrent.teacher_*`` of a recurrent run)."""

    def __init__(self, env, lost_to_reference: bool = True, gains: TeacherGains | None = None):
        self.teacher = PrivilegedTeacher(env, gains)
        self.reference = ScriptedLabels(env) if lost_to_reference else None
        sl = env.layout.slices
        self.sonar = sl["self.ultrasonic"]
        self.max_range = env.cfg.robot.ultrasonic.max_range_m
        self.fixes = [(sl[f"{p}.ir_valid"].start, sl[f"{p}.ir_age"].start)
                      for p in ("master", *(f"link{k}" for k in range(MAX_LINKS)))]

    def lost(self, row: np.ndarray) -> bool:
        """No fresh IR fix of the master or of any reference neighbour in this observation."""
        return not any(row[v] > 0.5 and row[age] < 1.0 for v, age in self.fixes)

    def __call__(self, rows: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        lost = {a: r for a, r in rows.items() if self.lost(r)} if self.reference is not None else {}
        labels = self.reference(lost) if lost else {}
        seen = [a for a in rows if a not in lost]  # the teacher's actions do not depend on which robots are asked
        labels.update(self.teacher.act_all(seen, {a: rows[a][self.sonar] * self.max_range for a in seen}))
        return {a: labels[a] for a in rows}


LABELLERS = {"scripted": ScriptedLabels, "privileged": TeacherLabels}


def collect_demonstrations(env_cfg: Config, samples: int, noise_std: float, seed: int, gamma: float, env=None,
                           driver=None, teacher: str = "scripted"):
    """Run the scripted reference with action noise over episodes ``seed, seed + 1, …`` until
    ``samples`` agent-steps; return the inputs (each live agent's row), the reference's
    (noise-free) actions and the discounted returns of the executed trajectories (for the critic).
    ``env`` is the run's fixed-agents env (:func:`petswarm.training.vec_env.training_env`: its draws, its
    rows with the state); by default ``FixedAgents(PetSwarmEnv(env_cfg))``. The reference reads
    only the observation (a row's first ``layout.size`` values) of the robots that are slaves. With
    ``driver`` (a function of a batch of rows to actions: DAgger) the driver's actions are executed
    (with the noise) and the reference's recorded. ``teacher`` names the labeller
    (:data:`LABELLERS`): ``scripted`` (the reference, from the observation) or ``privileged``
    (:class:`petswarm.training.teacher.PrivilegedTeacher`, from ground truth); it is called at every step,
    so the teacher sees the episode's every state."""
    env = env if env is not None else FixedAgents(PetSwarmEnv(env_cfg))
    rng = np.random.default_rng(seed)
    obs_l, act_l, ret_l = [], [], []
    episode = 0
    while len(obs_l) < samples:
        rows, infos = env.reset(seed=seed + episode)
        episode += 1
        label = LABELLERS[teacher](env)  # after the reset: the episode's env
        traj: dict[str, list[tuple[np.ndarray, np.ndarray, float]]] = {}
        while env.agents:
            live = [a for a in env.agents if infos[a]["active"]]
            target = label({a: rows[a] for a in live})
            executed = target if driver is None or not live else dict(zip(live, driver(np.stack([rows[a] for a in live]))))
            noisy = {a: np.clip(v + rng.normal(0.0, noise_std, 3), -1.0, 1.0).astype(np.float32) for a, v in executed.items()}
            next_rows, rewards, _, _, infos = env.step(noisy)
            for a in target:
                traj.setdefault(a, []).append((rows[a], target[a], rewards[a]))
            rows = next_rows
        for steps in traj.values():
            for (o, t, _), g in zip(steps, discounted_returns([r for _, _, r in steps], gamma)):
                obs_l.append(o)
                act_l.append(t)
                ret_l.append(g)
    return np.array(obs_l[:samples]), np.array(act_l[:samples]), np.array(ret_l[:samples], dtype=np.float32)


def _fit(actor, critic, opt, data, epochs: int, batch_size: int, gen) -> tuple[float, float]:
    """Epochs of MSE on the actions (actor) and 0.01 × MSE on the returns (critic); the last losses."""
    x, y, g = data
    n = len(x)
    actor_loss = critic_loss = math.nan
    for _ in range(epochs):
        perm = torch.randperm(n, generator=gen)
        for i in range(0, n, batch_size):
            idx = perm[i:i + batch_size]
            a_loss = ((actor(x[idx]) - y[idx]) ** 2).mean()
            v_loss = ((critic(x[idx]) - g[idx]) ** 2).mean()
            opt.zero_grad()
            (a_loss + 0.01 * v_loss).backward()
            opt.step()
            actor_loss, critic_loss = float(a_loss.detach()), float(v_loss.detach())
    return actor_loss, critic_loss


def _tensors(obs, act, ret):
    return (torch.as_tensor(obs, dtype=torch.float32), torch.as_tensor(act, dtype=torch.float32),
            torch.as_tensor(ret, dtype=torch.float32)[:, None])


def fit_actor_critic(actor, critic, params: list, cfg: TrainConfig, env_cfg: Config, env=None) -> dict:
    """Behaviour cloning of the scripted reference into ``actor`` (a function of an input batch
    to mean actions; MSE) and a regression of ``critic`` (inputs -> values) on the
    demonstrations' returns, optimising ``params`` with Adam: the warm start of every back end
    (``env``: :func:`collect_demonstrations`). Then ``pretrain.dagger_rounds`` rounds of DAgger:
    the actor drives (with the same action noise), the reference labels the states it visits,
    ``pretrain.dagger_samples`` more each round, and the actor is refitted on everything so far."""
    p = cfg.pretrain
    t0 = time.time()
    parts = [collect_demonstrations(env_cfg, p.samples, p.noise_std, cfg.seed + 100_000, cfg.ppo.gamma, env, teacher=p.teacher)]
    opt = torch.optim.Adam(params, lr=p.learning_rate)
    gen = torch.Generator().manual_seed(cfg.seed)
    actor_loss, critic_loss = _fit(actor, critic, opt, _tensors(*parts[0]), p.epochs, p.batch_size, gen)

    def drive(rows: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            return np.clip(actor(torch.as_tensor(rows, dtype=torch.float32)).numpy(), -1.0, 1.0)

    for k in range(p.dagger_rounds):
        parts.append(collect_demonstrations(env_cfg, p.dagger_samples, p.noise_std, cfg.seed + 200_000 + 10_000 * k,
                                            cfg.ppo.gamma, env, driver=drive, teacher=p.teacher))
        data = _tensors(*(np.concatenate([q[i] for q in parts]) for i in range(3)))
        actor_loss, critic_loss = _fit(actor, critic, opt, data, p.epochs, p.batch_size, gen)
    return {"samples": sum(len(q[0]) for q in parts), "dagger_rounds": p.dagger_rounds, "actor_mse": actor_loss,
            "critic_mse": critic_loss, "wall_time_s": round(time.time() - t0, 1)}


def pretrain_policy(model, cfg: TrainConfig, env_cfg: Config, env=None) -> dict:
    """The warm start of an SB3 PPO model: its actor MLP and action head, its critic MLP and value
    head (:func:`fit_actor_critic`; ``env``: the run's fixed-agents env, whose rows the model reads)."""
    policy = model.policy
    params = [*policy.mlp_extractor.parameters(), *policy.action_net.parameters(), *policy.value_net.parameters(),
              *policy.features_extractor.parameters()]
    return fit_actor_critic(lambda x: policy.action_net(policy.mlp_extractor(policy.extract_features(x))[0]),
                            lambda x: policy.value_net(policy.mlp_extractor(policy.extract_features(x))[1]), params, cfg, env_cfg, env)
