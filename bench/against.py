"""This checkout against another one (an older commit), side by side in one run.

    python -m petswarm.bench.against --other-python OTHER/.venv/bin/python --other-root OTHER [--json out.json]

One long-lived child process per checkout (its own Python, its own code), fed bursts in turn, so
that a change of the shared machine's speed during the run falls on both:

- **steps**: rounds of one burst of ``--burst-s`` step time per system, the order rotating from round
  to round: each checkout's ``parallel_env`` 1+5 with the scripted policy and with random actions
  (its own ``bench.loops.EnvLoop``: only ``env.step`` timed, the policy and the resets apart, as its
  ``petswarm bench`` times it), and this checkout's ``vector_env(64)`` 1+5 with random actions
  (``bench.vector.VectorEnv``, auto-resets inside the timed step). Rates per CPU-second of the child
  (``time.process_time`` over the timed calls) and per wall second.
- **training**: rounds of fresh SB3 PPO runs, each through its checkout's own ``bench_training``
  (its configs/train/ppo.yaml, one torch thread, ``model.learn`` timed, ``--samples`` samples,
  ``--rollout`` per rollout: the other's bench defaults): the other's SuperSuit one copy in process
  (``num_envs 1``), this checkout's SuperSuit one copy and its vector env (the default path of
  ``petswarm train``) at each of ``--train-envs`` copies.

Ratios: the total over all rounds (summed steps over summed seconds, one over the other) and the
per-round spread (min-max of the ratio of the two bursts of the same round).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent.parent  # this checkout's root
SLAVES, SEED, VECTOR_ENVS = 5, 0, 64


# -- the child: runs in either checkout's Python, imports only that checkout's code ----------------
def _child(root: str) -> None:
    sys.path[0] = root  # (was this file's folder: its modules would shadow the standard library's)
    pkg = "petswarm.bench" if (Path(root) / "petswarm" / "__init__.py").is_file() else "bench"
    loops = __import__(f"{pkg}.loops", fromlist=["EnvLoop"])
    systems: dict[str, Any] = {}
    for line in sys.stdin:
        cmd = json.loads(line)
        if cmd["op"] == "setup":
            name = cmd["system"]
            if name.startswith("vector"):
                systems[name] = __import__(f"{pkg}.vector", fromlist=["VectorEnv"]).VectorEnv(VECTOR_ENVS, SLAVES, SEED)
                systems[name].burst(0.2)
            else:
                systems[name] = loop = loops.EnvLoop(SLAVES, name.split("_")[1], SEED)
                # actions only for the agents still in the episode (an older EnvLoop gave one to an agent that
                # had just left, which env.step rejects); outside the timed call
                chosen = loop._actions
                loop._actions = lambda loop=loop, chosen=chosen: {a: x for a, x in chosen().items() if a in loop.env.agents}
                loop.run(steps=50)
            reply: dict[str, Any] = {"ok": name}
        elif cmd["op"] == "burst":
            reply = _burst(systems[cmd["system"]], cmd["seconds"])
        elif cmd["op"] == "train":
            reply = _train(pkg, cmd)
        else:
            return
        print(json.dumps(reply), flush=True)


def _burst(sys_: Any, seconds: float) -> dict[str, float]:
    if hasattr(sys_, "burst"):  # bench.vector's systems
        steps, wall, cpu = sys_.burst(seconds)
        return {"steps": steps, "wall": wall, "cpu": cpu}
    s0, w0, c0 = sys_.steps, sys_.step_s, sys_.step_cpu_s
    sys_.run(seconds=w0 + seconds, min_steps=s0 + 1)
    return {"steps": sys_.steps - s0, "wall": sys_.step_s - w0, "cpu": sys_.step_cpu_s - c0}


def _train(pkg: str, cmd: dict) -> dict[str, Any]:
    from dataclasses import replace

    settings = __import__(f"{pkg}.settings", fromlist=["FULL"])
    throughput = __import__(f"{pkg}.throughput", fromlist=["bench_training"])
    s = replace(settings.FULL, training_samples=cmd["samples"], training_rollout=cmd["rollout"],
                training_workers=(1,) if cmd["path"] == "supersuit" else ())
    if hasattr(s, "training_vector_envs"):
        s = replace(s, training_vector_envs=() if cmd["path"] == "supersuit" else (cmd["num_envs"],))
    out = throughput.bench_training(s)
    if "skipped" in out:
        return {"error": out["skipped"]}
    return {"steps": out["runs"][0]["samples"], "wall": out["runs"][0]["wall_s"]}


# -- the parent -----------------------------------------------------------------------------------
class Child:
    """One checkout's child process; ``ask`` sends one command and returns its reply."""

    def __init__(self, python: str, root: Path):
        env = {**os.environ, "PYTHONHASHSEED": "0"}
        self.proc = subprocess.Popen([python, str(Path(__file__).resolve()), "--child", str(root)], cwd=root, env=env,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)

    def ask(self, **cmd: Any) -> dict:
        self.proc.stdin.write(json.dumps(cmd) + "\n")
        self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        if not line:
            raise SystemExit(f"bench.against: the child for {cmd} ended without a reply (its error is above)")
        reply = json.loads(line)
        if "error" in reply:
            raise SystemExit(f"bench.against: {reply['error']}")
        return reply

    def close(self) -> None:
        self.proc.stdin.close()
        self.proc.wait(timeout=30)


