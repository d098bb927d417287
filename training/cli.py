"""The ``petswarm`` command line.

    petswarm run    [--config FILE] [--set KEY=VALUE ...] [--policy scripted|random|learned|PATH]
                    [--episodes N] [--seed S] [--json OUT] [--render human] [--video OUT.gif]
    petswarm train  [--config configs/train/ppo.yaml] [--set KEY=VALUE ...] [--timesteps N] [--out runs/NAME] [--resume]
    petswarm eval   --policy scripted|random|learned|PATH [--mix ROBOT=POLICY ...] [--scenarios a,b] [--episodes N] ...
    petswarm report RESULT.json ... --out report.html
    petswarm bench  [--quick] [--json OUT] [--md docs/benchmarks.md]
    petswarm reproduce [--only NAME,...] [--quick] [--json OUT] [--report OUT.html] [--check]
"""

from __future__ import annotations

import argparse
import sys

from petswarm_env.config import ConfigError, load_config, parse_override


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # one line, no traceback, exit 2
        self.exit(2, f"petswarm: error: {message}\n")


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got '{text}'") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value}")
    return value


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer seed, got '{text}'") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer seed, got {value}")
    return value


def _policy_name(text: str) -> str:
    from baselines.registry import POLICY_NAMES

    if text in POLICY_NAMES or text.endswith(".npz"):
        return text
    raise argparse.ArgumentTypeError(f"expected scripted, random, learned or a .npz policy file, got '{text}'")


def _add_env_config_options(parser: argparse.ArgumentParser) -> None:
    """--config and --set of the commands that build an environment from configs/default.yaml."""
    parser.add_argument("--config", metavar="FILE", help="YAML file merged over configs/default.yaml")
    parser.add_argument("--set", metavar="KEY=VALUE", action="append", default=[],
                        help="override a config key with a dotted path, e.g. --set swarm.num_slaves=3 (repeatable)")


def _experiment_list() -> list[str]:
    from experiments.registry import EXPERIMENTS

    return list(EXPERIMENTS)


