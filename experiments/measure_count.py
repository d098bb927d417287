"""The count is true: how many resets report a full swarm, and how many are still full 1 s later
(every slave that joined still drives as a slave: none fell back to waiting because it had heard no
status broadcast yet).

    python -m petswarm.experiments.measure_count --seeds 0-199 --loss 0.3

A reset that cannot organize is counted (``organized: false``), not raised.
"""

from __future__ import annotations


import numpy as np

import petswarm_env
from petswarm.cli.errors import OneLineParser, run_program
from petswarm.experiments.measure_succession import parse_seeds
from petswarm_env.middleware.join import OrganizeError


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(prog="python -m petswarm.experiments.measure_count", description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0-199")
    parser.add_argument("--loss", type=float, nargs="+", default=[0.3])
    parser.add_argument("--after", type=float, default=1.0, help="seconds after reset")
    args = parser.parse_args(argv)
    for loss in args.loss:
        env = petswarm_env.parallel_env(**{"radio.loss_prob": loss, "user.start_delay_s": 100.0})
        full = still = unorganized = 0
        seeds = parse_seeds(args.seeds)
        for seed in seeds:
            try:
                env.reset(seed=seed)
            except OrganizeError:
                unorganized += 1
                continue
            at_reset = set(env.agents)
            is_full = len(at_reset) == env.cfg.swarm.num_slaves
            full += is_full
            for _ in range(int(round(args.after / env.cfg.control_period_s))):
                if not env.agents:
                    break
                env.step({a: np.zeros(3, np.float32) for a in env.agents})
            still += is_full and at_reset <= set(env.agents)
        print(f"loss {loss}: {len(seeds)} resets, {unorganized} did not organize, {full} full at reset, "
              f"{still} still full {args.after:g} s later ({100.0 * still / max(full, 1):.1f} % of the full ones)")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_program("python -m petswarm.experiments.measure_count", main))