def ratio(a: list[dict], b: list[dict], per: str = "cpu") -> dict[str, float]:
    """a over b from bursts ``{"steps", "wall", "cpu"}`` paired by round: the total (summed steps over
    summed ``per`` seconds, a's rate over b's) and the min and max of the per-round ratios."""
    if not a or len(a) != len(b):
        raise ValueError(f"ratio needs two equal, non-empty lists of bursts, got {len(a)} and {len(b)}")
    rate = lambda bs: sum(x["steps"] for x in bs) / sum(x[per] for x in bs)  # noqa: E731
    rounds = [rate([x]) / rate([y]) for x, y in zip(a, b)]
    return {"total": rate(a) / rate(b), "min": min(rounds), "max": max(rounds)}


def parse(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="python -m petswarm.bench.against", description=__doc__.splitlines()[0])
    ap.add_argument("--other-python", required=True, help="the other checkout's Python (its venv's bin/python)")
    ap.add_argument("--other-root", required=True, help="the other checkout's root folder")
    ap.add_argument("--rounds", type=int, default=6, help="rounds of step bursts")
    ap.add_argument("--burst-s", type=float, default=0.5, help="timed step seconds per burst")
    ap.add_argument("--train-rounds", type=int, default=2, help="rounds of PPO runs (0: none)")
    ap.add_argument("--train-envs", type=int, nargs="*", default=[4, 16], help="this checkout's vector env sizes")
    ap.add_argument("--samples", type=int, default=8192, help="PPO samples per run")
    ap.add_argument("--rollout", type=int, default=1024, help="PPO samples per rollout")
    ap.add_argument("--json", help="write the result here")
    args = ap.parse_args(argv)
    root = Path(args.other_root)
    if not (root / "petswarm_env" / "__init__.py").is_file():
        ap.error(f"--other-root {root} holds no petswarm_env package; give the root of a petswarm checkout")
    if not (os.path.isfile(args.other_python) and os.access(args.other_python, os.X_OK)):
        ap.error(f"--other-python {args.other_python} is not an executable file; give the other checkout's venv bin/python")
    if args.rounds < 1 or args.burst_s <= 0 or args.train_rounds < 0 or args.samples < 1 or args.rollout < 1:
        ap.error("--rounds, --samples and --rollout must be >= 1, --burst-s > 0 and --train-rounds >= 0")
    return args