def _experiment_names(text: str) -> list[str]:
    from experiments.registry import parse_only

    try:
        return parse_only(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="petswarm", description="Pet-Bot swarm environment: run, evaluate and measure.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    run = sub.add_parser(
        "run",
        help="run the swarm with a slave policy and print per-episode metrics",
        description="Run episodes of the swarm (master + slaves) with a slave policy; print a per-episode "
        "table and optionally write JSON, a GIF, or show a window.",
    )
    _add_env_config_options(run)
    run.add_argument("--policy", type=_policy_name, default="scripted", metavar="scripted|random|learned|PATH",
                     help="slave policy: the scripted leader-follower reference (default), random, the shipped learned model, "
                     "or a saved policy file (.npz)")
    run.add_argument("--episodes", type=_positive_int, default=1, metavar="N", help="number of episodes (default 1)")
    run.add_argument("--seed", type=_seed, metavar="S", help="seed of the first episode; episode i uses S+i (default: config seed)")
    run.add_argument("--json", metavar="OUT", help="write the results as JSON to OUT (atomically)")
    run.add_argument("--render", choices=["human"], help="show a window while running")
    run.add_argument("--video", metavar="OUT.gif", help="write the first episode as an animated GIF")
    run.add_argument("--quiet", action="store_true", help="print only the summary line")

    train = sub.add_parser(
        "train",
        help="train a slave policy with PPO (stable-baselines3 + SuperSuit)",
        description="Train one PPO policy shared by all slaves. Hyper-parameters and env overrides come from "
        "configs/train/ppo.yaml (or --config), copied into the run folder; checkpoints are atomic; "
        "--resume continues a run.",
    )
    train.add_argument("--config", metavar="FILE", help="training YAML merged over configs/train/ppo.yaml")
    train.add_argument("--set", metavar="KEY=VALUE", action="append", default=[],
                       help="override a training key (ppo.learning_rate=1e-4) or an env key (env.swarm.num_slaves=3)")
    train.add_argument("--timesteps", type=_positive_int, metavar="N", help="total agent-steps (overrides the config)")
    train.add_argument("--out", metavar="runs/NAME", default="runs/ppo", help="run folder (default runs/ppo)")
    train.add_argument("--resume", action="store_true", help="continue the run in --out from its latest checkpoint")
    train.add_argument("--no-progress", action="store_true", help="no progress bar")

    ev = sub.add_parser(
        "eval",
        help="evaluate a slave policy (or a mixed team) on named scenarios",
        description="Evaluate a slave policy on each scenario over the same seeds; JSON as `petswarm run` plus "
        "per-scenario summaries, error traces and trajectories (input of `petswarm report`).",
    )
    ev.add_argument("--policy", type=_policy_name, default="scripted", metavar="scripted|random|learned|PATH",
                    help="policy of every slave not named in --mix (learned = the model shipped in the package)")
    ev.add_argument("--mix", metavar="ROBOT=POLICY", action="append", default=[],
                    help="give one robot another policy, e.g. --mix robot_2=learned (repeatable)")
    ev.add_argument("--scenarios", metavar="a,b,...", help="comma-separated scenarios (default: the config's scenario)")
    ev.add_argument("--episodes", type=_positive_int, default=5, metavar="N", help="episodes (seeds) per scenario (default 5)")
    ev.add_argument("--seed", type=_seed, metavar="S", help="first seed (default: config seed)")
    _add_env_config_options(ev)
    ev.add_argument("--json", metavar="OUT", help="write the results as JSON (atomically)")
    ev.add_argument("--video-dir", metavar="DIR", help="write a GIF of the first episode of each scenario into DIR")

    bench = sub.add_parser(
        "bench",
        help="measure env speed (vs. the physics floor and MPE), a step's cost breakdown, memory and training throughput",
        description="Speed benchmark: petswarm env.step rate with 2, 5 and 9 slaves (scripted and random actions), the "
        "pymunk physics floor, MPE simple_spread (mpe2, the bench extra), a cProfile breakdown of one step, memory "
        "growth over a long run and PPO samples/s; prints a report and the issue's targets.",
    )
    bench.add_argument("--quick", action="store_true", help="short measurements (about a minute) instead of the full run")
    bench.add_argument("--json", metavar="OUT", help="write the results as JSON (atomically)")
    bench.add_argument("--md", metavar="docs/benchmarks.md", help="also write the markdown report, with its plot beside it (*_steps.png)")

    repro = sub.add_parser(
        "reproduce",
        help="run the papers' evaluations in the simulation and print paper vs sim",
        description="Run the papers' own experiments (seed 000 §4.3-4.5, seed 002 Tables 3-4) through the code the "
        "environment uses and print paper vs simulation with the tolerance of each figure. --check exits 1 when a row "
        "is outside its tolerance or an experiment is not available yet.",
    )
    repro.add_argument("--only", type=_experiment_names, metavar="NAME,...",
                       help="comma-separated experiments (default: all): " + ", ".join(_experiment_list()))
    repro.add_argument("--quick", action="store_true", help="fewer trials where an experiment is slow (for CI)")
    repro.add_argument("--json", metavar="OUT", help="write the rows (and the data behind the plots) as JSON, atomically")
    repro.add_argument("--report", metavar="OUT.html", help="write a self-contained HTML page with the papers' plots")
    repro.add_argument("--check", action="store_true", help="exit 1 unless every row is within its tolerance")
    repro.add_argument("--seed", type=_seed, metavar="S", help="seed of the experiments (default: config seed)")
    _add_env_config_options(repro)

    rep = sub.add_parser("report", help="compare evaluation results in one self-contained HTML page",
                         description="Compare the JSON results of `petswarm eval` (one per policy) in one HTML page.")
    rep.add_argument("results", nargs="+", metavar="RESULT.json")
    rep.add_argument("--out", default="report.html", metavar="report.html", help="output HTML file (default report.html)")
    return parser


def _print_table(result: dict) -> None:
    head = f"{'episode':>7} {'seed':>5} {'slaves':>6} {'rmse_m':>7} {'coll r-r':>8} {'r-user':>6} {'r-wall':>6} {'org_s':>6} {'retries':>7} {'tok_rec':>7} {'sent':>6} {'lost':>5} {'collid':>6}"
    print(head)
    for i, e in enumerate(result["episodes"]):
        c, f = e["collisions"], e["frames"]
        print(
            f"{i:>7} {e['seed']:>5} {e['slaves']:>6} {e['formation_rmse_m']:>7.3f} {c['robot_robot']:>8} {c['robot_user']:>6} "
            f"{c['robot_wall']:>6} {e['organize_time_s']:>6.2f} {e['join_retries']:>7} {e['token_recoveries']:>7} "
            f"{f['sent']:>6} {f['lost']:>5} {f['collided']:>6}"
        )
    s = result["summary"]
    print(
        f"summary: {s['episodes']} episodes, formation_rmse_m {s['formation_rmse_m']:.3f}, collisions {s['collisions']} "
        f"(robot-robot {s['robot_robot_collisions']}), organize_time_s {s['organize_time_s']:.2f}, join_retries {s['join_retries']}"
    )


