"""Sizing a training config's randomization pools (``training/randomize.PoolSpaces.of``): an env of
every combination, built two ways side by side in alternating rounds of one run:

- **lazy** (what the env does): the env built and its observation bounds read
  (``env.observation_bounds``), its gymnasium Boxes never built;
- **eager** (the env before): the same, and its observation and state Boxes built as the env's
  constructor built them until 2026-12-07 (gymnasium formats a Box's bounds as text when it is built).

    python -m petswarm.bench.pool_spaces [--config recurrent_command_teacher] [--rounds 2]
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def time_pools(config: str = "recurrent_command_teacher", rounds: int = 2) -> dict[str, list[float]]:
    """Seconds per round of each way (alternating, lazy first in the first round), and a check that every
    run gave the same observation bounds."""
    from petswarm.training.config import load_train_config
    from petswarm.training.randomize import _Configs, check_pools
    from petswarm_env.env import PetSwarmEnv

    from pathlib import Path

    from petswarm import shipped

    cfg = load_train_config(config if Path(config).exists() else shipped(config) or config)  # a path or a shipped name
    combos = check_pools(cfg.env, cfg.randomize)
    configs = [_Configs(cfg.env)(over) for over in combos]  # validated once, outside the timing

    def run(eager: bool) -> tuple[float, np.ndarray]:
        start, low = time.perf_counter(), None
        for c in configs:
            env = PetSwarmEnv(c)
            if eager:
                _ = (env.observation_space(env.possible_agents[0]), env.state_space)
            lo = env.observation_bounds[0]
            low = lo if low is None else np.minimum(low, lo)
        return time.perf_counter() - start, low

    out: dict[str, list[float]] = {"lazy": [], "eager": [], "combinations": [len(configs)]}
    lows = []
    for r in range(rounds):
        for eager in ((False, True) if r % 2 == 0 else (True, False)):
            dt, low = run(eager)
            out["eager" if eager else "lazy"].append(dt)
            lows.append(low)
    if any(not np.array_equal(lows[0], low) for low in lows):
        raise AssertionError("the two ways gave other observation bounds")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default="recurrent_command_teacher", help="a training config (path or shipped name)")
    ap.add_argument("--rounds", type=int, default=2)
    a = ap.parse_args()
    res = time_pools(a.config, a.rounds)
    lazy, eager = sum(res["lazy"]), sum(res["eager"])
    print(f"{res['combinations'][0]} combinations of {a.config}'s pools, {a.rounds} rounds: "
          f"lazy {' / '.join(f'{t:.1f}' for t in res['lazy'])} s, eager {' / '.join(f'{t:.1f}' for t in res['eager'])} s; "
          f"eager / lazy {eager / lazy:.2f}x")


if __name__ == "__main__":
    main()