def _steps(children: dict[str, Child], args: argparse.Namespace) -> dict[str, list[dict]]:
    systems = [("other", "single_scripted"), ("other", "single_random"), ("this", "single_scripted"),
               ("this", "single_random"), ("this", "vector64_random")]
    for who, name in systems:
        children[who].ask(op="setup", system=name)
    bursts: dict[str, list[dict]] = {f"{who} {name}": [] for who, name in systems}
    for k in range(args.rounds):
        for who, name in systems[k % len(systems):] + systems[:k % len(systems)]:
            bursts[f"{who} {name}"].append(children[who].ask(op="burst", system=name, seconds=args.burst_s))
        print(f"[against] step round {k + 1}/{args.rounds}", file=sys.stderr, flush=True)
    return bursts


def _training(children: dict[str, Child], args: argparse.Namespace) -> dict[str, list[dict]]:
    runs = [("other", "supersuit", 1), ("this", "supersuit", 1)] + [("this", "petswarm", k) for k in args.train_envs]
    out: dict[str, list[dict]] = {f"{who} {path} {k}": [] for who, path, k in runs}
    for r in range(args.train_rounds):
        for who, path, k in runs[r % len(runs):] + runs[:r % len(runs)]:
            out[f"{who} {path} {k}"].append(children[who].ask(op="train", path=path, num_envs=k, samples=args.samples,
                                                             rollout=args.rollout))
        print(f"[against] training round {r + 1}/{args.train_rounds}", file=sys.stderr, flush=True)
    return out


def main(argv: list[str] | None = None) -> dict:
    args = parse(argv)
    children = {"other": Child(args.other_python, Path(args.other_root).resolve()), "this": Child(sys.executable, HERE)}
    try:
        bursts = _steps(children, args)
        training = _training(children, args) if args.train_rounds else {}
    finally:
        for c in children.values():
            c.close()
    rate = lambda bs, per: sum(x["steps"] for x in bs) / sum(x[per] for x in bs)  # noqa: E731
    commits = {"other": _commit(args.other_root), "this": _commit(HERE)}
    out: dict[str, Any] = {"args": vars(args), "commits": commits,
                           "bursts": bursts, "training": training, "rates": {}, "ratios": {}}
    for name, bs in bursts.items():
        out["rates"][name] = {"steps_per_s": rate(bs, "wall"), "steps_per_cpu_s": rate(bs, "cpu")}
        print(f"{name:28s} {rate(bs, 'wall'):10,.0f} env-steps/s  {rate(bs, 'cpu'):10,.0f} per CPU-s")
    pairs = [("this single_scripted", "other single_scripted"), ("this single_random", "other single_random"),
             ("this vector64_random", "other single_scripted"), ("this vector64_random", "other single_random"),
             ("this vector64_random", "this single_random")]
    for a, b in pairs:
        r = out["ratios"][f"{a} / {b} (CPU)"] = ratio(bursts[a], bursts[b], "cpu")
        print(f"{a} / {b}, per CPU-s: {r['total']:.2f}x (per round {r['min']:.2f}-{r['max']:.2f}x)")
    base = training.get("other supersuit 1")
    for name, runs in training.items():
        out["rates"][name] = {"samples_per_s": rate(runs, "wall")}
        line = f"{name:28s} {rate(runs, 'wall'):10,.0f} samples/s"
        if base and name != "other supersuit 1":
            r = out["ratios"][f"{name} / other supersuit 1 (wall)"] = ratio(runs, base, "wall")
            line += f"  {r['total']:.2f}x the other's SuperSuit one copy (per round {r['min']:.2f}-{r['max']:.2f}x)"
        print(line)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1) + "\n")
    return out


def _commit(root: str | Path) -> str:
    res = subprocess.run(["git", "-C", str(root), "rev-parse", "--short=10", "HEAD"], capture_output=True, text=True)
    return res.stdout.strip() or "unknown"


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--child":
        _child(sys.argv[2])
    else:
        main()
