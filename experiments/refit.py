"""After a change of behaviour (a change to a model, the protocol or the start): re-fit what the env's behaviour moves, re-run
the papers' experiments and print docs/reproduce.md's first table.

Usage: python -m petswarm.experiments.refit [--skip-fit] [--trials N] [--json reproduce.json] [--report reproduce.html]

1. **Fit** (unless ``--skip-fit``): the one calibration that the swarm's behaviour feeds,
   ``radio.processing_jitter_s`` on Table 5's fit counts (:data:`~petswarm.experiments.organize_time.RETRY_FIT_COUNTS`),
   swept around the current value with ``--trials`` organizations a count, exactly as
   ``python -m petswarm.experiments.calibrate_organize`` does (fit vs held out per candidate). When the best
   candidate is not the current value, it says so and stops: set the value in
   ``petswarm_env/default.yaml`` and ``configs/default.yaml``, regenerate the golden episodes
   (``python -m tests.golden.episodes --regenerate``, saying why in the commit) and run this again
   with ``--skip-fit``. The IR and LF fits read only the sensor models (``comms/ir.py``,
   ``wearables/lf.py``) on fixed grids, so a change elsewhere leaves them as they are; after a change
   there, run ``python -m petswarm.experiments.calibrate_ir`` / ``calibrate_lf --search``.
2. **Reproduce**: every experiment of the registry, the full run (``petswarm reproduce``), with the
   JSON and the HTML page written.
3. **The reproduce table**: the markdown of docs/reproduce.md's first table, with the basis column.

Exit status: 0 when it got to the table, 1 when the fit moved (nothing re-run), whatever the rows say.
"""

from __future__ import annotations


from petswarm.cli.errors import OneLineParser, run_program
from petswarm.experiments.calibrate_organize import sweep
from petswarm.experiments.organize_time import RETRY_FIT_COUNTS
from petswarm.experiments.registry import EXPERIMENTS
from petswarm.experiments.reproduce import markdown_table, reproduce_results
from petswarm_env.config import load_config

JITTER_STEPS = (-0.001, -0.0005, 0.0, 0.0005, 0.001)  # the sweep around the current radio.processing_jitter_s (s)


def refit_jitter(trials: int) -> tuple[float, float]:
    """(current, best on the fit counts) of ``radio.processing_jitter_s``, swept around the current
    value by :func:`petswarm.experiments.calibrate_organize.sweep` (which prints every candidate)."""
    current = load_config().radio.processing_jitter_s
    values = [round(current + step, 6) for step in JITTER_STEPS]
    best = sweep({"radio.processing_jitter_s": values}, RETRY_FIT_COUNTS, trials)
    return current, best["radio.processing_jitter_s"]


def main() -> int:
    parser = OneLineParser(prog="python -m petswarm.experiments.refit", description=__doc__.splitlines()[0])
    parser.add_argument("--skip-fit", action="store_true", help="skip the re-fit of radio.processing_jitter_s")
    parser.add_argument("--trials", type=int, default=200, help="organizations per slave count in the fit (default 200)")
    parser.add_argument("--json", default="reproduce.json", help="the reproduce JSON (default reproduce.json)")
    parser.add_argument("--report", default="reproduce.html", help="the reproduce HTML page (default reproduce.html)")
    args = parser.parse_args()
    if not args.skip_fit:
        current, best = refit_jitter(args.trials)
        if best != current:
            print(f"the fit moved: set radio.processing_jitter_s: {best} in petswarm_env/default.yaml and configs/default.yaml, "
                  "regenerate the golden episodes (python -m tests.golden.episodes --regenerate) and run again with --skip-fit")
            return 1
        print(f"the fit holds: radio.processing_jitter_s = {current} is still the best on the fit counts")
    cfg = load_config()
    results = reproduce_results(cfg, list(EXPERIMENTS), cfg.seed, False, args.json, args.report, "python -m petswarm.experiments.refit")
    print("\ndocs/reproduce.md, the papers' measurements:\n")
    print(markdown_table(results))
    return 0


if __name__ == "__main__":
    raise SystemExit(run_program("python -m petswarm.experiments.refit", main))
