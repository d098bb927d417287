"""The ``petswarm`` command line: parses the arguments and runs the command's function in its room
(:mod:`petswarm.evaluation.commands`, :mod:`petswarm.training.train`, :mod:`petswarm.bench.run`, :mod:`petswarm.experiments.reproduce`).

    petswarm run    [--config FILE] [--set KEY=VALUE ...] [--policy scripted|random|learned|PATH]
                    [--episodes N] [--seed S] [--json OUT] [--render human] [--video OUT.gif] [--pcap OUT.pcapng]
    petswarm train  [--config configs/train/ppo.yaml] [--set KEY=VALUE ...] [--timesteps N] [--out runs/NAME] [--resume]
                    [--backend sb3|rllib] [--address HOST:PORT]
    petswarm eval   --policy scripted|random|learned|PATH [--mix ROBOT=POLICY ...] [--scenarios a,b] [--episodes N]
                    [--video-dir DIR] [--pcap-dir DIR] [--replay-dir DIR] ...
    petswarm eval   --grid configs/eval/grid.yaml [--policy PATH] [--episodes N] [--seed S] [--json OUT] [--resume]
    petswarm report RESULT.json ... --out report.html [--replays first|all|none|SCENARIO:SEED,...]
    petswarm bench  [--quick] [--json OUT] [--md docs/benchmarks.md]
    petswarm benchmark [--config configs/benchmark.yaml] [--set KEY=VALUE ...] [--json OUT] [--out runs/benchmark]
                    [--md docs/benchmark.md]
    petswarm reproduce [--only NAME,...] [--quick] [--json OUT] [--report OUT.html] [--check] [--seed S]

Every command takes ``--log-level debug|info|warning|error`` (before or after its name). Every
input is checked before the work starts (docs/inputs.md): a bad one is one line on stderr, exit 2.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import warnings

from petswarm import shipped, shipped_configs
from petswarm.cli.errors import OneLineParser, run_program
from petswarm_env.config import ConfigError, load_config, parse_override
from petswarm_env.files import check_distinct_paths, check_output_path, jsonl_path

SHIPPED_GRID = shipped_configs() / "eval" / "grid.yaml"  # configs/eval/grid.yaml, shipped in the package


class _Parser(OneLineParser):
    name = "petswarm"  # its subcommands' errors too


def _int_at_least(minimum: int, what: str, maximum: int | None = None):
    """An argparse type: an integer from ``minimum`` to ``maximum``, else "expected <what>, got ..."."""

    def parse(text: str) -> int:
        if len(text) > 30:
            raise argparse.ArgumentTypeError(f"expected {what}, got a number of {len(text)} characters")
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got '{text}'") from None
        if value < minimum or (maximum is not None and value > maximum):
            raise argparse.ArgumentTypeError(f"expected {what}, got {value}")
        return value

    return parse


# the ranges of the command line's numbers: a million episodes (a day of one core at 0.1 s each),
# a seed of numpy's 63 bits, a training budget of 10^12 agent-steps (training/config.py MAX_STEPS)
_positive_int = _int_at_least(1, "a positive integer up to 1000000", 1_000_000)
_seed = _int_at_least(0, "a non-negative integer seed below 2^63", 2**63 - 1 - 1_000_000)
_timesteps = _int_at_least(1, "a positive integer up to 10^12", 10**12)


def _config_file(text: str) -> str:
    """A --config or --grid file: the path as given when it exists, else the shipped config of that
    name (``configs/train/generalize.yaml``, ``train/generalize``, ``generalize``: see
    :func:`petswarm.shipped`), else the path as given (its loader names what is missing)."""
    from pathlib import Path

    if Path(text).exists():
        return text
    found = shipped(text)
    return str(found) if found is not None else text


def _policy_name(text: str) -> str:
    from petswarm.baselines.registry import POLICY_NAMES

    if text in POLICY_NAMES or text.endswith(".npz"):
        return text
    raise argparse.ArgumentTypeError(f"expected scripted, random, learned or a .npz policy file, got '{text}'")


def _eval_policy_name(text: str) -> str:
    """``petswarm eval``'s --policy: a slave policy, or the privileged teacher (ground truth: an
    evaluation ceiling, never a policy; training/teacher.py)."""
    from petswarm.training.teacher import TEACHER_NAME, is_teacher, teacher_gains_of

    if is_teacher(text):
        try:
            teacher_gains_of(text)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        return text
    try:
        return _policy_name(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"expected scripted, random, learned, {TEACHER_NAME}[:TRAIN_CONFIG] "
                                         f"or a .npz policy file, got '{text}'") from None


def _add_env_config_options(parser: argparse.ArgumentParser) -> None:
    """--config and --set of the commands that build an environment from configs/default.yaml."""
    parser.add_argument("--config", metavar="FILE", type=_config_file,
                        help="YAML file merged over configs/default.yaml (a shipped config also by name)")
    parser.add_argument("--set", metavar="KEY=VALUE", action="append", default=[],
                        help="override a config key with a dotted path, e.g. --set swarm.num_slaves=3 (repeatable)")


def _experiment_list() -> list[str]:
    from petswarm.experiments.registry import EXPERIMENTS

    return list(EXPERIMENTS)


def _scenario_list(text: str) -> str:
    """``--scenarios``: comma-separated names, at least one (the names are checked against the
    scenarios when the config is known)."""
    if not [name for name in text.split(",") if name.strip()]:
        raise argparse.ArgumentTypeError(f"names no scenario ({text!r}); give comma-separated names such as zigzag,u_turn")
    names = [name.strip() for name in text.split(",") if name.strip()]
    twice = sorted({name for name in names if names.count(name) > 1})
    if twice:
        raise argparse.ArgumentTypeError(f"names {', '.join(twice[:3])} more than once; give each scenario once "
                                         "(--episodes sets how many episodes each runs)")
    return text


def _experiment_names(text: str) -> list[str]:
    from petswarm.experiments.registry import parse_only

    try:
        return parse_only(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _add_run(sub) -> None:
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
    run.add_argument("--pcap", metavar="OUT.pcapng",
                     help="write every radio frame of the first episode (reset included) for Wireshark (docs/pcap.md)")
    run.add_argument("--quiet", action="store_true", help="print only the summary line")


def _add_train(sub) -> None:
    train = sub.add_parser(
        "train",
        help="train a slave policy with PPO (stable-baselines3 + SuperSuit, or Ray RLlib)",
        description="Train one PPO policy shared by all slaves. Hyper-parameters and env overrides come from "
        "configs/train/ppo.yaml (or --config), copied into the run folder; checkpoints are atomic; "
        "--resume continues a run.",
    )
    train.add_argument("--config", metavar="FILE", type=_config_file,
                       help="training YAML merged over configs/train/ppo.yaml (a shipped one also by name: generalize, teacher, ...)")
    train.add_argument("--set", metavar="KEY=VALUE", action="append", default=[],
                       help="override a training key (ppo.learning_rate=1e-4) or an env key (env.swarm.num_slaves=3)")
    train.add_argument("--timesteps", type=_timesteps, metavar="N", help="total agent-steps (overrides the config)")
    train.add_argument("--out", metavar="runs/NAME", default="runs/ppo", help="run folder (default runs/ppo)")
    train.add_argument("--resume", action="store_true", help="continue the run in --out from its latest checkpoint")
    train.add_argument("--no-progress", action="store_true", help="no progress bar")
    train.add_argument("--backend", choices=["sb3", "rllib"], default="sb3",
                       help="sb3: Stable-Baselines3 + SuperSuit (default); rllib: Ray RLlib's PPO (the rllib extra), see docs/training.md")
    train.add_argument("--vec-env", choices=["petswarm", "supersuit"], default="petswarm",
                       help="sb3's vector env: petswarm = the batched vector env in this process (default; a run with randomize "
                            "pools or residual_of uses supersuit), supersuit = SuperSuit over num_cpus worker processes")
    train.add_argument("--address", metavar="HOST:PORT",
                       help="with --backend rllib: join the Ray cluster whose head is at HOST:PORT (default: a local Ray on 127.0.0.1)")


def _add_eval(sub) -> None:
    ev = sub.add_parser(
        "eval",
        help="evaluate a slave policy (or a mixed team) on named scenarios",
        description="Evaluate a slave policy on each scenario over the same seeds; JSON as `petswarm run` plus "
        "per-scenario summaries, error traces and trajectories (input of `petswarm report`).",
    )
    ev.add_argument("--policy", type=_eval_policy_name, default=None, metavar="scripted|random|learned|PATH",
                    help="policy of every slave not named in --mix (default scripted; learned = the model shipped in the package); "
                    "with --grid: the grid's candidate (default: the grid file's). privileged-teacher drives from ground "
                    "truth: a ceiling to compare with, not a policy (docs/training.md); privileged-teacher:TRAIN_CONFIG "
                    "is the teacher that labels that training config's samples (e.g. :recurrent_command_teacher)")
    ev.add_argument("--mix", metavar="ROBOT=POLICY", action="append", default=[],
                    help="give one robot another policy, e.g. --mix robot_2=learned (repeatable)")
    ev.add_argument("--scenarios", metavar="a,b,...", type=_scenario_list, help="comma-separated scenarios (default: the config's scenario)")
    ev.add_argument("--episodes", type=_positive_int, default=None, metavar="N",
                    help="episodes (seeds) per scenario (default 5); with --grid per cell (default: the grid file's)")
    ev.add_argument("--seed", type=_seed, metavar="S", help="first seed (default: config seed; with --grid the grid file's)")
    ev.add_argument("--grid", metavar="FILE", nargs="?", const=str(SHIPPED_GRID), type=_config_file,
                    help="run the comparison grid of FILE (without FILE: the committed configs/eval/grid.yaml, shipped in the "
                    "package): each cell's candidate vs the reference, "
                    "ratios and collisions; JSON input of `petswarm report` (its heatmap)")
    ev.add_argument("--resume", action="store_true", help="with --grid: keep the finished cells of the --json file, run the rest")
    _add_env_config_options(ev)
    ev.add_argument("--json", metavar="OUT", help="write the results as JSON (atomically)")
    ev.add_argument("--video-dir", metavar="DIR", help="write a GIF of the first episode of each scenario into DIR")
    ev.add_argument("--pcap-dir", metavar="DIR", help="write every episode's radio frames as pcapng into DIR (docs/pcap.md)")
    ev.add_argument("--replay-dir", metavar="DIR",
                    help="write every episode's replay into DIR (LABEL_SCENARIO_seedS.replay.json; `petswarm report` embeds them)")


def _add_bench(sub) -> None:
    bench = sub.add_parser(
        "bench",
        help="measure env speed (vs. the physics floor and MPE), a step's cost breakdown, memory and training throughput",
        description="Speed benchmark: petswarm env.step rate with 2, 5 and 9 slaves (scripted and random actions), the "
        "pymunk physics floor, MPE simple_spread (mpe2, the bench extra), a cProfile breakdown of one step, memory "
        "growth over a long run and PPO samples/s; prints a report and its targets (≥ 2× MPE's steps/s, 9 slaves ≤ 2× "
        "the cost of 5, no memory growth).",
    )
    bench.add_argument("--quick", action="store_true", help="short measurements (about a minute) instead of the full run")
    bench.add_argument("--json", metavar="OUT", help="write the results as JSON (atomically)")
    bench.add_argument("--md", metavar="docs/benchmarks.md", help="also write the markdown report, with its plot beside it (*_steps.png)")


def _add_benchmark(sub) -> None:
    bm = sub.add_parser(
        "benchmark",
        help="train each algorithm on named tasks from several seeds, evaluate on held-out seeds, report IQMs with CIs",
        description="The benchmark of slave policies (training/benchmark.py, docs/benchmark.md): each trained algorithm "
        "(IPPO, MAPPO) is trained on each task of the file from each training seed, then every policy (and the scripted "
        "reference and the privileged teacher) drives every slave on the same held-out seeds. Per task: the interquartile "
        "mean of the score with a 95 % bootstrap CI, the probability of improvement over scripted, wall time and "
        "agent-steps. Resumable: the runs already in --json with the same settings are kept.",
    )
    bm.add_argument("--config", type=_config_file, default=str(shipped_configs() / "benchmark.yaml"),
                    metavar="configs/benchmark.yaml", help="tasks, algorithms and budgets (default: the shipped one)")
    bm.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="override a top-level key of the file, e.g. --set episodes=3 --set training_seeds=[0] (repeatable)")
    bm.add_argument("--json", default="benchmark.json", metavar="OUT",
                    help="the runs and the summary (default benchmark.json); an existing one is resumed")
    bm.add_argument("--out", default="runs/benchmark", metavar="DIR", help="the training runs' folders (default runs/benchmark)")
    bm.add_argument("--md", metavar="docs/benchmark.md", help="also write the markdown page, with its plot beside it (*.png)")


def _add_reproduce(sub) -> None:
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


def _add_report(sub) -> None:
    rep = sub.add_parser("report", help="compare evaluation results in one self-contained HTML page",
                         description="Compare the JSON results of `petswarm eval` (one per policy) in one HTML page; a result of "
                         "`petswarm eval --grid` adds the comparison grid's heatmap of ratios and collisions.")
    rep.add_argument("results", nargs="+", metavar="RESULT.json")
    rep.add_argument("--out", default="report.html", metavar="report.html", help="output HTML file (default report.html)")
    rep.add_argument("--replays", default="first", metavar="first|all|none|SCENARIO:SEED,...",
                     help="episode replays to embed (recorded by eval --replay-dir): the first seed of each scenario "
                     "(default), all, none, or the named ones; the results' episodes of one scenario and seed play side by side")


LOG_LEVELS = ("debug", "info", "warning", "error")


def _add_log_level(parser: argparse.ArgumentParser, default) -> None:
    parser.add_argument("--log-level", choices=LOG_LEVELS, default=default,
                        help="messages on stderr from this level up (default info: warnings, and a training run's progress "
                        "lines when its output is not a terminal)")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="petswarm", description="Pet-Bot swarm environment: run, evaluate and measure.")
    _add_log_level(parser, "info")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for add in (_add_run, _add_train, _add_eval, _add_bench, _add_benchmark, _add_reproduce, _add_report):
        add(sub)
    for choice in sub.choices.values():  # before or after the command: petswarm --log-level debug run / petswarm run --log-level debug
        _add_log_level(choice, argparse.SUPPRESS)
    return parser


class _OneLine(logging.Formatter):
    """``petswarm: warning: <the message on one line>`` (the level in lower case, as the errors)."""

    def format(self, record: logging.LogRecord) -> str:
        return f"petswarm: {record.levelname.lower()}: {' '.join(record.getMessage().split())}"


def configure_logging(level: str) -> None:
    """The ``petswarm`` loggers (stdlib :mod:`logging`) write one line per message to stderr from
    ``level`` up; Python warnings go through them (logger ``petswarm.warnings``)."""
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(_OneLine())
    root = logging.getLogger("petswarm")
    root.handlers[:] = [handler]
    root.setLevel(level.upper())
    root.propagate = False


def _env_config(args):
    return load_config(args.config, dict(parse_override(item) for item in args.set))


def _check_video_budget(cfg, flag: str) -> None:
    """A GIF holds its frames in memory until it is written (petswarm_env/render.py: one byte a pixel
    after quantizing, a frame every ``VIDEO_EVERY`` steps): refuse before the episode one that would
    need more than the config's memory budget."""
    from petswarm.evaluation.runner import VIDEO_EVERY
    from petswarm_env.config import MEMORY_BUDGET_BYTES

    w, h = cfg.render.size_px
    need = -(-cfg.max_cycles // VIDEO_EVERY) * w * h
    if need > MEMORY_BUDGET_BYTES:
        raise ConfigError(f"{flag}: a GIF of max_cycles={cfg.max_cycles} steps at render.size_px={list(cfg.render.size_px)} needs "
                          f"{need / 1e9:.1f} GB of frames, more than the {MEMORY_BUDGET_BYTES / 1e9:g} GB budget; lower "
                          "max_cycles or render.size_px")


def _run(args, argv: list[str]) -> int:
    from petswarm.evaluation.commands import run_command

    cfg = _env_config(args)
    if args.video:
        _check_video_budget(cfg, "--video")
    return run_command(cfg, args.policy, args.episodes, args.seed, args.render, args.video, args.json, args.quiet,
                       args.pcap)


def _train(args, argv: list[str]) -> int:
    from petswarm.training.train import train_command

    run, options = None, {}
    if args.backend == "rllib":
        from petswarm.training.rllib_backend import train_rllib

        run, options = train_rllib, {"address": args.address}
        if args.vec_env != "petswarm":
            raise ConfigError("--vec-env chooses the SB3 back end's vector env: drop it with --backend rllib")
    elif args.address:
        raise ConfigError("--address joins a Ray cluster: it needs --backend rllib")
    else:
        options = {"vec_env": args.vec_env}
    return train_command(args.config, args.set, args.timesteps, args.out, args.resume, not args.no_progress,
                         "petswarm " + " ".join(argv), run, **options)


def _eval(args, argv: list[str]) -> int:
    from petswarm.evaluation.commands import eval_command, grid_command

    if args.grid:
        extra = [flag for flag, on in (("--mix", args.mix), ("--scenarios", args.scenarios), ("--video-dir", args.video_dir),
                                       ("--pcap-dir", args.pcap_dir), ("--replay-dir", args.replay_dir)) if on]
        if extra:
            raise ConfigError(f"--grid runs the cells of its file: drop {', '.join(extra)} (a cell's team and scenario are in the grid file)")
        return grid_command(_env_config(args), args.grid, args.policy, args.episodes, args.seed, args.json, args.resume)
    if args.resume:
        raise ConfigError("--resume belongs to --grid; give --grid FILE or drop --resume")
    cfg = _env_config(args)
    if args.video_dir:
        _check_video_budget(cfg, "--video-dir")
    return eval_command(cfg, args.policy or "scripted", args.mix, args.scenarios, args.episodes or 5, args.seed,
                        args.json, args.video_dir, args.pcap_dir, args.replay_dir)


def _report(args, argv: list[str]) -> int:
    from petswarm.evaluation.commands import report_command

    return report_command(args.results, args.out, args.replays)


def _bench(args, argv: list[str]) -> int:
    from petswarm.bench.run import bench_command

    check_output_path(args.json, "--json")
    check_output_path(args.md, "--md")
    return bench_command(args.quick, args.json, args.md)


def _benchmark(args, argv: list[str]) -> int:
    from petswarm.training.benchmark import benchmark_command

    return benchmark_command(args.config, args.set, args.json, args.out, args.md, "petswarm " + " ".join(argv))


def _reproduce(args, argv: list[str]) -> int:
    from petswarm.experiments.registry import EXPERIMENTS
    from petswarm.experiments.reproduce import reproduce

    cfg = _env_config(args)
    check_output_path(args.json, "--json")
    check_output_path(args.report, "--report")
    seed = cfg.seed if args.seed is None else args.seed
    return reproduce(cfg, args.only or list(EXPERIMENTS), seed, args.quick, args.json, args.report, args.check,
                     "petswarm " + " ".join(argv))


def _policy_file(word: str | None) -> str | None:
    return word if word and word.endswith(".npz") else None


def _check_paths(args) -> None:
    """Before any work: no output of the command is one of its inputs or another of its outputs
    (``run --config c.yaml --json c.yaml`` would destroy the config; ``--json x.gif --video x.gif``
    one output with the other). The JSON Lines file beside ``--json`` counts as an output."""
    get = lambda name: getattr(args, name, None)  # noqa: E731
    inputs = {"--config": get("config"), "--policy": _policy_file(get("policy"))}
    if args.command == "eval":
        inputs["--mix"] = [_policy_file(m.split("=", 1)[-1]) for m in args.mix]
        if args.grid:
            inputs["--grid"] = args.grid
    if args.command == "report":
        inputs["RESULT.json"] = list(args.results)
        seen: dict[str, str] = {}
        for path in args.results:  # one result twice would be compared with itself under two labels
            key = os.path.realpath(path)
            if key in seen:
                raise ValueError(f"RESULT.json '{path}' is given twice (also as '{seen[key]}'); give each result once")
            seen[key] = path
    outputs = {"--out": get("out") if args.command == "report" else None, "--json": get("json"), "--video": get("video"),
               "--pcap": get("pcap"), "--md": get("md"), "--report": get("report")}
    if get("json") and args.command in ("run", "eval") and not getattr(args, "grid", None):
        lines = outputs["--json's lines file"] = str(jsonl_path(args.json))
        try:
            check_output_path(lines, "--json's lines file")
        except ValueError as exc:
            raise ValueError(f"--json '{args.json}' writes each finished episode to '{lines}', which cannot be written "
                             f"({str(exc).split(': ', 1)[-1] if 'cannot be written' in str(exc) else 'it is not a file'}); "
                             "remove it or name another --json") from None
    check_distinct_paths(inputs, outputs)


# each command runs a function of its room (imported when the command runs: `petswarm run` needs no training stack)
COMMANDS = {"run": _run, "train": _train, "eval": _eval, "report": _report, "bench": _bench, "benchmark": _benchmark,
            "reproduce": _reproduce}


def _warn_in_one_line(message, category, filename, lineno, file=None, line=None) -> None:
    logging.getLogger("petswarm.warnings").warning(str(message))


# RLlib orders a step's agents through sets of agent ids, so with Python's per-process string hash
# (PYTHONHASHSEED unset) two runs of one seed sample and update in different orders and diverge
# (docs/training.md, "Deterministic runs"); a fixed hash makes them bit-identical.
RLLIB_HASH_SEED = "0"


def _restart_with_fixed_hash(args) -> None:
    """``petswarm train --backend rllib`` run as a program without PYTHONHASHSEED: this process is
    replaced by the same command with PYTHONHASHSEED=0 (its Ray workers inherit it)."""
    if args.command == "train" and args.backend == "rllib" and "PYTHONHASHSEED" not in os.environ:
        os.execve(sys.executable, sys.orig_argv, {**os.environ, "PYTHONHASHSEED": RLLIB_HASH_SEED})


def main(argv: list[str] | None = None) -> int:
    """Parse, dispatch, and turn every error a user can cause into one line on stderr with exit
    status 2; Ctrl-C exits 130, SIGTERM/SIGHUP 128 + the signal (after every temporary file is
    removed: :func:`petswarm_env.files.exit_cleanly_on_signals`). Run as a program (``argv`` from
    the command line), an RLlib training restarts itself with a fixed string hash first."""
    own_command_line = argv is None
    argv = sys.argv[1:] if argv is None else argv
    args = build_parser().parse_args(argv)
    if own_command_line:
        _restart_with_fixed_hash(args)
    configure_logging(args.log_level)

    def command() -> int:
        try:
            with warnings.catch_warnings():
                warnings.showwarning = _warn_in_one_line
                _check_paths(args)
                return COMMANDS[args.command](args, argv)
        except ImportError as exc:
            print(f"petswarm: error: {exc.name or exc} is not installed; set up the training stack with: "
                  "bash scripts/setup.sh train", file=sys.stderr)
            return 2

    return run_program("petswarm", command)


if __name__ == "__main__":
    sys.exit(main())
