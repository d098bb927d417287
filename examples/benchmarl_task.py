"""A BenchMARL task for petswarm, and a tiny MAPPO run (the critic reads ``state()``)::

    python -m venv .venv-benchmarl && .venv-benchmarl/bin/pip install torch==2.13.0
    .venv-benchmarl/bin/pip install torch==2.13.0 -e '.[benchmarl]'      # benchmarl 1.5.2 -> torchrl 0.11.1
    .venv-benchmarl/bin/python examples/benchmarl_task.py --frames 2000

BenchMARL 1.5.2 keeps torch==2.13.0 but pins torchrl < 0.12 (it installs torchrl 0.11.1, tensordict
0.11, torchvision 0.28 and hydra), which the ``torchrl`` extra (0.14.1) excludes: give it its own
venv; ``scripts/setup.sh`` does not install it.

``PetSwarmTask.PETSWARM.get_task({...})`` takes dotted env overrides plus ``max_cycles``; the env is
``FixedAgents(petswarm_v1.parallel_env(...))`` in TorchRL's ``PettingZooWrapper`` with the state, so
MAPPO's centralized critic reads the global state (docs/state.md) and every actor its observation.
"""

from __future__ import annotations

import argparse
import copy
import time
from pathlib import Path

import torch
from benchmarl.environments.common import Task
from benchmarl.environments.pettingzoo.common import PettingZooClass
from torchrl.envs import PettingZooWrapper

from petswarm_env import petswarm_v1
from petswarm_env.wrappers import FixedAgents


class PetSwarmClass(PettingZooClass):
    """BenchMARL's PettingZoo plumbing (specs, groups, state) with petswarm's env: continuous
    actions, a global state, no render in BenchMARL's loggers."""

    def get_env_fun(self, num_envs, continuous_actions, seed, device):
        overrides = copy.deepcopy(self.config)
        return lambda: PettingZooWrapper(env=FixedAgents(petswarm_v1.parallel_env(**overrides)), return_state=True,
                                         use_mask=False, done_on_any=False, categorical_actions=True, device=device, seed=seed)

    def supports_continuous_actions(self) -> bool:
        return True

    def supports_discrete_actions(self) -> bool:
        return False

    def has_state(self) -> bool:
        return True

    def has_render(self, env) -> bool:
        return False

    def max_steps(self, env) -> int:
        return self.config["max_cycles"]

    @staticmethod
    def env_name() -> str:
        return "petswarm"


class PetSwarmTask(Task):
    """The petswarm task: ``PetSwarmTask.PETSWARM.get_task({"max_cycles": 100, "swarm.num_slaves": 3})``."""

    PETSWARM = None

    @staticmethod
    def associated_class():
        return PetSwarmClass


def run_mappo(frames: int = 2000, frames_per_batch: int = 1000, max_cycles: int = 100, out: str = "runs/benchmarl") -> dict:
    """A tiny MAPPO run on the task (BenchMARL's default MAPPO and MLP configs, CPU, no loggers)."""
    from benchmarl.algorithms import MappoConfig
    from benchmarl.experiment import Experiment, ExperimentConfig
    from benchmarl.models.mlp import MlpConfig

    torch.set_num_threads(1)
    cfg = ExperimentConfig.get_from_yaml()
    cfg.max_n_frames, cfg.on_policy_collected_frames_per_batch = frames, frames_per_batch
    cfg.on_policy_n_envs_per_worker, cfg.on_policy_n_minibatch_iters = 1, 2
    cfg.loggers, cfg.evaluation, cfg.render, cfg.create_json, cfg.checkpoint_at_end = [], False, False, False, False
    cfg.sampling_device = cfg.train_device = cfg.buffer_device = "cpu"
    Path(out).mkdir(parents=True, exist_ok=True)
    cfg.save_folder = out
    t = time.perf_counter()
    experiment = Experiment(task=PetSwarmTask.PETSWARM.get_task({"max_cycles": max_cycles}), algorithm_config=MappoConfig.get_from_yaml(),
                            model_config=MlpConfig.get_from_yaml(), critic_model_config=MlpConfig.get_from_yaml(), seed=0,
                            config=cfg)
    experiment.run()
    return {"frames": experiment.total_frames, "wall_s": round(time.perf_counter() - t, 1),
            "policy_parameters": sum(p.numel() for p in experiment.policy.parameters())}


def main() -> None:
    parser = argparse.ArgumentParser(description="BenchMARL's MAPPO on petswarm")
    parser.add_argument("--frames", type=int, default=2000)
    parser.add_argument("--max-cycles", type=int, default=100)
    parser.add_argument("--out", default="runs/benchmarl")
    args = parser.parse_args()
    print(run_mappo(args.frames, min(1000, args.frames), args.max_cycles, args.out))


if __name__ == "__main__":
    main()