def _cmd_run(args) -> int:
    from petswarm_env.files import write_json_atomic
    from evaluation.runner import run

    overrides = dict(parse_override(item) for item in args.set)
    cfg = load_config(args.config, overrides)
    if args.video and not args.video.lower().endswith(".gif"):
        raise ConfigError(f"--video must name a .gif file, got '{args.video}'")
    result = run(cfg, args.policy, args.episodes, args.seed, args.render, args.video)
    if args.quiet:
        s = result["summary"]
        print(f"formation_rmse_m {s['formation_rmse_m']:.3f} collisions {s['collisions']}")
    else:
        _print_table(result)
    if args.json:
        write_json_atomic(args.json, result)
        print(f"wrote {args.json}")
    if args.video:
        print(f"wrote {args.video}")
    return 0


def _cmd_train(args, argv: list[str]) -> int:
    from training.train import train_command

    return train_command(args.config, args.set, args.timesteps, args.out, args.resume, not args.no_progress,
                         "petswarm " + " ".join(argv))


def _cmd_eval(args) -> int:
    from petswarm_env.files import write_json_atomic
    from evaluation.evaluate import evaluate, format_table, parse_mix

    cfg = load_config(args.config, dict(parse_override(item) for item in args.set))
    scenarios = [s.strip() for s in args.scenarios.split(",") if s.strip()] if args.scenarios else None
    result = evaluate(cfg, args.policy, parse_mix(args.mix), scenarios, args.episodes, args.seed, args.video_dir)
    print(format_table(result))
    if args.json:
        import os

        base = os.path.dirname(os.path.abspath(args.json))
        for ep in result["episodes"]:  # GIF paths relative to the JSON file, as the report expects
            if "gif" in ep:
                ep["gif"] = os.path.relpath(os.path.abspath(ep["gif"]), base)
        write_json_atomic(args.json, result)
        print(f"wrote {args.json}")
    return 0


def _cmd_bench(args) -> int:
    from training.bench import default_plot_path, format_report, main_bench

    result = main_bench(args.quick, args.json, md_out=args.md)
    print(format_report(result))
    if args.json:
        print(f"wrote {args.json}")
    if args.md:
        print(f"wrote {args.md} and {default_plot_path(args.md)}")
    return 0


def _cmd_reproduce(args, argv: list[str]) -> int:
    from experiments.registry import EXPERIMENTS
    from experiments.reproduce import reproduce

    cfg = load_config(args.config, dict(parse_override(item) for item in args.set))
    seed = cfg.seed if args.seed is None else args.seed
    return reproduce(cfg, args.only or list(EXPERIMENTS), seed, args.quick, args.json, args.report, args.check,
                     "petswarm " + " ".join(argv))


def _cmd_report(args) -> int:
    from evaluation.report import write_report

    write_report(args.results, args.out)
    print(f"wrote {args.out}")
    return 0


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    args = build_parser().parse_args(argv)
    try:
        if args.command == "run":
            return _cmd_run(args)
        if args.command == "train":
            return _cmd_train(args, argv)
        if args.command == "eval":
            return _cmd_eval(args)
        if args.command == "report":
            return _cmd_report(args)
        if args.command == "bench":
            return _cmd_bench(args)
        if args.command == "reproduce":
            return _cmd_reproduce(args, argv)
    except (ConfigError, ValueError, RuntimeError, OSError) as exc:
        print(f"petswarm: error: {exc}", file=sys.stderr)
        return 2
    except ImportError as exc:
        print(f"petswarm: error: {exc.name or exc} is not installed; set up the training stack with: bash scripts/setup.sh train", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("petswarm: interrupted", file=sys.stderr)
        return 130
    return 1


if __name__ == "__main__":
    sys.exit(main())
