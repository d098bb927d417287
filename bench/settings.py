"""How long and how much ``petswarm bench`` measures (the ``FULL`` and ``QUICK`` presets), and the
issue's targets (printed next to the measurements, never asserted)."""

from __future__ import annotations

import sys
from dataclasses import dataclass, replace
from typing import Any

TARGET_VS_MPE = 4.0  # petswarm (1 master + 5 slaves) steps/s >= 4x MPE simple_spread N=6 (3x counts as done)
TARGET_SCALING = 2.0  # per-step cost at 9 slaves <= 2x the cost at 5
TARGET_SCALING_16 = 2.5  # per-step cost at 16 slaves <= 2.5x the cost at 5
TARGET_VECTOR_PER_CORE = 12.0  # vector_env(64) env-steps per CPU-second >= 12x the single env's
TARGET_TRAINING = 3.0  # SB3 PPO samples/s with the vector env >= 3x SuperSuit's one-copy path (one core)
MEMORY_GROWTH_TOLERANCE_MB = 0.5  # "no growth": tracemalloc growth per episode below this
MEMORY_BLOCKS_TOLERANCE = 0.01  # ... and live pymalloc blocks grow by less than 1 % between the checkpoints


@dataclass(frozen=True)
class BenchSettings:
    """How long and how much to measure. ``FULL`` and ``QUICK`` are the two CLI presets."""

    slaves: tuple[int, ...] = (2, 5, 9, 16)  # petswarm sizes: 1 master + n slaves
    target_s: float = 3.0  # timed env.step seconds per speed measurement (after warm-up)
    warmup_steps: int = 50  # untimed steps (and one reset) before each speed measurement
    min_steps: int = 200  # at least this many timed steps per measurement
    profile_target_s: float = 4.0  # profiled env.step seconds for the breakdown
    memory_steps: tuple[int, int] = (1_000, 100_000)  # tracemalloc/RSS checkpoints (env steps)
    memory_isolated: bool = True  # run the memory measurement in a fresh (spawned) process
    memory_trace_episodes: int = 3  # whole episodes traced with tracemalloc after the untraced run (>= 2)
    memory_max_cycles: int | None = None  # episode length of the memory run (None: the config's)
    training_samples: int = 8192  # PPO samples (agent-steps) timed per worker setting
    training_rollout: int = 1024  # samples per PPO rollout (n_steps = rollout / vector rows)
    training_workers: tuple[int, ...] = (1, 2)  # SuperSuit's path: 1 = in-process, k >= 2 = k worker processes
    training_vector_envs: tuple[int, ...] = (1, 8, 16)  # the batched vector env's path: this many copies, in-process
    vector_envs: tuple[int, ...] = (1, 64, 256)  # vector_env sizes timed side by side with the single env
    vmas_envs: int = 64  # VMAS simple_spread N=6 with this many envs beside them (0: not measured)
    vector_rounds: int = 6  # rotating rounds of one burst per system
    vector_burst_s: float = 0.5  # timed step seconds per burst
    mpe: bool = True  # measure the MPE peer if mpe2 is installed
    side_by_side_rounds: int = 12  # petswarm 1+5 and MPE N=6 timed in alternating bursts: this many each
    side_by_side_burst_s: float = 0.5  # timed env.step seconds per burst
    # instructions per env.step (1+5, callgrind, where valgrind is installed): replays of this many
    # recorded steps, their difference per step; None: not measured
    instructions_steps: tuple[int, int] | None = (20, 220)
    seed: int = 0


FULL = BenchSettings()
QUICK = BenchSettings(
    target_s=0.5, warmup_steps=10, min_steps=50, profile_target_s=1.0, memory_steps=(1_000, 10_000),
    memory_trace_episodes=2, training_samples=1024, training_rollout=256, side_by_side_rounds=4,
    side_by_side_burst_s=0.1, instructions_steps=None, vector_envs=(1, 16), vector_rounds=2, vector_burst_s=0.2,
    training_vector_envs=(4,),
)


def log(verbose: bool, msg: str) -> None:
    if verbose:
        print(f"[bench] {msg}", file=sys.stderr, flush=True)


def tiny_settings(**changes: Any) -> BenchSettings:
    """Very short settings (tests, smoke runs): every measurement, a few steps each."""
    base = BenchSettings(
        slaves=(2, 5, 9), target_s=0.05, warmup_steps=3, min_steps=5, profile_target_s=0.05,
        memory_steps=(20, 60), memory_isolated=False, memory_max_cycles=15, training_samples=64, training_rollout=32,
        training_workers=(1,), instructions_steps=None, vector_envs=(2,), vmas_envs=2, vector_rounds=1,
        vector_burst_s=0.02, training_vector_envs=(1,),
    )
    return replace(base, **changes)
