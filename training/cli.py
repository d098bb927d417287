"""The ``petswarm`` command line.

    petswarm run [--config FILE] [--set KEY=VALUE ...] [--policy scripted|random]
                 [--episodes N] [--seed S] [--json OUT] [--render human] [--video OUT.gif]
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


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="petswarm", description="Pet-Bot swarm environment: run, evaluate and measure.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    run = sub.add_parser(
        "run",
        help="run the swarm with a slave policy and print per-episode metrics",
        description="Run episodes of the swarm (master + slaves) with a slave policy; print a per-episode "
        "table and optionally write JSON, a GIF, or show a window.",
    )
    run.add_argument("--config", metavar="FILE", help="YAML file merged over configs/default.yaml")
    run.add_argument(
        "--set",
        metavar="KEY=VALUE",
        action="append",
        default=[],
        help="override a config key with a dotted path, e.g. --set swarm.num_slaves=3 (repeatable)",
    )
    run.add_argument("--policy", choices=["scripted", "random"], default="scripted", help="slave policy (default: scripted leader-follower)")
    run.add_argument("--episodes", type=_positive_int, default=1, metavar="N", help="number of episodes (default 1)")
    run.add_argument("--seed", type=_seed, metavar="S", help="seed of the first episode; episode i uses S+i (default: config seed)")
    run.add_argument("--json", metavar="OUT", help="write the results as JSON to OUT (atomically)")
    run.add_argument("--render", choices=["human"], help="show a window while running")
    run.add_argument("--video", metavar="OUT.gif", help="write the first episode as an animated GIF")
    run.add_argument("--quiet", action="store_true", help="print only the summary line")
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
    from training.runner import run, write_json_atomic

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


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        if args.command == "run":
            return _cmd_run(args)
    except (ConfigError, ValueError, RuntimeError, OSError) as exc:
        print(f"petswarm: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("petswarm: interrupted", file=sys.stderr)
        return 130
    return 1


if __name__ == "__main__":
    sys.exit(main())
